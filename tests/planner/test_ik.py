"""Two-link IK at the edges of the leg's reach: the error names the sample, NaN when lenient."""

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from slopewalk.planner.errors import UnreachableError
from slopewalk.planner.ik import leg_ik, leg_vector, two_link_ik
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


@settings(max_examples=80, deadline=None, derandomize=True)
@given(
    knee=st.floats(-0.05, 0.05),
    shank=st.floats(-0.2, 1.4),
    bend=st.floats(0.05, 2.4),
)
def test_leg_ik_inverts_the_offset_knee_leg(spec, knee, shank, bend):
    """The leg with its knee k off the hip–ankle line, drawn by hand (ankle → knee → hip from
    the link angles, each link's offset turned with it): ``leg_ik`` of its hip gives back
    the link angles, and ``leg_vector`` is that hand-drawn hip. Drawn on the branch the IK
    takes: the knee–ankle and knee–hip lines bent forward by ``bend`` (the knee angle
    bend − γ_s − γ_t; a knee behind the line bends at least |γ_s + γ_t| there)."""
    spec = replace(spec, knee_offset=knee)
    thigh = shank - (bend - spec.shank_tilt - spec.thigh_tilt)

    def turned(v, angle):  # (u, w) turned as the leg plane's angles turn (u: sin, w: cos)
        c, s = np.cos(angle), np.sin(angle)
        return np.array([v[0] * c + v[1] * s, v[1] * c - v[0] * s])

    hip = turned([knee, spec.shank], shank) + turned([-knee, spec.thigh], thigh)
    u, w = leg_vector(spec, np.array([shank]), np.array([thigh]))
    np.testing.assert_allclose([u[0], w[0]], hip, atol=1e-15)
    zero = np.zeros(1)
    bs, bt = leg_ik((Curve(u, zero, zero), Curve(w, zero, zero)), spec, zero)
    np.testing.assert_allclose([bs.p[0], bt.p[0]], [shank, thigh], atol=1e-12)
