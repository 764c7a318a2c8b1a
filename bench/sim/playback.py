"""Play a planned walk open loop through the MJCF biped's position actuators.

The robot is placed at the plan's first pose with both soles flat on the tilted
plane (the plan is in the slope frame S, whose origin is the world origin), held
there for ``settle`` seconds, then the actuators are driven with the planned
joint angles (linearly interpolated to the simulation step), and finally held at
the last pose for ``hold`` seconds.

The whole trial is one ``mujoco.rollout`` call: the control sequence is known in
advance (open loop) and everything recorded is a sensor (``contact.py``), so
MuJoCo runs it in C and many trials can share threads (``play_many``). Sensor
rows are computed in each step's forward pass, i.e. row k describes the state at
the start of step k; that is the time base used here.

Feedforward modes ("_ff") command more than the planned angles: the plan's torque
over kp (``feedforward_torque``; while settling the first pose's torque at rest,
``settle_feedforward``), and the soft floor's deflection under the planned
loads (``floor_feedforward``, for the compiled scene's contact): the ankles turned
against each sole's give (``floor.give_feedforward``), so the robot stays where the plan
has it, and the legs shortened by the soles' sink (``touchdown``), so the swing sole
lands at the planned touch-down with the plan's zero normal velocity.

Divergence: when MuJoCo meets a bad acceleration it warns and resets the state,
which shows as the rollout's time running backwards; the recording is cut there
and marked ``diverged``. No exception escapes.
"""

from __future__ import annotations

import copy
from collections import OrderedDict
from dataclasses import dataclass

import mujoco
import numpy as np
from mujoco import rollout

from slopewalk.bench.actuators import DEFAULT_MODE
from slopewalk.bench.sim.contact import TrialSensors, add_trial_sensors, decode
from slopewalk.bench.sim.floor import SoftFloor, foot_deflection, give_feedforward
from slopewalk.bench.sim.model import SceneError, Servo, mujoco_message, scene_xml, servo_settings
from slopewalk.bench.sim.touchdown import leg_offsets, leg_shortening
from slopewalk.planner.compliance import torque_at_rest
from slopewalk.planner.joints import stance_swing_to_left_right
from slopewalk.planner.kinematics import Chain, rotation_slope_to_world
from slopewalk.planner.plan import Plan

SETTLE_TIME = 0.5  # [s] hold at the first pose before the walk
HOLD_TIME = 0.5  # [s] hold at the last pose after the walk
_STATE = mujoco.mjtState.mjSTATE_FULLPHYSICS


@dataclass(frozen=True)
class Recording:
    """Simulated series of one trial; time 0 is the start of the planned walk.

    Attributes:
        t: Time of each row [s], (m,).
        q_ref: Actuator commands, MJCF order [rad], (m, 8): the planned angles, plus
            τ_ff / kp in a feedforward mode (``control_sequence``).
        sensors: Decoded sensor series (``contact.TrialSensors``), in S.
        force_limit: Actuator torque limit [N m].
        diverged_at: Time the simulation blew up [s], or None.
        aim_offset: What the command aims the joints at beyond the planned angles, MJCF
            order [rad], (m, 8): a feedforward mode's answer to the floor's give and sink
            (``floor_feedforward``); None: the planned angles themselves (also for a
            closed-loop controller, whose own aim is not known here).
        model_qpos: An imported model's own ``qpos`` after each row, (m, nq), which a
            recording redraws the model from; None on the twin (its 15 coordinates are
            the sensors' pelvis pose and joint angles).
    """

    t: np.ndarray
    q_ref: np.ndarray
    sensors: TrialSensors
    force_limit: float
    diverged_at: float | None
    aim_offset: np.ndarray | None = None
    model_qpos: np.ndarray | None = None


