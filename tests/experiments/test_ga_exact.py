"""The GA's feasible bests stay feasible when re-planned at 1 ms (issue 9's exactness)."""

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from slopewalk.bench.experiments.ga.search import GaSettings, run_ga
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.gait_search import GaitProblem, ga_params
from slopewalk.planner.plan import plan_walk

RESULTS = Path(__file__).resolve().parents[2] / "results" / "optimize"


def _replan(spec, report, x) -> float:
    """Minimum margin [m] of gait x = (Hz, Szmax, tilt) re-planned at 1 ms on the report's case."""
    foot = {"foot_length": report["foot_length_m"], "ankle_to_toe": report["ankle_to_toe_m"]}
    robot = replace(spec, **foot)
    params = GaitParams.nominal(
        robot, report["step_time_s"], slope=np.deg2rad(report["slope_deg"]), steps=report["steps"],
        hip_height=x[0], swing_lift=x[1], tilt=x[2], dt=1e-3,
    )  # fmt: skip
    return float(plan_walk(robot, params).margin.min())


def test_committed_feasible_bests_are_feasible_at_1ms(spec):
    """Every committed GA result that says feasible: its best is feasible re-planned at 1 ms.

    The GA's margin is never above the 1 ms plan's (it sees both sides of every
    phase change and refines between samples), so its feasible gaits stay feasible.
    """
    checked = 0
    for path in sorted(RESULTS.rglob("*.json")):
        report = json.loads(path.read_text())
        if not report["feasible"]:
            continue
        best = report["best"]
        x = (best["hip_height_m"], best["swing_lift_m"], best["tilt_rad"])
        margin = _replan(spec, report, x)
        assert margin >= 0, f"{path.name}: {margin * 1e3:.4f} mm at 1 ms"
        assert best["min_margin_m"] <= margin + 1e-12, path.name
        assert report["check"]["min_margin_m"] == pytest.approx(margin, abs=1e-12)
        checked += 1
    assert checked >= 10


@pytest.mark.slow
@pytest.mark.parametrize(
    "slope_deg, foot_length, constraint", [(22.5, None, "penalty"), (30.0, 0.110, "margin")]
)
def test_paper_ga_best_is_feasible_at_1ms(spec, slope_deg, foot_length, constraint):
    """The paper's GA (130 x 500) at 22.5° and at 30° with the heel +10 mm, re-planned at 1 ms."""
    robot = spec if foot_length is None else spec.with_foot_length(foot_length, extend="heel")
    problem = GaitProblem(robot, ga_params(robot, 1.0, np.deg2rad(slope_deg)))
    result = run_ga(problem, GaSettings(constraint=constraint))
    assert result.best.feasible
    report = {
        "foot_length_m": robot.foot_length,
        "ankle_to_toe_m": robot.ankle_to_toe,
        "step_time_s": 1.0,
        "slope_deg": slope_deg,
        "steps": problem.params.steps,
    }
    assert _replan(spec, report, result.best.x) >= 0
