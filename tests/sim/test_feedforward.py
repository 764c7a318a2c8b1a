"""Torque feedforward: the plan's torque added to the position loop, clipped to the limit."""

import mujoco
import numpy as np
import pytest

from slopewalk.bench.sim.model import servo_settings
from slopewalk.bench.sim.playback import build_model, control_sequence, feedforward_torque, play
from slopewalk.bench.sim.trial import run_trial
from slopewalk.bench.sim.trial_spec import TrialSpec
from slopewalk.planner.compliance import torque_at_rest
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.joints import stance_swing_to_left_right
from slopewalk.planner.plan import plan_walk


@pytest.fixture(scope="module")
def plan(spec):
    return plan_walk(spec, GaitParams.nominal(spec, 2.0))


def test_servo_constants_come_from_the_spec(spec):
    from dataclasses import replace

    other = replace(spec, stiffness=20.0, velocity_gain=0.1, armature=0.01, friction_loss=0.02)
    servo = servo_settings(other, "servo_ff")
    assert (servo.kp, servo.kv, servo.armature, servo.frictionloss) == (20.0, 0.1, 0.01, 0.02)
    assert servo.force_limit == other.stall_torque and servo.feedforward
    assert servo_settings(other, "stiff").armature == 0.01
    assert not servo_settings(other, "servo").feedforward


def test_feedforward_widens_the_command_range_by_the_limit_over_kp(spec, plan):
    for mode in ("servo", "servo_ff"):
        model = build_model(plan, friction=1.0, actuators=mode, timestep=0.001)
        servo = servo_settings(spec, mode)
        widen = spec.stall_torque / spec.stiffness if mode == "servo_ff" else 0.0
        knee = model.actuator("l_knee")
        np.testing.assert_allclose(
            knee.ctrlrange, np.array(spec.joint_limits["knee"]) + [-widen, widen], atol=1e-5
        )  # the MJCF text carries 6 digits
        np.testing.assert_allclose(knee.forcerange, [-servo.force_limit, servo.force_limit])


def test_the_command_adds_the_torque_over_kp(spec, plan):
    """At the walk's start (q̇ = 0) the loop's force at the planned pose is τ + A q̈;
    while settling it is the first pose's torque at rest."""
    servo = servo_settings(spec, "servo_ff")
    t, command = control_sequence(plan, 0.001, 0.1, 0.0, servo)
    _, plain = control_sequence(plan, 0.001, 0.1, 0.0)
    start = np.flatnonzero(np.isclose(t, 0.0, atol=1e-9)).item()
    assert start == 100
    tau0 = feedforward_torque(plan, servo)[0]
    np.testing.assert_allclose(servo.kp * (command[start] - plain[start]), tau0, atol=1e-12)
    tau, qdd = (stance_swing_to_left_right(x, plan.stance)[0] for x in (plan.tau, plan.qdd))
    np.testing.assert_allclose(tau0, tau + spec.armature * qdd, atol=1e-12)
    assert np.abs(tau0).max() > 0.05  # a real load, not zero
    rest = stance_swing_to_left_right(torque_at_rest(plan)[None], plan.stance[:1])[0]
    for row in (0, start - 1):
        np.testing.assert_allclose(servo.kp * (command[row] - plain[row]), rest, atol=1e-12)
    assert np.abs(rest - tau0).max() > 1e-3  # the walk's first acceleration is not at rest


@pytest.mark.parametrize("step_time", [0.3, 1.0])
def test_the_robot_settles_at_the_first_pose(spec, step_time):
    """MuJoCo's robot, fed forward while it settles, stands at the plan's first pose.

    Measured at the settle's last row: joints within 0.35 deg of the plan (the rest is
    the floor's give, answered by the aim), both soles within 0.25 deg of flat. Holding
    the walk's first τ_ff instead (its inertial torque and A q̈(0) grow as 1/T²) leans
    the standing robot by up to 10.9 deg at 0.3 s and 1.6 deg at 1 s.
    """
    plan = plan_walk(spec, GaitParams.nominal(spec, step_time, steps=1))
    rec = play(plan, actuators="servo_ff")
    last = np.flatnonzero(rec.t < 0)[-1]
    error = np.abs(rec.sensors.q[last] - plan.q_left_right[0])
    assert np.degrees(error).max() < 1.0
    tilt = np.degrees(np.arccos(np.clip(rec.sensors.foot_normal[last, :, 2], -1, 1)))
    assert tilt.max() < 1.0


def test_feedforward_is_clipped_and_the_total_stays_within_the_limit(spec):
    """A weak servo (0.2 N m): τ_ff clipped to ±0.2 and the actuator force never beyond it."""
    from dataclasses import replace

    weak = replace(spec, stall_torque=0.2)
    plan = plan_walk(weak, GaitParams.nominal(weak, 1.0, steps=1))
    servo = servo_settings(weak, "servo_ff")
    assert np.abs(feedforward_torque(plan, servo)).max() == pytest.approx(0.2)
    rec = play(plan, actuators="servo_ff")
    assert np.abs(rec.sensors.actuator_force).max() <= 0.2 + 1e-9


@pytest.mark.parametrize("base", ["stiff", "servo"])
def test_feedforward_tracks_the_plan_better(spec, plan, base):
    """Flat ground, 2 s steps: the _ff loop follows the plan several times closer.

    Measured: stiff 0.35 deg -> stiff_ff 0.02 deg; servo falls (1.35 deg RMS while
    it stands) -> servo_ff walks with 0.19 deg.
    """
    plain = run_trial(spec, TrialSpec(plan.params, actuators=base), plan=plan)
    fed = run_trial(spec, TrialSpec(plan.params, actuators=f"{base}_ff"), plan=plan)
    assert fed.tracking_rms < plain.tracking_rms / 4
    assert fed.simulated_verdict == "stable"
    if base == "servo":
        assert plain.simulated_verdict != "stable"


def test_stiff_ff_model_compiles_without_warnings(spec, plan, caplog):
    model = build_model(plan, friction=1.0, actuators="stiff_ff", timestep=0.001)
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, 100)
    assert not any(data.warning[i].number for i in range(len(data.warning)))
