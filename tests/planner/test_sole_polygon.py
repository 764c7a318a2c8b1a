"""The sole polygon (``geometry.sole_polygon``): its checks, the support polygon and ZMP
margin it gives in the numpy pipeline and in the compiled kernel, against hand-derived
margins and against scipy's convex hull of both soles placed independently (the right
sole as the left one's mirror, not as a translate)."""

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.spatial import ConvexHull

from slopewalk.planner.errors import SpecError
from slopewalk.planner.kernel import sample as sm
from slopewalk.planner.kernel.tables import ChainTable
from slopewalk.planner.sole import edge_normals, outline
from slopewalk.planner.spec import default_spec_path, load_spec
from slopewalk.planner.zmp import signed_margin, sole_vertices, support_polygon

B = sm.B
# a hexagon inside the default spec's rectangle (x in [−0.051, 0.049], y in [−0.03, 0.03])
HEXAGON = ((0.04, -0.02), (0.04, 0.02), (0.0, 0.03), (-0.04, 0.02), (-0.04, -0.02), (0.0, -0.03))


def _spec(polygon, offset=0.0):
    return replace(load_spec(), sole_offset=offset, sole_polygon=polygon)


def _numpy_margin(spec, side, stance, swing, zmp, double):
    """Support polygon and margin of the numpy pipeline (reference.py's calls)."""
    sole = outline(spec)
    polygon = support_polygon(
        sole_vertices(stance, sole, spec.sole_shift(side)),
        sole_vertices(swing, sole, spec.sole_shift(1 - side)),
        np.full(len(stance), double),
        edge_normals(sole),
    )
    return polygon, signed_margin(zmp, polygon)


def _kernel_margin(spec, side, stance, swing, zmp, double):
    """``sample._margin`` of the compiled kernel on a scratch holding these samples."""
    n = len(stance)
    assert n <= B
    w = np.zeros(sm.SCRATCH)
    for row, values in (
        (sm._XS, stance[:, 0]), (sm._YS, stance[:, 1]), (sm._SIDE, side),
        (sm._SW, swing[:, 0]), (sm._SW + B, swing[:, 1]),
        (sm._ZX, zmp[:, 0]), (sm._ZY, zmp[:, 1]),
    ):  # fmt: skip
        w[row : row + n] = values
    sm._margin(ChainTable.of(spec).geometry, double, n, w)
    count = 4 * len(outline(spec))
    polygon = np.stack([w[sm._VERT + k * B : sm._VERT + k * B + n] for k in range(count)], 1)
    return polygon.reshape(n, -1, 2), w[sm._MARGIN : sm._MARGIN + n].copy()


def _both(spec, side, stance, swing, zmp, double):
    """The numpy and kernel margins, which must be equal; returns the numpy one.

    The polygons must be the same set: each one's vertices in the other to 1e-15 m. (Their
    vertex lists can differ where the feet's offset d is parallel to an edge to within
    rounding: numpy takes d from the placed corners, the kernel from the sole points.)"""
    poly, margin = _numpy_margin(spec, side, stance, swing, zmp, double)
    kpoly, kmargin = _kernel_margin(spec, side, stance, swing, zmp, double)
    for a, b in ((poly, kpoly), (kpoly, poly)):
        count = a.shape[1]
        inside = signed_margin(a.reshape(-1, 2), np.repeat(b, count, axis=0))
        assert inside.min() >= -1e-15
    np.testing.assert_allclose(kmargin, margin, rtol=0, atol=1e-15)
    return margin


@pytest.mark.parametrize(
    ("polygon", "words"),
    [
        (((0.04, -0.02), (0.0, 0.03), (0.04, 0.02)), "clockwise"),
        (((0.04, -0.02), (0.04, 0.02)), "has 2 vertices"),
        (tuple((0.01 * k, 0.0) for k in range(9)), "has 9 vertices"),
        (((0.04, -0.02), (0.04, 0.02), (0.03, 0.0), (-0.05, 0.02), (-0.05, -0.02)), "convex"),
        (((0.06, -0.02), (0.06, 0.02), (-0.05, 0.0)), "must lie in the sole rectangle"),
        (((0.04, -0.02), (0.04, 0.025), (-0.05, 0.0)), "symmetric"),
        (((0.04, float("nan")), (0.04, 0.02), (-0.05, 0.0)), "finite"),
        (((0.04, -0.02), "a", (-0.05, 0.0)), "pair"),
        (((0.04, 0.0), (-0.03, 0.02), (-0.03, -0.02)) * 2, "convex"),  # wound twice
    ],
)
def test_a_bad_sole_polygon_is_refused_in_one_line(polygon, words):
    with pytest.raises(SpecError, match=words) as err:
        _spec(polygon)
    assert "\n" not in str(err.value) and "geometry.sole_polygon" in str(err.value)


