"""Unplanned support: where the simulated feet touch the plane and the plan says otherwise.

The plan's support is the stance foot, plus the other foot in double support. A
simulated foot is in contact when the plane pushes on it at all (its net contact
normal force > 0). A trial whose support was not the planned one is not a test of
the planned ZMP against the planned polygon, so each trial reports, over the walk
samples where the robot still stands:

* ``unplanned_contact_s``: foot-time in contact where the plan has the foot in the
  air (early touch-down, late lift-off, a swing foot striking the plane);
* ``missed_contact_s``: foot-time in the air where the plan has it on the plane;
* their sum, ``unplanned_support_s`` (both feet counted, so at most 2 × the time).

``touch_downs`` times each swing foot's landing: its first contact after it left the
plane, from the planned touch-down, and its sole point's normal velocity there.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slopewalk.bench.sim.playback import Recording
from slopewalk.planner.joints import LEFT
from slopewalk.planner.plan import Plan


@dataclass(frozen=True)
class Support:
    """Foot-time [s] the simulated support differed from the plan's (see module doc)."""

    unplanned_contact_s: float
    missed_contact_s: float

    @property
    def unplanned_support_s(self) -> float:
        return self.unplanned_contact_s + self.missed_contact_s


def planned_contact(plan: Plan, t: np.ndarray) -> np.ndarray:
    """Whether each foot (left, right) is on the plane in the plan at times ``t``, (m, 2)."""
    idx = np.clip(np.searchsorted(plan.t, t - 1e-9), 0, plan.t.size - 1)
    stance, double = plan.stance[idx], plan.double_support[idx]
    left = (stance == LEFT) | double
    right = (stance != LEFT) | double
    return np.column_stack([left, right])


def support_difference(plan: Plan, recording: Recording, standing: np.ndarray) -> Support:
    """Foot-time where contact differs from the plan, over walk rows marked ``standing``.

    Args:
        plan: The walk.
        recording: The simulated trial.
        standing: Rows of ``recording`` to count (the walk, before any tip/fall), (m,).
    """
    t = recording.t
    dt = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    extra, missed = contact_differences(plan, recording, standing)
    return Support(float(extra.sum() * dt), float(missed.sum() * dt))


def contact_differences(
    plan: Plan, recording: Recording, standing: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Per row and foot (left, right), on rows marked ``standing``: in contact while the
    plan has the foot lifted, and in the air while the plan has it down, (m, 2) each."""
    contact = recording.sensors.foot_force[..., 2] > 0.0
    planned = planned_contact(plan, recording.t)
    rows = standing[:, None]
    return contact & ~planned & rows, ~contact & planned & rows


def touch_downs(plan: Plan, recording: Recording) -> tuple[np.ndarray, np.ndarray]:
    """Each step's landing: first contact from the planned touch-down [s] (< 0: early) and
    the sole point's velocity along z_S there [m/s] (< 0: descending), (steps,) each.

    The swing foot of step k leaves the plane at its planned lift-off or later; its first
    contact is the first row with a normal force after its first row without one. The
    velocity is the sole point's backward difference into that row. NaN where the foot
    never left or never landed again.
    """
    params = plan.params
    dsp = (1 - params.ssp_fraction) * params.step_time
    load = recording.sensors.foot_force[..., 2] > 0.0
    height = recording.sensors.sole[..., 2]
    t = recording.t
    early = np.full(params.steps, np.nan)
    speed = np.full(params.steps, np.nan)
    for k in range(params.steps):
        lift_off = k * params.step_time + dsp
        mid_swing = lift_off + params.ssp_fraction * params.step_time / 2
        stance = plan.stance[min(int(np.searchsorted(plan.t, mid_swing)), plan.t.size - 1)]
        swing = 1 if stance == LEFT else 0
        air = np.flatnonzero((t >= lift_off) & ~load[:, swing])
        if not air.size:
            continue
        landed = np.flatnonzero((t > t[air[0]]) & load[:, swing])
        if not landed.size:
            continue
        row = landed[0]
        early[k] = t[row] - (k + 1) * params.step_time
        speed[k] = (height[row, swing] - height[row - 1, swing]) / (t[row] - t[row - 1])
    return early, speed
