"""The stability envelope on one picture: step time × slope, analytic and simulated boundaries.

Per panel (one per friction and robot): each cell is coloured by the largest
minimum ZMP margin the GA found for the paper's family [mm] (diverging: blue
inside the polygon, red outside, clipped at ±10 mm); on top, each boundary is a
staircase along the cell borders, labelled on the line itself:

- the analytic feasibility boundary of each family (margin = 0, solid black for
  the paper's family, dashed for the others), and the required-margin contour
  (dotted) where the min-work gait exists;
- the simulated walking boundary per actuator mode (the max-margin gait walks:
  verdict ``stable``), one colour per mode; a marker per cell says where MuJoCo
  walks it in the first mode; for every other family (the extended one) the
  walking boundary of its own max-margin gaits in the first mode, dashed in that
  mode's colour. Boundaries that coincide are drawn side by side (each shifted a
  fraction of a cell), so none hides another.

Cells sit at equal spacing with their real values as tick labels, so a grid
denser near 15–30° stays readable. Degrees and millimetres only here.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import TwoSlopeNorm  # noqa: E402

from slopewalk.bench.files import atomic_path  # noqa: E402
from slopewalk.bench.sim.model import ACTUATOR_MODES  # noqa: E402
from slopewalk.bench.tables.envelope import is_failure  # noqa: E402
from slopewalk.bench.tables.table import read_table  # noqa: E402

CLIP_MM = 10.0
_MODE_COLOURS = ("#0072B2", "#E69F00", "#009E73", "#CC79A7", "#56B4E9", "#D55E00")  # Okabe-Ito


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
            verdict = r.get(f"maxmargin_{m}_verdict")
            if verdict:
                out[f"walks_{m}"][i, j] = verdict == "stable"
    return times, slopes, out


def envelope_figure(rows: list[dict]):
    """The figure (module doc) of an envelope table's rows."""
    panels = sorted({(r["friction"], r["robot"]) for r in rows})
    families = sorted({r["family"] for r in rows}, key=lambda f: (f != "paper", f))
    fig, axes = plt.subplots(
        1, len(panels), figsize=(9.5 * len(panels), 7.0), squeeze=False, layout="constrained"
    )
    for ax, (mu, robot) in zip(axes[0], panels, strict=True):
        sub = [r for r in rows if r["friction"] == mu and r["robot"] == robot]
        times, slopes, base = grids(sub, families[0])
        margin = np.clip(base["margin"], -CLIP_MM, CLIP_MM)
        image = ax.imshow(
            margin, cmap="RdBu", norm=TwoSlopeNorm(0.0, -CLIP_MM, CLIP_MM), aspect="auto"
        )
        lines = []  # (field, colour, style, width, label, offset [cells])
        for k, family in enumerate(families):
            _, _, g = grids(sub, family)
            style = "-" if k == 0 else "--"
            lines.append((g["feasible"], "black", style, 2.6, f"{family}: ZMP inside", 0.0))
        required = sub[0]["required_margin_mm"]
        lines.append((base["found"], "0.35", ":", 2.0, f"margin ≥ {required:g} mm", -0.12))
        modes = [k.removeprefix("walks_") for k in base if k.startswith("walks_")]
        for n, (mode, colour) in enumerate(zip(modes, _MODE_COLOURS, strict=False)):
            offset = 0.12 * (n + 1)
            lines.append((base[f"walks_{mode}"], colour, "-", 2.4, f"MuJoCo {mode} walks", offset))
        for k, family in enumerate(families[1:], start=1):  # their gaits, in the first mode
            _, _, g = grids(sub, family)
            if modes and f"walks_{modes[0]}" in g:
                label = f"{family}: MuJoCo {modes[0]} walks"
                offset = -0.12 * (k + 1)
                lines.append((g[f"walks_{modes[0]}"], _MODE_COLOURS[0], "--", 2.4, label, offset))
        for n, (field, colour, style, width, label, offset) in enumerate(lines):
            _boundary(ax, field, colour, style, width, label, offset, (n + 0.5) / len(lines))
        ax.set_xlim(-0.6, len(slopes) - 0.2)
        ax.set_ylim(len(times) - 0.2, -0.6)
        if modes:
            ii, jj = np.nonzero(base[f"walks_{modes[0]}"] == 1)
            ax.scatter(jj, ii, s=16, color=_MODE_COLOURS[0], zorder=3)
        ax.set_xticks(range(len(slopes)), [f"{s:g}" for s in slopes], fontsize=8)
        ax.set_yticks(range(len(times)), [f"{t:g}" for t in times], fontsize=8)
        ax.set_xlabel("slope [deg]  (negative: downhill, positive: uphill)")
        ax.set_ylabel("step time t_c [s]  (faster: lower)")
        dots = (
            f"\ndots: MuJoCo {modes[0]} walks the {families[0]} family's max-margin gait; "
            if modes
            else "\n"
        )
        ax.set_title(
            f"Stability envelope, μ = {mu:g}, robot {robot}: colour = largest minimum ZMP margin "
            f"the GA found ({families[0]} family){dots}each line encloses the cells where its "
            "label holds",
            fontsize=9,
        )
        bar = fig.colorbar(image, ax=ax, shrink=0.85, extend="both")
        bar.set_label("largest minimum ZMP margin [mm] (> 0: inside the support polygon)")
    return fig


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


def _boundary(ax, field, colour, style, width, label, offset, where) -> None:
    """The staircase around ``field``'s cells, shifted ``offset`` cells so coinciding
    boundaries lie side by side, with ``label`` written under its fast edge (the lowest
    segment of a column) at share ``where`` of its width, so labels of different lines
    fall at different places."""
    from matplotlib.collections import LineCollection

    segments = edges(field)
    if not segments:
        return
    shifted = [
        ((x0 + offset, y0 + offset), (x1 + offset, y1 + offset)) for (x0, y0), (x1, y1) in segments
    ]
    ax.add_collection(
        LineCollection(shifted, colors=colour, linestyles=style, linewidths=width, zorder=4)
    )
    horizontal = [s for s in shifted if s[0][1] == s[1][1]] or shifted
    # the fast edge (the lowest segment of each column) is where the boundaries differ most
    lowest: dict[float, tuple] = {}
    for seg in horizontal:
        x = round((seg[0][0] + seg[1][0]) / 2, 6)
        if x not in lowest or seg[0][1] > lowest[x][0][1]:
            lowest[x] = seg
    xs = sorted(lowest)
    (x0, y0), (x1, y1) = lowest[xs[min(len(xs) - 1, int(where * len(xs)))]]
    ax.annotate(
        label,
        ((x0 + x1) / 2, (y0 + y1) / 2),
        xytext=(0, -10),
        textcoords="offset points",
        ha="center",
        va="center",
        fontsize=8,
        color=colour if colour != "black" else "black",
        bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": colour, "lw": 0.8, "alpha": 0.9},
        zorder=5,
    )


def write_figure(table: str | Path, path: str | Path) -> Path:
    """Draw ``envelope.png`` from an envelope table, written whole."""
    fig = envelope_figure(read_table(table))
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return path
