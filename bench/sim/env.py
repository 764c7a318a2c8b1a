"""One trial as a ``dm_env.Environment``: a closed-loop controller drives the bench's biped.

A plain ``dm_env.Environment`` on the model ``playback.build_model`` compiles
(same MJCF, same trial sensors), not a dm_control ``composer`` task: the bench
already owns its MJCF (``model.py``), its sensors (``contact.py``) and its events
(``events.py``), and a composer task would rebuild the scene through its own
entity tree and step it through its own ``Physics``, i.e. a second model to keep
equal to the one the rollout plays. Here both paths step the very same
``MjModel`` with ``mj_step``, so the open-loop plan played through this
environment reproduces ``playback.play`` to the last bit (``tests/sim/test_env.py``).

Episode (times on the walk's clock, walk start = 0): ``reset()`` places the robot
at the plan's first pose (``playback.initial_state``) and settles it for
``settle`` seconds commanding that pose, exactly as a trial does; then every
``step(action)`` applies ``action`` as the actuators' command for one control
period of one simulation step (``trial.timestep``), through the walk and the
``hold`` after it. The episode ends (``LAST``) when that time is up (discount 1),
at a fall (``events.py``'s criterion; discount 0; only with ``end_at_fall``), or when
MuJoCo warns (bad acceleration, a reset; discount 0), where ``mujoco.rollout``
stops too. Reward: 1 per period the robot has not fallen.

Action: the ``nu`` actuator commands (position targets [rad], MJCF joint order
``joints.MJCF_JOINTS``), a ``BoundedArray`` of the actuators' ``ctrlrange``; a value
beyond it is clamped by MuJoCo as it is in the rollout. A wrong shape or a
non-finite value raises ``ActionError``.

Observation (a dict of float64 arrays, vectors in the slope frame S, joints in
``MJCF_JOINTS`` order). Joint and pelvis states are the current state; contact
forces, CoP and CoM come from the forward pass of the last simulation step (what
a force sensor reports over the last period, 1 step old; the recording's row):

* ``time`` (): walk time [s] of the current state.
* ``q``, ``qd`` (8,): joint angles [rad] and rates [rad/s].
* ``q_ref``, ``qd_ref``, ``tau_ff`` (8,): the plan's joint angles, rates and
  Newton-Euler torques [N m] at ``time``; ``ctrl_ref`` (nu,): the open-loop command
  the rollout sends for the coming period (the plan's references; ``open_loop``).
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

``recording()`` turns what was simulated so far into a ``playback.Recording``, the
same object ``playback.play`` returns, so events, the ZMP comparison, reports and
recordings follow unchanged (``trial.run_trial`` with a ``controller``).
"""

from __future__ import annotations

import dm_env
import mujoco
import numpy as np
from dm_env import specs

from bench.sim.contact import FOOT_GEOMS, MAX_CONTACTS, NON_FOOT_BODIES
from bench.sim.events import FALL_HEIGHT_FRACTION
from bench.sim.model import servo_settings
from bench.sim.playback import (
    _STATE,
    HOLD_TIME,
    SETTLE_TIME,
    Recording,
    build_model,
    control_sequence,
    initial_state,
    recording_from_rollout,
)
from planner.errors import SlopewalkError
from planner.joints import MJCF_JOINTS, SIDE_PREFIX, stance_swing_to_left_right
from planner.kinematics import rotation_slope_to_world
from planner.plan import Plan, plan_walk
from planner.spec import RobotSpec, load_spec

_CTRL = mujoco.mjtState.mjSTATE_CTRL


class ActionError(SlopewalkError):
    """An action that is not ``nu`` finite numbers."""


def open_loop(observation: dict) -> np.ndarray:
    """The open-loop playback as a policy: the plan's command for the coming period."""
    return observation["ctrl_ref"]


