"""The trials the claims table needs (``report.claims``): it reads tables and writes
documents; the walks its figures show and the GA's best gaits are played here.

``claim_trials(spec, rows)``: of the walks the figures show, the nominal gait at 0.5 s
and 2 s on flat ground and at 22.5° (ZMP traces) and at 1 s on flat ground (joint
torques and angles), those whose case the sweep's ``rows`` of this robot hold (stiff
actuators, μ = 1, no mass scaling), each with the row's number of steps: a report
shows no walk its sweep did not run. ``play_ga_best(report, spec)``: the best gait of
a ``slopewalk optimize`` report played through the bench. ``paper_ga_trial(spec)``: the
paper's published 22.5° GA gait replayed. ``mass_servo_trials(spec)``: 10× mass with the
servo unscaled and scaled as the heavier robot would have it, beside the nominal robot.
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
    paper_ga: tuple[Plan, TrialResult] | None = None
    mass_servo: dict[tuple[str, str], TrialResult] | None = None


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
    paper = paper_ga_trial(spec) if case_steps(rows, NOMINAL_STEP_TIME, 22.5) else None
    steps = case_steps(rows, NOMINAL_STEP_TIME, 0.0)
    if steps is None:
        return ClaimTrials(cases, None, None, paper)
    mass = mass_servo_trials(spec, steps)
    plan, result = _play(spec, NOMINAL_STEP_TIME, 0.0, steps)
    return ClaimTrials(cases, plan, result, paper, mass)


# The paper's GA optimum at 22.5° (sec. VI): Hz 0.151 m, Szmax 0.013 m, θ1max = −9.18°. θ1 is
# the stance ankle roll, which undoes the lean λ (q1 = −λ, ``planner.joints``), so the lean's
# peak, ``GaitParams.tilt``, is +9.18°.
PAPER_GA_GAIT = {"hip_height": 0.151, "swing_lift": 0.013, "tilt": np.deg2rad(9.18)}
PAPER_GA_SLOPE = 22.5  # [deg]


def paper_ga_trial(spec: RobotSpec, steps: int = DEFAULT_STEPS) -> tuple[Plan, TrialResult]:
    """The paper's published 22.5° GA gait at t_c = 1 s, planned and played (stiff, μ = 1)."""
    gait = GaitParams.nominal(
        spec, NOMINAL_STEP_TIME, slope=np.deg2rad(PAPER_GA_SLOPE), steps=steps, **PAPER_GA_GAIT
    )
    plan = plan_walk(spec, gait)
    return plan, run_trial(spec, TrialSpec(gait, friction=CLAIM_FRICTION), plan=plan)


MASS_FACTOR = 10.0  # the paper's heavier robot: every link × 10
SERVO_MODES = ("servo", "servo_ff")  # the modes whose constants come from the spec's servo


def scaled_servo(spec: RobotSpec, factor: float) -> RobotSpec:
    """The servo a robot ``factor`` times heavier would carry: torque-type constants (stall
    torque, kp, kv, Coulomb friction) and the reflected rotor inertia (armature) × factor, the
    no-load speed unchanged, so every joint's torque per unit of its load, and with it each
    joint's motion, is the lighter robot's (the walk's torques scale with the mass)."""
    return dataclasses.replace(
        spec,
        stall_torque=spec.stall_torque * factor,
        stiffness=spec.stiffness * factor,
        velocity_gain=spec.velocity_gain * factor,
        friction_loss=spec.friction_loss * factor,
        armature=spec.armature * factor,
    )


def mass_servo_trials(spec: RobotSpec, steps: int) -> dict[tuple[str, str], TrialResult]:
    """The nominal gait at 1 s on flat ground in each ``SERVO_MODES`` mode (μ = 1) for the
    nominal robot, 10× mass with the servo unscaled and 10× mass with ``scaled_servo``:
    {(robot label, mode): result}, labels "nominal", "10× mass", "10× mass, servo × 10"."""
    heavy = spec.with_mass_scale({"all": MASS_FACTOR})
    robots = {"nominal": spec, "10× mass": heavy, "10× mass, servo × 10": scaled_servo(heavy, 10)}
    out = {}
    for label, robot in robots.items():
        gait = GaitParams.nominal(robot, NOMINAL_STEP_TIME, steps=steps)
        plan = plan_walk(robot, gait)
        for mode in SERVO_MODES:
            trial = TrialSpec(gait, friction=CLAIM_FRICTION, actuators=mode)
            out[(label, mode)] = run_trial(robot, trial, plan=plan)
    return out


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
