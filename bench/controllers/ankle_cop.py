"""Stance-ankle CoP feedback: ankle torque corrections that keep each foot's CoP on target.

For a foot flat on the plane, loaded by the normal force F_n, the ankle torque τ
about the joint's axis puts the CoP at (sole frame, sole point = origin)

    x_cop = τ_pitch / F_n,        y_cop = −τ_roll / F_n

(moment balance of the foot about its ankle; positive pitch turns the toe down,
positive roll is about +x). Target: the plan's ZMP, clipped into the foot shrunk by
``MARGIN`` (the plan may ask for a ZMP the foot cannot hold, which is where the
open-loop foot tips). With the error e = cop_f − target_f of each loaded foot f,
the torque that moves its CoP by −G·e is

    Δτ_pitch = −G · F_n · e_x,    Δτ_roll = +G · F_n · e_y,

and a position actuator of gain kp gets it from a command offset Δq = Δτ / kp.
Once the CoP sits on an edge the foot starts to roll about it and the CoP error
stops growing, so a second term undoes a loaded foot's measured tilt off the plane
(φ_pitch = atan2(n_x, n_z), φ_roll = atan2(−n_y, n_z) from its normal n in S):
the ankle yields instead of levering the foot up (ankle compliance),

    Δq_pitch = −G · F_n · e_x / kp − K · φ_pitch,
    Δq_roll  = +G · F_n · e_y / kp − K · φ_roll,

each clipped to ±``MAX_OFFSET``. All other joints follow the plan (``ctrl_ref``).
"""

from __future__ import annotations

import math

import numpy as np

GAIN = 0.5  # G: share of the CoP error corrected per period
MARGIN = 0.008  # [m] the target stays this far inside the sole
FLATTEN = 0.3  # K: share of a loaded foot's tilt off the plane undone per period
MIN_LOAD = 0.5  # [N] a foot carrying less is left to the plan
MAX_OFFSET = 0.3  # [rad]
_PITCH, _ROLL = (2, 6), (3, 7)  # ankle pitch / roll of the left, right leg (MJCF order)


def ankle_cop_feedback(observation: dict) -> np.ndarray:
    """Actuator command: the plan's, plus each loaded ankle's CoP correction (module doc)."""
    action = observation["ctrl_ref"].copy()
    toe, heel, half_width = (observation["foot_size"] - MARGIN).tolist()
    zmp_x, zmp_y = observation["zmp_ref"].tolist()
    gain = observation["ctrl_gain"]
    forces, soles = observation["foot_force"], observation["sole"]
    cops, normals = observation["foot_cop"], observation["foot_normal"]
    for foot in (0, 1):
        load = float(forces[foot, 2])
        if load < MIN_LOAD:
            continue
        sole_x, sole_y, _ = soles[foot].tolist()
        error_x = cops[foot, 0] - min(max(zmp_x, sole_x - heel), sole_x + toe)
        error_y = cops[foot, 1] - min(max(zmp_y, sole_y - half_width), sole_y + half_width)
        nx, ny, nz = normals[foot].tolist()
        pitch, roll = _PITCH[foot], _ROLL[foot]
        d_pitch = -GAIN * load * error_x / gain[pitch] - FLATTEN * math.atan2(nx, nz)
        d_roll = GAIN * load * error_y / gain[roll] - FLATTEN * math.atan2(-ny, nz)
        action[pitch] += min(max(d_pitch, -MAX_OFFSET), MAX_OFFSET)
        action[roll] += min(max(d_roll, -MAX_OFFSET), MAX_OFFSET)
    return action
