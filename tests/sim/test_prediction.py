"""The prediction of a trial: the servo that is played, the compliance-aware verdict, events."""

from bench.sim.prediction import predict_trial
from bench.sim.trial import TrialSpec, run_trial
from planner.plan import plan_walk
from planner.trajectory import GaitParams


def test_a_servo_asked_for_more_than_its_stall_torque_saturates(spec):
    """1 s steps need ~2 N m at a knee (the AX-12A gives 1.5); 2 s steps stay within it."""
    fast = predict_trial(plan_walk(spec, GaitParams.nominal(spec, 1.0)), friction=1.0,
                         actuators="servo_ff")  # fmt: skip
    assert fast.verdict == "saturation"
    assert "N m of a servo limited to 1.5 N m" in fast.prediction.events[0].cause
    slow = predict_trial(plan_walk(spec, GaitParams.nominal(spec, 2.0)), friction=1.0,
                         actuators="servo_ff")  # fmt: skip
    assert "saturation" not in [e.kind for e in slow.prediction.events]
    stiff = predict_trial(plan_walk(spec, GaitParams.nominal(spec, 1.0)), friction=1.0,
                          actuators="stiff")  # fmt: skip
    assert "saturation" not in [e.kind for e in stiff.prediction.events]  # 50 N m


def test_a_trial_reports_all_three_verdicts_and_the_servo_falls_where_predicted(spec):
    """1 s flat with the AX-12A (no feedforward): the paper's test says stable, the reached
    walk's swing foot strikes the plane and the servo saturates; the robot does not walk."""
    result = run_trial(spec, TrialSpec(GaitParams.nominal(spec, 1.0), actuators="servo"))
    scalars = result.scalars()
    assert scalars["analytic_verdict"] == "stable"
    assert scalars["predicted_verdict"] in ("saturation", "strike")
    assert {"strike", "saturation"} <= {e["kind"] for e in scalars["predicted_events"]}
    assert scalars["simulated_verdict"] != "stable"
    assert "zmp_compliant" in result.series and result.series["zmp_compliant"].shape[1] == 2
