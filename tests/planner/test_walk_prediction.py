"""The plan's strict walk prediction, on cases whose answer is worked out by hand.

* overload: the planned servo torque (Newton–Euler + armature × q̈) against the stall
  torque: a servo of 0.9 × its peak cannot give it, one of 1.1 × can; a rotor without
  inertia leaves the Newton–Euler torque alone (MuJoCo's inverse dynamics confirms that
  one in ``test_newton_euler_vs_mujoco``, the sum MuJoCo's actuator force in
  ``test_walk_check``).
* shuffle: a swing that never lifts (lift 0) is within TOUCH_HEIGHT of the plane the whole
  single support; the nominal swing (66.6 mm) leaves the 1 mm band within the window the
  floor's give explains.
"""

from dataclasses import replace

import numpy as np
import pytest

from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.walk_prediction import (
    SATURATION,
    TOUCH_ALLOWANCE,
    planned_swing_touch,
    predict_walk,
    predicted_walk_verdict,
    servo_torque,
)


@pytest.mark.parametrize("factor", [0.9, 1.1])
def test_overload_is_predicted_where_the_planned_torque_passes_the_stall_torque(spec, factor):
    gait = GaitParams.nominal(spec, 1.0, steps=2)
    plan = plan_walk(spec, gait)
    peak = float(np.abs(servo_torque(plan)).max())
    bare = replace(spec, armature=0.0)
    assert predict_walk(plan_walk(bare, gait)).torque_ratio == pytest.approx(
        np.abs(plan.tau).max() / spec.stall_torque
    )
    weaker = replace(spec, stall_torque=factor * peak)
    prediction = predict_walk(plan_walk(weaker, gait))
    assert prediction.torque_ratio == pytest.approx(1 / factor)
    assert (prediction.torque_ratio >= SATURATION) == (factor < 1)
    verdict = predicted_walk_verdict("stable", prediction)
    assert verdict == ("overload" if factor < 1 else "walked")
    assert predicted_walk_verdict("tip", prediction) == "tip"  # balance first


def test_a_swing_that_never_lifts_is_a_predicted_shuffle(spec):
    g = GaitParams.nominal(spec, 1.0, steps=2, swing_lift=0.0)
    plan = plan_walk(spec, g)
    single = g.ssp_fraction * g.step_time
    assert planned_swing_touch(plan) == pytest.approx([single, single], abs=2 * g.dt)
    assert predicted_walk_verdict("stable", predict_walk(plan)) == "shuffle"
    nominal = predict_walk(plan_walk(spec, GaitParams.nominal(spec, 1.0, steps=2)))
    assert 0 < nominal.swing_touch < TOUCH_ALLOWANCE
