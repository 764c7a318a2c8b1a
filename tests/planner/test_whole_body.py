"""The whole-body walk (planner/whole_body.py) against independent references: the servo
loop's own linearisation (its mass matrix from the compiled Newton-Euler's finite
differences) and hand-derived statics; its compiled time loop against its numpy twin."""

from __future__ import annotations

import numpy as np
import pytest
from design_gaits import leaning_uphill

from slopewalk.planner import whole_body as wb
from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.servo_loop import _plan_linearisation
from slopewalk.planner.uncertainty import spec_at
from slopewalk.planner.walk_prediction import servo_torque


@pytest.fixture(scope="module")
def slow_walk(spec):
    return plan_walk(spec, GaitParams.nominal(spec, 2.0, slope=0.0))


def test_its_joint_block_is_the_servo_loops_mass_matrix_in_single_support(spec):
    """From the links' Jacobians here, from ∂τ/∂q̈ of the Newton-Euler pass there; in double
    support the loop's holds the plan's split and differs by design."""
    plan = plan_walk(spec, GaitParams.nominal(spec, 1.0, slope=np.deg2rad(10.0)))
    mass = wb.model_of(plan).mass
    mine = mass[:, wb.BASE :, wb.BASE :]
    loop = _plan_linearisation(plan)[1]
    single = ~plan.double_support
    scale = np.abs(loop[single]).max()
    np.testing.assert_allclose(mine[single], loop[single], rtol=0, atol=1e-9 * scale)
    # the base rows: the robot's mass on z, and M symmetric positive definite
    np.testing.assert_allclose(mass[:, 0, 0], spec.total_mass, rtol=1e-12)
    assert np.all(np.linalg.eigvalsh(mass[::200]) > 0)


@pytest.mark.parametrize("height, sign", [(0.2, -1.0), (-0.2, 1.0)])
def test_a_point_mass_turning_has_the_pendulums_stiffness(height, sign):
    """Hand-derived: m at r = (0, 0, h) under g = (0, 0, −g): roll and pitch stiffness
    −m g h (upright: it falls; hanging: it returns), none about the vertical."""
    mass, g = np.array([2.0]), 9.81
    arm = np.array([[[0.0], [0.0], [height]]])
    gravity = np.array([[[0.0], [0.0], [-g]]])
    k = wb.rotation_stiffness(mass, arm, gravity)[..., 0]
    np.testing.assert_allclose(np.diag(k), [sign * 2.0 * g * 0.2] * 2 + [0.0], atol=1e-12)
    np.testing.assert_allclose(k - np.diag(np.diag(k)), 0.0, atol=1e-12)


def test_a_point_mass_beside_the_pivot_couples_roll_and_pitch_only_through_gravity():
    """Hand-derived: r = (a, 0, 0) under g = (0, 0, −g): V = −m g·c has V_φφ =
    m ((g·r) I − sym(g rᵀ)) = m diag(0, 0, 0) + m (g a/2)(e_x e_zᵀ + e_z e_xᵀ)."""
    a, g = 0.1, 9.81
    k = wb.rotation_stiffness(
        np.array([1.0]), np.array([[[a], [0.0], [0.0]]]), np.array([[[0.0], [0.0], [-g]]])
    )[..., 0]
    want = np.zeros((3, 3))
    want[0, 2] = want[2, 0] = 0.5 * g * a
    np.testing.assert_allclose(k, want, atol=1e-12)


@pytest.fixture(scope="module")
def short_walk(spec):
    """Two 1 s steps up 10°, and its chain: the finite-difference tests' walk."""
    from slopewalk.planner.kinematics import Chain

    plan = plan_walk(spec, GaitParams.nominal(spec, 1.0, slope=np.deg2rad(10.0), steps=2))
    return plan, Chain.from_spec(spec)


def _samples(plan):
    """One sample in a double support and one in a single support."""
    return (
        int(np.flatnonzero(plan.double_support)[5]),
        int(np.flatnonzero(~plan.double_support)[300]),
    )


def _spin(rate, frame):
    """ω (..., 3) from Ṙ and R (..., 3, 3): the axial vector of Ṙ Rᵀ."""
    w = rate @ np.swapaxes(frame, -1, -2)
    return np.stack([w[..., 2, 1], w[..., 0, 2], w[..., 1, 0]], axis=-1)