def test_the_polygon_must_be_symmetric_about_the_offset_sole_line():
    """With a sole offset the centre line moves: a hexagon about y = 0.01 is accepted
    with sole_offset 0.01, the same hexagon about y = 0.005 (inside the rectangle) is not."""
    shifted = tuple((x, y / 2 + 0.01) for x, y in HEXAGON)
    assert _spec(shifted, offset=0.01).sole_polygon == shifted
    with pytest.raises(SpecError, match="symmetric"):
        _spec(tuple((x, y / 2 + 0.005) for x, y in HEXAGON), offset=0.01)


def test_a_spec_without_a_polygon_writes_and_reads_as_before(tmp_path):
    """The default spec's dict has no sole_polygon; one with it reads back equal from TOML."""
    assert "sole_polygon" not in load_spec().as_dict()
    rows = ", ".join(f"[{x!r}, {y!r}]" for x, y in HEXAGON)
    source = default_spec_path().read_text()
    toml = tmp_path / "hex.toml"
    toml.write_text(source.replace("[geometry]", f"[geometry]\nsole_polygon = [{rows}]", 1))
    assert load_spec(toml) == _spec(HEXAGON)


def test_hand_derived_margins_of_a_hexagon_sole():
    """Single support on the hexagon, the left foot's sole point at (0.1, 0.2):
    (0, 0.025) from it lies 5 mm below the slanted edges' lines y = 0.03 ∓ 0.25 x, a
    distance 0.005/√1.0625 (the toe and heel edges are 40 mm away); (0.06, 0) is 20 mm
    beyond the toe edge x = 0.04; (0, 0.04) is 10 mm beyond the vertex (0, 0.03), inside
    both slanted edges' normal cones. On the right foot the mirror points give the same."""
    spec = _spec(HEXAGON)
    point = np.array([[0.1, 0.2]] * 3)
    rel = np.array([[0.0, 0.025], [0.06, 0.0], [0.0, 0.04]])
    expected = [0.005 / np.sqrt(1.0625), -0.02, -0.01]
    for side, sign in ((0.0, 1.0), (1.0, -1.0)):
        zmp = point + rel * [1.0, sign]
        margin = _both(spec, np.full(3, side), point, point + [0.0, -0.1], zmp, False)
        np.testing.assert_allclose(margin, expected, rtol=0, atol=1e-15)


def test_hand_derived_margin_of_a_triangle_in_double_support():
    """A triangle sole (0.04, 0), (−0.05, ±0.03), the other foot 0.08 ahead: the hull is
    (0.12, 0), (0.03, 0.03), (−0.05, 0.03), (−0.05, −0.03), (0.03, −0.03). The point
    (0.04, 0) is 30 mm from the side edges y = ±0.03, 90 mm from the heel edge and
    0.08·0.03/√(0.09² + 0.03²) = 25.3 mm from the slanted front edges: the margin."""
    spec = _spec(((0.04, 0.0), (-0.05, 0.03), (-0.05, -0.03)))
    stance = np.array([[0.0, 0.0]])
    margin = _both(spec, np.zeros(1), stance, stance + [0.08, 0.0], np.array([[0.04, 0.0]]), True)
    front = 0.08 * 0.03 / np.hypot(0.09, 0.03)  # (0.04, 0) to the line (0.12, 0)–(0.03, 0.03)
    np.testing.assert_allclose(margin, [front], rtol=0, atol=1e-15)


