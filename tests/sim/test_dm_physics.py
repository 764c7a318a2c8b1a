"""``TrialEnv.physics``: the environment's own MjData as a dm_control ``Physics``, or why not.

dm-control is not a dependency: the tests that use it run where it is installed and
works with the MuJoCo installed (dm-control 1.0.50 with mujoco 3.17), and are skipped
elsewhere with the reason ``physics`` gives. The refusals are tested everywhere.
"""

import sys
import types

import mujoco
import numpy as np
import pytest

from slopewalk.bench.sim.dm_physics import WORKS_WITH, PhysicsUnavailable
from slopewalk.bench.sim.env import TrialEnv, open_loop
from slopewalk.bench.sim.trial_spec import TrialSpec
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.joints import MJCF_JOINTS
from slopewalk.planner.spec import load_spec

SERIES = ("q", "actuator_force", "foot_force", "cop", "sole", "pelvis_qpos", "touching")


def _short_env() -> TrialEnv:
    spec = load_spec()
    return TrialEnv(spec, TrialSpec(GaitParams.nominal(spec, 0.3, steps=1)), settle=0.05, hold=0.05)


def _physics(env: TrialEnv):
    try:
        return env.physics
    except PhysicsUnavailable as err:
        pytest.skip(f"dm_control is not usable beside mujoco {mujoco.__version__}: {err}")


def test_physics_reads_and_follows_the_state_the_environment_steps():
    env = _short_env()
    step = env.reset()
    physics = _physics(env)
    assert physics.data.ptr is env.data and physics.model.ptr is env.model  # shared, not copied
    start, start_time = physics.named.data.qpos[list(MJCF_JOINTS)].copy(), physics.data.time
    # the joint sensors the observation is made of, against dm_control's named qpos
    assert np.array_equal(physics.named.data.qpos[list(MJCF_JOINTS)], step.observation["q"])
    for _ in range(50):
        step = env.step(open_loop(step.observation))
    moved = physics.named.data.qpos[list(MJCF_JOINTS)]
    assert physics.data.time == pytest.approx(start_time + 50 * env.trial.timestep, abs=1e-12)
    assert np.array_equal(moved, step.observation["q"]) and not np.array_equal(moved, start)


def test_making_the_physics_leaves_the_episode_bit_for_bit():
    """dm_control runs mj_forward on the shared data; the state and warm start stay."""
    recordings = []
    for with_physics in (False, True):
        env = _short_env()
        step = env.reset()
        if with_physics:
            _physics(env)
        while not step.last():
            step = env.step(open_loop(step.observation))
        recordings.append(env.recording())
    plain, wrapped = recordings
    for name in SERIES:
        a, b = getattr(plain.sensors, name), getattr(wrapped.sensors, name)
        assert np.array_equal(a, b, equal_nan=True), name


def _refusal(env: TrialEnv) -> str:
    with pytest.raises(PhysicsUnavailable) as refused:
        env.physics  # noqa: B018 (the property is the call under test)
    message = str(refused.value)
    assert "\n" not in message and WORKS_WITH in message
    return message


def test_without_dm_control_physics_says_so_in_one_line(monkeypatch):
    for name in ("dm_control", "dm_control.mujoco"):  # importing them fails, even if imported
        monkeypatch.setitem(sys.modules, name, None)
    assert "TrialEnv.physics needs dm_control, which slopewalk does not install" in _refusal(
        _short_env()
    )


def test_a_dm_control_that_fails_on_this_mujoco_says_so_in_one_line(monkeypatch):
    """As dm-control 1.0.50 does on MuJoCo 4.0: it imports, then fails on first use."""

    def physics(_data):
        raise AttributeError("'MjModel' object has no attribute 'flex_vertedge'")

    engine = types.ModuleType("dm_control.mujoco")
    engine.Physics = physics
    engine.wrapper = types.SimpleNamespace(MjData=lambda data: data)
    monkeypatch.setitem(sys.modules, "dm_control", types.ModuleType("dm_control"))
    monkeypatch.setitem(sys.modules, "dm_control.mujoco", engine)
    message = _refusal(_short_env())
    assert f" does not work with mujoco {mujoco.__version__} (AttributeError: " in message
    assert "flex_vertedge" in message
