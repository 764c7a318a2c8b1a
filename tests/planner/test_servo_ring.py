"""The servo's ring (``planner/servo_ring.py``): the slowest decay of the loaded chain
against hand-derived cases and against its free response, stepped exactly here (expm); the
settling time on the default robot; the ``ring`` event."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.linalg import expm

from slopewalk.planner import servo_loop
from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.servo_ring import (
    RING_DECAYS,
    RingLoop,
    landing_rows,
    settle_times,
    slowest_decay,
    unsettled_landing,
)
from slopewalk.planner.trajectory import Timeline
from slopewalk.planner.verdict import PredictedEvent, predict, ring_events, verdict

A, D, KP = 0.0232, 1.5 / 6.18, 9.26  # the default spec's AX-12A: armature, damping, kp


def _ax12(spec, scale=1.0) -> RingLoop:
    return RingLoop(spec.armature * scale, spec.joint_damping, spec.stiffness)


def _settle(plan, loop) -> np.ndarray:
    """t_settle at each touch-down of ``plan``, as bench/sim/prediction.py makes it."""
    return settle_times(*servo_loop.linearised_at(plan, landing_rows(plan)), loop)


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


def test_the_links_make_the_ring_last_longer_than_the_joints_own(spec):
    """On the default robot's walk the loaded chain settles later than a joint alone
    (RING_DECAYS · 2A / D) and no later than a joint carrying A plus the chain's largest
    mass-matrix eigenvalue (light damping: each mode's modal inertia lies between)."""
    plan = plan_walk(spec, GaitParams.nominal(spec, 0.75, steps=3))
    loop = _ax12(spec)
    settle = _settle(plan, loop)
    downs = Timeline.of(plan.params).touch_downs
    assert landing_rows(plan).tolist() == (downs - 1).tolist()
    mass, _ = servo_loop.linearised_at(plan, downs - 1)
    heaviest = np.linalg.eigvalsh(0.5 * (mass + mass.transpose(0, 2, 1))).max(axis=1)
    alone = RING_DECAYS * 2 * loop.armature / loop.damping
    assert np.all(settle > 1.2 * alone)
    assert np.all(settle <= 1.05 * RING_DECAYS * 2 * (loop.armature + heaviest) / loop.damping)


def test_the_rows_are_the_full_linearisations(spec):
    plan = plan_walk(spec, GaitParams.nominal(spec, 0.5, steps=2))
    rows = np.array([3, 250, 499, 700])
    mass, gravity_k = servo_loop.linearised_at(plan, rows)
    _, want_mass, want_k, _ = servo_loop.linearised(plan)
    scale = np.abs(want_k).max()
    np.testing.assert_allclose(mass, want_mass[rows], rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(gravity_k, want_k[rows], rtol=0, atol=1e-6 * scale)


def test_a_stiff_loop_settles_at_once_an_undamped_one_never_and_no_inertia_rings_none(spec):
    plan = plan_walk(spec, GaitParams.nominal(spec, 0.5, steps=2))
    assert np.all(_settle(plan, RingLoop(spec.armature, 2.0 + D, 200.0)) < 0.1)
    assert np.all(_settle(plan, RingLoop(spec.armature, 0.0, spec.stiffness)) == np.inf)
    zero = np.zeros((8, 8))
    assert slowest_decay(zero, zero, RingLoop(0.0, 0.0, 0.0)) == 0.0


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
    gap = plan.t[downs[1]] - plan.t[downs[0]]
    found = unsettled_landing(plan, _settle(plan, _ax12(spec)))  # 0.59 s ring, 0.5 s steps
    assert found is not None and found[0] == downs[1] and found[1] > gap
    assert unsettled_landing(plan, _settle(plan, _ax12(spec, 0.25))) is None  # 0.35 s of ring
    one = plan_walk(spec, GaitParams.nominal(spec, 0.5, steps=1))
    assert unsettled_landing(one, _settle(one, _ax12(spec, 10.0))) is None  # one landing


@pytest.mark.parametrize(("step_time", "rings"), [(0.5, True), (0.75, False)])
def test_a_walk_faster_than_the_ring_is_predicted_ring(spec, step_time, rings):
    plan = plan_walk(spec, GaitParams.nominal(spec, step_time, steps=3))
    settle = _settle(plan, _ax12(spec))
    events = ring_events(plan, settle)
    assert bool(events) == rings
    if rings:  # at the second landing, one step after the first
        first, second = plan.t[Timeline.of(plan.params).touch_downs[:2]]
        assert events[0].time == pytest.approx(second)
        assert second - first == pytest.approx(step_time, abs=2e-3)
    assert ring_events(plan, None) == []
    kinds = [e.kind for e in predict(plan, friction=1.0, ring_settle=settle).events]
    assert ("ring" in kinds) == rings
    assert "ring" not in [e.kind for e in predict(plan, friction=1.0).events]


def test_ring_decides_only_where_no_mechanism_does():
    ring, tip = PredictedEvent(1.0, "ring", "r"), PredictedEvent(2.0, "tip", "t")
    assert verdict([ring]) == "ring"
    assert verdict([ring, tip]) == "tip"
    assert verdict([PredictedEvent(1.0, "foot_slide", "f"), ring]) == "foot_slide"
