"""Sensors that record a trial, and the simulated ZMP (CoP) decoded from them.

Everything a trial needs is a MuJoCo sensor, so one ``sensordata`` row per step
holds it and ``mujoco.rollout`` can run whole trials in C; decoding is
vectorised afterwards (``decode``). Sensors (``add_trial_sensors``):

* per foot, a ``<contact>`` sensor listing up to ``MAX_CONTACTS`` foot-floor
  contacts, each with its force in the contact frame (normal first) and its
  point; and a second one reducing them to the net force (world frame);
* per non-foot body, whether it touches the floor (for ``fall``);
* sole sites and pelvis positions, the feet's z and x axes, the 8 joint angles and
  the 8 actuator torques.

MuJoCo facts this relies on (each checked in ``tests/test_contact.py`` against
``data.contact`` and ``mj_contactForce``):

* the contact frame's first axis is the normal; a sensor whose first object is
  the foot reports the normal force as the first force component, ≥ 0;
* the net-force sensor gives the force of the foot on the floor in world axes;
  the ground force on the foot is its negative;
* contact points lie midway inside the penetration, so they are projected onto
  the plane along its normal before the CoP is taken;
* the CoP of forces on the plane is Σ f_n,i p_i / Σ f_n,i (tangential forces act
  in the plane and add no tangential moment about it). The net-force sensor's
  own ``pos`` is weighted by the whole force magnitude, which is not the CoP
  once friction is loaded (3.7 mm off for a rolled foot), so it is not used.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from slopewalk.planner.joints import MJCF_JOINTS, SIDE_PREFIX

FOOT_GEOMS = tuple(f"{p}foot" for p in SIDE_PREFIX)
NON_FOOT_BODIES = ("pelvis",) + tuple(
    f"{p}{link}" for p in SIDE_PREFIX for link in ("thigh", "shank", "ankle")
)
MAX_CONTACTS = 8  # per foot; a box on a plane makes at most 4
_FOUND, _FORCE, _POS = 1, 2, 16  # mjtConDataField bits
_MINDIST, _NETFORCE = 1, 3  # mjtReduce
_SENSOR = mujoco.mjtSensor
_OBJ = mujoco.mjtObj


JOINT_SIGN = "slopewalk_joint_sign"  # numeric of an imported model: each MJCF joint's sign


def add_trial_sensors(mjs: mujoco.MjSpec, floor: str = "floor") -> None:
    """Add every sensor a trial records to a scene spec (see module doc)."""
    for geom in FOOT_GEOMS:
        mjs.add_sensor(
            name=f"{geom}_contacts",
            type=_SENSOR.mjSENS_CONTACT,
            objtype=_OBJ.mjOBJ_GEOM,
            objname=geom,
            reftype=_OBJ.mjOBJ_GEOM,
            refname=floor,
            intprm=[_FOUND | _FORCE | _POS, _MINDIST, MAX_CONTACTS],
        )
        mjs.add_sensor(
            name=f"{geom}_net",
            type=_SENSOR.mjSENS_CONTACT,
            objtype=_OBJ.mjOBJ_GEOM,
            objname=geom,
            reftype=_OBJ.mjOBJ_GEOM,
            refname=floor,
            intprm=[_FORCE, _NETFORCE, 1],
        )
    for body in NON_FOOT_BODIES:
        mjs.add_sensor(
            name=f"{body}_touch",
            type=_SENSOR.mjSENS_CONTACT,
            objtype=_OBJ.mjOBJ_BODY,
            objname=body,
            reftype=_OBJ.mjOBJ_GEOM,
            refname=floor,
            intprm=[_FOUND, _NETFORCE, 1],
        )
    for p in SIDE_PREFIX:
        mjs.add_sensor(
            name=f"{p}sole_pos",
            type=_SENSOR.mjSENS_FRAMEPOS,
            objtype=_OBJ.mjOBJ_SITE,
            objname=f"{p}sole",
        )
        mjs.add_sensor(
            name=f"{p}foot_zaxis",
            type=_SENSOR.mjSENS_FRAMEZAXIS,
            objtype=_OBJ.mjOBJ_XBODY,
            objname=f"{p}foot",
        )
        mjs.add_sensor(
            name=f"{p}foot_xaxis",
            type=_SENSOR.mjSENS_FRAMEXAXIS,
            objtype=_OBJ.mjOBJ_XBODY,
            objname=f"{p}foot",
        )
    mjs.add_sensor(
        name="pelvis_pos", type=_SENSOR.mjSENS_FRAMEPOS, objtype=_OBJ.mjOBJ_XBODY, objname="pelvis"
    )
    mjs.add_sensor(
        name="pelvis_quat",
        type=_SENSOR.mjSENS_FRAMEQUAT,
        objtype=_OBJ.mjOBJ_XBODY,
        objname="pelvis",
    )
    for joint in MJCF_JOINTS:
        mjs.add_sensor(
            name=f"{joint}_pos",
            type=_SENSOR.mjSENS_JOINTPOS,
            objtype=_OBJ.mjOBJ_JOINT,
            objname=joint,
        )
        mjs.add_sensor(
            name=f"{joint}_torque",
            type=_SENSOR.mjSENS_ACTUATORFRC,
            objtype=_OBJ.mjOBJ_ACTUATOR,
            objname=joint,
        )


@dataclass(frozen=True)
class TrialSensors:
    """Decoded sensor series of a trial; vectors in the slope frame S.

    Attributes:
        q: Joint angles, MJCF order [rad], (m, 8).
        actuator_force: Actuator torques, MJCF order [N m], (m, 8).
        foot_force: Ground force on each foot (left, right) [N], (m, 2, 3).
        foot_cop: CoP under each foot on the plane [m], (m, 2, 2), NaN when unloaded.
        cop: CoP of both feet together [m], (m, 2), NaN when neither is loaded.
        sole: Sole sites [m], (m, 2, 3).
        foot_normal: Each foot's z axis, (m, 2, 3); (0, 0, 1) when flat on the plane.
        foot_axis_x: Each foot's x axis, (m, 2, 3): its heading in the plane (``walk_check``).
        pelvis_height: Pelvis origin above the plane [m], (m,).
        pelvis_qpos: Pelvis free-joint pose in the world (position, quaternion wxyz), (m, 7);
            with ``q`` it is the full ``qpos`` for replaying the motion (recordings).
        touching: A non-foot body touches the plane, (m,).
    """

    q: np.ndarray
    actuator_force: np.ndarray
    foot_force: np.ndarray
    foot_cop: np.ndarray
    cop: np.ndarray
    sole: np.ndarray
    foot_normal: np.ndarray
    foot_axis_x: np.ndarray
    pelvis_height: np.ndarray
    pelvis_qpos: np.ndarray
    touching: np.ndarray


def decode(model: mujoco.MjModel, sensordata: np.ndarray, rotation_slope_to_world) -> TrialSensors:
    """Turn rows of ``sensordata`` (m, nsensordata) into ``TrialSensors`` in S."""
    R = np.asarray(rotation_slope_to_world)  # row vectors: v_S = v_W @ R

    def block(name):
        i = mujoco.mj_name2id(model, _OBJ.mjOBJ_SENSOR, name)  # model.sensor(name): 10x slower
        adr, dim = model.sensor_adr[i], model.sensor_dim[i]
        return sensordata[:, adr : adr + dim]

    per_contact = np.stack(
        [block(f"{g}_contacts").reshape(-1, MAX_CONTACTS, 7) for g in FOOT_GEOMS], axis=1
    )  # (m, 2, k, found|f(3)|pos(3))
    normal = np.where(per_contact[..., 0] > 0, per_contact[..., 1], 0.0)  # (m, 2, k)
    points = per_contact[..., 4:7] @ R  # in S; z_S ≈ 0 (inside the penetration) is dropped
    load = normal.sum(axis=-1)  # (m, 2)
    with np.errstate(invalid="ignore", divide="ignore"):
        foot_cop = np.einsum("mfk,mfki->mfi", normal, points[..., :2]) / load[..., None]
        cop = np.einsum("mfk,mfki->mi", normal, points[..., :2]) / load.sum(-1)[:, None]
    foot_cop[load <= 0] = np.nan
    cop[load.sum(-1) <= 0] = np.nan
    foot_force = -np.stack([block(f"{g}_net") for g in FOOT_GEOMS], axis=1) @ R
    q = np.column_stack([block(f"{j}_pos") for j in MJCF_JOINTS])
    torque = np.column_stack([block(f"{j}_torque") for j in MJCF_JOINTS])
    # an imported model's joints have signs of their own (robot_import.scene); the twin has
    # the planner's (asked by id: model.numeric's KeyError cost 0.4 ms a trial)
    signs = mujoco.mj_name2id(model, _OBJ.mjOBJ_NUMERIC, JOINT_SIGN)
    if signs >= 0:
        sign = model.numeric(signs).data
        q, torque = q * sign, torque * sign
    return TrialSensors(
        q=q,
        actuator_force=torque,
        foot_force=foot_force,
        foot_cop=foot_cop,
        cop=cop,
        sole=np.stack([block(f"{p}sole_pos") for p in SIDE_PREFIX], axis=1) @ R,
        foot_normal=np.stack([block(f"{p}foot_zaxis") for p in SIDE_PREFIX], axis=1) @ R,
        foot_axis_x=np.stack([block(f"{p}foot_xaxis") for p in SIDE_PREFIX], axis=1) @ R,
        pelvis_height=block("pelvis_pos") @ R[:, 2],
        pelvis_qpos=np.column_stack([block("pelvis_pos"), block("pelvis_quat")]),
        touching=np.asarray(
            np.column_stack([block(f"{b}_touch") for b in NON_FOOT_BODIES]).any(axis=1)
        ),
    )
