"""The paper's claims 1 and 2 answered from the stability envelope (the GA's best gait per cell).

The sweep's claims are about one hand-picked gait; the paper's question is
whether *a* gait with the ZMP inside exists at a step time and slope. The
envelope (``envelope.csv``, rows as ``tables.table.read_table`` reads them)
answers it per cell: ``feasible`` (the GA's max-margin gait has its ZMP inside,
joints within limits) and whether MuJoCo walks that gait (per actuator mode): its strict
walk verdict (``walk`` columns, ``bench/sim/walk_check.py``) is ``walked``; a table
written before those columns is read by its balance verdict (``stable``).
Numbers at fixed precision, as in ``claims.py``.
"""

from __future__ import annotations

from pathlib import Path

from slopewalk.bench.files import atomic_path
from slopewalk.bench.sim.model import ACTUATOR_MODES
from slopewalk.bench.tables.envelope import is_failure, walk_column, walks
from slopewalk.bench.tables.table import read_table

DEFAULT_ROBOT = "default"  # an envelope table's ``robot`` for the paper's biped

NOMINAL_STEP_TIME = 1.0  # [s]


def _paper(rows) -> list[dict]:
    return [
        r
        for r in rows
        if r["family"] == "paper" and r["friction"] == 1.0 and r["robot"] == "default"
        if not is_failure(r["error"])
    ]


def _modes(rows) -> list[str]:
    return [m for m in ACTUATOR_MODES if any(r.get(f"maxmargin_{m}_verdict") for r in rows)]


def _walks(row, mode) -> bool:
    """The max-margin gait walks in ``mode``: strict walk verdict ``walked`` (balance
    ``stable`` in a table written before the walk columns, ``tables.envelope.walks``)."""
    return bool(walks(row, "maxmargin", mode))


def _word(value) -> str:
    return {True: "yes", False: "no", None: "-"}[value]


def _sim_text(row, modes) -> str:
    """Each mode's balance verdict, and its strict walk verdict where it differs."""

    def one(m):
        balance = row.get(f"maxmargin_{m}_verdict") or "not played"
        strict = row.get(walk_column("maxmargin", m))
        return f"{m} {balance}" + (f" ({strict})" if strict and strict != balance else "")

    return ", ".join(one(m) for m in modes)


def _cell(row) -> str:
    return f"t_c {row['step_time']:g} s, {row['slope_deg']:g}°"


def envelope_claims(rows, cite: str, spec=None) -> list[dict]:
    """Claims 1 (fastest flat step time) and 2 (steepest slopes at 1 s) from the envelope.

    ``spec``: the envelope's robot; with it each row gives the smallest lateral and
    sagittal margins of the cells' stored gaits it cites (``claim_axes``), re-planned."""
    rows = _paper(rows)
    modes = _modes(rows)
    flat = sorted((r for r in rows if r["slope_deg"] == 0.0), key=lambda r: r["step_time"])
    line = sorted(
        (r for r in rows if r["step_time"] == NOMINAL_STEP_TIME), key=lambda r: r["slope_deg"]
    )
    out = ([_flat_claim(flat, modes, cite)] if flat else []) + (
        [_slope_claim(line, modes, cite)] if line else []
    )
    for claim, cells, key in ((c, flat, "step_time") for c in out[:1] if flat):
        claim["axes"] = _cell_axes(spec, cells, key, (0.5, 0.4), " s")
    if line:
        out[-1]["axes"] = _cell_axes(spec, line, "slope_deg", (22.5, 25.0, 30.0), "°")
    return out


def _cell_axes(spec, cells, key: str, values, unit: str) -> str:
    """Smallest lateral and sagittal margins of the max-margin gaits of the cells whose
    ``key`` is one of ``values``, each re-planned at 1 ms."""
    if spec is None:
        return "-"
    from slopewalk.bench.report.claim_axes import axes
    from slopewalk.planner.errors import SlopewalkError
    from slopewalk.planner.plan import plan_walk

    parts = []
    for row in cells:
        if row[key] not in values or row["maxmargin_hip_height_m"] in ("", None):
            continue
        try:
            text = axes(plan_walk(spec, _stored_gait(spec, row)))
        except SlopewalkError as err:
            text = f"not plannable ({err})"
        parts.append(f"{row[key]:g}{unit}: {text}")
    return "; ".join(parts) or "-"


