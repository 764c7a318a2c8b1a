"""Trials of one plan share its per-plan work (``planner/per_plan.py``) and predict what
trials on fresh plans predict: nothing a trial does changes what the next one reads."""

import numpy as np
import pytest

from slopewalk.bench.sim.prediction import predict_trial
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import plan_walk


def _same(a, b) -> None:
    assert a.verdict == b.verdict
    assert [(e.time, e.kind, e.cause) for e in a.prediction.events] == [
        (e.time, e.kind, e.cause) for e in b.prediction.events
    ]
    np.testing.assert_array_equal(a.prediction.rotation, b.prediction.rotation)
    for walk in ("walk", "loop_walk"):
        x, y = getattr(a, walk), getattr(b, walk)
        np.testing.assert_array_equal(x.plan.q, y.plan.q)
        np.testing.assert_array_equal(x.plan.zmp, y.plan.zmp)
        np.testing.assert_array_equal(x.deflection, y.deflection)


@pytest.mark.parametrize("actuators", ["servo", "servo_ff"])
def test_trials_on_one_plan_object_predict_as_trials_on_fresh_plans(spec, actuators):
    """0.75 s on 10°: the soft loop lags and saturates, so every part of the prediction has
    work to do; the shared plan is played at μ 1 first, then at μ 0.4."""
    gait = GaitParams.nominal(spec, 0.75, slope=np.deg2rad(10.0), steps=2)
    shared = plan_walk(spec, gait)
    got = {}
    for friction in (1.0, 0.4, 1.0):
        got[friction] = predict_trial(shared, friction=friction, actuators=actuators)
        fresh = predict_trial(plan_walk(spec, gait), friction=friction, actuators=actuators)
        _same(got[friction], fresh)
    # a noise replica (the same plan, μ and mode) is given the prediction already made
    assert predict_trial(shared, friction=1.0, actuators=actuators) is got[1.0]


def test_trials_of_one_plan_in_several_modes_predict_as_on_fresh_plans(spec):
    """The whole-body model depends on the plan alone and is made once per plan object
    (``whole_body._plan_model``): each mode's walk on it, after the other modes', is the walk
    a fresh plan gives."""
    from slopewalk.bench.sim.prediction import body_walk

    gait = GaitParams.nominal(spec, 0.75, slope=np.deg2rad(10.0), steps=2)
    shared = plan_walk(spec, gait)
    for actuators in ("servo", "stiff_ff", "servo_ff"):
        _same(
            predict_trial(shared, friction=1.0, actuators=actuators),
            predict_trial(plan_walk(spec, gait), friction=1.0, actuators=actuators),
        )
        mine = body_walk(shared, friction=1.0, actuators=actuators)
        fresh = body_walk(plan_walk(spec, gait), friction=1.0, actuators=actuators)
        np.testing.assert_array_equal(mine.x, fresh.x)
        np.testing.assert_array_equal(mine.force, fresh.force)
