"""The MJCF against the planner: same spec, same kinematics, same inverse dynamics.

MuJoCo is the reference. Kinematics: the pelvis-rooted scene (plane tilted in the
world) posed from the planner's joint angles; its sites, CoMs and body rotations,
turned back into the slope frame S, match the DH chain. Dynamics: ``mj_inverse``
on the stance-rooted model, whose world frame is S (gravity set to its S
components), matches Newton-Euler torques and the ground wrench.
"""

from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from slopewalk.bench.sim.model import (
    SceneError,
    build_robot,
    robot_xml,
    scene_xml,
    stance_rooted_xml,
    write_default_mjcf,
)
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.joints import (
    JOINT_NAMES,
    MJCF_JOINTS,
    SIDE_PREFIX,
    stance_swing_to_left_right,
)
from slopewalk.planner.kinematics import (
    CHAIN_LINKS,
    Chain,
    gravity_in_slope,
    rotation_slope_to_world,
)
from slopewalk.planner.newton_euler import inverse_dynamics
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.spec import LinkInertial

MJCF_DIR = Path(__file__).resolve().parents[2] / "mjcf"
SLOPES = (0.0, np.deg2rad(15.0))  # [rad]
STRIDE = 7  # subsample the 1 kHz plans


# Lateral and fore-aft CoM offsets (the Bioloid's are all in the sagittal plane), so the
# left/right mirroring of link inertials is exercised too.
OFFSETS = {
    "pelvis": (0.004, 0.003, 0.03),
    "thigh": (0.003, 0.006, -0.07),
    "shank": (-0.002, -0.005, -0.07),
    "ankle": (0.001, 0.002, -0.001),
    "foot": (0.004, 0.005, -0.015),
}
# knee_offset: those CoMs on legs whose knees sit 30 mm behind the hip–ankle line (a real
# humanoid's, geometry.knee_offset), so the DH rows' b and the IK's effective links count
KNEE_OFFSET = -0.030  # [m]
SPECS = ("bioloid", "offset_coms", "knee_offset")
# The nominal gait, and one of the extended family: the pelvis 12 mm ahead (leaning into
# the slope), a 0.7-thigh step and a lean 40 % of the way from hold to sway.
GAITS = {
    "nominal": {},
    "extended": {"step_length": 0.7 * 0.111, "sway_share": 0.4, "pelvis_offset": 0.012},
}


@pytest.fixture(scope="module")
def robots(spec) -> dict:
    """By name: (spec, chain, {(gait, slope): 1 s-step walk of ``GAITS[gait]``})."""
    offset = replace(
        spec,
        links={
            name: LinkInertial(name, link.mass, OFFSETS[name], link.inertia)
            for name, link in spec.links.items()
        },
    )
    knee = replace(offset, knee_offset=KNEE_OFFSET)
    out = {}
    for name, robot in zip(SPECS, (spec, offset, knee), strict=True):
        walks = {
            (gait, s): plan_walk(
                robot,
                GaitParams.nominal(robot, 1.0, slope=s, **extra),
            )
            for gait, extra in GAITS.items()
            for s in SLOPES
        }
        out[name] = (robot, Chain.from_spec(robot), walks)
    return out


def _all_models(spec) -> dict[str, str]:
    models = {"robot": robot_xml(spec)}
    for actuators in ("stiff", "servo"):
        for slope in SLOPES:
            name = f"scene {actuators} {np.rad2deg(slope):g} deg"
            models[name] = scene_xml(spec, slope=slope, actuators=actuators)
    for stance in (0, 1):
        models[f"stance-rooted {SIDE_PREFIX[stance]}"] = stance_rooted_xml(spec, stance)
    return models


def test_every_model_steps_one_second_without_warnings(spec):
    for name, xml in _all_models(spec).items():
        model = mujoco.MjModel.from_xml_string(xml)
        data = mujoco.MjData(model)
        if model.nkey:
            mujoco.mj_resetDataKeyframe(model, data, 0)
        for _ in range(round(1.0 / model.opt.timestep)):
            mujoco.mj_step(model, data)
        warnings = {mujoco.mjtWarning(i).name: w.number for i, w in enumerate(data.warning)}
        assert not any(warnings.values()), f"{name}: {warnings}"
        assert np.all(np.isfinite(data.qpos)), name


def test_committed_mjcf_is_what_the_default_spec_generates(spec, tmp_path):
    robot, scene = write_default_mjcf(tmp_path)
    for generated in (robot, scene):
        committed = MJCF_DIR / generated.name
        assert committed.read_text() == generated.read_text(), (
            f"{committed} drifted from slopewalk.bench.sim.model; "
            "run slopewalk.bench.sim.model.write_default_mjcf('mjcf')"
        )
        mujoco.MjModel.from_xml_path(str(committed))
    assert (MJCF_DIR / "biped.xml").read_text() == robot_xml(spec)


