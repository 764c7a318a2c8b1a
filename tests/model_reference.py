"""MuJoCo on a user's original model as the reference for an imported spec.

Nothing here calls the planner: ``ModelReference`` poses the original model (compiled
from its file) at the planner's joint angles (Table-I order, each model joint at its
sign times the planner's angle, held joints at their angles) and reports, in the slope
frame S of the stance foot, points carried by the model's bodies, the CoM of body sets,
and, on a copy with the held joints welded (``welded_model``), the joint torques and
ground wrench of ``mj_inverse`` for a motion with the stance foot fixed.

S for a stance foot: origin at the sole point under its ankle centre, axes the base
body's at the reference pose carried rigidly by the foot (the foot lies flat on the
plane in S, as the planner's stance foot does).
"""

from __future__ import annotations

import mujoco
import numpy as np

from slopewalk.bench.robot_import.fit import BaseFrame, Fit, posed

SIDES = ("left", "right")
STANCE_KINDS = ("ankle_roll", "ankle_pitch", "knee", "hip_pitch")
SWING_KINDS = ("hip_pitch", "knee", "ankle_pitch", "ankle_roll")


def table_i(stance: int) -> list[tuple[str, str]]:
    """(side, joint kind) of each entry of the planner's q, Table-I order."""
    st, sw = SIDES[stance], SIDES[1 - stance]
    return [(st, k) for k in STANCE_KINDS] + [(sw, k) for k in SWING_KINDS]


def welded_model(fit: Fit) -> mujoco.MjModel:
    """The original model with every held joint removed at its held angle (welded), a free
    root joint (added where the model fixes its base to the world, e.g. a URDF), and no
    armature, damping, friction loss or constraints: the rigid multibody of the spec."""
    mjs = mujoco.MjSpec.from_file(fit.path)
    for joint in list(mjs.joints):
        if joint.name in fit.held:
            body = joint.parent
            angle = fit.held[joint.name]
            quat = np.zeros(4)
            mujoco.mju_axisAngle2Quat(quat, np.asarray(joint.axis, float), angle)
            R = np.zeros(9)
            mujoco.mju_quat2Mat(R, quat)
            R_body = np.zeros(9)
            mujoco.mju_quat2Mat(R_body, np.asarray(body.quat, float))
            p = np.asarray(joint.pos, float)
            body.pos = np.asarray(body.pos) + R_body.reshape(3, 3) @ (p - R.reshape(3, 3) @ p)
            new = np.zeros(4)
            mujoco.mju_mulQuat(new, np.asarray(body.quat, float), quat)
            body.quat = new
            mjs.delete(joint)
    base = mjs.body(fit.model.body(fit.base).name)
    if not any(j.type == mujoco.mjtJoint.mjJNT_FREE for j in base.joints):
        base.add_freejoint()
    for actuator in list(mjs.actuators):
        mjs.delete(actuator)
    model = mjs.compile()
    model.dof_armature[:] = 0
    model.dof_damping[:] = 0
    model.dof_frictionloss[:] = 0
    model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    return model


