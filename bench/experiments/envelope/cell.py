"""One cell of the stability envelope: the GA's two gaits, re-planned at 1 ms, played in MuJoCo.

A cell is a step time × slope × friction × robot × gait family. Its GA (the
paper's operators, ``ga.run_ga``, seeded) answers two questions:

- **max-margin**: the gait of largest minimum ZMP margin (treatment
  ``stability``; any individual of either search counts, since both search the
  same walk);
  the cell is *feasible* when that margin is ≥ 0 with every joint inside its
  limits: a gait with the ZMP inside the polygon exists.
- **min-work**: the least-work gait whose margin is ≥ the required margin
  (treatment ``margin`` on the margin minus the requirement); *found* when the
  GA has one.

A chosen gait must also plan at 1 ms: one whose legs overreach between the GA's
samples is passed over for the next best (``_choose``).

Each gait the GA returns as admissible (joints inside their limits) is planned
again at 1 ms (``plan_walk``: its margin there is ``*_margin_1ms_mm``, never
below the GA's, which is that of the continuous walk) and played in every
actuator mode of the cell (``run_trial``): the simulated verdict and the RMS
distance of the simulated CoP from the planned ZMP. A min-work search that
found nothing is not played (its verdicts are empty). With a recording folder,
the max-margin gait's trial in the first mode is written to ``<cell_id>.rrd``.

With controllers (the envelope file's ``controller`` key: ``MODULE:CALLABLE``
names, ``bench.controllers``) each played gait is also walked, in every mode,
closed loop by each of them (``TrialSpec.controller``: the same events and ZMP
comparison), into the columns ``<gait>_<mode>_<tag>_verdict`` and ``…_zmp_rms_mm``
(``tag``: the callable's name, ``controller_tag``); the recording of each is
``<cell_id>_<tag>.rrd``, marked with the controller's name.

``run_cell`` runs in a worker and never raises: a failure is the cell's
``error`` (verdicts ``error``). The table's columns are ``tables.envelope.ENVELOPE``'s; one
verdict column pair per actuator mode of ``slopewalk.bench.sim.model.ACTUATOR_MODES``, so
a mode the bench gains joins the table by itself; with controllers,
``envelope_format(controllers)`` appends theirs after every other column, so
each open-loop column keeps its place.
"""

from __future__ import annotations

import hashlib
import json
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from slopewalk.bench.batch.executor import one_line
from slopewalk.bench.experiments.sweep.trials import TIMESTEP, model_inputs, spec_text
from slopewalk.bench.robot_import.model_file import ModelFile
from slopewalk.bench.tables.envelope import (
    GAITS,
    REPLAN_NOTE,
    controller_tag,
    sim_columns,
    walk_column,
)
from slopewalk.planner.spec import RobotSpec

