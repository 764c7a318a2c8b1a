"""Touch-down on time: the legs shortened by the soft floor's sink, fed forward.

With the give turned away at the ankles (``floor.give_feedforward``) the robot still
stands lower than planned by the stance sole's sink s under its ankle
(``floor.foot_deflection``: 0.10 mm late in a 2 s step of the default robot, its CoP
near the toe). Played as planned, the swing sole decelerating at z̈ onto the plane
meets the sunk floor √(2 s / z̈) early (13 ms at 2 s steps), at √(2 s z̈) (14 mm/s),
where the plan has it land with zero normal velocity.

``leg_shortening`` raises each sole's target along z_S by

    c_i = max_j s_j − s_i   [m]

(s_i the planned sink of foot i; the more sunk foot keeps its planned leg): in single
support the swing sole is then at its planned height above the real, sunk floor and
meets it at the planned touch-down with the plan's zero normal velocity; through the
double support the landing foot's raise falls as its planned share sinks it, to 0 once
it carries more than the other. No foot on the floor is ever raised, and the command
takes no step:

* the foot a double support loads (the landing foot) follows that raise downwards only.
  The planned sinks jump with the planned ZMP at the phase changes (the lean's
  acceleration steps there); the real CoP cannot jump, and following the jump up would
  lift the foot that has just landed, unloaded;
* the foot a double support unloads keeps its planned leg until its lift-off. Raising it
  by the planned shares' sink difference lifts it off early: the real shares follow the
  fight of the double support's foot slide (``planner.verdict``'s ``foot_slide``), not the
  plan's split;
* after its lift-off the swing sole's raise grows no faster than its planned lift,
  min(c, lift), until the lift peaks.

Measured on flat ground at 2 s steps (``slopewalk cop-error``): unplanned support 0.24 s
with both rules, 0.32 s without the first, 0.89 s with neither.

``leg_offsets`` turns a raise into joint angles: each leg is a two-link chain in its
leaning plane (``planner.ik``), the ankle-to-hip vector shortened along the plane's up
axis by c / cos λ (λ the ankle roll, the lean), which raises the sole by c along z_S and
moves it c tan λ sideways (0.05 mm at 12°); the foot stays parallel to the pelvis (hip
pitch + knee + ankle pitch unchanged, 0). The "_ff" modes play it (``playback``).
"""

from __future__ import annotations

import numpy as np

from slopewalk.bench.sim.floor import foot_loads
from slopewalk.planner.ik import leg_ik, leg_vector
from slopewalk.planner.joints import LEFT
from slopewalk.planner.trajectory import Curve


def leg_shortening(plan, sink: np.ndarray) -> np.ndarray:
    """Raise of each sole's target (left, right) along z_S [m], (n, 2) on ``plan.t``.

    Args:
        plan: The walk.
        sink: Each foot's planned sink under its ankle [m], (n, 2)
            (``floor.foot_deflection``).
    """
    raw = sink.max(axis=1, keepdims=True) - sink  # (n, 2), ≥ 0
    _, load = foot_loads(plan)
    left = plan.stance == LEFT
    n = np.arange(plan.t.size)
    swing = np.where(left, 1, 0)
    out = np.zeros_like(raw)
    lift = plan.swing_sole[:, 2] - plan.stance_sole[:, 2]  # [m] above the plane
    single = ~plan.double_support
    rising = single & (np.gradient(lift) > 0)
    out[n, swing] = np.where(
        single, np.where(rising, np.minimum(raw[n, swing], lift), raw[n, swing]), 0.0
    )
    change = np.flatnonzero(np.diff(plan.double_support.astype(int))) + 1
    bounds = np.concatenate([[0], change, [plan.t.size]])
    for start, end in zip(bounds[:-1], bounds[1:], strict=True):
        if not plan.double_support[start]:
            continue
        landing = int(np.argmax(load[end - 1] - load[start]))  # the foot the DSP loads
        held = raw[start:end, landing]
        if start > 0:
            held = np.concatenate([out[start - 1 : start, landing], held])
        out[start:end, landing] = np.minimum.accumulate(held)[-(end - start) :]
    return out


def leg_offsets(plan, raise_: np.ndarray) -> np.ndarray:
    """Joint offsets that raise each sole by ``raise_`` (n, 2) [m], MJCF order [rad], (n, 8).

    Hip pitch, knee and ankle pitch of each leg from the shortened two-link chain
    (module doc); the ankle rolls are left as planned.
    """
    spec = plan.spec
    q = plan.q_left_right
    zero = np.zeros(plan.t.size)
    out = np.zeros_like(q)
    for leg in (0, 1):
        hip, knee, roll = q[:, 4 * leg], q[:, 4 * leg + 1], q[:, 4 * leg + 3]
        thigh, shank = hip, hip + knee  # each link's angle from the leg plane's up axis
        u, w = leg_vector(spec, shank, thigh)
        w_short = w - raise_[:, leg] / np.cos(roll)
        new_shank, new_thigh = leg_ik(
            (Curve(u, zero, zero), Curve(w_short, zero, zero)), spec, plan.t
        )
        out[:, 4 * leg] = new_thigh.p - thigh
        out[:, 4 * leg + 1] = (new_shank.p - new_thigh.p) - knee
        out[:, 4 * leg + 2] = -(new_shank.p - shank)
    return out
