"""The 8 joints: their order (Table I of the paper), names, signs and MJCF names.

Order of the joint vector ``q`` (shape (..., 8)), as in Table I of the paper:

    index  paper  joint
    0      θ1     stance ankle roll
    1      θ2     stance ankle pitch
    2      θ3     stance knee
    3      θ4     stance hip pitch
    4      θ5     swing hip pitch
    5      θ6     swing knee
    6      θ7     swing ankle pitch
    7      θ8     swing ankle roll

Signs: every value is the MJCF joint angle of that physical joint, i.e. the
rotation of the child link relative to its parent in the tree rooted at the
pelvis (pelvis → thigh → shank → ankle → foot), about the parent's +y axis for
pitch joints and +x for roll joints. So positive hip pitch swings the leg
backward, positive knee is flexion, positive ankle pitch turns the toe down,
positive ankle roll turns the sole's left edge down.

The paper's θ8 = −θ1 (swing foot parallel to the ground) reads ``q[7] = q[0]``
in these signs: both ankle rolls equal minus the lateral lean of the legs.

The stance leg alternates between steps; ``stance`` is 0 for left, 1 for right.

Every joint angle is the principal value of the joint's configuration, in
(−π, π] (``principal_angle``): the IK's β_shank = ψ + φ passes π only in postures
far from a walk (the swing sole above its hip), where the unwrapped sum would
count a full turn of a joint as an excursion past its limit.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

JOINT_NAMES = (
    "stance_ankle_roll",
    "stance_ankle_pitch",
    "stance_knee",
    "stance_hip_pitch",
    "swing_hip_pitch",
    "swing_knee",
    "swing_ankle_pitch",
    "swing_ankle_roll",
)
LEFT, RIGHT = 0, 1
SIDE_PREFIX = ("l_", "r_")

# The MJCF's 8 hinge joints, left leg then right leg, each hip → ankle.
MJCF_JOINTS = tuple(
    f"{prefix}{kind}"
    for prefix in SIDE_PREFIX
    for kind in ("hip_pitch", "knee", "ankle_pitch", "ankle_roll")
)
# Joint kind of each entry of q (to look up limits in the spec).
JOINT_KINDS = (
    "ankle_roll",
    "ankle_pitch",
    "knee",
    "hip_pitch",
    "hip_pitch",
    "knee",
    "ankle_pitch",
    "ankle_roll",
)
# Index into q of each (hip_pitch, knee, ankle_pitch, ankle_roll) of the stance / swing leg.
_STANCE_IDX = (3, 2, 1, 0)
_SWING_IDX = (4, 5, 6, 7)


def stance_swing_to_left_right(q: np.ndarray, stance: np.ndarray) -> np.ndarray:
    """Reorder joint values from (stance, swing) order to the MJCF's left/right order.

    Args:
        q: Values in Table-I order, shape (n, 8).
        stance: Stance leg per sample, 0 left / 1 right, shape (n,).

    Returns:
        Values ordered as ``MJCF_JOINTS`` (left hip..roll, right hip..roll), shape (n, 8).
    """
    q = np.asarray(q)
    stance_leg = q[:, _STANCE_IDX]
    swing_leg = q[:, _SWING_IDX]
    left_is_stance = (np.asarray(stance) == LEFT)[:, None]
    left = np.where(left_is_stance, stance_leg, swing_leg)
    right = np.where(left_is_stance, swing_leg, stance_leg)
    return np.concatenate([left, right], axis=1)


def principal_angle(q: npt.ArrayLike) -> np.ndarray:
    """q wrapped to (−π, π] [rad] (same shape, values inside untouched); as the kernel does."""
    q = np.asarray(q, dtype=float)
    inside = (q > -np.pi) & (q <= np.pi)
    return np.where(inside | np.isnan(q), q, np.pi - np.mod(np.pi - q, 2 * np.pi))
