"""Predicted events: joint limits, the planned foot slide, slip beyond μ, the propping
swing sole's drag, severity order."""

from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from slopewalk.planner.compliance import compliant_walk
from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.joints import JOINT_NAMES
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.servo_ring import landing_rows
from slopewalk.planner.strike import strike_roll
from slopewalk.planner.tipping import excursion_integral
from slopewalk.planner.verdict import (
    SLIP_DISTANCE,
    STRUCK,
    TIP_ANGLE,
    PredictedEvent,
    double_support_tilt,
    foot_slide_events,
    landing_tilt,
    planned_slide,
    predict,
    saturation_events,
    slip_events,
    stretch_slide,
    swing_drag_events,
    tip_events,
    verdict,
)


@pytest.fixture(scope="module")
def plan(spec):
    return plan_walk(spec, GaitParams.nominal(spec, 1.0, steps=2))


def test_a_knee_beyond_its_limit_is_predicted(spec, plan):
    low = replace(spec, joint_limits={**spec.joint_limits, "knee": (-0.1, 1.2)})
    tight = plan_walk(low, plan.params)
    result = predict(tight, friction=1.0)
    assert result.verdict == "joint_limit"
    knees = [e for e in result.events if e.kind == "joint_limit"]
    assert {e.cause.split()[0] for e in knees} == {"stance_knee", "swing_knee"}
    assert predict(plan, friction=1.0).verdict == "stable"


def test_the_planned_rear_foot_slide_is_hip_width_times_secant_minus_one(spec, plan):
    """No hip roll: the loaded rear foot moves sideways by Lh (1/cos λ − 1) as the lean turns."""
    expected = spec.hip_width * (1 / np.cos(plan.params.tilt) - 1)  # 1.9 mm at 12°
    assert planned_slide(plan) == pytest.approx(expected, rel=0.15)
    assert not [e for e in predict(plan, friction=1.0).events if e.kind == "foot_slide"]


def test_a_wide_robot_slides_its_rear_foot_past_the_slip_threshold(spec):
    wide = replace(spec, hip_width=0.37)  # 0.37 (1/cos 12° − 1) = 8.3 mm
    plan = plan_walk(wide, GaitParams.nominal(wide, 1.0, steps=2))
    assert planned_slide(plan) > SLIP_DISTANCE
    kinds = [e.kind for e in predict(plan, friction=1.0).events]
    assert "foot_slide" in kinds


def test_a_stretch_slides_as_far_as_the_path_moves_within_the_contact_time():
    """Hand-derived: a sole dragged at v for 0.3 s, sampled every 5 ms, loaded at most τ per
    stretch: a stretch ending t after the drag starts slides v min(t, τ)."""
    t = np.arange(61) * 0.005
    v, tau = 0.04, 0.02  # 40 mm/s, 20 ms: 0.8 mm per stretch
    xy = np.column_stack([np.zeros_like(t), v * t])
    moved = stretch_slide(t, xy, tau)
    assert moved == pytest.approx(v * np.minimum(t, tau), abs=1e-12)
    assert stretch_slide(t, xy, 10.0).max() == pytest.approx(v * t[-1])  # the whole drag


def test_a_wide_robots_drag_is_no_foot_slide_on_a_soft_floor_stretch(spec):
    """The 8.3 mm drag of the wide robot (above) moves the foot < 5 mm in any 20 ms: on
    MuJoCo's soft floor (contact time 20 ms) its chattering sole does not slide 5 mm loaded."""
    wide = replace(spec, hip_width=0.37)
    plan = plan_walk(wide, GaitParams.nominal(wide, 1.0, steps=2))
    assert foot_slide_events(plan)  # rigid floor: loaded through the drag
    assert foot_slide_events(plan, contact_time=0.02) == []
    assert foot_slide_events(plan, contact_time=10.0)  # a stretch as long as the run
    assert "foot_slide" not in [
        e.kind for e in predict(plan, friction=1.0, contact_time=0.02).events
    ]
    with pytest.raises(SlopewalkError, match="contact_time 0.0 s must be > 0"):
        foot_slide_events(plan, contact_time=0.0)


def test_slip_needs_the_excess_friction_long_enough(plan):
    need = plan.friction_ratio.max()
    assert slip_events(plan, friction=need * 1.01)[0] == []
    events, slide = slip_events(plan, friction=0.2 * need)
    assert events and events[0].kind == "slip"
    assert slide.max() > SLIP_DISTANCE


