"""The dm_env environment of one trial: conformance, observations, and the open-loop policy.

The open-loop policy played through ``TrialEnv`` must reproduce ``playback.play`` bit
for bit: both paths set the same initial state on a fresh ``MjData``, command the
same ``ctrl`` row by row and call the same ``mj_step`` on the same ``MjModel``, so
any difference at all means a different model, start, command or bookkeeping (a
row off by one, a warning handled differently), never float rounding. Hence
``array_equal`` there, and physical tolerances everywhere else.
"""

import dm_env
import mujoco
import numpy as np
import pytest
from absl.testing import absltest
from dm_env import test_utils
from mujoco import rollout

from slopewalk.bench.sim.env import ActionError, TrialEnv, open_loop
from slopewalk.bench.sim.playback import initial_state, play, recording_from_rollout
from slopewalk.bench.sim.trial_spec import TrialSpec
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.kinematics import rotation_slope_to_world
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.spec import load_spec

SENSOR_SERIES = ("q", "actuator_force", "foot_force", "foot_cop", "cop", "sole", "foot_normal")
SENSOR_SERIES += ("pelvis_height", "pelvis_qpos", "touching")


def _short_env(**kwargs) -> TrialEnv:
    spec = load_spec()
    trial = TrialSpec(GaitParams.nominal(spec, 0.3, steps=1))
    return TrialEnv(spec, trial, settle=0.05, hold=0.05, **kwargs)


class TrialEnvConformanceTest(test_utils.EnvironmentTestMixin, absltest.TestCase):
    """dm_env's own contract checks, over whole episodes of a short trial."""

    def make_object_under_test(self):
        return _short_env()

    def make_action_sequence(self):
        """Stand in the first pose past the episode's end (~470 periods) and into a new one."""
        stand = self.environment.plan.q_left_right[0]
        for _ in range(2 * 500):
            yield stand


def _play_open_loop(env: TrialEnv):
    step, periods = env.reset(), 0
    while not step.last():
        step = env.step(open_loop(step.observation))
        periods += 1
    return step, periods


@pytest.mark.parametrize(
    "step_time, slope, actuators",
    [(1.0, 0.0, "stiff"), (0.4, 0.0, "stiff"), (1.0, 25.0, "stiff"), (1.0, 0.0, "servo_ff")],
)
def test_the_open_loop_policy_reproduces_the_rollout_to_the_last_bit(
    spec, step_time, slope, actuators
):
    """Stable (1 s flat), falling (0.4 s) and tipping (25°) trials, every sensor series;
    and a feedforward mode, whose plan command carries the torque feedforward."""
    gait = GaitParams.nominal(spec, step_time, slope=np.deg2rad(slope), steps=2)
    trial = TrialSpec(gait, actuators=actuators)
    plan = plan_walk(spec, trial.gait)
    expected = play(plan, actuators=actuators)
    env = TrialEnv(spec, trial, plan=plan, end_at_fall=False)
    step, periods = _play_open_loop(env)
    got = env.recording()
    assert step.discount == 1.0  # played to the end, as the rollout does
    assert step.observation["time"] == pytest.approx(expected.t[-1] + trial.timestep, abs=1e-12)
    assert periods == np.count_nonzero(expected.t >= 0)
    assert np.array_equal(got.t, expected.t)
    assert np.array_equal(got.q_ref, expected.q_ref)
    for name in SENSOR_SERIES:
        a, b = getattr(got.sensors, name), getattr(expected.sensors, name)
        assert np.array_equal(a, b, equal_nan=True), name
    assert got.diverged_at == expected.diverged_at


