"""Event detection and verdicts on sensor series written by hand, with hand-worked answers.

``events.detect`` is a pure function of the decoded sensor series, so each rule of its
docstring (slip, tip, fall, torque_limit, diverged; thresholds; the first occurrence per
foot, actuator and kind; the verdict's order of severity) gets a series whose answer is
known exactly: time, kind and cause line. The trials in ``test_trial.py`` show the same
rules firing on MuJoCo's own series.
"""

import numpy as np
import pytest

from slopewalk.bench.sim.contact import TrialSensors
from slopewalk.bench.sim.events import (
    FALL_HEIGHT_FRACTION,
    LOADED_FRACTION,
    SLIP_DISTANCE,
    TIP_ANGLE,
    Event,
    detect,
    loaded_tilt,
    verdict,
)
from slopewalk.bench.sim.playback import Recording

WEIGHT = 6.0  # [N]
HIP = 0.2  # [m] planned hip height
LIMIT = 1.5  # [N m]
DT = 0.001  # [s]
N = 1000


def _standing(**changes) -> dict:
    """Series of a robot standing still on both feet, each carrying half the weight."""
    series = {
        "q": np.zeros((N, 8)),
        "actuator_force": np.zeros((N, 8)),
        "foot_force": np.tile([0.0, 0.0, WEIGHT / 2], (N, 2, 1)),
        "foot_cop": np.zeros((N, 2, 2)),
        "cop": np.zeros((N, 2)),
        "sole": np.tile([[0.0, 0.04, 0.0], [0.0, -0.04, 0.0]], (N, 1, 1)),
        "foot_normal": np.tile([0.0, 0.0, 1.0], (N, 2, 1)),
        "foot_axis_x": np.tile([1.0, 0.0, 0.0], (N, 2, 1)),
        "pelvis_height": np.full(N, HIP),
        "pelvis_qpos": np.tile([0, 0, HIP, 1, 0, 0, 0], (N, 1)),
        "touching": np.zeros(N, bool),
    }
    series.update(changes)
    return series


def _detect(series: dict, diverged_at=None) -> list[Event]:
    recording = Recording(
        t=np.arange(N) * DT,
        q_ref=np.zeros((N, 8)),
        sensors=TrialSensors(**series),
        force_limit=LIMIT,
        diverged_at=diverged_at,
    )
    return detect(recording, weight=WEIGHT, hip_height=HIP)


def _ramp(start: int, stop: int, total: float) -> np.ndarray:
    """0 before ``start``, rising linearly to ``total`` at ``stop``, held after, (N,)."""
    return np.clip((np.arange(N) - start) / (stop - start), 0.0, 1.0) * total


def test_standing_still_has_no_events():
    events = _detect(_standing())
    assert events == [] and verdict(events) == "stable"


def test_a_loaded_foot_sliding_slips_at_the_first_sample_past_the_threshold():
    sole = _standing()["sole"].copy()
    sole[:, 0, 0] += _ramp(200, 700, 0.011)  # left foot: 11 mm over 0.5 s, 22 um per sample
    events = _detect(_standing(sole=sole))
    assert SLIP_DISTANCE == 0.005
    # 5 mm is reached 227.3 samples in: the first sample beyond it is 428, at 5.016 mm
    assert events == [Event(428 * DT, "slip", "left foot slid 5.0 mm on the plane while loaded")]
    assert verdict(events) == "slip"


def test_slip_is_measured_from_when_the_foot_became_loaded():
    """Sliding while unloaded, or under a tenth of the weight, is no slip; then loaded it is."""
    base = _standing()
    force, sole = base["foot_force"].copy(), base["sole"].copy()
    light = np.arange(N) < 500
    force[light, 1, 2] = 0.9 * LOADED_FRACTION * WEIGHT  # right foot nearly unloaded ...
    force[light, 0, 2] = WEIGHT - force[light, 1, 2]
    sole[:, 1, 1] -= _ramp(100, 400, 0.020)  # ... while it slides 20 mm sideways
    sole[:, 1, 1] -= _ramp(600, 910, 0.006)  # then loaded, 6 mm: 5 mm at 258.3 samples in
    events = _detect(_standing(foot_force=force, sole=sole))
    assert events == [Event(859 * DT, "slip", "right foot slid 5.0 mm on the plane while loaded")]


def test_a_loaded_foot_tilting_tips_and_an_unloaded_one_does_not():
    base = _standing()
    normal, force = base["foot_normal"].copy(), base["foot_force"].copy()
    angle = _ramp(100, 400, np.deg2rad(10.5))  # both feet roll 10.5° over 0.3 s ...
    for f in (0, 1):
        normal[:, f] = np.column_stack([np.zeros(N), -np.sin(angle), np.cos(angle)])
    force[:, 0, 2], force[:, 1, 2] = 0.0, WEIGHT  # ... the left one in the air
    events = _detect(_standing(foot_normal=normal, foot_force=force))
    # 5° is reached 142.9 samples in: the first sample beyond it is 243, at 5.04°
    assert TIP_ANGLE == pytest.approx(np.deg2rad(5.0))
    assert events == [
        Event(243 * DT, "tip", "right foot tilted 5.0 deg off the plane while loaded")
    ]
    assert verdict(events) == "tip"


