"""One simulated flat walk for ``cop_error``: the command and the floor's feedforward chosen.

``simulate`` plays a plan as ``playback.play`` does, through the same
``playback.play_commands`` (its initial state, rollout and recording), with what the
command answers chosen case by case: the floor's give and sink
(``playback.floor_feedforward``) also in a mode without feedforward, terms of the
loop's torque added as positions / kp (``lead_torque``), the joints' dry friction fed
forward (``friction_sign``) or taken out of MuJoCo, and the contact's time constant and
the time step. ``run_case`` compares the walk with its plan as ``slopewalk trial`` does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slopewalk.bench.sim.floor import SoftFloor
from slopewalk.bench.sim.model import Servo, servo_settings
from slopewalk.bench.sim.playback import (
    HOLD_TIME,
    SETTLE_TIME,
    Recording,
    build_model,
    commands_and_aim,
    floor_feedforward,
    loop_torque,
    on_rows,
    play_commands,
    settle_rows,
)
from slopewalk.bench.sim.trial import TrialResult, compare
from slopewalk.bench.sim.trial_spec import TrialSpec
from slopewalk.planner.compliance import torque_at_rest
from slopewalk.planner.joints import stance_swing_to_left_right
from slopewalk.planner.plan import Plan

STEP_TIME, FRICTION, STEPS = 2.0, 1.0, 4
REST = 1e-9  # a joint is still below this share of its peak planned speed (roundoff)


@dataclass(frozen=True)
class Case:
    """One simulated walk and its comparison with the plan."""

    label: str
    result: TrialResult
    recording: Recording


def lead_torque(plan: Plan, servo: Servo, terms: tuple[str, ...]) -> np.ndarray:
    """``playback.loop_torque``'s ``terms``, MJCF order [N m], (n, 8) on ``plan.t``: the
    torque whose static lag / kp they add to the command (in ``LOOP_TERMS``' order the
    sum is ``feedforward_torque``'s, unclipped)."""
    return stance_swing_to_left_right(loop_torque(plan, servo, terms), plan.stance)


def lead_at_rest(plan: Plan, terms: tuple[str, ...]) -> np.ndarray:
    """``lead_torque`` while the robot settles at the first pose, MJCF order [N m], (8,):
    the torque at rest (``compliance.torque_at_rest``) if "torque" is in ``terms``; the
    rotor's and the rate's terms are zero at rest (as ``playback.settle_feedforward``)."""
    rest = torque_at_rest(plan) if "torque" in terms else np.zeros(plan.q.shape[1])
    return stance_swing_to_left_right(rest[None], plan.stance[:1])[0]


def friction_sign(qd: np.ndarray, *, held: bool) -> np.ndarray:
    """Sign of the motion each joint's dry friction resists, (n, k): the planned speed's,
    0 where the plan holds the joint still; with ``held`` the sign of its last motion
    there (0 before its first).

    A position loop with dry friction f stops a joint short of its command, at the edge
    of the deadband f / kp it approached from; pushing from that side puts it on its
    command, if the load has not moved it across the band since. Still is |q̇| ≤ ``REST``
    × the joint's peak |q̇|: the splines' roundoff (the lean's rate is ±1e-15 rad/s at
    each lift-off, against 0.1-2 rad/s when it moves), whose sign is noise.
    """
    qd = np.asarray(qd, dtype=float)
    peak = np.abs(qd).max(axis=0, initial=0.0)
    s = np.where(np.abs(qd) > REST * peak, np.sign(qd), 0.0)
    if not held:
        return s
    rows = np.arange(s.shape[0])[:, None]
    last = np.maximum.accumulate(np.where(s != 0, rows, 0), axis=0)  # last moving row
    return np.take_along_axis(s, last, axis=0)


def simulate(
    plan: Plan,
    actuators: str,
    *,
    floor_ff: str | None = None,
    leads: tuple[str, ...] = (),
    joint_friction: bool = True,
    friction_ff: str | None = None,
    timeconst: float | None = None,
    timestep: float = 0.001,
) -> Recording:
    """Play ``plan`` as ``playback.play`` does, with the contacts' solref time constant
    ``timeconst`` [s] and step ``timestep`` [s].

    Args:
        floor_ff: What of the floor's deflection the command answers, also in a mode
            without feedforward: "rigid" nothing, "give" the ankles turned against each
            sole's give, "sink" that and the legs shortened by the soles' sink
            (``playback.floor_feedforward``); None: as the mode does ("sink" in a "_ff"
            mode, "rigid" otherwise).
        leads: ``lead_torque``'s terms, / kp, added to the command of a mode without
            feedforward before the floor's offsets (the order in which
            ``commands_and_aim`` adds a "_ff" mode's).
        joint_friction: False: the joints' friction loss set to 0 in MuJoCo.
        friction_ff: The dry friction f added to the command as f s / kp: None none,
            "moving" or "held" (``friction_sign``'s ``held``).
    """
    model = build_model(plan, friction=FRICTION, actuators=actuators, timestep=timestep)
    if timeconst is not None:
        model.geom_solref[:, 0] = timeconst  # floor and feet: the contact's is theirs
    servo = servo_settings(plan.spec, actuators)
    floor = SoftFloor.of_scene(model)
    own = "sink" if servo.feedforward else "rigid"
    t, q_ref, aim = commands_and_aim(
        plan, timestep, SETTLE_TIME, HOLD_TIME, servo, floor if floor_ff in (None, own) else None
    )
    if leads:
        if servo.feedforward:
            raise ValueError(f"leads {leads!r}: only for a mode without feedforward")
        lead = on_rows(t, plan, lead_torque(plan, servo, leads))
        lead[: settle_rows(timestep, SETTLE_TIME)] = lead_at_rest(plan, leads)
        q_ref = q_ref + lead / servo.kp
    if not joint_friction:
        model.dof_frictionloss[:] = 0.0
    if friction_ff is not None:
        sign = friction_sign(plan.qd, held=friction_ff == "held")
        friction = stance_swing_to_left_right(servo.frictionloss * sign, plan.stance)
        q_ref = q_ref + on_rows(t, plan, friction) / servo.kp
    if floor_ff not in (None, own, "rigid"):
        aim = on_rows(t, plan, floor_feedforward(plan, floor, touchdown=floor_ff == "sink"))
        q_ref = q_ref + aim
    (recording,) = play_commands(model, [plan], [q_ref], t, servo.force_limit, aims=[aim])
    return recording


def run_case(plan: Plan, actuators: str, label: str, **options) -> Case:
    """``simulate``'s walk compared with the plan as ``slopewalk trial`` does."""
    recording = simulate(plan, actuators, **options)
    trial = TrialSpec(plan.params, friction=FRICTION, actuators=actuators)
    return Case(label, compare(plan, trial, recording, wall_s=0.0), recording)