def _stored_gait(spec, row):
    """The cell's max-margin gait as ``GaitParams`` (its stored variables)."""
    import numpy as np

    from slopewalk.planner.gait import GaitParams

    return GaitParams.nominal(
        spec, row["step_time"], slope=np.deg2rad(row["slope_deg"]), steps=int(row["steps"]),
        hip_height=row["maxmargin_hip_height_m"], swing_lift=row["maxmargin_swing_lift_m"],
        tilt=np.deg2rad(row["maxmargin_tilt_deg"]), pelvis_offset=row["maxmargin_pelvis_offset_m"],
        step_length=row["maxmargin_step_length_m"], sway_share=row["maxmargin_sway_share"],
    )  # fmt: skip


def _flat_claim(flat, modes, cite: str) -> dict:
    """Claim 1 from the flat cells, fastest first: 0.5 s inside, 0.4 s outside."""
    feasible = [r for r in flat if r["feasible"] == "True"]
    fastest = feasible[0] if feasible else None
    by_t = {r["step_time"]: r for r in flat}
    walked = {m: [r["step_time"] for r in flat if _walks(r, m)] for m in modes}
    sim = "; ".join(
        f"{m}: fastest walked {min(ts):g} s" if ts else f"{m}: walks none"
        for m, ts in walked.items()
    )
    analytic = (
        f"fastest t_c with a gait inside: {fastest['step_time']:g} s (largest margin "
        f"{fastest['maxmargin_margin_mm']:.1f} mm)"
        if fastest
        else "no step time of the grid has a gait inside"
    )
    for t in (0.5, 0.4):
        if t in by_t:
            analytic += f"; at {t:g} s: largest margin {by_t[t]['maxmargin_margin_mm']:.1f} mm"
    if fastest:
        sim = f"that gait in MuJoCo: {_sim_text(fastest, modes)}; " + sim

    def agrees(ok):
        return ok(by_t[0.5]) and not ok(by_t[0.4]) if 0.5 in by_t and 0.4 in by_t else None

    first = modes[0] if modes else None
    return {
        "claim": "flat ground: fastest step time with a gait inside the polygon (the "
        "GA's best gait per step time)",
        "paper": "0.5 s (ZMP outside at 0.4 s) for its hand-picked gait; the paper states no GA "
        "result on flat ground (its nominal gait is compared in the nominal rows)",
        "analytic": analytic,
        "simulated": sim,
        "agree": f"analytic {_word(agrees(lambda r: r['feasible'] == 'True'))}, simulated "
        f"{_word(agrees(lambda r: _walks(r, first)) if first else None)}"
        + (f" ({first})" if first else ""),
        "evidence": f"envelope.png, {cite} (slope 0)",
        "basis": "the gait family's shape and estimated spec values (the boundary moves with "
        "the foot's size, which the spec estimates)",
    }


