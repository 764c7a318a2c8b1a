"""``slopewalk benchmark envelope``: the default envelope end to end, as ``name: value`` figures.

Runs ``bench/experiments/envelopes/paper.toml`` (both gait families, both objectives,
MuJoCo in every actuator mode) on all cores into a temp dir and reports
``cells``, ``wall_s`` (pool start to the figure), ``cells_per_min`` and
``ga_evals_per_s`` (GA evaluations per second of GA time in one worker, both
searches of every cell), with the share of the workers' time spent in the GA
(``ga_share``) against planning at 1 ms and playing in MuJoCo. ``cpu_s`` (this
process and its workers) is what the run cost; on a machine shared with other
jobs ``wall_s`` moves with their load and ``cpu_s`` much less. ``first_estimate_s`` is
the time the run's first line announces (``run.first_estimate_s``, worked out before the
run as the command does: cells × ``CELL_S`` over the workers plus their start, at this
machine's pace ``slowdown``, and a cold kernel's compile), ``wall_over_estimate`` and
``cpu_over_estimate`` (CPU per worker) how far off it was (issue 24's goal: within 2×).
The goal, from the README, is ``wall_s`` ≤ 600 for both families on a 2-core machine of
its own.
"""

from __future__ import annotations

import os
import resource
import tempfile
import time


def _cpu_s() -> float:
    own, children = (
        resource.getrusage(resource.RUSAGE_SELF),
        resource.getrusage(resource.RUSAGE_CHILDREN),
    )
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def envelope_figures() -> dict:
    from slopewalk.bench.batch.executor import stop_server
    from slopewalk.bench.experiments.envelope.config import load_envelope
    from slopewalk.bench.experiments.envelope.run import first_estimate_s, run_envelope
    from slopewalk.planner import pace

    config = load_envelope()
    workers = os.cpu_count() or 1
    stop_server()  # the workers' fork server starts inside the timed run, as in a command
    estimate = first_estimate_s(len(config.cells), workers)
    with tempfile.TemporaryDirectory() as out:
        start, start_cpu = time.perf_counter(), _cpu_s()
        summary = run_envelope(config, out, workers=workers, quiet=True)
        wall = time.perf_counter() - start
        stop_server()  # its workers' CPU time reaches this process once it is waited for
        cpu = _cpu_s() - start_cpu
    busy = summary.ga_s + summary.sim_s
    return {
        "cells": summary.total,
        "errors": summary.errors,
        "workers": workers,
        "population": config.search.population,
        "generations": config.search.generations,
        "wall_s": wall,
        "cells_per_min": 60 * summary.total / wall,
        "ga_evaluations": summary.ga_evaluations,
        "ga_evals_per_s": summary.ga_evals_per_s,
        "ga_share": summary.ga_s / busy if busy > 0 else float("nan"),
        "cpu_s": cpu,
        "slowdown": pace.slowdown(),
        "first_estimate_s": estimate,
        "wall_over_estimate": wall / estimate,
        "cpu_over_estimate": cpu / workers / estimate,
    }