def test_slip_slide_is_driven_by_the_in_plane_force_beyond_mu_n(spec, plan):
    """The slide is the excursion driven by |F_xy| − μ F_z (both in-plane axes of the
    ground force, per row); the event is at its first sample past 5 mm and quotes the
    largest slide in mm."""
    friction = 0.2 * plan.friction_ratio.max()
    f = plan.ground_force
    excess = np.array([np.sqrt(x * x + y * y) - friction * max(z, 0.0) for x, y, z in f])
    expected = excursion_integral(plan.t, excess, spec.total_mass)
    (event,), slide = slip_events(plan, friction)
    np.testing.assert_allclose(slide, expected, rtol=1e-9, atol=1e-12)
    first = next(k for k in range(len(expected)) if expected[k] > SLIP_DISTANCE)
    assert event.time == pytest.approx(plan.t[first])
    assert f"slides the feet {expected.max() * 1e3:.1f} mm (threshold 5 mm)" in event.cause
    assert event.cause.startswith(f"friction ratio {np.nanmax(plan.friction_ratio):.3f} > mu")


def test_verdict_is_the_most_severe_event():
    def e(kind):
        return PredictedEvent(0.0, kind, "")

    assert verdict([]) == "stable"
    assert verdict([e("foot_slide"), e("slip")]) == "slip"
    assert verdict([e("slip"), e("tip"), e("strike")]) == "tip"
    assert verdict([e("tip"), e("joint_limit")]) == "joint_limit"
    # saturation is reported, like the simulator's torque_limit, and decides nothing
    assert verdict([e("saturation")]) == "stable"
    assert verdict([e("saturation"), e("foot_slide")]) == "foot_slide"


def test_a_sagging_servo_strikes_the_plane(spec):
    """0.8 s steps on the AX-12A: the swing sole would go ~25 mm into the plane and roll the
    stance foot ~7.5 deg (tip angle 5); a feedforward loop (no sag) does not."""
    plan = plan_walk(spec, GaitParams.nominal(spec, 0.8))
    damping = spec.joint_damping
    walk = compliant_walk(plan, stiffness=spec.stiffness, damping=damping, armature=spec.armature)
    soft = predict(plan, friction=1.0, walk=walk, stiffness=spec.stiffness)
    assert "strike" in [e.kind for e in soft.events]
    fed = compliant_walk(plan, stiffness=spec.stiffness, damping=damping, feedforward=plan.tau)
    held = predict(plan, friction=1.0, walk=fed, stiffness=spec.stiffness)
    assert "strike" not in [e.kind for e in held.events]


def _struck(walk, depth):
    """``walk`` with its swing sole ``depth`` [m] into the plane through single support
    (carried along the plane as the walk carries it)."""
    sole = walk.plan.swing_sole.copy()
    sole[~walk.plan.double_support, 2] = -depth
    return replace(walk, plan=replace(walk.plan, swing_sole=sole))


def test_a_struck_swing_sole_that_props_the_robot_and_is_carried_on_is_swing_drag(spec, plan):
    """A swing sole pressed into the plane past the leg's give at the strike's onset holds
    the robot up (``strike_roll`` > 0, here short of the tip angle), and the walk carries it
    along the plane: ``swing_drag``. Pressed in less (the leg gives it all) it props nothing;
    pressed in as deep but standing still, it drags nothing."""
    fed = compliant_walk(plan, stiffness=spec.stiffness, feedforward=plan.tau)
    assert predict(plan, friction=1.0, walk=fed, stiffness=spec.stiffness).verdict == "stable"
    depths = np.arange(1, 41) * 0.5e-3  # 0.5 ... 20 mm
    rolls = [strike_roll(_struck(fed, d).plan, spec.stiffness).max() for d in depths]
    giving = max(d for d, r in zip(depths, rolls, strict=True) if r == 0)  # 4.5 mm
    lifting = giving + 2e-3  # the roll at most ~1 deg: no strike
    assert 0 < strike_roll(_struck(fed, lifting).plan, spec.stiffness).max() < TIP_ANGLE / 4
    struck = predict(plan, friction=1.0, walk=_struck(fed, lifting), stiffness=spec.stiffness)
    assert struck.verdict == "swing_drag"
    (drag,) = [e for e in struck.events if e.kind == "swing_drag"]
    assert STRUCK in drag.cause
    given = predict(plan, friction=1.0, walk=_struck(fed, giving), stiffness=spec.stiffness)
    assert given.verdict == "stable"
    still = _struck(fed, lifting)
    ssp = ~still.plan.double_support
    sole = still.plan.swing_sole.copy()
    sole[ssp, :2] = sole[np.flatnonzero(ssp)[0], :2]  # the pressed sole kept in one place
    still = replace(still, plan=replace(still.plan, swing_sole=sole))
    assert predict(plan, friction=1.0, walk=still, stiffness=spec.stiffness).verdict == "stable"


