"""Support polygon and margins against scipy's convex hull and hand-derived cases."""

import numpy as np
from scipy.spatial import ConvexHull
from scipy.spatial.distance import cdist

from slopewalk.planner.zmp import foot_corners, friction_ratio, signed_margin, support_polygon


def test_margin_of_a_square():
    square = np.array([[[1.0, -1.0], [1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0]]] * 4)
    points = np.array([[0.0, 0.0], [0.5, 0.2], [3.0, 0.0], [2.0, 2.0]])
    np.testing.assert_allclose(
        signed_margin(points, square), [1.0, 0.5, -2.0, -np.sqrt(2)], atol=1e-15
    )


def test_double_support_polygon_is_the_convex_hull():
    """Hull of two translated soles equals scipy's ConvexHull; margins agree."""
    rng = np.random.default_rng(3)
    n = 200
    a = rng.uniform(-0.1, 0.1, (n, 2))
    b = a + rng.uniform(-0.12, 0.12, (n, 2))
    stance, other = foot_corners(a, 0.051, 0.049, 0.03), foot_corners(b, 0.051, 0.049, 0.03)
    polygon = support_polygon(stance, other, np.ones(n, bool))
    points = a + rng.uniform(-0.15, 0.15, (n, 2))
    margin = signed_margin(points, polygon)
    for i in range(n):
        corners = np.vstack([stance[i], other[i]])
        hull = ConvexHull(corners)
        # scipy's facet equations: normal·x + offset ≤ 0 inside
        distance = -(hull.equations[:, :2] @ points[i] + hull.equations[:, 2])
        if distance.min() >= 0:
            expected = distance.min()
        else:  # outside: distance to the nearest hull edge (densely sampled)
            ring = corners[hull.vertices]
            s = np.linspace(0, 1, 2001)[:, None]
            edges = [p + s * (q - p) for p, q in zip(ring, np.roll(ring, -1, 0), strict=True)]
            expected = -cdist(points[i][None], np.vstack(edges)).min()
        np.testing.assert_allclose(margin[i], expected, atol=1e-4)
    # single support keeps just the stance sole
    single = support_polygon(stance, other, np.zeros(n, bool))
    assert np.allclose(np.unique(single.round(12), axis=1).shape[1], 4)


def test_friction_ratio():
    force = np.array([[3.0, 4.0, 10.0], [0.0, 0.0, 5.0], [1.0, 0.0, -1.0]])
    np.testing.assert_allclose(friction_ratio(force), [0.5, 0.0, np.inf])