def build_model(plan: Plan, *, friction: float, actuators: str, timestep: float):
    """Compile the scene for ``plan`` (its robot and slope) with the trial sensors.

    A copy of the model compiled for the same scene text, if one of the last
    ``MODELS_KEPT`` was (a sweep's trials share scenes): 0.4 ms instead of 1 ms, and the
    copy is the caller's to change.
    """
    xml = scene_xml(
        plan.spec,
        slope=plan.params.slope,
        friction=friction,
        actuators=actuators,
        timestep=timestep,
    )
    model = _MODELS.get(xml)
    if model is None:
        mjs = mujoco.MjSpec.from_string(xml)
        add_trial_sensors(mjs)
        try:
            model = mjs.compile()
        except ValueError as err:
            raise SceneError(f"MuJoCo refused the model: {mujoco_message(err)}") from None
        _MODELS[xml] = model
        if len(_MODELS) > MODELS_KEPT:
            _MODELS.popitem(last=False)
    else:
        _MODELS.move_to_end(xml)
    return copy.copy(model)


MODELS_KEPT = 16
_MODELS: OrderedDict[str, mujoco.MjModel] = OrderedDict()


def initial_state(model: mujoco.MjModel, plan: Plan) -> np.ndarray:
    """Full physics state with the robot at the plan's first pose, soles on the plane."""
    chain = Chain.from_spec(plan.spec)
    frames = chain.frames(plan.q[:1], plan.stance_sole[:1], plan.stance[:1])
    (pelvis_in_slope,), (pelvis_rotation,) = chain.pelvis_pose(frames, plan.stance[:1])
    R_ws = rotation_slope_to_world(plan.params.slope)
    data = mujoco.MjData(model)
    data.qpos[:3] = R_ws @ pelvis_in_slope
    mujoco.mju_mat2Quat(data.qpos[3:7], (R_ws @ pelvis_rotation).reshape(-1))
    data.qpos[7:15] = plan.q_left_right[0]
    data.ctrl[:] = plan.q_left_right[0]  # the first row of the control sequence replaces it
    mujoco.mj_forward(model, data)
    state = np.empty(mujoco.mj_stateSize(model, _STATE))
    mujoco.mj_getState(model, data, state, _STATE)
    return state


def control_sequence(
    plan: Plan,
    timestep: float,
    settle: float,
    hold: float,
    servo: Servo | None = None,
    *,
    floor: SoftFloor | None = None,
):
    """Row times [s] (walk starts at 0) and commands, MJCF order, (m, 8).

    The command is the planned angle [rad], linearly interpolated to the rows; with a
    feedforward ``servo`` it is shifted by τ_ff / kp (``feedforward_torque``; while
    settling ``settle_feedforward``, the first pose's torque at rest; held at its last
    value while holding), which adds τ_ff to the actuator's
    force (``model.Servo``), and, on a soft floor, by the floor's give and sink
    (``floor_feedforward``).

    Args:
        floor: The scene's foot contact (``floor.SoftFloor.of_scene``); None: a rigid
            floor, nothing to cancel.
    """
    t, q_ref, _ = commands_and_aim(plan, timestep, settle, hold, servo, floor)
    return t, q_ref


def commands_and_aim(
    plan: Plan,
    timestep: float,
    settle: float,
    hold: float,
    servo: Servo | None = None,
    floor: SoftFloor | None = None,
):
    """``control_sequence``'s row times and commands, and what the command aims the joints
    at beyond the plan on those rows (``floor_feedforward``), MJCF order [rad], (m, 8): None
    where the mode aims at the plan itself (no feedforward, or a rigid floor)."""
    t = _rows(plan, timestep, settle, hold)
    q_ref = on_rows(t, plan, plan.q_left_right)
    aim = None
    if servo is not None and servo.feedforward:
        tau_ff = on_rows(t, plan, feedforward_torque(plan, servo))
        tau_ff[: settle_rows(timestep, settle)] = settle_feedforward(plan, servo)
        q_ref += tau_ff / servo.kp
        if floor is not None:
            aim = on_rows(t, plan, floor_feedforward(plan, floor))
            q_ref += aim
    return t, q_ref, aim