def _landing_turned(walk, row, angle):
    """``walk`` with its swing ankle's roll turned by ``angle`` [rad] at sample ``row``."""
    q = walk.plan.q.copy()
    q[row, JOINT_NAMES.index("swing_ankle_roll")] += angle
    return replace(walk, plan=replace(walk.plan, q=q))


def test_a_swing_sole_landing_tilted_past_the_tip_angle_is_a_tip(spec, plan):
    """The plan lands each swing sole flat (its IK puts the sole on the plane), so its
    landing tilt is 0. Turning the flat sole's ankle roll, whose axis then lies in the
    plane, by δ tilts the sole by exactly δ. Landing tilted 6° (past the 5° tip angle) the
    sole is loaded on its edge: ``tip`` at that landing; tilted 4°, nothing."""
    fed = compliant_walk(plan, stiffness=spec.stiffness, feedforward=plan.tau)
    rows = landing_rows(plan)
    assert rows.size >= 2 and not plan.double_support[rows].any()
    assert np.abs(landing_tilt(plan, rows)).max() < 1e-9
    row = int(rows[1])
    six = _landing_turned(fed, row, np.deg2rad(6.0))
    assert np.rad2deg(landing_tilt(six.plan, [row])[0]) == pytest.approx(6.0, abs=1e-9)
    tipped = predict(plan, friction=1.0, walk=six, stiffness=spec.stiffness)
    assert tipped.verdict == "tip"
    (tip,) = [e for e in tipped.events if e.kind == "tip"]
    assert tip.time == pytest.approx(plan.t[row])
    assert "swing sole tilted 6.0 deg" in tip.cause
    four = _landing_turned(fed, row, np.deg2rad(-4.0))
    assert predict(plan, friction=1.0, walk=four, stiffness=spec.stiffness).verdict == "stable"
    # turned a sample after the landing (the sole already down): not a landing
    late = _landing_turned(fed, row + 1, np.deg2rad(6.0))
    assert "tip" not in [e.kind for e in predict(
        plan, friction=1.0, walk=late, stiffness=spec.stiffness).events]  # fmt: skip


def _opened(walk, rows, joint, angle):
    """``walk`` whose open chain (``open_deflection``) turns ``joint`` by ``angle`` [rad]
    at samples ``rows`` and leaves every other joint on the plan."""
    opened = np.zeros_like(walk.plan.q)
    opened[rows, JOINT_NAMES.index(joint)] = -angle  # q = q_ref − deflection
    return replace(walk, open_deflection=opened)


def test_soles_turned_apart_in_double_support_past_the_tip_angle_are_a_tip(spec, plan):
    """In double support the plan keeps both soles flat, so with the open chain on the
    plan the soles are 0° apart. Turning the second sole's ankle roll, whose axis then
    lies in the plane, by δ turns it δ off the plane: 6° (past the 5° tip angle) in the
    second double support is ``tip`` at its first sample; 4°, or 6° in single support,
    nothing (``double_support_tilt`` reads double support only)."""
    fed = compliant_walk(plan, stiffness=spec.stiffness, feedforward=plan.tau)
    both = np.flatnonzero(plan.double_support)
    # flat to the arccos's resolution at 0: √(2 ε) ≈ 2e-8 rad per ulp of the cosine
    assert np.abs(double_support_tilt(plan, np.zeros_like(plan.q))).max() < 1e-7
    second = both[both > landing_rows(plan)[0]]
    second = second[: np.argmax(np.diff(second) > 1) or second.size]  # one run
    six = _opened(fed, second, "swing_ankle_roll", np.deg2rad(6.0))
    tilt = double_support_tilt(plan, six.open_deflection)
    np.testing.assert_allclose(np.rad2deg(tilt[second]), 6.0, atol=1e-9)
    assert tilt[np.setdiff1d(np.arange(plan.t.size), second)].max() < 1e-7
    tipped = predict(plan, friction=1.0, walk=six, stiffness=spec.stiffness)
    assert tipped.verdict == "tip"
    (tip,) = [e for e in tipped.events if e.kind == "tip"]
    assert tip.time == pytest.approx(plan.t[second[0]])
    assert "two soles 6.0 deg apart" in tip.cause
    four = _opened(fed, second, "swing_ankle_roll", np.deg2rad(-4.0))
    assert predict(plan, friction=1.0, walk=four, stiffness=spec.stiffness).verdict == "stable"
    single = np.flatnonzero(~plan.double_support)
    swinging = _opened(fed, single, "swing_ankle_roll", np.deg2rad(6.0))
    assert predict(plan, friction=1.0, walk=swinging, stiffness=spec.stiffness).verdict == (
        "stable"
    )


