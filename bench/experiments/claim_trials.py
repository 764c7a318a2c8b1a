"""The trials the claims table needs (``report.claims``): it reads tables and writes
documents; the walks its figures show and the GA's best gaits are played here.

``claim_trials(spec, rows)``: of the walks the figures show, the nominal gait at 0.5 s
and 2 s on flat ground and at 22.5° (ZMP traces) and at 1 s on flat ground (joint
torques and angles), those whose case the sweep's ``rows`` of this robot hold (stiff
actuators, μ = 1, no mass scaling), each with the row's number of steps: a report
shows no walk its sweep did not run. ``play_ga_best(report, spec)``: the best gait of
a ``slopewalk optimize`` report played through the bench.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from slopewalk.bench.actuators import DEFAULT_MODE
from slopewalk.bench.sim.trial import TrialResult, TrialSpec, run_trial
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import Plan, plan_walk
from slopewalk.planner.spec import RobotSpec

NOMINAL_STEP_TIME = 1.0  # [s], the paper's step time for the slope claims
CLAIM_FRICTION = 1.0  # μ of every walk the figures show
DEFAULT_STEPS = 4  # ``GaitParams``' default, the paper sweep's
ZMP_TRACE_CASES = (  # (title, step time [s], slope [deg])
    ("flat, t_c = 0.5 s", 0.5, 0.0),
    ("22.5°, t_c = 1 s", NOMINAL_STEP_TIME, 22.5),
    ("flat, t_c = 2 s", 2.0, 0.0),
)


@dataclass(frozen=True)
class ClaimTrials:
    """The walks the claims' figures show.

    Attributes:
        cases: (title, plan, result) of each ``ZMP_TRACE_CASES`` walk the sweep holds.
        nominal: The nominal gait at ``NOMINAL_STEP_TIME`` on flat ground; None when
            the sweep does not hold that case.
        nominal_result: ``nominal`` played in MuJoCo (stiff actuators); None with it.
    """

    cases: list[tuple[str, Plan, TrialResult]]
    nominal: Plan | None
    nominal_result: TrialResult | None


def case_steps(rows: list[dict] | None, step_time: float, slope_deg: float) -> int | None:
    """Steps of the sweep's row of this case (stiff, μ = 1, no mass scaling), None if
    ``rows`` hold no such row; with ``rows`` None, the nominal gait's default steps."""
    if rows is None:
        return DEFAULT_STEPS
    for r in rows:
        if (
            r["step_time"] == step_time
            and r["slope_deg"] == slope_deg
            and r["friction"] == CLAIM_FRICTION
            and r["actuators"] == DEFAULT_MODE
            and not r["mass_scale"]
        ):
            return int(r["steps"])
    return None


def _play(spec: RobotSpec, step_time: float, slope_deg: float, steps: int):
    gait = GaitParams.nominal(spec, step_time, slope=np.deg2rad(slope_deg), steps=steps)
    plan = plan_walk(spec, gait)
    return plan, run_trial(spec, TrialSpec(plan.params, friction=CLAIM_FRICTION), plan=plan)


def claim_trials(spec: RobotSpec, rows: list[dict] | None = None) -> ClaimTrials:
    """Plan and play the walks of ``ClaimTrials`` for ``spec`` (stiff actuators, μ = 1):
    those whose case ``rows`` (the sweep's rows of this robot) hold; all with None."""
    cases = []
    for title, step_time, slope in ZMP_TRACE_CASES:
        steps = case_steps(rows, step_time, slope)
        if steps is not None:
            cases.append((title, *_play(spec, step_time, slope, steps)))
    steps = case_steps(rows, NOMINAL_STEP_TIME, 0.0)
    if steps is None:
        return ClaimTrials(cases, None, None)
    return ClaimTrials(cases, *_play(spec, NOMINAL_STEP_TIME, 0.0, steps))


def play_ga_best(report: dict, spec: RobotSpec) -> tuple[str, bool | None]:
    """Play the best gait of one ``slopewalk optimize`` report in MuJoCo (stiff actuators):
    (what it did, in words; walked, or None when there is no feasible gait to play)."""
    if not report["feasible"]:
        return "no feasible gait to play", None
    robot = spec.with_foot_length(report["foot_length_m"], extend="both")
    robot = dataclasses.replace(robot, ankle_to_toe=report["ankle_to_toe_m"])
    best = report["best"]
    gait = GaitParams.nominal(
        robot,
        report["step_time_s"],
        slope=np.deg2rad(report["slope_deg"]),
        hip_height=best["hip_height_m"],
        swing_lift=best["swing_lift_m"],
        tilt=np.deg2rad(best["tilt_deg"]),
    )
    result = run_trial(robot, TrialSpec(gait))
    text = (
        f"{result.simulated_verdict} (ZMP RMS {result.zmp_rms * 1e3:.1f} mm, events: "
        f"{', '.join(sorted({e.kind for e in result.events})) or 'none'})"
    )
    return text, result.simulated_verdict == "stable"