def test_the_rectangle_as_a_polygon_gives_the_rectangles_margins():
    """The default rectangle named as a sole_polygon: the kernel's general path (no closed
    form) and the numpy pipeline equal the default spec's margins to 1e-15 m."""
    base = load_spec()
    h, t, w = base.heel_offset, base.ankle_to_toe, base.foot_width / 2
    named = _spec(((t, -w), (t, w), (-h, w), (-h, -w)))
    rng = np.random.default_rng(7)
    stance = rng.uniform(-0.1, 0.1, (64, 2))
    swing = stance + rng.uniform(-0.12, 0.12, (64, 2))
    zmp = stance + rng.uniform(-0.15, 0.15, (64, 2))
    side = (rng.random(64) < 0.5).astype(float)
    for double in (False, True):
        expected = _both(base, side, stance, swing, zmp, double)
        np.testing.assert_allclose(
            _both(named, side, stance, swing, zmp, double), expected, rtol=0, atol=1e-15
        )


def _independent_margin(polygon, offset, side, stance, swing, zmp, double):
    """Margin from scipy's hull of the soles, the right sole the left's mirror in y."""
    left = np.array(polygon)
    feet = [(stance, side)] + ([(swing, 1 - side)] if double else [])
    corners = np.vstack([point + left * [1.0, 1.0 - 2.0 * s] for point, s in feet])
    hull = ConvexHull(corners)
    inside = -(hull.equations[:, :2] @ zmp + hull.equations[:, 2])
    if inside.min() >= 0:
        return inside.min()
    ring = corners[hull.vertices]
    a, e = ring, np.roll(ring, -1, axis=0) - ring
    u = np.clip(np.einsum("ij,ij->i", zmp - a, e) / np.einsum("ij,ij->i", e, e), 0.0, 1.0)
    return -np.hypot(*(zmp - a - u[:, None] * e).T).min()


_coord = st.floats(-1.0, 1.0)


@settings(max_examples=150, deadline=None)
@given(
    points=st.lists(st.tuples(_coord, _coord), min_size=3, max_size=3),
    axis=st.floats(-1.0, 1.0),
    offset=st.floats(-0.4, 0.4),
    feet=st.lists(st.floats(-0.12, 0.12), min_size=6, max_size=6),
    side=st.sampled_from([0.0, 1.0]),
    double=st.booleans(),
)
def test_sampled_polygons_and_points_against_scipys_hull(points, axis, offset, feet, side, double):
    """Random symmetric convex soles (the hull of three points, their mirrors about the
    sole line and a point on it), random feet and ZMPs: numpy = kernel (1e-15 m), and
    both = the half-plane / segment distances to scipy's hull of the placed soles (1e-12)."""
    base = load_spec()
    h, t, w = base.heel_offset, base.ankle_to_toe, base.foot_width / 2
    s = offset * w  # the sole line, inside the rectangle
    half = w - abs(s)  # room either side of it
    raw = [((x + 1) / 2 * (h + t) - h, y * half) for x, y in points]
    raw.append(((axis + 1) / 2 * (h + t) - h, 0.0))
    cloud = np.array(raw + [(x, -y) for x, y in raw]) + [0.0, s]
    assume(np.ptp(cloud[:, 0]) > 1e-3 and np.ptp(cloud[:, 1]) > 1e-3)  # not flat
    ring = cloud[ConvexHull(cloud).vertices]  # at most 7 vertices, counter-clockwise
    try:
        spec = replace(base, sole_offset=s, sole_polygon=tuple(map(tuple, ring.tolist())))
    except SpecError:  # nearly collinear vertices qhull kept: not strictly convex
        assume(False)
    stance = np.array([feet[:2]])
    swing = stance + np.array([feet[2:4]])
    zmp = stance + 1.5 * np.array([feet[4:6]])
    margin = _both(spec, np.array([side]), stance, swing, zmp, double)
    expected = _independent_margin(spec.sole_polygon, s, side, stance[0], swing[0], zmp[0], double)
    np.testing.assert_allclose(margin[0], expected, rtol=0, atol=1e-12)


def test_a_longer_foot_stretches_the_polygon_with_its_rectangle():
    """``with_foot_length(0.12)`` on the hexagon (heel 51, toe 49 mm → 61, 59 mm): each
    x maps −51..49 mm onto −61..59 mm, x' = −61 + 1.2 (x + 51) mm (x = 40 → 48.2 mm); y stays."""
    longer = _spec(HEXAGON).with_foot_length(0.12)
    expected = [(-0.061 + 1.2 * (x + 0.051), y) for x, y in HEXAGON]
    np.testing.assert_allclose(longer.sole_polygon, expected, rtol=0, atol=1e-15)
    assert longer.sole_polygon[0][0] == pytest.approx(0.0482, abs=1e-15)
