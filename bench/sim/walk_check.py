"""The strict walk verdict: did the simulated robot walk the plan?

The balance verdict (``events.verdict``: stable, slip, tip, fall, diverged) says whether
the robot kept its balance. A robot can keep its balance and still not walk the plan: drag
its swing foot, land elsewhere, or need torques its servos do not have. The walk verdict
(``walk_verdict``) adds four checks, each measured on the simulation, each with one
tolerance and its physical basis:

* ``off_footprint``: every landing lies within ``LANDING_TOLERANCE`` of its planned
  footprint in the plane and within ``HEADING_TOLERANCE`` of its planned heading. The
  plan's ZMP margin is measured against the planned footprints; a foot that lands
  ``LANDING_TOLERANCE`` (= ``SLIP_DISTANCE``, 5 mm) away has moved its edge of the support
  polygon as far as a slip does, and the margin no longer describes the walk. The heading
  tolerance is the turn that moves the sole's toe or heel by the same distance:
  ``LANDING_TOLERANCE`` / (half the foot length). A landing is measured where the landed
  foot is about to carry the robot alone: at the planned lift-off of the other foot (the
  end of the double support after its touch-down; the end of the walk for the last one),
  from the sole point under the ankle, relative to where the same foot stood at the first
  row of the trial (the plan's first pose, placed exactly), so a site offset of an imported
  model cancels.
* ``shuffle``: during each step's planned single support the swing sole stays off the
  plane, except for ``TOUCH_ALLOWANCE`` seconds. The plan lifts the swing foot off the
  plane at lift-off and sets it down at touch-down with zero normal velocity; the soft
  floor's give tilts the robot towards the swing foot so that its sole meets the plane
  ~1 mm, ~50 ms, early (``floor.py``), and a late lift-off mirrors it. One such window at
  each end of the swing: 2 × 50 ms = 0.1 s per step. A foot touching longer slides or
  drags over the plane while the plan has it in the air: a shuffle, not a step.
* ``pelvis_off``: at the end of the trial (after the hold at the last pose) the pelvis
  origin lies within ``PELVIS_TOLERANCE`` of the plan's last pelvis position: the landing
  tolerance (where its feet may stand) plus the turn a loaded foot may make before it is a
  tip (``TIP_ANGLE``) over the planned hip height.
* ``overload``: no actuator's torque over the walk reaches ``SATURATION`` of the spec's
  servo stall torque (``RobotSpec.stall_torque``; the Bioloid's AX-12A 1.5 N m). A stiff
  (ideal) actuator may be simulated, but a walk that needs more torque than the robot's
  servo gives is not that robot's walk; a spec servo (forcerange ± stall torque) at its
  limit no longer tracks the plan (the same ``SATURATION`` as the ``torque_limit`` event).

Verdict (``walk_verdict``): the balance verdict when it is not ``stable`` (the robot did not
stay up: nothing else can be judged); else the first failed check in the order overload,
shuffle, off_footprint, pelvis_off (a cause before its consequences: a dragged foot lands
off its footprint, a robot off its footprints ends off its end pose); else ``walked``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slopewalk.bench.sim.playback import Recording
from slopewalk.planner.joints import LEFT
from slopewalk.planner.kinematics import Chain
from slopewalk.planner.plan import Plan
from slopewalk.planner.verdict import SLIP_DISTANCE, TIP_ANGLE

# SATURATION, TOUCH_ALLOWANCE: one definition with the plan's prediction
# (planner/walk_prediction.py), their basis stated there and above.
from slopewalk.planner.walk_prediction import SATURATION, TOUCH_ALLOWANCE

LANDING_TOLERANCE = SLIP_DISTANCE  # [m] landing off its planned footprint, in the plane
WALK_CHECKS = ("overload", "shuffle", "off_footprint", "pelvis_off")  # in the verdict's order
WALK_VERDICTS = ("walked", *WALK_CHECKS)


def heading_tolerance(foot_length: float) -> float:
    """``HEADING_TOLERANCE`` [rad] of a foot ``foot_length`` [m] long: the turn that moves
    its toe or heel by ``LANDING_TOLERANCE`` (module doc)."""
    return LANDING_TOLERANCE / (foot_length / 2)


def pelvis_tolerance(hip_height: float) -> float:
    """``PELVIS_TOLERANCE`` [m] for a planned hip height [m] (module doc)."""
    return LANDING_TOLERANCE + hip_height * np.tan(TIP_ANGLE)


@dataclass(frozen=True)
class WalkMeasures:
    """What the strict checks measure in one trial (module doc); NaN where not measurable.

    Attributes:
        landing_error: Largest distance of a landing from its planned footprint in the
            plane [m].
        landing_heading_error: Largest |heading| difference of a landing from the plan's [rad].
        swing_touch: Longest time a swing foot touched the plane in one step's planned
            single support [s].
        pelvis_end_error: Distance of the pelvis origin at the end of the trial from the
            plan's last pelvis position [m].
        torque_ratio: Largest |actuator torque| over the walk / the spec's stall torque [-].
        heading_tolerance: The trial's ``HEADING_TOLERANCE`` [rad].
        pelvis_tolerance: The trial's ``PELVIS_TOLERANCE`` [m].
    """

    landing_error: float
    landing_heading_error: float
    swing_touch: float
    pelvis_end_error: float
    torque_ratio: float
    heading_tolerance: float
    pelvis_tolerance: float

    def failed(self) -> list[str]:
        """The checks this trial fails, in ``WALK_CHECKS`` order (NaN fails nothing)."""
        over = {
            "overload": self.torque_ratio >= SATURATION,
            "off_footprint": self.landing_error > LANDING_TOLERANCE
            or self.landing_heading_error > self.heading_tolerance,
            "shuffle": self.swing_touch > TOUCH_ALLOWANCE,
            "pelvis_off": self.pelvis_end_error > self.pelvis_tolerance,
        }
        return [k for k in WALK_CHECKS if over[k]]


def walk_verdict(balance: str, measures: WalkMeasures) -> str:
    """The strict verdict (module doc): ``balance`` unless ``stable``, else the first failed
    check, else ``walked``."""
    if balance != "stable":
        return balance
    failed = measures.failed()
    return failed[0] if failed else "walked"


def _heading(axis_x: np.ndarray) -> np.ndarray:
    """Heading in the plane [rad] of a foot x axis in S, (..., 3) -> (...)."""
    return np.arctan2(axis_x[..., 1], axis_x[..., 0])


def _row(t: np.ndarray, time: float) -> int:
    """The recording row at or just after ``time`` [s] (the last row if beyond)."""
    return min(int(np.searchsorted(t, time - 1e-9)), t.size - 1)


def _sample(plan: Plan, time: float) -> int:
    return min(int(np.searchsorted(plan.t, time - 1e-9)), plan.t.size - 1)


def _planned_sole(plan: Plan, i: int, side: int) -> np.ndarray:
    """The plan's sole point of foot ``side`` (0 left, 1 right) at sample ``i`` [m], (3,)."""
    return plan.stance_sole[i] if plan.stance[i] == side else plan.swing_sole[i]


