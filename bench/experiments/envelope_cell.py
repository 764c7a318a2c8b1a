"""One cell of the stability envelope: the GA's two gaits, re-planned at 1 ms, played in MuJoCo.

A cell is a step time × slope × friction × robot × gait family. Its GA (the
paper's operators, ``ga.run_ga``, seeded) answers two questions:

- **max-margin**: the gait of largest minimum ZMP margin (treatment
  ``stability``, or a gait of larger margin the min-work search met on its way);
  the cell is *feasible* when that margin is ≥ 0 with every joint inside its
  limits: a gait with the ZMP inside the polygon exists.
- **min-work**: the least-work gait whose margin is ≥ the required margin
  (treatment ``margin`` on the margin minus the requirement); *found* when the
  GA has one.

Each gait the GA returns as admissible (joints inside their limits) is planned
again at 1 ms (``plan_walk``: its margin there is ``*_margin_1ms_mm``, never
below the GA's, which is that of the continuous walk) and played in every
actuator mode of the cell (``run_trial``): the simulated verdict and the RMS
distance of the simulated CoP from the planned ZMP. A min-work search that
found nothing is not played (its verdicts are empty). With a recording folder,
the max-margin gait's trial in the first mode is written to ``<cell_id>.rrd``.

``run_cell`` runs in a worker and never raises: a failure is the cell's
``error`` (verdicts ``error``). The table's columns are ``ENVELOPE``'s; one
verdict column pair per actuator mode of ``bench.sim.model.ACTUATOR_MODES``, so
a mode the bench gains joins the table by itself.
"""

from __future__ import annotations

import hashlib
import json
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bench.experiments.executor import one_line
from bench.experiments.sweep_table import SIMULATED_VERDICTS, TableFormat
from bench.experiments.sweep_trials import TIMESTEP, spec_text
from bench.sim.model import ACTUATOR_MODES
from planner.spec import RobotSpec

FAMILIES = ("paper",)  # (Hz, Szmax, θ1max), planner/gait_search.py
GAITS = ("maxmargin", "minwork")
GAIT_COLUMNS = ("found", "margin_mm", "margin_1ms_mm", "work_J", "hip_height_m",
                "swing_lift_m", "tilt_deg")  # fmt: skip


def sim_columns(gait: str, mode: str) -> tuple[str, str]:
    """(verdict, ZMP RMS) column names of ``gait`` played in ``mode``."""
    return f"{gait}_{mode}_verdict", f"{gait}_{mode}_zmp_rms_mm"


COLUMNS = (
    "cell_id",
    "step_time",  # [s], as written in the envelope file
    "slope_deg",
    "friction",
    "robot",
    "family",
    "steps",
    "population",
    "generations",
    "seed",
    "required_margin_mm",
    "feasible",  # the max-margin gait has its ZMP inside and every joint within limits
    *(f"{g}_{c}" for g in GAITS for c in GAIT_COLUMNS),
    *(c for g in GAITS for m in ACTUATOR_MODES for c in sim_columns(g, m)),
    "ga_evaluations",
    "error",
)
DECIMALS = {
    **{f"{g}_{c}": 4 for g in GAITS for c in ("margin_mm", "margin_1ms_mm")},
    **{f"{g}_work_J": 7 for g in GAITS},
    **{f"{g}_{c}": 7 for g in GAITS for c in ("hip_height_m", "swing_lift_m")},
    **{f"{g}_tilt_deg": 5 for g in GAITS},
    **{sim_columns(g, m)[1]: 4 for g in GAITS for m in ACTUATOR_MODES},
}
VERDICTS = ("", *SIMULATED_VERDICTS)  # "": not played (nothing found, or mode not asked)
ENVELOPE = TableFormat(
    "envelope",
    COLUMNS,
    DECIMALS,
    {"feasible": ("True", "False", "")}
    | {sim_columns(g, m)[0]: VERDICTS for g in GAITS for m in ACTUATOR_MODES},
)


@dataclass(frozen=True)
class SearchSettings:
    """The GA of every cell: population, generations, seed, families, required margin [m]."""

    population: int = 40
    generations: int = 30
    seed: int = 0
    families: tuple[str, ...] = ("paper",)
    required_margin: float = 0.005


