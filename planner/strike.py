"""Swing-foot strike: a sagging leg props the robot up and rolls the stance foot off the plane.

The compliance-aware walk (``compliance.py``) may put the swing sole below the
plane in single support, by p: the servos sag under the load, and the swing leg
comes down with the pelvis. The plane does not let it: it pushes the sole up
with a force F, which the robot's two ways to give way share:

* the leg's own compliance, p_leg = C_zz F, with C = J Jᵀ / kp the sole's
  Cartesian compliance through the 8 servos in series from the stance foot
  (J the sole position's Jacobian in q, all servos of stiffness kp);
* a rotation θ of the whole robot about the stance foot's far edge (the edge
  away from the swing foot), which lifts the swing side by ℓ θ, ℓ the lateral
  distance from that edge to the swing sole.

The robot turns only once F's moment about the edge, F ℓ, exceeds the weight's,
W d (d: lateral distance from the edge to the CoM); below that the sole just
carries load. So with F = W d / ℓ at the onset,

    θ = max(0, p − C_zz W d / ℓ) / ℓ

(small angles, the leg's compliance at the onset force). A stance foot turned
past the simulator's tip angle is a tip the paper's ZMP test cannot see: its ZMP
was computed for a support the robot no longer has.
"""

from __future__ import annotations

import numpy as np

from slopewalk.planner.kinematics import GRAVITY, Chain

_EPS = 1e-6  # [rad], finite-difference step of the Jacobian


def sole_compliance_z(plan, rows, stiffness: float) -> np.ndarray:
    """C_zz of the swing sole at samples ``rows`` [m/N], (k,): J Jᵀ / kp, normal part."""
    chain = Chain.from_spec(plan.spec)
    q, sole, stance = plan.q[rows], plan.stance_sole[rows], plan.stance[rows]
    base = chain.poses(q, sole, stance)[1][9, 2]  # swing sole height, (k,)
    jz = np.empty((rows.size, 8))
    for j in range(8):
        bumped = q.copy()
        bumped[:, j] += _EPS
        jz[:, j] = (chain.poses(bumped, sole, stance)[1][9, 2] - base) / _EPS
    return np.einsum("kj,kj->k", jz, jz) / stiffness


def strike_roll(plan, stiffness: float) -> np.ndarray:
    """Rotation θ of the stance foot about its far edge from a swing-sole strike [rad], (n,).

    Args:
        plan: The compliance-aware walk (its ``swing_sole`` is where the sole would be).
        stiffness: The servos' kp [N m/rad].
    """
    theta = np.zeros(plan.t.size)
    rows = np.flatnonzero(~plan.double_support & (plan.swing_sole[:, 2] < 0))
    if not rows.size:
        return theta
    half = plan.spec.foot_width / 2
    towards_swing = np.sign(plan.swing_sole[rows, 1] - plan.stance_sole[rows, 1])
    centre = plan.stance_sole[rows, 1] + plan.spec.sole_shift(plan.stance[rows])
    edge_y = centre - towards_swing * half
    lever = np.abs(plan.swing_sole[rows, 1] - edge_y)
    arm = np.clip(towards_swing * (plan.com[rows, 1] - edge_y), 0.0, None)
    weight = plan.spec.total_mass * GRAVITY
    absorbed = sole_compliance_z(plan, rows, stiffness) * weight * arm / lever
    theta[rows] = np.maximum(0.0, -plan.swing_sole[rows, 2] - absorbed) / lever
    return theta
