"""The floor's give: the sole-corner stiffness derived from MuJoCo's solref/solimp
against the tilt MuJoCo gives a standing robot under a known moment."""

from dataclasses import replace

import mujoco
import numpy as np
import pytest

from slopewalk.bench.sim.floor import (
    SoftFloor,
    corner_stiffness,
    impedance,
    scene_corner_stiffness,
    sole_equilibrium,
)
from slopewalk.bench.sim.model import scene_xml


def test_impedance_follows_mujocos_sigmoid():
    solimp = (0.9, 0.95, 0.001, 0.5, 2.0)
    assert impedance(0.0, solimp)[0] == pytest.approx(0.9)
    assert impedance(0.0005, solimp)[0] == pytest.approx(0.925)  # the midpoint: halfway
    assert impedance(0.00025, solimp)[0] == pytest.approx(0.9 + 0.05 * 2 * 0.25**2)
    assert impedance(0.002, solimp)[0] == pytest.approx(0.95)  # past the width: d_max


def test_a_heavier_load_presses_deeper_and_stiffens_the_corner(spec):
    model = mujoco.MjModel.from_xml_string(scene_xml(spec))
    assert corner_stiffness(model, 100.0) > corner_stiffness(model, 1.0)


@pytest.mark.parametrize("contact", [(0.02, 1.0), (0.04, 1.0), (0.02, 0.5)])
def test_the_derived_stiffness_gives_the_tilt_mujoco_measures(spec, contact):
    """Both feet flat, a pitch moment τ on the pelvis: the soles turn by τ / k_rot with
    k_rot = k_c Σ (x_i − m)² over the 8 sole corners = 2 k_c L²; on the default contact,
    a softer one and a stiffer one (the spec's ``[contact]``: τ [s], ζ)."""
    spec = replace(spec, contact_timeconst=contact[0], contact_dampratio=contact[1])
    model = mujoco.MjModel.from_xml_string(scene_xml(spec, actuators="stiff"))
    data = mujoco.MjData(model)
    feet = [model.body(name).id for name in ("l_foot", "r_foot")]
    pelvis = model.body("pelvis").id

    def pitch():
        return np.mean([np.arctan2(data.xmat[b][2], data.xmat[b][8]) for b in feet])

    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_step(model, data, 1000)
    before = pitch()
    moment = 0.1  # [N m] about y
    data.xfrc_applied[pelvis, 4] = moment
    mujoco.mj_step(model, data, 1500)
    turned = pitch() - before
    k_rot = 2 * scene_corner_stiffness(model) * spec.foot_length**2
    assert turned == pytest.approx(moment / k_rot, rel=0.05)


@pytest.fixture(scope="module")
def floor(spec):
    return SoftFloor.of_scene(mujoco.MjModel.from_xml_string(scene_xml(spec)))


def test_the_corner_force_slope_is_its_derivative(floor):
    r = np.linspace(1e-6, 1.5e-3, 40)  # across the impedance's width and past it
    h = 1e-9
    numeric = (floor.corner_force(r + h)[0] - floor.corner_force(r - h)[0]) / (2 * h)
    np.testing.assert_allclose(floor.corner_force(r)[1], numeric, rtol=1e-5)
    assert floor.corner_force(-1e-4) == (0.0, 0.0)  # a corner in the air pushes nothing


def test_a_centred_load_sinks_the_sole_evenly_by_the_corner_stiffness(spec, floor):
    model = mujoco.MjModel.from_xml_string(scene_xml(spec))
    weight = 6.0
    r0, theta_x, theta_y = sole_equilibrium(
        floor, [weight], [[0.0, 0.0]], length=spec.foot_length, width=spec.foot_width
    )[0]
    assert r0 == pytest.approx(weight / 4 / corner_stiffness(model, weight), rel=1e-6)
    assert abs(theta_x) < 1e-12 and abs(theta_y) < 1e-12


def test_the_sole_equilibrium_carries_the_load_at_its_cop(spec, floor):
    """Σ f_i = F_n and Σ f_i (x_i, y_i) = F_n (p − m) at the solution, for CoPs from the
    centre to near a corner (where corners lift); a CoP beyond the sole stands the sole on
    its edge, the far corners carrying nothing; a sole in the air neither sinks nor turns."""
    length, width = spec.foot_length, spec.foot_width
    offset = np.array([[0.0, 0.0], [0.01, -0.005], [0.04, 0.025], [-0.045, 0.028], [0.08, 0.0]])
    load = np.array([6.5, 3.0, 6.5, 1.0, 4.0])
    u = sole_equilibrium(floor, load, offset, length=length, width=width)
    x = np.array([1, 1, -1, -1]) * length / 2
    y = np.array([1, -1, 1, -1]) * width / 2
    force = floor.corner_force(u[:, :1] - u[:, 1:2] * y + u[:, 2:3] * x)[0]  # (5, 4)
    held = np.clip(offset, -np.array([length, width]) / 2, np.array([length, width]) / 2)
    np.testing.assert_allclose(force.sum(axis=1), load, rtol=1e-9)
    np.testing.assert_allclose(force @ x, load * held[:, 0], rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(force @ y, load * held[:, 1], rtol=1e-6, atol=1e-9)
    assert np.all(force[1] > 0) and np.count_nonzero(force[2]) < 4  # near a corner one lifts
    np.testing.assert_allclose(force[4, 2:], 0.0, atol=1e-6 * load[4])  # on the toe edge
    assert np.all(sole_equilibrium(floor, [0.0], [[0.01, 0.0]], length=length, width=width) == 0)


def test_a_two_box_sole_balances_its_load_on_all_eight_corners(spec, floor):
    """Given corners (an imported two-box sole: 8 corners, 4 of them on the seam), the
    corner forces still carry the load at its CoP, and each corner's penetration is the
    sole's rigid turn: Σ f_i = F_n, Σ f_i (x_i, y_i) = F_n p."""
    length, width = 0.14, 0.07
    x = np.array([-0.07, -0.01, -0.07, -0.01, -0.01, 0.07, -0.01, 0.07])
    y = np.array([-1, -1, 1, 1, -1, -1, 1, 1]) * width / 2
    offset = np.array([[0.0, 0.0], [0.02, -0.01], [-0.05, 0.03]])
    load = np.array([20.0, 30.0, 10.0])
    u = sole_equilibrium(floor, load, offset, length=length, width=width,
                         corners=np.column_stack([x, y]))  # fmt: skip
    force = floor.corner_force(u[:, :1] - u[:, 1:2] * y + u[:, 2:3] * x)[0]  # (3, 8)
    np.testing.assert_allclose(force.sum(axis=1), load, rtol=1e-9)
    np.testing.assert_allclose(force @ x, load * offset[:, 0], rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(force @ y, load * offset[:, 1], rtol=1e-6, atol=1e-9)
    four = sole_equilibrium(floor, load, offset, length=length, width=width)
    assert np.all(np.abs(u[1:, 1]) < np.abs(four[1:, 1]))  # twice the corners across: less roll
