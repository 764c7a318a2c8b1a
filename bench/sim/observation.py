"""What a controller sees of a trial: the observation of ``env.TrialEnv``, named arrays.

Every vector is in the slope frame S, every joint in ``joints.MJCF_JOINTS`` order,
float64. Joint and pelvis states are the current state; contact forces, CoP and
CoM come from the forward pass of the last simulation step (what a force sensor
reports over the last period, 1 step old; the row the recording stores). The
plan's references are those of the coming control row, clamped at both ends of the
trial like the open-loop command.

* ``time`` (): walk time [s] of the current state.
* ``q``, ``qd`` (8,): joint angles [rad] and rates [rad/s].
* ``q_ref``, ``qd_ref``, ``tau_ff`` (8,): the plan's joint angles, rates and
  Newton-Euler torques [N m] at ``time``; ``ctrl_ref`` (nu,): the open-loop command
  the rollout sends for the coming period (the plan's references, shifted by
  τ_ff / kp in a feedforward mode; ``open_loop``).
* ``zmp_ref`` (2,) [m], ``com_ref`` (3,) [m]: the plan's multibody ZMP and CoM.
* ``foot_force`` (2, 3) [N]: ground force on each foot (left, right).
* ``foot_cop`` (2, 2) [m]: CoP under each foot on the plane; a foot with no
  normal load reports its sole point (the ankle's projection), never NaN.
* ``cop`` (2,) [m]: CoP of both feet; the soles' midpoint when neither is loaded.
* ``sole`` (2, 3) [m]: each foot's sole point (under the ankle); ``foot_normal`` (2, 3):
  each foot's z axis, (0, 0, 1) when flat on the plane.
* ``com`` (3,) [m], ``com_vel`` (3,) [m/s]: whole-body centre of mass and its velocity;
  ``com_vel_ref`` (3,) [m/s]: the plan's CoM velocity (finite differences of ``com_ref``).
* ``pelvis_quat`` (4,): pelvis orientation relative to S (w, x, y, z).
* ``pelvis_angvel`` (3,) [rad/s]: pelvis angular velocity in the pelvis frame.
* ``stance`` (): planned stance leg, 0 left / 1 right; ``double_support`` (): 1 in DSP.
* ``phase`` () in [0, 1]: progress through the current step (DSP then SSP).
* constants of the robot, for controllers that work in torques or on the foot:
  ``ctrl_gain`` (nu,) [N m/rad], each position actuator's kp (a command offset δ
  changes its torque by kp·δ); ``foot_size`` (3,) [m], the sole's reach from the
  sole point: to the toe, to the heel, and half its width.
"""

from __future__ import annotations

import mujoco
import numpy as np
from dm_env import specs

from slopewalk.bench.sim import playback
from slopewalk.bench.sim.contact import FOOT_GEOMS, MAX_CONTACTS
from slopewalk.planner.joints import MJCF_JOINTS, SIDE_PREFIX, stance_swing_to_left_right
from slopewalk.planner.kinematics import rotation_slope_to_world
from slopewalk.planner.plan import Plan


def sensor_indices(model: mujoco.MjModel, *names: str) -> np.ndarray:
    """Indices into ``sensordata`` of the named sensors' values, in order."""
    return np.concatenate(
        [
            np.arange(model.sensor_adr[i], model.sensor_adr[i] + model.sensor_dim[i])
            for i in (model.sensor(name).id for name in names)
        ]
    )


