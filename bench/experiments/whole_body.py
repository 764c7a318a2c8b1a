"""The whole-body walk (``planner/whole_body.py``) on a finished sweep: its design loop.

Run, from the repository root, on a finished sweep and its file:

    python -m slopewalk.bench.experiments.whole_body SWEEP.toml TABLE.csv [--mode MODE]
        [--workers N]

It prints per actuator mode the table's predicted verdict's agreement with MuJoCo's on
walking, the model's alone (walks unless it tips) and the predicted verdict with the
model's tip added (on a table the predictor wrote since stop 50 the first and the last are
the same: the predictor adds that tip itself, ``verdict.predict``'s ``body_tip``). That is
how the model was designed on the design sets (results/README.md, stop 49).
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

from slopewalk.bench.experiments.controller_comparison import map_local
from slopewalk.bench.experiments.repredict import on_table, table_jobs
from slopewalk.bench.sim.prediction import body_walk
from slopewalk.bench.tables.sweep import walks
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.whole_body import tip_time


@dataclass(frozen=True)
class Evaluated:
    """One trial of a table: its mode, MuJoCo's verdict, the table's predicted verdict and
    the model's tip time [s] (None: it walks)."""

    trial_id: str
    actuators: str
    simulated: str
    predicted: str
    tip: float | None


def evaluate(
    sweep_file: str | Path, table: str | Path, *, mode: str | None = None, workers: int = 1
) -> list[Evaluated]:
    """The model on every trial of ``table`` (a finished sweep of ``sweep_file``), in the
    sweep file's order, on ``workers`` processes; ``mode``: only that actuator mode's.

    Raises:
        SlopewalkError: ``table`` is not a sweep table.
    """
    return map_local(_evaluated, table_jobs(sweep_file, table, mode), workers)


def _evaluated(job: tuple) -> Evaluated:
    """One (trial, row) of ``table_jobs`` (top level: a worker's job)."""
    trial, row = job
    plan = plan_walk(trial.spec, trial.gait())
    walked = body_walk(plan, friction=trial.friction, actuators=trial.actuators)
    return Evaluated(
        trial.trial_id,
        trial.actuators,
        row["simulated_verdict"],
        row["predicted_verdict"],
        tip_time(plan, walked),
    )


def report(found: list[Evaluated]) -> str:
    """Per mode: trials and the agreement with MuJoCo on walking of the table's predicted
    verdict, of the model alone, and of the predicted verdict with the model's tip added."""
    lines = [
        "mode: trials, agreement on walking: predicted / model alone / predicted + model's tip"
    ]
    for mode in dict.fromkeys(r.actuators for r in found):
        mine = [r for r in found if r.actuators == mode]
        table = sum(walks(r.predicted) == walks(r.simulated) for r in mine)
        alone = sum((r.tip is None) == walks(r.simulated) for r in mine)
        added = sum((walks(r.predicted) and r.tip is None) == walks(r.simulated) for r in mine)
        lines.append(f"{mode}: {len(mine)}, {table} / {alone} / {added}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    return on_table(
        "slopewalk.bench.experiments.whole_body",
        __doc__.split("\n")[0],
        lambda sweep_file, table, mode, workers: report(
            evaluate(sweep_file, table, mode=mode, workers=workers)
        ),
        argv,
    )


if __name__ == "__main__":
    sys.exit(main())
