"""The planner's support polygon against the MJCF's foot boxes, and its margin against a hull.

Reference: the sole rectangle of each foot read from the compiled MuJoCo model (the
foot box's bottom face, relative to the sole site under the ankle), placed at the
plan's sole points; in double support the convex hull of both rectangles
(``scipy.spatial.ConvexHull``), and the signed distance of a point to that hull by
brute force over its edges. A heel or toe offset wired wrongly (or 2 mm off) moves
the polygon's vertices off the MJCF foot's corners.
"""

from dataclasses import replace

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from scipy.spatial import ConvexHull

from slopewalk.bench.sim.model import scene_xml
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.joints import SIDE_PREFIX
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.zmp import foot_corners, signed_margin, support_polygon


def _mjcf_sole_rectangle(spec) -> np.ndarray:
    """Corners (x, y) of each foot's sole relative to its sole site, from MuJoCo, (2, 4, 2)."""
    model = mujoco.MjModel.from_xml_string(scene_xml(spec))
    out = []
    for prefix in SIDE_PREFIX:
        geom, site = model.geom(f"{prefix}foot"), model.site(f"{prefix}sole")
        assert geom.bodyid == site.bodyid
        center = geom.pos - site.pos  # both in the foot body frame (S-aligned when flat)
        hx, hy = geom.size[:2]
        assert center[2] + 0 == pytest.approx(geom.size[2])  # the box sits on the sole
        out.append([[center[0] + sx * hx, center[1] + sy * hy] for sx, sy in _CORNERS])
    return np.array(out)


_CORNERS = ((1, -1), (1, 1), (-1, 1), (-1, -1))


def _hull_margin(point, corners) -> float:
    """Signed distance of ``point`` to the convex hull of ``corners`` (k, 2); + inside."""
    hull = ConvexHull(corners)
    vertices = corners[hull.vertices]
    edges = np.roll(vertices, -1, axis=0) - vertices
    s = np.clip(
        np.einsum("ki,ki->k", point - vertices, edges) / np.einsum("ki,ki->k", edges, edges), 0, 1
    )
    distance = np.hypot(*(vertices + s[:, None] * edges - point).T).min()
    inside = np.all(hull.equations[:, :2] @ point + hull.equations[:, 2] <= 0)
    return distance if inside else -distance


@pytest.mark.parametrize("sole_offset", [0.0, 0.013, -0.007])  # [m] outward of the ankle
def test_polygon_vertices_are_the_mjcf_sole_corners(spec, sole_offset):
    spec = replace(spec, sole_offset=sole_offset)
    walk = plan_walk(spec, GaitParams.nominal(spec, 1.0, slope=np.deg2rad(10.0)))
    rect = _mjcf_sole_rectangle(spec)
    # the twin's soles mirror each other: the left one's centre sits sole_offset at +y
    np.testing.assert_allclose(rect[0] * [1, -1], rect[1][[1, 0, 3, 2]], atol=1e-12)
    assert rect[0][:, 1].mean() == pytest.approx(sole_offset, abs=1e-12)
    stance = walk.stance[:, None, None]  # each row's stance foot picks its rectangle
    stance_feet = walk.stance_sole[:, None, :2] + np.where(stance == 0, rect[0], rect[1])
    swing_feet = walk.swing_sole[:, None, :2] + np.where(stance == 0, rect[1], rect[0])
    for k in range(0, walk.t.size, 13):
        if walk.double_support[k]:
            points = np.concatenate([stance_feet[k], swing_feet[k]])
            expected = points[ConvexHull(points).vertices]
        else:
            expected = stance_feet[k]
        got = np.unique(walk.polygon[k].round(12), axis=0)
        # every hull vertex is a polygon vertex, and every polygon vertex lies on the hull
        for v in expected:
            assert np.hypot(*(got - v).T).min() < 1e-9, (walk.t[k], v)
        hull_points = np.concatenate([expected, got])
        assert len(ConvexHull(hull_points).vertices) == len(expected)


@settings(max_examples=150, deadline=None, derandomize=True)
@given(
    offset=hnp.arrays(np.float64, 2, elements=st.floats(-0.12, 0.12)),
    point=hnp.arrays(np.float64, 2, elements=st.floats(-0.15, 0.15)),
    double=st.booleans(),
)
def test_signed_margin_is_the_distance_to_the_mjcf_hull(spec, offset, point, double):
    rect = _mjcf_sole_rectangle(spec)[0]
    stance, other = np.zeros((1, 2)), offset[None]
    heel, toe, half = spec.heel_offset, spec.ankle_to_toe, spec.foot_width / 2
    polygon = support_polygon(
        foot_corners(stance, heel, toe, half),
        foot_corners(other, heel, toe, half),
        np.array([double]),
    )
    corners = np.concatenate([rect, rect + offset]) if double else rect
    margin = signed_margin(point[None], polygon)[0]
    assert margin == pytest.approx(_hull_margin(point, corners), abs=1e-9)
