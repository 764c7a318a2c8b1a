"""The spec's five links lumped from the model's bodies at the reference pose.

Each planned joint moves its body and everything below it down to the next planned
joint; the bodies between two planned joints (held joints welded at their angles)
are one spec link: thigh (hip pitch → knee), shank (knee → ankle pitch), ankle
(ankle pitch → ankle roll), foot (ankle roll and below). The pelvis is everything
else: the base's subtree without the two legs below the hip pitch joints, so its
mass and CoM are MuJoCo's subtree quantities, ``subtree_mass`` and ``subtree_com``
of the base less those of the two hip pitch bodies.

Inertia: the link's tensor about its CoM in the base axes, Σ Rᵢ Iᵢ Rᵢᵀ + mᵢ (|dᵢ|² E −
dᵢ dᵢᵀ). The spec keeps its diagonal (principal moments along the body axes); the
products of inertia it drops are reported (``Lumped.dropped``).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from slopewalk.bench.robot_import.fit import BaseFrame, Fit, posed

LEG_LINKS = (("thigh", "hip_pitch", "knee"), ("shank", "knee", "ankle_pitch"),
             ("ankle", "ankle_pitch", "ankle_roll"), ("foot", "ankle_roll", None))  # fmt: skip


@dataclass(frozen=True)
class Lumped:
    """One spec link from the model, base axes at the reference pose.

    Attributes:
        mass: [kg]; com: in the spec link's frame [m], (3,); inertia: full tensor about
            the CoM [kg m²], (3, 3); bodies: the model's body ids it lumps.
    """

    mass: float
    com: np.ndarray
    inertia: np.ndarray
    bodies: tuple[int, ...]

    @property
    def dropped(self) -> float:
        """Largest product of inertia the spec drops, relative to the largest moment."""
        off = self.inertia - np.diag(np.diag(self.inertia))
        return float(np.abs(off).max() / np.abs(np.diag(self.inertia)).max())


def subtree(model: mujoco.MjModel, body: int) -> set[int]:
    """``body`` and every body below it."""
    out = {body}
    for b in range(body + 1, model.nbody):
        if model.body_parentid[b] in out:
            out.add(b)
    return out


def _tensor(model, data, frame: BaseFrame, bodies, com_world) -> np.ndarray:
    total = np.zeros((3, 3))
    for b in bodies:
        R = frame.R.T @ data.ximat[b].reshape(3, 3)
        d = frame.vector(data.xipos[b] - com_world)
        m = model.body_mass[b]
        total += R @ np.diag(model.body_inertia[b]) @ R.T + m * (d @ d * np.eye(3) - np.outer(d, d))
    return total


def link_origins(fit: Fit, side: str) -> dict[str, np.ndarray]:
    """Spec body-frame origins of one leg's links in the base frame [m] (``docs/robot-spec.md``)."""
    leg, ankle = fit.legs[side], fit.ankle_centre(side)
    hip = np.array([leg["hip_pitch"].anchor[0], ankle[1], leg["hip_pitch"].anchor[2]])
    knee = np.array([leg["knee"].anchor[0], ankle[1], leg["knee"].anchor[2]])  # knee_offset
    return {"thigh": hip, "shank": knee, "ankle": ankle, "foot": ankle}


def lump_links(fit: Fit, side: str = "left") -> dict[str, Lumped]:
    """The five spec links (pelvis and ``side``'s leg) at the reference pose (module doc)."""
    model = fit.model
    data = posed(model, fit.qpos)
    frame = BaseFrame(data, fit.base)
    leg = fit.legs[side]
    out = {}
    origins = link_origins(fit, side)
    for link, top, bottom in LEG_LINKS:
        bodies = subtree(model, leg[top].body)
        if bottom is not None:
            bodies -= subtree(model, leg[bottom].body)
        out[link] = _lumped(model, data, frame, sorted(bodies), origins[link])
    hips = [fit.legs[s]["hip_pitch"].body for s in ("left", "right")]
    mass = model.body_subtreemass[fit.base] - sum(model.body_subtreemass[h] for h in hips)
    moment = model.body_subtreemass[fit.base] * data.subtree_com[fit.base] - sum(
        model.body_subtreemass[h] * data.subtree_com[h] for h in hips
    )
    com_world = moment / mass
    pelvis = sorted(subtree(model, fit.base) - subtree(model, hips[0]) - subtree(model, hips[1]))
    out["pelvis"] = Lumped(
        float(mass), frame.point(com_world) - fit.pelvis_origin,
        _tensor(model, data, frame, pelvis, com_world), tuple(pelvis),
    )  # fmt: skip
    return out


def _lumped(model, data, frame, bodies, origin) -> Lumped:
    masses = model.body_mass[bodies]
    mass = float(masses.sum())
    com_world = (masses[:, None] * data.xipos[bodies]).sum(axis=0) / mass
    inertia = _tensor(model, data, frame, bodies, com_world)
    return Lumped(mass, frame.point(com_world) - origin, inertia, tuple(bodies))


def mirrored(link: Lumped) -> Lumped:
    """The link reflected in the base's xz plane (a left link as the right leg's)."""
    M = np.diag([1.0, -1.0, 1.0])
    return Lumped(link.mass, M @ link.com, M @ link.inertia @ M, link.bodies)
