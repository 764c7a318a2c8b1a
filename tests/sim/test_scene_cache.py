"""The scenes a process keeps (bench/sim/model.py ``scene_xml``, playback.py ``build_model``):
a kept scene is the one built from its options, another robot or option is another
scene, and a kept model is handed out as a copy, the caller's to change."""

from dataclasses import replace

import numpy as np
import pytest

from slopewalk.bench.sim import model as sim_model
from slopewalk.bench.sim import playback
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import plan_walk


@pytest.mark.parametrize(
    "options",
    [
        {"slope": 0.0},
        {"slope": -0.0},
        {"slope": np.deg2rad(12.5), "friction": 0.4},
        {"slope": np.deg2rad(-8), "actuators": "servo", "timestep": 0.002},
    ],
)
def test_a_kept_scene_is_the_scene_its_options_build(spec, options):
    full = {"slope": 0.0, "friction": 1.0, "actuators": "stiff", "timestep": 0.001} | options
    first = sim_model.scene_xml(spec, **options)
    assert sim_model.scene_xml(spec, **options) is first  # kept
    assert first == sim_model._scene_xml(spec, *full.values())


def test_another_robot_or_option_is_another_scene(spec):
    base = sim_model.scene_xml(spec, slope=0.1)
    longer = replace(spec, thigh=spec.thigh * 1.1)
    assert sim_model.scene_xml(longer, slope=0.1) != base
    assert sim_model.scene_xml(spec, slope=0.1, friction=0.5) != base
    assert sim_model.scene_xml(spec, slope=-0.0) != sim_model.scene_xml(spec, slope=0.0)


def test_a_kept_model_is_handed_out_as_a_copy(spec):
    plan = plan_walk(spec, GaitParams.nominal(spec, 1.0, steps=1))
    first = playback.build_model(plan, friction=1.0, actuators="stiff", timestep=0.001)
    solref = first.geom_solref.copy()
    first.geom_solref[:, 0] = 0.5  # a caller's change (experiments/cop_error does so)
    again = playback.build_model(plan, friction=1.0, actuators="stiff", timestep=0.001)
    np.testing.assert_array_equal(again.geom_solref, solref)
    assert again.nsensor == first.nsensor > 0  # the trial sensors, added once
