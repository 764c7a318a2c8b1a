"""LIPM capture-point correction of the pelvis, through the stance ankles.

Linear inverted pendulum of height z (the CoM above the plane, slope frame S):
ω = √(g / z) (g = 9.81 m/s²; the slope's cos θ on it is neglected), and the divergent
component of motion (capture point)

    ξ = c + ċ / ω            (measured: ``com``, ``com_vel``)
    ξ_ref = c_ref + ċ_ref / ω   (the plan's ``com_ref``, ``com_vel_ref``).

ξ drifts away from the CoP, ξ̇ = ω (ξ − p), so a capture point ahead of its
reference is corrected by moving the pelvis (and so the CoM) back towards it:

    δ = −K · (ξ − ξ_ref)      [m], the pelvis displacement asked for, in S,

K = diag(K_x, K_y): the lateral gain is the larger; sagittal corrections push the
feet along the plane, and on a slope near its friction limit a sagittal gain of
0.15 already makes a foot slip (18° at μ = 0.4, where the plan alone walks).

Each loaded foot's ankle rotates the leg over that foot: with h the ankle's
height under the CoM, positive ankle pitch moves the pelvis by −h·Δq (−x),
positive ankle roll by +h·Δq (+y), so

    Δq_pitch = −δ_x / h,      Δq_roll = +δ_y / h,

each clipped to ±``MAX_OFFSET``, added to the plan's command; the other joints
follow the plan (``ctrl_ref``). A foot carrying less than ``MIN_LOAD`` is left alone.
"""

from __future__ import annotations

import math

import numpy as np

from slopewalk.planner.kinematics import GRAVITY

GAIN_X, GAIN_Y = 0.05, 0.15  # K, sagittal and lateral
MIN_LOAD = 0.5  # [N]
MAX_OFFSET = 0.2  # [rad]
_PITCH, _ROLL = (2, 6), (3, 7)  # ankle pitch / roll of the left, right leg (MJCF order)


def capture_point_pelvis(observation: dict) -> np.ndarray:
    """Actuator command: the plan's, plus the capture-point pelvis correction (module doc)."""
    action = observation["ctrl_ref"].copy()
    cx, cy, cz = observation["com"].tolist()
    vx, vy, _ = observation["com_vel"].tolist()
    rx, ry, _ = observation["com_ref"].tolist()
    wx, wy, _ = observation["com_vel_ref"].tolist()
    omega = math.sqrt(GRAVITY / max(cz, 0.05))
    shift_x = -GAIN_X * ((cx + vx / omega) - (rx + wx / omega))  # δ [m]
    shift_y = -GAIN_Y * ((cy + vy / omega) - (ry + wy / omega))
    forces, soles = observation["foot_force"], observation["sole"]
    for foot in (0, 1):
        if forces[foot, 2] < MIN_LOAD:
            continue
        h = max(cz - float(soles[foot, 2]), 0.05)
        action[_PITCH[foot]] += min(max(-shift_x / h, -MAX_OFFSET), MAX_OFFSET)
        action[_ROLL[foot]] += min(max(shift_y / h, -MAX_OFFSET), MAX_OFFSET)
    return action
