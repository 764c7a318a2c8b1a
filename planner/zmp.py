"""Zero-moment point on the (possibly tilted) plane, support polygons and margins (sec. V-B).

The ZMP is the point p of the plane z_S = 0 about which the tangential moment of
the ground reaction vanishes. With each link's momentum balance
m_i a_i = m_i g + (forces), the ground wrench about the origin of S is

    F = Σ m_i (a_i − g),      M = Σ [ c_i × m_i (a_i − g) + Ḣ_i ],   Ḣ_i = I_i ω̇_i + ω_i × I_i ω_i

and M − p × F has zero x and y components at

    p_x = −M_y / F_z = Σ [ m x (z̈ − g_z) − m (ẍ − g_x) z − Ḣ_y ] / Σ m (z̈ − g_z)
    p_y =  M_x / F_z = Σ [ m y (z̈ − g_z) − m (ÿ − g_y) z + Ḣ_x ] / Σ m (z̈ − g_z)

which is eq. (4) of the paper with the gravity vector written in S: on a slope
θs, g_S = (−g sin θs, 0, −g cos θs), so both components appear. On flat ground
(g_x = 0, g_z = −g) it is the paper's formula (whose "z̈ − g" takes g = −9.81).

The same point is the centre of pressure (CoP) of the ground wrench that the
Newton-Euler recursion returns at the feet (``cop_of_wrench``); the two are
computed by separate code and checked against each other in the tests.
"""

from __future__ import annotations

import warnings

import numpy as np

from slopewalk.planner.newton_euler import cross
from slopewalk.planner.sole import edge_normals, rectangle


def zmp_multibody(mass, com, com_acc, momentum_rate, gravity) -> np.ndarray:
    """Eq. (4): ZMP of a multibody from link CoM motion, in S [m].

    Args:
        mass: Link masses [kg], shape (L,).
        com: Link CoM positions in S [m], shape (n, L, 3).
        com_acc: Link CoM accelerations in S [m/s²], shape (n, L, 3).
        momentum_rate: Ḣ_i = I ω̇ + ω × I ω per link in S [N m], shape (n, L, 3).
        gravity: Gravity in S [m/s²], shape (3,).

    Returns:
        (p_x, p_y) on the plane, shape (n, 2).
    """
    x, y, z = com[..., 0], com[..., 1], com[..., 2]
    net = com_acc - gravity  # a − g per link
    ax, ay, az = net[..., 0], net[..., 1], net[..., 2]
    den = np.einsum("l,nl->n", mass, az)
    px = (np.einsum("l,nl->n", mass, x * az - ax * z) - momentum_rate[..., 1].sum(-1)) / den
    py = (np.einsum("l,nl->n", mass, y * az - ay * z) + momentum_rate[..., 0].sum(-1)) / den
    return np.stack([px, py], axis=-1)


def cop_of_wrench(force, moment, point) -> np.ndarray:
    """Centre of pressure on the plane z_S = 0 of a wrench acting at ``point``.

    Args:
        force: Ground force [N], shape (n, 3), in S.
        moment: Ground moment about ``point`` [N m], shape (n, 3), in S.
        point: Reference point in S [m], shape (n, 3).

    Returns:
        CoP (x, y) [m], shape (n, 2); NaN where the normal force is not positive.
    """
    moment_origin = moment + cross(point, force)
    fz = np.where(force[:, 2] > 0, force[:, 2], np.nan)
    return np.stack([-moment_origin[:, 1] / fz, moment_origin[:, 0] / fz], axis=-1)


def zmp_lipm(com, com_acc, gravity) -> np.ndarray:
    """Eq. (5): linear-inverted-pendulum ZMP from the whole-body CoM, in S [m].

    A point mass with no vertical acceleration (the LIPM's constant height):
    p = c_xy − c_z (c̈_xy − g_xy) / (−g_z). On flat ground this is
    p = c − z_c c̈ / g; the paper prints "+ z_c c̈ / g", which holds only with
    g = −9.81 (the same sign convention as its eq. 4).

    Args:
        com: CoM in S [m], shape (n, 3).
        com_acc: CoM acceleration in S [m/s²], shape (n, 3).
        gravity: Gravity in S [m/s²], shape (3,).

    Returns:
        (p_x, p_y), shape (n, 2).
    """
    return com[:, :2] - com[:, 2:3] * (com_acc[:, :2] - gravity[:2]) / (-gravity[2])