def test_written_xml_reproduces_the_compiled_spec(spec):
    """MuJoCo's writer keeps 6 significant digits: enough for the spec's numbers."""
    direct = build_robot(spec).compile()
    from_xml = mujoco.MjModel.from_xml_string(robot_xml(spec))
    for field in ("body_pos", "body_quat", "body_ipos", "body_mass", "body_inertia",
                  "jnt_axis", "jnt_range", "site_pos", "geom_pos", "geom_size"):  # fmt: skip
        np.testing.assert_allclose(
            getattr(from_xml, field), getattr(direct, field), rtol=1e-12, atol=1e-15, err_msg=field
        )
    assert from_xml.body_mass.sum() == pytest.approx(spec.total_mass, rel=1e-12)


def _planner_points(spec, frames, stance, stance_sole) -> dict[str, np.ndarray]:
    """Positions in S of the MJCF's sites from the DH frames, by site name, each (n, 3)."""
    toe, heel = np.array([spec.ankle_to_toe, 0, 0]), np.array([-spec.heel_offset, 0, 0])
    stance_points = {
        "ankle": frames[:, 0, :3, 3],
        "knee": frames[:, 3, :3, 3],
        "hip": frames[:, 4, :3, 3],
        "sole": stance_sole,
        "toe": stance_sole + toe,  # the stance foot lies flat, S-aligned
        "heel": stance_sole + heel,
    }
    swing_points = {
        "hip": frames[:, 5, :3, 3],
        "knee": frames[:, 6, :3, 3],
        "ankle": frames[:, 8, :3, 3],
        "sole": frames[:, 9, :3, 3],
        "toe": frames[:, 9, :3, 3] + frames[:, 9, :3, :3] @ toe,
        "heel": frames[:, 9, :3, 3] + frames[:, 9, :3, :3] @ heel,
    }
    out = {}
    for name in stance_points:
        for side, prefix in enumerate(SIDE_PREFIX):
            is_stance = (stance == side)[:, None]
            out[prefix + name] = np.where(is_stance, stance_points[name], swing_points[name])
    return out


def _body_name(role: str, link: str, stance: int) -> str:
    if role == "pelvis":
        return "pelvis"
    side = stance if role == "stance" else 1 - stance
    return SIDE_PREFIX[side] + link


@pytest.mark.parametrize("name", SPECS)
@pytest.mark.parametrize("slope", SLOPES, ids=["flat", "slope15"])
@pytest.mark.parametrize("gait", GAITS)
def test_kinematics_match_the_dh_chain(robots, name, slope, gait):
    spec, chain, walks = robots[name]
    plan = walks[gait, slope]
    keep = np.arange(0, plan.t.size, STRIDE)
    stance, stance_sole = plan.stance[keep], plan.stance_sole[keep]
    frames = chain.frames(plan.q[keep], stance_sole, stance)
    frames_zero = chain.frames(np.zeros((1, 8)), np.zeros((1, 3)), np.zeros(1, int))[0]
    points = _planner_points(spec, frames, stance, stance_sole)
    coms = chain.link_coms(frames, stance)  # (n, 9, 3)
    pelvis_origin, pelvis_rotation = chain.pelvis_pose(frames, stance)
    q_lr = plan.q_left_right[keep]

    model = mujoco.MjModel.from_xml_string(scene_xml(spec, slope=slope))
    data = mujoco.MjData(model)
    R_sw = rotation_slope_to_world(slope)
    hinge_adr = [model.joint(name).qposadr[0] for name in MJCF_JOINTS]
    errors = {"site": 0.0, "com": 0.0, "rotation": 0.0}
    for k in range(keep.size):
        data.qpos[:3] = R_sw @ pelvis_origin[k]
        mujoco.mju_mat2Quat(data.qpos[3:7], (R_sw @ pelvis_rotation[k]).reshape(-1))
        data.qpos[hinge_adr] = q_lr[k]
        mujoco.mj_kinematics(model, data)
        for site, p in points.items():
            mj = R_sw.T @ data.site(site).xpos
            errors["site"] = max(errors["site"], np.abs(mj - p[k]).max())
        for i, (role, link) in enumerate(CHAIN_LINKS):
            body = data.body(_body_name(role, link, stance[k]))
            errors["com"] = max(errors["com"], np.abs(R_sw.T @ body.xipos - coms[k, i]).max())
            R_planner = frames[k, i, :3, :3] @ frames_zero[i, :3, :3].T
            R_mj = R_sw.T @ body.xmat.reshape(3, 3)
            errors["rotation"] = max(errors["rotation"], np.abs(R_mj - R_planner).max())
    print(f"{name}, slope {np.rad2deg(slope):g} deg, max abs errors: {errors}")
    assert errors["site"] < 1e-9 and errors["com"] < 1e-9 and errors["rotation"] < 1e-9, errors


