"""CI's out-of-sample fidelity check (issue 22): 40 random gaits played again.

``bench/experiments/sweeps/ci.toml`` draws 40 gaits with a seed of its own (never the
reported sets', never one a predictor change was designed on). The committed table
``results/fidelity/ci/sweep.csv`` (``slopewalk regenerate``) holds its verdicts; this test
plays the set again and fails when the predicted verdict's agreement with MuJoCo falls
below the committed agreement's 95 % Wilson interval. Slow (about a minute on 2 cores);
.ci/run runs it.
"""

from pathlib import Path

import pytest

from slopewalk.bench.experiments.sweep.config import SWEEPS_DIR, load_sweep
from slopewalk.bench.experiments.sweep.run import run_sweep
from slopewalk.bench.report.fidelity import VERDICTS, agreement, wilson
from slopewalk.bench.tables.table import read_table

ROOT = Path(__file__).resolve().parents[2]
COMMITTED = ROOT / "results/fidelity/ci/sweep.csv"


@pytest.mark.slow
def test_the_out_of_sample_set_agrees_as_committed(tmp_path):
    committed = read_table(COMMITTED)
    config = load_sweep(SWEEPS_DIR / "ci.toml")
    assert {t.trial_id for t in config.trials} == {r["trial_id"] for r in committed}
    summary = run_sweep(config, tmp_path, workers=2, quiet=True)
    fresh = read_table(summary.table)
    for verdict in VERDICTS:
        k, n = agreement(committed, verdict)
        low, _ = wilson(k, n)
        got, total = agreement(fresh, verdict)
        print(f"{verdict}: committed {k}/{n} (95 % from {low:.1%}), now {got}/{total}")
        assert total == n, "trials raised now that did not when the table was committed"
        assert got / total >= low, (
            f"{verdict} verdict agrees with MuJoCo in {got}/{total} of CI's out-of-sample "
            f"gaits, below the committed {k}/{n}'s 95 % interval (from {low:.1%})"
        )