def floor_feedforward(plan: Plan, floor: SoftFloor, *, touchdown: bool = True) -> np.ndarray:
    """Joint offsets that answer the soft floor's deflection, MJCF order [rad], (n, 8) on
    ``plan.t``: the ankles turned against each sole's give (``floor.give_feedforward``)
    and, with ``touchdown``, the legs shortened by the soles' sink (``touchdown``)."""
    turn, sink = foot_deflection(plan, floor)
    out = give_feedforward(plan, turn)
    if touchdown:
        out += leg_offsets(plan, leg_shortening(plan, sink))
    return out


def settle_rows(timestep: float, settle: float) -> int:
    """How many of ``_rows``' rows are the settle's (those before the walk's t = 0)."""
    return int(round(settle / timestep))


def _rows(plan: Plan, timestep: float, settle: float, hold: float) -> np.ndarray:
    m = int(round((settle + plan.t[-1] + hold) / timestep))
    return np.arange(m) * timestep - settle


def on_rows(t: np.ndarray, plan: Plan, x: np.ndarray) -> np.ndarray:
    """``x`` (n, ...) on ``plan.t`` interpolated to the rows ``t``, ends held: (m, k), k the
    product of ``x``'s trailing dimensions (1 for a series of scalars)."""
    x = np.asarray(x, float).reshape(plan.t.size, -1)
    return np.column_stack([np.interp(t, plan.t, x[:, j]) for j in range(x.shape[1])])


def feedforward_torque(plan: Plan, servo: Servo) -> np.ndarray:
    """Torque the position loop is fed forward, MJCF order [N m], (n, 8) on ``plan.t``.

    τ_ff = τ (Newton-Euler) + A q̈ (rotor inertia) + (d + kv) q̇: the torque the joint
    needs to follow the plan, plus what the servo's own joint damping d and velocity
    gain kv (which acts on the joint speed, not its error) take away at the planned
    speed; clipped to ±``servo.force_limit``. Dry friction is left out (its sign
    flips with the speed). The actuator's forcerange clips the loop's total again.
    """
    return stance_swing_to_left_right(feedforward_stance_swing(plan, servo), plan.stance)


def settle_feedforward(plan: Plan, servo: Servo) -> np.ndarray:
    """Torque the position loop is fed forward while the robot settles, MJCF order [N m],
    (8,): the torque that holds the first pose at rest (``compliance.torque_at_rest``),
    clipped to ±``servo.force_limit``. Not the walk's first τ_ff: that adds the
    inertial torque and A q̈ of the walk's first acceleration, which grow as 1/T² with
    the step time T and would lean the standing robot before its first step."""
    tau = np.clip(torque_at_rest(plan), -servo.force_limit, servo.force_limit)
    return stance_swing_to_left_right(tau[None], plan.stance[:1])[0]


def feedforward_stance_swing(plan: Plan, servo: Servo) -> np.ndarray:
    """``feedforward_torque`` in the plan's Table-I order [N m], (n, 8)."""
    return np.clip(loop_torque(plan, servo), -servo.force_limit, servo.force_limit)


LOOP_TERMS = ("torque", "rotor", "rate")  # what the loop must deliver, in summing order


def loop_torque(plan: Plan, servo: Servo, terms: tuple[str, ...] = LOOP_TERMS) -> np.ndarray:
    """The sum of ``terms`` of the torque a joint needs to follow the plan, unclipped,
    Table-I order [N m], (n, 8): "torque" τ (Newton-Euler), "rotor" A q̈, "rate"
    (d + kv) q̇, summed in the order given (``LOOP_TERMS``: ``feedforward_torque``'s)."""
    term = {
        "torque": lambda: plan.tau,
        "rotor": lambda: servo.armature * plan.qdd,
        "rate": lambda: (servo.damping + servo.kv) * plan.qd,
    }
    total = np.zeros_like(plan.q)
    for k, name in enumerate(terms):
        total = term[name]() if k == 0 else total + term[name]()
    return total


