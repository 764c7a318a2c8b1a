"""What ``stiff``'s and ``servo_ff``'s commands lack, term by term, for ``cop_error``.

* ``ladder_section``: ``stiff`` with the position loop's missing terms added to its
  command one at a time (``LADDER``): the floor's give and sink, kv q̇ / kp (the
  velocity gain acting on the planned speed, as a D term on the error would), A q̈ / kp
  (the rotor inertia the stiff mode keeps from the servo), and τ / kp (the
  Newton–Euler torque's static lag): with all four the command is ``stiff_ff``'s, bit
  for bit (the loop's 50 N m are never reached, so nothing is clipped);
* ``friction_section``: ``servo_ff``'s early landing and the joints' dry friction: the
  walk with MuJoCo's friction loss, without it, and with f s / kp added to the command
  (s ``flat_walk.friction_sign``, with or without a still joint's last sign held),
  flat and on a slope.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from slopewalk.bench.experiments.cop_error.flat_walk import FRICTION, STEP_TIME, STEPS, run_case
from slopewalk.bench.sim.model import servo_settings
from slopewalk.bench.sim.playback import LOOP_TERMS
from slopewalk.bench.sim.support import touch_downs
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import Plan, plan_walk
from slopewalk.planner.spec import RobotSpec

# What ``stiff`` adds to the plan's angles, one term at a time: (terms of ``lead``, the
# floor fed forward, label). The last rung is stiff_ff's command.
LADDER = (
    ((), "rigid", "the plan's angles (stiff)"),
    ((), "sink", "+ the floor's give and sink"),
    (("rate",), "sink", "+ kv q̇ / kp (the velocity gain on the error)"),
    (("rate", "rotor"), "sink", "+ A q̈ / kp (the rotor's inertia)"),
    (LOOP_TERMS, "sink", "+ τ / kp (the static lag): stiff_ff"),
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
        "(`flat_walk.lead_torque`), to the plan's angles; the floor's give and sink are "
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
