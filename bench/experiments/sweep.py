"""Run a sweep: every trial of a sweep file, in parallel, each row written as it finishes.

One code path for local cores and a cluster: trials go to a
``concurrent.futures`` executor, a ``ProcessPoolExecutor`` by default or the
executor of a Dask ``distributed.Client`` (``--cluster ADDRESS``), each as a
call of the top-level ``run_one``; results are collected with ``as_completed``
and appended to ``DIR/sweep.csv`` at once (``sweep_table.py``). Trials whose
``trial_id`` is already in the table are skipped, so a killed sweep resumes
where it stopped. When every trial is done, the table is rewritten in the
sweep file's order (atomically), so the committed file is stable across runs.

A trial that raises (e.g. an unreachable gait) becomes a row with the verdicts
``error`` and the one-line message; a trial lost with its worker (a crashed
process, a lost cluster) leaves no row and is reported, to be run by a re-run.

On a cluster, the workers need slopewalk installed (they import ``bench``), and
``--record`` writes ``.rrd`` files from the workers, so ``DIR`` must be on a
file system they share.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import time
from collections.abc import Iterator
from concurrent.futures import Executor, ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bench.experiments.sweep_config import SweepConfig, SweepError, SweepTrial
from bench.experiments.sweep_table import SweepTable
from planner.errors import SlopewalkError

TABLE_NAME = "sweep.csv"
RECORDINGS_DIR = "recordings"


def run_one(trial: SweepTrial, record_dir: str | None = None) -> dict:
    """Plan, simulate and compare one trial (in a worker); its table row.

    Never raises for a bad trial: any exception becomes an ``error`` row.

    Args:
        trial: The trial.
        record_dir: Where to write ``<trial_id>.rrd``, or None for no recording.
    """
    from bench.sim.trial import run_trial
    from planner.plan import plan_walk

    start = time.perf_counter()
    try:
        plan = plan_walk(trial.spec, trial.gait())
        result = run_trial(trial.spec, trial.trial_spec(), plan=plan)
        row = trial.inputs() | outcome_columns(result, plan)
        if record_dir is not None:
            try:
                _record(Path(record_dir), trial.trial_id, plan, result)
            except Exception as err:  # the trial stands; a re-run with --record retries
                row["error"] = f"recording failed: {_one_line(err)}"
    except Exception as err:  # a trial's failure is a result, not a crash of the sweep
        row = trial.inputs() | {
            "analytic_verdict": "error",
            "simulated_verdict": "error",
            "error": _one_line(err),
        }
    row["wall_s"] = time.perf_counter() - start
    return row


def outcome_columns(result, plan) -> dict:
    """The outcome columns of a row (``sweep_table.COLUMNS``) from a TrialResult and its Plan."""
    events = sorted(result.events, key=lambda e: e.time)
    return {
        "analytic_verdict": result.analytic_verdict,
        "simulated_verdict": result.simulated_verdict,
        "slip_predicted": bool(result.slip_predicted),
        "events": ";".join(dict.fromkeys(e.kind for e in events)),
        "first_event_time_s": float(events[0].time) if events else None,
        "zmp_rms_mm": result.zmp_rms * 1e3,
        "zmp_max_mm": result.zmp_max * 1e3,
        "lipm_rms_mm": result.lipm_rms * 1e3,
        "cop_lipm_rms_mm": result.cop_lipm_rms * 1e3,
        "analytic_min_margin_mm": result.analytic_min_margin * 1e3,
        "simulated_min_margin_mm": result.simulated_min_margin * 1e3,
        "max_friction_ratio": result.max_friction_ratio,
        "simulated_max_friction_ratio": result.simulated_max_friction_ratio,
        "tracking_rms_deg": float(np.rad2deg(result.tracking_rms)),
        "peak_torque_planned_Nm": result.peak_torque_planned,
        "peak_torque_simulated_Nm": result.peak_torque_simulated,
        "work_J": float(plan.work.sum()),
        "standing_fraction": result.standing_fraction,
        "sim_steps": int(result.sim_steps),
        "error": "",
    }


def _record(directory: Path, trial_id: str, plan, result) -> None:
    """Write ``<trial_id>.rrd`` whole: recorded beside it, then moved into place."""
    from bench.report.recording import record_trial

    directory.mkdir(parents=True, exist_ok=True)
    tmp = directory / f".{trial_id}.{os.getpid()}.part.rrd"
    try:
        written = record_trial(tmp, plan, result)
        os.replace(written or tmp, directory / f"{trial_id}.rrd")
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.remove(tmp)


def _one_line(err: BaseException) -> str:
    text = " ".join(str(err).split())
    if isinstance(err, SlopewalkError):  # its message says it all
        return text
    return f"{type(err).__name__}: {text}" if text else type(err).__name__


def _ignore_sigint() -> None:
    """Workers leave Ctrl-C to the parent, which stops the sweep."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


@contextlib.contextmanager
def open_executor(*, workers: int | None = None, cluster: str | None = None) -> Iterator:
    """A ``concurrent.futures`` executor: local processes, or a Dask cluster's.

    Args:
        workers: Local worker processes (default ``os.cpu_count()``); ignored
            with ``cluster``.
        cluster: Dask scheduler address, e.g. ``tcp://host:8786``.

    Raises:
        SweepError: the cluster cannot be reached, or Dask is not installed.
    """
    if cluster is not None:
        try:
            from distributed import Client
        except ImportError:
            raise SweepError("--cluster needs Dask: pip install 'dask[distributed]'") from None
        from distributed.comm.addressing import parse_address, parse_host_port

        try:  # a malformed address, refused before a Client exists (its __del__ would hang)
            scheme, location = parse_address(cluster, strict=True)
            if scheme in ("tcp", "tls"):
                parse_host_port(location)
        except ValueError as err:
            raise SweepError(
                f"cluster {cluster!r}: not a scheduler address like tcp://host:8786 ({err})"
            ) from None
        try:
            client = Client(cluster, timeout=10, set_as_default=False)
        except Exception as err:
            raise SweepError(f"cluster {cluster!r}: cannot connect ({_one_line(err)})") from None
        try:
            yield client.get_executor(pure=False)
        finally:
            client.close()
        return
    pool = ProcessPoolExecutor(max_workers=workers or os.cpu_count(), initializer=_ignore_sigint)
    try:
        yield pool
    except BaseException:
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown(wait=True)