# (Hz, Szmax, θ1max) and (…, δ, L, w): planner/gait_search.py's FAMILIES
FAMILIES = ("paper", "extended")
MAX_REPLANS = 256  # distinct candidates tried per gait when the best cannot be planned at 1 ms
DENSE = 32  # of them, the best ones tried in order before the ranking is sampled
AGREEMENT_TOL = 1e-6  # [m] a 1 ms plan's margin may not fall further below the GA's


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
        controllers: ``MODULE:CALLABLE`` of the controllers each played gait is also
            walked with (part of the id only when there are some: open-loop ids stay).
        threads: numba threads of the cell's GA (not part of the id).
        model: The unmodified model each gait is played on (``envelope --model``), ``spec``
            its imported spec; None: the spec's twin. Part of the id only when set.
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
    controllers: tuple[str, ...] = ()
    threads: int = field(default=1, compare=False)
    model: ModelFile | None = None

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
        if self.controllers:  # only then: the open-loop ids stay what they were
            key["controllers"] = list(self.controllers)
        if self.model is not None:  # likewise: the twin's ids stay; the files' digest
            key["model"] = self.model.digest
        return hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:12]

    @property
    def label(self) -> str:
        text = f"T={self.step_time:g} s slope={self.slope_deg:g} mu={self.friction:g}"
        if self.family != "paper":
            text += f" {self.family}"
        text += f" robot {self.robot}" if self.robot != "default" else ""
        return text + (f" model {self.model.name}" if self.model is not None else "")

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
        } | model_inputs(self.model)

    def problem(self):
        """The GA's problem of this cell's family (``planner.gait_search.GaitProblem``)."""
        from slopewalk.planner.gait_search import GaitProblem, ga_params

        params = ga_params(self.spec, self.step_time, self.slope, steps=self.steps)
        return GaitProblem(self.spec, params, family=self.family, friction=self.friction)

    def gait(self, x):
        """The walk of GA variables ``x`` at 1 ms (``GaitParams``): (Hz, Szmax, tilt), and
        (δ, L, w) for the extended family."""
        from slopewalk.planner.gait import GaitParams

        extra = {}
        if len(x) == 6:
            extra = {
                "pelvis_offset": float(x[3]),
                "step_length": float(x[4]),
                "sway_share": float(x[5]),
            }
        return GaitParams.nominal(
            self.spec,
            self.step_time,
            slope=self.slope,
            steps=self.steps,
            hip_height=float(x[0]),
            swing_lift=float(x[1]),
            tilt=float(x[2]),
            **extra,
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
        from slopewalk.planner.gait_search import Measurement

        m = self.inner.measure(X)
        return Measurement(
            m.work, m.margin - self.required, m.joint_gap, m.friction_gap, m.slide_gap
        )


def error_row(cell: EnvelopeCell, cause: str) -> dict:
    """The row of a cell that raised or killed its worker."""
    tags = ["", *(controller_tag(c) for c in cell.controllers)]
    verdicts = {
        c: "error"
        for g in GAITS
        for m in cell.modes
        for t in tags
        for c in (sim_columns(g, m, t)[0], walk_column(g, m, t))
    }
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


def run_cell_stability(cell: EnvelopeCell) -> dict:
    """The cell's first question alone: the max-margin search (treatment ``stability``, the
    cell's GA settings) and the 1 ms re-plan of its best gait (``_choose``), no min-work
    search, no MuJoCo. Its row: ``feasible``, the ``maxmargin_*`` columns, ``error``.

    ``slopewalk bands`` asks this of many specs; without the min-work search's individuals
    its max margin can only be ≤ ``run_cell``'s (the same search, a smaller pool).
    """
    from slopewalk.bench.experiments.ga.search import GaSettings, run_ga

    s = cell.search
    settings = {"population": s.population, "generations": s.generations, "seed": s.seed}
    stable = run_ga(cell.problem(), GaSettings(**settings, constraint="stability"))
    pool = _Pool.of(stable, None, 0.0)
    row = {"error": ""} | _choose(
        cell, "maxmargin", pool, pool.most_stable(), stable.best, 0.0, None, False
    )
    return row | {"feasible": row["maxmargin_found"]}


def _run(cell: EnvelopeCell, record_dir: str | None, simulate: bool) -> dict:
    from slopewalk.bench.experiments.ga.search import GaSettings, run_ga

    s = cell.search
    problem = cell.problem()
    start = time.perf_counter()
    settings = {"population": s.population, "generations": s.generations, "seed": s.seed}
    stable = run_ga(problem, GaSettings(**settings, constraint="stability"))
    cheap = run_ga(
        _Shifted(problem, s.required_margin), GaSettings(**settings, constraint="margin")
    )
    ga_s = time.perf_counter() - start
    row = cell.inputs() | {
        "ga_evaluations": stable.evaluations + cheap.evaluations,
        "error": "",
        "ga_s": ga_s,
    }
    start = time.perf_counter()
    pool = _Pool.of(stable, cheap, s.required_margin)
    for gait, order, fallback in (
        ("maxmargin", pool.most_stable(), stable.best),
        ("minwork", pool.least_work(s.required_margin), cheap.best),
    ):
        row |= _choose(cell, gait, pool, order, fallback, s.required_margin, record_dir, simulate)
    row["feasible"] = row["maxmargin_found"]
    row["sim_s"] = time.perf_counter() - start
    return row


@dataclass(frozen=True)
class _Pool:
    """Every individual both searches evaluated (they search the same walk): X, work,
    true margin [m] (the min-work log's margins are shifted back), joint gap [rad], and
    the friction [-] and slide [m] gaps (``gait_search.Measurement``)."""

    X: np.ndarray
    work: np.ndarray
    margin: np.ndarray
    gap: np.ndarray
    friction_gap: np.ndarray
    slide_gap: np.ndarray

    @classmethod
    def of(cls, stable, cheap, required: float) -> _Pool:
        """The pool of both searches; ``cheap`` None: of the max-margin search alone."""
        if cheap is None:
            a = stable.log
            return cls(a["X"], a["work"], a["margin"], a["gap"], a["friction_gap"],
                       a["slide_gap"])  # fmt: skip
        a, b = stable.log, cheap.log
        return cls(
            np.concatenate([a["X"], b["X"]]),
            np.concatenate([a["work"], b["work"]]),
            np.concatenate([a["margin"], b["margin"] + required]),
            np.concatenate([a["gap"], b["gap"]]),
            np.concatenate([a["friction_gap"], b["friction_gap"]]),
            np.concatenate([a["slide_gap"], b["slide_gap"]]),
        )

    @property
    def admissible(self) -> np.ndarray:
        contact = (self.friction_gap <= 0) & (self.slide_gap <= 0)
        return np.isfinite(self.work) & np.isfinite(self.margin) & (self.gap <= 0) & contact

    def most_stable(self) -> np.ndarray:
        """Admissible individuals, largest margin first."""
        ok = np.flatnonzero(self.admissible)
        return ok[np.argsort(-self.margin[ok], kind="stable")]

    def least_work(self, required: float) -> np.ndarray:
        """Admissible individuals of margin ≥ ``required``, least work first."""
        ok = np.flatnonzero(self.admissible & (self.margin >= required))
        return ok[np.argsort(self.work[ok], kind="stable")]


def _choose(cell, gait, pool, order, fallback, required, record_dir, simulate) -> dict:
    """The columns of ``gait``: the first of ``order`` that can be planned at 1 ms, played.

    The GA samples a walk at 100 points per step; a gait whose legs are straight at
    those points may overreach between them, which a 1 ms plan finds
    (``UnreachableError``), or pass so near the straight knee that the 1 ms plan's
    joint accelerations, and with them its ZMP, are not what the GA scored (its 1 ms
    margin falls below the GA's, which it never may: ``plan.py``). Such a gait is
    passed over for the next candidate (``_spread``): the gait reported is the best of
    those tried that plans as the GA scored it. With
    no candidate (nothing admissible, or nothing of the required margin) the
    search's own best is reported, ``found`` False, and not played.
    """
    from slopewalk.planner.errors import UnreachableError
    from slopewalk.planner.plan import plan_walk

    failures = []
    for i in _spread(order, pool.X):
        x, margin = pool.X[i], float(pool.margin[i])
        try:
            plan = plan_walk(cell.spec, cell.gait(x))
        except UnreachableError as err:
            failures.append(one_line(err))
            continue
        fine = float(plan.margin.min())
        if fine < margin - AGREEMENT_TOL:
            failures.append(
                f"re-planned at 1 ms its margin is {fine * 1e3:.1f} mm, not {margin * 1e3:.1f}"
            )
            continue
        found = margin >= (required if gait == "minwork" else 0.0)
        columns = _gait_columns(cell, gait, x, float(pool.work[i]), margin, found)
        columns[f"{gait}_margin_1ms_mm"] = fine * 1e3
        if simulate:
            columns |= _play(cell, gait, plan, record_dir if gait == "maxmargin" else None)
        return columns
    best_margin = fallback.margin + (required if gait == "minwork" else 0.0)
    columns = _gait_columns(cell, gait, fallback.x, fallback.work, best_margin, False)
    if failures:
        columns["error"] = (
            f"{REPLAN_NOTE} {gait}: none of the {len(failures)} best distinct gaits plans at "
            f"1 ms as scored ({failures[0]})"
        )
    return columns


def _spread(order: np.ndarray, X: np.ndarray) -> np.ndarray:
    """At most ``MAX_REPLANS`` distinct candidates of ``order``: its first ``DENSE`` in
    order, then ranks spaced geometrically down the rest (a GA converged on a
    straight-leg corner holds hundreds of near copies of it: the next plannable gait
    may lie far down the ranking)."""
    _, first = np.unique(X[order], axis=0, return_index=True)
    distinct = order[np.sort(first)]
    if distinct.size <= MAX_REPLANS:
        return distinct
    ranks = np.geomspace(DENSE, distinct.size - 1, MAX_REPLANS - DENSE).astype(int)
    return distinct[np.unique(np.concatenate([np.arange(DENSE), ranks]))]


def _gait_columns(cell, gait: str, x, work: float, margin: float, found: bool) -> dict:
    params = cell.gait(x)  # a paper row: the walk's own δ, L and w
    return {
        f"{gait}_found": bool(found),
        f"{gait}_margin_mm": margin * 1e3,
        f"{gait}_work_J": work,
        f"{gait}_hip_height_m": float(x[0]),
        f"{gait}_swing_lift_m": float(x[1]),
        f"{gait}_tilt_deg": float(np.rad2deg(x[2])),
        f"{gait}_pelvis_offset_m": params.pelvis_offset,
        f"{gait}_step_length_m": params.step_length,
        f"{gait}_sway_share": params.lean_share,
    }


def _play(cell: EnvelopeCell, gait: str, plan, record_dir: str | None) -> dict:
    """Play a 1 ms ``plan`` in every mode of the cell, open loop and with each of its
    controllers: their verdict and ZMP RMS columns."""
    from slopewalk.bench.sim.trial import run_trial
    from slopewalk.bench.sim.trial_spec import TrialSpec

    out = {}
    scene = None if cell.model is None else cell.model.scene(cell.spec)  # checked, fitted once
    for i, mode in enumerate(cell.modes):
        for controller in (None, *cell.controllers):
            trial = TrialSpec(
                plan.params,
                friction=cell.friction,
                actuators=mode,
                timestep=TIMESTEP,
                controller=controller,
            )
            # the simulated columns only
            result = run_trial(cell.spec, trial, plan=plan, predict=False, scene=scene)
            tag = controller_tag(controller) if controller else ""
            verdict, rms = sim_columns(gait, mode, tag)
            out |= {
                verdict: result.simulated_verdict,
                rms: result.zmp_rms * 1e3,
                walk_column(gait, mode, tag): result.walk_verdict,
            }
            if record_dir is not None and i == 0:
                from slopewalk.bench.experiments.sweep.run import _record

                name = f"{cell.cell_id}_{tag}" if tag else cell.cell_id
                try:
                    _record(Path(record_dir), name, plan, result, scene)
                except Exception as err:  # the cell stands; a re-run with --record retries
                    out["error"] = f"recording failed: {one_line(err)}"
    return out
