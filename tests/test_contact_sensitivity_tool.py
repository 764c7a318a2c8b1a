"""``tools/contact_sensitivity.py`` scales the contact of the model a trial plays, and only
that model: the cached compile stays as it was, so no play compounds another's scale."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from slopewalk.bench.sim import playback
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import plan_walk

TOOL = Path(__file__).resolve().parents[1] / "tools" / "contact_sensitivity.py"


@pytest.fixture
def tool(monkeypatch):
    spec = importlib.util.spec_from_file_location("contact_sensitivity", TOOL)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    monkeypatch.setattr(playback, "build_model", playback.build_model)  # restored after
    module._scaled_builds()
    return module


@pytest.mark.parametrize("variant", range(4))
def test_each_variant_scales_its_solref_column_of_the_played_model_alone(spec, tool, variant):
    plan = plan_walk(spec, GaitParams.nominal(spec, 1.0, steps=2))
    scene = dict(friction=1.0, actuators="servo", timestep=0.001)
    tool._SCALE = (0, 1.0)
    plain = playback.build_model(plan, **scene).geom_solref.copy()
    np.testing.assert_array_equal(plain, np.tile([0.02, 1.0], (len(plain), 1)))  # the default
    _, column, factor = tool.VARIANTS[variant]
    tool._SCALE = (column, factor)
    want = plain.copy()
    want[:, column] *= factor
    for _ in range(2):  # a second play is scaled once, not twice
        np.testing.assert_array_equal(playback.build_model(plan, **scene).geom_solref, want)
