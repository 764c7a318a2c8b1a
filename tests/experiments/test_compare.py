"""The CI comparison flags flipped verdicts and grown distances, and nothing else."""

import json

import pytest

from slopewalk.bench.experiments.compare import (
    CASES,
    TOLERANCE_FRACTION,
    TOLERANCE_MM,
    CompareError,
    check,
    load_baseline,
    report,
)


def _row(case, analytic="stable", simulated="stable", rms=5.0):
    return {
        "case": case,
        "analytic_verdict": analytic,
        "simulated_verdict": simulated,
        "zmp_rms_mm": rms,
        "zmp_max_mm": 3 * rms,
        "standing_fraction": 1.0,
        "events": [],
    }


def test_unchanged_run_passes():
    rows = [_row("a"), _row("b", "zmp_outside", "fall", 60.0)]
    assert check(rows, rows) == []
    assert "Result: pass" in report(rows, rows, [])


def test_flipped_verdict_fails():
    problems = check([_row("a", simulated="fall")], [_row("a")])
    assert problems == ["a: simulated_verdict flipped stable -> fall"]


def test_distance_may_grow_only_within_tolerance():
    limit = 5.0 * (1 + TOLERANCE_FRACTION) + TOLERANCE_MM
    assert check([_row("a", rms=limit - 1e-6)], [_row("a")]) == []
    assert len(check([_row("a", rms=limit + 1e-3)], [_row("a")])) == 1
    assert check([_row("a", rms=0.1)], [_row("a")]) == []  # improving is fine


def test_no_baseline_checks_nothing():
    """Only for --write-baseline: the CLI refuses a missing baseline (load_baseline)."""
    assert check([_row("a")], None) == []


def test_a_case_missing_from_the_baseline_is_a_problem():
    assert check([_row("a"), _row("b")], [_row("a")]) == [
        "b: not in the baseline (refresh it: --write-baseline)"
    ]


@pytest.mark.parametrize(
    "content, message",
    [
        (None, "no such file"),
        ("", "is empty"),
        ("  \n", "is empty"),
        ("[]", "must be a non-empty list"),
        ("{}", "must be a non-empty list"),
        ("[{", "not valid JSON"),
        ('[{"case": "flat 2 s"}]', "row 0 lacks analytic_verdict"),
        (json.dumps([_row("flat 2 s", rms="5")]), "zmp_rms_mm '5': not a number"),
        (json.dumps([_row("another robot's case")]), "covers none of the cases"),
    ],
)
def test_a_missing_empty_or_foreign_baseline_is_refused(tmp_path, content, message):
    path = tmp_path / "baseline.json"
    if content is not None:
        path.write_text(content)
    with pytest.raises(CompareError, match=message):
        load_baseline(path)


def test_the_committed_baseline_loads():
    from pathlib import Path

    rows = load_baseline(Path(__file__).parents[2] / "results" / "compare_baseline.json")
    assert {row["case"] for row in rows} == {name for name, _, _ in CASES}
