"""DH forward kinematics and closed-form IK against hand-derived poses and round trips."""

from dataclasses import replace

import numpy as np
import pytest
from conftest import away_from_phase_changes

from slopewalk.planner.errors import UnreachableError
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.kinematics import Chain, dh_transform, rotation_slope_to_world
from slopewalk.planner.plan import plan_walk


def _rot(axis: str, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    if axis == "x":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    if axis == "y":
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def test_dh_transform_is_rotx_transx_rotz_transz():
    """Eq. (1) equals RotX(α)·TransX(a)·RotZ(θ)·TransZ(d) (Craig's modified DH)."""
    rng = np.random.default_rng(0)
    for a, alpha, d, theta in rng.uniform(-2, 2, (20, 4)):
        expected = np.eye(4)
        for R, p in ((_rot("x", alpha), [a, 0, 0]), (_rot("z", theta), [0, 0, d])):
            step = np.eye(4)
            step[:3, :3] = R
            step[:3, 3] = R @ p if p[0] == 0 else p
            expected = expected @ step
        np.testing.assert_allclose(dh_transform(a, alpha, d, theta), expected, atol=1e-14)


@pytest.mark.parametrize("stance", [0, 1])
def test_straight_legs(spec, stance):
    """q = 0: hips at ankle height + shank + thigh, swing foot Lh to the side, flat."""
    chain = Chain.from_spec(spec)
    frames = chain.frames(np.zeros((1, 8)), np.zeros((1, 3)), np.array([stance]))[0]
    hip_height = spec.ankle_height + spec.shank + spec.thigh
    side = -1.0 if stance == 0 else 1.0  # stance left → swing foot to the right
    np.testing.assert_allclose(frames[4, :3, 3], [0, 0, hip_height], atol=1e-15)
    np.testing.assert_allclose(frames[5, :3, 3], [0, side * spec.hip_width, hip_height], atol=1e-15)
    np.testing.assert_allclose(frames[9, :3, 3], [0, side * spec.hip_width, 0], atol=1e-15)
    np.testing.assert_allclose(frames[9, :3, :3], np.eye(3), atol=1e-15)


def test_hand_derived_crouch_and_lean(spec):
    """Knees bent symmetric (shank +β, thigh −β from vertical) and a lean λ about x_S."""
    beta, lean = 0.4, 0.15
    q = np.array([[-lean, -beta, 2 * beta, -beta, -beta, 2 * beta, -beta, -lean]])
    chain = Chain.from_spec(spec)
    frames = chain.frames(q, np.zeros((1, 3)), np.array([1]))[0]  # stance right
    height = (spec.shank + spec.thigh) * np.cos(beta)
    up = np.array([0.0, -np.sin(lean), np.cos(lean)])  # R_x(λ) z
    ankle = np.array([0, 0, spec.ankle_height])
    np.testing.assert_allclose(
        frames[3, :3, 3],
        ankle + spec.shank * (np.sin(beta) * np.array([1, 0, 0]) + np.cos(beta) * up),
        atol=1e-15,
    )
    np.testing.assert_allclose(frames[4, :3, 3], ankle + height * up, atol=1e-15)
    np.testing.assert_allclose(frames[4, :3, :3] @ [1, 0, 0], up, atol=1e-15)  # pelvis upright
    # swing leg mirrors the stance leg: its ankle is the stance ankle shifted by Lh along y'
    lateral = np.array([0.0, np.cos(lean), np.sin(lean)])  # R_x(λ) y
    np.testing.assert_allclose(frames[8, :3, 3], ankle + spec.hip_width * lateral, atol=1e-15)
    np.testing.assert_allclose(frames[9, :3, :3], np.eye(3), atol=1e-15)  # q8 = q1: sole flat


def test_slope_rotation_matches_eq2():
    """S is the world turned by −θs about y: x_S points uphill, gravity gains −x_S."""
    R = rotation_slope_to_world(np.deg2rad(30))
    np.testing.assert_allclose(R @ [1, 0, 0], [np.cos(np.pi / 6), 0, 0.5], atol=1e-15)
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-15)


# knees 0, 30 mm behind and 14 mm ahead of the hip–ankle line (geometry.knee_offset)
KNEES = (0.0, -0.030, 0.014)


@pytest.mark.parametrize("stance", [0, 1])
@pytest.mark.parametrize("knee", KNEES[1:])
def test_straight_legs_with_a_knee_offset(spec, stance, knee):
    """q = 0 with the knee axis k ahead of the line: knees at (k, ·, ankle + shank) and
    (k, ·, hip − thigh), hips and swing sole where they are without an offset."""
    spec = replace(spec, knee_offset=knee)
    frames = Chain.from_spec(spec).frames(np.zeros((1, 8)), np.zeros((1, 3)), np.array([stance]))
    side = -1.0 if stance == 0 else 1.0
    hip = spec.ankle_height + spec.shank + spec.thigh
    knee_z = spec.ankle_height + spec.shank
    np.testing.assert_allclose(frames[0, 3, :3, 3], [knee, 0, knee_z], atol=1e-15)
    np.testing.assert_allclose(frames[0, 4, :3, 3], [0, 0, hip], atol=1e-15)
    np.testing.assert_allclose(
        frames[0, 6, :3, 3], [knee, side * spec.hip_width, knee_z], atol=1e-15
    )
    np.testing.assert_allclose(frames[0, 9, :3, 3], [0, side * spec.hip_width, 0], atol=1e-15)


