"""Run a stability envelope: every cell of an envelope file in parallel, each row kept as it ends.

The envelope's half; the resumable table run (lock, partial table, resume, worker
deaths, signals, progress) is the sweep's, ``batch/run.py``. A run directory holds
``envelope.partial.csv`` while a run is going and ``envelope.csv`` when it is
done (columns: ``tables.envelope.envelope_format(config.controllers)``); with
``record``, ``recordings/<cell_id>.rrd``. ``slopewalk envelope`` then writes the
table's documents (``report.envelope_claims.write_envelope_documents``).

Convergence (``run_convergence``): a seeded 10 % of the cells is searched again
with 4 × the generations (no MuJoCo: the question is the GA's), into
``convergence.csv`` in the same run directory (resumable the same way); the
report counts the feasibility verdicts that change and the largest change of
the max-margin and min-work margins.
"""

from __future__ import annotations

import math
import os
import time
from concurrent.futures import Executor
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from slopewalk.bench.batch.progress import RateSinceFirst
from slopewalk.bench.batch.run import Batch, duration, run_batch
from slopewalk.bench.experiments.envelope.cell import (
    error_row,
    run_cell,
    run_cell_search,
)
from slopewalk.bench.experiments.envelope.config import EnvelopeConfig
from slopewalk.bench.experiments.sweep.run import WORKER_START_S, on_model
from slopewalk.bench.tables.envelope import envelope_format, is_failure
from slopewalk.bench.tables.table import model_format
from slopewalk.planner import pace

RECORDINGS_DIR = "recordings"
CELL_S = 1.3  # [s] per cell and worker, the first estimate: run_cell's CPU time, 8 cells of
# the default grid from 0.3 to 2 s and -30 to 35 deg (GA 2 x 3000 evaluations ~0.6 s, its trials
# 0.3-2 s), load ~5 on the 2-core machine; was 2.5 before the predictors were compiled
CONVERGENCE_SHARE = 0.10
CONVERGENCE_FACTOR = 4


def _is_error(row: dict) -> bool:
    return is_failure(row.get("error"))


def _batch(name: str, fn, config: EnvelopeConfig) -> Batch:
    fmt = envelope_format(config.controllers)
    return Batch(
        name=name,
        fmt=fmt if config.model is None else model_format(fmt),
        fn=fn,
        key=lambda cell: cell.cell_id,
        label=lambda cell: cell.label,
        error_row=error_row,
        is_error=_is_error,
        source=config.source + on_model(config.model),
        unit="cells",
        outcome=_outcome,
        kernel=("scores", "plan", "predictors"),
    )


def _outcome(row: dict) -> str:
    """E.g. "feasible, margin 6.4 mm, stiff stable, servo tip"."""
    if _is_error(row):
        return f"error: {row['error']}"
    margin = row.get("maxmargin_margin_mm")
    text = ("feasible" if row.get("feasible") else "infeasible") + (
        f", margin {margin:.1f} mm" if isinstance(margin, float) else ""
    )
    played = [
        f"{k.removeprefix('maxmargin_').removesuffix('_verdict')} {v}"
        for k, v in row.items()
        if k.startswith("maxmargin_")
        if k.endswith("_verdict") and v
    ]
    return ", ".join([text, *played])


@dataclass(frozen=True)
class EnvelopeSummary:
    """What an envelope run did: its table, counts, wall time, and the workers' time [s]
    in the GA (``ga_s``) and in planning at 1 ms and playing (``sim_s``), this run's cells."""

    table: Path
    total: int
    resumed: int
    ran: int
    errors: int
    lost: tuple[str, ...]
    feasible: int
    wall_s: float
    ga_evaluations: int
    ga_s: float
    sim_s: float = 0.0
    lost_workers: tuple[str, ...] = ()  # one line per worker a cluster lost, with its cells

    @property
    def cells_per_min(self) -> float:
        return 60 * self.ran / self.wall_s if self.wall_s > 0 else math.inf

    @property
    def ga_evals_per_s(self) -> float:
        """GA evaluations per second of GA time, per worker."""
        return self.ga_evaluations / self.ga_s if self.ga_s > 0 else math.nan

    def lines(self) -> list[str]:
        out = [
            f"envelope: {self.total} cells: {self.ran} run, {self.resumed} already done, "
            f"{self.errors} errors, {len(self.lost)} lost, in {self.wall_s:.1f} s"
            + (f" ({self.cells_per_min:.1f} cells/min)" if self.ran else ""),
            f"feasible (a gait with the ZMP inside exists): {self.feasible} of {self.total} cells",
            f"wrote {self.table}",
        ]
        lost = [f"lost: {line}" for line in self.lost[:5]]
        return out + lost + list(self.lost_workers)


