"""Gravity in the slope frame S, pinned by references that do not call ``gravity_in_slope``.

1. MuJoCo's own gravity (0, 0, −9.81 in the world) expressed in the frame of the plane
   geom of a scene built at that slope (the plane's axes are S: x up the slope).
2. A hand derivation: walking uphill on θs, gravity pulls back down the slope and into
   the plane: g_S = (−g sin θs, 0, −g cos θs); the ground must push up-slope with
   m g sin θs, so standing needs μ ≥ tan θs.
3. A static robot standing on the slope in MuJoCo: the measured contact force and CoP
   equal the planner's static inverse dynamics at MuJoCo's own settled pose.
"""

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from slopewalk.bench.sim.model import scene_xml
from slopewalk.planner.joints import MJCF_JOINTS, RIGHT, SIDE_PREFIX
from slopewalk.planner.kinematics import Chain, gravity_in_slope
from slopewalk.planner.newton_euler import inverse_dynamics
from slopewalk.planner.zmp import cop_of_wrench, friction_ratio

MAX_DEG = 59.0


def _floor_rotation(model, data) -> np.ndarray:
    """Axes of the floor geom (x up the slope, z its normal) in the world, as columns."""
    mujoco.mj_kinematics(model, data)
    return data.geom("floor").xmat.reshape(3, 3).copy()


@settings(max_examples=25, deadline=None, derandomize=True)
@given(slope_deg=st.one_of(st.just(0.0), st.floats(0.01, MAX_DEG), st.floats(-MAX_DEG, -0.01)))
def test_gravity_is_mujocos_gravity_in_the_plane_frame(spec, slope_deg):
    """(Below ~1e-6 rad MuJoCo's compiler takes the plane's quaternion for the identity.)"""
    slope = np.deg2rad(slope_deg)
    model = mujoco.MjModel.from_xml_string(scene_xml(spec, slope=slope))
    data = mujoco.MjData(model)
    R = _floor_rotation(model, data)
    assert R[2, 0] == pytest.approx(np.sin(slope), abs=1e-12)  # +x_S climbs for slope > 0
    np.testing.assert_allclose(gravity_in_slope(slope), R.T @ model.opt.gravity, atol=1e-12)


@pytest.mark.parametrize("slope_deg", [5.0, 15.0, 30.0, -20.0])
def test_gravity_by_hand(slope_deg):
    slope, g = np.deg2rad(slope_deg), 9.81
    np.testing.assert_allclose(
        gravity_in_slope(slope), [-g * np.sin(slope), 0.0, -g * np.cos(slope)], atol=1e-15
    )
    # a body at rest: ground force −m g (per unit mass), up the slope for an uphill slope
    ground = -gravity_in_slope(slope)
    assert np.sign(ground[0]) == np.sign(slope)
    assert friction_ratio(ground[None])[0] == pytest.approx(abs(np.tan(slope)), rel=1e-12)


@pytest.mark.parametrize("slope_deg", [0.0, 15.0, 25.0, -8.0])
def test_standing_on_the_slope_matches_the_static_plan(spec, slope_deg):
    """MuJoCo holds the home pose on the slope; its contacts carry what the planner says.

    Measured (mj_contactForce on every foot contact, points on the plane): the total
    ground force in the plane frame is m g (sin θs, 0, cos θs) and its CoP is the
    planner's static ZMP of the settled pose (``inverse_dynamics`` with zero rates,
    rooted at the right foot, gravity from ``gravity_in_slope``). With the slope
    rotation reversed the static ZMP moves by 2 c_z tan θs, about 70 mm at 15°.
    """
    slope = np.deg2rad(slope_deg)
    model = mujoco.MjModel.from_xml_string(scene_xml(spec, slope=slope, friction=1.0))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    for _ in range(800):  # settle into the soft contact, servos holding the key
        mujoco.mj_step(model, data)
    mujoco.mj_forward(model, data)
    assert np.abs(data.qvel).max() < 1e-2  # standing still
    R = _floor_rotation(model, data)  # S axes in the world; the plane passes through 0
    mass = model.body_mass.sum()
    force, moment = np.zeros(3), np.zeros(2)
    for i in range(data.ncon):
        c = data.contact[i]
        f = np.zeros(6)
        mujoco.mj_contactForce(model, data, i, f)
        world = c.frame.reshape(3, 3).T @ f[:3]  # floor (geom1) on foot, world axes
        f_s, p_s = R.T @ world, R.T @ c.pos
        force += f_s
        moment += f_s[2] * p_s[:2]  # CoP of normal forces, points projected onto z_S = 0
    cop = moment / force[2]
    g = 9.81
    np.testing.assert_allclose(
        force, mass * g * np.array([np.sin(slope), 0.0, np.cos(slope)]), rtol=0, atol=1e-3
    )

    # the planner's static ZMP at MuJoCo's settled pose, rooted at the right sole
    hinge = {j: data.joint(j).qpos[0] for j in MJCF_JOINTS}
    r, left = SIDE_PREFIX[RIGHT], SIDE_PREFIX[1 - RIGHT]
    kinds = ("ankle_roll", "ankle_pitch", "knee", "hip_pitch")  # Table I: stance ankle → hip
    q = np.array([hinge[r + k] for k in kinds] + [hinge[left + k] for k in reversed(kinds)])
    sole = R.T @ data.site(r + "sole").xpos
    sole[2] = 0.0
    chain = Chain.from_spec(spec)
    stance = np.array([RIGHT])
    frames = chain.frames(q[None], sole[None], stance)
    dyn = inverse_dynamics(
        chain, frames, np.zeros((1, 8)), np.zeros((1, 8)), stance, gravity_in_slope(slope)
    )
    planned_cop = cop_of_wrench(dyn.stance_force, dyn.stance_moment, sole[None])[0]
    print(f"slope {slope_deg:g} deg: MuJoCo CoP {cop * 1e3} mm, planner {planned_cop * 1e3} mm")
    np.testing.assert_allclose(dyn.stance_force[0], force, rtol=0, atol=0.02 * mass * g)
    np.testing.assert_allclose(planned_cop, cop, rtol=0, atol=1e-3)  # measured: 0.1–0.3 mm