def _slope_claim(line, modes, cite: str) -> dict:
    """Claim 2 from the cells at the nominal step time, by slope: 15° inside, beyond 22.5° not."""
    up = [r["slope_deg"] for r in line if r["slope_deg"] >= 0 and r["feasible"] == "True"]
    down = [r["slope_deg"] for r in line if r["slope_deg"] <= 0 and r["feasible"] == "True"]
    walked = {m: ([r["slope_deg"] for r in line if _walks(r, m)]) for m in modes}
    analytic = (
        f"steepest uphill with the ZMP inside: {max(up):g}°" if up else "no uphill slope inside"
    ) + (f"; steepest downhill: {min(down):g}°" if down else "; no downhill slope inside")
    analytic += "; largest margin [mm]: " + ", ".join(
        f"{r['slope_deg']:g}°: {r['maxmargin_margin_mm']:.1f}" for r in line
    )
    sim = "; ".join(
        f"{m}: walks {min(s):g}° … {max(s):g}° ({len(s)} of {len(line)} slopes)"
        if s
        else f"{m}: walks none"
        for m, s in walked.items()
    )

    def agrees(ok_slopes):
        """The paper's GA: a gait at 22.5° (re-optimised), none at 30° (nominal foot)."""
        have = {r["slope_deg"] for r in line}
        if not {22.5, 30.0} <= have:
            return None
        return 22.5 in ok_slopes and 30.0 not in ok_slopes

    first = modes[0] if modes else None
    ups = [s for s in walked.get(first, []) if s >= 0] if first else []
    return {
        "claim": "t_c = 1 s: steepest uphill slope with the ZMP inside (the GA's best "
        "gait per slope), and the steepest downhill one",
        "paper": "the paper's GA (sec. VI): a gait inside at 22.5° after re-optimising, none "
        "at 30° with the nominal foot (its 15° is the nominal gait's: see the nominal rows); "
        "no downhill case",
        "analytic": analytic,
        "simulated": sim,
        "agree": f"analytic {_word(agrees(up))}, simulated "
        f"{_word(agrees(ups) if first else None)}" + (f" ({first})" if first else ""),
        "evidence": f"envelope.png, {cite} (t_c = 1 s)",
        "basis": "uphill: physics (gravity along the plane) and estimated spec values (the "
        "heel and the ankle-pitch limit); downhill: the gait family's shape (the hip spline "
        "puts the single-support ZMP ahead of the ankle, and crouching is its only sagittal "
        "knob)",
    }


def envelope_cell_note(rows, slope_deg: float, cite: str) -> str:
    """One sentence on the envelope's cell at t_c = 1 s and ``slope_deg``, or ""."""
    rows = _paper(rows)
    cell = next(
        (r for r in rows if r["step_time"] == NOMINAL_STEP_TIME and r["slope_deg"] == slope_deg),
        None,
    )
    if cell is None:
        return ""
    modes = _modes(rows)
    minwork = (
        f"least work with margin ≥ {cell['required_margin_mm']:g} mm: "
        f"{cell['minwork_work_J']:.3f} J"
        if cell["minwork_found"] == "True"
        else f"no gait with margin ≥ {cell['required_margin_mm']:g} mm found"
    )
    verdict = "feasible" if cell["feasible"] == "True" else "infeasible"
    return (
        f"; envelope cell {_cell(cell)} ({cite}): {verdict}, largest margin "
        f"{cell['maxmargin_margin_mm']:.1f} mm (Hz {cell['maxmargin_hip_height_m']:.3f} m, "
        f"Szmax {cell['maxmargin_swing_lift_m']:.3f} m, θ1max {-cell['maxmargin_tilt_deg']:.2f}°"
        f"), {minwork}; MuJoCo: {_sim_text(cell, modes)}"
    )


def _of_family(rows, family: str, robot: str = DEFAULT_ROBOT) -> list[dict]:
    return [
        r
        for r in rows
        if r["family"] == family and r["friction"] == 1.0 and r["robot"] == robot
        if not is_failure(r["error"])
    ]


def family_boundaries(rows, robot: str = DEFAULT_ROBOT) -> dict[str, dict]:
    """The envelope's boundaries per gait family (μ 1, ``robot``: the default one), as claims
    1-2 read them.

    Per family: ``flat_inside`` the fastest flat step time [s] with a gait inside (None:
    none), ``flat_walked`` {mode: the fastest flat step time MuJoCo walks}, ``up_inside``
    and ``down_inside`` the steepest uphill and downhill slopes [deg] at t_c = 1 s with a
    gait inside, ``up_walked`` and ``down_walked`` {mode: the same for MuJoCo}, and
    ``edges``: the grid's fastest flat step time and steepest slopes at 1 s.
    """
    out = {}
    families = sorted({r["family"] for r in rows}, key=lambda f: (f != "paper", f))
    for family in families:
        sub = _of_family(rows, family, robot)
        modes = _modes(sub)
        flat = [r for r in sub if r["slope_deg"] == 0.0]
        line = [r for r in sub if r["step_time"] == NOMINAL_STEP_TIME]

        def best(cells, key, pick, ok):
            values = [r[key] for r in cells if ok(r)]
            return pick(values) if values else None

        def inside(r):
            return r["feasible"] == "True"

        def uphill(r):
            return r["slope_deg"] >= 0

        def downhill(r):
            return r["slope_deg"] <= 0

        out[family] = {
            "edges": {  # the grid's own extremes: a boundary there may lie beyond the grid
                "flat": best(flat, "step_time", min, lambda r: True),
                "up": best(line, "slope_deg", max, lambda r: True),
                "down": best(line, "slope_deg", min, lambda r: True),
            },
            "flat_inside": best(flat, "step_time", min, inside),
            "flat_walked": {
                m: best(flat, "step_time", min, lambda r, m=m: _walks(r, m)) for m in modes
            },
            "up_inside": best(line, "slope_deg", max, lambda r: uphill(r) and inside(r)),
            "down_inside": best(line, "slope_deg", min, lambda r: downhill(r) and inside(r)),
            "up_walked": {
                m: best(line, "slope_deg", max, lambda r, m=m: uphill(r) and _walks(r, m))
                for m in modes
            },
            "down_walked": {
                m: best(line, "slope_deg", min, lambda r, m=m: downhill(r) and _walks(r, m))
                for m in modes
            },
        }
    return out


