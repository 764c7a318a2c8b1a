"""GaitParams validation at its boundaries, and the GA's batch path against plan_walk.

Each range in ``GaitParams``'s docstring is checked on both sides of its edge (the
edge value itself where the range says open or closed), with the one-line message
that names the value and the range.
"""

from dataclasses import replace

import numpy as np
import pytest

from slopewalk.planner.errors import GaitError
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import evaluate, plan_walk


@pytest.mark.parametrize(
    "field, value, message",
    [
        ("step_time", 0.0, "step time 0.0 s: must lie in (0, 60] s"),
        ("slope", np.deg2rad(60.0001), "deg: must lie in (-60, 60) deg"),
        ("slope", -np.deg2rad(60.0001), "deg: must lie in (-60, 60) deg"),
        ("hip_height", 0.0, "hip height 0.0 m: must be a finite length > 0 m"),
        ("swing_lift", -1e-3, "swing lift -0.001 m: must be a finite length >= 0 m"),
        ("tilt", np.pi / 4, "tilt 45.0 deg: must lie in (-45, 45) deg"),
        ("tilt", np.deg2rad(50.0), "tilt 50.0 deg: must lie in (-45, 45) deg"),
        ("steps", 0, "steps 0: must be an integer in [1, 1000]"),
        ("steps", 1.5, "steps 1.5: must be an integer in [1, 1000]"),
        ("step_length", 0.0, "step length 0.0 m: must be a finite length > 0 m"),
        ("ssp_fraction", 0.0, "ssp fraction 0.0: must lie in (0, 1)"),
        ("ssp_fraction", 1.0, "ssp fraction 1.0: must lie in (0, 1)"),
        ("tilt_profile", "wave", "tilt profile 'wave': must be one of sway, hold"),
        ("tilt_profile", "blend", "tilt profile 'blend': give its sway share in (0, 1)"),
        ("sway_share", -1e-9, "sway share -1e-09: must lie in [0, 1]"),
        ("sway_share", 1.0 + 1e-9, "sway share 1.000000001: must lie in [0, 1]"),
        ("pelvis_offset", np.inf, "pelvis offset inf m: must be a finite length"),
        ("dt", 0.0, "dt 0.0 s: must lie in (0, 0.1] s"),
        ("dt", 0.2, "dt 0.2 s: must lie in (0, 0.1] s"),
    ],
)
def test_out_of_range_is_refused_in_one_line(field, value, message):
    with pytest.raises(GaitError) as error:
        GaitParams(**{"step_time": 1.0, field: value})
    assert message in str(error.value) and "\n" not in str(error.value)
    assert str(error.value).startswith(field.replace("_", " "))


@pytest.mark.parametrize(
    "field, value",
    [
        ("step_time", 1e-2),  # the shortest step, with a finer dt
        ("slope", np.deg2rad(59.9)),
        ("swing_lift", 0.0),  # a shuffle is allowed
        ("tilt", np.deg2rad(44.0)),
        ("tilt", np.deg2rad(-40.0)),
        ("steps", 1),
        ("steps", np.int64(3)),
        ("ssp_fraction", 0.99),
        ("ssp_fraction", 0.01),
        ("dt", 0.1),  # exactly step_time / 10
        ("sway_share", 0.0),
        ("sway_share", 1.0),
        ("pelvis_offset", -0.02),
    ],
)
def test_edges_inside_the_range_are_accepted(field, value):
    extra = {"dt": 1e-4} if field == "step_time" else {}
    GaitParams(**{"step_time": 1.0, field: value, **extra})


def test_population_batch_equals_planning_each_individual(spec):
    """``evaluate`` over a GA population agrees with ``plan_walk`` of each individual.

    ``evaluate`` also samples both sides of every phase change and refines the margin
    between samples (``planner/plan.py``): its work may differ by that extra sampling
    (measured 1.4e-4 relative) and its margin is at most the plan's, within a fraction
    of a millimetre.
    """
    params = GaitParams.nominal(spec, 0.8, slope=np.deg2rad(5.0), steps=3)
    population = np.array(
        [[0.19, 0.05, np.deg2rad(8.0)], [0.2, 0.0666, np.deg2rad(12.0)], [0.18, 0.03, 0.15]]
    )
    work, margin = evaluate(spec, params, population)
    for k, (hz, lift, tilt) in enumerate(population):
        single = GaitParams.nominal(
            spec, 0.8, slope=np.deg2rad(5.0), steps=3, hip_height=hz, swing_lift=lift, tilt=tilt
        )
        plan = plan_walk(spec, single)
        assert work[k] == pytest.approx(plan.work.sum(), rel=1e-3)
        assert plan.margin.min() - 2e-4 <= margin[k] <= plan.margin.min() + 1e-12
    assert len(set(np.round(work, 9))) == 3  # three different walks


@pytest.mark.parametrize(
    "fields, message",
    [
        ({"tilt_profile": "sway", "sway_share": 0.5}, "tilt profile 'sway' and sway share 0.5"),
        ({"tilt_profile": "hold", "sway_share": 1.0}, "tilt profile 'hold' and sway share 1"),
        ({"tilt_profile": "blend", "sway_share": 0.0}, "tilt profile 'blend' and sway share 0"),
        ({"sway_share": "half"}, "sway share 'half': must lie in [0, 1]"),
        ({"sway_share": np.nan}, "sway share nan: must lie in [0, 1]"),
    ],
)
def test_a_lean_given_twice_must_agree(fields, message):
    with pytest.raises(GaitError) as error:
        GaitParams(step_time=1.0, **fields)
    assert message in str(error.value) and "\n" not in str(error.value)


@pytest.mark.parametrize(
    "fields, expected",
    [
        ({}, ("hold", 0.0)),
        ({"tilt_profile": "sway"}, ("sway", 1.0)),
        ({"sway_share": 0.0}, ("hold", 0.0)),
        ({"sway_share": 1.0}, ("sway", 1.0)),
        ({"sway_share": 0.25}, ("blend", 0.25)),
        ({"tilt_profile": "blend", "sway_share": 0.25}, ("blend", 0.25)),
    ],
)
def test_the_profile_names_the_ends_of_the_sway_share(fields, expected):
    params = GaitParams(step_time=1.0, **fields)
    assert (params.lean_profile, params.lean_share) == expected
    assert replace(params, dt=2e-3).lean_share == expected[1]  # a copy keeps its lean
    if "sway_share" not in fields:  # a lean given by its name changes with it
        assert replace(params, tilt_profile="sway").lean_share == 1.0


def test_a_pelvis_offset_past_the_legs_reach_is_refused_before_planning(spec):
    with pytest.raises(GaitError) as error:
        plan_walk(spec, GaitParams.nominal(spec, 1.0, pelvis_offset=-0.3))
    assert "pelvis offset -0.3 m: must lie in (-0.222, 0.222) m" in str(error.value)
