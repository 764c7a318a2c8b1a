"""Where the simulated CoP leaves the analytic ZMP: the error of a slow flat walk by phase.

``cop_error_report(spec)`` plays flat ground at 2 s steps (μ 1, 4 steps) and writes
markdown that takes the CoP − ZMP distance (``trial.compare``'s, over the samples
where the robot stands) apart:

* by phase window (``phase_windows``): the first and last ``WINDOW`` of each single
  support (after lift-off, before touch-down), the first ``WINDOW`` of each double
  support that starts with a touch-down, and the rest of each phase; per window its
  share of the samples, RMS, max and share of the mean square (the windows partition
  the samples, so the shares add up to the total);
* the cases: ``stiff`` (positions only), ``stiff`` with the floor's give and sink fed
  forward (``playback.floor_feedforward``, no torque), ``stiff_ff`` (torque, give and sink:
  the swing sole lands at the planned touch-down, ``bench.sim.touchdown``), ``stiff_ff``
  with the give fed forward but not the sink, and ``stiff_ff`` with its ankles aimed as
  on a rigid floor (torque only); per case each swing foot's first contact against the
  planned touch-down and its normal velocity there (``support.touch_downs``), and the
  unplanned support split into foot-time touching while planned lifted and lifted while
  planned down, the latter on the landing and the unloading foot of each double support;
* the servo's sag in ``stiff``: the stance leg's joints late in single support lag their
  command by (τ + kv q̇) / kp, which a positions-only mode keeps (``stiff_ff`` feeds it
  forward);
* what the plan's angles need to track in ``stiff``, added to the command one term at a
  time (``LADDER``): the floor's give and sink, kv q̇ / kp (the velocity gain acting on
  the planned speed, as a D term on the error would), A q̈ / kp (the rotor inertia the
  stiff mode keeps from the servo), and τ / kp (the Newton–Euler torque's static lag):
  with all four the command is ``stiff_ff``'s, bit for bit (the loop's 50 N m are never
  reached, so nothing is clipped);
* the plan's own ZMP jumps at the phase changes (its lean's cubic changes λ̈ there);
* ``servo_ff``'s early landing and the joints' dry friction (``friction_section``): the
  walk with MuJoCo's friction loss, without it, and with f s / kp added to the command
  (s ``friction_sign``, with or without a still joint's last sign held), flat and on a
  slope;
* the soft contact: the same walks with MuJoCo's contact time constant (``solref``,
  0.02 s by default) and time step made smaller (a stiffer floor, finer steps);
* double support: how far the plan moves its rear sole sideways there
  (``planner.verdict``'s ``foot_slide``), how far the simulated foot slides, and the
  share of the double support that foot spends at the friction limit.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import mujoco
import numpy as np
from mujoco import rollout

from bench.report.landing import landing_section
from bench.sim.floor import SoftFloor
from bench.sim.model import Servo, servo_settings
from bench.sim.playback import (
    HOLD_TIME,
    SETTLE_TIME,
    Recording,
    build_model,
    commands_and_aim,
    floor_feedforward,
    initial_state,
    on_rows,
    recording_from_rollout,
)
from bench.sim.support import touch_downs
from bench.sim.trial import TrialResult, TrialSpec, compare
from planner.joints import LEFT, stance_swing_to_left_right
from planner.kinematics import rotation_slope_to_world
from planner.plan import Plan, plan_walk
from planner.spec import RobotSpec
from planner.trajectory import GaitParams

WINDOW = 0.05  # [s] the transient after / before a phase change
STEP_TIME, FRICTION, STEPS = 2.0, 1.0, 4
# (actuator mode, the floor fed forward (None: as the mode does), label); the floor's
# feedforward: "rigid" none, "give" the ankles' turns, "sink" the give and the sink
CASES = (
    ("stiff", None, "stiff"),
    ("stiff", "sink", "stiff, the floor's give and sink fed forward"),
    ("stiff_ff", None, "stiff_ff"),
    ("stiff_ff", "give", "stiff_ff, the give fed forward, not the sink"),
    ("stiff_ff", "rigid", "stiff_ff, ankles aimed as on a rigid floor"),
)
# What ``stiff`` adds to the plan's angles, one term at a time: (terms of ``lead``, the
# floor fed forward, label). The last rung is stiff_ff's command.
LADDER = (
    ((), "rigid", "the plan's angles (stiff)"),
    ((), "sink", "+ the floor's give and sink"),
    (("rate",), "sink", "+ kv q̇ / kp (the velocity gain on the error)"),
    (("rate", "rotor"), "sink", "+ A q̈ / kp (the rotor's inertia)"),
    (("torque", "rotor", "rate"), "sink", "+ τ / kp (the static lag): stiff_ff"),
)
# servo_ff and the joints' dry friction: (friction loss as the spec's, the friction fed
# forward: None, "moving" (0 where the plan holds a joint still) or "held", label)
FRICTION_CASES = (
    (True, None, "servo_ff"),
    (False, None, "servo_ff, the joints' friction loss 0"),
    (True, "moving", "+ f s / kp, s the sign of the planned speed"),
    (True, "held", "+ f s / kp, a still joint's last sign held"),
)
FRICTION_SLOPES = (0.0, np.deg2rad(10.0))  # [rad]
REST = 1e-9  # a joint is still below this share of its peak planned speed (roundoff)
# (solref time constant [s], time step [s]); MuJoCo keeps the time constant ≥ 2 steps
CONTACTS = ((0.02, 0.001), (0.02, 0.00025), (0.01, 0.0005), (0.005, 0.00025), (0.002, 0.00025))
WINDOWS = (
    "single support, first 50 ms",
    "single support, middle",
    "single support, last 50 ms",
    "double support, first 50 ms after touch-down",
    "double support, rest",
)


@dataclass(frozen=True)
class Case:
    """One simulated walk and its comparison with the plan."""

    label: str
    result: TrialResult
    recording: Recording


def lead_torque(plan: Plan, servo: Servo, terms: tuple[str, ...]) -> np.ndarray:
    """The torque whose static lag / kp ``terms`` add to the command, MJCF order [N m],
    (n, 8) on ``plan.t``: "torque" τ (Newton–Euler), "rotor" A q̈, "rate" (d + kv) q̇,
    summed in the order given (``playback.feedforward_stance_swing`` sums torque, rotor,
    rate: in that order the sum is its, unclipped)."""
    term = {
        "torque": lambda: plan.tau,
        "rotor": lambda: servo.armature * plan.qdd,
        "rate": lambda: (servo.damping + servo.kv) * plan.qd,
    }
    total = np.zeros_like(plan.q)
    for k, name in enumerate(terms):
        total = term[name]() if k == 0 else total + term[name]()
    return stance_swing_to_left_right(total, plan.stance)


def friction_sign(qd: np.ndarray, *, held: bool) -> np.ndarray:
    """Sign of the motion each joint's dry friction resists, (n, k): the planned speed's,
    0 where the plan holds the joint still; with ``held`` the sign of its last motion
    there (0 before its first).

    A position loop with dry friction f stops a joint short of its command, at the edge
    of the deadband f / kp it approached from; pushing from that side puts it on its
    command, if the load has not moved it across the band since. Still is |q̇| ≤ ``REST``
    × the joint's peak |q̇|: the splines' roundoff (the lean's rate is ±1e-15 rad/s at
    each lift-off, against 0.1-2 rad/s when it moves), whose sign is noise.
    """
    qd = np.asarray(qd, dtype=float)
    peak = np.abs(qd).max(axis=0, initial=0.0)
    s = np.where(np.abs(qd) > REST * peak, np.sign(qd), 0.0)
    if not held:
        return s
    rows = np.arange(s.shape[0])[:, None]
    last = np.maximum.accumulate(np.where(s != 0, rows, 0), axis=0)  # last moving row
    return np.take_along_axis(s, last, axis=0)


def simulate(
    plan: Plan,
    actuators: str,
    *,
    floor_ff: str | None = None,
    leads: tuple[str, ...] = (),
    joint_friction: bool = True,
    friction_ff: str | None = None,
    timeconst: float | None = None,
    timestep: float = 0.001,
) -> Recording:
    """Play ``plan`` as ``playback.play`` does, with the contacts' solref time constant
    ``timeconst`` [s] and step ``timestep`` [s].

    Args:
        floor_ff: What of the floor's deflection the command answers, also in a mode
            without feedforward: "rigid" nothing, "give" the ankles turned against each
            sole's give, "sink" that and the legs shortened by the soles' sink
            (``playback.floor_feedforward``); None: as the mode does ("sink" in a "_ff"
            mode, "rigid" otherwise).
        leads: ``lead_torque``'s terms, / kp, added to the command of a mode without
            feedforward before the floor's offsets (the order in which
            ``commands_and_aim`` adds a "_ff" mode's).
        joint_friction: False: the joints' friction loss set to 0 in MuJoCo.
        friction_ff: The dry friction f added to the command as f s / kp: None none,
            "moving" or "held" (``friction_sign``'s ``held``).
    """
    model = build_model(plan, friction=FRICTION, actuators=actuators, timestep=timestep)
    if timeconst is not None:
        model.geom_solref[:, 0] = timeconst  # floor and feet: the contact's is theirs
    servo = servo_settings(plan.spec, actuators)
    floor = SoftFloor.of_scene(model)
    own = "sink" if servo.feedforward else "rigid"
    t, q_ref, aim = commands_and_aim(
        plan, timestep, SETTLE_TIME, HOLD_TIME, servo, floor if floor_ff in (None, own) else None
    )
    if leads:
        if servo.feedforward:
            raise ValueError(f"leads {leads!r}: only for a mode without feedforward")
        q_ref = q_ref + on_rows(t, plan, lead_torque(plan, servo, leads)) / servo.kp
    if not joint_friction:
        model.dof_frictionloss[:] = 0.0
    if friction_ff is not None:
        sign = friction_sign(plan.qd, held=friction_ff == "held")
        friction = stance_swing_to_left_right(servo.frictionloss * sign, plan.stance)
        q_ref = q_ref + on_rows(t, plan, friction) / servo.kp
    if floor_ff not in (None, own, "rigid"):
        aim = on_rows(t, plan, floor_feedforward(plan, floor, touchdown=floor_ff == "sink"))
        q_ref = q_ref + aim
    state, sensordata = rollout.rollout(
        model, mujoco.MjData(model), initial_state(model, plan), q_ref[None]
    )
    return recording_from_rollout(
        model,
        state[0],
        sensordata[0],
        t,
        q_ref,
        rotation_slope_to_world(plan.params.slope),
        servo.force_limit,
        aim_offset=aim,
    )


def run_case(plan: Plan, actuators: str, label: str, **options) -> Case:
    """``simulate``'s walk compared with the plan as ``slopewalk trial`` does."""
    recording = simulate(plan, actuators, **options)
    trial = TrialSpec(plan.params, friction=FRICTION, actuators=actuators)
    return Case(label, compare(plan, trial, recording, wall_s=0.0), recording)


def phase_windows(plan: Plan, t: np.ndarray) -> np.ndarray:
    """Index into ``WINDOWS`` of each time ``t`` [s] of the walk, (m,)."""
    idx = np.clip(np.searchsorted(plan.t, t), 0, plan.t.size - 1)
    double = plan.double_support[idx]
    change = plan.t[np.flatnonzero(np.diff(plan.double_support.astype(int))) + 1]
    k = np.searchsorted(change, t, side="right")  # changes at or before t
    since = np.where(k > 0, t - change[np.maximum(k - 1, 0)], np.inf)
    until = np.where(k < change.size, change[np.minimum(k, change.size - 1)] - t, np.inf)
    window = np.where(since < WINDOW, 0, np.where(until < WINDOW, 2, 1))
    return np.where(double, np.where(since < WINDOW, 3, 4), window)


def by_window(case: Case, plan: Plan) -> list[tuple[str, float, float, float, float]]:
    """(window, share of samples, RMS [m], max [m], share of the mean square) per window."""
    s = case.result.series
    standing = s["standing"]
    t = s["t"][standing]
    distance = np.hypot(*(s["cop"] - s["zmp_analytic"]).T)[standing]
    window = phase_windows(plan, t)
    total = np.sum(distance**2)
    rows = []
    for w, name in enumerate(WINDOWS):
        d = distance[window == w]
        if d.size:
            rms = float(np.sqrt(np.mean(d**2)))
            rows.append((name, d.size / t.size, rms, float(d.max()), np.sum(d**2) / total))
    return rows


def zmp_jumps(plan: Plan) -> tuple[float, float, float]:
    """Largest jump of the planned ZMP at a lift-off and at a touch-down, and the
    median change from one sample to the next elsewhere [m]."""
    step = np.hypot(*np.diff(plan.zmp, axis=0).T)
    change = np.diff(plan.double_support.astype(int))
    lift = step[change == -1].max()
    touch = step[change == 1].max()
    return float(lift), float(touch), float(np.median(step[change == 0]))


def double_support_slide(plan: Plan, case: Case) -> tuple[float, float, float]:
    """(planned rear-sole slide, simulated slide of that foot [m], share of the double
    support that foot spends at the friction limit), the largest over the double supports
    that start with a touch-down."""
    rec, s = case.recording, case.recording.sensors
    planned, simulated, limited = 0.0, 0.0, []
    dsp = (1 - plan.params.ssp_fraction) * plan.params.step_time
    for k in range(1, plan.params.steps):
        start = k * plan.params.step_time
        in_plan = (plan.t >= start) & (plan.t < start + dsp)
        planned = max(planned, np.ptp(plan.swing_sole[in_plan, 1]))
        rows = (rec.t >= start) & (rec.t < start + dsp)
        rear = 1 if plan.stance[np.flatnonzero(in_plan)[0]] == LEFT else 0
        simulated = max(simulated, np.ptp(s.sole[rows, rear, 1]))
        force = s.foot_force[rows, rear]
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = np.hypot(force[:, 0], force[:, 1]) / force[:, 2]
        limited.append(np.mean(ratio[force[:, 2] > 0] >= 0.99 * FRICTION))
    return float(planned), float(simulated), float(np.mean(limited))


def friction_section(spec: RobotSpec) -> list[str]:
    """Markdown lines: ``servo_ff``'s landings with and without the joints' dry friction."""
    servo = servo_settings(spec, "servo_ff")
    lines = [
        "",
        "## servo_ff's landing: the joints' dry friction",
        "",
        f"`servo_ff` feeds the torque forward but not the joints' dry friction (the spec's "
        f"friction loss f = {servo.frictionloss:g} N m): a joint comes to rest anywhere in "
        f"its deadband |q_ref − q| ≤ f / kp = {servo.frictionloss / servo.kp * 1e3:.2f} mrad. "
        f"{STEP_TIME:g} s steps, μ {FRICTION:g}, {STEPS} steps; each landing's first contact "
        "against the planned touch-down:",
        "",
        "| slope [°] | command | landings [ms] | RMS [mm] | simulated |",
        "|---|---|---|---|---|",
    ]
    for slope in FRICTION_SLOPES:
        params = replace(GaitParams.nominal(spec, STEP_TIME, steps=STEPS), slope=slope)
        plan = plan_walk(spec, params)
        for joint_friction, friction_ff, label in FRICTION_CASES:
            c = run_case(
                plan,
                "servo_ff",
                label,
                joint_friction=joint_friction,
                friction_ff=friction_ff,
            )
            early, _ = touch_downs(plan, c.recording)
            landings = ", ".join("–" if np.isnan(e) else f"{e * 1e3:+.0f}" for e in early)
            lines.append(
                f"| {np.rad2deg(slope):g} | {label} | {landings} | "
                f"{c.result.zmp_rms * 1e3:.2f} | {c.result.simulated_verdict} |"
            )
    lines += [
        "",
        "Without the friction loss the swing sole lands on time: the early landing is the "
        "deadband. Feeding f forward on the moving joints changes nothing: the joints that "
        "matter are the ones the plan holds still (the ankle rolls while the lean is "
        "held). Holding a still joint's last sign lands some steps on time and others "
        "late: where a joint rests inside its deadband depends on how the load moved it "
        "since it stopped (the real foot's load is not the plan's split at lift-off), "
        "which no command computed from the plan knows. `servo_ff` is left without it.",
    ]
    return lines


def ladder_section(plan: Plan) -> list[str]:
    """Markdown lines: ``stiff`` with ``LADDER``'s terms added to its command one at a time."""
    lines = [
        "",
        "## stiff: what its command lacks, one term at a time",
        "",
        "A position loop reaches its command only where it needs no torque: it lags by "
        "(τ + A q̈ + (d + kv) q̇) / kp. Each row adds one more of those terms, as a position "
        "(`cop_error.lead_torque`), to the plan's angles; the floor's give and sink are "
        "geometry (positions from the planned loads). The last row is stiff_ff's command.",
        "",
        "| command | RMS [mm] | max [mm] | first contact vs planned touch-down [ms] | "
        "normal velocity there [mm/s] | unplanned support [s] | joint tracking of the plan [°] |",
        "|---|---|---|---|---|---|---|",
    ]
    for terms, floor_ff, label in LADDER:
        c = run_case(plan, "stiff", label, floor_ff=floor_ff, leads=terms)
        early, speed = touch_downs(plan, c.recording)
        r, s = c.result, c.result.series
        tracking = (s["q_simulated"] - s["q_planned"])[s["standing"]]
        lines.append(
            f"| {label} | {r.zmp_rms * 1e3:.2f} | {r.zmp_max * 1e3:.1f} | "
            f"{np.nanmean(early) * 1e3:+.0f} | {np.nanmean(speed) * 1e3:+.1f} | "
            f"{r.unplanned_support_s:.3f} | {np.rad2deg(np.sqrt(np.mean(tracking**2))):.3f} |"
        )
    lines += [
        "",
        "Positions alone (every row but the last) leave the static lag τ / kp: the robot "
        "stands lower and turned by it, and the swing foot meets the floor before the "
        "planned touch-down whatever else the command answers. Only the plan's torque "
        "removes it, and a command that carries it is stiff_ff's.",
    ]
    return lines


def cop_error_report(spec: RobotSpec, *, command: str = "") -> str:
    """Markdown of the flat 2 s walk's CoP error, decomposed (module doc)."""
    plan = plan_walk(spec, GaitParams.nominal(spec, STEP_TIME, steps=STEPS))
    cases = [run_case(plan, mode, label, floor_ff=ff) for mode, ff, label in CASES]
    lines = ["# CoP error on flat ground: where the simulated CoP leaves the analytic ZMP", ""]
    if command:
        lines += [f"Written by `{command}`.", ""]
    lines += [
        f"Flat ground, {STEP_TIME:g} s steps, μ {FRICTION:g}, {STEPS} steps, 1 ms; the distance "
        "of `slopewalk trial` (simulated CoP vs analytic ZMP while the robot stands). "
        "Module doc of `bench/report/cop_error.py` for each quantity.",
        "",
        "| case | RMS [mm] | max [mm] | unplanned support [s] (touching / lifted) | first "
        "contact vs planned touch-down [ms] | normal velocity there [mm/s] | joint tracking [°] |",
        "|---|---|---|---|---|---|---|",
    ]
    for c in cases:
        early, speed = touch_downs(plan, c.recording)
        r = c.result
        lines.append(
            f"| {c.label} | {r.zmp_rms * 1e3:.2f} | {r.zmp_max * 1e3:.1f} | "
            f"{r.unplanned_support_s:.3f} ({r.unplanned_contact_s:.3f} / "
            f"{r.missed_contact_s:.3f}) | {np.nanmean(early) * 1e3:+.0f} | "
            f"{np.nanmean(speed) * 1e3:+.1f} | {np.rad2deg(r.tracking_rms):.2f} |"
        )
    fed, plain = cases[2], cases[0]
    lost = [e.time for e in fed.result.events if e.kind in ("tip", "fall", "diverged")]
    lines += landing_section(plan, fed.recording, min(lost, default=np.inf), plain.recording)
    late = {c.label: {n: r for n, _, r, _, _ in by_window(c, plan)} for c in cases[2:4]}
    on_time, early = (late[c.label] for c in cases[2:4])
    lines += [
        "",
        f"Against {cases[3].label}, landing on time moves error out of the last 50 ms before "
        f"touch-down ({early[WINDOWS[2]] * 1e3:.2f} → {on_time[WINDOWS[2]] * 1e3:.2f} mm) into "
        f"the double support ({early[WINDOWS[4]] * 1e3:.2f} → {on_time[WINDOWS[4]] * 1e3:.2f} "
        f"mm; RMS {cases[3].result.zmp_rms * 1e3:.2f} → {fed.result.zmp_rms * 1e3:.2f} mm), and "
        f"its unplanned support from touching early to a landing foot in the air "
        f"({cases[3].result.unplanned_support_s:.3f} → {fed.result.unplanned_support_s:.3f} s).",
    ]
    for c in cases:
        lines += [
            "",
            f"## {c.label}: by phase",
            "",
            "| window | share of samples | RMS [mm] | max [mm] | share of the mean square |",
            "|---|---|---|---|---|",
        ]
        lines += [
            f"| {name} | {share:.1%} | {rms * 1e3:.2f} | {peak * 1e3:.1f} | {part:.0%} |"
            for name, share, rms, peak, part in by_window(c, plan)
        ]
    lines += ladder_section(plan)
    lines += friction_section(spec)
    lift, touch, typical = zmp_jumps(plan)
    lines += [
        "",
        "## The plan's ZMP at the phase changes",
        "",
        f"The planned ZMP jumps {touch * 1e3:.1f} mm at a touch-down and {lift * 1e3:.1f} mm "
        f"at a lift-off (elsewhere it moves {typical * 1e3:.2f} mm per 1 ms sample): the lean's "
        "cubic of the double support starts and ends with λ̈ = ±6·(2 tilt)/T_dsp², held at 0 "
        "through the single support, and the ZMP follows the accelerations. The simulated "
        "CoP cannot jump with it (finite servo and floor bandwidth); the first 50 ms after "
        "each change above hold that lag.",
    ]
    lines += [
        "",
        "## A stiffer contact and a finer time step (stiff_ff)",
        "",
        "| solref time constant [s] | time step [ms] | RMS [mm] | single support, middle | "
        "last 50 ms before touch-down | double support, rest | unplanned support [s] |",
        "|---|---|---|---|---|---|---|",
    ]
    for timeconst, timestep in CONTACTS:
        c = run_case(plan, "stiff_ff", "", timeconst=timeconst, timestep=timestep)
        rms = {name: r for name, _, r, _, _ in by_window(c, plan)}
        lines.append(
            f"| {timeconst:g} | {timestep * 1e3:g} | {c.result.zmp_rms * 1e3:.2f} | "
            f"{rms[WINDOWS[1]] * 1e3:.2f} | {rms[WINDOWS[2]] * 1e3:.2f} | "
            f"{rms[WINDOWS[4]] * 1e3:.2f} | {c.result.unplanned_support_s:.3f} |"
        )
    planned, simulated, limited = double_support_slide(plan, cases[2])
    lines += [
        "",
        "A stiffer floor takes the give away (single support converges), but the double "
        "support gets worse, not better: it is not the floor's compliance there.",
        "",
        "## Double support: the plan moves a loaded foot",
        "",
        f"The 8 joints have no hip roll, so the legs stay parallel and perpendicular to the "
        f"pelvis in the frontal plane, and two flat feet fix the lean: cos λ = hip width / "
        f"feet separation. The plan changes the lean in every double support and moves its "
        f"rear sole sideways by up to {planned * 1e3:.1f} mm to allow it; in MuJoCo the feet "
        f"stick, the loops fight, and that foot slides {simulated * 1e3:.1f} mm, at the "
        f"friction limit {limited:.0%} of the double support ({cases[2].label}). What the "
        "CoP does there follows that fight, not the plan's motion, and no command of this "
        "robot removes it without changing the planned motion.",
    ]
    return "\n".join(lines) + "\n"
