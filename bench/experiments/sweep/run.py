"""Run a sweep: every trial of a sweep file, in parallel, each row written as it finishes.

The sweep-specific half; the generic half (the resumable table run shared with
``slopewalk envelope``) is ``batch/run.py``, on top of ``batch/executor.py`` (workers, one
job each at a time, worker deaths, signals) and ``progress.py``. Trials run as calls of
the top-level ``run_one`` on local workers (``LocalPool``) or on any
``concurrent.futures`` executor, e.g. a Dask ``distributed.Client``'s
(``--cluster ADDRESS``: ``batch/cluster.py``, fed by ``FuturesPool``).

A run directory holds ``sweep.partial.csv`` while a run is going and
``sweep.csv`` when it is done (``tables/sweep.py``):

- A fresh run (``resume=False``, the default of ``slopewalk sweep``) plays
  every trial into a new ``sweep.partial.csv``; when all are done, their rows
  are written to ``sweep.csv`` in the sweep file's order (atomically, replacing
  the finished table of an earlier run: the same trials give the same bytes)
  and the partial table is removed. A ``sweep.csv`` that is not a sweep table
  is refused, never overwritten. So is an unfinished run in the directory,
  which is the user's to resume or remove.
- ``resume=True`` (``--resume``) counts the rows of the unfinished run, or of
  the finished ``sweep.csv`` when there is none, as done and plays the rest.
- ``resume=None`` (``--out DIR`` given) resumes an unfinished run found in
  ``DIR``, else starts a fresh one.

A trial that raises (e.g. an unreachable gait) is a row with the verdicts
``error`` and the one-line message; so is a trial whose worker died (a segfault,
``os._exit``, ``kill -9``: "worker died: signal 9 (SIGKILL)"), and the sweep
goes on. A trial lost by a cluster executor, which cannot say which trial a
lost worker held, leaves no row and is reported, to be run by ``--resume``.
SIGINT and SIGTERM stop the run with every finished row kept (``Stopped``).

On a cluster, the workers need this slopewalk installed (``batch/cluster.py`` refuses
a worker whose code differs), and ``--record`` writes ``.rrd`` files from the
workers, into ``DIR`` made absolute, so ``DIR`` must be on a file system they share
at the same path (docs/cluster.md).
"""

from __future__ import annotations

import contextlib
import os
import time
from collections import OrderedDict
from concurrent.futures import Executor
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

from slopewalk.bench.batch.executor import one_line
from slopewalk.bench.batch.progress import RateSinceFirst
from slopewalk.bench.batch.run import Batch, Stopped, duration, run_batch
from slopewalk.bench.experiments.sweep.config import SweepConfig, SweepTrial
from slopewalk.bench.experiments.sweep.trials import spec_text
from slopewalk.bench.tables.sweep import (
    SWEEP,
    SWEEP_CONTROLLER,
    SWEEP_GAIT,
    SWEEP_GAIT_NOISE,
    SWEEP_NOISE,
    outcome_columns,
    spec_end_format,
)
from slopewalk.bench.tables.table import TableFormat, model_format
from slopewalk.planner import pace

if TYPE_CHECKING:
    from slopewalk.planner.plan import Plan

TABLE_NAME = "sweep.csv"
PARTIAL_NAME = "sweep.partial.csv"
RECORDINGS_DIR = "recordings"
SORT_LIMIT = 10_000  # sweeps up to this size run longest trial first; larger ones in file order
# The first estimate of a sweep's time (``first_estimate_s``), from run_trial's CPU time on
# the 2-core machine (trials of 0.3-3 s step time, flat and 10 deg, warm cache, load ~5):
ROLLOUT_RATE = 60_000.0  # [sim steps/s] per worker: the trial's mujoco.rollout alone
ANALYTIC_S_PER_STEP = 31e-6  # [s] per sim step: the rest of a trial - the plan, the
# predictors (servo loop, compliance, tipping, the whole-body walk), decoding and
# comparison - all of which scale with the walk's samples (1 ms, as the sim's steps): 48 us
# a step in all (20 us before the whole-body walk, which added 10.7 us a sample of CPU,
# 0.42 of predict_trial's, measured on 20 nominal trials at load 3.3, stop 50)
WORKER_START_S = 2.5  # [s] the workers' imports and cached-kernel loading (their fork server's)
# [s] per robot: the report a plain ``slopewalk sweep`` (or ``--report``) writes after the
# trials (``commands._write_claims``: the claims' 13 replays, the GA's best gaits played,
# matplotlib's import and 5 figures); measured 8.8 and 10.1 s at pace 1.6 and 1.9
REPORT_S = 5.5