class Observer:
    """Builds observations of one trial's model and plan (module doc).

    Args:
        model: The trial's model (``playback.build_model``, with the trial sensors).
        data: The data it is stepped in; ``observer(row)`` reads it.
        plan: The trial's plan.
        t: Walk time of each control row [s], (m,).
        ctrl_ref: The open-loop command of each row, (m, nu).
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        plan: Plan,
        t: np.ndarray,
        ctrl_ref: np.ndarray,
    ):
        self.model, self.plan, self._data = model, plan, data
        self._R = rotation_slope_to_world(plan.params.slope)
        joints = [model.joint(name) for name in MJCF_JOINTS]
        self._q = np.array([model.jnt_qposadr[j.id] for j in joints])
        self._qd = np.array([model.jnt_dofadr[j.id] for j in joints])
        robot = model.body("pelvis").id  # the robot's root: its subtree CoM is the CoM
        # views into ``data`` (valid for its life: MuJoCo never moves its arrays)
        self._sensordata, self._qpos, self._qvel = data.sensordata, data.qpos, data.qvel
        self._com_in_world = data.subtree_com[robot]
        self._com_vel_in_world = data.subtree_linvel[robot]
        self._pelvis_quat_in_world = data.qpos[3:7]
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, np.ascontiguousarray(self._R).reshape(-1))
        self._world_to_slope = np.array([quat[0], -quat[1], -quat[2], -quat[3]])
        self._t0, self._dt = t[0], model.opt.timestep  # t[k] = k dt - settle = t0 + k dt
        self._references(t)
        self._indices(t, ctrl_ref)

    def _references(self, t) -> None:
        """The plan's series on the control rows (clamped at both ends, like the command)."""
        plan = self.plan

        def on_rows(x):
            return playback.on_rows(t, plan, x)

        idx = np.clip(np.searchsorted(plan.t, t), 0, plan.t.size - 1)
        stance = plan.stance[idx]
        self._ref = {
            "q_ref": on_rows(plan.q_left_right),
            "qd_ref": stance_swing_to_left_right(on_rows(plan.qd), stance),
            "tau_ff": stance_swing_to_left_right(on_rows(plan.tau), stance),
            "zmp_ref": on_rows(plan.zmp),
            "com_ref": on_rows(plan.com),
            "com_vel_ref": on_rows(np.gradient(plan.com, plan.t, axis=0)),
        }
        step_time = plan.params.step_time
        progress = np.clip(t, 0.0, plan.t[-1]) / step_time
        self._scalar_ref = {
            "time": t,
            "stance": stance.astype(float),
            "double_support": plan.double_support[idx].astype(float),
            "phase": np.clip(progress - np.floor(progress), 0.0, 1.0),
        }

    def _indices(self, t, ctrl_ref) -> None:
        model = self.model
        contacts = sensor_indices(model, *(f"{g}_contacts" for g in FOOT_GEOMS))
        vectors = sensor_indices(
            model,
            *(f"{g}_net" for g in FOOT_GEOMS),
            *(f"{p}sole_pos" for p in SIDE_PREFIX),
            *(f"{p}foot_zaxis" for p in SIDE_PREFIX),
        )
        self._sensors, self._ncontact = np.concatenate([contacts, vectors]), contacts.size
        self._vectors = np.empty((10, 3))  # scratch: the world-frame vectors of one observation
        spec = self.plan.spec
        constants = {
            "ctrl_gain": np.tile(model.actuator_gainprm[:, 0], (t.size, 1)),
            "foot_size": np.tile(
                [spec.ankle_to_toe, spec.heel_offset, spec.foot_width / 2], (t.size, 1)
            ),
        }
        # every per-row value side by side, so an observation copies one row and slices it
        columns = {**self._scalar_ref, **self._ref, "ctrl_ref": ctrl_ref, **constants}
        blocks, self._row_views, start = [], [], 0
        for name, values in columns.items():
            values = np.asarray(values, float)
            shape = values.shape[1:]
            width = int(np.prod(shape))
            blocks.append(values.reshape(values.shape[0], width))
            view = start if not shape else slice(start, start + width)
            self._row_views.append((name, view))
            start += width
        self._rows = np.hstack(blocks)

    def __call__(self, row_index: int) -> dict:
        """The observation of the data after ``row_index`` control rows (module doc)."""
        k = min(row_index, self._rows.shape[0] - 1)
        raw = self._sensordata[self._sensors]  # foot contacts, then nets, soles, normals
        contacts = raw[: self._ncontact].reshape(2, MAX_CONTACTS, 7)
        normal = contacts[..., 1] * (contacts[..., 0] > 0)  # (2, k) normal forces
        load_left, load_right = normal.sum(axis=1).tolist()
        # one rotation into S: contact-weighted points, nets, soles, normals, CoM, its velocity
        vectors = self._vectors
        np.matmul(normal[:, None, :], contacts[..., 4:7], out=vectors[0:2, None, :])
        vectors[2:8] = raw[self._ncontact :].reshape(6, 3)
        vectors[8] = self._com_in_world
        mujoco.mj_subtreeVel(self.model, self._data)  # subtree_linvel of the last forward pass
        vectors[9] = self._com_vel_in_world
        in_slope = vectors @ self._R
        weighted, sole = in_slope[0:2, :2], in_slope[4:6]
        foot_cop = sole[:, :2].copy()
        if load_left > 0:
            foot_cop[0] = weighted[0] / load_left
        if load_right > 0:
            foot_cop[1] = weighted[1] / load_right
        total = load_left + load_right
        cop = (weighted[0] + weighted[1]) / total if total > 0 else sole[:, :2].mean(axis=0)
        pelvis_quat = np.empty(4)
        mujoco.mju_mulQuat(pelvis_quat, self._world_to_slope, self._pelvis_quat_in_world)
        row = self._rows[k].copy()  # the plan's references and the constants at this row
        obs = {name: row[view] for name, view in self._row_views}
        if row_index > k:  # past the last row: the state's own time, references held
            obs["time"] = np.float64(self._t0 + row_index * self._dt)
        obs["q"] = self._qpos[self._q]
        obs["qd"] = self._qvel[self._qd]
        obs["foot_force"] = -in_slope[2:4]
        obs["foot_cop"] = foot_cop
        obs["cop"] = cop
        obs["sole"] = sole
        obs["foot_normal"] = in_slope[6:8]
        obs["com"] = in_slope[8]
        obs["com_vel"] = in_slope[9]
        obs["pelvis_quat"] = pelvis_quat
        obs["pelvis_angvel"] = self._qvel[3:6].copy()
        return obs

    def spec(self) -> dict:
        """Names, shapes and dtypes of the observation (module doc)."""
        nu = self.model.nu
        shapes = {
            "time": (),
            "stance": (),
            "double_support": (),
            "phase": (),
            "q_ref": (8,),
            "qd_ref": (8,),
            "tau_ff": (8,),
            "zmp_ref": (2,),
            "com_ref": (3,),
            "q": (8,),
            "qd": (8,),
            "ctrl_ref": (nu,),
            "foot_force": (2, 3),
            "foot_cop": (2, 2),
            "cop": (2,),
            "sole": (2, 3),
            "foot_normal": (2, 3),
            "com": (3,),
            "com_vel": (3,),
            "com_vel_ref": (3,),
            "ctrl_gain": (nu,),
            "foot_size": (3,),
            "pelvis_quat": (4,),
            "pelvis_angvel": (3,),
        }
        bounded = {"stance": (0.0, 1.0), "double_support": (0.0, 1.0), "phase": (0.0, 1.0)}
        out = {}
        for name, shape in shapes.items():
            if name in bounded:
                out[name] = specs.BoundedArray(shape, np.float64, *bounded[name], name=name)
            else:
                out[name] = specs.Array(shape, np.float64, name=name)
        return out
