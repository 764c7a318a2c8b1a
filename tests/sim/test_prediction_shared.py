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


def test_a_trial_marks_its_predictors_compiled_after_their_last_kernel_call(spec, monkeypatch):
    """The "predictors" entry is marked warm (``cache.compiled``) once every one of its
    kernel modules has been called: a process stopped between a mark and a later module's
    first compile would leave that module cold under a warm mark, and the next run would
    compile it without the notice line."""
    import numba

    from slopewalk.planner.kernel import cache, dynamics, rocking, servo, whole_body

    calls = []
    for module in (dynamics, servo, rocking, whole_body):
        for name, f in vars(module).items():
            if isinstance(f, numba.core.registry.CPUDispatcher):

                def logged(*args, _f=f, _name=f"{module.__name__}.{name}", **kw):
                    calls.append(_name)
                    return _f(*args, **kw)

                monkeypatch.setattr(module, name, logged)
    marks = []
    monkeypatch.setattr(cache, "compiled", lambda entry: marks.append((entry, len(calls))))
    plan = plan_walk(spec, GaitParams.nominal(spec, 1.0, slope=0.0, steps=2))
    predict_trial(plan, friction=1.0, actuators="servo")
    called = {c.rsplit(".", 2)[-2] for c in calls}
    assert called == {"dynamics", "servo", "rocking", "whole_body"}  # the entry's modules
    mark = [at for entry, at in marks if entry == "predictors"]
    assert mark == [len(calls)]  # marked once, with no kernel call after it
