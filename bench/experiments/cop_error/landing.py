"""The swing foot's landing in a trial: when, how fast, and the support around it.

For ``cop_error``'s report, from one simulated walk against its plan:

* ``lost_contact``: the foot-time a foot is in the air while the plan has it on the
  plane (``support.support_difference``'s missed contact), by the foot's role: the
  landing foot of a double support (the plan's stance foot there), the unloading one
  (the plan's swing foot there), the stance foot of a single support; and the largest
  planned load of the landing foot on its rows in the air;
* ``servo_sag``: the stance leg's joint error (command − angle) over the last
  ``WINDOW`` before each touch-down, against the position loop's static lag under the
  planned load, (τ + (d + kv) q̇) / kp: what a mode that plays positions only keeps, and
  ``stiff_ff`` feeds forward.
"""

from __future__ import annotations

import numpy as np

from slopewalk.bench.sim.floor import foot_loads
from slopewalk.bench.sim.model import Servo, servo_settings
from slopewalk.bench.sim.playback import Recording, loop_torque, on_rows
from slopewalk.bench.sim.support import contact_differences
from slopewalk.planner.joints import LEFT, stance_swing_to_left_right
from slopewalk.planner.plan import Plan

WINDOW = 0.05  # [s] before each touch-down, as cop_error's last window of a single support


def lost_contact(plan: Plan, recording: Recording, until: float = np.inf):
    """(landing, unloading, single support) foot-time in the air while planned down [s],
    and the landing foot's largest planned load on those rows [N], over the walk before
    ``until`` [s] (the first tip, fall or divergence, as ``trial.compare`` counts)."""
    t = recording.t
    standing = (t >= plan.t[0]) & (t <= plan.t[-1]) & (t < until)
    dt = float(np.median(np.diff(t)))
    idx = np.clip(np.searchsorted(plan.t, t - 1e-9), 0, plan.t.size - 1)
    _, air = contact_differences(plan, recording, standing)
    stance_is_left = plan.stance[idx] == LEFT
    stance_foot = np.column_stack([stance_is_left, ~stance_is_left])  # (m, 2)
    double = plan.double_support[idx][:, None]
    landing = air & double & stance_foot
    unloading = air & double & ~stance_foot
    single = air & ~double
    _, load = foot_loads(plan)
    landing_load = load[idx][landing]
    return (
        float(landing.sum() * dt),
        float(unloading.sum() * dt),
        float(single.sum() * dt),
        float(landing_load.max()) if landing_load.size else 0.0,
    )


def servo_sag(plan: Plan, recording: Recording, servo: Servo) -> tuple[np.ndarray, np.ndarray]:
    """Stance hip pitch, knee and ankle pitch error before touch-down: measured and
    (τ + (d + kv) q̇) / kp [rad], (3,) each, means over the last ``WINDOW`` of each single support.
    """
    t = recording.t
    params = plan.params
    before = np.zeros(t.size, dtype=bool)
    for k in range(params.steps):
        touch_down = (k + 1) * params.step_time
        before |= (t >= touch_down - WINDOW) & (t < touch_down)
    idx = np.clip(np.searchsorted(plan.t, t[before] - 1e-9), 0, plan.t.size - 1)
    lag = stance_swing_to_left_right(loop_torque(plan, servo, ("torque", "rate")), plan.stance)
    lag = lag / servo.kp
    command = on_rows(t[before], plan, plan.q_left_right)
    error = command - recording.sensors.q[before]
    predicted = on_rows(t[before], plan, lag)
    right = plan.stance[idx] != LEFT  # the stance leg's hip, knee, ankle pitch in MJCF order
    cols = np.where(right[:, None], np.array([4, 5, 6]), np.array([0, 1, 2]))
    rows = np.arange(cols.shape[0])[:, None]
    return error[rows, cols].mean(axis=0), predicted[rows, cols].mean(axis=0)


def landing_section(plan: Plan, fed: Recording, until: float, plain: Recording) -> list[str]:
    """Markdown lines for ``cop_error``: how the "_ff" modes land on time, where ``fed``
    (stiff_ff, standing until ``until`` [s]) still loses contact, and the servo's sag
    that ``plain`` (stiff, positions only) keeps."""
    weight = plan.spec.total_mass * 9.81
    landing, unloading, single, load = lost_contact(plan, fed, until)
    measured, predicted = servo_sag(plan, plain, servo_settings(plan.spec, "stiff"))
    return [
        "",
        "## Touch-down",
        "",
        "The soft floor turns and sinks each sole under its planned load and CoP (`bench/sim/"
        'floor.py`: the 4 corners\' nonlinear springs of solref/solimp). The "_ff" modes turn '
        "the ankles against the give, and shorten the legs by the sink (`bench/sim/touchdown."
        "py`): in single support the swing sole's target is raised by the stance sole's sink "
        "under its ankle, so it is at its planned height above the real, sunk floor and meets "
        "it at the planned touch-down with the plan's zero normal velocity; through the double "
        "support the landing foot's raise falls as its planned share sinks it (never rising "
        "once it is down), and the unloading foot is never raised before its lift-off.",
        "",
        f"stiff_ff: the feet are in the air while the plan has them down for "
        f"{landing:.3f} s on the landing foot of a double support (its planned load there at "
        f"most {load:.2f} N, {load / weight:.0%} of the weight), {unloading:.3f} s on the "
        f"unloading foot and {single:.3f} s in single support. Landing on time, the front "
        "foot carries what the plan gives it, a share that grows from nothing; the plan's "
        "lean acceleration steps at the touch-down (below), and so do the commands, so "
        "that light foot leaves and retouches the floor.",
        "",
        "stiff plays positions only: late in each single support its stance hip pitch, knee "
        f"and ankle pitch lag their command by {_mrad(measured)} mrad, the position loop's "
        f"static lag under the planned load (τ + kv q̇) / kp = {_mrad(predicted)} mrad "
        "(kp 200 N m/rad); the robot stands lower and turned, so its swing foot lands early "
        "even with the floor's give and sink fed forward. Removing that lag is feeding the "
        "torque forward: stiff_ff.",
    ]


def _mrad(x: np.ndarray) -> str:
    return " / ".join(f"{v * 1e3:+.1f}" for v in x)
