"""Imported by a batch's fork server (``bench/batch/executor.py``): a trial's kernel
entries loaded from numba's cache once, for every worker forked from the server.

The entries a trial calls ("plan", "predictors") are loaded where their marks say they
are cached (``cache.Entry.mark``). One that is not is left to the workers' first use,
after the batch has compiled it side by side (``cache.prepare``): the server never
compiles. A GA's "scores" entry is not loaded here: it runs on numba's threads, and a
process must not fork once those have started. Best effort: where loading fails, the
workers load (and meet the failure) themselves.
"""

from __future__ import annotations

from slopewalk.planner.kernel import cache, warm

TRIAL_ENTRIES = ("plan", "predictors")

try:
    for _name in TRIAL_ENTRIES:
        if cache.ENTRIES[_name].mark().exists():
            warm.compile_entry(_name)
except Exception:  # noqa: BLE001 - the workers' own first use says what went wrong
    pass
