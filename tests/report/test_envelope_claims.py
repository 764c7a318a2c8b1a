"""Claims 1 and 2 from the envelope: the fastest flat step time, the steepest slopes at 1 s."""

from slopewalk.bench.report.envelope_claims import (
    boundaries_markdown,
    envelope_cell_note,
    envelope_claims,
    walked_intervals,
)


def _row(t, s, feasible, walks):
    return {
        "family": "paper",
        "friction": 1.0,
        "robot": "default",
        "error": "",
        "step_time": t,
        "slope_deg": s,
        "feasible": str(feasible),
        "maxmargin_margin_mm": 3.0 if feasible else -4.0,
        "maxmargin_hip_height_m": 0.15,
        "maxmargin_swing_lift_m": 0.005,
        "maxmargin_tilt_deg": 10.0,
        "minwork_found": "False",
        "minwork_work_J": 1.0,
        "required_margin_mm": 5.0,
        "maxmargin_stiff_verdict": "stable" if walks else "fall",
        "maxmargin_servo_verdict": "tip",
    }


ROWS = [
    _row(1.0, 0.0, True, True),
    _row(0.7, 0.0, True, True),
    _row(0.5, 0.0, True, False),
    _row(0.4, 0.0, False, False),
    _row(1.0, -20.0, False, False),
    _row(1.0, -10.0, True, True),
    _row(1.0, 15.0, True, True),
    _row(1.0, 22.5, True, False),
    _row(1.0, 25.0, False, True),
    {**_row(0.3, 0.0, True, True), "family": "extended"},  # another family: not the paper's
]


def test_claim_1_is_the_fastest_flat_step_time_with_a_gait_inside():
    first = envelope_claims(ROWS, "envelope/envelope.csv")[0]
    assert "fastest t_c with a gait inside: 0.5 s" in first["analytic"]
    assert "at 0.4 s: largest margin -4.0 mm" in first["analytic"]
    assert "stiff: fastest walked 0.7 s" in first["simulated"]
    assert "that gait in MuJoCo: stiff fall, servo tip" in first["simulated"]
    assert first["agree"] == "analytic yes, simulated no (stiff)"
    assert first["evidence"] == "envelope.png, envelope/envelope.csv (slope 0)"


def test_claim_2_is_the_steepest_slopes_at_1_s():
    second = envelope_claims(ROWS, "e.csv")[1]
    assert second["analytic"].startswith(
        "steepest uphill with the ZMP inside: 22.5°; steepest downhill: -10°"
    )
    assert "stiff: walks -10° … 25° (4 of 6 slopes)" in second["simulated"]
    assert second["agree"] == "analytic -, simulated - (stiff)"  # no 30° cell: cannot say


def test_the_slope_row_compares_ga_with_the_papers_ga():
    """The paper's GA: a gait inside at 22.5°, none at 30° (its 15° is the nominal gait's):
    with a 30° cell infeasible the envelope bears it out; without one it cannot say."""
    rows = [*ROWS, _row(1.0, 30.0, False, False)]
    second = envelope_claims(rows, "e.csv")[1]
    assert "a gait inside at 22.5° after re-optimising, none at 30°" in second["paper"]
    assert second["agree"] == "analytic yes, simulated no (stiff)"  # 22.5° is not walked
    walked = [
        {**r, "maxmargin_stiff_verdict": "stable"} if r["slope_deg"] == 22.5 else r for r in rows
    ]
    assert envelope_claims(walked, "e.csv")[1]["agree"] == "analytic yes, simulated yes (stiff)"
    assert "downhill: the gait family's shape" in second["basis"]


def test_the_ga_rows_cite_the_envelope_cell():
    note = envelope_cell_note(ROWS, 22.5, "e.csv")
    assert note.startswith("; envelope cell t_c 1 s, 22.5° (e.csv): feasible, largest margin 3.0")
    assert "no gait with margin ≥ 5 mm found; MuJoCo: stiff fall, servo tip" in note
    assert envelope_cell_note(ROWS, 30.0, "e.csv") == ""


def test_boundaries_are_given_per_family():
    from slopewalk.bench.report.envelope_claims import boundaries_markdown, family_boundaries

    extended = [
        {**_row(0.3, 0.0, True, False), "family": "extended"},
        {**_row(1.0, 30.0, True, True), "family": "extended"},
        {**_row(1.0, -30.0, True, False), "family": "extended"},
        {**_row(1.0, -20.0, False, True), "family": "extended"},
    ]
    b = family_boundaries(ROWS[:-1] + extended)
    assert list(b) == ["paper", "extended"]
    paper, wide = b["paper"], b["extended"]
    assert (paper["flat_inside"], paper["flat_walked"]) == (0.5, {"stiff": 0.7, "servo": None})
    assert (paper["up_inside"], paper["down_inside"]) == (22.5, -10.0)
    assert paper["up_walked"]["stiff"] == 25.0 and paper["down_walked"]["stiff"] == -10.0
    assert (wide["flat_inside"], wide["flat_walked"]["stiff"]) == (0.3, None)
    assert (wide["up_inside"], wide["down_inside"]) == (30.0, -30.0)
    assert wide["down_walked"]["stiff"] == -20.0  # walked, though its ZMP leaves the polygon
    text = boundaries_markdown(ROWS[:-1] + extended, "e.csv")
    assert "| paper | 0.5 s | stiff 0.7 s, servo none | 22.5° | -10° |" in text
    assert "| extended | 0.3 s (grid edge) | stiff none, servo none | 30° (grid edge) | " in text
    assert b["paper"]["edges"] == {"flat": 0.4, "up": 25.0, "down": -20.0}


def test_walked_intervals_break_at_a_grid_value_that_is_not_walked():
    """Slopes -5, 0, 5, 10, 15 at 1 s, walked at -5, 5, 10 and 15: two runs, not 'up to 15'."""
    rows = [_row(1.0, s, True, s != 0.0) for s in (-5.0, 0.0, 5.0, 10.0, 15.0)]
    assert walked_intervals(rows, "slope_deg", "stiff") == [(-5.0, -5.0), (5.0, 15.0)]
    assert walked_intervals(rows, "slope_deg", "servo") == []  # servo tips everywhere
    text = boundaries_markdown(rows, "e.toml")
    assert "| paper | stiff | -5° to -5°" not in text
    assert "| paper | stiff | -5°, 5° to 15° |" in text
    assert "| paper | servo | none |" in text