def walked_intervals(rows, key: str, mode: str) -> list[tuple[float, float]]:
    """The runs of consecutive grid values of ``key`` in ``rows`` that MuJoCo walks in
    ``mode``, as (first, last) pairs in ascending order: the grid's own neighbours decide
    where a run breaks (a value the grid holds but the mode does not walk)."""
    values = sorted({r[key] for r in rows})
    walked = {r[key] for r in rows if _walks(r, mode)}
    runs: list[tuple[float, float]] = []
    start = None
    for i, value in enumerate(values):
        if value in walked and start is None:
            start = value
        if start is not None and (value not in walked or i == len(values) - 1):
            last = value if value in walked else values[i - 1]
            runs.append((start, last))
            start = None
    return runs


def _intervals_text(runs: list[tuple[float, float]], unit: str) -> str:
    if not runs:
        return "none"
    return ", ".join(f"{a:g}{unit}" if a == b else f"{a:g}{unit} to {b:g}{unit}" for a, b in runs)


def _walked_interval_lines(rows, robot: str = DEFAULT_ROBOT) -> list[str]:
    """Per family and mode: every slope walked at t_c = 1 s and every flat step time walked,
    as intervals of the grid, since the steepest or fastest alone hides the gaps below it."""
    lines = [
        "",
        "Walked, as intervals of the grid (the steepest or fastest value alone hides the cells "
        "below it that MuJoCo does not walk):",
        "",
        f"| family | mode | slopes walked at t_c = {NOMINAL_STEP_TIME:g} s | "
        "flat step times walked |",
        "|---|---|---|---|",
    ]
    families = sorted({r["family"] for r in rows}, key=lambda f: (f != "paper", f))
    for family in families:
        sub = _of_family(rows, family, robot)
        line = [r for r in sub if r["step_time"] == NOMINAL_STEP_TIME]
        flat = [r for r in sub if r["slope_deg"] == 0.0]
        for mode in _modes(sub):
            lines.append(
                f"| {family} | {mode} | "
                f"{_intervals_text(walked_intervals(line, 'slope_deg', mode), '°')} | "
                f"{_intervals_text(walked_intervals(flat, 'step_time', mode), ' s')} |"
            )
    return lines