def _threads(workers: int, executor) -> int:
    return 1 if executor is not None else max(1, (os.cpu_count() or 1) // workers)


def run_envelope(
    config: EnvelopeConfig,
    out_dir: str | Path,
    *,
    workers: int | None = None,
    executor: Executor | None = None,
    resume: bool | None = False,
    record: bool = False,
    progress: bool = False,
    quiet: bool = False,
) -> EnvelopeSummary:
    """Run the cells of ``config`` into ``out_dir`` (module doc).

    Args: as ``sweep.run_sweep``. The documents of a finished table (``envelope.png``,
    ``boundaries.md``) are ``report.envelope_claims.write_envelope_documents``'s.

    Raises:
        SweepError: a table there is not an envelope table, holds cells not in ``config``,
            or is an unfinished run and ``resume`` is False.
        Stopped: SIGINT or SIGTERM; the rows written so far stay in ``envelope.partial.csv``.
    """
    start = time.perf_counter()
    out_dir = Path(out_dir)
    workers = workers or os.cpu_count() or 1
    threads = _threads(workers, executor)
    cells = [replace(c, threads=threads) for c in config.cells]
    record_dir = out_dir / RECORDINGS_DIR if record else None
    result = run_batch(
        _batch("envelope", run_cell, config),
        cells,
        len(cells),
        out_dir,
        workers=workers,
        executor=executor,
        resume=resume,
        record_dir=record_dir,
        progress=progress,
        quiet=quiet,
        order=lambda c: -c.step_time,  # longest walks first
        intro=lambda done, w: _intro("envelope", len(cells), done, w, executor, CELL_S),
        after_row=_eta(),
    )
    return EnvelopeSummary(
        table=result.table,
        total=len(cells),
        resumed=result.resumed,
        ran=result.ran,
        errors=result.errors,
        lost=result.lost,
        feasible=sum(n for v, n in result.verdicts.items() if v[0] == "True"),
        wall_s=time.perf_counter() - start,
        ga_evaluations=sum(r.get("ga_evaluations") or 0 for r in result.rows),
        ga_s=sum(r.get("ga_s") or 0.0 for r in result.rows),
        sim_s=sum(r.get("sim_s") or 0.0 for r in result.rows),
        lost_workers=result.lost_workers,
    )


def first_estimate_s(
    cells: int, workers: int, cell_s: float = CELL_S, *, compile_s=None, slowdown=None
):
    """The time [s] ``cells`` cells take on ``workers`` workers: ``cell_s`` each (the GA
    and the cell's trials, analytic work included) and the workers' start, both times
    ``slowdown`` (this machine's pace against the reference machine's; None:
    ``pace.slowdown()``, measured), and, where the kernel's code is not cached, its
    compiling (``compile_s``; None: as ``planner/kernel/cache.py`` says for the GA's and a
    trial's entries side by side, one process per worker and core, at the same pace)."""
    slowdown = pace.slowdown() if slowdown is None else slowdown
    if compile_s is None:
        from slopewalk.planner.kernel import cache

        slots = min(workers, os.cpu_count() or 1)  # ``prepare``'s processes (batch.run)
        compile_s = cache.cold_seconds(
            "scores", "plan", "predictors", slots=slots, slowdown=slowdown
        )
    return (cells * cell_s / max(workers, 1) + WORKER_START_S) * slowdown + compile_s


def _intro(name, total, done, workers, executor, cell_s) -> str:
    left = total - done
    where = f" on {workers} workers" if executor is None else ""
    per = workers if executor is None else 1
    return (
        f"{name}: {total} cells, {done} already done, {left} to run{where}: about "
        f"{duration(first_estimate_s(left, per, cell_s))} at {cell_s * pace.slowdown():.2g} s "
        "per cell and worker (refined as cells finish)"
    )


def _eta():
    rate = RateSinceFirst()  # the cells' own rate: the compile and workers' start aside

    def after_row(row: dict, left: int) -> str:
        cells_per_s = rate.add(1)
        return "" if cells_per_s is None else f", about {duration(left / cells_per_s)} left"

    return after_row


# --- convergence -----------------------------------------------------------------------------


def convergence_cells(config: EnvelopeConfig) -> list:
    """The seeded 10 % of the cells (at least one), searched with 4 x the generations."""
    n = len(config.cells)
    k = max(1, round(CONVERGENCE_SHARE * n))
    rng = np.random.default_rng(config.search.seed)
    chosen = sorted(rng.choice(n, size=k, replace=False))
    search = replace(config.search, generations=CONVERGENCE_FACTOR * config.search.generations)
    return [config.cells[i] for i in chosen], [
        replace(config.cells[i], search=search) for i in chosen
    ]


@dataclass(frozen=True)
class Convergence:
    """Budget vs 4 x budget on the same cells.

    Attributes:
        cells: Cells compared. flips: Feasibility verdicts (max-margin margin ≥ 0)
            that change. found_flips: min-work "found" verdicts that change.
        max_change_mm: Largest |Δ margin| of the max-margin gait [mm], over the cells
            feasible at either budget (those that place the boundary).
        max_change_all_mm: The same over every cell compared (an infeasible cell's
            margin, tens of mm outside, is a poorly posed maximum: it decides nothing).
        minwork_work_change: Largest relative change of the min-work gait's work,
            over cells where both budgets found one.
        rows: (label, margin at budget, margin at 4x) [mm] per cell.
    """

    cells: int
    flips: int
    found_flips: int
    max_change_mm: float
    max_change_all_mm: float
    minwork_work_change: float
    rows: tuple

    def lines(self) -> list[str]:
        return [
            f"convergence: {self.cells} cells re-searched with {CONVERGENCE_FACTOR}x the "
            f"generations: {self.flips} feasibility verdicts change (goal 0), "
            f"{self.found_flips} min-work verdicts change, largest max-margin change "
            f"{self.max_change_mm:.3f} mm over feasible cells (goal <= 0.5 mm; "
            f"{self.max_change_all_mm:.3f} mm over all), largest min-work work change "
            f"{100 * self.minwork_work_change:.1f} %"
        ]


def run_convergence(
    config: EnvelopeConfig,
    table: str | Path,
    out_dir: str | Path,
    *,
    workers: int | None = None,
    executor: Executor | None = None,
    resume: bool | None = None,
    progress: bool = False,
    quiet: bool = False,
) -> Convergence:
    """Search the convergence cells again at 4 x the budget and compare with ``table``."""
    out_dir = Path(out_dir)
    workers = workers or os.cpu_count() or 1
    base, bigger = convergence_cells(config)
    threads = _threads(workers, executor)
    bigger = [replace(c, threads=threads) for c in bigger]
    result = run_batch(
        _batch("convergence", run_cell_search, config),
        bigger,
        len(bigger),
        out_dir,
        workers=workers,
        executor=executor,
        resume=resume,
        progress=progress,
        quiet=quiet,
        order=lambda c: -c.step_time,
        intro=lambda done, w: _intro(
            "convergence", len(bigger), done, w, executor, CELL_S * CONVERGENCE_FACTOR / 2
        ),
        after_row=_eta(),
    )
    return compare_budgets(table, result.table, base, bigger)


def _by_id(path, fmt) -> dict[str, dict]:
    """The rows of a table (``read_table``: numbers as floats) by their id as written
    (an id of decimal digits only would read as a number)."""
    from slopewalk.bench.tables.table import read_table

    ids = fmt.read_rows(path)
    return dict(zip(ids, read_table(path), strict=True))


def compare_budgets(table, bigger_table, base: list, bigger: list) -> Convergence:
    """The ``Convergence`` of the rows of ``base`` in ``table`` vs ``bigger`` in the other."""
    fmt = envelope_format(base[0].controllers if base else ())
    if base and base[0].model is not None:
        fmt = model_format(fmt)
    small, large = _by_id(table, fmt), _by_id(bigger_table, fmt)
    flips = found_flips = 0
    change = change_all = work_change = 0.0
    rows = []
    for a, b in zip(base, bigger, strict=True):
        ra, rb = small[a.cell_id], large[b.cell_id]
        flips += ra["feasible"] != rb["feasible"]
        found_flips += ra["minwork_found"] != rb["minwork_found"]
        delta = abs(ra["maxmargin_margin_mm"] - rb["maxmargin_margin_mm"])
        change_all = max(change_all, delta)
        if "True" in (ra["feasible"], rb["feasible"]):
            change = max(change, delta)
        if ra["minwork_found"] == rb["minwork_found"] == "True":
            w0, w1 = ra["minwork_work_J"], rb["minwork_work_J"]
            work_change = max(work_change, abs(w0 - w1) / w1)
        rows.append((a.label, ra["maxmargin_margin_mm"], rb["maxmargin_margin_mm"]))
    return Convergence(len(base), flips, found_flips, change, change_all, work_change, tuple(rows))


def write_convergence(check: Convergence, config: EnvelopeConfig, out_dir: str | Path) -> Path:
    """``convergence.md`` in ``out_dir``: the figures and one line per cell compared."""
    from slopewalk.bench.files import atomic_path

    s = config.search
    lines = [
        "# Convergence of the envelope's GA",
        "",
        f"Regenerated by `slopewalk envelope --convergence` ({config.source}): a seeded "
        f"{CONVERGENCE_SHARE:.0%} of the cells (numpy seed {s.seed}) searched again with "
        f"{CONVERGENCE_FACTOR} × the generations (population {s.population}, "
        f"{CONVERGENCE_FACTOR * s.generations} instead of {s.generations} generations).",
        "",
        f"- cells compared: {check.cells}",
        f"- feasibility verdicts that change: {check.flips} (goal 0)",
        f"- min-work 'found' verdicts that change (margin ≥ {s.required_margin * 1e3:g} mm): "
        f"{check.found_flips}",
        f"- largest change of the largest minimum ZMP margin, cells feasible at either budget: "
        f"{check.max_change_mm:.3f} mm (goal ≤ 0.5 mm); over every cell compared: "
        f"{check.max_change_all_mm:.3f} mm (an infeasible cell's margin decides nothing)",
        f"- largest relative change of the least work: {100 * check.minwork_work_change:.1f} %",
        "",
        "| cell | max margin [mm] | at 4× budget [mm] |",
        "|---|---|---|",
        *(f"| {label} | {a:.3f} | {b:.3f} |" for label, a, b in check.rows),
    ]
    path = Path(out_dir) / "convergence.md"
    with atomic_path(path) as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    return path
