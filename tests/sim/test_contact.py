"""Simulated CoP and events against MuJoCo's raw contact data, and the issue's pitfalls."""

import mujoco
import numpy as np
import pytest

from slopewalk.bench.sim.contact import decode
from slopewalk.bench.sim.events import SLIP_DISTANCE, detect, verdict
from slopewalk.bench.sim.playback import build_model, initial_state, play
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.kinematics import rotation_slope_to_world
from slopewalk.planner.plan import plan_walk


def _contact_force_path(model, data, R):
    """Per-foot normal force and CoP from data.contact + mj_contactForce (the reference).

    mj_contactForce gives the force in the contact frame; contact.frame holds the
    frame's axes as rows, normal first, normal from geom1 to geom2; the floor is
    geom1. Points are projected onto the plane before averaging.
    """
    out = {}
    for foot in ("l_foot", "r_foot"):
        gid = model.geom(foot).id
        total, moment = np.zeros(3), np.zeros(2)
        for i in range(data.ncon):
            c = data.contact[i]
            if gid not in c.geom:
                continue
            assert c.geom[0] == model.geom("floor").id
            f = np.zeros(6)
            mujoco.mj_contactForce(model, data, i, f)
            world = c.frame.reshape(3, 3).T @ f[:3]  # force of floor on foot, world
            point = R.T @ c.pos  # in S
            force = R.T @ world
            total += force
            moment += force[2] * point[:2]  # projected onto z_S = 0
        out[foot] = (total, moment / total[2] if total[2] > 0 else np.full(2, np.nan))
    return out


@pytest.mark.parametrize("slope_deg", [0.0, 20.0])
def test_sensor_cop_equals_mj_contact_force_path(spec, slope_deg):
    """Decoded per-foot forces and CoPs equal the mj_contactForce computation, mid-walk."""
    plan = plan_walk(spec, GaitParams.nominal(spec, 1.0, slope=np.deg2rad(slope_deg)))
    model = build_model(plan, friction=1.0, actuators="stiff", timestep=0.001)
    data = mujoco.MjData(model)
    mujoco.mj_setState(model, data, initial_state(model, plan), mujoco.mjtState.mjSTATE_FULLPHYSICS)
    R = rotation_slope_to_world(plan.params.slope)
    checked = 0
    for k in range(1800):
        data.ctrl[:] = plan.q_left_right[min(max(k - 500, 0), plan.t.size - 1)]
        mujoco.mj_step(model, data)
        if k % 97 == 0:
            mujoco.mj_forward(model, data)  # sensors of the current state
            sensors = decode(model, data.sensordata[None].copy(), R)
            reference = _contact_force_path(model, data, R)
            # The scene passes through MJCF text (6 significant digits), so the plane's
            # normal and our slope rotation differ by ~1e-7 rad: 0.1 um, 1 uN tolerances.
            for side, foot in enumerate(("l_foot", "r_foot")):
                force, cop = reference[foot]
                np.testing.assert_allclose(sensors.foot_force[0, side], force, atol=1e-6)
                np.testing.assert_allclose(sensors.foot_cop[0, side], cop, atol=1e-7)
                checked += np.isfinite(cop).all()
    assert checked > 10


def test_creep_of_a_standing_robot_is_below_the_slip_threshold(spec, capsys):
    """MuJoCo's soft friction lets loaded feet creep; measure it standing still on each slope."""
    for slope_deg, mu in ((0.0, 1.0), (15.0, 1.0), (30.0, 1.0), (15.0, 0.5)):
        plan = plan_walk(spec, GaitParams.nominal(spec, 1.0, slope=np.deg2rad(slope_deg), steps=1))
        rec = play(plan, friction=mu, settle=3.0, hold=0.0)
        still = (rec.t > -2.5) & (rec.t < 0)  # 2.5 s of standing, after 0.5 s to settle
        sole = rec.sensors.sole[still, :, :2]
        creep = np.hypot(*(sole[-1] - sole[0]).T).max() / 2.5
        with capsys.disabled():
            print(f"creep standing on {slope_deg:g} deg, mu {mu}: {creep * 1e3:.4f} mm/s")
        assert creep * 10 < SLIP_DISTANCE  # a 10 s walk creeps less than the slip threshold


def test_low_friction_slope_slips(spec):
    """On 30 deg with mu 0.3 < tan 30 deg the feet must slide: a slip event, no silent pass."""
    plan = plan_walk(spec, GaitParams.nominal(spec, 1.0, slope=np.deg2rad(30), steps=1))
    rec = play(plan, friction=0.3, settle=1.0, hold=0.0)
    events = detect(rec, weight=spec.total_mass * 9.81, hip_height=plan.params.hip_height)
    assert any(e.kind == "slip" for e in events)
    assert verdict(events) in ("slip", "tip", "fall")


def test_solref_time_constant_not_clamped(spec):
    """MuJoCo clamps a solref time constant below 2 timesteps; ours must stay above."""
    plan = plan_walk(spec, GaitParams.nominal(spec, 1.0, steps=1))
    model = build_model(plan, friction=1.0, actuators="stiff", timestep=0.001)
    used = model.geom_solref[:, 0]
    assert (used[used > 0] >= 2 * model.opt.timestep).all()
