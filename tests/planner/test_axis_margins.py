"""Per-axis ZMP margins (``zmp.axis_margins``) on polygons whose chords are derived by hand."""

import numpy as np
import pytest

from slopewalk.planner.zmp import axis_margins, foot_corners, signed_margin


def _one(point, polygon):
    s, lat = axis_margins(np.array([point]), np.array([polygon]))
    return float(s[0]), float(lat[0])


def test_a_sole_rectangle():
    """Heel 51 mm behind the ankle, toe 49 mm ahead, 60 mm wide: the chords are the sides."""
    sole = foot_corners(np.array([[0.0, 0.0]]), 0.051, 0.049, 0.03)[0]
    assert _one((0.01, 0.02), sole) == pytest.approx((0.039, 0.01))  # inside: nearer ends
    assert _one((0.06, 0.0), sole) == pytest.approx((-0.011, 0.03))  # 11 mm past the toe
    # 10 mm beyond the left edge: laterally −10 mm; along x the chord at the nearest y (the
    # left edge itself) still holds it 20 mm from the toe
    assert _one((0.029, 0.04), sole) == pytest.approx((0.02, -0.01))


def test_the_hull_of_two_offset_feet():
    """Double support: feet x 0..0.1, y 0..0.06 and x 0.1..0.2, y 0.08..0.14. The hull's slanted
    edges (0.1, 0) -> (0.2, 0.08) and (0, 0.06) -> (0.1, 0.14) cut the line y = 0.07 at
    x = 0.1 + 0.1 · 0.07 / 0.08 = 0.1875 and x = 0.1 · 0.01 / 0.08 = 0.0125; the line x = 0.1
    meets the bottom at y = 0 and the top at y = 0.14."""
    hull = np.array([[0.0, 0.0], [0.1, 0.0], [0.2, 0.08], [0.2, 0.14], [0.1, 0.14], [0.0, 0.06]])
    sagittal, lateral = _one((0.1, 0.07), hull)
    assert sagittal == pytest.approx(min(0.1 - 0.0125, 0.1875 - 0.1))
    assert lateral == pytest.approx(0.07)
    # the Euclidean margin is never more than either axis's inside the polygon
    assert signed_margin(np.array([[0.1, 0.07]]), hull[None])[0] <= min(sagittal, lateral)
    # beyond the slanted edge along x only: (0.19, 0.07) is 2.5 mm past x = 0.1875
    assert _one((0.19, 0.07), hull)[0] == pytest.approx(-0.0025)


def test_repeated_vertices_and_nan_points():
    """A polygon padded with repeats (as the plan's 8-vertex rows are) gives the same chords; a
    NaN point gives NaN."""
    sole = foot_corners(np.array([[0.0, 0.0]]), 0.05, 0.05, 0.03)[0]
    padded = np.concatenate([sole, sole[-1:].repeat(4, axis=0)])
    assert _one((0.01, -0.02), padded) == pytest.approx((0.04, 0.01))
    s, lat = axis_margins(np.array([[np.nan, 0.0]]), padded[None])
    assert np.isnan(s[0]) and np.isnan(lat[0])
