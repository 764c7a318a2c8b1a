"""Fidelity report: agreement counts, both confusion tables, a cause for every disagreement."""

import subprocess
import sys

import pytest

from slopewalk.bench.report.fidelity import FidelityError, fidelity_report


def _row(paper, predicted, simulated, **extra):
    row = {
        "step_time": 1.0, "slope_deg": 0.0, "friction": 1.0, "actuators": "stiff",
        "mass_scale": "", "analytic_verdict": paper, "compliant_verdict": paper,
        "predicted_verdict": predicted, "predicted_events": "" if predicted == "stable"
        else predicted, "simulated_verdict": simulated, "events": "" if simulated == "stable"
        else simulated, "first_event_time_s": float("nan") if simulated == "stable" else 0.8,
        "analytic_min_margin_mm": -3.0, "compliant_min_margin_mm": -3.2,
        "predicted_rotation_deg": 1.5, "simulated_max_tilt_deg": 5.4,
        "tracking_rms_deg": 0.3, "unplanned_support_s": 0.1,
        "zmp_rms_mm": 4.0, "zmp_max_mm": 40.0,
    }  # fmt: skip
    return row | extra


def test_agreement_counts_walks_against_does_not():
    rows = [
        _row("zmp_outside", "stable", "stable"),  # paper wrong, predicted right
        _row("zmp_outside", "tip", "fall"),  # both right (kinds differ, both "does not walk")
        _row("stable", "stable", "tip"),  # both wrong
        _row("stable", "stable", "stable"),
    ]
    text = fidelity_report({"t.csv": rows})
    assert "| paper | 2/4 | 50.0% |" in text
    assert "| predicted | 3/4 | 75.0% |" in text
    assert "### Disagreements of the predicted verdict (1)" in text
    assert "predicted stable, simulated tip (tip, first at 0.80 s)" in text
    assert "predicted support tilt 1.50°, simulated 5.40°" in text  # measured, quoted
    assert "**rocking short of the tip angle**: predicted stable, simulated tip" in text


def test_each_disagreement_gets_its_class():
    from slopewalk.bench.report.fidelity import cause_class

    sway = _row("stable", "stable", "fall", actuators="servo", compliant_min_margin_mm=3.3)
    assert cause_class(sway) == "servo sway"
    short = _row("zmp_outside", "stable", "tip", predicted_rotation_deg=3.9)
    assert cause_class(short) == "rocking short of the tip angle"
    # a slip, not a tip: it is the rocking sole's measured tilt that explains it
    slid = short | {"simulated_verdict": "slip", "events": "slip"}
    assert cause_class(slid | {"simulated_max_tilt_deg": 4.5}) == "slip of a rocking sole"
    assert cause_class(slid | {"simulated_max_tilt_deg": 0.5}) != "slip of a rocking sole"
    inside = _row(
        "stable", "stable", "tip", analytic_min_margin_mm=2.0, compliant_min_margin_mm=1.0,
        predicted_rotation_deg=0.4,
    )  # fmt: skip
    assert cause_class(inside) == "unexplained"
    # predicted tip, walked: explained only when MuJoCo's support did rock (4.2°, not
    # the floor's give of a few tenths)
    over = _row("zmp_outside", "tip", "stable", predicted_rotation_deg=6.9)
    assert cause_class(over | {"simulated_max_tilt_deg": 4.2}) == (
        "rocking past the tip angle in the prediction only"
    )
    assert cause_class(over | {"simulated_max_tilt_deg": 0.3}) == "unexplained"
    assert cause_class(over | {"simulated_verdict": "fall"}) != (
        "rocking past the tip angle in the prediction only"
    )


def test_the_goals_are_reported_where_the_table_has_their_cells():
    rows = [
        _row("stable", "stable", "stable", step_time=2.0, zmp_rms_mm=5.5),
        _row("stable", "stable", "tip", actuators="servo_ff", analytic_min_margin_mm=5.7),
    ]
    text = fidelity_report({"t.csv": rows})
    assert "- stiff, μ 1: RMS 5.50 mm" in text
    assert "servo_ff on the cells whose plan keeps ≥ 5 mm margin" in text and ": 0/1 walk" in text


def test_a_table_of_an_older_version_is_refused():
    row = _row("stable", "stable", "stable")
    del row["predicted_verdict"]
    with pytest.raises(FidelityError, match="no column predicted_verdict"):
        fidelity_report({"old.csv": [row]})


def test_cli_refuses_a_missing_table_in_one_line(tmp_path):
    out = tmp_path / "f.md"
    command = ["fidelity", str(tmp_path / "no.csv"), "--out", str(out)]
    run = subprocess.run(
        [sys.executable, "-m", "slopewalk.bench.cli", *command], capture_output=True, text=True
    )
    assert run.returncode == 2
    assert run.stderr.strip().count("\n") == 0 and "no such file" in run.stderr
    assert not out.exists()
