"""Compiling a command's kernel entries side by side (planner/kernel/warm.py): what the
entries' processes compile is what a trial then calls, so a trial after them compiles
nothing (a wrong type would compile a second signature, and cost the time saved)."""

import json
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

from slopewalk.bench.sim.trial import run_trial
from slopewalk.bench.sim.trial_spec import TrialSpec
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.kernel import cache, dynamics, rocking, servo, warm, whole_body

TOP = (
    servo.integrate,
    servo.fixed_point,
    dynamics.linearised,
    dynamics.rows,
    rocking.rocking_loop,
    whole_body.integrate,
    whole_body.mass_and_stiffness,  # the chain's read-only arrays: a type of their own
)


def test_the_predictors_warm_up_calls_the_signatures_a_trial_calls(spec):
    warm.compile_entry("predictors")
    run_trial(spec, TrialSpec(GaitParams.nominal(spec, 0.5, steps=2, slope=np.deg2rad(10))))
    for function in TOP:
        assert len(function.signatures) == 1, (function.__name__, function.signatures)


def test_one_cold_entry_is_left_to_its_first_use(tmp_path, monkeypatch):
    """Side by side needs two cold entries: one alone compiles where it is first called."""
    monkeypatch.setattr(cache, "_root", lambda: str(tmp_path))
    mark = cache.ENTRIES["plan"].mark()
    mark.parent.mkdir(parents=True)
    mark.touch()
    assert cache.prepare("plan", "predictors") == 0.0  # returns at once, nothing spawned
    alone = cache.ENTRIES["predictors"].seconds
    assert cache.cold_seconds("plan", "predictors", slots=2, slowdown=1.0) == alone
    mark.unlink()
    both = cache.cold_seconds("plan", "predictors", slots=2, slowdown=1.0)
    assert both >= max(alone, cache.ENTRIES["plan"].seconds)  # no faster than its longest
    assert cache.cold_seconds("plan", "predictors", slots=2, slowdown=2.5) == 2.5 * both


def test_side_by_side_compiles_take_the_spread_sum_or_the_longest_process(tmp_path, monkeypatch):
    """Entries of 10, 12 and 14 s: on 2 processes 18 s (the sum spread) where none is
    longer; 10 and 30 s side by side take the 30 s one's time, not their 20 s mean (stop
    51's sweep compile: the predictors' process took 36 s beside a plan's of ~15 s, where
    the mean said 17 s); on one process the sum."""
    monkeypatch.setattr(cache, "_root", lambda: str(tmp_path))  # an empty cache: all cold
    fake = {n: cache.Entry(n, (), s) for n, s in (("plan", 10.0), ("scores", 12.0))}
    monkeypatch.setattr(
        cache, "ENTRIES", fake | {"predictors": cache.Entry("predictors", (), 14.0)}
    )
    assert cache.cold_seconds("plan", "scores", "predictors", slots=2, slowdown=1.0) == 18.0
    assert cache.cold_seconds("plan", "scores", "predictors", slots=1, slowdown=1.0) == 36.0
    monkeypatch.setattr(
        cache, "ENTRIES", fake | {"predictors": cache.Entry("predictors", (), 30.0)}
    )
    assert cache.cold_seconds("plan", "predictors", slots=2, slowdown=1.0) == 30.0
    assert cache.cold_seconds("plan", "predictors", slots=2, slowdown=2.0) == 60.0
    assert cache.cold_seconds("plan", "scores", "predictors", slots=4, slowdown=1.0) == 30.0


class _Done:
    """A finished entry process (``cache._spawn``'s stand-in: its compiling is not the point)."""

    def __init__(self, name, spawned):
        spawned.append(name)
        cache.ENTRIES[name].mark().touch()

    def wait(self):
        return 0

    def poll(self):
        return 0


def test_a_cold_command_compiles_its_entries_side_by_side_and_says_so_once(
    tmp_path, monkeypatch, capsys
):
    monkeypatch.setattr(cache, "_root", lambda: str(tmp_path))
    monkeypatch.setattr(cache, "_WARM", set())
    monkeypatch.setattr(cache, "_EXPECTED", [("plan", "predictors")])
    spawned: list[str] = []
    monkeypatch.setattr(cache, "_spawn", lambda name: _Done(name, spawned))
    monkeypatch.setattr(cache.os, "cpu_count", lambda: 2)
    seconds = cache.cold_seconds("plan", "predictors", slots=2)
    cache.first_use("plan")
    cache.first_use("predictors")
    assert sorted(spawned) == ["plan", "predictors"]
    lines = capsys.readouterr().err.splitlines()
    assert lines == [f"slopewalk: compiling the kernel (once, about {seconds:.0f} s)"]


_AFTER = """
import json, sys
from numba.core import event
from slopewalk.planner.kernel import cache
cache.prepare("plan", "predictors", workers=2)
seen = []
class Listener(event.Listener):
    def on_start(self, e): seen.append(e.data["dispatcher"].py_func.__qualname__)
    def on_end(self, e): pass
event.register("numba:compile", Listener())
from slopewalk.planner.spec import load_spec
from slopewalk.planner.gait import GaitParams
from slopewalk.bench.sim.trial import run_trial
from slopewalk.bench.sim.trial_spec import TrialSpec
spec = load_spec()
run_trial(spec, TrialSpec(GaitParams.nominal(spec, 1.0, steps=2)))
print(json.dumps(seen))
"""


@pytest.mark.slow
def test_after_the_entries_side_by_side_a_trial_compiles_nothing(tmp_path):
    """On an empty cache (~40 s of compiling on 2 cores)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    out = subprocess.run(
        [sys.executable, "-c", _AFTER], env=env, capture_output=True, text=True, check=True
    )
    assert json.loads(out.stdout.splitlines()[-1]) == []


def test_a_second_checkout_of_the_same_kernel_is_cold(tmp_path, monkeypatch):
    """numba files its cache under a hash of the kernel folder's path, so a clone elsewhere
    compiles anew even with the same sources: its mark must not say it is compiled (it did,
    and a fresh clone's sweep compiled silently in each worker, 75 s instead of 10)."""
    monkeypatch.setattr(cache, "_root", lambda: str(tmp_path / "cache"))
    here, key = cache.ENTRIES["predictors"].mark(), cache.module_key("servo")
    copy = tmp_path / "clone" / "kernel"
    shutil.copytree(cache.KERNEL, copy)
    monkeypatch.setattr(cache, "KERNEL", copy)
    elsewhere = cache.ENTRIES["predictors"].mark()
    assert cache.module_key("servo") == key  # the same sources
    assert elsewhere != here
