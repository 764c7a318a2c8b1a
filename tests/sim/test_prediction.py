"""The prediction of a trial: the servo that is played, the compliance-aware verdict, events."""

from slopewalk.bench.sim.prediction import predict_trial
from slopewalk.bench.sim.trial import run_trial
from slopewalk.bench.sim.trial_spec import TrialSpec
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import plan_walk


def test_saturation_is_reported_and_its_consequence_decides(spec):
    """1 s steps ask ~2 N m of a knee (the AX-12A gives 1.5): reported as saturation, and
    the clipped loop still walks, as MuJoCo's robot does (dense grid: 1 s, 0-10°,
    ``servo_ff``, with ``torque_limit`` events); at 0.75 s the knee falls far behind and
    the robot tips (MuJoCo: falls). 2 s steps stay within the limit."""
    fast = predict_trial(plan_walk(spec, GaitParams.nominal(spec, 1.0)), friction=1.0,
                         actuators="servo_ff")  # fmt: skip
    assert "saturation" in [e.kind for e in fast.prediction.events]
    assert "N m of a servo limited to 1.5 N m" in fast.prediction.events[0].cause
    assert fast.verdict == "stable"
    faster = predict_trial(plan_walk(spec, GaitParams.nominal(spec, 0.75)), friction=1.0,
                           actuators="servo_ff")  # fmt: skip
    assert "saturation" in [e.kind for e in faster.prediction.events]
    assert faster.verdict in ("tip", "strike")
    slow = predict_trial(plan_walk(spec, GaitParams.nominal(spec, 2.0)), friction=1.0,
                         actuators="servo_ff")  # fmt: skip
    assert "saturation" not in [e.kind for e in slow.prediction.events]
    stiff = predict_trial(plan_walk(spec, GaitParams.nominal(spec, 1.0)), friction=1.0,
                          actuators="stiff")  # fmt: skip
    assert "saturation" not in [e.kind for e in stiff.prediction.events]  # 50 N m


def test_a_trial_reports_all_three_verdicts_and_the_servo_falls_where_predicted(spec):
    """1 s flat with the AX-12A (no feedforward): the paper's test says stable, the servo
    saturates and the loop's sway tips the robot; the robot does not walk."""
    result = run_trial(spec, TrialSpec(GaitParams.nominal(spec, 1.0), actuators="servo"))
    scalars = result.scalars()
    assert scalars["analytic_verdict"] == "stable"
    assert scalars["predicted_verdict"] in ("tip", "strike")
    assert "saturation" in {e["kind"] for e in scalars["predicted_events"]}
    assert scalars["simulated_verdict"] != "stable"
    assert "zmp_compliant" in result.series and result.series["zmp_compliant"].shape[1] == 2
