"""The open-loop vs controllers comparison: real trials, counted and reported."""

from pathlib import Path

from slopewalk.bench.experiments.controller_comparison import OPEN_LOOP, compare_controllers, report
from slopewalk.bench.experiments.sweep.config import sweep_from_dict

OPEN_LOOP_POLICY = "slopewalk.bench.sim.env:open_loop"


def test_the_table_counts_walks_and_the_open_loop_policy_changes_none():
    """2 s walks (stable, walked: at 1 s the stiff knee overloads the servo) and a 0.4 s one
    (falls); the plan as a controller matches open loop."""
    config = sweep_from_dict({"steps": 1, "grid": {"step_time": [2.0, 0.4]}}, base_dir=Path("."))
    table = compare_controllers(config, (OPEN_LOOP_POLICY,), workers=1)
    assert [r["verdict"] for r in table[OPEN_LOOP]] == [
        r["verdict"] for r in table[OPEN_LOOP_POLICY]
    ]
    assert table[OPEN_LOOP][0]["verdict"] == "stable"
    assert table[OPEN_LOOP][0]["walk"] == "walked"
    assert table[OPEN_LOOP][1]["verdict"] != "stable"
    text = report(table, source="s.toml", command="slopewalk controllers s.toml --out c.md")
    assert f"| {OPEN_LOOP} | 1 / 2 | 0: - | 0: - |" in text
    assert f"| {OPEN_LOOP_POLICY} | 1 / 2 | 0: - | 0: - |" in text
    assert "Regenerate with `slopewalk controllers s.toml --out c.md`" in text
