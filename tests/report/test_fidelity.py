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
        "tracking_rms_deg": 0.3, "unplanned_support_s": 0.1, "swing_touch_s": 0.0,
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
    # a tip whose rocking stays under the tip angle is a sole the servos stand on its
    # edge: landed tilted past it, or turned past it from the other in double support
    # (planner.verdict.landing_events, double_support_events)
    # predicted swing_drag, walked: explained only when MuJoCo's swing foot did stay on the
    # plane through a single support (0.5 s, not the floor's early touch of 0.05 s)
    drag = _row("stable", "swing_drag", "stable", swing_touch_s=0.5)
    assert cause_class(drag) == "a dragged swing sole the robot walked over"
    assert cause_class(drag | {"swing_touch_s": 0.05}) == "unexplained"
    assert cause_class(drag | {"swing_touch_s": float("nan")}) == "unexplained"
    assert cause_class(drag | {"simulated_verdict": "slip"}) != (
        "a dragged swing sole the robot walked over"
    )
    landed = over | {"predicted_rotation_deg": 1.2, "simulated_max_tilt_deg": 4.2}
    assert cause_class(landed) == "a sole on its edge in the prediction only"
    assert cause_class(landed | {"predicted_rotation_deg": 5.1}) == (
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


def test_the_wilson_interval_matches_the_hand_worked_one():
    """0/10 and 10/10: (z²/2n ± z²/2n) / (1 + z²/n) with z = 1.96, i.e. [0, 0.2775] and
    [0.7225, 1]; 5/10: 0.5 ± 1.96 sqrt(0.25/10 + 3.8415/400) / 1.38415 = [0.2366, 0.7634]."""
    from slopewalk.bench.report.fidelity import wilson

    assert wilson(0, 10) == pytest.approx((0.0, 0.27753), abs=1e-5)
    assert wilson(10, 10) == pytest.approx((0.72247, 1.0), abs=1e-5)
    assert wilson(5, 10) == pytest.approx((0.23659, 0.76341), abs=1e-5)


def test_held_out_tables_are_reported_apart_with_intervals_by_mode():
    dev = [_row("stable", "stable", "stable"), _row("stable", "stable", "fall", actuators="servo")]
    held = [_row("zmp_outside", "tip", "fall", gait="paper draw 0", hip_height_m=0.18,
                 swing_lift_m=0.005, tilt_deg=10.0, pelvis_offset_m=0.0, step_length_m=0.111,
                 sway_share=0.0)] * 10  # fmt: skip
    text = fidelity_report({"runs/dense/sweep.csv": dev}, held_out={"runs/random/sweep.csv": held})
    assert "| dense | development | servo | 0/1 0.0% [0.0%, 79.3%] |" in text
    # hedged: both rows' models agree (stable, stable): decided, 1 of 2 right, none uncertain
    assert "| 1/2 50.0% [9.5%, 90.5%]; uncertain 0/2 0.0% |" in text
    assert "| dense | development | all | 1/2 50.0% [9.5%, 90.5%] |" in text
    assert "| random | held out | stiff | 10/10 100.0% [72.2%, 100.0%] |" in text
    assert text.index("# Held out") < text.index("## runs/random/sweep.csv")


def test_a_planned_foot_slide_the_robot_walks_through_has_its_class():
    from slopewalk.bench.report.fidelity import cause_class

    slid = _row("stable", "foot_slide", "stable", simulated_max_tilt_deg=0.4)
    assert cause_class(slid) == "foot slide in the plan only"
    # a predicted rocking tip on a sole that hardly turned (0.4°) is no foot slide, and
    # unexplained
    rocked = {"predicted_verdict": "tip", "predicted_rotation_deg": 6.0}
    assert cause_class(slid | rocked) == "unexplained"


def test_a_ring_the_robot_walks_through_has_its_class():
    from slopewalk.bench.report.fidelity import cause_class

    rode = _row("stable", "ring", "stable", actuators="servo", compliant_min_margin_mm=-2.0)
    assert cause_class(rode) == "ring the robot rode out"
    assert cause_class(rode | {"simulated_verdict": "fall"}) == "unexplained"  # no miss


def test_the_hedged_verdict_is_uncertain_where_the_two_models_disagree():
    from slopewalk.bench.report.fidelity import hedged, hedged_agreement

    rows = [
        _row("stable", "stable", "stable"),  # both say walks: decided, right
        _row("stable", "tip", "stable") | {"compliant_verdict": "stable"},  # models part
        _row("zmp_outside", "tip", "stable"),  # both say falls: decided, wrong
        _row("zmp_outside", "stable", "fall"),  # compliant zmp_outside, predicted stable
    ]
    assert [hedged(r) for r in rows] == ["stable", "uncertain", "tip", "uncertain"]
    assert hedged_agreement(rows) == (1, 2, 2)
