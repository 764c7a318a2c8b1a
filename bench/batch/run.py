"""A resumable batch: jobs run in parallel into a results table, one row appended as each ends.

What ``slopewalk sweep`` and ``slopewalk envelope`` share; each says only what
its jobs are (``Batch``). The parallel half is ``executor.py`` (local spawned
workers or any ``concurrent.futures`` executor, worker deaths, signals), the
table half ``tables/table.py`` (whole-line appends, a lock, a ``TableFormat``).

A run directory holds ``<name>.partial.csv`` while a run is going and
``<name>.csv`` when it is done:

- A fresh run (``resume=False``) runs every job into a new partial table; when
  all are done, their rows are written to the finished table in the jobs' order
  (atomically, replacing the finished table of an earlier run) and the partial
  table is removed. A finished table that is not of this format is refused,
  never overwritten; so is an unfinished run in the directory, which is the
  user's to resume or remove.
- ``resume=True`` counts the rows of the unfinished run, or of the finished
  table when there is none, as done and runs the rest.
- ``resume=None`` resumes an unfinished run if there is one, else starts fresh.

A job whose function raises is the job's ``error_row``; so is one whose worker
died ("worker died: signal 9 (SIGKILL)"), and the run goes on. A job lost by a
cluster executor, which cannot say which job a lost worker held, leaves no row
and is reported, to be run by ``--resume``. SIGINT and SIGTERM stop the run with
every finished row kept (``Stopped``). A worker a cluster lost while its jobs ran is
said at once, one line each with the jobs it held (the cluster ran them again elsewhere),
and listed in the result (``lost_workers``).

The recordings directory travels to the workers absolute: a cluster's workers do not
share the caller's working directory.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable
from concurrent.futures import Executor
from dataclasses import dataclass, field
from pathlib import Path
from typing import cast

from slopewalk.bench.batch.executor import (
    KERNEL_PRELOAD,
    FuturesPool,
    Interrupted,
    LocalPool,
    Lost,
    WorkerLost,
    interruptible,
)
from slopewalk.bench.batch.progress import Progress
from slopewalk.bench.tables.table import AppendTable, TableError, TableFormat


class Stopped(Interrupted):
    """A run stopped by SIGINT or SIGTERM; ``message`` says what was kept and how to go on."""

    def __init__(self, signum: int, message: str):
        super().__init__(signum)
        self.message = message


@dataclass(frozen=True)
class Batch:
    """What a batch runs and how its rows look.

    Attributes:
        name: The table's name and the progress prefix ("sweep": ``sweep.csv``).
        fmt: The table's columns and verdicts.
        fn: Top-level function (picklable by reference) run in a worker as
            ``fn(job, record_dir)``; returns the job's row and never raises for a bad job.
        key: The job's id (the table's first column), 12 hex digits.
        label: Short human description of a job, for progress lines.
        error_row: The row of a job that killed its worker, from the job and the cause.
        is_error: Whether a row counts as an error in the summary.
        source: Where the jobs come from, for messages (the config file).
        unit: What a job is, plural, for messages ("trials").
        outcome: A row's outcome in a few words, for progress lines (default: its
            verdicts joined by "/").
        kernel: The compiled kernel's entries a job calls (``planner/kernel/cache.py``):
            on a cold cache a local run compiles them side by side before its workers
            start (``kernel.cache.prepare``), instead of every worker compiling them all.
        group: Of a job, a hashable naming the work it shares with other jobs, which a
            worker keeps (a sweep's: the trial's plan); a local run gives a worker the
            jobs of its last job's group first (``LocalPool.run``). None: no such work.
    """

    name: str
    fmt: TableFormat
    fn: Callable
    key: Callable
    label: Callable
    error_row: Callable
    is_error: Callable
    source: str
    unit: str = "jobs"
    outcome: Callable | None = None
    kernel: tuple[str, ...] = ()
    group: Callable | None = None

    def paths(self, out_dir: Path) -> tuple[Path, Path]:
        """(finished table, partial table) in ``out_dir``."""
        return out_dir / f"{self.name}.csv", out_dir / f"{self.name}.partial.csv"


@dataclass(frozen=True)
class BatchResult:
    """What a run did: ``table`` (the finished one, or the partial one if jobs were lost),
    jobs in all, found done, run now, error rows, lost jobs (one line each), verdict counts,
    the rows written now (in the order they finished), and the workers a cluster lost
    while jobs ran (one line each, with the jobs it ran again elsewhere)."""

    table: Path
    total: int
    resumed: int
    ran: int
    errors: int
    lost: tuple[str, ...]
    verdicts: dict
    rows: tuple[dict, ...]
    lost_workers: tuple[str, ...] = ()


def run_batch(
    batch: Batch,
    jobs: Iterable,
    total: int,
    out_dir: str | Path,
    *,
    workers: int | None = None,
    executor: Executor | None = None,
    resume: bool | None = False,
    record_dir: Path | None = None,
    progress: bool = False,
    quiet: bool = False,
    order: Callable | None = None,
    intro: Callable[[int, int], str] | None = None,
    after_row: Callable[[dict, int], str] | None = None,
) -> BatchResult:
    """Run ``jobs`` (re-iterable, ``total`` of them) into ``out_dir`` (module doc).

    Args:
        record_dir: Where jobs write ``<key>.rrd``; a job without its recording is not done.
            Made absolute here, before it travels to a worker.
        order: Sort key of the jobs still to run (longest first pays off), or None.
        intro: (done, workers) -> the line said before the first job.
        after_row: (row, jobs left) -> text appended to progress log lines (an ETA).

    Raises:
        TableError: a table there is not of ``batch.fmt``, holds jobs not in
            ``jobs``, or is an unfinished run and ``resume`` is False.
        Stopped: SIGINT or SIGTERM; the rows written so far stay in the partial table.
    """
    out_dir = Path(out_dir)
    record_dir = None if record_dir is None else Path(record_dir).absolute()
    final, partial = batch.paths(out_dir)
    workers = workers or os.cpu_count() or 1
    # a table that is not ours is refused here; one of the previous version may be replaced
    finished = batch.fmt.read_rows(final, previous_ok=resume is not True) if final.exists() else {}
    with interruptible(), AppendTable.open(partial, batch.fmt) as table:
        _start_partial(table, batch, jobs, finished, resume, out_dir)
        done, todo = _still_to_run(table, batch, jobs, record_dir, order)
        bar = Progress(total, done, tty=progress, quiet=quiet, name=batch.name)
        if intro is not None:
            bar.say(intro(done, workers))
        try:  # a stop from here on (the compile, the workers' start) is the run's to report
            played = _play(
                _pool(batch, executor, workers, jobs_left=done < total),
                todo, table, batch, bar, record_dir, total - done, after_row,
            )  # fmt: skip
        except BaseException as err:
            bar.close()
            if table.created and not table.rows:  # nothing of ours to keep: leave no file
                os.remove(partial)
            if not isinstance(err, Interrupted):
                raise
            raise _stopped(err, table, batch, total, partial) from None
        bar.close()
        if not played.lost:
            table.write_finished(final, (batch.key(j) for j in jobs))
            os.remove(partial)
        counts = dict(table.counts())
    return BatchResult(
        table=final if not played.lost else partial,
        total=total,
        resumed=done,
        ran=played.ran,
        errors=played.errors,
        lost=tuple(played.lost),
        verdicts=counts,
        rows=tuple(played.rows),
        lost_workers=tuple(played.lost_workers),
    )


def _pool(batch: Batch, executor: Executor | None, workers: int, *, jobs_left: bool):
    """The batch's pool: local workers, the kernel's cold entries compiled first where
    there are ``jobs_left`` to run, or the given executor."""
    if executor is not None:
        # a cluster sets its window from its workers' threads, never from this machine's cores
        return FuturesPool(batch.fn, executor)
    if jobs_left and batch.kernel:
        from slopewalk.planner.kernel import cache

        cache.prepare(*batch.kernel, workers=workers)
    # a kernel batch's workers' server loads a trial's compiled entries once for them all
    preload = (KERNEL_PRELOAD,) if batch.kernel else ()
    return LocalPool(batch.fn, workers=workers, preload=preload)


def _start_partial(
    table: AppendTable, batch: Batch, jobs: Iterable, finished: dict, resume, out_dir: Path
) -> None:
    """Refuse an unfinished run without ``resume`` and another run's rows; a fresh partial
    table resumed from a finished one starts with its rows. A refused new table is removed."""
    try:
        if not table.created and resume is False:
            raise TableError(
                f"{out_dir} holds an unfinished {batch.name} ({len(table.rows)} "
                f"{batch.unit} in {table.path.name}): add --resume to finish it, or remove "
                f"{table.path} to start over"
            )
        if table.created and resume:
            for line in finished.values():
                table.append_line(line)
        _check_keys(table, jobs, batch)
    except BaseException:
        if table.created:
            os.remove(table.path)
        raise


def _still_to_run(
    table: AppendTable, batch: Batch, jobs: Iterable, record_dir: Path | None, order
) -> tuple[int, Iterable]:
    """(jobs done, the jobs to run): a job is done when its row is in the table and, if
    recordings are asked for, its recording exists."""

    def recorded(key) -> bool:
        return record_dir is None or (record_dir / f"{key}.rrd").exists()

    done = sum(recorded(k) for k in table.rows)
    todo: Iterable = (
        j for j in jobs if batch.key(j) not in table.rows or not recorded(batch.key(j))
    )
    if order is not None:
        todo = sorted(todo, key=order)
    return done, todo


@dataclass
class _Played:
    """What ``_play`` did: rows appended, error rows among them, lost jobs, the rows,
    the workers lost (one line each)."""

    ran: int = 0
    errors: int = 0
    lost: list[str] = field(default_factory=list)
    rows: list[dict] = field(default_factory=list)
    lost_workers: list[str] = field(default_factory=list)


def _play(pool, todo, table, batch, bar, record_dir, left_before, after_row) -> _Played:
    """Run ``todo`` on ``pool``, appending each job's row to ``table`` as it ends."""
    inflight: dict[str, object] = {}
    played = _Played()

    def pairs():
        for job in todo:
            inflight[batch.key(job)] = job
            yield batch.key(job), (job, None if record_dir is None else str(record_dir))

    with pool:
        group = None if batch.group is None else (lambda job, _record_dir: batch.group(job))
        for key, outcome in pool.run(pairs(), group):
            if isinstance(outcome, WorkerLost):
                played.lost_workers.append(_worker_lost(outcome, batch, inflight))
                bar.say(f"{batch.name}: {played.lost_workers[-1]}")
                continue
            job = inflight.pop(key)
            if isinstance(outcome, Lost) and not outcome.known:
                played.lost.append(f"{batch.label(job)}: {outcome.cause}")
                bar.update(f"{batch.label(job)}: lost")
                continue
            row: dict = (
                batch.error_row(job, outcome.cause)
                if isinstance(outcome, Lost)
                else cast(dict, outcome)  # a job's row; a Lost is handled above
            )
            table.append(row)
            played.rows.append(row)
            played.ran += 1
            played.errors += bool(batch.is_error(row))
            left = left_before - played.ran
            verdict = (
                batch.outcome(row)
                if batch.outcome is not None
                else "/".join(str(row.get(c)) for c in batch.fmt.verdicts)
            )
            extra = after_row(row, left) if after_row is not None and left > 0 else ""
            bar.update(f"{batch.label(job)}: {verdict}", extra)
    return played


