"""The plan's strict walk prediction, on cases whose answer is worked out by hand.

* overload: the planned torque against the stall torque. The nominal 1 s walk's largest
  planned torque is a third of the AX-12A's 1.5 N m (``test_walk_check``: 0.45 N m, which
  MuJoCo's inverse dynamics confirms in ``test_newton_euler_vs_mujoco``); a servo of
  0.9 × that peak cannot give it, one of 1.1 × can.
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
)


@pytest.mark.parametrize("factor", [0.9, 1.1])
def test_overload_is_predicted_where_the_planned_torque_passes_the_stall_torque(spec, factor):
    gait = GaitParams.nominal(spec, 1.0, steps=2)
    peak = float(np.abs(plan_walk(spec, gait).tau).max())
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
