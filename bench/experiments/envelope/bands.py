"""The envelope's boundaries under the robot's unknowns: each estimated value at either end.

``boundaries.md`` (``slopewalk envelope``) reports, per gait family, three *analytic*
boundaries: the fastest flat step time with a gait inside, and the steepest uphill and
downhill slope with one at the reference step time (1 s). They rest on values the spec
only estimates (its ``[uncertain]`` table, ``planner/uncertainty.py``). ``run_bands``
searches each boundary again with the spec changed in **one** value at a time, set to the
low and then the high end of its range (the others at the spec's values; no corners or
combinations), and reports per value the boundary at low / nominal / high: the band of a
boundary is the min–max over every value's two ends and the nominal.

*Inside* is the envelope's first question, from its own max-margin search:
``run_cell_stability`` of a cell with the envelope file's GA settings (population,
generations, seed, the family), which holds the GA's admissibility constraints (knee bent
by at least the servo's compliance band, swing lift ≥ the clearance, friction ratio ≤ μ,
planned slide ≤ the slip threshold; ``planner/gait_search.py``) and the 1 ms re-plan; the
cell is inside when its max-margin gait has margin ≥ 0. The envelope also counts the
individuals of its min-work search, which this leaves out to halve the cost: a cell can
only be inside here if it is in the envelope with the same code and spec.

``play_boundaries`` then walks a few boundary cells in MuJoCo as the envelope does
(``run_cell``): the simulated verdicts of the boundary gaits.

The search of one boundary (``walk``) runs along the envelope's own grid, from the easy
end outwards (flat: step times from the slowest; uphill: slopes from 0° up; downhill: from
0° down), starting at the nominal spec's boundary: while the cell there is inside it
steps outwards, else inwards, and the boundary is the last inside cell before the first
one outside. It assumes that near the boundary the inside cells form one run from the easy
end (an inside cell beyond the first outside one is not looked for), so it searches 2–4
cells per boundary rather than the whole axis.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

from slopewalk.bench.batch.executor import LocalPool, Lost
from slopewalk.bench.experiments.envelope.cell import EnvelopeCell, run_cell_stability
from slopewalk.bench.experiments.envelope.config import EnvelopeConfig, EnvelopeError
from slopewalk.bench.experiments.sweep.trials import spec_text
from slopewalk.bench.tables.envelope import is_failure
from slopewalk.planner.spec import RobotSpec
from slopewalk.planner.uncertainty import Uncertain, spec_at

REFERENCE_STEP_TIME = 1.0  # [s]: the slope boundaries' step time, as boundaries.md's
BOUNDARIES = ("flat", "up", "down")  # the order of the tables
NOMINAL = "nominal"


def axis(config: EnvelopeConfig, boundary: str) -> list[tuple[float, float]]:
    """The (step time [s], slope [deg]) cells of the grid along ``boundary``, easy end first."""
    if boundary == "flat":
        if 0.0 not in config.slopes_deg:
            raise EnvelopeError(f"{config.source}: the grid has no flat slope (0) for bands")
        return [(t, 0.0) for t in sorted(config.step_times, reverse=True)]
    if REFERENCE_STEP_TIME not in config.step_times:
        raise EnvelopeError(
            f"{config.source}: the grid has no step time {REFERENCE_STEP_TIME:g} s for bands"
        )
    up = boundary == "up"
    slopes = sorted((s for s in config.slopes_deg if (s >= 0 if up else s <= 0)), reverse=not up)
    return [(REFERENCE_STEP_TIME, s) for s in slopes]


def walk(inside: Callable[[int], bool], n: int, start: int) -> int:
    """Index of the boundary along an axis of ``n`` cells, easy end first (module doc).

    From ``start`` (clipped into the axis): outwards while ``inside``, else inwards to the
    first cell inside. Returns the last inside index before the first outside one, −1
    when none is inside.
    """
    i = min(max(start, 0), n - 1)
    if inside(i):
        while i + 1 < n and inside(i + 1):
            i += 1
        return i
    while i > 0:
        i -= 1
        if inside(i):
            return i
    return -1


@dataclass(frozen=True)
class Job:
    """One boundary of one family searched with one spec: the nominal or one value at one end.

    Attributes:
        family, boundary: The gait family; "flat", "up" or "down" (``BOUNDARIES``).
        key, end, value: The value moved (``Uncertain.key``), "low" or "high", and its
            value there (SI unit); "nominal", "nominal" and nan for the spec itself.
        cells: The axis, easy end first (``axis``). start: Index to start the walk at.
        cell: The envelope cell whose search settings, family and μ every cell uses.
        spec: The robot as changed.
    """

    family: str
    boundary: str
    key: str
    end: str
    value: float
    cells: tuple[tuple[float, float], ...]
    start: int
    cell: EnvelopeCell
    spec: RobotSpec

    def identity(self) -> dict:
        """The columns that name this search in a result row: family, boundary, key, end,
        value."""
        return {"family": self.family, "boundary": self.boundary, "key": self.key,
                "end": self.end, "value": self.value}  # fmt: skip


def run_job(job: Job) -> dict:
    """Walk one boundary (``walk``); its row: the boundary's grid value (None: no cell
    inside), whether it is the axis's last cell, the largest margin [mm] at the nominal spec's
    boundary cell (where a changed spec's walk starts: a change too small to move the
    boundary a grid cell still shows there), and the cells searched with their margins."""
    spec_json = spec_text(job.spec)
    searched: dict[int, tuple[bool, float]] = {}

    def inside(i: int) -> bool:
        t, s = job.cells[i]
        cell = replace(job.cell, step_time=t, slope_deg=s, spec=job.spec, spec_json=spec_json)
        row = run_cell_stability(cell)
        if is_failure(row.get("error")):
            raise EnvelopeError(f"{cell.label} ({job.key} {job.end}): {row['error']}")
        searched[i] = (bool(row["feasible"]), float(row["maxmargin_margin_mm"]))
        return searched[i][0]

    i = walk(inside, len(job.cells), job.start)
    # the cell whose margin is reported: the nominal spec's boundary (its own walk's result;
    # the first cell when none is inside), where every changed spec's walk starts
    first = min(max(job.start, 0), len(job.cells) - 1)
    anchor = max(i, 0) if job.key == NOMINAL else first
    coordinate = 0 if job.boundary == "flat" else 1
    return job.identity() | {
        "index": i,
        "at": job.cells[i][coordinate] if i >= 0 else None,
        "edge": i == len(job.cells) - 1,
        "nominal_cell_margin_mm": searched[anchor][1],
        "searched": "; ".join(
            f"{job.cells[k][coordinate]:g}: {m:+.1f} mm" for k, (_, m) in sorted(searched.items())
        ),
    }


def _base_cell(config: EnvelopeConfig, family: str) -> EnvelopeCell:
    for cell in config.cells:
        if cell.family == family and cell.robot == "default" and cell.friction == 1.0:
            return replace(cell, threads=1)
    raise EnvelopeError(
        f"{config.source}: no cell of family {family!r} at mu 1 with the default robot for bands"
    )


def _run(jobs: list[Job], workers: int, say) -> list[dict]:
    rows = []
    with LocalPool(run_job, workers=workers) as pool:
        for _, result in pool.run((str(i), (job,)) for i, job in enumerate(jobs)):
            if isinstance(result, Lost) or not isinstance(result, dict):
                raise EnvelopeError(f"a bands worker was lost: {result}")
            rows.append(result)
            say(f"  {result['family']} {result['boundary']} {result['key']} {result['end']}: "
                f"{result['at']} ({result['searched']})")  # fmt: skip
    return rows


def run_bands(
    config: EnvelopeConfig,
    spec: RobotSpec,
    uncertain: Sequence[Uncertain],
    *,
    workers: int | None = None,
    quiet: bool = False,
) -> tuple[list[dict], float]:
    """Every boundary of every family of ``config``, nominal and with each value of
    ``uncertain`` at each end (module doc); (rows, wall time [s]).

    The nominal boundaries are searched first (from the middle of each axis); each changed
    spec's walk then starts at its nominal boundary.
    """
    workers = workers or os.cpu_count() or 1

    def say(text: str) -> None:
        if not quiet:
            print(text, file=sys.stderr, flush=True)

    start = time.perf_counter()
    plans = [
        (family, boundary, tuple(axis(config, boundary)), _base_cell(config, family))
        for family in config.search.families
        for boundary in BOUNDARIES
    ]
    say(f"bands: {len(plans)} nominal boundaries, then {2 * len(uncertain)} changed specs each")
    nominal = _run(
        [Job(f, b, NOMINAL, NOMINAL, float("nan"), c, len(c) // 2, cell, spec)
         for f, b, c, cell in plans],
        workers, say,
    )  # fmt: skip
    begin = {(r["family"], r["boundary"]): r["index"] for r in nominal}
    jobs = [
        Job(f, b, u.key, end, value, c, begin[f, b], cell, spec_at(spec, u.key, value))
        for f, b, c, cell in plans
        for u in uncertain
        for end, value in u.ends()
    ]
    changed = _run(jobs, workers, say)
    ranges = {u.key: {"low": u.low, "high": u.high, "unit": u.unit} for u in uncertain}
    changed = [r | ranges[r["key"]] for r in changed]
    order = {(j.family, j.boundary, j.key, j.end): i for i, j in enumerate(jobs)}
    changed.sort(key=lambda r: order[r["family"], r["boundary"], r["key"], r["end"]])
    return nominal + changed, time.perf_counter() - start


@dataclass(frozen=True)
class Play:
    """One boundary cell to walk in MuJoCo: the cell of ``job``'s axis at ``index``, with the
    job's spec (the nominal, or one value at one end)."""

    job: Job
    index: int


