"""envelope.png: one panel per question, each outline around exactly its cells, the paper's
statements marked, names in the legend."""

import numpy as np
from matplotlib.collections import LineCollection

from slopewalk.bench.report.envelope_figure import edges, envelope_figure, grids

TIMES = (2.0, 1.0, 0.5)
SLOPES = (-10.0, 0.0, 15.0, 30.0)
FEASIBLE = {(2.0, 0.0), (2.0, 15.0), (1.0, 0.0), (1.0, 15.0), (1.0, -10.0)}
WALKS = {(2.0, 0.0), (1.0, 0.0), (0.5, 0.0)}  # MuJoCo walks a cell the analysis refuses


def _rows():
    out = []
    for t in TIMES:
        for s in SLOPES:
            ok = (t, s) in FEASIBLE
            out.append(
                {
                    "family": "paper",
                    "step_time": t,
                    "slope_deg": s,
                    "friction": 1.0,
                    "robot": "default",
                    "error": "",
                    "feasible": str(ok),
                    "maxmargin_margin_mm": 6.0 if ok else -8.0,
                    "minwork_found": str(ok and s == 0.0),
                    "required_margin_mm": 5.0,
                    "maxmargin_stiff_verdict": "stable" if (t, s) in WALKS else "fall",
                    "maxmargin_servo_verdict": "tip",
                }
            )
    return out


def _field(cells) -> np.ndarray:
    return np.array([[float((t, s) in cells) for s in SLOPES] for t in TIMES])


def test_edges_surround_the_cells():
    assert sorted(edges(np.array([[0.0, 1.0], [0.0, 0.0]]))) == sorted(
        [
            ((0.5, -0.5), (1.5, -0.5)),
            ((0.5, 0.5), (1.5, 0.5)),
            ((0.5, -0.5), (0.5, 0.5)),
            ((1.5, -0.5), (1.5, 0.5)),
        ]
    )
    assert edges(np.array([[np.nan, 0.0]])) == []
    assert len(edges(np.ones((2, 3)))) == 2 * (2 + 3)  # the outline only


def test_grids_put_each_cell_in_its_place():
    times, slopes, g = grids(_rows(), "paper")
    assert times == list(TIMES) and slopes == list(SLOPES)  # fast steps at the bottom
    np.testing.assert_array_equal(g["feasible"], _field(FEASIBLE))
    np.testing.assert_array_equal(g["walks_stiff"], _field(WALKS))
    assert not g["walks_servo"].any()
    assert g["margin"][0, 1] == 6.0 and g["margin"][2, 0] == -8.0


def _drawn(ax) -> list[np.ndarray]:
    return [np.asarray(c.get_segments()) for c in ax.collections if isinstance(c, LineCollection)]


def _found(ax, cells) -> bool:
    """Whether some outline of ``ax`` runs exactly around ``cells`` (no shift: labels are in
    the legend, never on a line)."""
    want = np.array(sorted(edges(_field(cells))))
    for segments in _drawn(ax):
        got = np.array(sorted(map(tuple, segments.round(9).tolist())))
        if got.shape == want.shape and np.allclose(got, want):
            return True
    return False


def _legend(fig) -> set[str]:
    return {t.get_text() for legend in fig.legends for t in legend.get_texts()}


def test_one_panel_per_question_each_outline_around_its_cells():
    """The margin panel outlines the feasible cells and the required-margin ones; each mode's
    panel fills the cells MuJoCo walks and outlines the feasible ones; names only in the
    legend, no text on the panels."""
    fig = envelope_figure(_rows())
    main, stiff, servo = (ax for ax in fig.axes if ax.get_title())
    assert "ZMP inside" in main.get_title() and stiff.get_title().endswith("stiff")
    assert _found(main, FEASIBLE) and _found(main, {(2.0, 0.0), (1.0, 0.0)})
    assert not _found(main, WALKS)
    walked = stiff.images[0].get_array()
    np.testing.assert_array_equal(np.asarray(walked), _field(WALKS))
    assert _found(stiff, FEASIBLE) and not np.asarray(servo.images[0].get_array()).any()
    assert not any(ax.texts for ax in fig.axes)
    legend = _legend(fig)
    assert {"paper family: a gait with the ZMP inside", "MuJoCo stiff walks (max-margin gait)",
            "paper family: a gait with margin ≥ 5 mm"} <= legend  # fmt: skip


def test_the_papers_statements_are_marked_where_the_grid_holds_them():
    """0.5 s flat and 15° at 1 s (nominal, inside) and 30° at 1 s (GA, outside) are cells of
    the grid; 0.4 s and 22.5° are not and are not drawn."""
    fig = envelope_figure(_rows())
    main = next(ax for ax in fig.axes if ax.get_title())
    points = [c for c in main.collections if not isinstance(c, LineCollection)]
    where = {tuple(np.asarray(c.get_offsets())[0]) for c in points}
    assert where == {
        (SLOPES.index(0.0), TIMES.index(0.5)),
        (SLOPES.index(15.0), TIMES.index(1.0)),
        (SLOPES.index(30.0), TIMES.index(1.0)),
    }
    faces = {tuple(np.asarray(c.get_offsets())[0]): c.get_facecolor()[0][0] for c in points}
    assert faces[(SLOPES.index(30.0), TIMES.index(1.0))] == 1.0  # open: the paper says outside
    assert faces[(SLOPES.index(0.0), TIMES.index(0.5))] == 0.0  # filled: inside
    legend = _legend(fig)
    assert "the paper: nominal gait stable at 0.5 s" in legend
    assert "the paper: no GA gait at 30° (nominal foot)" in legend
    assert "the paper: GA gait inside at 22.5°" not in legend


def test_uneven_axis_spacing_is_said():
    fig = envelope_figure(_rows())
    main = next(ax for ax in fig.axes if ax.get_title())
    assert "evenly spaced, values not" in main.get_xlabel()
    assert "evenly spaced, values not" in main.get_ylabel()


EXTENDED_FEASIBLE = FEASIBLE | {(0.5, 0.0), (0.5, 15.0), (2.0, 30.0)}
EXTENDED_WALKS = {(2.0, 0.0), (1.0, 0.0), (0.5, 0.0), (0.5, 15.0)}


def _two_families():
    rows = _rows()
    for r in list(rows):
        cell = (r["step_time"], r["slope_deg"])
        ok = cell in EXTENDED_FEASIBLE
        rows.append(
            r
            | {
                "family": "extended",
                "feasible": str(ok),
                "maxmargin_margin_mm": 7.0 if ok else -3.0,
                "maxmargin_stiff_verdict": "stable" if cell in EXTENDED_WALKS else "tip",
            }
        )
    return rows


def test_both_families_analytic_and_walking_boundaries_are_drawn():
    fig = envelope_figure(_two_families())
    main, stiff = [ax for ax in fig.axes if ax.get_title()][:2]
    assert _found(main, FEASIBLE) and _found(main, EXTENDED_FEASIBLE)
    assert _found(stiff, EXTENDED_WALKS)  # the extended family's own walks, dashed
    assert {"extended family: a gait with the ZMP inside",
            "extended family: MuJoCo walks its own gait (dashed, the mode's colour)"} <= _legend(
        fig
    )  # fmt: skip
    _, _, g = grids(_two_families(), "extended")
    np.testing.assert_array_equal(g["feasible"], _field(EXTENDED_FEASIBLE))
    np.testing.assert_array_equal(g["walks_stiff"], _field(EXTENDED_WALKS))
