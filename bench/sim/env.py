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
stops too. Reward: 1 per period, so with ``end_at_fall`` the return counts the
periods the robot stayed up.

Action: the ``nu`` actuator commands (position targets [rad], MJCF joint order
``joints.MJCF_JOINTS``), a ``BoundedArray`` of the actuators' ``ctrlrange``; a value
beyond it is clamped by MuJoCo as it is in the rollout. A wrong shape or a
non-finite value raises ``ActionError``.

Observation: a dict of named float64 arrays in the slope frame, listed with their
units in ``observation.py`` (joints, the plan's references, per-foot ground force
and CoP, CoM, pelvis orientation, stance and phase).

``recording()`` turns what was simulated so far into a ``playback.Recording``, the
same object ``playback.play`` returns, so events, the ZMP comparison, reports and
recordings follow unchanged (``trial.run_trial`` with a ``controller``).

``physics``: the same ``MjData`` as a ``dm_control.mujoco.Physics`` (named indexing,
rendering), where dm_control is installed and works with the MuJoCo installed
(``dm_physics.py``; slopewalk does not depend on it); else one line that says why.
"""

from __future__ import annotations

import dm_env
import mujoco
import numpy as np
from dm_env import specs

from slopewalk.bench.sim.contact import NON_FOOT_BODIES
from slopewalk.bench.sim.dm_physics import shared_physics
from slopewalk.bench.sim.events import FALL_HEIGHT_FRACTION
from slopewalk.bench.sim.floor import SoftFloor
from slopewalk.bench.sim.model import servo_settings
from slopewalk.bench.sim.observation import Observer, sensor_indices
from slopewalk.bench.sim.playback import (
    _STATE,
    HOLD_TIME,
    SETTLE_TIME,
    Recording,
    build_model,
    control_sequence,
    initial_state,
    recording_from_rollout,
)
from slopewalk.bench.sim.trial_spec import TrialSpec
from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.kinematics import rotation_slope_to_world
from slopewalk.planner.plan import Plan, plan_walk
from slopewalk.planner.spec import RobotSpec, load_spec

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
        servo = servo_settings(spec, trial.actuators)  # a "_ff" mode's command carries τ_ff / kp
        floor = SoftFloor.of_scene(self.model)  # a "_ff" mode answers the floor's give and sink
        self._t, self._ctrl_ref = control_sequence(self.plan, dt, settle, hold, servo, floor=floor)
        self._settle_rows = int(np.count_nonzero(self._t < 0))
        self._R = rotation_slope_to_world(self.plan.params.slope)
        self._force_limit = servo.force_limit
        self._observe = Observer(self.model, self.data, self.plan, self._t, self._ctrl_ref)
        self._touch = sensor_indices(self.model, *(f"{b}_touch" for b in NON_FOOT_BODIES))
        self._pelvis = sensor_indices(self.model, "pelvis_pos")
        self._fall_height = FALL_HEIGHT_FRACTION * self.plan.params.hip_height
        m, nstate = self._t.size, mujoco.mj_stateSize(self.model, _STATE)
        self._state = np.empty((m, nstate))
        self._sensordata = np.empty((m, self.model.nsensordata))
        self._ctrl = np.empty((m, self.model.nu))
        self._row = 0
        self._needs_reset = True
        self._ended: str | None = None
        # live views into the data (MuJoCo never moves its arrays)
        self._warnings = self.data.warning.number  # MuJoCo's warning counters
        self._ctrl_in_data, self._sensordata_in_data = self.data.ctrl, self.data.sensordata
        lo, hi = self.model.actuator_ctrlrange.T
        self._action_spec = specs.BoundedArray(
            (self.model.nu,), np.float64, lo.copy(), hi.copy(), name="ctrl"
        )
        self._observation_spec = self._observe.spec()
        self._physics = None  # made on first use of ``physics``

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
        return dm_env.restart(self._observe(self._row))

    def step(self, action) -> dm_env.TimeStep:
        """Command ``action`` for one control period (see module doc)."""
        if self._needs_reset:
            return self.reset()
        if self._ended is None:
            self._advance(self._checked(action))
        observation = self._observe(self._row)
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
    def physics(self):
        """This environment's ``MjData`` itself as a ``dm_control.mujoco.Physics``.

        Raises:
            dm_physics.PhysicsUnavailable: dm_control is not installed, or does not
                work with the MuJoCo installed (one line saying which).
        """
        if self._physics is None:
            self._physics = shared_physics(self.data)
        return self._physics

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
        self._ctrl_in_data[:] = ctrl  # what mj_setState(..., mjSTATE_CTRL) writes
        mujoco.mj_step(model, data)
        mujoco.mj_getState(model, data, self._state[k], _STATE)
        self._sensordata[k] = self._sensordata_in_data
        self._ctrl[k] = ctrl
        self._row = k + 1
        if self._warnings.any():  # mujoco.rollout stops stepping and repeats this row
            self._state[k + 1 :] = self._state[k]
            self._sensordata[k + 1 :] = self._sensordata_in_data
            self._ctrl[k + 1 :] = ctrl
            self._row, self._ended = self._t.size, "diverged"
            return True
        if self.end_at_fall and self._fallen():
            self._ended = "fall"
            return True
        return self._row >= self._t.size

    def _fallen(self) -> bool:
        """``events.py``'s fall: a non-foot body on the plane, or the pelvis too low."""
        sd = self._sensordata_in_data
        if sd[self._touch].any():
            return True
        return float(sd[self._pelvis] @ self._R[:, 2]) < self._fall_height


def _nominal(spec: RobotSpec):
    from slopewalk.planner.gait import GaitParams

    return GaitParams.nominal(spec, 1.0)