def boundaries_markdown(rows, source: str, bands: list[dict] | None = None) -> str:
    """``boundaries.md``: ``family_boundaries`` as a table, one row per family: of the
    default robot, or of the table's one robot where it has no other (an imported spec,
    its model named where the table's rows were played on one); the GA's admissibility
    constraints that shape them, and their bands over the spec's unknowns (``bands``: the
    rows of a ``bands.csv``, ``report.bands``; None: where to find them)."""

    def show(value, unit, edge=None):
        text = "none" if value is None else f"{value:g}{unit}"
        return text + (" (grid edge)" if value is not None and value == edge else "")

    def per_mode(values, unit, edge):
        return ", ".join(f"{m} {show(v, unit, edge)}" for m, v in values.items()) or "not played"

    robots = {r["robot"] for r in rows}
    robot = robots.pop() if len(robots) == 1 else DEFAULT_ROBOT
    whose = "the default robot" if robot == DEFAULT_ROBOT else f"the robot `{robot}`"
    models = {(r["model"], r["model_digest"]) for r in rows if r.get("model")}
    whose += "".join(f", played on the unmodified model {m} ({d})" for m, d in sorted(models))
    lines = [
        "# The envelope's boundaries per gait family",
        "",
        f"Written by `slopewalk envelope` with the table ({source}): per family, μ = 1, "
        f"{whose}. *Inside*: the GA's max-margin gait has its ZMP inside the support "
        "polygon at every instant with every joint within its limits; *walked*: MuJoCo plays "
        "that gait to the end and walks the plan (strict walk verdict `walked`: balanced, "
        "every landing on its footprint, the swing foot off the plane, the pelvis at the end "
        "pose, every actuator within the servo's stall torque; `docs/verdicts.md`; a table "
        "written before the walk columns: the balance verdict `stable`), per actuator mode. "
        "The slopes are "
        f"those at t_c = {NOMINAL_STEP_TIME:g} s (negative: downhill).",
        "",
        "| family | flat: fastest t_c inside | flat: fastest t_c walked | "
        "uphill inside | downhill inside | uphill walked | downhill walked |",
        "|---|---|---|---|---|---|---|",
    ]
    for family, b in family_boundaries(rows, robot).items():
        e = b["edges"]
        lines.append(
            f"| {family} | {show(b['flat_inside'], ' s', e['flat'])} | "
            f"{per_mode(b['flat_walked'], ' s', e['flat'])} | "
            f"{show(b['up_inside'], '°', e['up'])} | {show(b['down_inside'], '°', e['down'])} | "
            f"{per_mode(b['up_walked'], '°', e['up'])} | "
            f"{per_mode(b['down_walked'], '°', e['down'])} |"
        )
    lines += [
        "",
        "*(grid edge)*: the boundary lies at or beyond the grid's last step time or slope.",
        "",
        *_shaping_lines(bands),
        *_walked_interval_lines(rows, robot),
    ]
    return "\n".join(lines) + "\n"


def _shaping_lines(bands: list[dict] | None) -> list[str]:
    """What shapes the *inside* boundaries besides the ZMP, and how far they move with what
    the spec only estimates."""
    from slopewalk.bench.report.bands import MD_NAME, admissibility, band_lines
    from slopewalk.planner.spec import load_spec

    lines = [
        "*Inside* also needs what the GA admits: gaits with "
        f"{admissibility(load_spec())}; a boundary may be set by one of these rather than by "
        "the ZMP.",
        "",
    ]
    if bands is None:
        return lines + [
            f"Their bands over the values the robot spec only estimates: `slopewalk bands` "
            f"writes {MD_NAME} beside this file.",
        ]
    return lines + [
        f"Over the values the robot spec only estimates ({MD_NAME}, `slopewalk bands`: each "
        "boundary searched again with one estimated value at a time at either end of its "
        "range; the nominal there is that search's own, with the envelope's GA settings):",
        "",
        *band_lines(bands),
    ]


FIGURE_NAME = "envelope.png"
BOUNDARIES_NAME = "boundaries.md"


def write_envelope_documents(table: str | Path, out_dir: str | Path, source: str) -> list[Path]:
    """``envelope.png`` and ``boundaries.md`` (per gait family: the fastest flat step time
    and the steepest slopes at 1 s, inside the polygon and walked in MuJoCo) of a finished
    envelope table, into ``out_dir``; each written whole."""
    from slopewalk.bench.report.envelope_figure import write_figure

    out_dir = Path(out_dir)
    figure = write_figure(table, out_dir / FIGURE_NAME)
    boundaries = out_dir / BOUNDARIES_NAME
    from slopewalk.bench.report.bands import CSV_NAME, read_csv

    bands_csv = out_dir / CSV_NAME  # `slopewalk bands` writes it beside the envelope
    bands = read_csv(bands_csv) if bands_csv.is_file() else None
    with atomic_path(boundaries) as tmp:
        tmp.write_text(boundaries_markdown(read_table(table), source, bands))
    return [figure, boundaries]
