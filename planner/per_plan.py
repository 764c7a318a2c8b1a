"""Work done once per plan: what depends on the planned walk alone, shared by its trials.

A sweep plays one planned walk several times: at each friction of its grid, in each
actuator mode, at each command-noise seed (``bench/experiments/sweep``). Some of a
trial's prediction depends on the plan alone and not on how it is played, above all
the servo loop's linearisation about the plan (``servo_loop``: M, K_g, C and the
second sole's Jacobian at every sample, ~16 ms of a default-sweep trial's ~170 ms of
CPU). ``once_per_plan`` keeps such a function's result for as long as the plan object
lives, keyed by the object itself (a ``Plan`` holds arrays: it has no hash, and two
equal plans are two computations), so the trials a worker plays on one plan object
share it (``sweep.run``'s plan memo hands them the same object).

The results are the same numbers a fresh call gives (the function is deterministic
and called on the same object), and the same arrays: a caller must not write into
them. They are not made read-only, because a read-only array is another type to the
compiled kernel (numba compiles a new signature for it, which the cache of a fresh
install does not hold); ``tests/sim/test_prediction_shared.py`` plays trials on one
plan object and checks each against a trial on a fresh plan instead.
"""

from __future__ import annotations

import functools
import threading
import weakref
from collections.abc import Callable
from typing import TypeVar

R = TypeVar("R")


def once_per_plan(fn: Callable[..., R]) -> Callable[..., R]:
    """``fn(plan, *args)`` worked out once per plan object and ``args`` (hashable; module
    doc). A plan's entries go when it is collected (a weak reference's callback), so a
    long sweep holds only the results of the plans alive in it.
    """
    cache: dict[int, tuple[weakref.ref, dict]] = {}
    lock = threading.Lock()  # a trial's prediction runs on a thread beside its playback

    def forget(ref: weakref.ref, key: int) -> None:
        with lock:
            if key in cache and cache[key][0] is ref:
                del cache[key]

    @functools.wraps(fn)
    def shared(plan, *args) -> R:
        key = id(plan)
        with lock:
            entry = cache.get(key)
            if entry is None or entry[0]() is not plan:
                entry = (weakref.ref(plan, functools.partial(forget, key=key)), {})
                cache[key] = entry
            values = entry[1]
            if args in values:
                return values[args]
        value = fn(plan, *args)
        with lock:
            values[args] = value
        return value

    shared.plans_kept = lambda: len(cache)  # type: ignore[attr-defined]  # for the tests
    return shared
