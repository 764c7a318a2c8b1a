"""The whole-body walk as the prediction plays it (``prediction.body_walk``) against MuJoCo's
nominal 2 s ``servo`` walk as measured, and its design loop's command line
(bench/experiments/whole_body.py)."""

from __future__ import annotations

import numpy as np
import pytest

from slopewalk.bench.experiments import whole_body as experiment
from slopewalk.bench.sim.prediction import body_walk
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.whole_body import tip_time


@pytest.fixture(scope="module")
def slow_walk(spec):
    return plan_walk(spec, GaitParams.nominal(spec, 2.0, slope=0.0))


def test_the_nominal_slow_servo_walk_rolls_and_splits_its_load_as_mujoco(spec, slow_walk):
    """Measured in MuJoCo (default robot, ``servo``, 2 s steps on flat ground; results/README.md,
    stops 33-34): the robot rolls about 2° in the first single support and recovers, and at
    the end of a double support after a landing the stance foot carries 4.23 N and the
    lifting one 2.35 N (the servo loop's bolted chain: 0.0 and 6.6 N). The predictor's
    rocking tips in the first single support (1.25 s); MuJoCo's robot tips at 3.53 s."""
    walked = body_walk(slow_walk, friction=1.0, actuators="servo")
    t = slow_walk.t
    first_single = (t > 0.8) & (t < 2.0)
    roll = np.rad2deg(np.abs(walked.x[first_single, 1]).max())
    assert 1.0 < roll < 3.0
    second_double = np.flatnonzero((t > 2.0) & (t < 3.0) & slow_walk.double_support)
    end = second_double[-1] - 20  # 20 ms before the lift-off
    assert walked.stance_load[end] == pytest.approx(4.23, abs=0.3)
    assert walked.second_load[end] == pytest.approx(2.35, abs=0.3)
    tip = tip_time(slow_walk, walked)
    assert tip is None or tip > 2.0  # not in the first single support, as in MuJoCo


def test_a_file_that_is_not_a_sweep_table_is_one_error_line(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("a,b\n1,2\n")
    assert experiment.main(["bench/experiments/sweeps/paper.toml", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "not a sweep table" in err


@pytest.mark.parametrize(
    "workers, says",
    [
        ("0", "0: must be an integer in [1, 1024]"),
        ("x", "'x' is not an integer"),
        ("2000", "2000: must be an integer in [1, 1024]"),
    ],
)
def test_a_bad_worker_count_is_one_error_line(workers, says, capsys):
    """The batch commands' own --workers check (``flags.WORKERS``)."""
    with pytest.raises(SystemExit) as stop:
        experiment.main(["bench/experiments/sweeps/paper.toml", "t.csv", "--workers", workers])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert says in err and err.count("\n") == 1
