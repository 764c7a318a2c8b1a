"""The sole's contact footprint: the convex hull of where the sole geoms would touch a plane.

A foot standing flat on a plane touches it where its sole geoms reach their lowest height;
the support polygon of that foot is the convex hull of those points. Measured in the base
frame at the reference pose (``fit``: x forward, z up), per geom type:

* box: its 8 corners (exact);
* mesh: its vertices (MuJoCo collides with the mesh's convex hull, whose lowest vertices
  are the mesh's own; exact);
* sphere: the point below its centre; capsule: the points below its two segment ends
  (exact: a capsule lying flat touches along that segment);
* any other type (cylinder, ellipsoid): the corners of its bounding box, an outer bound,
  said so (``Footprint.bounded``).

Points within ``LOWEST_TOLERANCE`` of the lowest one are the contact face. The spec's sole is
the rectangle around them (``geometry.foot_length`` …, ``sole_offset``) and, where the
footprint is not that rectangle, ``geometry.sole_polygon``: the footprint itself
(``spec_polygon``), when it is symmetric about the sole's centre line to
``SYMMETRY_TOLERANCE`` and has at most ``MAX_SOLE_VERTICES`` vertices; otherwise the
rectangle alone, and the report says why and how much larger than the footprint it is.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from scipy.spatial import ConvexHull, QhullError

from slopewalk.planner.errors import SpecError
from slopewalk.planner.sole import MAX_SOLE_VERTICES, check_polygon

LOWEST_TOLERANCE = 1e-6  # [m] contact points this close to the lowest are the sole face
# [m] a footprint symmetric about its centre line to this (mesh vertices are float32 in
# MuJoCo, ~1e-8 m off at foot scale) is written symmetric to the last bit
SYMMETRY_TOLERANCE = 1e-6
_EXACT = {
    int(mujoco.mjtGeom.mjGEOM_BOX),
    int(mujoco.mjtGeom.mjGEOM_MESH),
    int(mujoco.mjtGeom.mjGEOM_SPHERE),
    int(mujoco.mjtGeom.mjGEOM_CAPSULE),
}


@dataclass(frozen=True)
class Footprint:
    """One sole's contact footprint, in the base frame from the ankle centre [m].

    Attributes:
        vertices: The convex hull (x, y), counter-clockwise, (K, 2); fewer than 3 rows where
            the contact face is a point or a segment.
        bounded: Whether some sole geom was taken by its bounding box (an outer bound).
    """

    vertices: np.ndarray
    bounded: bool

    @property
    def area(self) -> float:
        """Area of the footprint [m²] (0 for a point or a segment)."""
        if len(self.vertices) < 3:
            return 0.0
        x, y = self.vertices.T
        return float(0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def geom_points(model: mujoco.MjModel, data: mujoco.MjData, geom: int) -> np.ndarray:
    """Candidate contact points of ``geom`` in the world frame (module doc), (k, 3)."""
    kind = int(model.geom_type[geom])
    R, p = data.geom_xmat[geom].reshape(3, 3), data.geom_xpos[geom]
    size = model.geom_size[geom]
    down = np.array([0.0, 0.0, -size[0]])  # a sphere's or capsule's radius, straight down
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        signs = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
        return p + (signs * size) @ R.T
    if kind == mujoco.mjtGeom.mjGEOM_MESH:
        mesh = int(model.geom_dataid[geom])
        start, count = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
        return p + model.mesh_vert[start : start + count] @ R.T
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return (p + down)[None]
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        ends = np.array([[0.0, 0.0, -size[1]], [0.0, 0.0, size[1]]])
        return p + ends @ R.T + down
    centre, half = model.geom_aabb[geom, :3], model.geom_aabb[geom, 3:]
    signs = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
    return p + (centre + signs * half) @ R.T


def sole_footprint(model, data, frame, geoms, ankle: np.ndarray) -> Footprint:
    """The footprint of the sole ``geoms`` (module doc), from ``ankle`` (base frame) [m].

    Args:
        frame: ``fit.BaseFrame`` of the reference pose (world → base).
        geoms: The foot's sole geoms (``fit._sole_geoms``).
        ankle: The ankle centre in the base frame [m], (3,).
    """
    points = np.concatenate([frame.point(geom_points(model, data, g)) for g in geoms])
    face = points[points[:, 2] < points[:, 2].min() + LOWEST_TOLERANCE][:, :2] - ankle[:2]
    bounded = any(int(model.geom_type[g]) not in _EXACT for g in geoms)
    try:
        hull = ConvexHull(face)
    except (QhullError, ValueError):  # a point or a segment: no area to wrap
        return Footprint(np.unique(face.round(12), axis=0), bounded)
    return Footprint(face[hull.vertices], bounded)  # counter-clockwise in 2-D


def spec_polygon(foot: Footprint, extent) -> tuple[list[list[float]] | None, str]:
    """``geometry.sole_polygon`` from the left sole's footprint, or None and why not.

    The rectangle ``extent`` (x min, x max, y min, y max from the ankle [m], the spec's
    sole rectangle) is the footprint already when each of its corners is a footprint vertex
    to ``SYMMETRY_TOLERANCE``: then None (the spec keeps the rectangle alone, as before the
    key existed). Otherwise the footprint's vertices, each pair mirrored about the centre
    line y = (y min + y max)/2 averaged so the polygon is symmetric exactly, clipped onto
    the rectangle, as the spec checks them (``sole.check_polygon``).

    Returns:
        (vertices [[x, y], …] counter-clockwise [m] or None, a phrase for the report).
    """
    x0, x1, y0, y1 = extent
    p = np.asarray(foot.vertices, dtype=float)
    corners = np.array([[x1, y0], [x1, y1], [x0, y1], [x0, y0]])
    if len(p) >= 3 and all(np.abs(p - c).max(axis=1).min() <= SYMMETRY_TOLERANCE for c in corners):
        return None, "the footprint is the rectangle"
    if not 3 <= len(p) <= MAX_SOLE_VERTICES:
        return None, f"{len(p)} vertices (the planner takes 3 to {MAX_SOLE_VERTICES})"
    centre = (y0 + y1) / 2
    mirror = p * [1.0, -1.0] + [0.0, 2 * centre]
    gap = np.abs(mirror[:, None, :] - p[None, :, :]).max(axis=2)
    partner = gap.argmin(axis=1)
    worst = float(gap.min(axis=1).max())
    if worst > SYMMETRY_TOLERANCE:
        return None, f"not symmetric about its centre line ({worst * 1e3:.3g} mm off)"
    sym = (p + mirror[partner]) / 2
    sym = np.clip(sym, [x0, y0], [x1, y1])
    vertices = [[float(x), float(y)] for x, y in sym]
    try:
        check_polygon(vertices, -x0, x1, (y1 - y0) / 2, centre)
    except SpecError as err:
        return None, f"refused as a sole polygon ({err})"
    return vertices, "written as geometry.sole_polygon"