def test_loaded_tilt_is_the_angle_off_the_plane_of_a_loaded_foot_only():
    base = _standing()
    normal, force = base["foot_normal"].copy(), base["foot_force"].copy()
    angle = _ramp(100, 400, np.deg2rad(3.0))  # roll of the right foot, pitch of the left
    normal[:, 1] = np.column_stack([np.zeros(N), -np.sin(angle), np.cos(angle)])
    normal[:, 0] = np.column_stack([np.sin(2 * angle), np.zeros(N), np.cos(2 * angle)])
    force[300:, 0, 2] = 0.1 * WEIGHT  # the left foot unloaded (under 20 %) from 0.3 s
    recording = Recording(np.arange(N) * DT, np.zeros((N, 8)),
                          TrialSensors(**_standing(foot_normal=normal, foot_force=force)),
                          LIMIT, None)  # fmt: skip
    tilt = loaded_tilt(recording, weight=WEIGHT)
    np.testing.assert_allclose(tilt[:, 1], angle, atol=1e-12)
    np.testing.assert_allclose(tilt[:300, 0], 2 * angle[:300], atol=1e-12)
    assert np.all(tilt[300:, 0] == 0.0)  # 6° off the plane but unloaded: no support tilt


def test_falls_by_touch_and_by_pelvis_height():
    touching = np.arange(N) >= 300
    height = HIP - _ramp(500, 900, 0.105)  # pelvis sinks to 95 mm
    events = _detect(_standing(touching=touching, pelvis_height=height))
    # below 0.6 × 200 mm = 120 mm from 304.8 samples into the drop: sample 805, 119.9 mm
    assert FALL_HEIGHT_FRACTION == 0.6
    assert events == [
        Event(300 * DT, "fall", "a body other than the feet touched the plane"),
        Event(805 * DT, "fall", "pelvis at 120 mm above the plane (planned 200 mm)"),
    ]
    assert verdict(events) == "fall"


def test_causes_print_millimetres():
    """The numbers in the cause lines are the series' values in mm, rounded as printed."""
    base = _standing()
    sole, height = base["sole"].copy(), base["pelvis_height"].copy()
    sole[300:, 0, 0] += 0.005049  # left foot jumps 5.049 mm while loaded
    hip = 0.2004  # [m] planned; the fall line is at 120.24 mm
    height[600:] = 0.11945
    recording = Recording(
        t=np.arange(N) * DT,
        q_ref=np.zeros((N, 8)),
        sensors=TrialSensors(**_standing(sole=sole, pelvis_height=height)),
        force_limit=LIMIT,
        diverged_at=None,
    )
    events = detect(recording, weight=WEIGHT, hip_height=hip)
    assert [e.cause for e in events] == [
        "left foot slid 5.0 mm on the plane while loaded",
        "pelvis at 119 mm above the plane (planned 200 mm)",
    ]


def test_a_saturated_actuator_is_reported_once_and_leaves_the_verdict_alone():
    force = np.zeros((N, 8))
    force[:, 5] = -_ramp(0, 400, 3.1).clip(0, LIMIT)  # r_knee: 0.99 of the limit at 191.6
    force[600:, 2] = 0.995 * LIMIT  # l_ankle_pitch from 600 on
    events = _detect(_standing(actuator_force=force))
    assert events == [
        Event(192 * DT, "torque_limit", "r_knee at -1.488 N m (limit 1.5 N m)"),
        Event(600 * DT, "torque_limit", "l_ankle_pitch at +1.492 N m (limit 1.5 N m)"),
    ]
    assert verdict(events) == "stable"


def test_divergence_is_an_event_and_the_worst_verdict():
    sole = _standing()["sole"].copy()
    sole[:, 0, 0] += _ramp(100, 200, 0.02)
    events = _detect(_standing(sole=sole), diverged_at=250 * DT)
    assert [e.kind for e in events] == ["slip", "diverged"]
    assert events[-1] == Event(
        250 * DT, "diverged", "MuJoCo reset the simulation or the state became non-finite"
    )
    assert verdict(events) == "diverged"


@pytest.mark.parametrize(
    "kinds, expected",
    [
        ([], "stable"),
        (["torque_limit"], "stable"),
        (["slip", "torque_limit"], "slip"),
        (["slip", "tip"], "tip"),
        (["tip", "fall", "slip"], "fall"),
        (["fall", "diverged", "tip"], "diverged"),
    ],
)
def test_verdict_is_the_most_severe_event(kinds, expected):
    assert verdict([Event(0.1 * i, k, "") for i, k in enumerate(kinds)]) == expected
