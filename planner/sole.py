"""The sole polygon: the convex contact outline of a foot, checked against its rectangle.

A spec's sole is the rectangle ``foot_length`` × ``foot_width`` (the ankle ``ankle_to_toe``
behind its toe edge, its centre ``sole_offset`` outward of the ankle) unless it names
``geometry.sole_polygon``: the left sole's vertices (x forward, y left) relative to the
sole point under the ankle [m], counter-clockwise, strictly convex, inside that rectangle
and symmetric about the sole's centre line y = ``sole_offset``. The right sole is the
left one's mirror in y; with the symmetry that mirror is the left polygon translated by
−2 ``sole_offset`` in y, so both soles are translates of one outline (relative to each
sole's centre, ``outline``) and the double-support polygon is the Minkowski sum of the
outline with a segment (``zmp.support_polygon``).

The rectangle stays the outer bound: what the polygon refines is the support polygon and
the ZMP margin (planner, compiled kernel, simulator's measured support); users that need
a rectangle (tipping, strike, floor give, twin collision boxes, figures, controllers)
keep it as a stated approximation.
"""

from __future__ import annotations

import math

import numpy as np

from slopewalk.planner.errors import SpecError

MAX_SOLE_VERTICES = 8  # the compiled kernel's fixed room (the DSP hull has twice as many)
INSIDE_TOL = 1e-12  # [m] a vertex on the rectangle's edge counts as inside
SYMMETRY_TOL = 1e-9  # [m] mirror of a vertex about the centre line meets another vertex


def rectangle(heel: float, toe: float, half_width: float) -> np.ndarray:
    """The sole rectangle about its centre, counter-clockwise from front-right, (4, 2) [m]."""
    return np.array(
        [[toe, -half_width], [toe, half_width], [-heel, half_width], [-heel, -half_width]]
    )


def check_polygon(value: object, heel: float, toe: float, half: float, offset: float) -> tuple:
    """``geometry.sole_polygon`` as a tuple of (x, y) floats, or one SpecError line.

    Args:
        value: The vertices as read (a list of [x, y] pairs) [m], relative to the sole point.
        heel, toe, half: The rectangle's extent: x in [−heel, toe], y in
            [offset − half, offset + half] [m].
        offset: ``sole_offset`` [m], the y of the sole's centre line.
    """
    name = "geometry.sole_polygon"
    pts = _pairs(value, name)
    if not 3 <= len(pts) <= MAX_SOLE_VERTICES:
        raise SpecError(
            f"{name} has {len(pts)} vertices: must have 3 to {MAX_SOLE_VERTICES} (a convex polygon)"
        )
    p = np.array(pts)
    e = np.roll(p, -1, axis=0) - p
    turn = e[:, 0] * np.roll(e[:, 1], -1) - e[:, 1] * np.roll(e[:, 0], -1)  # at vertex k+1
    area = 0.5 * float(np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1]))
    if area <= 0:
        raise SpecError(
            f"{name} {pts}: is clockwise or flat (signed area {area:.3g} m^2): "
            "list the vertices counter-clockwise (x forward, y left)"
        )
    dot = e[:, 0] * np.roll(e[:, 0], -1) + e[:, 1] * np.roll(e[:, 1], -1)
    winding = float(np.arctan2(turn, dot).sum()) / (2 * np.pi)  # 1 for a simple polygon
    if (turn <= 0).any() or abs(winding - 1.0) > 1e-9:
        k = (int(np.argmax(turn <= 0)) + 1) % len(pts)
        raise SpecError(
            f"{name} {pts}: not strictly convex at vertex {k} {pts[k]} "
            "(must turn left at every vertex)"
        )
    lo = np.array([-heel, offset - half]) - INSIDE_TOL
    hi = np.array([toe, offset + half]) + INSIDE_TOL
    outside = ((p < lo) | (p > hi)).any(axis=1)
    if outside.any():
        k = int(np.argmax(outside))
        raise SpecError(
            f"{name} vertex {k} {pts[k]} m: must lie in the sole rectangle x in "
            f"[{-heel:.6g}, {toe:.6g}], y in [{offset - half:.6g}, {offset + half:.6g}] m"
        )
    mirror = p * [1.0, -1.0] + [0.0, 2 * offset]
    gap = np.abs(mirror[:, None, :] - p[None, :, :]).max(axis=2).min(axis=1)
    if (gap > SYMMETRY_TOL).any():
        k = int(np.argmax(gap))
        raise SpecError(
            f"{name} vertex {k} {pts[k]} m: its mirror about the sole's centre line "
            f"y = sole_offset = {offset:.6g} m is {gap[k]:.3g} m from every vertex "
            f"(must be symmetric to {SYMMETRY_TOL:g} m)"
        )
    return pts


def _pairs(value: object, name: str) -> tuple[tuple[float, float], ...]:
    if not isinstance(value, list | tuple):
        raise SpecError(f"{name} {value!r}: must be a list of [x, y] pairs [m]")
    out = []
    for k, pair in enumerate(value):
        ok = isinstance(pair, list | tuple) and len(pair) == 2
        ok = ok and all(isinstance(v, int | float) and not isinstance(v, bool) for v in pair)
        if not ok:
            raise SpecError(f"{name} vertex {k} {pair!r}: must be a pair [x, y] of numbers [m]")
        x, y = float(pair[0]), float(pair[1])
        if not (math.isfinite(x) and math.isfinite(y)):
            raise SpecError(f"{name} vertex {k} [{x!r}, {y!r}] m: must be finite numbers")
        out.append((x, y))
    return tuple(out)


def outline(spec) -> np.ndarray:
    """The spec's sole relative to the sole's centre (the left sole point + (0, sole_offset)),
    counter-clockwise, (M, 2) [m]: the polygon if the spec names one, else the rectangle
    (exactly ``rectangle``, so the default spec's support polygons keep their bits)."""
    if spec.sole_polygon is None:
        return rectangle(spec.heel_offset, spec.ankle_to_toe, spec.foot_width / 2)
    return np.array(spec.sole_polygon) - [0.0, spec.sole_offset]


def edge_normals(corners: np.ndarray) -> np.ndarray:
    """Outward unit normals of a counter-clockwise polygon's edges k → k+1, (M, 2).

    The rectangle's are exactly (1, 0), (0, 1), (−1, 0), (0, −1) (no −0.0)."""
    e = np.roll(corners, -1, axis=0) - corners
    return np.stack([e[:, 1], -e[:, 0]], axis=1) / np.hypot(e[:, 0], e[:, 1])[:, None] + 0.0
