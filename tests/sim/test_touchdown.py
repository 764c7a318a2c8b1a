"""Touch-down on time: the legs shortened by the floor's sink (``bench/sim/touchdown.py``)."""

import mujoco
import numpy as np
import pytest

from slopewalk.bench.sim.floor import SoftFloor, foot_deflection, foot_loads
from slopewalk.bench.sim.model import scene_xml
from slopewalk.bench.sim.support import planned_contact
from slopewalk.bench.sim.touchdown import leg_offsets, leg_shortening
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.joints import LEFT
from slopewalk.planner.kinematics import Chain
from slopewalk.planner.plan import plan_walk


@pytest.fixture(scope="module")
def plan(spec):
    return plan_walk(spec, GaitParams.nominal(spec, 2.0, steps=2))


@pytest.fixture(scope="module")
def raised(plan):
    model = mujoco.MjModel.from_xml_string(scene_xml(plan.spec))
    _, sink = foot_deflection(plan, SoftFloor.of_scene(model))
    return sink, leg_shortening(plan, sink)


def _soles_in_slope(plan, q_left_right, rows):
    """Sole sites and foot rotations in S with the pelvis posed as planned, (r, 2, 3), (r, 2, 9)."""
    model = mujoco.MjModel.from_xml_string(scene_xml(plan.spec))
    data = mujoco.MjData(model)
    chain = Chain.from_spec(plan.spec)
    frames = chain.frames(plan.q[rows], plan.stance_sole[rows], plan.stance[rows])
    origin, rotation = chain.pelvis_pose(frames, plan.stance[rows])
    sites = [model.site(f"{p}sole").id for p in ("l_", "r_")]
    feet = [model.body(f"{p}foot").id for p in ("l_", "r_")]
    pos, rot = [], []
    for i, row in enumerate(rows):
        data.qpos[:3] = origin[i]
        mujoco.mju_mat2Quat(data.qpos[3:7], rotation[i].reshape(-1))
        data.qpos[7:15] = q_left_right[row]
        mujoco.mj_kinematics(model, data)
        pos.append(data.site_xpos[sites].copy())
        rot.append(data.xmat[feet].copy())
    return np.array(pos), np.array(rot)


def test_the_offsets_raise_each_sole_along_the_plane_normal_keeping_it_flat(plan):
    """MuJoCo's kinematics, pelvis as planned: a raise c lifts each sole by c along z_S
    (to 1e-3 of c) and moves it c tan λ sideways at most, the foot's axes unchanged."""
    rows = np.arange(0, plan.t.size, 251)
    raise_ = np.column_stack([np.full(plan.t.size, 2e-4), np.full(plan.t.size, 1e-4)])
    before, turn_before = _soles_in_slope(plan, plan.q_left_right, rows)
    after, turn_after = _soles_in_slope(plan, plan.q_left_right + leg_offsets(plan, raise_), rows)
    moved = after - before  # (r, 2, 3)
    np.testing.assert_allclose(moved[..., 2], raise_[rows], rtol=1e-3)
    lean = np.abs(plan.q_left_right[rows][:, [3, 7]])
    assert np.all(np.abs(moved[..., 1]) <= raise_[rows] * np.tan(lean) * 1.01 + 1e-9)
    assert np.abs(moved[..., 0]).max() < 1e-3 * raise_.max()
    np.testing.assert_allclose(turn_after, turn_before, atol=1e-9)
    assert np.abs(leg_offsets(plan, np.zeros_like(raise_))).max() < 1e-12


def test_the_swing_sole_waits_at_the_stance_soles_sink_above_the_plan(plan, raised):
    """Late in single support the swing sole is raised by the stance sole's sink, the
    stance leg as planned; no raise is negative."""
    sink, raise_ = raised
    left = plan.stance == LEFT
    late = ~plan.double_support & (np.gradient(plan.swing_sole[:, 2]) < 0)
    stance = np.where(left, 0, 1)
    n = np.arange(plan.t.size)
    np.testing.assert_allclose(raise_[n, 1 - stance][late], sink[n, stance][late], rtol=1e-12)
    assert np.all(raise_[n, stance][~plan.double_support] == 0.0)
    assert raise_.min() >= 0.0 and raise_.max() > 5e-5


def test_no_foot_on_the_floor_is_raised(plan, raised):
    """While the plan has a foot on the plane its raise never grows, stays within the two
    sinks' difference, and is 0 on the foot a double support unloads."""
    sink, raise_ = raised
    on_floor = planned_contact(plan, plan.t)
    both = on_floor[1:] & on_floor[:-1]
    assert np.all(np.diff(raise_, axis=0)[both] <= 0.0)
    assert np.all(raise_ <= sink.max(axis=1, keepdims=True) - sink + 1e-15)
    _, load = foot_loads(plan)
    unloading = plan.double_support[:-1, None] & (np.diff(load, axis=0) < 0)
    assert np.all(raise_[:-1][unloading] == 0.0)


def test_the_raise_never_steps(plan, raised):
    """From one 1 ms sample to the next a raise changes by no more than the sinks and the
    planned lift it is made of change in that sample: it adds no step of its own (dropping
    the landing foot's raise at its touch-down would step it by the whole sink)."""
    sink, raise_ = raised
    bound = np.abs(np.diff(sink, axis=0)).sum(axis=1) + np.abs(np.diff(plan.swing_sole[:, 2]))
    assert np.all(np.abs(np.diff(raise_, axis=0)) <= bound[:, None] + 1e-15)