def play_cell(play: Play) -> dict:
    """The envelope's own cell (``run_cell``: both searches, the 1 ms re-plan, every actuator
    mode of the envelope) at a boundary, with the job's spec; the max-margin gait's row:
    its margin [mm] and its simulated verdicts per mode: balance, and the strict walk
    verdict in brackets where it is not the balance one (``docs/verdicts.md``)."""
    from slopewalk.bench.experiments.envelope.cell import run_cell

    job = play.job
    t, s = job.cells[play.index]
    cell = replace(job.cell, step_time=t, slope_deg=s, spec=job.spec,
                   spec_json=spec_text(job.spec))  # fmt: skip
    row = run_cell(cell)
    if is_failure(row.get("error")):
        raise EnvelopeError(f"{cell.label} ({job.key} {job.end}): {row['error']}")
    return job.identity() | {
        "step_time": t,
        "slope_deg": s,
        "margin_mm": float(row["maxmargin_margin_mm"]),
        "verdicts": {m: _verdicts(row, m) for m in cell.modes},
    }


def _verdicts(row: dict, mode: str) -> str:
    """ "stable (overload)": the balance verdict, and the strict walk one where it differs."""
    from slopewalk.bench.tables.envelope import sim_columns, walk_column

    balance, walk = row[sim_columns("maxmargin", mode)[0]], row.get(walk_column("maxmargin", mode))
    return balance if walk in (None, "", balance) else f"{balance} ({walk})"


