"""How fast this machine runs now, against the machine the bench's time constants come from.

Every first estimate the bench prints (a cold kernel's compile time, a sweep's or an
envelope's run time) is a constant measured on the 2-core reference machine times a
count. The same machine is not always as fast: on the 2-core VM the bench is developed
on, raw ``mj_step`` ran 70k steps/s at one hour and 30k at the next, and a cold
``slopewalk plan`` took 13.6 s and 34 s; an estimate from constants alone missed by
2×. ``slowdown`` times a fixed piece of pure-Python work (``probe_s``, ~6 ms there at
70k steps/s) and returns its ratio to ``REFERENCE_S``, by which the estimates scale.

The probe tracks what the estimates count: over 25 samples on that VM, spread over its
fast and slow moments, its rate correlates 0.88 with raw ``mj_step``'s (the raw steps
made in one probe's time stay within 290–580 while each rate moved 2×), and a cold compile
(numba's front end is Python, LLVM branchy C++) slowed as the raw rate did (34.5 s at
31k steps/s against 13.6 s at 70k). It is a proxy: the estimate it scales is asked to
be within 2× of the wall time, not exact. Its cost is ~3 probes of ~6–15 ms, once per
process (cached).
"""

from __future__ import annotations

import time
from functools import cache

PROBE_LOOPS = 100_000  # iterations of ``_work``: ~6 ms on the reference machine
PROBES = 3  # ``probe_s`` is the best of this many (a blip of other load is not the pace)
# ``probe_s`` on the reference machine [s], the state every time constant of the bench's
# estimates is given for: the 2-core VM when raw mj_step ran 70k steps/s (docs/benchmark.md)
REFERENCE_S = 6.2e-3


def _work(loops: int) -> int:
    total = 0
    for i in range(loops):
        total += (i * i) % 7
    return total


def probe_s(loops: int = PROBE_LOOPS, probes: int = PROBES, *, clock=time.perf_counter) -> float:
    """Best wall time [s] of ``probes`` runs of ``loops`` iterations of fixed Python work."""
    best = float("inf")
    for _ in range(probes):
        start = clock()
        _work(loops)
        best = min(best, clock() - start)
    return best


@cache
def slowdown() -> float:
    """This machine's time for the probe over the reference machine's (> 1: slower now).

    Measured once per process; every constant-based estimate of the bench is multiplied
    by it (module doc).
    """
    return probe_s() / REFERENCE_S