def _worker_lost(loss: WorkerLost, batch: Batch, inflight: dict) -> str:
    """One line: the worker, why, and the jobs it held, which its executor ran again."""
    labels = [batch.label(inflight[k]) for k in loss.keys if k in inflight]
    held = (
        f"resubmitted to the other workers, the {len(labels)} {batch.unit} it held: "
        + "; ".join(labels[:3])
        + (f"; and {len(labels) - 3} more" if len(labels) > 3 else "")
        if labels
        else f"it held none of the {batch.unit}"
    )
    return f"worker {loss.worker} lost ({loss.cause}); {held}"


def _stopped(err: Interrupted, table: AppendTable, batch: Batch, total: int, partial: Path):
    """The ``Stopped`` of a run interrupted by a signal: what was kept and how to go on."""
    return Stopped(
        err.signum,
        f"stopped by {err.args[0]}: {len(table.rows)} of {total} {batch.unit} are in "
        f"{partial}; run the same command with --resume to finish"
        if table.rows
        else f"stopped by {err.args[0]} before any of the {batch.unit} finished; nothing written",
    )


def _check_keys(table: AppendTable, jobs: Iterable, batch: Batch) -> None:
    """Refuse a table with rows of jobs that are not in ``jobs`` (another run's)."""
    if not table.rows:
        return
    stray = set(table.rows)
    for job in jobs:
        stray.discard(batch.key(job))
        if not stray:
            return
    raise TableError(
        f"{table.path}: {len(stray)} rows (e.g. {batch.fmt.columns[0]} {min(stray)}) are not "
        f"{batch.unit} of {batch.source}: another {batch.name}'s table, or the {batch.name} file "
        "changed; use another --out"
    )


def duration(seconds: float) -> str:
    """A duration for people: "40 s", "12 min", "2.5 h"."""
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"
