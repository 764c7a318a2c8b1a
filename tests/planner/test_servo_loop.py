"""Servo-loop dynamics: the mass matrix is a mass matrix, a damped loop settles on the static
fixed point, a soft loop rings at its own frequency about it, and the output is clipped."""

import numpy as np
import pytest

from slopewalk.planner.compliance import compliant_walk
from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.servo_loop import linearised, servo_walk


@pytest.fixture(scope="module")
def plan(spec):
    return plan_walk(spec, GaitParams.nominal(spec, 1.0, steps=2))


def test_the_mass_matrix_of_single_support_is_symmetric_positive(plan):
    """No load on the other foot: M = ∂τ/∂q̈ is the chain's kinetic-energy matrix."""
    _, mass, _, _ = linearised(plan)
    single = ~plan.double_support
    m = mass[single]
    np.testing.assert_allclose(m, np.swapaxes(m, 1, 2), atol=1e-9)
    assert np.linalg.eigvalsh(m).min() > 0


def test_the_linearisation_predicts_the_torque_of_a_nearby_pose(spec, plan):
    """τ(q + δ) ≈ τ(q) + K_g δ to second order in δ."""
    from slopewalk.planner.compliance import _Dynamics

    tau, _, k, _ = linearised(plan)
    delta = np.full(8, 1e-3)
    moved = _Dynamics(plan).torque(plan.q + delta, plan.qd, plan.qdd)
    first = np.abs(moved - tau).max()
    assert first > 1e-4  # the pose change matters ...
    np.testing.assert_allclose(moved, tau + k @ delta, atol=1e-2 * first)  # ... and K_g has it


def test_a_damped_loop_settles_on_the_static_fixed_point(spec, plan):
    """kp 200, kv 5: critically damped or more; the sway dies within a few ms of each jump."""
    kw = dict(stiffness=200.0, velocity_gain=5.0, armature=spec.armature)
    static = compliant_walk(plan, **kw)
    dynamic = servo_walk(plan, **kw)
    assert dynamic.converged
    gap = np.abs(dynamic.deflection - static.deflection)
    assert np.median(gap) < 0.05 * np.abs(static.deflection).max()


def test_a_soft_loop_rings_at_its_own_frequency(spec):
    """The AX-12A loop on the slow walk: the sway about the fixed point sits at ~2-3.5 Hz.

    Measured in MuJoCo (2 s steps, flat, servo): the joints ring at 2.5-2.8 Hz about
    the fixed point. √(kp / A) / 2π = 3.2 Hz is the unloaded joint's frequency, the
    shank and foot on it lower it (without the rotor inertia A it would be ~1 Hz
    gait content, the sway half as large).
    """
    plan = plan_walk(spec, GaitParams.nominal(spec, 2.0, steps=2))
    damping = spec.joint_damping
    kw = dict(stiffness=spec.stiffness, damping=damping, armature=spec.armature)
    sway = servo_walk(plan, **kw).deflection - compliant_walk(plan, **kw).deflection
    x = sway[:, 5] - sway[:, 5].mean()  # the swing knee: its own servo's mode
    f = np.fft.rfftfreq(x.size, plan.t[1] - plan.t[0])
    power = np.abs(np.fft.rfft(x)) ** 2
    band = f > 1.0
    assert 2.0 < f[band][np.argmax(power[band])] < 3.5
    assert np.sqrt(np.mean(x**2)) > np.deg2rad(0.3)  # a sway the static pass misses


def test_a_limited_servo_falls_behind(spec, plan):
    """Beyond its limit the servo delivers the limit: the joint lags more than without one,
    and ``loop_torque`` keeps what the loop asked for."""
    kw = dict(stiffness=spec.stiffness, armature=spec.armature)
    free = servo_walk(plan, **kw)
    limit = 0.5 * np.abs(free.loop_torque).max()
    held = servo_walk(plan, force_limit=limit, **kw)
    assert np.abs(held.loop_torque).max() > limit  # it asked for more ...
    assert np.abs(held.deflection).max() > 1.2 * np.abs(free.deflection).max()  # ... and lags


def test_double_support_holds_the_second_sole(spec, plan):
    """With the closed chain the second sole's pose (x, z, roll, pitch) stays put through each
    double support, to first order; with the plan's split alone it sways with the legs."""
    from slopewalk.planner.servo_loop import HELD, support_jacobian

    kw = dict(stiffness=spec.stiffness, armature=spec.armature)
    jac = support_jacobian(plan)[:, HELD]
    both = np.flatnonzero(plan.double_support)
    runs = np.split(both, np.flatnonzero(np.diff(both) > 1) + 1)

    def drift(walk):
        d = -walk.deflection  # δ = q − q_ref
        return max(np.abs(np.einsum("nij,nj->ni", jac[r], d[r] - d[r[1]])).max() for r in runs)

    held = drift(servo_walk(plan, **kw))
    loose = drift(servo_walk(plan, closed_chain=False, **kw))
    assert held < 0.05 * loose


def test_the_open_chain_beside_the_walk_is_the_loop_with_no_sole_held(spec, plan):
    """``open_chain_too`` integrates the same loop on the same linearisation with the
    second sole never held: its deflection is the ``closed_chain=False`` walk's, bit for
    bit, and the walk itself is the one made without it."""
    kw = dict(stiffness=spec.stiffness, armature=spec.armature, force_limit=1.5)
    both = servo_walk(plan, open_chain_too=True, **kw)
    np.testing.assert_array_equal(both.deflection, servo_walk(plan, **kw).deflection)
    opened = servo_walk(plan, closed_chain=False, **kw).deflection
    np.testing.assert_array_equal(both.open_deflection, opened)
    assert np.abs(both.open_deflection - both.deflection)[plan.double_support].max() > 1e-3
    assert servo_walk(plan, **kw).open_deflection is None