@dataclass(frozen=True)
class SweepSummary:
    """What a sweep run did.

    Attributes:
        table: Path of the results table.
        total: Trials in the sweep.
        resumed: Trials found finished in the table and skipped.
        ran: Trials run now (rows written).
        errors: Rows of this run with the verdict ``error``.
        lost: One line per trial lost with its worker (no row written).
        sim_steps: Simulation steps of the trials run now.
        wall_s: Wall time of this run [s].
        verdicts: (analytic, simulated) -> count over the whole table.
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

    def lines(self) -> list[str]:
        out = [
            f"sweep: {self.total} trials: {self.ran} run, {self.resumed} already done, "
            f"{self.errors} errors, {len(self.lost)} lost, in {self.wall_s:.1f} s"
            + (f" ({self.sim_steps / self.wall_s:.0f} sim steps/s)" if self.ran else ""),
            "analytic / simulated verdicts: "
            + ", ".join(f"{a}/{s} {n}" for (a, s), n in sorted(self.verdicts.items())),
            f"wrote {self.table}",
        ]
        return out + [f"lost: {line}" for line in self.lost[:5]]


def run_sweep(
    config: SweepConfig,
    out_dir: str | Path,
    *,
    executor: Executor,
    record: bool = False,
    progress: bool = False,
    quiet: bool = False,
) -> SweepSummary:
    """Run the trials of ``config`` not yet in ``out_dir/sweep.csv``, appending each row.

    Args:
        config: The parsed sweep file.
        out_dir: Output directory: ``sweep.csv`` and, with ``record``, ``recordings/``.
        executor: Where trials run (``open_executor``).
        record: Also write ``recordings/<trial_id>.rrd`` per trial.
        progress: A tqdm bar on stderr; else a log line at every tenth of the sweep.
        quiet: Neither bar nor log lines.
    """
    start = time.perf_counter()
    out_dir = Path(out_dir)
    record_dir = out_dir / RECORDINGS_DIR if record else None
    with SweepTable.open(out_dir / TABLE_NAME) as table:

        def finished(trial: SweepTrial) -> bool:
            if trial.trial_id not in table.rows:
                return False
            return record_dir is None or (record_dir / f"{trial.trial_id}.rrd").exists()

        todo = [t for t in config.trials if not finished(t)]
        todo.sort(key=lambda t: -t.step_time * (t.steps + 0.4))  # longest first
        done = len(config.trials) - len(todo)
        bar = _Progress(len(config.trials), done, tty=progress, quiet=quiet)
        futures = {
            executor.submit(run_one, t, None if record_dir is None else str(record_dir)): t
            for t in todo
        }
        ran = errors = sim_steps = 0
        lost = []
        try:
            for future in as_completed(futures):
                trial = futures.pop(future)
                try:
                    row = future.result()
                except Exception as err:  # the worker itself was lost
                    lost.append(f"{trial.label}: {_one_line(err)}")
                    bar.update(trial, None)
                    continue
                if trial.trial_id in table.rows:  # re-run for its recording only
                    table.replace(row)
                else:
                    table.append(row)
                ran += 1
                errors += row["simulated_verdict"] == "error"
                sim_steps += row.get("sim_steps") or 0
                bar.update(trial, row)
        finally:
            bar.close()
            for future in futures:
                future.cancel()
        if not lost:
            table.rewrite(t.trial_id for t in config.trials)
        verdicts: dict[tuple[str, str], int] = {}
        for row in table.rows.values():
            key = (row["analytic_verdict"], row["simulated_verdict"])
            verdicts[key] = verdicts.get(key, 0) + 1
    return SweepSummary(
        table=table.path,
        total=len(config.trials),
        resumed=done,
        ran=ran,
        errors=errors,
        lost=tuple(lost),
        sim_steps=sim_steps,
        wall_s=time.perf_counter() - start,
        verdicts=verdicts,
    )


class _Progress:
    """A tqdm bar on a terminal; otherwise a plain line at every tenth of the sweep."""

    def __init__(self, total: int, done: int, *, tty: bool, quiet: bool = False):
        self.total, self.count, self.quiet = total, done, quiet
        self._next_log = done
        self._bar = None
        if quiet:
            return
        if tty:
            from tqdm import tqdm

            self._bar = tqdm(total=total, initial=done, unit="trial", desc="sweep", file=sys.stderr)
        elif done < total:
            print(f"sweep: {total - done} of {total} trials to run", file=sys.stderr, flush=True)

    def update(self, trial: SweepTrial, row: dict | None) -> None:
        self.count += 1
        verdicts = (
            "lost" if row is None else f"{row['analytic_verdict']}/{row['simulated_verdict']}"
        )
        if self._bar is not None:
            self._bar.set_postfix_str(f"{trial.label}: {verdicts}", refresh=False)
            self._bar.update(1)
        elif not self.quiet and (self.count >= self._next_log or self.count == self.total):
            print(
                f"[{self.count}/{self.total}] {trial.label}: {verdicts}",
                file=sys.stderr,
                flush=True,
            )
            self._next_log = self.count + max(1, self.total // 10)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
