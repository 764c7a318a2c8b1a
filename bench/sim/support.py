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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bench.sim.playback import Recording
from planner.joints import LEFT
from planner.plan import Plan


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
    contact = recording.sensors.foot_force[..., 2] > 0.0
    planned = planned_contact(plan, t)
    rows = standing[:, None]
    extra = (contact & ~planned & rows).sum() * dt
    missed = (~contact & planned & rows).sum() * dt
    return Support(float(extra), float(missed))