@pytest.mark.parametrize("knee", KNEES)
@pytest.mark.parametrize("step_time, slope_deg, profile", [(1.0, 0.0, "hold"), (0.5, 20.0, "sway")])
def test_fk_of_ik_returns_the_targets(spec, step_time, slope_deg, profile, knee):
    """Over a whole walk FK(IK(target)) puts the pelvis centre, swing sole and feet on target
    (with the knees off the hip–ankle line too)."""
    spec = replace(spec, knee_offset=knee)
    params = GaitParams.nominal(spec, step_time, slope=np.deg2rad(slope_deg), tilt_profile=profile)
    plan = plan_walk(spec, params)
    chain = Chain.from_spec(spec)
    frames = chain.frames(plan.q, plan.stance_sole, plan.stance)
    pelvis = (frames[:, 4, :3, 3] + frames[:, 5, :3, 3]) / 2
    # pelvis height above the plane is Hz, swing sole height the planned lift
    np.testing.assert_allclose(pelvis[:, 2], params.hip_height, atol=1e-9)
    from slopewalk.planner.trajectory import Timeline

    timeline = Timeline.of(params)
    lift = params.swing_lift * timeline.lift_shape.p
    np.testing.assert_allclose(frames[:, 9, 2, 3], lift, atol=1e-9)
    np.testing.assert_allclose(
        frames[:, 9, 0, 3] - plan.stance_sole[:, 0], timeline.swing_x.p, atol=1e-9
    )
    hip_x = pelvis[:, 0] - plan.stance_sole[:, 0]
    np.testing.assert_allclose(hip_x, timeline.hip_x.p, atol=1e-9)
    np.testing.assert_allclose(
        frames[:, 9, :3, :3], np.broadcast_to(np.eye(3), (plan.t.size, 3, 3)), atol=1e-9
    )
    # At each touch-down the old chain (roles swapped: Table-I order reversed)
    # puts its swing sole on the new stance footprint and its stance sole under
    # the new swing foot: the pose is continuous when the chain is re-rooted.
    switch = np.flatnonzero(np.diff(plan.stance)) + 1
    old = chain.frames(plan.q[switch, ::-1], plan.swing_sole[switch], plan.stance[switch - 1])
    np.testing.assert_allclose(old[:, 9, :3, 3], plan.stance_sole[switch], atol=1e-9)
    np.testing.assert_allclose(old[:, 4:6, :3, 3], frames[switch, 5:3:-1, :3, 3], atol=1e-9)


@pytest.mark.parametrize("knee", KNEES[:2])
def test_joint_rates_are_derivatives_of_angles(spec, knee):
    """q̇ and q̈ from the IK Jacobian match finite differences of q."""
    spec = replace(spec, knee_offset=knee)
    plan = plan_walk(spec, GaitParams.nominal(spec, 0.8, dt=1e-4))
    keep = away_from_phase_changes(plan)
    qd = np.gradient(plan.q, plan.t, axis=0)
    qdd = np.gradient(plan.qd, plan.t, axis=0)
    np.testing.assert_allclose(qd[keep], plan.qd[keep], atol=1e-5)
    np.testing.assert_allclose(qdd[keep], plan.qdd[keep], rtol=1e-3, atol=1e-3)


def test_unreachable_hip_height_names_time_and_distance(spec):
    with pytest.raises(UnreachableError, match=r"t = .* s: hip-ankle distance .* m"):
        plan_walk(spec, GaitParams.nominal(spec, 1.0, hip_height=0.25))


@pytest.mark.parametrize("knee", KNEES[:2])
def test_frames_are_the_product_of_eq1_transforms(spec, knee):
    """The fast frame composition equals ⁰T₁·¹T₂⋯ of eq. (1) matrices, for random poses."""
    spec = replace(spec, knee_offset=knee)
    rng = np.random.default_rng(11)
    n = 64
    q = rng.uniform(-1.5, 1.5, (n, 8))
    stance = rng.integers(0, 2, n)
    sole = rng.uniform(-0.2, 0.2, (n, 3))
    chain = Chain.from_spec(spec)
    frames = chain.frames(q, sole, stance)
    T = np.tile(np.eye(4), (n, 1, 1))
    T[:, :3, 3] = sole + [0, 0, spec.ankle_height]
    T[:, :3, :3] = [[0, 0, 1], [0, -1, 0], [1, 0, 0]]
    np.testing.assert_allclose(frames[:, 0], T, atol=1e-15)
    steps = dh_transform(*chain.dh_parameters(q, stance))
    for i in range(8):
        T = T @ steps[:, i]
        np.testing.assert_allclose(frames[:, i + 1], T, atol=1e-14)
