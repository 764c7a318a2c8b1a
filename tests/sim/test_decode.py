"""Decoding sensor rows written by hand into a compiled trial model's ``sensordata`` layout.

The layout is MuJoCo's (``model.sensor_adr``, ``sensor_dim``); the rows are ours, so the
answer is known exactly: a normal-force-weighted CoP per foot and for both, light loads
included, empty contact slots ignored by their ``found`` flag, points and forces turned
into the slope frame, non-foot touches per row.
"""

import numpy as np
import pytest

from slopewalk.bench.sim.contact import MAX_CONTACTS, NON_FOOT_BODIES, decode
from slopewalk.bench.sim.playback import build_model
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.kinematics import rotation_slope_to_world
from slopewalk.planner.plan import plan_walk


@pytest.fixture  # per test: mutmut maps a test to the code its fixtures run
def model(spec):
    plan = plan_walk(spec, GaitParams.nominal(spec, 1.0, steps=1))
    return build_model(plan, friction=1.0, actuators="stiff", timestep=0.001)


def _put(model, row, name, values):
    i = model.sensor(name).id
    adr, dim = model.sensor_adr[i], model.sensor_dim[i]
    row[adr : adr + dim] = np.resize(np.asarray(values, float), dim)


def _contacts(slots) -> np.ndarray:
    """(found, normal, t1, t2, x, y, z) per slot, MAX_CONTACTS slots."""
    out = np.zeros((MAX_CONTACTS, 7))
    out[: len(slots)] = slots
    return out.reshape(-1)


def test_cop_of_hand_written_contacts_on_a_slope(model):
    slope = np.deg2rad(12.0)
    R = rotation_slope_to_world(slope)
    in_world = R @ np.array([[0.1, 0.02, 0.0], [0.14, 0.03, 0.0], [0.05, -0.05, 0.0]]).T
    rows = np.zeros((3, model.nsensordata))
    # row 0: left foot two contacts (3 N, 1 N), right foot a light 0.5 N one; an empty
    # slot with leftover numbers but found = 0, which must be ignored
    left = _contacts([[1, 3.0, 0, 0, *in_world[:, 0]], [1, 1.0, 0, 0, *in_world[:, 1]],
                      [0, 9.0, 0, 0, 1.0, 1.0, 1.0]])  # fmt: skip
    right = _contacts([[1, 0.5, 0, 0, *in_world[:, 2]]])
    _put(model, rows[0], "l_foot_contacts", left)
    _put(model, rows[0], "r_foot_contacts", right)
    _put(model, rows[0], "l_foot_net", -(R @ [0.0, 0.0, 4.0]))  # foot on floor, world
    _put(model, rows[0], "r_foot_net", -(R @ [0.1, 0.0, 0.5]))
    _put(model, rows[0], f"{NON_FOOT_BODIES[2]}_touch", [1.0])
    # row 1: nothing touches; row 2: only a light 0.5 N contact under the right foot
    _put(model, rows[2], "r_foot_contacts", right)
    s = decode(model, rows, R)
    np.testing.assert_allclose(s.foot_cop[0, 0], [(3 * 0.1 + 0.14) / 4, (3 * 0.02 + 0.03) / 4])
    np.testing.assert_allclose(s.foot_cop[0, 1], [0.05, -0.05], atol=1e-12)
    np.testing.assert_allclose(
        s.cop[0], [(3 * 0.1 + 0.14 + 0.5 * 0.05) / 4.5, (3 * 0.02 + 0.03 - 0.5 * 0.05) / 4.5]
    )
    np.testing.assert_allclose(s.foot_force[0], [[0, 0, 4.0], [0.1, 0, 0.5]], atol=1e-12)
    assert np.isnan(s.foot_cop[1]).all() and np.isnan(s.cop[1]).all()
    assert np.isnan(s.foot_cop[2, 0]).all()
    np.testing.assert_allclose(s.foot_cop[2, 1], [0.05, -0.05], atol=1e-12)
    np.testing.assert_allclose(s.cop[2], [0.05, -0.05], atol=1e-12)  # a light load has a CoP
    assert s.touching.tolist() == [True, False, False]
