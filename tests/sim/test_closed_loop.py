"""Closed-loop trials: the same comparison, events and outputs as open loop, marked as such."""

import json
import subprocess
import sys

import numpy as np
import pytest

from bench.controllers import SHIPPED, ControllerError, load_controller
from bench.sim.trial import TrialSpec, run_trial
from planner.trajectory import GaitParams

OPEN_LOOP = "bench.sim.env:open_loop"


@pytest.mark.parametrize("step_time", [1.0, 0.5])
def test_the_open_loop_policy_gives_the_open_loop_trial(spec, step_time):
    """Verdicts, events, every scalar and every series equal the rollout's (0.5 s falls)."""
    gait = GaitParams.nominal(spec, step_time, steps=2)
    rollout = run_trial(spec, TrialSpec(gait))
    closed = run_trial(spec, TrialSpec(gait, controller=OPEN_LOOP))
    assert closed.events == rollout.events
    a, b = closed.scalars(), rollout.scalars()
    assert a["trial"].pop("controller") == OPEN_LOOP
    a.pop("wall_s"), b.pop("wall_s")
    assert a == b
    for name, series in rollout.series.items():
        assert np.array_equal(closed.series[name], series, equal_nan=True), name
    assert closed.summary_lines()[0].endswith(f"controller {OPEN_LOOP}")
    assert rollout.summary_lines()[0].endswith("stiff actuators")


def test_an_open_loop_trial_says_nothing_of_controllers(spec):
    result = run_trial(spec, TrialSpec(GaitParams.nominal(spec, 1.0, steps=1)))
    assert "controller" not in result.scalars()["trial"]


@pytest.mark.parametrize("name", SHIPPED)
def test_each_shipped_controller_walks_the_nominal_trial(spec, name):
    """Where open loop walks (1 s steps, flat, 15°), the controllers walk too."""
    for slope in (0.0, 15.0):
        gait = GaitParams.nominal(spec, 1.0, slope=np.deg2rad(slope))
        result = run_trial(spec, TrialSpec(gait, controller=name))
        assert result.simulated_verdict == "stable", (name, slope, result.events)
        assert result.zmp_rms < 0.03


def test_a_controller_name_is_checked_in_the_trial_spec(spec):
    with pytest.raises(ControllerError, match="must read MODULE:CALLABLE"):
        TrialSpec(GaitParams.nominal(spec, 1.0), controller="not a name")
    with pytest.raises(ControllerError, match="no module named 'no_such'"):
        load_controller("no_such:f")


def test_trial_cli_runs_a_shipped_controller_with_every_output(tmp_path):
    out, series, record = tmp_path / "t.json", tmp_path / "t.npz", tmp_path / "t.rrd"
    name = "bench.controllers.ankle_cop:ankle_cop_feedback"
    result = subprocess.run(
        [sys.executable, "-m", "bench.cli", "trial", "--step-time", "1", "--steps", "1",
         "--controller", name, "--out", str(out), "--series", str(series),
         "--record", str(record)],
        capture_output=True, text=True, timeout=300, cwd=tmp_path,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert f"controller {name}" in result.stdout
    data = json.loads(out.read_text(), parse_constant=pytest.fail)
    assert data["trial"]["controller"] == name
    assert data["simulated_verdict"] == "stable"
    assert record.read_bytes()[:4] == b"RRF2" and np.load(series)["cop"].shape[1] == 2


def test_each_shipped_controller_walks_where_open_loop_falls(spec):
    """1 s steps up 20° at μ = 1: the plan alone tips and falls; both controllers walk."""
    gait = GaitParams.nominal(spec, 1.0, slope=np.deg2rad(20.0))
    assert run_trial(spec, TrialSpec(gait, friction=1.0)).simulated_verdict == "fall"
    for name in SHIPPED:
        result = run_trial(spec, TrialSpec(gait, friction=1.0, controller=name))
        assert result.simulated_verdict == "stable", (name, result.events)