def test_a_walk_without_its_stiffness_is_refused(spec, plan):
    """Strike is judged with the servo's kp: a walk given without it is refused up front,
    even where no sole would strike (the kp would go unread and the gap unnoticed)."""
    fed = compliant_walk(plan, stiffness=spec.stiffness, feedforward=plan.tau)
    with pytest.raises(SlopewalkError, match="stiffness"):
        predict(plan, friction=1.0, walk=fed)


def test_saturation_names_the_first_sample_and_the_neediest_joint(spec, plan):
    """A servo limit at 80 % of the walk's peak loop torque: the event sits at the first
    sample where any joint needs more than the limit, and names the joint whose peak is
    highest; a limit above the peak predicts nothing. The reference is a plain loop."""
    damping = spec.joint_damping
    walk = compliant_walk(plan, stiffness=spec.stiffness, damping=damping, armature=spec.armature)
    need = np.abs(walk.loop_torque)  # (n, 8) [N m]
    peak = need.max(axis=0)
    limit = 0.8 * peak.max()
    first = next(k for k in range(len(need)) if any(need[k, j] > limit for j in range(8)))
    neediest = max(range(8), key=lambda j: peak[j])
    (event,) = saturation_events(walk, limit)
    assert event.kind == "saturation"
    assert event.time == pytest.approx(plan.t[first])
    assert event.cause.startswith(f"{JOINT_NAMES[neediest]} asks for {peak[neediest]:.2f} N m")
    assert saturation_events(walk, 1.01 * peak.max()) == []


def _sole_path(moves_mm, props):
    """A walk whose swing sole moves by ``moves_mm`` [mm] along x between samples (1 ms)."""
    x = np.concatenate([[0.0], np.cumsum(moves_mm)]) * 1e-3
    sole = np.column_stack([x, np.zeros_like(x), np.zeros_like(x)])
    return SimpleNamespace(t=np.arange(x.size) * 1e-3, swing_sole=sole), np.array(props)


def test_a_swing_sole_dragged_past_the_slip_distance_while_propping_is_swing_drag():
    # one run of 4 propped samples; the sole moves 2 mm per sample: 6 mm from where
    # the run began at its 4th sample (index 4), the first past 5 mm
    walk, props = _sole_path([1, 2, 2, 2, 2, 1], [0, 1, 1, 1, 1, 0, 0])
    (event,) = swing_drag_events(walk, props)
    assert event.kind == "swing_drag" and event.time == pytest.approx(4e-3)
    # the same motion in two runs of 4 mm each: each run starts its own count
    walk, props = _sole_path([2, 2, 2, 2, 2, 2], [1, 1, 1, 0, 1, 1, 1])
    assert swing_drag_events(walk, props) == []
    # a propped sole that stands still (or 5 mm exactly) is no drag
    walk, props = _sole_path([0, 0, 2.5, 2.5, 0], [1, 1, 1, 1, 1, 1])
    assert swing_drag_events(walk, props) == []
    assert swing_drag_events(walk, np.zeros(6, dtype=bool)) == []
    assert SLIP_DISTANCE == 0.005


def test_a_low_swing_sole_props_the_rocking_in_single_support_and_is_dragged(spec):
    # a GA-like gait (0.55 s, 27.5 deg, Hz 139 mm, 7.4 mm of swing lift): the support
    # rocks towards the swing sole, which meets the plane and props it
    gait = GaitParams.nominal(
        spec, 0.55, slope=np.deg2rad(27.5), hip_height=0.1386608, swing_lift=0.0074092,
        tilt=np.deg2rad(11.68377),
    )  # fmt: skip
    low = plan_walk(spec, gait)
    props = np.zeros(low.t.size, dtype=bool)
    _, theta = tip_events(low, props=props)
    assert props.any() and not (props & low.double_support).any()  # single support only
    np.testing.assert_array_equal(theta, tip_events(low)[1])  # props only reports
    result = predict(low, friction=1.0)
    assert result.verdict == "swing_drag"
    # the same walk with its swing sole a metre up: nothing to prop on, no drag
    high = replace(low, swing_sole=low.swing_sole + [0.0, 0.0, 1.0])
    none = np.zeros(low.t.size, dtype=bool)
    tip_events(high, props=none)
    assert not none.any()
    assert "swing_drag" not in [e.kind for e in predict(high, friction=1.0).events]
