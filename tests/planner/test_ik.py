"""Two-link IK at the edges of the leg's reach: the error names the sample, NaN when lenient."""

import numpy as np
import pytest

from slopewalk.planner.errors import UnreachableError
from slopewalk.planner.ik import two_link_ik
from slopewalk.planner.trajectory import Curve

SHANK, THIGH = 0.08, 0.07  # [m]


def _target(distance):
    """Hip straight above the ankle at the given distances [m], at rest."""
    w = np.asarray(distance, dtype=float)
    zero = np.zeros_like(w)
    return Curve(zero, zero, zero), Curve(w, zero, zero)


def test_a_reachable_target_is_solved():
    """Hip at (0, w) with w = 0.12 m: by the law of cosines the shank leans by
    arccos((L1² + w² − L2²) / (2 L1 w)) from the vertical."""
    bs, _ = two_link_ik(_target([0.12]), SHANK, THIGH, np.array([0.0]))
    expected = np.arccos((SHANK**2 + 0.12**2 - THIGH**2) / (2 * SHANK * 0.12))
    assert bs.p[0] == pytest.approx(expected)


@pytest.mark.parametrize("distance", [0.16, 0.009])  # beyond L1 + L2; nearer than |L1 − L2|
def test_an_unreachable_target_names_its_time_distance_and_the_reach(distance):
    t = np.array([0.0, 0.25, 0.5])
    with pytest.raises(UnreachableError) as caught:
        two_link_ik(_target([0.12, distance, 0.12]), SHANK, THIGH, t)
    assert str(caught.value) == (
        f"unreachable hip target at t = 0.2500 s: hip-ankle distance {distance:.4f} m, "
        "the leg reaches (0.0100, 0.1500) m"
    )


def test_an_unreachable_target_is_nan_when_not_strict():
    shank, thigh = two_link_ik(
        _target([0.12, 0.16, 0.009]), SHANK, THIGH, np.zeros(3), strict=False
    )
    assert np.isfinite(shank.p[0]) and np.isfinite(thigh.p[0])
    assert np.isnan(shank.p[1:]).all() and np.isnan(thigh.p[1:]).all()
