"""The soles turned apart in double support (``verdict.double_support_tilt``), against
MuJoCo: where the lagging servos' open chain puts the two soles past the tip angle, the
simulated robot stands a loaded sole on its edge; where it keeps them flat, so does MuJoCo."""

import numpy as np
import pytest

from slopewalk.bench.sim.events import loaded_tilt
from slopewalk.bench.sim.playback import play
from slopewalk.bench.sim.prediction import predict_trial
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.kinematics import GRAVITY
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.servo_ring import landing_rows
from slopewalk.planner.verdict import BODY_TIP, TIP_ANGLE, double_support_tilt, landing_tilt

# A design-set gait (ga-dev3, the GA's fast-step envelope: extended family, 0.22 s steps,
# 7.5° downhill), whose saturated servo_ff legs lag behind the plan at every landing.
FAST = dict(
    hip_height=0.1736165, swing_lift=0.0074107, tilt=np.deg2rad(7.12088),
    pelvis_offset=0.0045688, step_length=0.0556495, sway_share=0.8416427, tilt_profile="blend",
)  # fmt: skip


def _runs(mask):
    """(first, stop) sample of each run of True in ``mask``."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True))


def _both(spec, step_time, actuators, **gait):
    plan = plan_walk(spec, GaitParams.nominal(spec, step_time, **gait))
    prediction = predict_trial(plan, friction=1.0, actuators=actuators)
    recording = play(plan, friction=1.0, actuators=actuators)
    loaded = loaded_tilt(recording, weight=spec.total_mass * GRAVITY).max(axis=1)
    return plan, prediction, recording.t, loaded


def test_lagging_servos_stand_a_sole_on_its_edge_in_double_support(spec):
    """MuJoCo: a loaded sole passes the tip angle in the double supports after the
    landings. The servos' walk lands every sole within the tip angle (its landing check
    stays silent) and holds it flat from there; its open chain first turns the soles past
    the tip angle in a double support where MuJoCo's sole is past it too, and that is the
    predicted ``tip``."""
    plan, prediction, t, loaded = _both(spec, 0.22, "servo_ff", slope=np.deg2rad(-7.5), **FAST)
    walk = prediction.loop_walk
    assert landing_tilt(walk.plan, landing_rows(plan)).max() < TIP_ANGLE
    tilt = double_support_tilt(plan, walk.open_deflection)
    both = [(a, b) for a, b in _runs(plan.double_support) if a > 0 and tilt[a:b].max() > TIP_ANGLE]
    assert both
    a, b = both[0]  # the first: after it the robot is no longer on the plan
    rows = (t >= plan.t[a]) & (t <= plan.t[b - 1])
    assert loaded[rows].max() > TIP_ANGLE
    assert prediction.verdict == "tip"
    events = prediction.prediction.events
    (first,) = [e for e in events if e.kind == "tip" and e.cause != BODY_TIP]
    assert first.time == pytest.approx(plan.t[both[0][0]], abs=0.1)


def test_servos_that_keep_up_keep_both_soles_flat(spec):
    """The nominal 1 s walk with the torque fed forward: MuJoCo's loaded soles stay
    within a third of the tip angle, and the open chain keeps the soles as close."""
    plan, prediction, _, loaded = _both(spec, 1.0, "servo_ff")
    tilt = double_support_tilt(plan, prediction.loop_walk.open_deflection)
    assert loaded.max() < TIP_ANGLE / 2
    assert tilt.max() < TIP_ANGLE / 3
    assert prediction.verdict == "stable"
