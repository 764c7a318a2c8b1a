"""The CI comparison flags flipped verdicts and grown distances, and nothing else."""

from bench.experiments.compare import TOLERANCE_FRACTION, TOLERANCE_MM, check, report


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
    assert check([_row("a")], None) == []