def test_a_blow_up_ends_the_episode_where_the_rollout_stops(spec, tmp_path, monkeypatch):
    """Explicit Euler with absurd gains: MuJoCo warns and resets; both paths cut the same row."""
    monkeypatch.chdir(tmp_path)
    trial = TrialSpec(GaitParams.nominal(spec, 1.0, steps=1), timestep=0.004)
    env = TrialEnv(spec, trial, end_at_fall=False, settle=0.1, hold=0.0)
    model = env.model  # the env steps this very model: break it in place
    model.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    model.actuator_gainprm[:, 0] *= 1e6
    model.actuator_biasprm[:, 1] *= 1e6
    model.actuator_forcelimited[:] = 0
    step, _ = _play_open_loop(env)
    assert env.ended == "diverged" and step.discount == 0.0
    got = env.recording()
    t, q_ref = env._t, env._ctrl_ref
    state, sensordata = rollout.rollout(
        model, mujoco.MjData(model), initial_state(model, env.plan), q_ref[None]
    )
    expected = recording_from_rollout(
        model, state[0], sensordata[0], t, q_ref, rotation_slope_to_world(0.0), 50.0
    )
    assert expected.diverged_at is not None
    assert got.diverged_at == expected.diverged_at
    assert np.array_equal(got.sensors.q, expected.sensors.q)
    assert list(tmp_path.iterdir()) == []


def test_reset_settles_the_robot_at_the_plans_first_pose(spec):
    """Walk time 0, both feet flat and loaded with the weight's normal part, CoM as planned."""
    slope = np.deg2rad(10.0)
    trial = TrialSpec(GaitParams.nominal(spec, 1.0, slope=slope))
    env = TrialEnv(spec, trial)
    obs = env.reset().observation
    assert obs["time"] == 0.0
    assert np.array_equal(obs["q_ref"], env.plan.q_left_right[0])
    np.testing.assert_allclose(obs["q"], obs["q_ref"], atol=np.deg2rad(1.0))
    weight = spec.total_mass * 9.81
    np.testing.assert_allclose(obs["foot_force"][:, 2].sum(), weight * np.cos(slope), rtol=0.02)
    # the tangential force holds the robot on the slope: m g sin(slope) uphill
    np.testing.assert_allclose(obs["foot_force"][:, 0].sum(), weight * np.sin(slope), rtol=0.05)
    np.testing.assert_allclose(obs["foot_normal"][:, 2], 1.0, atol=1e-3)
    np.testing.assert_allclose(obs["com"], obs["com_ref"], atol=0.005)
    np.testing.assert_allclose(obs["pelvis_quat"] @ obs["pelvis_quat"], 1.0)
    toe, heel, half_width = obs["foot_size"]
    for foot in (0, 1):
        offset = obs["foot_cop"][foot] - obs["sole"][foot, :2]
        assert -heel <= offset[0] <= toe and abs(offset[1]) <= half_width
    for name, spec_ in env.observation_spec().items():
        spec_.validate(obs[name])


def test_a_fall_ends_the_episode_with_discount_zero(spec):
    """0.4 s steps fall open loop; with ``end_at_fall`` the episode stops there."""
    env = TrialEnv(spec, TrialSpec(GaitParams.nominal(spec, 0.4)))
    step, periods = _play_open_loop(env)
    assert env.ended == "fall" and step.last() and step.discount == 0.0
    assert periods < np.count_nonzero(env._t >= 0)
    assert env.recording().t.size == env._settle_rows + periods


@pytest.mark.parametrize(
    "action, fragment",
    [(np.zeros(7), "shape (7,): must be (8,)"), (np.full(8, np.nan), "must be finite")],
)
def test_a_bad_action_is_refused(action, fragment):
    env = _short_env()
    env.reset()
    with pytest.raises(ActionError, match=fragment.replace("(", r"\(").replace(")", r"\)")):
        env.step(action)


def test_the_environment_alone_is_the_nominal_flat_trial(spec):
    env = TrialEnv()
    assert env.trial == TrialSpec(GaitParams.nominal(spec, 1.0))
    assert env.action_spec().shape == (8,) and env.model.opt.timestep == 0.001


def test_step_before_reset_starts_an_episode():
    env = _short_env()
    assert env.step(np.zeros(8)).step_type is dm_env.StepType.FIRST
