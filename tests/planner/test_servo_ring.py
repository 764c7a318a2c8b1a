"""The servo's ring (``planner/servo_ring.py``): the slowest decay of the loaded chain
against hand-derived cases and against its free response, stepped exactly here (expm); the
ring a load transfer leaves against a mass-spring driven through it (integrated here); the
residual on the default robot; the ``ring`` event."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp
from scipy.linalg import expm

from slopewalk.planner import servo_loop
from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.servo_ring import (
    RING_RESIDUAL,
    RingLoop,
    landing_residuals,
    landing_rows,
    slowest_decay,
    slowest_mode,
    transfer_residual,
    unsettled_landing,
)
from slopewalk.planner.trajectory import Timeline
from slopewalk.planner.verdict import PredictedEvent, predict, ring_events, verdict

A, D, KP = 0.0232, 1.5 / 6.18, 9.26  # the default spec's AX-12A: armature, damping, kp


def _ax12(spec, scale=1.0) -> RingLoop:
    return RingLoop(spec.armature * scale, spec.joint_damping, spec.stiffness)


def _residual(plan, loop) -> np.ndarray:
    """R at each touch-down of ``plan``, as bench/sim/prediction.py makes it."""
    return landing_residuals(plan, *servo_loop.linearised_at(plan, landing_rows(plan)), loop)


def test_a_joint_alone_decays_as_its_own_mass_spring():
    """M = K_g = 0: each joint is A θ̈ + D θ̇ + kp θ = 0, whose roots are
    (−D ± √(D² − 4 A kp)) / 2A: σ = D / 2A underdamped, the slow real root overdamped."""
    zero = np.zeros((8, 8))
    assert slowest_decay(zero, zero, RingLoop(A, D, KP)) == pytest.approx(D / (2 * A))
    heavy = 2 * np.sqrt(A * KP) * 3  # damping ratio 3
    slow = (heavy - np.sqrt(heavy**2 - 4 * A * KP)) / (2 * A)
    assert slowest_decay(zero, zero, RingLoop(A, heavy, KP)) == pytest.approx(slow)
    assert slowest_decay(zero, zero, RingLoop(A, 0.0, KP)) == pytest.approx(0.0, abs=1e-9)
    # gravity taking 99 % of the spring: A θ̈ + D θ̇ + 0.01 kp θ = 0 is overdamped and
    # creeps back; taking more than all of it, the loop cannot hold the pose (σ < 0)
    soft = 0.01 * KP
    creep = (D - np.sqrt(D**2 - 4 * A * soft)) / (2 * A)
    sag = -0.99 * KP * np.eye(8)
    assert slowest_decay(zero, sag, RingLoop(A, D, KP)) == pytest.approx(creep)
    assert slowest_decay(zero, -1.5 * KP * np.eye(8), RingLoop(A, D, KP)) < 0


def _late_decay(mass, gravity_k, loop, t_end, samples=12000):
    """The decay rate [1/s] of the free response's envelope, max |δ| over each of two late
    windows, from a generic start. The response is the free system's own: the first-order
    form F of (M + A) δ̈ + D δ̇ + (K_g + kp) δ = 0 stepped exactly by expm(F dt) (no
    eigen-decomposition), the state rescaled at every step and the scale kept in log, so it
    is followed far below any tolerance, long enough for modes that decay only a little
    faster than the slowest to die too."""
    n = mass.shape[0]
    inertia = mass + loop.armature * np.eye(n)
    spring = gravity_k + loop.stiffness * np.eye(n)
    first_order = np.block([
        [np.zeros((n, n)), np.eye(n)],
        [-np.linalg.solve(inertia, spring), -np.linalg.solve(inertia, loop.damping * np.eye(n))],
    ])  # fmt: skip
    t = np.linspace(0.0, t_end, samples + 1)
    step = expm(first_order * (t[1] - t[0]))
    state = np.concatenate([np.linspace(1.0, -0.7, n), np.zeros(n)])
    log_size, scale = np.empty(t.size), 0.0
    for k in range(t.size):
        log_size[k] = np.log(np.abs(state[:n]).max()) + scale
        size = np.abs(state).max()
        state, scale = step @ (state / size), scale + np.log(size)
    first, second = (t > 0.55 * t_end) & (t < 0.75 * t_end), t > 0.8 * t_end
    t1, t2 = t[first][np.argmax(log_size[first])], t[second][np.argmax(log_size[second])]
    return -(log_size[second].max() - log_size[first].max()) / (t2 - t1)


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**16), link=st.floats(0.2, 2.0), sag=st.floats(-0.3, 0.3))
def test_the_slowest_decay_is_the_free_responses(seed, link, sag):
    """A chain-like M (symmetric, positive definite, up to ``link`` × A) and a gravity
    stiffness up to ``sag`` × kp (sign either way, not symmetric): the envelope of the
    free response (stepped exactly, expm) decays at σ late on, once the faster modes have died."""
    rng = np.random.default_rng(seed)
    n = 4
    basis = rng.normal(size=(n, n))
    mass = link * A * (basis @ basis.T) / n
    gravity_k = sag * KP * rng.uniform(-1, 1, size=(n, n)) / n
    loop = RingLoop(A, D, KP)
    sigma = slowest_decay(mass, gravity_k, loop)
    assert sigma > 0
    assert _late_decay(mass, gravity_k, loop, 96.0 / sigma) == pytest.approx(sigma, rel=0.1)


@settings(max_examples=25, deadline=None)
@given(
    omega=st.floats(5.0, 30.0),
    zeta=st.floats(0.03, 0.6),
    transfer=st.floats(0.01, 0.6),
    after=st.floats(0.0, 0.4),
)
def test_the_residual_is_what_a_mass_spring_driven_through_the_transfer_rings_with(
    omega, zeta, transfer, after
):
    """x'' + 2ζω x' + ω² x = ω² s(t), s the plan's cubic 3u² − 2u³ over the transfer
    (u = t / t_d), integrated here from rest: its ring about x = 1 at t_d + after, the
    amplitude √(e² + ((ė + σe)/ω_d)²) of e = x − 1, is R times the ring a sudden step
    starts with (ω / ω_d), λ = −σ + i ω_d its root."""
    sigma, damped = zeta * omega, omega * np.sqrt(1 - zeta**2)

    def load(t):
        u = min(max(t / transfer, 0.0), 1.0)
        return 3 * u**2 - 2 * u**3

    def rate(t, y):
        return [y[1], omega**2 * (load(t) - y[0]) - 2 * sigma * y[1]]

    end = transfer + after
    got = solve_ivp(rate, (0.0, end), [0.0, 0.0], method="DOP853", rtol=1e-11, atol=1e-13,
                    max_step=transfer / 50)  # fmt: skip
    e, de = got.y[0, -1] - 1.0, got.y[1, -1]
    ring = np.hypot(e, (de + sigma * e) / damped)
    left = transfer_residual(complex(-sigma, damped), transfer, end)
    assert ring == pytest.approx(left * omega / damped, rel=1e-6, abs=1e-9)


def test_a_sudden_transfer_leaves_a_steps_ring_and_the_small_a_form_joins_the_closed_one():
    mode = complex(-2.9, 14.0)
    assert transfer_residual(mode, 0.0, 0.6) == pytest.approx(np.exp(-2.9 * 0.6))
    near = 1e-3 / abs(mode)  # the two forms' seam, |a| = 1e-3
    assert transfer_residual(mode, near * 0.999, 0.5) == pytest.approx(
        transfer_residual(mode, near * 1.001, 0.5), rel=1e-5
    )


def test_the_ring_left_grows_with_the_armature_and_shrinks_with_the_damping_and_the_step(
    spec,
):
    """On the default robot's walk: a heavier rotor rings longer, more damping or a longer
    step leaves less; every landing after the first is checked, the first is not."""
    loop = _ax12(spec)
    fast, slow = (plan_walk(spec, GaitParams.nominal(spec, t, steps=3)) for t in (0.5, 0.75))
    base = _residual(fast, loop)
    assert base[0] == 0.0 and np.all(base[1:] > 0)
    assert np.all(_residual(fast, _ax12(spec, 2.0))[1:] > base[1:])
    damped = RingLoop(loop.armature, 2 * loop.damping, loop.stiffness)
    assert np.all(_residual(fast, damped)[1:] < base[1:])
    assert np.all(_residual(slow, loop)[1:] < base[1:])
    mass, gravity_k = servo_loop.linearised_at(fast, landing_rows(fast))
    # the chain's slowest mode decays slower than the joint alone (σ = D / 2A)
    assert -slowest_mode(mass[1], gravity_k[1], loop).real < loop.damping / (2 * loop.armature)


def test_the_rows_are_the_full_linearisations(spec):
    plan = plan_walk(spec, GaitParams.nominal(spec, 0.5, steps=2))
    rows = np.array([3, 250, 499, 700])
    mass, gravity_k = servo_loop.linearised_at(plan, rows)
    _, want_mass, want_k, _ = servo_loop.linearised(plan)
    scale = np.abs(want_k).max()
    np.testing.assert_allclose(mass, want_mass[rows], rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(gravity_k, want_k[rows], rtol=0, atol=1e-6 * scale)


def test_a_stiff_loop_leaves_no_ring_an_undamped_one_all_and_no_inertia_none(spec):
    plan = plan_walk(spec, GaitParams.nominal(spec, 0.5, steps=2))
    assert np.all(_residual(plan, RingLoop(spec.armature, 2.0 + D, 200.0)) < 1e-3)
    undamped = _residual(plan, RingLoop(spec.armature, 0.0, spec.stiffness))
    assert np.all(undamped[1:] > RING_RESIDUAL)
    zero = np.zeros((8, 8))
    assert slowest_decay(zero, zero, RingLoop(0.0, 0.0, 0.0)) == 0.0
    zeros = np.zeros((2, 8, 8))  # the loop with no inertia: nothing rings
    assert landing_residuals(plan, zeros, zeros, RingLoop(0.0, 0.0, KP)).tolist() == [0.0, 0.0]


@pytest.mark.parametrize(
    "bad",
    [
        (-1.0, 0.2, 9.0),
        (0.02, -0.1, 9.0),
        (np.nan, 0.2, 9.0),
        (0.02, np.inf, 9.0),
        (0.02, 0.2, -1.0),
        (0.02, 0.2, "9"),
    ],  # fmt: skip
)
def test_bad_settings_are_refused_in_one_line(bad):
    with pytest.raises(SlopewalkError, match="must be a finite number >= 0") as err:
        RingLoop(*bad)
    assert "\n" not in str(err.value)


def test_the_unsettled_landing_is_the_first_touch_down_inside_the_ring(spec):
    plan = plan_walk(spec, GaitParams.nominal(spec, 0.5, steps=2))
    downs = Timeline.of(plan.params).touch_downs
    assert (
        downs.tolist()
        == (np.flatnonzero(~plan.double_support[:-1] & plan.double_support[1:]) + 1).tolist()
    )
    left = _residual(plan, _ax12(spec))
    found = unsettled_landing(plan, left)  # 24 % of a step's ring left at 0.5 s steps
    assert found is not None and found[0] == downs[1] and found[1] == left[1] > RING_RESIDUAL
    assert unsettled_landing(plan, _residual(plan, _ax12(spec, 0.25))) is None  # 9 %
    one = plan_walk(spec, GaitParams.nominal(spec, 0.5, steps=1))
    assert unsettled_landing(one, _residual(one, _ax12(spec, 10.0))) is None  # one landing


@pytest.mark.parametrize(("step_time", "rings"), [(0.5, True), (0.75, False)])
def test_a_walk_faster_than_the_ring_is_predicted_ring(spec, step_time, rings):
    plan = plan_walk(spec, GaitParams.nominal(spec, step_time, steps=3))
    left = _residual(plan, _ax12(spec))
    events = ring_events(plan, left)
    assert bool(events) == rings
    if rings:  # at the second landing, one step after the first
        first, second = plan.t[Timeline.of(plan.params).touch_downs[:2]]
        assert events[0].time == pytest.approx(second)
        assert second - first == pytest.approx(step_time, abs=2e-3)
    assert ring_events(plan, None) == []
    kinds = [e.kind for e in predict(plan, friction=1.0, ring_residual=left).events]
    assert ("ring" in kinds) == rings
    assert "ring" not in [e.kind for e in predict(plan, friction=1.0).events]


def test_ring_decides_only_where_no_mechanism_does():
    ring, tip = PredictedEvent(1.0, "ring", "r"), PredictedEvent(2.0, "tip", "t")
    assert verdict([ring]) == "ring"
    assert verdict([ring, tip]) == "tip"
    assert verdict([PredictedEvent(1.0, "foot_slide", "f"), ring]) == "foot_slide"