def landing_errors(plan: Plan, recording: Recording) -> tuple[np.ndarray, np.ndarray]:
    """Each step's landing: distance from its planned footprint in the plane [m] and
    heading error [rad], (steps,) each (module doc: where and how it is measured)."""
    g = plan.params
    dsp = (1 - g.ssp_fraction) * g.step_time
    s, t = recording.sensors, recording.t
    start = {side: _planned_sole(plan, 0, side)[:2] for side in (0, 1)}  # left, right
    distance = np.full(g.steps, np.nan)
    heading = np.full(g.steps, np.nan)
    for k in range(g.steps):
        touch = (k + 1) * g.step_time
        mid_swing = touch - g.ssp_fraction * g.step_time / 2
        swing = 1 if plan.stance[_sample(plan, mid_swing)] == LEFT else 0
        i = _sample(plan, touch + dsp)  # the plan's sole where the simulated one is read
        planned = _planned_sole(plan, i, swing)[:2] - start[swing]
        row = _row(t, touch + dsp)
        moved = s.sole[row, swing, :2] - s.sole[0, swing, :2]
        distance[k] = float(np.hypot(*(moved - planned)))
        turn = _heading(s.foot_axis_x[row, swing]) - _heading(s.foot_axis_x[0, swing])
        heading[k] = float(abs(np.arctan2(np.sin(turn), np.cos(turn))))  # planned: no turn
    return distance, heading


def swing_touch_times(plan: Plan, recording: Recording) -> np.ndarray:
    """Each step's time [s] its swing foot touched the plane (contact normal force > 0)
    during the step's planned single support, (steps,)."""
    g = plan.params
    dsp = (1 - g.ssp_fraction) * g.step_time
    t = recording.t
    dt = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    contact = recording.sensors.foot_force[..., 2] > 0.0
    out = np.zeros(g.steps)
    for k in range(g.steps):
        lift_off, touch = k * g.step_time + dsp, (k + 1) * g.step_time
        swing = 1 if plan.stance[_sample(plan, (lift_off + touch) / 2)] == LEFT else 0
        rows = (t >= lift_off) & (t < touch)
        out[k] = float(contact[rows, swing].sum() * dt)
    return out


def planned_end_pelvis(plan: Plan) -> np.ndarray:
    """The pelvis origin in S at the plan's last sample [m], (3,)."""
    chain = Chain.from_spec(plan.spec)
    frames = chain.frames(plan.q[-1:], plan.stance_sole[-1:], plan.stance[-1:])
    (origin,), _ = chain.pelvis_pose(frames, plan.stance[-1:])
    return origin


def measure(plan: Plan, recording: Recording, rotation_slope_to_world) -> WalkMeasures:
    """The strict checks' measures of one trial (module doc).

    Args:
        plan: The walk played.
        recording: Its simulation (``sensors`` in S).
        rotation_slope_to_world: R with v_W = R v_S, (3, 3), to bring the pelvis into S.
    """
    t = recording.t
    walk = (t >= plan.t[0]) & (t <= plan.t[-1])
    distance, heading = landing_errors(plan, recording)
    pelvis = recording.sensors.pelvis_qpos[-1, :3] @ np.asarray(rotation_slope_to_world)
    force = np.abs(recording.sensors.actuator_force[walk])
    finite = np.isfinite(pelvis).all() and recording.diverged_at is None
    return WalkMeasures(
        landing_error=float(np.max(distance, initial=0.0)),
        landing_heading_error=float(np.max(heading, initial=0.0)),
        swing_touch=float(np.max(swing_touch_times(plan, recording), initial=0.0)),
        pelvis_end_error=float(np.linalg.norm(pelvis - planned_end_pelvis(plan)))
        if finite
        else float("nan"),
        torque_ratio=float(force.max(initial=0.0) / plan.spec.stall_torque),
        heading_tolerance=heading_tolerance(plan.spec.foot_length),
        pelvis_tolerance=pelvis_tolerance(plan.params.hip_height),
    )
