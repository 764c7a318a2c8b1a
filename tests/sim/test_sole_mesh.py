"""The twin's sole for a ``geometry.sole_polygon``: a convex mesh of the polygon, and
MuJoCo's own contacts of the standing twin inside it.

Reference: MuJoCo's compiled model (the mesh's vertices placed by the geom's pose, in
the frame of the sole site under the ankle) and its contact points after standing; the
polygon the planner uses (``sole.outline`` placed by ``zmp.sole_vertices``) must hold
them. A mirrored or unshifted right sole puts its contacts off the planner's polygon.
"""

from dataclasses import replace

import mujoco
import numpy as np

from slopewalk.bench.sim.model import scene_xml
from slopewalk.planner.joints import SIDE_PREFIX
from slopewalk.planner.sole import outline
from slopewalk.planner.spec import load_spec
from slopewalk.planner.zmp import signed_margin, sole_vertices, support_polygon

HEXAGON = ((0.04, -0.012), (0.04, 0.028), (0.0, 0.035), (-0.045, 0.028), (-0.045, -0.012),
           (0.0, -0.019))  # fmt: skip


def _in_sole_frame(model, data, side, points):
    """World points in the frame of the sole site of foot ``side``, (k, 3)."""
    site = model.site(f"{SIDE_PREFIX[side]}sole").id
    R = data.site_xmat[site].reshape(3, 3)
    return (np.asarray(points) - data.site_xpos[site]) @ R


def _planner_sole(spec, side):
    """The planner's sole polygon of foot ``side`` about its sole point, (2M, 2)."""
    here = np.zeros((1, 2))
    sole = sole_vertices(here, outline(spec), spec.sole_shift(side))
    return support_polygon(sole, sole, np.zeros(1, bool))[0]


def test_the_twins_sole_is_a_mesh_of_the_polygon_and_its_contacts_lie_in_it():
    spec = replace(load_spec(), sole_offset=0.008, sole_polygon=HEXAGON)
    model = mujoco.MjModel.from_xml_string(scene_xml(spec))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    mujoco.mj_forward(model, data)
    for side in (0, 1):
        geom = model.geom(f"{SIDE_PREFIX[side]}foot")
        assert geom.type[0] == mujoco.mjtGeom.mjGEOM_MESH
        mesh = model.mesh(geom.dataid[0])
        start, count = mesh.vertadr[0], mesh.vertnum[0]
        local = model.mesh_vert[start : start + count]
        world = data.geom_xpos[geom.id] + local @ data.geom_xmat[geom.id].reshape(3, 3).T
        rel = _in_sole_frame(model, data, side, world)
        # MuJoCo stores mesh vertices as float32 (re-centred): ~1e-9 m off, so 1e-7 here
        bottom = rel[np.abs(rel[:, 2]) < 1e-7, :2]
        expected = np.array(HEXAGON) * [1.0, 1.0 - 2.0 * side]  # the right: the mirror
        assert len(bottom) == len(HEXAGON)
        assert np.abs(bottom[:, None] - expected[None]).max(axis=2).min(axis=1).max() < 1e-7
        assert rel[:, 2].min() > -1e-7  # nothing below the sole
    for _ in range(300):  # 0.3 s standing at the home pose
        mujoco.mj_step(model, data)
    touching = {0: [], 1: []}
    feet = {model.geom(f"{p}foot").id: side for side, p in enumerate(SIDE_PREFIX)}
    for contact in data.contact[: data.ncon]:
        for g in (contact.geom1, contact.geom2):
            if g in feet:
                touching[feet[g]].append(contact.pos.copy())
    for side, points in touching.items():
        # MuJoCo's plane-convex collision: at most 4 points, at bottom vertices
        assert 3 <= len(points) <= 4, side
        rel = _in_sole_frame(model, data, side, points)[:, :2]
        margin = signed_margin(rel, np.repeat(_planner_sole(spec, side)[None], len(rel), 0))
        assert margin.min() > -1e-6, (side, margin)