def friction_ratio(force) -> np.ndarray:
    """Required friction |F_t| / F_n of a ground force in S, shape (n,) (inf if F_n ≤ 0)."""
    fn = force[..., 2]
    ft = np.hypot(force[..., 0], force[..., 1])
    return np.where(fn > 0, ft / np.where(fn > 0, fn, 1.0), np.inf)


def foot_corners(center, heel: float, toe: float, half_width: float, shift=0.0) -> np.ndarray:
    """Sole rectangle of feet parallel to x_S, counter-clockwise from front-right.

    Args:
        center: Sole point under the ankle in S [m], shape (n, 2) (or (n, 3)).
        heel, toe: Ankle-to-heel and ankle-to-toe distances along x [m].
        half_width: Half the foot width [m].
        shift: y of the rectangle's centre from the sole point [m], scalar or (n,)
            (``RobotSpec.sole_shift`` of each row's foot); 0: centred under the ankle.

    Returns:
        Corners (x, y), shape (n, 4, 2).
    """
    return sole_vertices(center, rectangle(heel, toe, half_width), shift)


def sole_vertices(center, outline, shift=0.0) -> np.ndarray:
    """A sole outline placed at feet parallel to x_S: center + (0, shift) + outline.

    Args:
        center: Sole point under the ankle in S [m], shape (n, 2) (or (n, 3)).
        outline: Vertices about the sole's centre, counter-clockwise, (M, 2) [m]
            (``sole.outline``: the same for both feet).
        shift: y of the sole's centre from the sole point [m], scalar or (n,).

    Returns:
        Vertices (x, y), shape (n, M, 2).
    """
    center = np.array(center, dtype=float)[:, :2]
    center[:, 1] += shift
    return center[:, None, :] + np.asarray(outline, dtype=float)


def support_polygon(stance_corners, other_corners, double_support, normals=None) -> np.ndarray:
    """Support polygon: the stance sole, or the convex hull of both soles in DSP.

    Both soles are translates of one convex outline (M vertices), so their hull is the
    Minkowski sum of the outline with the segment d joining them: each vertex v_i becomes
    v_i or v_i + d, or both, depending on which side of its two edges d points to. The
    result is a counter-clockwise polygon of 2M vertices, repeats allowed (each vertex
    twice in SSP).

    Args:
        stance_corners: (n, M, 2) stance sole, counter-clockwise.
        other_corners: (n, M, 2) other sole (the same outline, translated).
        double_support: (n,) bool, True where both feet carry load.
        normals: Outward unit normals of the outline's edges k → k+1, (M, 2)
            (``sole.edge_normals`` of ``sole.outline``, as the kernel takes them); None:
            from the first row's corners.

    Returns:
        Vertices, shape (n, 2M, 2).
    """
    d = (other_corners[:, 0] - stance_corners[:, 0]) * double_support[:, None]  # (n, 2)
    corners = stance_corners.shape[1]
    if normals is None:
        if not len(d):
            return np.empty((0, 2 * corners, 2))
        normals = edge_normals(stance_corners[0] - stance_corners[0, 0])  # every row's
    # (n, M): edge i faces the direction d (the kernel's products and sum, no BLAS)
    ahead = d[:, :1] * normals[:, 0] + d[:, 1:] * normals[:, 1] > 0
    out = np.empty(stance_corners.shape[:1] + (2 * corners, 2))
    for i in range(corners):
        incoming, outgoing = ahead[:, i - 1], ahead[:, i]
        v, vd = stance_corners[:, i], stance_corners[:, i] + d
        first = np.where(incoming[:, None], vd, v)
        second = np.where(outgoing[:, None], vd, v)
        out[:, 2 * i], out[:, 2 * i + 1] = first, second
    return out


