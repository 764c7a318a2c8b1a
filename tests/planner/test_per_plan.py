"""Work kept once per plan object (``planner/per_plan.py``)."""

import gc

from slopewalk.planner.per_plan import once_per_plan


class _Plan:  # a plan's part here: an object that has no hash of its own use
    __hash__ = None  # type: ignore[assignment]  # as a ``Plan`` (frozen, arrays inside)


def test_one_call_per_plan_object_and_arguments_and_none_kept_past_the_plan():
    calls = []

    @once_per_plan
    def work(plan, *args):
        calls.append(args)  # not the plan: the test must not keep it alive
        return object()

    a, b = _Plan(), _Plan()
    first = work(a)
    assert work(a) is first  # the same object: kept
    assert work(b) is not first  # another plan object: worked out again
    assert work(a, "servo") is not first and work(a, "servo") is work(a, "servo")
    assert len(calls) == 3
    assert work.plans_kept() == 2
    del a, first
    gc.collect()
    assert work.plans_kept() == 1  # a's entries went with it
    c = _Plan()  # may take a's freed id: must not see a's results
    work(c)
    assert len(calls) == 4
