"""The stability envelope as small multiples: one panel per question, step time × slope.

Per friction and robot, one row of panels:

- **Is there a gait with the ZMP inside?** Each cell is coloured by the largest minimum
  ZMP margin the GA found for the first family [mm] (diverging: blue inside the polygon,
  red outside, clipped at ±10 mm); outlines, each a staircase along the cell borders:
  every family's feasibility boundary (margin = 0; solid black for the paper's family,
  dashed for the others) and the required-margin contour of the first family (dotted).
- **Does MuJoCo walk that gait?** One small panel per actuator mode: the cells where the
  first family's max-margin gait walks (strict walk verdict ``walked``; balance ``stable`` in a
  table written before it) filled in the mode's colour,
  those where it does not in light grey, cells not played white; the first family's
  feasibility outline on top (black), so a walk outside the analytic boundary shows at a
  glance, and every other family's walked cells as a dashed outline in the mode's colour.

Every panel marks the paper's own statements where the grid holds their cell: circles
for its hand-picked (nominal) gait (flat ground stable at 0.5 s, outside at 0.4 s; inside
at 15° at 1 s), stars for its GA (a gait inside at 22.5°, none at 30°, at 1 s); filled
where the paper says inside, open where it says outside. Names go in one legend below
the panels, never on a line.

Cells sit at equal spacing with their real values as tick labels (the axis labels say
so): the grid is denser near 15–30° and at fast steps. Degrees and millimetres only here.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.artist import Artist  # noqa: E402
from matplotlib.colors import ListedColormap, TwoSlopeNorm  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402

from slopewalk.bench.files import atomic_path  # noqa: E402
from slopewalk.bench.sim.model import ACTUATOR_MODES  # noqa: E402
from slopewalk.bench.tables.envelope import is_failure, walks  # noqa: E402
from slopewalk.bench.tables.table import read_table  # noqa: E402

CLIP_MM = 10.0
_MODE_COLOURS = ("#0072B2", "#E69F00", "#009E73", "#CC79A7", "#56B4E9", "#D55E00")  # Okabe-Ito
# The paper's statements: (step time [s], slope [deg], inside?, whose gait, what it says)
PAPER_POINTS = (
    (0.5, 0.0, True, "nominal", "nominal gait stable at 0.5 s"),
    (0.4, 0.0, False, "nominal", "nominal gait outside at 0.4 s"),
    (1.0, 15.0, True, "nominal", "nominal gait inside at 15°"),
    (1.0, 22.5, True, "GA", "GA gait inside at 22.5°"),
    (1.0, 30.0, False, "GA", "no GA gait at 30° (nominal foot)"),
)
_PAPER_MARKERS = {"nominal": "o", "GA": "*"}
SPACING_NOTE = "cells evenly spaced, values not"


def grids(rows: list[dict], family: str) -> tuple[list, list, dict]:
    """(step times descending, slopes ascending, {name: (T, S) array}) of one family's cells.

    Arrays: ``margin`` [mm] of the max-margin gait, ``feasible`` and ``found`` (1/0),
    and ``walks_<mode>`` (1 where the max-margin gait walks in that mode, 0 where it
    does not, NaN where it was not played).
    """
    rows = [r for r in rows if r["family"] == family]
    times = sorted({r["step_time"] for r in rows}, reverse=True)
    slopes = sorted({r["slope_deg"] for r in rows})
    shape = (len(times), len(slopes))
    out = {k: np.full(shape, np.nan) for k in ("margin", "feasible", "found")}
    modes = [m for m in ACTUATOR_MODES if any(r.get(f"maxmargin_{m}_verdict") for r in rows)]
    out |= {f"walks_{m}": np.full(shape, np.nan) for m in modes}
    for r in rows:
        i, j = times.index(r["step_time"]), slopes.index(r["slope_deg"])
        if is_failure(r["error"]):
            continue
        margin = r["maxmargin_margin_mm"]
        out["margin"][i, j] = margin if isinstance(margin, float) else np.nan
        out["feasible"][i, j] = r["feasible"] == "True"
        out["found"][i, j] = r["minwork_found"] == "True"
        for m in modes:
            walked = walks(r, "maxmargin", m)  # the strict walk verdict (balance in old tables)
            if walked is not None:
                out[f"walks_{m}"][i, j] = walked
    return times, slopes, out


def envelope_figure(rows: list[dict]):
    """The figure (module doc) of an envelope table's rows."""
    panels = sorted({(r["friction"], r["robot"]) for r in rows})
    families = sorted({r["family"] for r in rows}, key=lambda f: (f != "paper", f))
    modes = [m for m in ACTUATOR_MODES if any(r.get(f"maxmargin_{m}_verdict") for r in rows)]
    cols = -(-len(modes) // 2)  # the mode panels in two rows beside the margin panel
    fig = plt.figure(figsize=(7.5 + 3.6 * cols, 8.2 * len(panels) + 0.8), layout="constrained")
    grid = fig.add_gridspec(2 * len(panels), 1 + cols, width_ratios=[2.0] + [1.0] * cols)
    handles: dict[str, Artist] = {}
    for p, (mu, robot) in enumerate(panels):
        sub = [r for r in rows if r["friction"] == mu and r["robot"] == robot]
        times, slopes, _ = grids(sub, families[0])
        main = fig.add_subplot(grid[2 * p : 2 * p + 2, 0])
        image = _margin_panel(main, sub, families, handles)
        model = "".join(sorted({f", played on model {r['model']}" for r in sub if r.get("model")}))
        main.set_title(
            f"Is there a gait with the ZMP inside? (μ = {mu:g}, robot {robot}{model})\n"
            f"colour: largest minimum ZMP margin the GA found, {families[0]} family",
            fontsize=9,
        )
        bar = fig.colorbar(image, ax=main, shrink=0.7, extend="both", location="left")
        bar.set_label("largest minimum ZMP margin [mm] (> 0: inside)")
        _grid_axes(main, times, slopes, True)
        _paper_points(main, times, slopes, handles)
        for n, (mode, colour) in enumerate(zip(modes, _MODE_COLOURS, strict=False)):
            ax = fig.add_subplot(grid[2 * p + n // cols, 1 + n % cols])
            _walk_panel(ax, sub, families, mode, colour, handles)
            ax.set_title(f"Does MuJoCo walk that gait? {mode}", fontsize=9)
            _grid_axes(ax, times, slopes, False)
            _paper_points(ax, times, slopes, handles)
    if handles:  # none where no gait was found (nothing played) and no contour drawn
        fig.legend(
            list(handles.values()), list(handles), loc="outside lower center",
            ncol=min(3, len(handles)), fontsize=8, frameon=False,
        )  # fmt: skip
    return fig


def _margin_panel(ax, sub, families, handles):
    """The first question's panel: margin colours and every family's outlines; the image."""
    _, _, base = grids(sub, families[0])
    margin = np.clip(base["margin"], -CLIP_MM, CLIP_MM)
    image = ax.imshow(margin, cmap="RdBu", norm=TwoSlopeNorm(0.0, -CLIP_MM, CLIP_MM), aspect="auto")
    for k, family in enumerate(families):
        _, _, g = grids(sub, family)
        style = "-" if k == 0 else "--"
        _outline(
            ax,
            g["feasible"],
            "black",
            style,
            2.4,
            f"{family} family: a gait with the ZMP inside",
            handles,
        )
    required = sub[0]["required_margin_mm"]
    label = f"{families[0]} family: a gait with margin ≥ {required:g} mm"
    _outline(ax, base["found"], "0.35", ":", 2.0, label, handles)
    return image


def _walk_panel(ax, sub, families, mode, colour, handles) -> None:
    """One mode's panel: walked cells filled, the first family's feasibility outline on top."""
    _, _, base = grids(sub, families[0])
    walks = base.get(f"walks_{mode}", np.full(base["margin"].shape, np.nan))
    ax.imshow(
        np.where(np.isnan(walks), np.nan, walks), cmap=ListedColormap(["0.88", colour]),
        vmin=0, vmax=1, aspect="auto",
    )  # fmt: skip
    handles.setdefault("not walked (max-margin gait)", _patch("0.88"))
    handles.setdefault(f"MuJoCo {mode} walks (max-margin gait)", _patch(colour))
    _outline(
        ax,
        base["feasible"],
        "black",
        "-",
        1.8,
        f"{families[0]} family: a gait with the ZMP inside",
        handles,
    )
    for family in families[1:]:
        _, _, g = grids(sub, family)
        label = f"{family} family: MuJoCo walks its own gait (dashed, the mode's colour)"
        _outline(ax, g.get(f"walks_{mode}", np.zeros(1)), colour, "--", 2.0, label, handles)


def _patch(colour):
    return Line2D([], [], marker="s", markersize=10, linestyle="", color=colour)


def _grid_axes(ax, times, slopes, main: bool) -> None:
    """Ticks at the grid's values (evenly spaced cells); the main panel's labels say so."""
    ax.set_xlim(-0.5, len(slopes) - 0.5)
    ax.set_ylim(len(times) - 0.5, -0.5)
    size = 8 if main else 6
    ax.set_xticks(range(len(slopes)), [f"{s:g}" for s in slopes], fontsize=size, rotation=90)
    ax.set_yticks(range(len(times)), [f"{t:g}" for t in times], fontsize=size)
    if main:
        ax.set_xlabel(f"slope [deg], < 0 downhill ({SPACING_NOTE})", fontsize=9)
        ax.set_ylabel(f"step time t_c [s], faster lower ({SPACING_NOTE})", fontsize=9)
    else:
        ax.set_xlabel("slope [deg]", fontsize=8)
        ax.set_ylabel("t_c [s]", fontsize=8)


def _paper_points(ax, times, slopes, handles) -> None:
    """The paper's statements (``PAPER_POINTS``) on the cells the grid holds."""
    for t, s, inside, whose, text in PAPER_POINTS:
        if t not in times or s not in slopes:
            continue
        marker = _PAPER_MARKERS[whose]
        face = "white" if not inside else "black"
        ax.scatter(
            slopes.index(s), times.index(t), marker=marker, s=110 if marker == "*" else 55,
            facecolors=face, edgecolors="black", linewidths=1.2, zorder=6,
        )  # fmt: skip
        handles.setdefault(
            f"the paper: {text}",
            Line2D([], [], marker=marker, linestyle="", markerfacecolor=face,
                   markeredgecolor="black", markersize=9 if marker == "*" else 7),
        )  # fmt: skip


def _outline(ax, field, colour, style, width, label, handles) -> None:
    """The staircase around ``field``'s cells; its name goes in the legend (``handles``)."""
    from matplotlib.collections import LineCollection

    segments = edges(np.asarray(field)) if np.ndim(field) == 2 else []
    if not segments:
        return
    ax.add_collection(
        LineCollection(segments, colors=colour, linestyles=style, linewidths=width, zorder=4)
    )
    handles.setdefault(label, Line2D([], [], color=colour, linestyle=style, linewidth=width))


def edges(field: np.ndarray) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """Cell-border segments between a cell where ``field`` is 1 and one where it is not.

    In image coordinates (column x, row y, cell centres on integers); cells outside
    the grid or NaN count as "not".
    """
    on = np.pad(field == 1, 1)
    out = []
    rows, cols = field.shape
    for i in range(rows + 1):  # horizontal borders, between rows i-1 and i
        for j in range(cols):
            if on[i, j + 1] != on[i + 1, j + 1]:
                out.append(((j - 0.5, i - 0.5), (j + 0.5, i - 0.5)))
    for i in range(rows):  # vertical borders, between columns j-1 and j
        for j in range(cols + 1):
            if on[i + 1, j] != on[i + 1, j + 1]:
                out.append(((j - 0.5, i - 0.5), (j - 0.5, i + 0.5)))
    return out


def write_figure(table: str | Path, path: str | Path) -> Path:
    """Draw ``envelope.png`` from an envelope table, written whole."""
    fig = envelope_figure(read_table(table))
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return path