@dataclass(frozen=True)
class EnvelopeCell:
    """One cell × family of an envelope file (degrees at this edge).

    Attributes:
        step_time: Step completion time [s]. slope_deg: Plane inclination [deg],
            negative downhill. friction: Coulomb μ.
        robot: The spec path as written, or "default". family: Gait family.
        steps: Steps per walk. search: The GA settings. modes: Actuator modes played.
        spec: The robot. spec_json: ``spec_text(spec)``, its part of the id.
        threads: numba threads of the cell's GA (not part of the id).
    """

    step_time: float
    slope_deg: float
    friction: float
    robot: str
    family: str
    steps: int
    search: SearchSettings
    modes: tuple[str, ...]
    spec: RobotSpec = field(repr=False, compare=False)
    spec_json: str = field(default="", repr=False, compare=False)
    threads: int = field(default=1, compare=False)

    @property
    def cell_id(self) -> str:
        """12 hex digits of a SHA-256 over everything that decides the cell's row."""
        key = {
            "step_time": self.step_time,
            "slope_deg": self.slope_deg,
            "friction": self.friction,
            "family": self.family,
            "steps": self.steps,
            "search": [self.search.population, self.search.generations, self.search.seed],
            "required_margin": self.search.required_margin,
            "modes": list(self.modes),
            "timestep": TIMESTEP,
            "spec": self.spec_json or spec_text(self.spec),
        }
        return hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:12]

    @property
    def label(self) -> str:
        text = f"T={self.step_time:g} s slope={self.slope_deg:g} mu={self.friction:g}"
        if self.family != "paper":
            text += f" {self.family}"
        return text + (f" robot {self.robot}" if self.robot != "default" else "")

    @property
    def slope(self) -> float:
        return float(np.deg2rad(self.slope_deg))

    def inputs(self) -> dict:
        return {
            "cell_id": self.cell_id,
            "step_time": self.step_time,
            "slope_deg": self.slope_deg,
            "friction": self.friction,
            "robot": self.robot,
            "family": self.family,
            "steps": self.steps,
            "population": self.search.population,
            "generations": self.search.generations,
            "seed": self.search.seed,
            "required_margin_mm": self.search.required_margin * 1e3,
        }

    def problem(self):
        """The GA's problem of this cell's family (``planner.gait_search.GaitProblem``)."""
        from planner.gait_search import GaitProblem, ga_params

        return GaitProblem(
            self.spec, ga_params(self.spec, self.step_time, self.slope, steps=self.steps)
        )

    def gait(self, x):
        """The walk of GA variables ``x`` at 1 ms (``GaitParams``)."""
        from planner.trajectory import GaitParams

        return GaitParams.nominal(
            self.spec,
            self.step_time,
            slope=self.slope,
            steps=self.steps,
            hip_height=float(x[0]),
            swing_lift=float(x[1]),
            tilt=float(x[2]),
        )


@dataclass(frozen=True)
class _Shifted:
    """A problem whose margin is reported less ``required`` [m]: "feasible" means margin ≥ it."""

    inner: object
    required: float

    @property
    def bounds(self):
        return self.inner.bounds

    def measure(self, X):
        from planner.gait_search import Measurement

        m = self.inner.measure(X)
        return Measurement(m.work, m.margin - self.required, m.joint_gap)


def error_row(cell: EnvelopeCell, cause: str) -> dict:
    """The row of a cell that raised or killed its worker."""
    verdicts = {sim_columns(g, m)[0]: "error" for g in GAITS for m in cell.modes}
    return cell.inputs() | verdicts | {"error": cause}


def run_cell(cell: EnvelopeCell, record_dir: str | None = None, *, simulate: bool = True) -> dict:
    """Search, re-plan and play one cell (module doc); its row. Never raises.

    Besides the table's columns the row carries ``ga_s`` and ``sim_s`` [s] (wall
    time of the searches and of planning and playing), which the table leaves out.
    """
    try:
        import numba

        numba.set_num_threads(max(1, min(cell.threads, numba.config.NUMBA_NUM_THREADS)))
        return _run(cell, record_dir, simulate)
    except Exception as err:  # a cell's failure is a result, not a crash of the envelope
        return error_row(cell, one_line(err))


