"""The claims table compares like with like: per-axis margins, the paper's own GA gait, the
heavier robot with its servo scaled, friction (issue 21's independent measurements)."""

import numpy as np
import pytest

from slopewalk.bench.experiments.claim_trials import PAPER_GA_GAIT, scaled_servo
from slopewalk.bench.report import claim_axes as ax
from slopewalk.bench.report.claims import step_time_claim
from slopewalk.bench.sim.trial import TrialSpec, run_trial
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import plan_walk


def test_the_flat_nominal_no_is_the_lateral_limit(spec):
    """Issue 21 measured the nominal gait front to back at 0.4 s: −33.5 mm; at 0.5 s the
    sagittal margin is positive, so the paper's claim holds along x and the lateral limit
    decides both step times."""
    rows = [
        {"step_time": t, "slope_deg": 0.0, "friction": 1.0, "mass_scale": "", "actuators": "stiff",
         "analytic_verdict": "zmp_outside", "simulated_verdict": "fall", "steps": 4,
         "analytic_min_margin_mm": -1.0}
        for t in (0.5, 0.4)
    ]  # fmt: skip
    claim = step_time_claim(rows, spec)
    assert "the lateral limit decides every step time outside" in claim["analytic"]
    assert "front to back: yes" in claim["agree"]
    sagittal_04 = float(claim["axes"].split("0.4 s: ")[1].split("sagittal ")[1].split(" mm")[0])
    assert sagittal_04 == pytest.approx(-33.5, abs=0.05)


def test_the_papers_22_5_gait_is_outside_laterally_only(spec):
    """Issue 21 replayed the paper's gait (Hz 0.151 m, Szmax 0.013 m, θ1max −9.18°): −3.3 mm
    laterally, +3.3 mm front to back."""
    gait = GaitParams.nominal(spec, 1.0, slope=np.deg2rad(22.5), **PAPER_GA_GAIT)
    lateral, sagittal = ax.axis_minima(plan_walk(spec, gait))
    assert lateral * 1e3 == pytest.approx(-3.3, abs=0.05)
    assert sagittal * 1e3 == pytest.approx(3.3, abs=0.05)


def test_a_heavier_robot_with_its_servo_scaled_walks_as_the_light_one(spec):
    """Every mass, inertia, torque constant and the armature × 10 multiply every torque of
    the equations of motion by 10: the same walk. The unscaled servo is a weaker robot."""
    heavy = spec.with_mass_scale({"all": 10.0})
    runs = {}
    for label, robot in (("nominal", spec), ("scaled", scaled_servo(heavy, 10.0)),
                         ("unscaled", heavy)):  # fmt: skip
        gait = GaitParams.nominal(robot, 1.0, steps=1)
        runs[label] = run_trial(robot, TrialSpec(gait, actuators="servo_ff"))
    assert runs["scaled"].zmp_rms == pytest.approx(runs["nominal"].zmp_rms, rel=1e-6)
    assert runs["scaled"].simulated_verdict == runs["nominal"].simulated_verdict
    assert abs(runs["unscaled"].zmp_rms - runs["nominal"].zmp_rms) > 1e-3


def test_friction_row_finds_the_slope_a_lower_mu_loses(spec):
    def row(slope, mu, verdict, ratio):
        return {"slope_deg": slope, "friction": mu, "simulated_verdict": verdict,
                "max_friction_ratio": ratio}  # fmt: skip

    line = [row(15.0, 1.0, "stable", 0.33), row(15.0, 0.4, "stable", 0.33),
            row(20.0, 1.0, "stable", 0.42), row(20.0, 0.4, "fall", 0.42),
            row(22.5, 1.0, "fall", 0.46), row(22.5, 0.4, "fall", 0.46)]  # fmt: skip
    claim = ax.friction_claim(line, spec, line)
    assert "at 20° μ 0.4 loses the walk μ 1 keeps" in claim["simulated"]
    assert claim["agree"] == "analytic yes, simulated yes"
    assert "|" not in claim["analytic"] + claim["simulated"]  # a table cell