def play(
    plan: Plan,
    *,
    friction: float = 1.0,
    actuators: str = DEFAULT_MODE,
    timestep: float = 0.001,
    settle: float = SETTLE_TIME,
    hold: float = HOLD_TIME,
    command_noise: float = 0.0,
    noise_seed: int = 0,
    scene=None,
) -> Recording:
    """Simulate ``plan`` and record it (see module doc).

    Args:
        plan: The analytic walk to play.
        friction: Coulomb μ of the feet on the plane, > 0.
        actuators: A mode of ``bench.actuators.MODES``.
        timestep: Simulation step [s].
        settle, hold: Hold times before and after the walk [s].
        command_noise: σ of white noise added to every command row [rad] (``noisy``).
        noise_seed: Seed of that noise.
        scene: Where to play it: None the twin of ``plan.spec``; else an imported model's
            scene (``robot_import.scene.ModelScene``: ``build``, ``controls``,
            ``initial_state``, ``floor``: its soft floor, fed forward as the twin's).
    """
    return play_many(
        [plan],
        friction=[friction],
        actuators=[actuators],
        timestep=timestep,
        settle=settle,
        hold=hold,
        threads=1,
        noise=[(command_noise, noise_seed)],
        scene=scene,
    )[0]


def noisy(q_ref: np.ndarray, sigma: float, seed: int) -> np.ndarray:
    """``q_ref`` (m, 8) [rad] plus independent normal noise of σ ``sigma`` [rad] on every
    entry, drawn from ``numpy.random.default_rng(seed)``; ``q_ref`` itself for σ = 0.

    A probe of the simulation's sensitivity, not a model of anything physical: at 1e-6
    rad it is a thousandth of the loops' own lag, and a verdict it flips was decided by
    the integration's last bits (``slopewalk fidelity`` counts such trials over seeds).
    """
    if sigma == 0:
        return q_ref
    return q_ref + np.random.default_rng(seed).normal(0.0, sigma, q_ref.shape)


def play_many(
    plans,
    *,
    friction,
    actuators,
    timestep=0.001,
    settle=SETTLE_TIME,
    hold=HOLD_TIME,
    threads: int = 1,
    noise=None,
    scene=None,
) -> list[Recording]:
    """Simulate several plans, trials sharing ``threads`` MuJoCo threads.

    Trials with the same scene (robot, slope, friction, actuators) and length
    share one ``rollout`` call; each scene is compiled once. ``noise``: per plan
    (σ [rad], seed) of ``noisy`` on its commands; None: none. ``scene``: ``play``'s.
    """
    groups: dict[tuple, list[int]] = {}
    for i, plan in enumerate(plans):
        rows = _rows(plan, timestep, settle, hold).size
        key = (id(plan.spec), plan.params.slope, friction[i], actuators[i], rows)
        groups.setdefault(key, []).append(i)
    out: dict[int, Recording] = {}
    for (_, _, mu, mode, _), members in groups.items():
        first = plans[members[0]]
        build = build_model if scene is None else scene.build
        model = build(first, friction=mu, actuators=mode, timestep=timestep)
        servo = servo_settings(first.spec, mode)
        floor = SoftFloor.of_scene(model) if scene is None else scene.floor(model)
        controls, aims = [], []
        for i in members:  # the members share a length, so one time base: the last one's
            times, q_ref, aim = commands_and_aim(plans[i], timestep, settle, hold, servo, floor)
            if noise is not None:
                q_ref = noisy(q_ref, *noise[i])
            controls.append(q_ref)
            aims.append(aim)
        played = play_commands(
            model,
            [plans[i] for i in members],
            controls,
            times,
            servo.force_limit,
            aims=aims,
            threads=threads,
            scene=scene,
        )
        out.update(zip(members, played, strict=True))
    return [out[i] for i in range(len(plans))]


