"""Command noise: white noise of a given σ on every command row, seeded, for replicas."""

import numpy as np
import pytest

from slopewalk.bench.sim.model import SceneError
from slopewalk.bench.sim.playback import noisy, play
from slopewalk.bench.sim.trial_spec import MAX_COMMAND_NOISE, TrialSpec
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import plan_walk


def test_noisy_adds_seeded_white_noise_of_sigma():
    """5000 × 8 draws: their spread is σ to 3 % (the estimate's own error is 0.4 %), their
    mean 0 to 10 standard errors, the same seed draws the same, another seed not."""
    q = np.linspace(0, 1, 40000).reshape(5000, 8)
    out = noisy(q, 1e-6, 7)
    d = out - q
    assert abs(d.std() / 1e-6 - 1) < 0.03 and abs(d.mean()) < 10 * 1e-6 / np.sqrt(d.size)
    np.testing.assert_array_equal(noisy(q, 1e-6, 7), out)
    assert not np.array_equal(noisy(q, 1e-6, 8), out)
    assert noisy(q, 0.0, 7) is q


def test_play_puts_the_noise_on_the_commands_and_the_walk_moves_by_little(spec):
    plan = plan_walk(spec, GaitParams.nominal(spec, 1.0, steps=1))
    plain = play(plan)
    fed = play(plan, command_noise=1e-5, noise_seed=3)
    d = fed.q_ref - plain.q_ref
    assert abs(d.std() / 1e-5 - 1) < 0.05
    moved = np.abs(fed.sensors.q - plain.sensors.q).max()
    assert 0 < moved < 1e-3  # the joints feel it, far below their tracking error


@pytest.mark.parametrize(
    "options, message",
    [
        ({"command_noise": float("nan")}, "command_noise nan rad: must lie in [0,"),
        ({"command_noise": -1e-6}, "command_noise -1e-06 rad: must lie in [0,"),
        ({"command_noise": 2 * MAX_COMMAND_NOISE}, "rad: must lie in [0, 0.008727] rad"),
        ({"command_noise": "1e-6"}, "command_noise '1e-6': must be a number of radians"),
        ({"command_noise": True}, "command_noise True: must be a number of radians"),
        ({"noise_seed": -1}, "noise_seed -1: must be an integer >= 0"),
        ({"noise_seed": 1.5}, "noise_seed 1.5: must be an integer >= 0"),
        (
            {
                "command_noise": 1e-6,
                "controller": "slopewalk.bench.controllers.ankle_cop:ankle_cop_feedback",
            },
            "noise is for the plan played open loop",
        ),
    ],
)
def test_bad_noise_is_one_line(spec, options, message):
    with pytest.raises(SceneError) as err:
        TrialSpec(GaitParams.nominal(spec, 1.0), **options)
    assert message in str(err.value) and "\n" not in str(err.value)
