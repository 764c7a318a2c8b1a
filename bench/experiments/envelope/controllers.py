"""Open loop vs closed-loop controllers over a stability envelope's gaits: how many cells walk.

The envelope's counterpart of ``controllers.py`` (which walks a sweep's trials).
Its jobs are the gaits an envelope played: per cell, the max-margin gait when
it plans at 1 ms and the min-work gait when one was found (``*_margin_1ms_mm``
set, ``envelope/cell.py``'s ``_choose``), each in the actuator modes played. They come
either from a finished ``envelope.csv`` (``table_jobs``: its parameters,
re-planned at 1 ms, no GA run again) or from an envelope file
(``config_jobs``: every cell's GA run again, no MuJoCo). ``compare_envelope``
walks each gait open loop (one ``mujoco.rollout``) and with each controller
(``slopewalk.bench.sim.env``) on local worker processes; ``envelope_report`` writes the
markdown section of ``results/controllers.md``: per gait and mode, how many
cells walk (strict walk verdict ``walked``) open loop and with each controller,
and which cells each controller gains and loses.

The table keeps hip height and swing lift to 0.1 µm and the tilt to 1e-5 deg, so a
re-planned gait is that of the table to those digits, not to the bit: the open-loop
walk is played again from the same parameters (the comparison is like for like),
and the report counts how often its verdict is the table's.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from slopewalk.bench.experiments.controller_comparison import map_local
from slopewalk.bench.sim.model import ACTUATOR_MODES
from slopewalk.bench.tables.envelope import GAITS, controller_tag, sim_columns
from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.spec import RobotSpec

WALK = "walk"  # the key of a strict walk verdict in ``play_gait``'s answer

GAIT_NAMES = {"maxmargin": "max-margin", "minwork": "min-work"}
_INPUTS = ("cell_id", "step_time", "slope_deg", "friction", "robot", "steps", "error")


class EnvelopeTableError(SlopewalkError):
    """An envelope table that cannot be read, or whose robot file is missing."""


@dataclass(frozen=True)
class GaitJob:
    """One played gait of one envelope cell (degrees at this edge, like the table).

    Attributes:
        cell_id: The cell's id. label: e.g. "T=1 s slope=15 mu=1".
        step_time: [s]. slope_deg: [deg]. friction: Coulomb μ. steps: Steps per walk.
        gait: "maxmargin" or "minwork". x: (hip height [m], swing lift [m], tilt [rad]),
            then for the extended family (pelvis offset [m], step length [m], sway share).
        modes: Actuator modes it is walked in. family: The gait family of the row.
        table_verdicts: The table's open-loop verdict per mode ({} from a GA run).
    """

    cell_id: str
    label: str
    step_time: float
    slope_deg: float
    friction: float
    steps: int
    gait: str
    x: tuple[float, ...]
    modes: tuple[str, ...]
    spec: RobotSpec = field(repr=False)
    table_verdicts: dict = field(default_factory=dict)
    family: str = "paper"

    def params(self):
        """The walk of this gait (``GaitParams``), as ``envelope.cell.EnvelopeCell.gait``
        builds it from the GA's variables: (Hz, Szmax, tilt), then (δ, L, w) when extended."""
        from slopewalk.planner.gait import GaitParams

        hip, lift, tilt, *extended = self.x
        extra = {}
        if extended:
            offset, length, sway = extended
            extra = {"pelvis_offset": offset, "step_length": length, "sway_share": sway}
        return GaitParams.nominal(
            self.spec, self.step_time, slope=float(np.deg2rad(self.slope_deg)),
            steps=self.steps, hip_height=hip, swing_lift=lift, tilt=tilt, **extra,
        )  # fmt: skip


def _label(row: dict) -> str:
    t, s, mu = (float(row[k]) for k in ("step_time", "slope_deg", "friction"))
    text = f"T={t:g} s slope={s:g} mu={mu:g}"
    if row.get("family", "paper") != "paper":
        text += f" {row['family']}"
    return text + (f" robot {row['robot']}" if row["robot"] != "default" else "")


