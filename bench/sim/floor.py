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

The give fed forward (``give_feedforward``, played by the "_ff" actuator modes): a
sole loaded by F_n with its CoP p off the centroid m of its 4 corners turns on
those springs by

    θ_x = −F_n (p_y − m_y) / (k_c w²),   θ_y = F_n (p_x − m_x) / (k_c l²)   [rad]

(rotations of the sole about x_S and y_S; w, l the sole's width and length, so
k_c w² = 4 k_c (w/2)² is the corners' roll stiffness). Unless the ankle turns the
other way, the whole robot above the sole turns with it: the stance foot's give
of 0.3–0.4° in a slow walk tilts the robot towards the swing foot, whose sole,
~0.1 m away, meets the plane ~1 mm early (~50 ms before the planned touch-down),
takes half the weight at once and throws the CoP ~40 mm off the planned ZMP.
Turning each ankle by its foot's give (roll by θ_x, pitch by θ_y / cos(roll), the
pitch axis sitting on the rolled ankle) keeps the legs, the body and the swing
foot where the plan has them, so the swing sole lands flat at the planned time.

Each foot's load and CoP come from the plan: in single support the stance foot
carries the whole ground force at the ZMP; in double support each foot carries
the plan's share F_i (``planner.plan``'s load split) at p_i = m_i + (p − m̄), with
m̄ = Σ F_i m_i / Σ F_i: the shares' moments add up to the planned ZMP's, and p_i
is the ZMP itself when a foot carries everything, so the hand-over from foot to
foot adds no jump (the give jumps only where the planned ZMP does: at the phase
changes, where the lean's acceleration steps). First order: the sole turns about
its corners' centroid, the ankle about its axis an ankle height above it (a 0.2 mm
horizontal shift at 6 mrad for the default robot); the
sink F_n / 4 k_c (0.23 mm at the whole weight) is not fed forward: lengthening the
legs by it makes the unloading foot of a double support lose contact (measured:
unplanned support 0.14 → 1.17 s on flat ground at 2 s steps), because the plan's
double support asks a foot to slide (``planner.verdict``'s ``foot_slide``) and the
feet's real shares follow that fight, not the plan's split.
"""

from __future__ import annotations

import mujoco
import numpy as np

from bench.sim.contact import FOOT_GEOMS
from planner.joints import LEFT

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


def foot_loads(plan) -> tuple[np.ndarray, np.ndarray]:
    """Each foot's (left, right) sole point [m], (n, 2, 2), and planned normal load [N], (n, 2).

    The stance foot carries ``plan.stance_force``, the other foot ``plan.swing_force``
    in double support and nothing in single support (``planner.plan``'s load split).
    """
    left = (plan.stance == LEFT)[:, None]
    sole = np.stack(
        [
            np.where(left, plan.stance_sole[:, :2], plan.swing_sole[:, :2]),
            np.where(left, plan.swing_sole[:, :2], plan.stance_sole[:, :2]),
        ],
        axis=1,
    )
    stance = np.maximum(plan.stance_force[:, 2], 0.0)
    other = np.where(plan.double_support, np.maximum(plan.swing_force[:, 2], 0.0), 0.0)
    load = np.column_stack(
        [np.where(left[:, 0], stance, other), np.where(left[:, 0], other, stance)]
    )
    return sole, load


def foot_give(plan, corner_stiffness: float) -> np.ndarray:
    """Planned turn of each sole (left, right) on the soft floor [rad], (n, 2, 2): (θ_x, θ_y).

    Rotations about x_S and y_S of a sole on 4 corner springs of ``corner_stiffness``
    [N/m] under its planned load and CoP (module doc); zero for a foot in the air.
    """
    spec = plan.spec
    sole, load = foot_loads(plan)
    centroid = sole + np.array([(spec.ankle_to_toe - spec.heel_offset) / 2, 0.0])
    total = load.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.einsum("nf,nfi->ni", load, centroid) / total[:, None]
    offset = np.where(total[:, None] > 0, plan.zmp - mean, 0.0)  # p_i − m_i, the same for both
    theta_x = -load * offset[:, None, 1] / (corner_stiffness * spec.foot_width**2)
    theta_y = load * offset[:, None, 0] / (corner_stiffness * spec.foot_length**2)
    return np.stack([theta_x, theta_y], axis=-1)


def give_feedforward(plan, corner_stiffness: float) -> np.ndarray:
    """Ankle turns that cancel each sole's give, MJCF joint order [rad], (n, 8) on ``plan.t``.

    Ankle roll by θ_x and ankle pitch by θ_y / cos(roll) of ``foot_give`` (module doc);
    the hips and knees are left as planned.
    """
    give = foot_give(plan, corner_stiffness)
    roll = plan.q_left_right[:, [3, 7]]  # (n, 2) ankle rolls, left and right
    out = np.zeros((plan.t.size, 8))
    out[:, [2, 6]] = give[..., 1] / np.cos(roll)
    out[:, [3, 7]] = give[..., 0]
    return out
