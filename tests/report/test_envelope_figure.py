"""envelope.png: each boundary encloses exactly the cells where its label holds, labelled."""

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


def test_each_boundary_is_drawn_around_its_cells_and_labelled():
    fig = envelope_figure(_rows())
    ax = fig.axes[0]
    labels = {t.get_text() for t in ax.texts}
    assert {"paper: ZMP inside", "MuJoCo stiff walks", "margin ≥ 5 mm"} <= labels
    assert "MuJoCo servo walks" not in labels  # servo walks no cell: no line
    drawn = [np.asarray(c.get_segments()) for c in ax.collections if isinstance(c, LineCollection)]

    def found(cells) -> bool:
        want = np.array(sorted(edges(_field(cells))))
        for segments in drawn:
            if len(segments) != len(want):
                continue
            # each line is shifted as a whole (coinciding boundaries lie side by side)
            shift = segments.reshape(-1, 2).min(axis=0) - want.reshape(-1, 2).min(axis=0)
            got = np.array(sorted(map(tuple, (segments - shift).round(9).tolist())))
            if np.allclose(got, want):
                return True
        return False

    assert found(FEASIBLE) and found(WALKS) and found({(2.0, 0.0), (1.0, 0.0)})
    assert not found({(2.0, 0.0)})


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
    ax = fig.axes[0]
    labels = {t.get_text() for t in ax.texts}
    assert {"paper: ZMP inside", "extended: ZMP inside", "MuJoCo stiff walks"} <= labels
    assert "extended: MuJoCo stiff walks" in labels
    sizes = {len(c.get_segments()) for c in ax.collections if isinstance(c, LineCollection)}
    for cells in (FEASIBLE, EXTENDED_FEASIBLE, WALKS, EXTENDED_WALKS):
        assert len(edges(_field(cells))) in sizes
    _, _, g = grids(_two_families(), "extended")
    np.testing.assert_array_equal(g["feasible"], _field(EXTENDED_FEASIBLE))
    np.testing.assert_array_equal(g["walks_stiff"], _field(EXTENDED_WALKS))