def step_seconds() -> float:
    """A worker's time per simulated step of a trial [s]: the rollout and the analytic work."""
    return 1.0 / ROLLOUT_RATE + ANALYTIC_S_PER_STEP


def first_estimate_s(
    steps: float,
    workers: int,
    *,
    compile_s: float | None = None,
    slowdown: float | None = None,
    report_robots: int = 0,
) -> float:
    """The time [s] ``steps`` simulated steps of trials take on ``workers`` workers.

    Each step costs ``step_seconds`` (the rollout and the plan's and predictors' work per
    sample); the workers start once (``WORKER_START_S``), and a report on
    ``report_robots`` robots follows the trials (``REPORT_S`` each), all times ``slowdown``
    (this machine's pace against the reference machine's; None: ``pace.slowdown()``,
    measured), and, where the kernel's code is not cached, compile it first (``compile_s``;
    None: as ``planner/kernel/cache.py`` says for a trial's entries, at the same pace).
    """
    slowdown = pace.slowdown() if slowdown is None else slowdown
    if compile_s is None:
        from slopewalk.planner.kernel import cache

        compile_s = cache.cold_seconds(
            "plan", "predictors", slots=min(workers, os.cpu_count() or 1), slowdown=slowdown
        )
    work = steps * step_seconds() / max(workers, 1) + WORKER_START_S + report_robots * REPORT_S
    return work * slowdown + compile_s


# plans a worker keeps (``plan_of``): its group's. With a plan go its per-plan results
# (``planner/per_plan.py``): for a 4,400-sample walk (4 steps of 1 s) the plan 2.8 MB, the
# loop's linearisation 8.2 MB, the whole-body model 14.8 MB, 6.2 MB per friction and mode
# predicted on it, and the whole-body walk's 0.8 MB per mode
PLANS_KEPT = 1


_plans: OrderedDict[tuple, Plan] = OrderedDict()  # a worker's last plans, by spec and gait


def plan_of(trial: SweepTrial) -> Plan:
    """``trial``'s plan: the same object for the trials of one spec and gait that a worker
    runs in a row (a sweep's trials of one plan at several frictions, modes or noise seeds
    come to one worker in a row: ``SWEEP_BATCH.group``), so the work done once per plan
    object (``planner/per_plan.py``) is shared; planned afresh otherwise. The plan before
    is let go, and its per-plan results with it (``PLANS_KEPT``)."""
    from slopewalk.planner.plan import plan_walk

    gait = trial.gait()
    key = (trial.spec_json or spec_text(trial.spec), gait)
    plan = _plans.pop(key, None) or plan_walk(trial.spec, gait)
    _plans[key] = plan
    while len(_plans) > PLANS_KEPT:
        _plans.popitem(last=False)
    return plan


def run_one(trial: SweepTrial, record_dir: str | None = None) -> dict:
    """Plan, simulate and compare one trial (in a worker); its table row.

    Never raises for a bad trial: any exception becomes an ``error`` row.

    Args:
        trial: The trial.
        record_dir: Where to write ``<trial_id>.rrd``, or None for no recording.
    """
    from slopewalk.bench.sim.trial import run_trial

    try:
        # a model is fitted once per worker, its files' digest checked for every trial
        scene = None if trial.model is None else trial.model.scene(trial.spec)
        plan = plan_of(trial)
        result = run_trial(trial.spec, trial.trial_spec(), plan=plan, scene=scene)
        row = trial.inputs() | outcome_columns(result, plan)
        if record_dir is not None:
            try:
                _record(Path(record_dir), trial.trial_id, plan, result, scene)
            except Exception as err:  # the trial stands; a re-run with --record retries
                row["error"] = f"recording failed: {one_line(err)}"
    except Exception as err:  # a trial's failure is a result, not a crash of the sweep
        row = error_row(trial, one_line(err))
    return row