def _number(value) -> float:
    """``value`` as a float (a table's text or a row's number), NaN when empty."""
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def row_jobs(row: dict, spec: RobotSpec, modes: tuple[str, ...], *, verdicts: bool) -> list:
    """The played gaits of one envelope row (the table's text, or ``run_cell``'s values)."""
    jobs = []
    for gait in GAITS:
        if not math.isfinite(_number(row.get(f"{gait}_margin_1ms_mm"))):
            continue  # not plannable at 1 ms: not played
        if gait == "minwork" and str(row.get("minwork_found")) != "True":
            continue  # nothing of the required margin: not played
        x: tuple[float, ...] = (
            _number(row[f"{gait}_hip_height_m"]),
            _number(row[f"{gait}_swing_lift_m"]),
            float(np.deg2rad(_number(row[f"{gait}_tilt_deg"]))),
        )
        family = str(row.get("family", "paper"))
        if family != "paper":  # the extended family's own pelvis offset, step length, sway
            x += tuple(
                _number(row[f"{gait}_{c}"])
                for c in ("pelvis_offset_m", "step_length_m", "sway_share")
            )
        table = {m: row.get(sim_columns(gait, m)[0], "") for m in modes} if verdicts else {}
        jobs.append(
            GaitJob(
                str(row["cell_id"]),
                _label(row),
                _number(row["step_time"]),
                _number(row["slope_deg"]),
                _number(row["friction"]),
                int(row["steps"]),
                gait,
                x,
                modes,
                spec,
                table,
                family,
            )  # fmt: skip
        )
    return jobs


def table_jobs(path: str | Path, *, min_step_time: float = 0.0) -> list[GaitJob]:
    """The played gaits of a finished envelope table, at step times ≥ ``min_step_time`` [s].

    The modes are those the table played (a max-margin verdict in some row); robots
    other than "default" are spec files relative to the table's folder.

    Raises:
        EnvelopeTableError: not an envelope table, or a robot file missing, in one line.
    """
    import csv

    from slopewalk.bench.tables.envelope import is_failure
    from slopewalk.planner.spec import load_spec

    path = Path(path)
    try:
        header = path.read_bytes().split(b"\n", 1)[0].decode().split(",")
    except IsADirectoryError:
        raise EnvelopeTableError(f"{path}: is a directory, not an envelope table") from None
    except OSError as err:
        raise EnvelopeTableError(f"{path}: cannot read ({err.strerror})") from None
    except UnicodeDecodeError:
        raise EnvelopeTableError(f"{path}: not an envelope table (not UTF-8 text)") from None
    needed = (*_INPUTS, *(f"{g}_{c}" for g in GAITS for c in ("margin_1ms_mm", "hip_height_m")))
    missing = [c for c in needed if c not in header]
    if missing:
        raise EnvelopeTableError(
            f"{path}: not an envelope table (no column {missing[0]}); give the envelope.csv "
            "of `slopewalk envelope` or an envelope TOML"
        )
    with open(path, newline="") as f:
        rows = [r for r in csv.DictReader(f) if not is_failure(r["error"])]
    modes = tuple(m for m in ACTUATOR_MODES if any(r.get(f"maxmargin_{m}_verdict") for r in rows))
    specs: dict[str, RobotSpec] = {}
    jobs = []
    for row in rows:
        if _number(row["step_time"]) < min_step_time:
            continue
        if row.get("model"):
            raise EnvelopeTableError(
                f"{path}: cell {row['cell_id']} was played on the model {row['model']}: the "
                "controllers step the twin's scene only (a model plays the plan open loop)"
            )
        robot = row["robot"]
        if robot not in specs:
            try:
                specs[robot] = load_spec(None if robot == "default" else path.parent / robot)
            except SlopewalkError as err:
                raise EnvelopeTableError(f"{path}: robot of cell {row['cell_id']}: {err}") from None
        jobs += row_jobs(row, specs[robot], modes, verdicts=True)
    return jobs


def config_jobs(config, *, workers: int = 1, min_step_time: float = 0.0) -> list[GaitJob]:
    """The gaits of an envelope file's cells at step times ≥ ``min_step_time`` [s], each
    cell's GA run again (``run_cell_search``, no MuJoCo), walked in the file's modes."""
    from slopewalk.bench.experiments.envelope.cell import run_cell_search
    from slopewalk.bench.tables.envelope import is_failure

    cells = [c for c in config.cells if c.step_time >= min_step_time]
    rows = map_local(run_cell_search, cells, workers)
    jobs = []
    for cell, row in zip(cells, rows, strict=True):
        if is_failure(row.get("error")):
            raise EnvelopeTableError(f"{config.source}: cell {cell.label}: {row['error']}")
        jobs += row_jobs(row, cell.spec, cell.modes, verdicts=False)
    return jobs


def play_gait(job_and_controllers) -> dict:
    """{(mode, controller or None): balance verdict, (mode, controller or None, WALK): strict
    walk verdict} of one gait, re-planned at 1 ms."""
    import numba

    from slopewalk.bench.experiments.sweep.trials import TIMESTEP
    from slopewalk.bench.sim.trial import run_trial
    from slopewalk.bench.sim.trial_spec import TrialSpec
    from slopewalk.planner.plan import plan_walk

    job, controllers = job_and_controllers
    numba.set_num_threads(1)  # one per worker process
    params = job.params()
    plan = plan_walk(job.spec, params)
    out: dict[tuple, str] = {}
    for mode in job.modes:
        for controller in (None, *controllers):
            trial = TrialSpec(
                params, friction=job.friction, actuators=mode, timestep=TIMESTEP,
                controller=controller,
            )  # fmt: skip
            result = run_trial(job.spec, trial, plan=plan, predict=False)  # simulated only
            out[mode, controller] = result.simulated_verdict
            out[mode, controller, WALK] = result.walk_verdict
    return out


