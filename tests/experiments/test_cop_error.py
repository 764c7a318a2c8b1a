"""The flat walk's CoP error taken apart: phase windows, the plan's ZMP jumps, the report."""

import numpy as np
import pytest

from slopewalk.bench.experiments.cop_error.command_terms import LADDER
from slopewalk.bench.experiments.cop_error.flat_walk import (
    friction_sign,
    lead_torque,
    run_case,
    simulate,
)
from slopewalk.bench.experiments.cop_error.report import (
    WINDOW,
    WINDOWS,
    by_window,
    cop_error_report,
    phase_windows,
    zmp_jumps,
)
from slopewalk.bench.sim.model import servo_settings
from slopewalk.bench.sim.support import touch_downs
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.joints import stance_swing_to_left_right
from slopewalk.planner.plan import plan_walk


@pytest.fixture(scope="module")
def plan(spec):
    return plan_walk(spec, GaitParams.nominal(spec, 2.0, steps=2))


def test_the_windows_cut_each_phase_at_its_changes(plan):
    t = plan.t
    window = phase_windows(plan, t)
    double = plan.double_support
    assert set(window[double]) == {3, 4} and set(window[~double]) == {0, 1, 2}
    per_window = round(WINDOW / plan.params.dt)
    # 2 steps: 2 lift-offs, 2 touch-downs (the walk's first DSP starts at t = 0)
    for w in (0, 2, 3):
        assert abs(np.count_nonzero(window == w) - 2 * per_window) <= 2, WINDOWS[w]
    first_touch_down = np.searchsorted(t, plan.params.step_time - 1e-9)
    assert window[first_touch_down - 1] == 2 and window[first_touch_down + 1] == 3


def test_the_planned_zmp_jumps_where_the_leans_acceleration_does(spec, plan):
    """The hold lean's cubic has λ̈ = 12 tilt / T_dsp² at a touch-down and 0 in single
    support: the CoM, ~0.15 m up, steps its lateral acceleration by about h λ̈, and the
    ZMP by about h² λ̈ / g (order of magnitude: within a factor of two)."""
    lift, touch, typical = zmp_jumps(plan)
    dsp = (1 - plan.params.ssp_fraction) * plan.params.step_time
    h = plan.com[:, 2].mean()
    estimate = h**2 * 12 * plan.params.tilt / dsp**2 / 9.81
    assert estimate / 2 < touch < 2 * estimate
    assert lift > 50 * typical and touch > 50 * typical


def test_the_windows_share_out_the_whole_mean_square(plan):
    case = run_case(plan, "stiff_ff", "stiff_ff")
    rows = by_window(case, plan)
    assert sum(share for _, share, *_ in rows) == pytest.approx(1.0)
    assert sum(part for *_, part in rows) == pytest.approx(1.0)
    rms = np.sqrt(sum(share * r**2 for _, share, r, _, _ in rows))
    assert rms == pytest.approx(case.result.zmp_rms)


@pytest.mark.slow  # the whole report: about 60 s of flat walks; .ci/run runs it on its own
def test_the_report_names_its_command_and_every_case(spec):
    text = cop_error_report(spec, command="slopewalk cop-error --out x.md")
    assert "Written by `slopewalk cop-error --out x.md`" in text
    for label in ("| stiff |", "| stiff_ff |", "ankles aimed as on a rigid floor", "not the sink"):
        assert label in text
    assert "## Touch-down" in text
    assert "## Double support: the plan moves a loaded foot" in text


def test_the_ladders_last_rung_is_stiff_ffs_command(plan):
    """stiff with every lead term and the floor's give and sink plays stiff_ff's command
    bit for bit (nothing is clipped at 50 N m), so the ladder ends where stiff_ff is."""
    terms, floor_ff, _ = LADDER[-1]
    laddered = simulate(plan, "stiff", floor_ff=floor_ff, leads=terms)
    fed = simulate(plan, "stiff_ff")
    np.testing.assert_array_equal(laddered.q_ref, fed.q_ref)
    np.testing.assert_array_equal(laddered.sensors.cop, fed.sensors.cop)


def test_each_lead_term_moves_the_command_by_its_lag(spec, plan):
    """A term's lead is its torque / kp: the rate term is kv q̇ / kp on every joint."""
    servo = servo_settings(spec, "stiff")
    rate = lead_torque(plan, servo, ("rate",))
    expected = stance_swing_to_left_right(servo.kv * plan.qd, plan.stance)
    np.testing.assert_allclose(rate, expected, rtol=1e-15)
    both = lead_torque(plan, servo, ("torque", "rate"))
    torque = stance_swing_to_left_right(plan.tau, plan.stance)
    np.testing.assert_allclose(both, torque + expected, atol=1e-12)


def test_friction_sign_follows_the_motion_and_holds_a_still_joints_last(plan):
    qd = np.array([[0.0], [0.0], [0.5], [1.0], [1e-12], [0.0], [-0.3], [0.0]])
    moving = friction_sign(qd, held=False)[:, 0]
    held = friction_sign(qd, held=True)[:, 0]
    np.testing.assert_array_equal(moving, [0, 0, 1, 1, 0, 0, -1, 0])  # 1e-12: roundoff
    np.testing.assert_array_equal(held, [0, 0, 1, 1, 1, 1, -1, -1])


def test_servo_ff_lands_early_by_the_joints_dry_friction(plan):
    """The measured cause of servo_ff's early landing: MuJoCo without the friction loss
    lands on time (within 2 steps of 1 ms); with it over 10 ms early (measured 17-18)."""
    with_friction = touch_downs(plan, simulate(plan, "servo_ff"))[0]
    without = touch_downs(plan, simulate(plan, "servo_ff", joint_friction=False))[0]
    assert np.all(np.abs(without) <= 0.002)
    assert np.all(with_friction < -0.010)


@pytest.mark.parametrize("actuators", ["stiff", "servo_ff"])
def test_a_case_without_options_is_the_trials_own_playback(plan, actuators):
    """cop_error plays through playback's path: with nothing chosen, ``simulate`` is
    ``playback.play`` bit for bit (commands, aim, every sensor)."""
    from slopewalk.bench.experiments.cop_error.flat_walk import FRICTION
    from slopewalk.bench.sim.playback import play

    own, trial = simulate(plan, actuators), play(plan, friction=FRICTION, actuators=actuators)
    np.testing.assert_array_equal(own.t, trial.t)
    np.testing.assert_array_equal(own.q_ref, trial.q_ref)
    assert (own.aim_offset is None) == (trial.aim_offset is None) == (actuators == "stiff")
    for name, value in vars(trial.sensors).items():
        np.testing.assert_array_equal(getattr(own.sensors, name), value, err_msg=name)
    assert own.diverged_at == trial.diverged_at and own.force_limit == trial.force_limit