def run_cell_search(cell: EnvelopeCell, record_dir: str | None = None) -> dict:
    """``run_cell`` without MuJoCo: the searches and the 1 ms re-plans only (no verdicts)."""
    return run_cell(cell, None, simulate=False)


def _run(cell: EnvelopeCell, record_dir: str | None, simulate: bool) -> dict:
    from bench.experiments.ga import GaSettings, run_ga

    s = cell.search
    problem = cell.problem()
    start = time.perf_counter()
    settings = {"population": s.population, "generations": s.generations, "seed": s.seed}
    stable = run_ga(problem, GaSettings(**settings, constraint="stability"))
    cheap = run_ga(
        _Shifted(problem, s.required_margin), GaSettings(**settings, constraint="margin")
    )
    ga_s = time.perf_counter() - start
    most = _most_stable(stable, cheap, s.required_margin)
    row = cell.inputs() | {
        "feasible": most.feasible,
        "ga_evaluations": stable.evaluations + cheap.evaluations,
        "error": "",
        "ga_s": ga_s,
    }
    start = time.perf_counter()
    for gait, best, margin, found in (
        ("maxmargin", most, most.margin, most.feasible),
        ("minwork", cheap.best, cheap.best.margin + s.required_margin, cheap.best.feasible),
    ):
        row |= {
            f"{gait}_found": found,
            f"{gait}_margin_mm": margin * 1e3,
            f"{gait}_work_J": best.work,
            f"{gait}_hip_height_m": float(best.x[0]),
            f"{gait}_swing_lift_m": float(best.x[1]),
            f"{gait}_tilt_deg": float(np.rad2deg(best.x[2])),
        }
        admissible = np.isfinite(best.work) and best.joint_gap <= 0
        if not admissible or (gait == "minwork" and not found):
            continue
        record = record_dir if gait == "maxmargin" else None
        row |= _play(cell, gait, best.x, record if simulate else None, simulate)
    row["sim_s"] = time.perf_counter() - start
    return row


def _most_stable(stable, cheap, required: float):
    """The max-margin gait: the stability search's best, unless the min-work search met a
    gait of larger margin on its way (both search the same walk; the min-work log holds
    margins less ``required``). Returns a ``ga.Best``."""
    from bench.experiments.ga import Best

    log = cheap.log
    ok = np.isfinite(log["work"]) & np.isfinite(log["margin"]) & (log["gap"] <= 0)
    if not ok.any():
        return stable.best
    i = int(np.flatnonzero(ok)[np.argmax(log["margin"][ok])])
    margin = float(log["margin"][i]) + required
    if stable.best.joint_gap <= 0 and margin <= stable.best.margin:
        return stable.best
    return Best(
        x=log["X"][i].copy(),
        work=float(log["work"][i]),
        margin=margin,
        joint_gap=float(log["gap"][i]),
        objective=-margin,
        feasible=margin >= 0,
    )


def _play(cell: EnvelopeCell, gait: str, x, record_dir: str | None, simulate: bool) -> dict:
    """Plan ``x`` at 1 ms and play it in every mode of the cell: its columns."""
    from bench.sim.trial import TrialSpec, run_trial
    from planner.plan import plan_walk

    params = cell.gait(x)
    plan = plan_walk(cell.spec, params)
    out = {f"{gait}_margin_1ms_mm": float(plan.margin.min()) * 1e3}
    if not simulate:
        return out
    for i, mode in enumerate(cell.modes):
        trial = TrialSpec(params, friction=cell.friction, actuators=mode, timestep=TIMESTEP)
        result = run_trial(cell.spec, trial, plan=plan)
        verdict, rms = sim_columns(gait, mode)
        out |= {verdict: result.simulated_verdict, rms: result.zmp_rms * 1e3}
        if record_dir is not None and i == 0:
            from bench.experiments.sweep import _record

            try:
                _record(Path(record_dir), cell.cell_id, plan, result)
            except Exception as err:  # the cell stands; a re-run with --record retries
                out["error"] = f"recording failed: {one_line(err)}"
    return out
