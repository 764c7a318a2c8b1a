"""Unplanned support: foot-time the simulated contacts differ from the plan's."""

from dataclasses import replace

import numpy as np
import pytest

from slopewalk.bench.sim.playback import play
from slopewalk.bench.sim.support import planned_contact, support_difference, touch_downs
from slopewalk.bench.sim.trial import run_trial
from slopewalk.bench.sim.trial_spec import TrialSpec
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import plan_walk


@pytest.fixture(scope="module")
def walk(spec):
    plan = plan_walk(spec, GaitParams.nominal(spec, 2.0, steps=2))
    return plan, play(plan)


def test_planned_contact_is_the_stance_foot_and_both_in_double_support(walk):
    plan, _ = walk
    t = np.array([0.1, 1.0, 2.1, 3.0])  # DSP, SSP on the right, DSP, SSP on the left
    np.testing.assert_array_equal(
        planned_contact(plan, t), [[True, True], [False, True], [True, True], [True, False]]
    )


def test_a_recording_that_follows_the_plan_has_no_unplanned_support(walk):
    plan, rec = walk
    planned = planned_contact(plan, rec.t)
    force = rec.sensors.foot_force.copy()
    force[..., 2] = np.where(planned, 1.0, 0.0)
    exact = replace(rec, sensors=replace(rec.sensors, foot_force=force))
    rows = (rec.t >= 0) & (rec.t <= plan.t[-1])
    support = support_difference(plan, exact, rows)
    assert support.unplanned_support_s == 0.0
    force[(rec.t > 1.0) & (rec.t <= 1.1), 1, 2] = 0.0  # the stance foot lifted for 0.1 s
    force[(rec.t > 1.0) & (rec.t <= 1.05), 0, 2] = 2.0  # the swing foot down for 0.05 s
    lifted = replace(rec, sensors=replace(rec.sensors, foot_force=force))
    support = support_difference(plan, lifted, rows)
    assert support.missed_contact_s == pytest.approx(0.1, abs=1.5e-3)
    assert support.unplanned_contact_s == pytest.approx(0.05, abs=1.5e-3)


def test_the_slow_walk_touches_down_early(spec, walk):
    """Measured: each swing foot lands ~50 ms before its DSP (the stance foot rolls ~0.45 deg on
    MuJoCo's soft contact, so the swing sole is ~1 mm low while its zero-speed landing spends
    ~40 ms in its last mm) and lifts ~35 ms late."""
    plan, rec = walk
    result = run_trial(spec, TrialSpec(plan.params), plan=plan, recording=rec)
    assert 0.04 < result.unplanned_contact_s < 0.4
    assert result.missed_contact_s < 0.02
    assert result.scalars()["unplanned_support_s"] == pytest.approx(result.unplanned_support_s)


def test_touch_downs_time_each_landing_and_its_speed(walk):
    """Contacts as planned: each landing at its planned DSP start; the swing foot down
    20 ms early: −20 ms; its sole descending at 3 mm/s: −3 mm/s there."""
    plan, rec = walk
    planned = planned_contact(plan, rec.t)
    force = rec.sensors.foot_force.copy()
    force[..., 2] = np.where(planned, 1.0, 0.0)
    sole = rec.sensors.sole.copy()
    sole[..., 2] = -0.003 * rec.t[:, None]
    exact = replace(rec, sensors=replace(rec.sensors, foot_force=force, sole=sole))
    early, speed = touch_downs(plan, exact)
    np.testing.assert_allclose(early, 0.0, atol=1e-9)
    np.testing.assert_allclose(speed, -0.003, rtol=1e-6)
    force[(rec.t >= 1.98) & (rec.t < 2.0), 0, 2] = 1.0  # the left foot lands 20 ms early
    sooner = replace(rec, sensors=replace(rec.sensors, foot_force=force, sole=sole))
    np.testing.assert_allclose(touch_downs(plan, sooner)[0], [-0.02, 0.0], atol=1e-9)
