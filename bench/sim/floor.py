"""The floor's give: the stiffness of a sole corner on MuJoCo's soft contact.

MuJoCo's contacts are soft constraints. A contact of impedance d, reference
time constant τ and damping ratio ζ (``solref``), with d from ``solimp`` at its
penetration r, is solved so that its acceleration obeys

    a + d (b v + k r) = (1 − d) a₀,   b = 2 / (d_max τ),   k = d / (d_max² τ² ζ²)

and its force is f = (a_ref − a₀) / (Â + R), with R = Â (1 − d) / d the solver's
regulariser and Â the contact's approximate inverse mass, the translational
``body_invweight0`` of the foot (the floor, the world, adds none). At rest
(a = v = 0) the force holding a penetration r is f = k d r / ((1 − d) Â): a
spring of stiffness

    k_c = d² / ((1 − d) Â d_max² τ² ζ²)     [N/m]

per contact; a box sole on the plane touches at its four corners. For the
default robot (τ 0.02 s, ζ 1, d 0.9…0.95 over 1 mm, Â 3.6 kg⁻¹) k_c ≈ 6500 N/m;
measured from walking trials' flat-foot phases (tilt against the CoP's moment):
7000–7400 N/m (``tests/sim/test_floor.py`` holds the two together on a standing
robot). ``planner.tipping`` turns it into the floor's give.
"""

from __future__ import annotations

import mujoco
import numpy as np

from bench.sim.contact import FOOT_GEOMS

G = 9.81  # [m/s²]


def impedance(r: float, solimp) -> float:
    """MuJoCo's impedance d at penetration ``r`` [m] for ``solimp`` (d0, d_width, width, mid, p)."""
    d0, dmax, width, mid, power = (float(v) for v in solimp[:5])
    x = min(max(r / width, 0.0), 1.0) if width > 0 else 1.0
    if x <= mid:
        y = x**power / mid ** (power - 1) if mid > 0 else 1.0
    else:
        y = 1 - (1 - x) ** power / (1 - mid) ** (power - 1)
    return d0 + y * (dmax - d0)


def corner_stiffness(model: mujoco.MjModel, weight: float) -> float:
    """k_c [N/m] of one sole corner of the compiled scene, loaded by a quarter of ``weight`` [N].

    The impedance is taken at the corner's static penetration (a fixed point: the
    penetration sets d, d the stiffness); the floor and the feet share ``solref`` and
    ``solimp`` (MuJoCo mixes the two geoms' values; with equal values they are these).
    """
    geom = model.geom(FOOT_GEOMS[0])
    timeconst, dampratio = model.geom_solref[geom.id]
    solimp = model.geom_solimp[geom.id]
    inverse_mass = model.body_invweight0[model.geom_bodyid[geom.id], 0]
    dmax = float(solimp[1])
    r, stiffness = 0.0, 0.0
    for _ in range(20):
        d = impedance(r, solimp)
        stiffness = d**2 / ((1 - d) * inverse_mass * dmax**2 * timeconst**2 * dampratio**2)
        r_next = weight / 4 / stiffness
        if abs(r_next - r) < 1e-9:
            break
        r = r_next
    return float(stiffness)


def scene_corner_stiffness(model: mujoco.MjModel) -> float:
    """``corner_stiffness`` of a compiled scene under the robot's own weight."""
    mass = float(np.sum(model.body_mass))
    return corner_stiffness(model, mass * G)
