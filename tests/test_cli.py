"""The command line as a user meets it: one-line refusals, whole output files."""

import json
import subprocess
import sys

import numpy as np
import pytest

REQUIRED = (
    "t",
    "q",
    "qd",
    "qdd",
    "tau",
    "zmp",
    "zmp_lipm",
    "cop_ne",
    "com",
    "stance",
    "margin",
    "meta",
)


def _run(*args):
    return subprocess.run(
        [sys.executable, "-m", "bench.cli", *args], capture_output=True, text=True, timeout=120
    )


def test_plan_writes_the_series(tmp_path):
    out = tmp_path / "plan.npz"
    result = _run("plan", "--step-time", "1", "--slope", "10", "--out", str(out))
    assert result.returncode == 0, result.stderr
    assert "verdict:" in result.stdout
    data = np.load(out)
    for key in REQUIRED:
        assert key in data.files, key
    n = data["t"].size
    assert data["q"].shape == (n, 8) and data["tau"].shape == (n, 8)
    assert data["zmp"].shape == (n, 2) and data["com"].shape == (n, 3)
    meta = json.loads(str(data["meta"]))
    assert meta["params"]["slope"] == pytest.approx(np.deg2rad(10))
    assert meta["spec"]["thigh"] == 0.111


@pytest.mark.parametrize(
    "flags, message",
    [
        (["--step-time", "0"], "step time 0.0 s: must be > 0"),
        (["--step-time", "-1"], "step time -1.0 s: must be > 0"),
        (["--step-time", "1", "--slope", "60"], "slope 60 deg: must lie in (-60, 60) deg"),
        (["--step-time", "1", "--slope", "-75"], "slope -75 deg"),
        (["--step-time", "1", "--hip-height", "0.5"], "unreachable hip target at t ="),
        (["--step-time", "abc"], "'abc' is not a number"),
        (["--step-time", "1", "--robot", "missing.toml"], "no such file"),
    ],
)
def test_bad_input_is_one_line(tmp_path, flags, message):
    out = tmp_path / "plan.npz"
    result = _run("plan", *flags, "--out", str(out))
    assert result.returncode == 2
    assert message in result.stderr
    assert result.stderr.count("\n") == 1, result.stderr
    assert "Traceback" not in result.stderr
    assert not out.exists()
    assert list(tmp_path.iterdir()) == []  # nothing half-written


def test_planner_never_imports_mujoco():
    code = (
        "import sys; sys.modules['mujoco'] = None; import planner.plan, planner.spec, "
        "planner.zmp, planner.ik, planner.trajectory, planner.newton_euler"
    )
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0