def _moved(plan, chain, k, x, *, soles=False):
    """The links' CoMs [m] (9, 3) and frames (9, 3, 3) in S at sample k moved by x (z, roll,
    pitch as a rotation vector about the stance sole point, the 8 joints' angles), from the
    chain's forward kinematics alone; ``soles``: instead the 8 sole corners (stance 0-3,
    second 4-7) [m] (8, 3), the second sole point (3,) and its frame (3, 3)."""
    from scipy.spatial.transform import Rotation

    q = plan.q[k : k + 1] + x[None, wb.BASE :]
    R, o = chain.poses(q, plan.stance_sole[k : k + 1], plan.stance[k : k + 1])
    side = int(plan.stance[k])
    pivot = plan.stance_sole[k]
    turn = Rotation.from_rotvec([x[1], x[2], 0.0]).as_matrix()

    def moved(p):
        return (p - pivot) @ turn.T + pivot + np.array([0.0, 0.0, x[0]])

    if soles:
        spec = plan.spec
        heel, toe, half = spec.heel_offset, spec.ankle_to_toe, spec.foot_width / 2
        along, across = np.array([-heel, toe, toe, -heel]), np.array([-half, -half, half, half])
        stance = pivot + np.stack([along, spec.sole_shift(side) + across, 0 * along], axis=1)
        offset = np.stack([along, spec.sole_shift(1 - side) + across, 0 * along], axis=1)
        second = o[9, :, 0] + offset @ R[9, :, :, 0].T
        corners = np.concatenate([stance, second])
        return moved(corners), moved(o[9, :, 0]), turn @ R[9, :, :, 0]
    c = o[:9, :, 0] + np.einsum("kij,kj->ki", R[:9, :, :, 0], chain.com[side])
    return moved(c), turn @ R[:9, :, :, 0]


def _potential(plan, chain, felt, k, x):
    """V = −Σ m g'·c [J] at sample k moved by x (``_moved``); g' (9, 3) per link."""
    return -(chain.mass * (felt * _moved(plan, chain, k, x)[0]).sum(axis=1)).sum()


@pytest.mark.parametrize("compiled", [False, True])
def test_its_stiffness_is_the_potentials_hessian(short_walk, compiled):
    """The base turn's stiffness, its coupling to the joints and the joints' Hessian, against
    central differences of V = −Σ m g'·c through the forward kinematics, with a g' of its
    own for each link (gravity plus a d'Alembert pull), in double and in single support."""
    plan, chain = short_walk
    R, o = chain.poses(plan.q, plan.stance_sole, plan.stance)
    com, inertia = wb._links(plan, chain, R, o)
    axes, origins = wb._joints(chain, R, o)
    pull = np.random.default_rng(0).normal(0.0, 5.0, (9, 3)) + [0.0, 0.0, -9.81]
    felt = np.repeat(pull[..., None], plan.t.size, axis=2)
    if compiled:
        _, stiffness = wb._mass_and_stiffness_compiled(plan, chain, R, com, axes, origins, felt)
    else:
        stiffness = wb._mass_and_stiffness(plan, chain, com, inertia, axes, origins, felt)[1]
    h, step = 1e-4, np.eye(wb.DOF) * 1e-4
    for k in _samples(plan):
        hessian = np.array(
            [
                [
                    sum(
                        si * sj * _potential(plan, chain, pull, k, si * step[i] + sj * step[j])
                        for si in (1, -1)
                        for sj in (1, -1)
                    )
                    / (4 * h * h)
                    for j in range(wb.DOF)
                ]
                for i in range(wb.DOF)
            ]
        )
        scale = np.abs(hessian).max()
        np.testing.assert_allclose(stiffness[k], hessian, rtol=0, atol=1e-6 * scale)


def test_its_mass_matrix_is_the_kinetic_energys(short_walk):
    """M = Σ m Jvᵀ Jv + Jωᵀ I Jω with each link's Jacobians taken by central differences of
    its CoM and frame through the forward kinematics (ω from Ṙ Rᵀ, I = R I_link Rᵀ), every
    row (the base's turn and its coupling to the joints included), in double and single
    support."""
    plan, chain = short_walk
    mass = wb.model_of(plan).mass
    h = 1e-6
    for k in _samples(plan):
        c, frame = _moved(plan, chain, k, np.zeros(wb.DOF))
        jv, jw = np.zeros((9, 3, wb.DOF)), np.zeros((9, 3, wb.DOF))
        for i in range(wb.DOF):
            step = np.eye(wb.DOF)[i] * h
            (up, turned_up), (down, turned_down) = (
                _moved(plan, chain, k, s) for s in (step, -step)
            )
            jv[:, :, i] = (up - down) / (2 * h)
            jw[:, :, i] = _spin((turned_up - turned_down) / (2 * h), frame)
        inertia = frame @ chain.inertia[int(plan.stance[k])] @ frame.transpose(0, 2, 1)
        want = np.einsum("k,kai,kaj->ij", chain.mass, jv, jv)
        want += np.einsum("kai,kab,kbj->ij", jw, inertia, jw)
        np.testing.assert_allclose(mass[k], want, rtol=0, atol=1e-6 * np.abs(want).max())


