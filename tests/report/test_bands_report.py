"""bands.md and boundaries.md's band lines from hand-made rows: the band, what moves it most."""

import math

from slopewalk.bench.report import bands
from slopewalk.bench.report.envelope_claims import boundaries_markdown
from slopewalk.planner.spec import load_spec


def _row(boundary, key, end, index, at, value=None, margin=1.0):
    return {
        "family": "paper",
        "boundary": boundary,
        "key": key,
        "end": end,
        "value": value,
        "low": 0.05,
        "high": 0.07,
        "unit": "m",
        "index": index,
        "at": at,
        "edge": False,
        "nominal_cell_margin_mm": margin,
        "searched": "",
    }


ROWS = [
    _row("flat", "nominal", "nominal", 7, 0.7),
    _row("flat", "geometry.foot_width", "low", 5, 0.9, 0.05, -3.0),
    _row("flat", "geometry.foot_width", "high", 8, 0.6, 0.07, 5.0),
    _row("flat", "links.pelvis.mass", "low", 7, 0.7, 0.21),
    _row("flat", "links.pelvis.mass", "high", 6, 0.8, 0.27),
    _row("up", "nominal", "nominal", 7, 25.0),
    _row("up", "geometry.foot_width", "low", 7, 25.0, 0.05),
    _row("up", "geometry.foot_width", "high", 7, 25.0, 0.07),
    _row("up", "joint_limits.ankle_pitch.upper", "low", -1, None, 1.3, -9.0),
    _row("up", "joint_limits.ankle_pitch.upper", "high", 7, 25.0, 1.5),
    _row("down", "nominal", "nominal", 1, -5.0),
    _row("down", "geometry.foot_width", "low", 1, -5.0, 0.05, 0.5),
    _row("down", "geometry.foot_width", "high", 1, -5.0, 0.07, 2.5),
    _row("down", "links.pelvis.mass", "low", 1, -5.0, 0.21, 0.9),
    _row("down", "links.pelvis.mass", "high", 1, -5.0, 0.27, 1.1),
]


def test_the_band_is_the_min_max_and_the_widest_span_moves_it_most():
    by = {s["boundary"]: s for s in bands.summaries(ROWS)}
    assert by["flat"]["band"] == (0.6, 0.9)
    assert by["flat"]["movers"] == ["geometry.foot_width"] and by["flat"]["span"] == 3
    # a spec with no cell inside: the band's lower end is "none inside"
    assert by["up"]["band"] == (None, 25.0)
    assert by["up"]["movers"] == ["joint_limits.ankle_pitch.upper"]
    assert by["down"]["band"] == (-5.0, -5.0) and by["down"]["movers"] == []
    # none moves it a cell: the margin at its cell moves most with the foot width (2 mm)
    assert by["down"]["closest"] == "geometry.foot_width"
    assert by["down"]["spread"]["geometry.foot_width"] == 2.0


def test_band_lines_say_band_and_mover():
    lines = bands.band_lines(ROWS)
    assert lines[0] == (
        "- paper, fastest flat step time inside: 0.7 s, band [0.6, 0.9] s over the spec's "
        "unknowns; moves most with geometry.foot_width (0.9 s at 0.05 m, 0.6 s at 0.07 m; "
        "margin at the nominal boundary -3.0 / +1.0 / +5.0 mm)"
    )
    assert "band [none inside, 25]°" in lines[1]
    assert lines[2].endswith(
        "band [-5, -5]° over the spec's unknowns; no value moves it a grid cell; its margin "
        "there (+1.0 mm) moves most with geometry.foot_width (+0.5 mm at 0.05 m, +2.5 mm at "
        "0.07 m)"
    )


def test_values_that_move_a_boundary_as_far_are_ordered_by_the_margin_they_move():
    rows = [
        _row("up", "nominal", "nominal", 7, 25.0, margin=1.4),
        _row("up", "a", "low", 7, 25.0, 1.0, margin=1.3),
        _row("up", "a", "high", 6, 22.5, 2.0, margin=-0.2),
        _row("up", "b", "low", 6, 22.5, 1.0, margin=-2.0),
        _row("up", "b", "high", 7, 25.0, 2.0, margin=3.0),
    ]
    (s,) = bands.summaries(rows)
    assert s["movers"] == ["b", "a"] and s["span"] == 1
    (line,) = bands.band_lines(rows)
    assert "moves most with b (22.5° at 1 m, 25° at 2 m;" in line
    assert "; as far, by less margin: a (25° at 1 m, 22.5° at 2 m;" in line


def test_the_csv_round_trips(tmp_path):
    path = bands.write_csv(ROWS, tmp_path / "bands.csv")
    back = bands.read_csv(path)
    assert [(r["index"], r["at"]) for r in back] == [(r["index"], r["at"]) for r in ROWS]
    assert bands.band_lines(back) == bands.band_lines(ROWS)