def error_row(trial: SweepTrial, cause: str) -> dict:
    """The row of a trial that raised or killed its worker, ``cause`` in one line."""
    return trial.inputs() | {
        "analytic_verdict": "error",
        "simulated_verdict": "error",
        "walk": "error",
        "error": cause,
    }


SWEEP_BATCH = Batch(
    name="sweep",
    fmt=SWEEP,
    fn=run_one,
    key=lambda trial: trial.trial_id,
    label=lambda trial: trial.label,
    error_row=error_row,
    is_error=lambda row: row["simulated_verdict"] == "error",
    source="the sweep file",
    unit="trials",
    kernel=("plan", "predictors"),
    group=lambda trial: trial.plan_group,
)
__all__ = ["SWEEP_BATCH", "Stopped", "SweepSummary", "run_one", "run_sweep"]


def on_model(model) -> str:
    """ " on model NAME (sha256:…)": what a run's messages add to its file's name."""
    return "" if model is None else f" on model {model.name} ({model.short_digest})"


def _record(directory: Path, trial_id: str, plan, result, scene=None) -> None:
    """Write ``<trial_id>.rrd`` whole: recorded beside it, then moved into place; its plots
    at ``SWEEP_PLOT_RATE`` (a tenth of a trial's, a third of the size per simulated second)."""
    from slopewalk.bench.sim.recording import SWEEP_PLOT_RATE, record_trial

    directory.mkdir(parents=True, exist_ok=True)
    tmp = directory / f".{trial_id}.{os.getpid()}.part.rrd"
    try:
        written = record_trial(tmp, plan, result, plot_rate=SWEEP_PLOT_RATE, scene=scene)
        os.replace(written or tmp, directory / f"{trial_id}.rrd")
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.remove(tmp)


@dataclass(frozen=True)
class SweepSummary:
    """What a sweep run did.

    Attributes:
        table: Path of the results table (``sweep.csv``, or the partial one if trials were lost).
        total: Trials in the sweep.
        resumed: Trials found finished in the table and skipped.
        ran: Trials run now (rows written).
        errors: Rows of this run with the verdict ``error`` (worker deaths included).
        lost: One line per trial lost by a cluster executor (no row written).
        sim_steps: Simulation steps of the trials run now.
        wall_s: Wall time of this run [s].
        verdicts: (analytic, simulated) -> count over the whole table.
        lost_workers: One line per worker a cluster lost while trials ran, with the trials
            it held (run again on the other workers).
    """

    table: Path
    total: int
    resumed: int
    ran: int
    errors: int
    lost: tuple[str, ...]
    sim_steps: int
    wall_s: float
    verdicts: dict
    lost_workers: tuple[str, ...] = ()

    def lines(self) -> list[str]:
        verdicts = ", ".join(f"{'/'.join(v)} {n}" for v, n in sorted(self.verdicts.items()))
        out = [
            f"sweep: {self.total} trials: {self.ran} run, {self.resumed} already done, "
            f"{self.errors} errors, {len(self.lost)} lost, in {self.wall_s:.1f} s"
            + (f" ({self.sim_steps / self.wall_s:.0f} sim steps/s)" if self.ran else ""),
            "analytic / simulated / walk verdicts: " + (verdicts or "none (no row written)"),
            f"wrote {self.table}",
        ]
        lost = [f"lost: {line}" for line in self.lost[:5]]
        return out + lost + list(self.lost_workers)


def _open_loop_format(config: SweepConfig) -> TableFormat:
    """The table layout of an open-loop sweep: its gaits' columns where it plays drawn or
    given gaits, then the noise's where its commands get noise."""
    if config.noisy:
        return SWEEP_GAIT_NOISE if config.other_gaits else SWEEP_NOISE
    return SWEEP_GAIT if config.other_gaits else SWEEP