def compare_envelope(jobs: list[GaitJob], controllers: tuple[str, ...], *, workers: int = 1):
    """The verdicts of every job, open loop and with each controller (``play_gait``)."""
    return map_local(play_gait, [(j, tuple(controllers)) for j in jobs], workers)


def envelope_report(
    jobs: list[GaitJob], verdicts: list[dict], controllers: tuple[str, ...], *, source: str,
    subset: str = "",
) -> str:  # fmt: skip
    """The markdown section (module doc) of ``compare_envelope``'s verdicts."""
    tags = [controller_tag(c) for c in controllers]
    cells = len({j.cell_id for j in jobs})
    lines = [
        "## Stability envelope: open loop vs controllers",
        "",
        f"The gaits of `{source}` ({cells} cells{subset}): per cell the max-margin gait "
        "(when it plans at 1 ms) and the min-work gait (when the GA found one), re-planned at "
        "1 ms from the table's parameters (no GA run again) and walked in each actuator mode "
        "the table played, open loop and with each controller "
        f"({', '.join(f'`{c}`' for c in controllers)}). A cell *walks* when that gait's "
        "strict walk verdict is `walked` (balanced, on its footprints, the swing foot off the "
        "plane, the pelvis at the end pose, every actuator within the servo's stall torque: "
        "`docs/verdicts.md`). Cells: how many walk; in brackets, the cells a "
        "controller gains and loses against open loop.",
        "",
        "| gait | mode | gaits played | open loop | " + " | ".join(tags) + " |",
        "|---" * (4 + len(tags)) + "|",
    ]
    changes = []
    tally = {tag: [0, 0, 0] for tag in tags}  # rows where it walks more, as many, fewer cells
    agree = compared = 0
    families = sorted({j.family for j in jobs}, key=lambda f: (f != "paper", f))
    for family, gait, mode in itertools.product(families, GAITS, ACTUATOR_MODES):
        name = GAIT_NAMES[gait] + (f" ({family})" if family != "paper" else "")
        picked = [
            (j, v) for j, v in zip(jobs, verdicts, strict=True)
            if j.family == family and j.gait == gait and mode in j.modes
        ]  # fmt: skip
        if not picked:
            continue
        base = [v[mode, None, WALK] == "walked" for _, v in picked]
        cells_text = []
        for controller, tag in zip(controllers, tags, strict=True):
            walks = [v[mode, controller, WALK] == "walked" for _, v in picked]
            gained = [j.label for (j, _), w, b in zip(picked, walks, base, strict=True) if w > b]
            lost = [j.label for (j, _), w, b in zip(picked, walks, base, strict=True) if w < b]
            cells_text.append(f"{sum(walks)} (+{len(gained)} −{len(lost)})")
            tally[tag][(sum(walks) <= sum(base)) + (sum(walks) < sum(base))] += 1
            if gained or lost:
                changes.append(
                    f"- {tag}, {name} gait, {mode}: "
                    + (f"gains {'; '.join(gained)}" if gained else "gains none")
                    + (f"; loses {'; '.join(lost)}" if lost else "")
                )
        lines.append(
            f"| {name} | {mode} | {len(picked)} | {sum(base)} | " + " | ".join(cells_text) + " |"
        )
        for j, v in picked:
            if j.table_verdicts.get(mode):
                compared += 1
                agree += j.table_verdicts[mode] == v[mode, None]
    lines.append("")
    for tag, (more, same, fewer) in tally.items():
        lines.append(
            f"- {tag} walks strictly more cells than open loop in {more} of these "
            f"{more + same + fewer} rows, as many in {same}, fewer in {fewer}."
        )
    if compared:
        lines += [
            "",
            f"The open-loop walks played again from the table's parameters (as rounded in the "
            f"table) have the table's balance verdict in {agree} of {compared} (gait, mode) walks; "
            "the others differ by that rounding or by a change of the bench since the table "
            "was written. The counts above compare like with like: open loop and controllers "
            "from the same re-planned gait.",
        ]
    lines += ["", "Cells gained (walk with the controller, not open loop) and lost:", ""]
    lines += changes or ["- none"]
    return "\n".join(lines) + "\n"