def test_the_constraints_are_stated_with_the_spec_numbers():
    text = bands.admissibility(load_spec())
    # by hand: stall 1.5 N m / kp 9.26 N m/rad; 85 mm hip width x sin 5 deg; 5 mm slip
    assert f"{1.5 / 9.26:.3f} rad" in text and "0.162 rad" in text
    assert f"{85 * math.sin(math.radians(5)):.1f} mm" in text and "7.4 mm" in text
    assert "at most μ = 1" in text and "at most 5 mm" in text


def test_boundaries_md_quotes_the_bands_or_says_where_they_are():
    from tests.report.test_envelope_claims import ROWS as ENVELOPE

    with_bands = boundaries_markdown(ENVELOPE, "e.csv", ROWS)
    assert bands.band_lines(ROWS)[0] in with_bands
    assert "0.162 rad" in with_bands
    without = boundaries_markdown(ENVELOPE, "e.csv")
    assert "`slopewalk bands` writes bands.md beside this file" in without


def test_bands_md_marks_the_values_that_move_a_boundary():
    from slopewalk.bench.experiments.envelope.config import SearchSettings

    text = bands.markdown(ROWS, source="p.toml", robot="r.toml", spec=load_spec(),
                          search=SearchSettings(), wall_s=60.0, workers=2)  # fmt: skip
    assert (
        "| paper | flat | geometry.foot_width | [0.05, 0.07] m | 0.9 s ** | 0.7 s | 0.6 s ** | "
        "-3.0 / +1.0 / +5.0 mm |"
    ) in text
    # only the end that moves the boundary is marked
    assert "| links.pelvis.mass | [0.05, 0.07] m | 0.7 s | 0.7 s | 0.8 s ** |" in text
    assert "| paper | down | geometry.foot_width | [0.05, 0.07] m | -5° | -5° | -5° | " in text
    assert "none inside" in text


def test_the_gaits_walked_are_the_nominal_and_the_top_movers_ends():
    chosen = bands.picks(ROWS)
    assert ("paper", "flat", "nominal", "nominal", math.nan, 7)[:4] == chosen[0][:4]
    assert chosen[1:3] == [
        ("paper", "flat", "geometry.foot_width", "low", 0.05, 5),
        ("paper", "flat", "geometry.foot_width", "high", 0.07, 8),
    ]
    # no cell inside at the low end: only the nominal and the high end are walked
    up = [c for c in chosen if c[1] == "up"]
    assert [c[2:4] for c in up] == [
        ("nominal", "nominal"),
        ("joint_limits.ankle_pitch.upper", "high"),
    ]
    # none moves the downhill boundary: the value that moves its margin most
    assert [c[2] for c in chosen if c[1] == "down"][1:] == ["geometry.foot_width"] * 2
    # --walk adds a value's ends after the top mover's, each at its own boundary cell, and
    # never walks the top mover twice
    walked = bands.picks(ROWS, ("links.pelvis.mass", "geometry.foot_width"))
    assert [c for c in walked if c[1] == "flat"] == chosen[:3] + [
        ("paper", "flat", "links.pelvis.mass", "low", 0.21, 7),
        ("paper", "flat", "links.pelvis.mass", "high", 0.27, 6),
    ]
    # uphill: no row of the pelvis mass, so only the foot width's ends are added
    assert [c for c in walked if c[1] == "up"] == [*up, ("paper", "up", "geometry.foot_width",
                                                      "low", 0.05, 7),
                                                   ("paper", "up", "geometry.foot_width",
                                                    "high", 0.07, 7)]  # fmt: skip
    assert len(walked) == len(chosen) + 6  # and downhill, the pelvis mass's two ends
    played = [{"family": "paper", "boundary": "flat", "key": "geometry.foot_width",
               "end": "low", "value": 0.05, "step_time": 0.9, "slope_deg": 0.0,
               "margin_mm": 3.71, "verdicts": {"stiff": "stable", "servo": "tip"}}]  # fmt: skip
    lines = bands.played_lines(played)
    assert (
        lines[-1]
        == "| paper | flat | geometry.foot_width = 0.05 | 0.9 s, 0° | +3.7 mm | stable | tip |"
    )


def test_the_convergence_paragraph_counts_flips_and_the_largest_change():
    def c(at, small, big):
        return {"family": "paper", "boundary": "up", "key": "nominal", "end": "nominal",
                "at": at, "margin_mm": small, "inside": small >= 0,
                "margin_big_mm": big, "inside_big": big >= 0}  # fmt: skip

    (line,) = bands.convergence_lines([c(25.0, 1.4, 1.5), c(30.0, -0.2, 0.3), c(22.5, 5.0, 4.0)], 4)
    assert "the 3 cells" in line and ": 1 inside / outside verdicts change" in line
    assert "largest margin change is -1.00 mm (up 22.5°, nominal nominal)" in line
    assert "nearest 0 is -0.20 mm (+0.30 mm at 4 ×; up 30°" in line