class TrialEnv(dm_env.Environment):
    """One trial of the bench as a ``dm_env.Environment`` (see module doc).

    Args:
        spec: The robot (default: the paper's biped).
        trial: Gait, μ, actuator mode, timestep (default: the nominal 1 s gait on flat ground).
        plan: The trial's plan, if already made (``plan_walk(spec, trial.gait)``).
        end_at_fall: End the episode at a fall (else play the whole trial, as the rollout).
        settle, hold: Hold times before and after the walk [s].
    """

    def __init__(
        self,
        spec: RobotSpec | None = None,
        trial=None,
        *,
        plan: Plan | None = None,
        end_at_fall: bool = True,
        settle: float = SETTLE_TIME,
        hold: float = HOLD_TIME,
    ):
        from bench.sim.trial import TrialSpec  # trial.py runs controllers through this module

        spec = spec if spec is not None else load_spec()
        trial = trial if trial is not None else TrialSpec(_nominal(spec))
        self.trial, self.spec = trial, spec
        self.plan = plan if plan is not None else plan_walk(spec, trial.gait)
        self.end_at_fall = end_at_fall
        dt = trial.timestep
        self.model = build_model(
            self.plan, friction=trial.friction, actuators=trial.actuators, timestep=dt
        )
        self.data = mujoco.MjData(self.model)
        self._initial = initial_state(self.model, self.plan)
        self._t, self._ctrl_ref = control_sequence(self.plan, dt, settle, hold)
        self._settle_rows = int(np.count_nonzero(self._t < 0))
        self._R = rotation_slope_to_world(self.plan.params.slope)
        self._force_limit = servo_settings(spec, trial.actuators).force_limit
        self._references()
        self._sensor_indices()
        m, nstate = self._t.size, mujoco.mj_stateSize(self.model, _STATE)
        self._state = np.empty((m, nstate))
        self._sensordata = np.empty((m, self.model.nsensordata))
        self._ctrl = np.empty((m, self.model.nu))
        self._row = 0
        self._needs_reset = True
        self._ended: str | None = None
        self._warnings = self.data.warning.number  # live view of MuJoCo's warning counters
        lo, hi = self.model.actuator_ctrlrange.T
        self._action_spec = specs.BoundedArray(
            (self.model.nu,), np.float64, lo.copy(), hi.copy(), name="ctrl"
        )
        self._observation_spec = _observation_spec(self.model.nu)

    # ---- dm_env.Environment ----

    def reset(self) -> dm_env.TimeStep:
        """Put the robot at the plan's first pose and settle it; the FIRST step at walk time 0."""
        mujoco.mj_resetData(self.model, self.data)
        mujoco.mj_setState(self.model, self.data, self._initial, _STATE)
        self._row = 0
        self._needs_reset = False
        self._ended = None
        for k in range(self._settle_rows):
            if self._advance(self._ctrl_ref[k]):
                break
        return dm_env.restart(self._observation())

    def step(self, action) -> dm_env.TimeStep:
        """Command ``action`` for one control period (see module doc)."""
        if self._needs_reset:
            return self.reset()
        if self._ended is None:
            self._advance(self._checked(action))
        observation = self._observation()
        if self._ended is None and self._row < self._t.size:
            return dm_env.transition(1.0, observation)
        self._needs_reset = True
        if self._ended is None:
            return dm_env.truncation(1.0, observation)
        return dm_env.termination(0.0, observation)

    def action_spec(self) -> specs.BoundedArray:
        return self._action_spec

    def observation_spec(self) -> dict:
        return self._observation_spec

    # ---- the bench's side ----

    @property
    def ended(self) -> str | None:
        """Why the episode ended early: "fall", "diverged", or None."""
        return self._ended

    def recording(self) -> Recording:
        """What was simulated since ``reset()``, as ``playback.play`` records it."""
        k = self._row
        return recording_from_rollout(
            self.model,
            self._state[:k],
            self._sensordata[:k],
            self._t[:k],
            self._ctrl[:k],
            self._R,
            self._force_limit,
        )

    def _checked(self, action) -> np.ndarray:
        try:
            action = np.asarray(action, dtype=float)
        except (TypeError, ValueError):
            raise ActionError(f"action {str(action)[:40]!r}: not an array of numbers") from None
        if action.shape != (self.model.nu,):
            raise ActionError(f"action of shape {action.shape}: must be ({self.model.nu},)")
        if not np.isfinite(action).all():
            raise ActionError(f"action {np.array2string(action, precision=4)}: must be finite")
        return action

    def _advance(self, ctrl) -> bool:
        """One simulation step commanding ``ctrl``, recorded as the rollout records it.

        Returns True when the episode ends here (``self._ended`` says why).
        """
        k, model, data = self._row, self.model, self.data
        mujoco.mj_setState(model, data, ctrl, _CTRL)
        mujoco.mj_step(model, data)
        mujoco.mj_getState(model, data, self._state[k], _STATE)
        self._sensordata[k] = data.sensordata
        self._ctrl[k] = ctrl
        self._row = k + 1
        if self._warnings.any():  # mujoco.rollout stops stepping and repeats this row
            self._state[k + 1 :] = self._state[k]
            self._sensordata[k + 1 :] = data.sensordata
            self._ctrl[k + 1 :] = ctrl
            self._row, self._ended = self._t.size, "diverged"
            return True
        if self.end_at_fall and self._fallen():
            self._ended = "fall"
            return True
        return self._row >= self._t.size

    def _fallen(self) -> bool:
        """``events.py``'s fall: a non-foot body on the plane, or the pelvis too low."""
        sd = self.data.sensordata
        if sd[self._touch].any():
            return True
        return float(sd[self._pelvis] @ self._R[:, 2]) < self._fall_height

    # ---- observations ----

    def _references(self) -> None:
        """The plan's series on the control rows (clamped at both ends, like the command)."""
        plan, t = self.plan, self._t

        def on_rows(x):
            x = np.asarray(x, float).reshape(plan.t.size, -1)
            return np.column_stack([np.interp(t, plan.t, x[:, j]) for j in range(x.shape[1])])

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

    def _sensor_indices(self) -> None:
        model = self.model

        def block(name):
            i = model.sensor(name).id
            return np.arange(model.sensor_adr[i], model.sensor_adr[i] + model.sensor_dim[i])

        self._contacts = np.concatenate([block(f"{g}_contacts") for g in FOOT_GEOMS])
        self._net = np.concatenate([block(f"{g}_net") for g in FOOT_GEOMS])
        self._soles = np.concatenate([block(f"{p}sole_pos") for p in SIDE_PREFIX])
        normals = np.concatenate([block(f"{p}foot_zaxis") for p in SIDE_PREFIX])
        self._vectors = np.concatenate([self._net, self._soles, normals])
        self._touch = np.concatenate([block(f"{b}_touch") for b in NON_FOOT_BODIES])
        self._pelvis = block("pelvis_pos")
        self._fall_height = FALL_HEIGHT_FRACTION * self.plan.params.hip_height
        joints = [model.joint(name) for name in MJCF_JOINTS]
        self._qpos = np.array([model.jnt_qposadr[j.id] for j in joints])
        self._qvel = np.array([model.jnt_dofadr[j.id] for j in joints])
        self._robot = model.body("pelvis").id  # the robot's root: its subtree CoM is the CoM
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, np.ascontiguousarray(self._R).reshape(-1))
        self._world_to_slope = np.array([quat[0], -quat[1], -quat[2], -quat[3]])
        spec = self.spec
        constants = {
            "ctrl_gain": np.tile(self.model.actuator_gainprm[:, 0], (self._t.size, 1)),
            "foot_size": np.tile(
                [spec.ankle_to_toe, spec.heel_offset, spec.foot_width / 2], (self._t.size, 1)
            ),
        }
        # every per-row value side by side, so an observation copies one row and slices it
        columns = {**self._scalar_ref, **self._ref, "ctrl_ref": self._ctrl_ref, **constants}
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

    def _observation(self) -> dict:
        data, R = self.data, self._R
        k = min(self._row, self._t.size - 1)
        sd = data.sensordata
        contacts = sd[self._contacts].reshape(2, MAX_CONTACTS, 7)
        normal = contacts[..., 1] * (contacts[..., 0] > 0)  # (2, k) normal forces
        load = normal.sum(axis=1)  # (2,)
        # one rotation into S: contact-weighted points, nets, soles, normals, CoM, its velocity
        vectors = np.empty((9, 3))
        np.matmul(normal[:, None, :], contacts[..., 4:7], out=vectors[0:2, None, :])
        vectors[2:8] = sd[self._vectors].reshape(6, 3)
        vectors[8] = data.subtree_com[self._robot]
        mujoco.mj_subtreeVel(self.model, data)  # subtree_linvel of the last forward pass
        in_slope = np.vstack([vectors, data.subtree_linvel[self._robot]]) @ R
        weighted, sole = in_slope[0:2], in_slope[4:6]
        foot_cop = sole[:, :2].copy()
        if load[0] > 0:
            foot_cop[0] = weighted[0, :2] / load[0]
        if load[1] > 0:
            foot_cop[1] = weighted[1, :2] / load[1]
        total = load[0] + load[1]
        cop = (weighted[0, :2] + weighted[1, :2]) / total if total > 0 else sole[:, :2].mean(0)
        pelvis_quat = np.empty(4)
        mujoco.mju_mulQuat(pelvis_quat, self._world_to_slope, data.qpos[3:7])
        row = self._rows[k].copy()  # the plan's references and the constants at this row
        obs = {name: row[view] for name, view in self._row_views}
        obs.update(
            q=data.qpos[self._qpos],
            qd=data.qvel[self._qvel],
            foot_force=-in_slope[2:4],
            foot_cop=foot_cop,
            cop=cop,
            sole=sole,
            foot_normal=in_slope[6:8],
            com=in_slope[8],
            com_vel=in_slope[9],
            pelvis_quat=pelvis_quat,
            pelvis_angvel=data.qvel[3:6].copy(),
        )
        return obs


def _nominal(spec: RobotSpec):
    from planner.trajectory import GaitParams

    return GaitParams.nominal(spec, 1.0)


def _observation_spec(nu: int) -> dict:
    """Names, shapes and dtypes of the observation (module doc)."""
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