def test_its_sole_jacobians_are_the_forward_kinematics(short_walk):
    """The corners' ∂z/∂x, the second sole point's ∂p/∂x and the second sole's ∂θ/∂x (θ from
    Ṙ Rᵀ), against central differences through the forward kinematics, in double and single
    support; and the corners' planned heights (the swing sole's off the plane)."""
    plan, chain = short_walk
    model = wb.model_of(plan)
    h = 1e-6
    for k in _samples(plan):
        corners, _, frame = _moved(plan, chain, k, np.zeros(wb.DOF), soles=True)
        height = np.where(plan.double_support[k], 0.0, np.maximum(corners[4:, 2], 0.0))
        np.testing.assert_allclose(model.height[4:, k], height, rtol=0, atol=1e-12)
        jz, jp, jt = np.zeros((8, wb.DOF)), np.zeros((3, wb.DOF)), np.zeros((3, wb.DOF))
        for i in range(wb.DOF):
            step = np.eye(wb.DOF)[i] * h
            up, down = (_moved(plan, chain, k, s, soles=True) for s in (step, -step))
            jz[:, i] = (up[0][:, 2] - down[0][:, 2]) / (2 * h)
            jp[:, i] = (up[1] - down[1]) / (2 * h)
            jt[:, i] = _spin((up[2] - down[2]) / (2 * h), frame)
        for mine, want in ((model.corner, jz), (model.second_point, jp), (model.second_turn, jt)):
            np.testing.assert_allclose(mine[..., k], want, rtol=0, atol=1e-6)


def test_the_planned_loads_carry_the_planned_force_at_the_planned_zmp(spec):
    """The corners' ideal loads add up to the planned normal force, and their moment puts it
    at the planned ZMP; clamped to the soles they are never negative."""
    plan = plan_walk(spec, GaitParams.nominal(spec, 0.6, slope=np.deg2rad(15.0)))
    model = wb.model_of(plan)
    normal = plan.ground_force[:, 2]
    np.testing.assert_allclose(model.ideal.sum(axis=0), normal, rtol=0, atol=1e-9)
    # each corner's position on the plane, from its height Jacobian's turn columns:
    # ∂z/∂roll = y − y0, ∂z/∂pitch = −(x − x0) about the stance sole point
    y = model.corner[:, 1] + plan.stance_sole[:, 1]
    x = -model.corner[:, 2] + plan.stance_sole[:, 0]
    second = np.where(plan.double_support, plan.swing_force[:, 2], 0.0)
    loaded = normal - second > 0.1  # the stance sole's CoP makes up the rest of the moment
    zmp = np.stack([(model.ideal * x).sum(0), (model.ideal * y).sum(0)]) / np.where(
        loaded, normal, 1
    )
    # to 0.1 mm: the second sole's planned centre is its sole point's, its corners the FK's
    np.testing.assert_allclose(zmp[:, loaded].T, plan.zmp[loaded], rtol=0, atol=1e-4)
    assert (model.nominal >= 0).all()


def test_a_tip_is_a_loaded_sole_past_the_tip_angle(slow_walk):
    """As the simulator's: a sole turned past TIP_ANGLE counts only while it carries
    LOADED_FRACTION of the weight."""
    n = slow_walk.t.size
    tilt, load = np.zeros(n), np.full(n, 6.0)
    tilt[1000:] = np.deg2rad(6.0)
    unloaded = np.zeros(n)
    walked = wb.Walk(np.zeros((n, wb.DOF)), np.zeros((n, 8)), tilt, tilt, unloaded, load, 6.5)
    assert wb.tip_time(slow_walk, walked) == pytest.approx(slow_walk.t[1000])
    light = wb.Walk(
        np.zeros((n, wb.DOF)), np.zeros((n, 8)), tilt, tilt, unloaded, 0.5 * load / 6, 6.5
    )
    assert wb.tip_time(slow_walk, light) is None


