"""The floor's give: the sole-corner stiffness derived from MuJoCo's solref/solimp
against the tilt MuJoCo gives a standing robot under a known moment."""

import mujoco
import numpy as np
import pytest

from bench.sim.floor import corner_stiffness, impedance, scene_corner_stiffness
from bench.sim.model import scene_xml


def test_impedance_follows_mujocos_sigmoid():
    solimp = (0.9, 0.95, 0.001, 0.5, 2.0)
    assert impedance(0.0, solimp) == pytest.approx(0.9)
    assert impedance(0.0005, solimp) == pytest.approx(0.925)  # the midpoint: halfway
    assert impedance(0.00025, solimp) == pytest.approx(0.9 + 0.05 * 2 * 0.25**2)
    assert impedance(0.002, solimp) == pytest.approx(0.95)  # past the width: d_max


def test_a_heavier_load_presses_deeper_and_stiffens_the_corner(spec):
    model = mujoco.MjModel.from_xml_string(scene_xml(spec))
    assert corner_stiffness(model, 100.0) > corner_stiffness(model, 1.0)


def test_the_derived_stiffness_gives_the_tilt_mujoco_measures(spec):
    """Both feet flat, a pitch moment τ on the pelvis: the soles turn by τ / k_rot with
    k_rot = k_c Σ (x_i − m)² over the 8 sole corners = 2 k_c L²."""
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