class ModelReference:
    """Poses of the original (or welded) model at the planner's q (module doc)."""

    def __init__(self, fit: Fit, model: mujoco.MjModel | None = None):
        self.fit = fit
        self.model = fit.model if model is None else model
        self.data = mujoco.MjData(self.model)
        ref = posed(fit.model, fit.qpos)
        self.base0 = BaseFrame(ref, fit.base)
        self._ref = ref
        self.hinges = {}
        for side in SIDES:
            for kind, joint in fit.legs[side].items():
                j = self.model.joint(joint.name)
                self.hinges[side, kind] = (j.qposadr[0], j.dofadr[0], joint.sign)

    def body(self, name_or_id) -> int:
        name = name_or_id if isinstance(name_or_id, str) else self.fit.model.body(name_or_id).name
        return self.model.body(name).id

    def pose(self, q: np.ndarray, stance: int) -> None:
        """Set and compute the model at the planner's ``q`` (Table-I order, (8,))."""
        data = self.data
        if self.model is self.fit.model:
            data.qpos[:] = self.fit.qpos
        else:
            data.qpos[:] = self.model.qpos0
        for (side, kind), value in zip(table_i(stance), q, strict=True):
            adr, _, sign = self.hinges[side, kind]
            data.qpos[adr] = sign * value
        mujoco.mj_kinematics(self.model, data)
        mujoco.mj_comPos(self.model, data)

    def slope_frame(self, stance: int) -> tuple[np.ndarray, np.ndarray]:
        """(S axes in the world (3, 3), S origin in the world (3,)) at the current pose."""
        foot = self.fit.feet[SIDES[stance]]
        b = self.body(foot)
        R0 = self._ref.xmat[foot].reshape(3, 3)
        R_foot = self.data.xmat[b].reshape(3, 3)
        R_S = R_foot @ R0.T @ self.base0.R
        ankle = self.fit.ankle_centre(SIDES[stance])
        sole0 = self.base0.R @ (ankle - [0, 0, self.fit.geometry["ankle_height"]]) + self.base0.p
        local = R0.T @ (sole0 - self._ref.xpos[foot])
        return R_S, self.data.xpos[b] + R_foot @ local

    def carried_point(self, body: int, point_in_base: np.ndarray, stance: int) -> np.ndarray:
        """In S: the point at ``point_in_base`` (base frame, reference pose) carried by ``body``."""
        world0 = self.base0.R @ point_in_base + self.base0.p
        local = self._ref.xmat[body].reshape(3, 3).T @ (world0 - self._ref.xpos[body])
        b = self.body(body)
        world = self.data.xpos[b] + self.data.xmat[b].reshape(3, 3) @ local
        R_S, o_S = self.slope_frame(stance)
        return R_S.T @ (world - o_S)

    def center_of_mass(self, bodies, stance: int) -> np.ndarray:
        """In S: the CoM of the model's ``bodies`` (ids in the original model)."""
        ids = [self.body(b) for b in bodies]
        m = self.model.body_mass[ids]
        world = (m[:, None] * self.data.xipos[ids]).sum(axis=0) / m.sum()
        R_S, o_S = self.slope_frame(stance)
        return R_S.T @ (world - o_S)

    def inverse(self, q, qd, qdd, stance: int, gravity_in_slope) -> tuple[np.ndarray, np.ndarray]:
        """``mj_inverse`` with the stance foot fixed: (torques Table-I order [N m], ground force
        on the stance foot in S [N]). Needs the welded model (a free root, 8 hinges).

        The base's velocity and acceleration are those that keep the stance foot still
        (J v = 0, J a + J̇ v = 0); ``qfrc_inverse`` = τ + Jᵀ w with w the ground wrench at the
        stance sole point, whose 6 base rows give w."""
        model, data = self.model, self.data
        self.pose(q, stance)
        R_S, o_S = self.slope_frame(stance)
        model.opt.gravity[:] = R_S @ gravity_in_slope
        foot = self.body(self.fit.feet[SIDES[stance]])
        hinge_dofs = [self.hinges[k][1] for k in table_i(stance)]
        signs = np.array([self.hinges[k][2] for k in table_i(stance)])
        base_dofs = [d for d in range(model.nv) if d not in hinge_dofs]
        J = np.zeros((6, model.nv))
        mujoco.mj_jac(model, data, J[:3], J[3:], o_S, foot)
        data.qvel[:] = 0
        data.qvel[hinge_dofs] = signs * qd
        data.qvel[base_dofs] = np.linalg.solve(
            J[:, base_dofs], -J[:, hinge_dofs] @ data.qvel[hinge_dofs]
        )
        mujoco.mj_comVel(model, data)
        Jdot = np.zeros((6, model.nv))
        mujoco.mj_jacDot(model, data, Jdot[:3], Jdot[3:], o_S, foot)
        data.qacc[:] = 0
        data.qacc[hinge_dofs] = signs * qdd
        rhs = -J[:, hinge_dofs] @ data.qacc[hinge_dofs] - Jdot @ data.qvel
        data.qacc[base_dofs] = np.linalg.solve(J[:, base_dofs], rhs)
        mujoco.mj_inverse(model, data)
        qfrc = data.qfrc_inverse
        wrench = np.linalg.solve(J[:, base_dofs].T, qfrc[base_dofs])
        tau = signs * (qfrc[hinge_dofs] - J[:, hinge_dofs].T @ wrench)
        return tau, R_S.T @ wrench[:3]


def held_at_first_pose(scene, plan, *, actuators: str, steps: int):
    """The scene's model and data after ``steps`` 1 ms steps from the plan's first pose,
    each actuator commanded to hold it (``ModelScene.initial_state``/``controls``)."""
    model = scene.build(plan, friction=1.0, actuators=actuators, timestep=1e-3)
    data = mujoco.MjData(model)
    state = scene.initial_state(model, plan)
    mujoco.mj_setState(model, data, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    data.ctrl[:] = scene.controls(model, plan.q_left_right[0])[0]
    for _ in range(steps):
        mujoco.mj_step(model, data)
    return model, data