def _settings(plan, *, feedforward: bool, force_limit: float | None = None) -> dict:
    """The spec's servo loop (as ``bench/sim/model.servo_settings``'s ``servo`` mode builds
    it, here without the bench) on a soft floor like the default scene's (corner stiffness
    6707 N/m, contact time 20 ms); ``feedforward``: the planned servo torque, clipped."""
    spec = plan.spec
    limit = spec.stall_torque if force_limit is None else force_limit
    ff = np.clip(servo_torque(plan), -limit, limit) if feedforward else None
    return dict(
        stiffness=spec.stiffness,
        velocity_gain=spec.velocity_gain,
        damping=spec.joint_damping,
        armature=spec.armature,
        force_limit=limit,
        feedforward=ff,
        corner_stiffness=6707.0,
        contact_time=0.02,
    )


@pytest.mark.parametrize(
    "step_time, slope, feedforward, force_limit",
    [
        (2.0, 0.0, False, None),  # walks: both stances, landings, the second sole held
        (1.0, 10.0, True, None),  # fed forward
        (0.6, 15.0, False, 0.3),  # the output clipped most of the walk
        (0.5, 25.0, False, None),  # tips and falls: the walk held from there
    ],
)
def test_the_compiled_walk_is_its_numpy_twin(spec, step_time, slope, feedforward, force_limit):
    """The kernel's time loop (kernel/whole_body.py) against ``_integrate``: the same
    backward Euler, the same contacts; its 11 × 11 solves are LU with partial pivoting in
    another order than LAPACK's, so the states agree to rounding carried by a contractive
    step (held to 1e-9 m and rad), the loads to 1e-6 N, and the tip to the sample."""
    plan = plan_walk(spec, GaitParams.nominal(spec, step_time, slope=np.deg2rad(slope)))
    settings = _settings(plan, feedforward=feedforward, force_limit=force_limit)
    mine = wb.walk(plan, **settings)
    numpy = wb.walk(plan, compiled=False, **settings)
    np.testing.assert_allclose(mine.x, numpy.x, rtol=0, atol=1e-9)
    np.testing.assert_allclose(mine.force, numpy.force, rtol=0, atol=1e-6)
    assert wb.tip_time(plan, mine) == wb.tip_time(plan, numpy)


@pytest.mark.parametrize("compiled", [True, False])
def test_a_corner_off_the_plane_carries_no_load(spec, compiled):
    """MuJoCo's soft contact, damper included, acts only on a geom pressed into the plane:
    a corner carries load only where its spring is pressed, f_nom − k_c (height + z) > 0,
    however fast it comes down. The walk: a design gait at the joint damping's estimated high
    end (0.56 N m s/rad), whose swing sole lags 1.6 mm above the plane at its touch-down
    (results/README.md, stop 58); the damper alone held its toe up on 3.4 N there."""
    stiff = spec_at(spec, "servo.damping", 0.56)
    plan = plan_walk(stiff, leaning_uphill(stiff))
    settings = _settings(plan, feedforward=False)
    walked = wb.walk(plan, compiled=compiled, **settings)
    model = wb.model_of(plan)
    z = model.height + np.einsum("cjn,nj->cn", model.corner, walked.x)
    pressed = model.nominal - settings["corner_stiffness"] * z
    loaded = walked.force.T > 0
    assert loaded.any()
    assert (pressed[loaded] > 0).all(), pressed[loaded].min()
    off = plan.double_support & (z[:4] > 1e-3).all(axis=0)  # the new sole above the plane
    assert off.any() and (walked.stance_load[off] == 0).all()


def test_the_compiled_model_is_its_numpy_twin(spec):
    """M and the stiffness from the kernel's per-sample loops against the numpy twin's
    batched products: the same sums in another order, held to 1e-12 of their scale."""
    plan = plan_walk(spec, GaitParams.nominal(spec, 0.5, steps=2, slope=np.deg2rad(-12.0)))
    mine, numpy = wb.model_of(plan), wb.model_of(plan, compiled=False)
    for a, b in ((mine.mass, numpy.mass), (mine.stiffness, numpy.stiffness)):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 * np.abs(b).max())
        np.testing.assert_allclose(a, a.transpose(0, 2, 1), rtol=0, atol=1e-12 * np.abs(b).max())


@pytest.mark.parametrize("name", ["stiffness", "force_limit", "corner_stiffness", "contact_time"])
@pytest.mark.parametrize("value", [0.0, -1.0, float("nan"), float("inf"), "6707"])
def test_a_bad_setting_is_one_error_naming_it(slow_walk, name, value):
    settings = _settings(slow_walk, feedforward=False) | {name: value}
    with pytest.raises(SlopewalkError) as err:
        wb.walk(slow_walk, **settings)
    message = str(err.value)
    assert f"{name} {value!r}" in message and "\n" not in message
