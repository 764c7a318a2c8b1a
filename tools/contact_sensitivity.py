"""How much MuJoCo's verdict of each trial of a sweep table depends on the soft contact's
``solref`` (issue 22): a diagnostic, not a part of the bench.

Usage, from the repository root:

    python tools/contact_sensitivity.py SWEEP.toml TABLE.csv --mode MODE [--workers N]

The scene's feet and floor use MuJoCo's default soft contact (``solref`` time constant
0.02 s, damping ratio 1; ``bench/sim/floor.py``), not a measured floor. Each trial of
TABLE (a finished sweep of SWEEP.toml, one actuator mode) is played again four times, the
plan and its commands unchanged, each time with one of the two ``solref`` values of every
geom scaled by 0.5 or 2 (``VARIANTS``; equal on the two geoms of a contact, so the
contact's is scaled). A trial *moves* where one of the four plays changes whether the
robot walks. Printed: per class of the table's predicted verdict against its simulated
one (both walk, both fail, false alarm, miss), how many move; and the predicted and the
paper's verdicts' agreement on the trials that do not move, with the 95 % Wilson
interval. The scaling is applied to the compiled model a trial plays
(``playback.build_model``'s copy), in the worker processes only.
"""

from __future__ import annotations

import multiprocessing
import sys
from collections import Counter

VARIANTS = (("time constant", 0, 0.5), ("time constant", 0, 2.0), ("damping ratio", 1, 0.5),
            ("damping ratio", 1, 2.0))  # fmt: skip  # (name, solref column, factor)
_TRIALS: dict = {}


def _scaled_builds() -> None:
    """Worker start: ``playback.build_model`` returns its copy with ``solref`` scaled by
    the job's variant (``_SCALE``)."""
    from slopewalk.bench.sim import playback

    build = playback.build_model

    def scaled(*args, **kwargs):
        model = build(*args, **kwargs)
        column, factor = _SCALE
        model.geom_solref[:, column] *= factor
        return model

    playback.build_model = scaled


_SCALE = (0, 1.0)


def _play(job: tuple) -> tuple[str, int, str]:
    """(trial id, variant index, MuJoCo's verdict) of one trial played with one variant."""
    global _SCALE
    sweep, table, mode, trial_id, variant = job
    from slopewalk.bench.experiments.repredict import table_jobs
    from slopewalk.bench.sim.trial import run_trial

    if table not in _TRIALS:
        _TRIALS[table] = {t.trial_id: t for t, _ in table_jobs(sweep, table, mode)}
    trial = _TRIALS[table][trial_id]
    _SCALE = VARIANTS[variant][1:]
    return (
        trial_id,
        variant,
        run_trial(trial.spec, trial.trial_spec(), predict=False).simulated_verdict,
    )


def main(argv: list[str]) -> None:
    from slopewalk.bench.experiments.repredict import table_jobs
    from slopewalk.bench.report.fidelity import wilson

    sweep, table = argv[0], argv[1]
    mode = argv[argv.index("--mode") + 1]
    workers = int(argv[argv.index("--workers") + 1]) if "--workers" in argv else 2
    rows = {t.trial_id: row for t, row in table_jobs(sweep, table, mode)}
    jobs = [(sweep, table, mode, i, v) for i in rows for v in range(len(VARIANTS))]
    with multiprocessing.get_context("spawn").Pool(workers, initializer=_scaled_builds) as pool:
        played = pool.map(_play, jobs, chunksize=8)
    walks = {(i, v): verdict == "stable" for i, v, verdict in played}
    moved, kept = Counter(), {"predicted": [0, 0], "paper": [0, 0]}
    kind = {(1, 1): "both walk", (0, 0): "both fail", (0, 1): "false alarm", (1, 0): "miss"}
    for i, row in rows.items():
        sim = row["simulated_verdict"] == "stable"
        pred = row["predicted_verdict"] == "stable"
        moves = any(walks[(i, v)] != sim for v in range(len(VARIANTS)))
        moved[(kind[(pred, sim)], moves)] += 1
        if not moves:
            for name, verdict in (
                ("predicted", pred),
                ("paper", row["analytic_verdict"] == "stable"),
            ):
                kept[name][0] += verdict == sim
                kept[name][1] += 1
    print(f"{table}, {mode}: {len(rows)} trials; solref scaled: "
          + ", ".join(f"{name} x{f:g}" for name, _, f in VARIANTS))  # fmt: skip
    for kind in ("both walk", "both fail", "false alarm", "miss"):
        total = moved[(kind, True)] + moved[(kind, False)]
        print(f"  {kind:12} {moved[(kind, True)]:5} of {total:5} move")
    n = kept["predicted"][1]
    print(f"  not moved: {n} of {len(rows)} ({n / len(rows):.1%})")
    for name, (ok, total) in kept.items():
        low, high = wilson(ok, total)
        print(f"  {name} verdict on them: {ok}/{total} {ok / total:.1%} [{low:.1%}, {high:.1%}]")


if __name__ == "__main__":
    main(sys.argv[1:])
