"""The compiled servo-loop predictors (planner/kernel/dynamics.py, servo.py) against their
numpy twins (compliance._Dynamics, servo_loop.linearised / support_jacobian / _integrate).

Tolerances are properties of the sums, not of this machine: the torques are the same
sums in another order (rounding ~1e-15 of their scale, held to 1e-9); the central
differences of K_g, C and the sole's Jacobian divide that rounding by their step
(1e-6): held to 1e-6 of the torque's scale; the loop through time is backward Euler,
contractive, so the walks made stay within 1e-8 rad.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from slopewalk.planner import servo_loop
from slopewalk.planner.compliance import _Dynamics, compliant_walk
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.kernel import dynamics, servo
from slopewalk.planner.plan import plan_walk


@pytest.fixture(scope="module")
def plan(spec):
    """Two 0.5 s steps up 10°: both stances, double support, a swap of the legs."""
    return plan_walk(spec, GaitParams.nominal(spec, 0.5, steps=2, slope=np.deg2rad(10)))


@pytest.fixture(scope="module")
def inputs(plan):
    return dynamics.plan_inputs(plan)


@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), size=st.floats(0.01, 0.5))
def test_compiled_torques_are_the_numpy_torques_at_sampled_states(plan, inputs, seed, size):
    """Random joint angles, rates and accelerations about the plan: every term of the
    recursion (Coriolis, the swing split in double support) is loaded."""
    rng = np.random.default_rng(seed)
    shape = plan.q.shape
    q = plan.q + size * rng.standard_normal(shape)
    qd = plan.qd + 10 * size * rng.standard_normal(shape)
    qdd = plan.qdd + 100 * size * rng.standard_normal(shape)
    chain, gravity, side, sole, share = inputs
    got = dynamics.torques(chain, gravity, q, qd, qdd, side, sole, share)
    want = _Dynamics(plan).torque(q, qd, qdd)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9 * np.abs(want).max())


@settings(max_examples=4, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), size=st.floats(0.01, 0.3))
def test_compiled_plan_of_is_the_numpy_plan_of_at_sampled_states(plan, seed, size):
    """The walk at other joint motion (``_Dynamics.plan_of``): torques, ZMP (the kernel's
    as the wrench's CoP, numpy's link by link, eq. (4)), CoM, swing sole, forces, margin.
    The ZMP, its margin and the friction ratio divide by F_z, which a random state takes
    near 0 (a ZMP km away): their rounding is relative, held to 1e-9 of the value."""
    rng = np.random.default_rng(seed)
    shape = plan.q.shape
    q = plan.q + size * rng.standard_normal(shape)
    qd = plan.qd + 10 * size * rng.standard_normal(shape)
    qdd = plan.qdd + 100 * size * rng.standard_normal(shape)
    dyn = _Dynamics(plan)
    got, want = dyn.plan_of(q, qd, qdd, compiled=True), dyn.plan_of(q, qd, qdd)
    force = np.abs(want.ground_force).max()
    for name, atol in [
        ("tau", 1e-9 * np.abs(want.tau).max()),
        ("zmp", 1e-9),  # [m]
        ("zmp_lipm", 1e-9),
        ("com", 1e-12),
        ("com_acc", 1e-9 * np.abs(want.com_acc).max()),
        ("swing_sole", 1e-12),
        ("margin", 1e-9),
        ("ground_force", 1e-9 * force),
        ("stance_force", 1e-9 * force),
        ("swing_force", 1e-9 * force),
        ("friction_ratio", 1e-9),
    ]:
        np.testing.assert_allclose(getattr(got, name), getattr(want, name), rtol=1e-9, atol=atol)
    assert np.array_equal(got.q, q) and np.array_equal(got.polygon, plan.polygon)


def test_compiled_linearisation_is_the_numpy_one(plan):
    tau, mass, stiff, vel, jac = servo_loop._linearised_compiled(plan)
    want = servo_loop.linearised(plan) + (servo_loop.support_jacobian(plan),)
    scale = np.abs(want[0]).max()
    assert plan.double_support.any() and (~plan.double_support).any()
    np.testing.assert_allclose(tau, want[0], rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(mass, want[1], rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(stiff, want[2], rtol=0, atol=1e-6 * scale)
    np.testing.assert_allclose(vel, want[3], rtol=0, atol=1e-6 * scale)
    np.testing.assert_allclose(jac, want[4], rtol=0, atol=1e-6)


@pytest.mark.parametrize("limit", [np.inf, 0.3])
@pytest.mark.parametrize("share", [0.5, 0.0])
def test_compiled_servo_walk_is_the_numpy_one(spec, plan, limit, share):
    """The AX-12A loop with feedforward (``share`` of the torque; none: the trailing sole
    stays loaded after lift-off, ``_trailing``); at 0.3 N m its output clips."""
    kw = dict(
        stiffness=spec.stiffness,
        velocity_gain=0.05,
        damping=spec.joint_damping,
        armature=spec.armature,
        force_limit=limit,
        feedforward=share * plan.tau if share else None,
    )
    got = servo_loop.servo_walk(plan, **kw)
    want = servo_loop.servo_walk(plan, compiled=False, **kw)
    assert np.isfinite(limit) == (np.abs(want.loop_torque) > limit).any()
    assert got.converged == want.converged
    np.testing.assert_array_equal(got.held, want.held)
    np.testing.assert_array_equal(np.isnan(got.friction_checks), np.isnan(want.friction_checks))
    np.testing.assert_allclose(got.friction_checks, want.friction_checks, rtol=1e-6, atol=1e-6)
    if not share:
        assert (want.held & ~plan.double_support).any()  # a lifting sole held: _trailing ran
    np.testing.assert_allclose(got.deflection, want.deflection, rtol=0, atol=1e-8)
    np.testing.assert_allclose(got.plan.zmp, want.plan.zmp, rtol=0, atol=1e-8)
    np.testing.assert_allclose(got.loop_torque, want.loop_torque, rtol=0, atol=1e-6)


def test_compiled_fixed_point_is_the_numpy_one(spec, plan):
    kw = dict(stiffness=spec.stiffness, armature=spec.armature, velocity_gain=0.1)
    got = compliant_walk(plan, **kw)
    want = compliant_walk(plan, compiled=False, **kw)
    assert (got.iterations, got.converged) == (want.iterations, want.converged)
    np.testing.assert_allclose(got.deflection, want.deflection, rtol=0, atol=1e-10)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 12), order=st.randoms())
def test_the_lu_solve_is_numpys_on_regular_systems(seed, n, order):
    """Diagonally dominant rows shuffled: every column's pivot lies on another row, so the
    row swaps (and how the solve replays them, ``_lu_solve``) are exercised."""
    rng = np.random.default_rng(seed)
    rows = list(range(n))
    order.shuffle(rows)
    a = (rng.standard_normal((n, n)) + n * np.eye(n))[rows]
    b = rng.standard_normal(n)
    x, ok = servo._solve(a, b)
    assert ok
    # LU with partial pivoting on a well-conditioned matrix: a residual of rounding size
    np.testing.assert_allclose(a @ x, b, rtol=0, atol=1e-12 * n * np.abs(b).max())


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), rows=st.integers(1, 4))
def test_the_landing_impulse_stops_the_sole(seed, rows):
    """``_landed`` (one factorisation, several solves) against the impulse's closed form:
    J q̇⁺ = 0, and q̇⁺ − q̇ = M⁻¹ Jᵀ p, on a mass matrix whose rows need swapping."""
    rng = np.random.default_rng(seed)
    root = rng.standard_normal((8, 8))
    mass = root @ root.T + np.eye(8)
    mass[[0, 7]] = mass[[7, 0]]  # not symmetric: the pivots lie off the diagonal
    jac, rate = rng.standard_normal((rows, 8)), rng.standard_normal(8)
    after, ok = servo._landed(mass, jac, rate)
    assert ok
    mj = np.linalg.solve(mass, jac.T)
    want = rate - mj @ np.linalg.solve(jac @ mj, jac @ rate)
    np.testing.assert_allclose(after, want, rtol=0, atol=1e-9 * np.abs(rate).max())
    np.testing.assert_allclose(jac @ after, 0.0, atol=1e-9 * np.abs(jac @ rate).max())


def test_a_singular_system_is_reported_not_solved():
    """Where LU cannot be numpy's minimum-norm answer, the caller must run the numpy twin."""
    a = np.ones((3, 3))
    assert not servo._solve(a, np.ones(3))[1]