def play_commands(
    model: mujoco.MjModel,
    plans,
    controls,
    t: np.ndarray,
    force_limit: float,
    *,
    aims=None,
    threads: int = 1,
    scene=None,
) -> list[Recording]:
    """Play each plan of one scene from its first pose (``initial_state``) with its command.

    The one place a rollout becomes recordings: ``play_many`` and every player that
    chooses its commands itself (``experiments/cop_error``) come through here.

    Args:
        model: The compiled scene of every plan (``build_model``), its slope theirs.
        plans: The plans, all of the same length.
        controls: Per plan its commands, MJCF order [rad], (m, 8) on the rows ``t`` [s].
        force_limit: The actuators' torque limit [N m] (``Recording.force_limit``).
        aims: Per plan ``Recording.aim_offset`` (m, 8) or None; None: None for every plan.
        threads: MuJoCo threads the rollouts share.
        scene: ``play``'s; its ``controls`` turn each command into the model's controls.
    """
    aims = [None] * len(plans) if aims is None else aims
    start = initial_state if scene is None else scene.initial_state
    states = np.array([start(model, plan) for plan in plans])
    datas = [mujoco.MjData(model) for _ in range(max(1, min(threads, len(plans))))]
    ctrl = np.array(controls if scene is None else [scene.controls(model, c) for c in controls])
    state, sensordata = rollout.rollout(model, datas, states, ctrl)
    R_ws = rotation_slope_to_world(plans[0].params.slope)
    return [
        recording_from_rollout(
            model,
            state[row],
            sensordata[row],
            t,
            q_ref,
            R_ws,
            force_limit,
            aim_offset=aim,
            model_qpos=None if scene is None else _qpos_sensed(model, states[row], state[row]),
        )  # fmt: skip
        for row, (q_ref, aim) in enumerate(zip(controls, aims, strict=True))
    ]


def _qpos_sensed(model, start: np.ndarray, states: np.ndarray) -> np.ndarray:
    """``qpos`` (m, nq) as each row's sensors saw it: a rollout's sensor row is computed at
    the start of its step, before the integration that gives its state row, so the qpos of
    row k is that of state k − 1 (of ``start``, the full physics state, for k = 0)."""
    qpos = slice(1, 1 + model.nq)  # mjSTATE_FULLPHYSICS: time, then qpos
    return np.vstack([start[qpos], states[:-1, qpos]])


def recording_from_rollout(
    model, state, sensordata, t, q_ref, rotation_slope_to_world, force_limit, *, aim_offset=None,
    model_qpos=None,
) -> Recording:  # fmt: skip
    """A ``Recording`` from one rollout's states (m, nstate) and sensor rows (m, nsensor).

    A MuJoCo reset (time running backwards) or a non-finite row cuts the series
    there and sets ``diverged_at``. ``aim_offset`` (m, 8): ``Recording.aim_offset``;
    ``model_qpos`` (m, nq): ``Recording.model_qpos``.
    """
    clock = state[:, 0]  # time after each step
    reset = np.flatnonzero(np.diff(clock) <= 0)
    bad = ~np.isfinite(sensordata).all(axis=1) | ~np.isfinite(state).all(axis=1)
    cut = clock.size
    if reset.size:
        cut = int(reset[0]) + 1
    if bad.any():
        cut = min(cut, int(np.argmax(bad)))
    diverged = cut < clock.size
    return Recording(
        t=t[:cut],
        q_ref=q_ref[:cut],
        sensors=decode(model, sensordata[:cut], rotation_slope_to_world),
        force_limit=force_limit,
        diverged_at=float(t[min(cut, t.size - 1)]) if diverged else None,
        aim_offset=None if aim_offset is None else aim_offset[:cut],
        model_qpos=None if model_qpos is None else model_qpos[:cut],
    )
