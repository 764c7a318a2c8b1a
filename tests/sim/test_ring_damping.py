"""The servo ring's check (``planner/servo_ring.py``) against MuJoCo where the joint damping
moves it: two design-set GA gaits (ga-dev2, 0.65 s cells, 7.5° down, extended family)
re-timed and played by the AX-12A loop without feed-forward (results/README.md, stop 57).

With the damping at its estimated low end (0.12 N m s/rad) MuJoCo's robot walks 0.9 s
steps that the ring's decay alone would call ringing (T σ ≈ 1.2, under stop 38's 1.8
time constants); at the spec's own damping it falls at 0.6 s steps, as the check says
(the whole-body walk tips it earlier since stop 58; the check still calls the ring).
The two residuals bracket ``RING_RESIDUAL``: 0.14 walks, 0.20 falls; the check fails
here if its threshold is halved or doubled."""

import numpy as np
import pytest

from slopewalk.bench.sim.model import servo_settings
from slopewalk.bench.sim.prediction import _ring_residual
from slopewalk.bench.sim.trial import run_trial
from slopewalk.bench.sim.trial_spec import TrialSpec
from slopewalk.planner import servo_loop
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.servo_ring import (
    RING_RESIDUAL,
    RingLoop,
    landing_rows,
    slowest_decay,
)
from slopewalk.planner.uncertainty import spec_at

# hip height [m], swing lift [m], lean [deg], pelvis offset [m], step length [m], sway share
LEANING = (0.1806624, 0.0074096, 23.0132, -0.0273336, 0.0564044, 0.7793187)  # max margin
UPRIGHT = (0.2330874, 0.0074117, 12.7140, -0.0259937, 0.0555436, 0.7922619)  # min work


def _trial(spec, values, step_time):
    hip, lift, lean, pelvis, length, sway = values
    gait = GaitParams.nominal(
        spec,
        step_time,
        slope=np.deg2rad(-7.5),
        steps=4,
        hip_height=hip,
        swing_lift=lift,
        tilt=np.deg2rad(lean),
        pelvis_offset=pelvis,
        step_length=length,
        sway_share=sway,
    )
    plan = plan_walk(spec, gait)
    result = run_trial(spec, TrialSpec(gait, actuators="servo"), plan=plan)
    return plan, result.scalars()


@pytest.mark.parametrize(
    ("values", "damping", "step_time", "walks"),
    [(LEANING, 0.12, 0.9, True), (UPRIGHT, None, 0.6, False)],
    ids=["low damping walks", "spec damping falls"],
)
def test_the_ring_check_follows_mujoco_across_the_joint_damping(
    spec, values, damping, step_time, walks
):
    spec = spec if damping is None else spec_at(spec, "servo.damping", damping)
    plan, got = _trial(spec, values, step_time)
    assert (got["simulated_verdict"] == "stable") == walks
    left = _ring_residual(plan, servo_settings(spec, "servo"))
    if walks:
        assert got["predicted_verdict"] == "stable"
        assert RING_RESIDUAL / 2 < left.max() <= RING_RESIDUAL
        loop = RingLoop(spec.armature, spec.joint_damping, spec.stiffness)
        mass, gravity_k = servo_loop.linearised_at(plan, landing_rows(plan))
        assert step_time * slowest_decay(mass[1], gravity_k[1], loop) < 1.8
    else:
        assert got["predicted_verdict"] != "stable"  # the whole-body walk also tips it
        assert "ring" in [event["kind"] for event in got["predicted_events"]]
        assert RING_RESIDUAL < left[1:].min() <= 2 * RING_RESIDUAL
