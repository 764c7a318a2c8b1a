"""Events of a simulated trial, each with its time and cause, and the trial's verdict.

Thresholds (stated here, used everywhere):

* ``slip``: a loaded foot's sole slides more than ``SLIP_DISTANCE`` in the plane
  since it became loaded. A foot counts as loaded while it carries more than
  ``LOADED_FRACTION`` of the robot's weight. 5 mm sits well above two motions that
  are not slips: the ~1 mm lateral motion the 8-DOF kinematics plans for the rear
  foot in double support (no hip roll; ``planner/trajectory.py``), and MuJoCo's
  creep of a loaded foot inside the friction cone. Measured standing still at
  μ = 1 (``tests/test_contact.py``, elliptic cone, impratio 10): 0.006 mm/s flat,
  0.09 mm/s on 15°, 0.38 mm/s on 30°, i.e. under 2 mm over the longest time a
  foot stays loaded in a 2 s-step walk.
* ``tip``: a loaded foot rotates off the plane by more than ``TIP_ANGLE``
  (it can only do so about an edge). The plan keeps both soles flat.
* ``fall``: any body but the feet touches the plane, or the pelvis drops below
  ``FALL_HEIGHT_FRACTION`` of the planned hip height.
* ``torque_limit``: an actuator delivers at least ``SATURATION`` of its limit.
* ``diverged``: MuJoCo reset the simulation (bad acceleration) or the state
  became non-finite.

Verdict: the most severe event kind present, in the order diverged, fall, tip,
slip; ``stable`` when none of these occurs (``torque_limit`` alone does not
change the verdict; it is reported).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slopewalk.bench.sim.playback import Recording
from slopewalk.planner.joints import MJCF_JOINTS

# SLIP_DISTANCE, LOADED_FRACTION, TIP_ANGLE: one definition with the analytic prediction's
# (planner/verdict.py), their basis stated above.
from slopewalk.planner.verdict import LOADED_FRACTION, SLIP_DISTANCE, TIP_ANGLE, slide_runs

# SATURATION: one definition with the strict walk's overload (planner/walk_prediction.py).
from slopewalk.planner.walk_prediction import SATURATION

FALL_HEIGHT_FRACTION = 0.6  # of the planned hip height
VERDICTS = ("stable", "slip", "tip", "fall", "diverged")  # least severe first
_SEVERITY = {kind: i for i, kind in enumerate(VERDICTS) if i}
LOST = ("tip", "fall", "diverged")  # the robot did not walk on: no CoP compared after
_FEET = ("left", "right")


@dataclass(frozen=True)
class Event:
    """Something that happened in the simulation.

    Attributes:
        time: When [s], walk start = 0.
        kind: slip, tip, fall, torque_limit or diverged.
        cause: One line saying what and how much.
    """

    time: float
    kind: str
    cause: str


def loaded_tilt(recording: Recording, *, weight: float) -> np.ndarray:
    """Each foot's (left, right) tilt off the plane while loaded [rad], (m, 2); 0 unloaded.

    The angle between the sole's normal and the plane's, on the rows where the foot
    carries more than ``LOADED_FRACTION`` of ``weight`` [N]: how far the support
    turns about an edge (``tip`` past ``TIP_ANGLE``).
    """
    s = recording.sensors
    tilt = np.arccos(np.clip(s.foot_normal[..., 2], -1.0, 1.0))
    return np.where(s.foot_force[..., 2] > LOADED_FRACTION * weight, tilt, 0.0)


def detect(recording: Recording, *, weight: float, hip_height: float) -> list[Event]:
    """All events of a recording, first occurrence per foot / actuator / kind, by time.

    Args:
        recording: The simulated trial.
        weight: Robot weight m·g [N], to decide when a foot is loaded.
        hip_height: Planned pelvis height above the plane [m].
    """
    s, t = recording.sensors, recording.t
    events = []
    loaded = s.foot_force[..., 2] > LOADED_FRACTION * weight  # (m, 2)
    tilts = loaded_tilt(recording, weight=weight)
    for foot in (0, 1):
        events += _slips(t, s.sole[:, foot, :2], loaded[:, foot], _FEET[foot])
        tilt = tilts[:, foot]
        hit = np.flatnonzero(tilt > TIP_ANGLE)
        if hit.size:
            k = hit[0]
            events.append(
                Event(
                    float(t[k]),
                    "tip",
                    f"{_FEET[foot]} foot tilted "
                    f"{np.rad2deg(tilt[k]):.1f} deg off the plane while loaded",
                )
            )
    touch = np.flatnonzero(s.touching)
    if touch.size:
        events.append(
            Event(float(t[touch[0]]), "fall", "a body other than the feet touched the plane")
        )
    low = np.flatnonzero(s.pelvis_height < FALL_HEIGHT_FRACTION * hip_height)
    if low.size:
        k = low[0]
        events.append(
            Event(
                float(t[k]),
                "fall",
                f"pelvis at {s.pelvis_height[k] * 1e3:.0f} mm "
                f"above the plane (planned {hip_height * 1e3:.0f} mm)",
            )
        )
    saturated = np.abs(s.actuator_force) >= SATURATION * recording.force_limit
    for j in np.flatnonzero(saturated.any(axis=0)):
        k = int(np.argmax(saturated[:, j]))
        events.append(
            Event(
                float(t[k]),
                "torque_limit",
                f"{MJCF_JOINTS[j]} at "
                f"{s.actuator_force[k, j]:+.3f} N m (limit "
                f"{recording.force_limit:g} N m)",
            )
        )
    if recording.diverged_at is not None:
        events.append(
            Event(
                recording.diverged_at,
                "diverged",
                "MuJoCo reset the simulation or the state became non-finite",
            )
        )
    return sorted(events, key=lambda e: (e.time, e.kind))


def verdict(events: list[Event]) -> str:
    """The most severe of diverged, fall, tip, slip among ``events``; else ``stable``."""
    worst = max((_SEVERITY.get(e.kind, 0) for e in events), default=0)
    return VERDICTS[worst] if worst else "stable"


def _slips(t, sole_xy, loaded, name) -> list[Event]:
    """First time a loaded foot's sole moved more than SLIP_DISTANCE since loading."""
    for a, moved in slide_runs(loaded, sole_xy):
        over = np.flatnonzero(moved > SLIP_DISTANCE)
        if over.size:
            k = a + over[0]
            return [
                Event(
                    float(t[k]),
                    "slip",
                    f"{name} foot slid {moved[over[0]] * 1e3:.1f} mm on the plane while loaded",
                )
            ]
    return []