# long: to be split once the actuator-mode work in this module has landed (issue 20)
def run_sweep(
    config: SweepConfig,
    out_dir: str | Path,
    *,
    workers: int | None = None,
    executor: Executor | None = None,
    resume: bool | None = False,
    record: bool = False,
    progress: bool = False,
    quiet: bool = False,
    report_robots: int = 0,
) -> SweepSummary:
    """Run the trials of ``config`` into ``out_dir`` (module doc), appending each row.

    Args:
        config: The parsed sweep file.
        out_dir: Run directory: ``sweep.csv`` and, with ``record``, ``recordings/``.
        workers: Local worker processes (default all cores), when ``executor`` is None.
        executor: A ``concurrent.futures`` executor to run on instead, e.g. a Dask
            cluster's (``batch.cluster.open_cluster``).
        resume: True: go on from the rows there; None: resume an unfinished run
            if there is one; False: a fresh run (refused over an unfinished one).
        record: Also write ``recordings/<trial_id>.rrd`` per trial.
        progress: A tqdm bar on stderr; else a log line at every tenth of the sweep.
        quiet: Neither bar nor log lines.
        report_robots: The caller writes a report on this many robots after the trials
            (``slopewalk sweep`` without CONFIG, or ``--report``): the first line's
            estimate counts it (``REPORT_S``).

    Raises:
        SweepError: a table there is not a sweep table, holds trials not in
            ``config``, or is an unfinished run and ``resume`` is False.
        Stopped: SIGINT or SIGTERM; the rows written so far stay in ``sweep.partial.csv``.
    """
    start = time.perf_counter()
    out_dir = Path(out_dir)
    record_dir = out_dir / RECORDINGS_DIR if record else None
    workers = workers or os.cpu_count() or 1
    total = len(config.trials)
    steps_left = [0.0]

    def report_s() -> float:  # [s] the report after the trials, at this machine's pace
        return report_robots * REPORT_S * pace.slowdown()

    def intro(done: int, workers: int) -> str:
        steps_left[0] = config.trials.simulated_steps() * (total - done) / max(total, 1)
        rate = 1.0 / (step_seconds() * pace.slowdown())
        if executor is None:
            where = f" on {workers} workers"
            first = first_estimate_s(steps_left[0], workers, report_robots=report_robots)
            estimate = f"about {duration(first)}"
        else:  # the cluster's workers play the trials; the report is written here
            where = ""
            estimate = f"about {duration(first_estimate_s(steps_left[0], 1))} of worker time"
            estimate += f", then about {duration(report_s())} here" if report_robots else ""
        report_too = " and the report after the trials" if report_robots else ""
        return (
            f"sweep: {total} trials, {done} already done, {total - done} to run{where}: "
            f"{estimate} at {rate:.0f} sim steps/s per worker, the analytic work{report_too} "
            "included (refined as trials finish)"
        )

    rate = RateSinceFirst()  # the trials' own rate: the compile and workers' start aside

    def after_row(row: dict, left_trials: int) -> str:
        steps_per_s = rate.add(row.get("sim_steps") or 0)
        left = steps_left[0] - rate.done
        if steps_per_s is None or left <= 0:
            return ""
        return f", about {duration(left / steps_per_s + report_s())} left"

    # a controller, command noise or other gaits add columns (tables/sweep.py), a model its own
    fmt = SWEEP_CONTROLLER if config.closed_loop else _open_loop_format(config)
    if config.spec_ends:
        fmt = spec_end_format(fmt)
    result = run_batch(
        replace(
            SWEEP_BATCH,
            source=config.source + on_model(config.model),
            fmt=fmt if config.model is None else model_format(fmt),
        ),
        config.trials,
        total,
        out_dir,
        workers=workers,
        executor=executor,
        resume=resume,
        record_dir=record_dir,
        progress=progress,
        quiet=quiet,
        order=(lambda t: -t.step_time * (t.steps + 0.4)) if total <= SORT_LIMIT else None,
        intro=intro,
        after_row=after_row,
    )
    return SweepSummary(
        table=result.table,
        total=total,
        resumed=result.resumed,
        ran=result.ran,
        errors=result.errors,
        lost=result.lost,
        sim_steps=sum(r.get("sim_steps") or 0 for r in result.rows),
        wall_s=time.perf_counter() - start,
        verdicts=result.verdicts,
        lost_workers=result.lost_workers,
    )
