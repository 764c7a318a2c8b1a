"""MuJoCo as the reference for the planner's dynamics: ``mj_inverse`` on the stance-rooted model.

``stance_rooted_xml`` builds, from the same ``RobotSpec``, a MuJoCo model rooted at the
stance foot whose world frame is the slope frame S and whose hinge angles are the
planner's q (Table-I order). ``mj_inverse`` then gives the generalized force that
produces a motion: on the hinges the joint torques, on the root free joint the
ground wrench on the stance foot. An external wrench on the swing foot (double
support) enters through MuJoCo's own Jacobian ``mj_jac`` at the swing sole point:
``qfrc_inverse = τ + J_stanceᵀ w_stance + J_swingᵀ w_swing``.

Nothing here calls the planner's recursion; the tests compare the two.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from slopewalk.bench.sim.model import stance_rooted_xml
from slopewalk.planner.joints import JOINT_NAMES, SIDE_PREFIX


@dataclass(frozen=True)
class InverseResult:
    """MuJoCo's inverse dynamics of one sample, vectors in S.

    Attributes:
        tau: Hinge torques [N m], Table-I order, (8,).
        force: Ground force on the stance foot [N], (3,).
        moment: Ground moment on the stance foot about its sole point [N m], (3,).
        swing_sole: Swing sole point (under the swing ankle) [m], (3,).
        omega, omega_dot: Angular velocity [rad/s] and acceleration [rad/s²] of the 9
            chain links (stance foot … swing foot, ``kinematics.CHAIN_LINKS``), (9, 3).
    """

    tau: np.ndarray
    force: np.ndarray
    moment: np.ndarray
    swing_sole: np.ndarray
    omega: np.ndarray
    omega_dot: np.ndarray


class StanceRootedInverse:
    """``mj_inverse`` of the stance-rooted models (both stance sides) under gravity ``gravity``."""

    def __init__(self, spec, gravity):
        self.spec = spec
        self.models, self.datas, self.hinges = [], [], []
        for side in (0, 1):
            model = mujoco.MjModel.from_xml_string(stance_rooted_xml(spec, side))
            model.opt.gravity[:] = gravity  # this model's world frame is S
            self.models.append(model)
            self.datas.append(mujoco.MjData(model))
            self.hinges.append(np.array([model.joint(j).dofadr[0] for j in JOINT_NAMES]))

    def __call__(self, q, qd, qdd, stance, sole, swing_wrench=None) -> InverseResult:
        """Inverse dynamics of one sample.

        Args:
            q, qd, qdd: Joint angles [rad], rates, accelerations, Table-I order, (8,).
            stance: 0 left / 1 right.
            sole: Stance sole point in S [m], (3,).
            swing_wrench: Optional (force [N], moment about the swing sole [N m]) that the
                ground applies to the swing foot, in S.
        """
        model, data, hinges = self.models[stance], self.datas[stance], self.hinges[stance]
        stance_foot = model.body(f"{SIDE_PREFIX[stance]}foot").id
        swing_foot = model.body(f"{SIDE_PREFIX[1 - stance]}foot").id
        data.qpos[:7] = [*(np.asarray(sole) + [0, 0, self.spec.ankle_height]), 1, 0, 0, 0]
        data.qpos[7:] = q
        data.qvel[:] = 0
        data.qacc[:] = 0
        data.qvel[hinges], data.qacc[hinges] = qd, qdd
        mujoco.mj_inverse(model, data)
        mujoco.mj_rnePostConstraint(model, data)  # cacc: body accelerations
        st, sw = SIDE_PREFIX[stance], SIDE_PREFIX[1 - stance]
        links = [st + "foot", st + "ankle", st + "shank", st + "thigh", "pelvis",
                 sw + "thigh", sw + "shank", sw + "ankle", sw + "foot"]  # fmt: skip
        ids = [model.body(name).id for name in links]
        omega, omega_dot = data.cvel[ids, :3].copy(), data.cacc[ids, :3].copy()  # world = S
        qfrc = data.qfrc_inverse.copy()
        R_swing = data.xmat[swing_foot].reshape(3, 3)
        swing_sole = data.xpos[swing_foot] - self.spec.ankle_height * R_swing[:, 2]
        if swing_wrench is not None:
            jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
            mujoco.mj_jac(model, data, jacp, jacr, swing_sole, swing_foot)
            force, moment = (np.asarray(w, dtype=float) for w in swing_wrench)
            qfrc -= jacp.T @ force + jacr.T @ moment
        # Free joint: force in world (= S) axes at the body origin (the ankle centre),
        # moment in the body frame; moved to the sole point here.
        force = qfrc[:3]
        moment_ankle = data.xmat[stance_foot].reshape(3, 3) @ qfrc[3:6]
        moment = moment_ankle + np.cross(data.xpos[stance_foot] - sole, force)
        return InverseResult(qfrc[hinges], force, moment, swing_sole, omega, omega_dot)