@pytest.mark.parametrize(
    "kw",
    [
        dict(stiffness=0.0),
        dict(stiffness=9.0, force_limit=-1.0),
        dict(stiffness=9.0, friction=0.0),
        dict(stiffness=9.0, friction=float("nan")),
    ],
)
def test_bad_gains_name_the_value(plan, kw):
    with pytest.raises(SlopewalkError, match="must be > 0"):
        servo_walk(plan, **kw)


@pytest.mark.parametrize("compiled", [False, True])
@pytest.mark.parametrize("push, friction", [(20.0, 1.0), (5.0, 1.0), (5.0, np.inf), (12.0, 0.8)])
def test_a_trailing_sole_is_held_along_the_plane_only_inside_the_friction_cone(
    compiled, push, friction
):
    """Hand-derived: as below, but the plan carries the sole along x at 10 mm/s while the
    loop presses it down with ``push`` N. Held, v' = −q̇_ref, so the plane's wrench is
    λ = m a − f = (−10, push, 0, 0) N: held while 10 ≤ μ push (20 N at μ 1; 5 N without
    a bound), let go where the hold would need more than the cone gives (5 N at μ 1,
    12 N at μ 0.8: 10 > 9.6), the free step a = f."""
    from slopewalk.planner.kernel import servo
    from slopewalk.planner.servo_loop import _trailing

    h, dof = 1e-3, 4
    eye, zero = np.eye(dof), np.zeros((dof, dof))
    force = np.array([0.0, -push, 0.0, 0.0])
    drag = np.array([0.01, 0.0, 0.0, 0.0])
    still = np.zeros(dof)
    args = (eye, zero, zero, force, still, still, h, eye, drag, friction)
    if compiled:
        v, d, a, ok, held, normal, along = servo._trailing(*args)
        assert ok
    else:
        v, d, a, held, normal, along = _trailing(*args)
    assert (normal, along) == pytest.approx((push, 10.0))  # λ_z, |λ_x| [N], as derived
    assert held == (10.0 <= friction * push)
    want = -drag if held else h * force
    np.testing.assert_allclose(v, want, rtol=0, atol=1e-12)


@pytest.mark.parametrize("compiled", [False, True])
def test_a_walk_is_made_again_only_at_a_friction_that_decides_a_lifting_soles_hold(spec, compiled):
    """``friction_decides``: two 0.5 s steps up 10° with the AX-12A loop and no
    feed-forward keep the trailing sole held after lift-off (``_trailing``), each hold as
    long as |λ_x| ≤ μ λ_z. Just above the largest |λ_x| / λ_z of the holds (made at μ = ∞)
    every check comes out the same: the walk at that μ is the same to the bit and says so;
    just below it one hold lets go: another walk, and it says that too."""
    from slopewalk.planner.servo_loop import friction_decides

    plan = plan_walk(spec, GaitParams.nominal(spec, 0.5, steps=2, slope=np.deg2rad(10)))
    kw = dict(
        stiffness=spec.stiffness,
        damping=spec.joint_damping,
        armature=spec.armature,
        force_limit=spec.stall_torque,
        compiled=compiled,
        open_chain_too=True,
    )
    free = servo_walk(plan, friction=np.inf, **kw)
    checks = free.friction_checks
    held = ~np.isnan(checks[:, 0]) & free.held
    assert held.sum() > 2  # holds after lift-off to decide
    ratio = (checks[held, 1] / checks[held, 0]).max()
    assert ratio > 0
    for bad in (0.0, -1.0, np.nan):
        with pytest.raises(SlopewalkError, match="must be > 0"):
            friction_decides(free, bad)
    for mu, decides in ((ratio * 1.001, False), (ratio * 0.999, True)):
        assert friction_decides(free, mu) == decides
        walk = servo_walk(plan, friction=mu, **kw)
        same = np.array_equal(walk.held, free.held) and np.array_equal(
            walk.deflection, free.deflection
        )
        assert same != decides
        np.testing.assert_array_equal(walk.open_deflection, free.open_deflection)


@pytest.mark.parametrize("compiled", [False, True])
@pytest.mark.parametrize("push", [20.0, 5.0])
def test_a_lifting_sole_stays_on_the_plane_while_the_plane_pushes_it(compiled, push):
    """Hand-derived: four joints that are the sole's held rows (J = I), unit mass, no
    stiffness or damping, at rest; the plan lifts the sole at 10 mm/s and the loop presses
    it down with ``push`` N. Held, v' = −q̇_ref and the plane's force is λ_z = m a − f =
    −0.01 / h + push: 10 N at 20 N of push (held), −5 N at 5 N (it would have to pull:
    the free step, a = f)."""
    from slopewalk.planner.kernel import servo
    from slopewalk.planner.servo_loop import _trailing

    h, dof = 1e-3, 4
    eye, zero = np.eye(dof), np.zeros((dof, dof))
    force = np.array([0.0, -push, 0.0, 0.0])
    lift = np.array([0.0, 0.01, 0.0, 0.0])
    still = np.zeros(dof)
    if compiled:
        v, d, a, ok, pushed, normal, along = servo._trailing(
            eye, zero, zero, force, still, still, h, eye, lift, np.inf
        )
        assert ok
    else:
        v, d, a, pushed, normal, along = _trailing(
            eye, zero, zero, force, still, still, h, eye, lift, np.inf
        )
    assert normal == pytest.approx(-0.01 / h + push)
    held = -0.01 / h + push > 0
    assert pushed == held
    want = -lift if held else h * force
    np.testing.assert_allclose(v, want, rtol=0, atol=1e-12)
    np.testing.assert_allclose(d, h * want, rtol=0, atol=1e-15)