def play_boundaries(
    config: EnvelopeConfig,
    spec: RobotSpec,
    picks: Sequence[tuple[str, str, str, str, float, int]],
    *,
    workers: int | None = None,
    quiet: bool = False,
) -> list[dict]:
    """Walk in MuJoCo the boundary gaits of ``picks``: (family, boundary, key, end, value,
    index of the boundary cell on the axis), key "nominal" for the spec itself; rows of
    ``play_cell`` in the order of ``picks``."""
    plays = []
    for family, boundary, key, end, value, index in picks:
        changed = spec if key == NOMINAL else spec_at(spec, key, value)
        cells = tuple(axis(config, boundary))
        job = Job(family, boundary, key, end, value, cells, index,
                  _base_cell(config, family), changed)  # fmt: skip
        plays.append(Play(job, index))
    rows: list[dict | None] = [None] * len(plays)
    with LocalPool(play_cell, workers=workers or os.cpu_count() or 1) as pool:
        for key, result in pool.run((str(i), (p,)) for i, p in enumerate(plays)):
            if isinstance(result, Lost) or not isinstance(result, dict):
                raise EnvelopeError(f"a bands worker was lost: {result}")
            rows[int(key)] = result
            if not quiet:
                print(
                    f"  played {result['family']} {result['boundary']} {result['key']} "
                    f"{result['end']}: {result['verdicts']}",
                    file=sys.stderr,
                    flush=True,
                )
    return [r for r in rows if r is not None]


CONVERGENCE_FACTOR = 4  # generations of the convergence check, × the envelope's


def converge_cell(play: Play) -> dict:
    """The cell of ``play`` searched as ``run_job`` does, and again with
    ``CONVERGENCE_FACTOR`` × the generations: its row (boundary, key, end, the cell, the
    margin [mm] and verdict of each budget)."""
    job = play.job
    t, s = job.cells[play.index]
    out = {
        "family": job.family,
        "boundary": job.boundary,
        "key": job.key,
        "end": job.end,
        "at": job.cells[play.index][0 if job.boundary == "flat" else 1],
    }
    small = job.cell.search
    big = replace(small, generations=CONVERGENCE_FACTOR * small.generations)
    for name, search in (("", small), ("_big", big)):
        cell = replace(job.cell, step_time=t, slope_deg=s, search=search, spec=job.spec,
                       spec_json=spec_text(job.spec))  # fmt: skip
        row = run_cell_stability(cell)
        if is_failure(row.get("error")):
            raise EnvelopeError(f"{cell.label} ({job.key} {job.end}): {row['error']}")
        out[f"margin{name}_mm"] = float(row["maxmargin_margin_mm"])
        out[f"inside{name}"] = bool(row["feasible"])
    return out


def converge_boundaries(
    config: EnvelopeConfig,
    spec: RobotSpec,
    picks: Sequence[tuple[str, str, str, str, float, int]],
    *,
    workers: int | None = None,
) -> list[dict]:
    """``converge_cell`` of each boundary cell of ``picks`` (as ``play_boundaries``) and of
    the first cell beyond it, where the boundary's verdicts flip."""
    plays = []
    for family, boundary, key, end, value, index in picks:
        changed = spec if key == NOMINAL else spec_at(spec, key, value)
        cells = tuple(axis(config, boundary))
        job = Job(family, boundary, key, end, value, cells, index,
                  _base_cell(config, family), changed)  # fmt: skip
        plays += [Play(job, i) for i in (index, index + 1) if i < len(cells)]
    rows: list[dict | None] = [None] * len(plays)
    with LocalPool(converge_cell, workers=workers or os.cpu_count() or 1) as pool:
        for key, result in pool.run((str(i), (p,)) for i, p in enumerate(plays)):
            if isinstance(result, Lost) or not isinstance(result, dict):
                raise EnvelopeError(f"a bands worker was lost: {result}")
            rows[int(key)] = result
    return [r for r in rows if r is not None]
