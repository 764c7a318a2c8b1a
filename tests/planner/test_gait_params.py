"""GaitParams refuses what is not a walk, through the API, in one line with the range."""

import math
from dataclasses import replace

import pytest

from slopewalk.planner.errors import GaitError
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.ranges import Range

NAN, INF = math.nan, math.inf


@pytest.mark.parametrize(
    "fields, message",
    [
        ({"step_time": INF}, "step time inf s: must lie in (0, 60] s"),
        ({"step_time": NAN}, "step time nan s: must lie in (0, 60] s"),
        ({"step_time": 1e5}, "step time 100000.0 s: must lie in (0, 60] s"),
        ({"step_time": "1"}, "step time '1': must lie in (0, 60] s"),
        ({"step_time": True}, "step time True: must lie in"),
        ({"step_time": 0.005}, "step time 0.005 s: must lie in [0.01, 60] s"),
        ({"steps": 100_000}, "steps 100000: must be an integer in [1, 1000]"),
        ({"steps": 2.0}, "steps 2.0: must be an integer in [1, 1000]"),
        ({"step_time": 60, "steps": 1000}, "6e+07 samples: must be <= 1e+06"),
        ({"dt": 1e-9}, "samples: must be <= 1e+06"),
        ({"dt": NAN}, "dt nan s: must lie in (0, 0.1] s"),
        ({"slope": NAN}, "slope nan deg: must lie in (-60, 60) deg"),
        ({"slope": INF}, "slope inf deg"),
        ({"slope": "steep"}, "slope 'steep': must lie in (-60, 60) deg"),
        ({"hip_height": INF}, "hip height inf m: must be a finite length > 0 m"),
        ({"hip_height": NAN}, "hip height nan m"),
        ({"swing_lift": INF}, "swing lift inf m: must be a finite length >= 0 m"),
        ({"swing_lift": -0.01}, "swing lift -0.01 m"),
        ({"tilt": NAN}, "tilt nan deg: must lie in (-45, 45) deg"),
        ({"step_length": INF}, "step length inf m"),
        ({"ssp_fraction": 1.0}, "ssp fraction 1.0: must lie in (0, 1)"),
        ({"tilt_profile": "wobble"}, "tilt profile 'wobble'"),
    ],
)
def test_bad_gait_is_refused_in_one_line(fields, message):
    fields = {"step_time": 1.0, **fields}
    with pytest.raises(GaitError) as err:
        GaitParams(**fields)
    assert message in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize(
    "fields, message",
    [
        ({"hip_height": 0.5}, "hip height 0.5 m: must lie in (0, 0.254] m"),
        ({"swing_lift": 1e300}, "swing lift 1e+300 m: must lie in [0, 0.39) m"),
        ({"step_length": 1.0}, "step length 1 m: must lie in (0, 0.444] m"),
    ],
)
def test_lengths_no_leg_spans_are_refused_before_planning(spec, fields, message, recwarn):
    with pytest.raises(GaitError, match=r".*") as err:
        plan_walk(spec, GaitParams.nominal(spec, 1.0, **fields))
    assert message in str(err.value)
    assert not [w for w in recwarn if issubclass(w.category, RuntimeWarning)]


def test_range_reads_like_the_interval():
    assert str(Range(0, 60, "s")) == "(0, 60] s"
    assert Range(0, 1, high_open=True).contains(0.5)
    assert not Range(0, 1).contains(NAN) and not Range(0, 1).contains("0.5")
    assert not Range(1, 10, integer=True, low_open=False).contains(2.0)


def test_the_hip_height_bound_counts_the_knee_offset(spec):
    """Knees 30 mm behind the leg line: the hip reaches the ankle height plus both links in
    line, 0.032 + 2 √(0.111² + 0.03²) = 0.26196 m (by hand), and the line says how."""
    knees = replace(spec, knee_offset=-0.03)
    top = 0.032 + 2 * (0.111**2 + 0.03**2) ** 0.5
    GaitParams.nominal(knees, 1.0, hip_height=top - 1e-9).check_fits(knees)
    with pytest.raises(GaitError, match=r"\(0, 0\.262\] m .*with the knee offset k"):
        GaitParams.nominal(knees, 1.0, hip_height=top + 1e-9).check_fits(knees)