@pytest.mark.parametrize("name", SPECS)
@pytest.mark.parametrize("slope", SLOPES, ids=["flat", "slope15"])
@pytest.mark.parametrize("gait", GAITS)
def test_inverse_dynamics_match_mj_inverse(robots, name, slope, gait):
    spec, chain, walks = robots[name]
    plan = walks[gait, slope]
    gravity = gravity_in_slope(slope)
    single = np.flatnonzero(~plan.double_support)[::STRIDE]
    assert set(plan.stance[single]) == {0, 1}
    q, qd, qdd = plan.q[single], plan.qd[single], plan.qdd[single]
    stance, sole = plan.stance[single], plan.stance_sole[single]
    frames = chain.frames(q, sole, stance)
    dyn = inverse_dynamics(chain, frames, qd, qdd, stance, gravity)
    # In single support the plan's torques are the recursion's (no load split).
    np.testing.assert_allclose(plan.tau[single], dyn.tau, rtol=0, atol=1e-12)

    tau = np.empty_like(dyn.tau)
    force, moment = np.empty((single.size, 3)), np.empty((single.size, 3))
    for side in (0, 1):
        model = mujoco.MjModel.from_xml_string(stance_rooted_xml(spec, side))
        model.opt.gravity[:] = gravity  # this model's world frame is S
        data = mujoco.MjData(model)
        hinges = [model.joint(name).dofadr[0] for name in JOINT_NAMES]
        foot = model.body(f"{SIDE_PREFIX[side]}foot").id
        for k in np.flatnonzero(stance == side):
            data.qpos[:7] = [*(sole[k] + [0, 0, spec.ankle_height]), 1, 0, 0, 0]
            data.qpos[7:] = q[k]
            data.qvel[:] = 0
            data.qacc[:] = 0
            data.qvel[hinges], data.qacc[hinges] = qd[k], qdd[k]
            mujoco.mj_inverse(model, data)
            tau[k] = data.qfrc_inverse[hinges]
            # Free joint: force in the world frame at the body origin (the ankle
            # centre), moment in the body frame; moved to the sole point here.
            force[k] = data.qfrc_inverse[:3]
            moment_origin = data.xmat[foot].reshape(3, 3) @ data.qfrc_inverse[3:6]
            moment[k] = moment_origin + np.cross(data.xpos[foot] - sole[k], force[k])
    relative = np.abs(tau - dyn.tau) / np.maximum(np.abs(tau), 1e-3)  # 1 mN m floor
    d_force, d_moment = force - dyn.stance_force, moment - dyn.stance_moment
    print(
        f"{name}, slope {np.rad2deg(slope):g} deg: max |dtau| {np.abs(tau - dyn.tau).max():.3g}"
        f" N m, max rel {relative.max():.3g}; max |dF| {np.abs(d_force).max():.3g} N,"
        f" max |dM| {np.abs(d_moment).max():.3g} N m"
    )
    np.testing.assert_allclose(dyn.tau, tau, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(dyn.stance_force, force, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(dyn.stance_moment, moment, rtol=1e-6, atol=1e-9)


@settings(max_examples=40, deadline=None, derandomize=True)
@given(
    knee=st.floats(-0.05, 0.05),
    stance=st.integers(0, 1),
    q=hnp.arrays(np.float64, 8, elements=st.floats(-1.2, 1.2)),
)
def test_random_poses_with_a_knee_offset_match_mj_kinematics(spec, knee, stance, q):
    """Random joint angles (not a walk's), either stance leg, knees up to 50 mm off the
    hip–ankle line: the twin's knee, ankle, hip, sole, toe and heel sites under
    ``mj_kinematics`` are the DH frames' points, to 1e-12 m."""
    spec = replace(spec, knee_offset=knee)
    chain = Chain.from_spec(spec)
    stance_arr, sole = np.array([stance]), np.zeros((1, 3))
    frames = chain.frames(q[None], sole, stance_arr)
    points = _planner_points(spec, frames, stance_arr, sole)
    origin, rotation = chain.pelvis_pose(frames, stance_arr)
    model = build_robot(spec).compile()  # full precision (the XML text keeps 6 digits)
    data = mujoco.MjData(model)
    data.qpos[:3] = origin[0]
    mujoco.mju_mat2Quat(data.qpos[3:7], rotation[0].reshape(-1))
    q_lr = stance_swing_to_left_right(q[None], stance_arr)[0]
    data.qpos[[model.joint(name).qposadr[0] for name in MJCF_JOINTS]] = q_lr
    mujoco.mj_kinematics(model, data)
    worst = max(np.abs(data.site(site).xpos - p[0]).max() for site, p in points.items())
    assert worst < 1e-12, worst


@pytest.mark.parametrize(
    "options, message",
    [
        ({"slope": np.deg2rad(60.0)}, "slope 60 deg: must lie in (-60, 60) deg"),
        ({"slope": np.deg2rad(-75.0)}, "slope -75 deg"),
        ({"friction": 0.0}, "friction 0.0: must lie in (0, 10]"),
        ({"friction": float("nan")}, "friction nan: must lie in (0, 10]"),
        ({"friction": float("inf")}, "friction inf: must lie in (0, 10]"),
        ({"friction": 1e6}, "friction 1000000.0: must lie in (0, 10]"),
        ({"friction": "1"}, "friction '1': must lie in (0, 10]"),
        ({"actuators": "soft"}, "actuators 'soft': must be one of stiff, servo"),
        ({"timestep": -1e-3}, "timestep -0.001 s"),
    ],
)
def test_bad_scene_options_are_refused_in_one_line(spec, options, message):
    with pytest.raises(SceneError) as error:
        scene_xml(spec, **options)
    assert message in str(error.value) and "\n" not in str(error.value)


def test_a_tiny_slope_still_builds_and_is_written_exactly(spec):
    """Below ~1e-16 rad MuJoCo's writer drops the floor's quat (identity); it was refused."""
    slope = 1e-17  # [rad]
    xml = scene_xml(spec, slope=slope)
    assert f'euler="0 {-slope:.17g} 0"' in xml
    mujoco.MjModel.from_xml_string(xml)


def test_bad_stance_is_refused(spec):
    with pytest.raises(SceneError, match="stance 2"):
        stance_rooted_xml(spec, 2)


@pytest.mark.parametrize("knee_offset", [0.0, KNEE_OFFSET])
@pytest.mark.parametrize("actuators", ["stiff", "servo"])
def test_home_pose_stands_still(spec, actuators, knee_offset):
    """Flat feet, no chatter: after 1 s at the home key the soles have not crept (a knee
    offset too: the home key's angles are those of the effective links, turned back)."""
    spec = replace(spec, knee_offset=knee_offset)
    model = mujoco.MjModel.from_xml_string(scene_xml(spec, actuators=actuators))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    soles = np.array([data.site(f"{p}sole").xpos for p in SIDE_PREFIX])
    for _ in range(1000):
        mujoco.mj_step(model, data)
    crept = np.array([data.site(f"{p}sole").xpos for p in SIDE_PREFIX]) - soles
    assert np.abs(crept).max() < 1e-3, crept
    assert np.abs(data.qvel).max() < 1e-2, data.qvel


def test_home_key_puts_both_soles_on_the_tilted_plane_with_the_scene_friction(spec):
    slope, mu = np.deg2rad(15.0), 0.35
    model = mujoco.MjModel.from_xml_string(scene_xml(spec, slope=slope, friction=mu))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    R_sw = rotation_slope_to_world(slope)
    for prefix in SIDE_PREFIX:
        for site in ("sole", "toe", "heel"):
            assert abs((R_sw.T @ data.site(prefix + site).xpos)[2]) < 1e-5  # 6-digit key
    for _ in range(100):  # settle into the soft contact
        mujoco.mj_step(model, data)
    floor = model.geom("floor").id
    contacts = data.contact[: data.ncon]
    feet = {model.geom(f"{p}foot").id for p in SIDE_PREFIX}
    assert data.ncon == 8 and all({floor, *feet} >= set(c.geom) for c in contacts)
    assert all(c.dim == 3 and c.friction[0] == pytest.approx(mu) for c in contacts)


@pytest.mark.parametrize("slope_deg", [12.0, -7.3, 30.0, 45.123456789])
def test_written_floor_is_tilted_by_exactly_the_slope(spec, slope_deg, tmp_path):
    """The XML `slopewalk mjcf` writes, read back by MuJoCo: the plane's tilt is the slope.

    MuJoCo's writer keeps 6 digits of a quaternion (12° read back as 11.999946°, an
    error of 1e-6 rad); the floor's orientation must survive the text to 1e-12 rad.
    """
    slope = np.deg2rad(slope_deg)
    path = tmp_path / "scene.xml"
    path.write_text(scene_xml(spec, slope=slope))
    model = mujoco.MjModel.from_xml_path(str(path))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    R = data.geom("floor").xmat.reshape(3, 3)
    normal, uphill = R[:, 2], R[:, 0]
    tilt = np.arctan2(np.hypot(normal[0], normal[1]), normal[2])
    assert tilt == pytest.approx(abs(slope), abs=1e-12)
    assert np.arctan2(uphill[2], uphill[0]) == pytest.approx(slope, abs=1e-12)  # x_S goes up
    np.testing.assert_allclose(R, rotation_slope_to_world(slope), atol=1e-15)
