"""The servo's ring (``planner/servo_ring.py``): its settling time against the free
response of the joint's own mass-spring, integrated here, and the ``ring`` event."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp
from scipy.signal import find_peaks

from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.servo_ring import settle_time, unsettled_landing
from slopewalk.planner.trajectory import Timeline
from slopewalk.planner.verdict import PredictedEvent, predict, ring_events, verdict

AX12 = {"armature": 0.0232, "damping": 1.5 / 6.18}  # the default spec's servo (no kv)


def _ring_envelope(armature, damping, stiffness, t_end):
    """Peaks of |θ| of A θ̈ + d θ̇ + kp θ = 0 from θ = 1 at rest: (times, heights)."""
    sol = solve_ivp(
        lambda t, y: [y[1], -(damping * y[1] + stiffness * y[0]) / armature],
        (0.0, t_end),
        [1.0, 0.0],
        max_step=2e-3,
        rtol=1e-9,
        atol=1e-12,
    )
    peaks, _ = find_peaks(np.abs(sol.y[0]))
    return sol.t[peaks], np.abs(sol.y[0][peaks])


@settings(max_examples=12, deadline=None)
@given(stiffness=st.sampled_from([6.17, 9.26, 18.5, 40.0]), scale=st.floats(0.5, 2.0))
def test_the_ring_is_down_to_five_percent_at_the_settling_time_whatever_kp(stiffness, scale):
    armature, damping = AX12["armature"] * scale, AX12["damping"]
    settle = settle_time(armature, damping)
    times, heights = _ring_envelope(armature, damping, stiffness, 1.5 * settle)
    # the peaks lie on the envelope exp(-d t / 2A) (to the phase of the peak): at the
    # settling time it is exp(-3) of the start
    envelope_at = np.interp(settle, times, np.log(heights))
    assert envelope_at == pytest.approx(-3.0, abs=0.15)


def test_the_ax12a_settles_in_0_57_s():
    assert settle_time(**AX12) == pytest.approx(3 * 2 * 0.0232 / (1.5 / 6.18))
    assert settle_time(**AX12) == pytest.approx(0.573, abs=1e-3)


def test_a_stiff_loop_settles_at_once_and_an_undamped_one_never():
    assert settle_time(0.0232, 2.0) < 0.1  # kv = 2 N m s/rad ("stiff")
    assert settle_time(0.0232, 0.0) == np.inf
    assert settle_time(0.0, 0.0) == 0.0


@pytest.mark.parametrize("bad", [(-1.0, 0.2), (0.02, -0.1), (np.nan, 0.2), (0.02, np.nan)])
def test_bad_settings_are_refused_in_one_line(bad):
    with pytest.raises(SlopewalkError, match="must be >= 0") as err:
        settle_time(*bad)
    assert "\n" not in str(err.value)


def test_the_touch_downs_are_where_double_support_begins_after_single_support(spec):
    plan = plan_walk(spec, GaitParams.nominal(spec, 0.5, steps=2))
    downs = Timeline.of(plan.params).touch_downs
    both = plan.double_support
    assert downs.tolist() == (np.flatnonzero(~both[:-1] & both[1:]) + 1).tolist()
    gap = plan.t[downs[1]] - plan.t[downs[0]]
    # landings one step apart: a ring that takes longer finds the second one
    assert unsettled_landing(plan, gap + 1e-6) == downs[1]
    assert unsettled_landing(plan, gap) is None
    one = plan_walk(spec, GaitParams.nominal(spec, 0.5, steps=1))
    assert unsettled_landing(one, 10.0) is None  # one landing


@pytest.mark.parametrize(("step_time", "rings"), [(0.5, True), (0.75, False)])
def test_a_walk_faster_than_the_ring_is_predicted_ring(spec, step_time, rings):
    plan = plan_walk(spec, GaitParams.nominal(spec, step_time, steps=3))
    settle = settle_time(**AX12)
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