def signed_margin(points, polygon) -> np.ndarray:
    """Signed distance from points to a convex polygon's boundary [m], positive inside.

    Args:
        points: (n, 2).
        polygon: Counter-clockwise vertices, repeats allowed, shape (n, V, 2).

    Returns:
        Margin, shape (n,); NaN where the point is NaN.
    """
    # per coordinate on contiguous (V, n) arrays: the same products and sums as on
    # (n, V, 2) (the projection's 0 + r_x e_x + r_y e_y is einsum's), each minimum over
    # the vertices an element-wise one of V rows; ~2x faster
    p = np.asarray(points, dtype=float)
    px, py = p[:, 0], p[:, 1]
    ax, ay = (np.ascontiguousarray(np.asarray(polygon, dtype=float)[..., k].T) for k in (0, 1))
    ex, ey = np.roll(ax, -1, axis=0) - ax, np.roll(ay, -1, axis=0) - ay
    length = np.hypot(ex, ey)
    valid = length > 1e-12
    safe = np.where(valid, length, 1.0)
    rx, ry = px - ax, py - ay
    # inward normal of a counter-clockwise edge is its left normal (−e_y, e_x)
    inside_dist = (ex * ry - ey * rx) / safe
    inside_dist[~valid] = np.inf
    margin = inside_dist.min(axis=0)
    # outside (or NaN): minus the distance to the nearest edge segment, computed for those
    # points' columns only (most ZMPs are inside; the same operations on each element)
    away = ~(margin >= 0)
    if away.any():
        ex, ey, ax, ay, rx, ry = (v[:, away] for v in (ex, ey, ax, ay, rx, ry))
        square = np.where(valid[:, away], safe[:, away] ** 2, 1.0)
        s = np.clip((0.0 + rx * ex + ry * ey) / square, 0.0, 1.0)
        margin[away] = -np.hypot(px[away] - (ax + s * ex), py[away] - (ay + s * ey)).min(axis=0)
    return margin


def axis_margins(points, polygon) -> tuple[np.ndarray, np.ndarray]:
    """Per-axis signed ZMP margins [m] in the slope frame: (sagittal along x_S, lateral along y_S).

    The margin along an axis is the signed distance, along that axis alone, from the
    point to the boundary of the polygon's chord through the point parallel to the axis:
    for x, the chord [x_lo, x_hi] that the line y = p_y cuts from the polygon, and the
    margin min(p_x − x_lo, x_hi − p_x); positive inside the chord, negative outside by
    the distance to its nearer end. Where the line misses the polygon (the point lies
    beyond it along the other axis) the chord is taken at the polygon's nearest extreme
    of that other coordinate, so each axis says only how far along itself the point is
    from the polygon's extent. For y the roles of x and y swap. ``signed_margin`` (the
    Euclidean distance to the boundary) is at most either where the point is inside.

    Args:
        points: (n, 2).
        polygon: Counter-clockwise vertices of a convex polygon, repeats allowed, (n, V, 2).

    Returns:
        (sagittal, lateral), each shape (n,); NaN where the point is NaN.
    """
    points = np.asarray(points, dtype=float)
    polygon = np.asarray(polygon, dtype=float)
    return _chord_margin(points, polygon, 0), _chord_margin(points, polygon, 1)


def _chord_margin(points, polygon, axis: int) -> np.ndarray:
    """Signed distance along ``axis`` from each point to its chord's ends (``axis_margins``)."""
    other = 1 - axis
    a = polygon
    b = np.roll(polygon, -1, axis=1)
    lo, hi = polygon[..., other].min(axis=1), polygon[..., other].max(axis=1)
    c = np.clip(points[:, other], lo, hi)[:, None]  # the chord's line, clamped onto the polygon
    da, db = a[..., other] - c, b[..., other] - c
    span = b[..., other] - a[..., other]
    crosses = (da * db <= 0) & (np.abs(span) > 1e-15)
    with np.errstate(invalid="ignore", divide="ignore"):
        t = np.where(crosses, -da / np.where(crosses, span, 1.0), np.nan)
    cut = a[..., axis] + t * (b[..., axis] - a[..., axis])
    on = np.abs(da) <= 1e-15  # a vertex on the line (a flat edge along the axis: both ends)
    ends = np.concatenate([cut, np.where(on, a[..., axis], np.nan)], axis=1)
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a NaN point: an all-NaN row
        low, high = np.nanmin(ends, axis=1), np.nanmax(ends, axis=1)
    p = points[:, axis]
    return np.minimum(p - low, high - p)
