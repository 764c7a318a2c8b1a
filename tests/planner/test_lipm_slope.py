"""The LIPM ZMP (eq. 5) on a slope: its gravity term, against a physical identity.

A point mass m at c with acceleration a is pushed by the ground with F = m (a − g)
through the ZMP p, and nothing else acts on it, so F's line passes through c:
(c − p) × F = 0 with p on the plane. Gravity is written here by hand in S,
g_S = (−g sin θs, 0, −g cos θs) (uphill walking along +x_S), not taken from the
planner. The LIPM keeps its height (c̈_z = 0).
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from slopewalk.planner.gait import GaitParams
from slopewalk.planner.kinematics import gravity_in_slope
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.zmp import zmp_lipm


def _gravity_by_hand(slope: float, g: float = 9.81) -> np.ndarray:
    return np.array([-g * np.sin(slope), 0.0, -g * np.cos(slope)])


@settings(max_examples=200, deadline=None, derandomize=True)
@given(
    slope=st.floats(-1.0, 1.0),
    com=hnp.arrays(np.float64, 3, elements=st.floats(-0.5, 0.5)),
    acc=hnp.arrays(np.float64, 2, elements=st.floats(-20, 20)),
)
def test_lipm_zmp_lies_on_the_line_of_the_ground_force(slope, com, acc):
    com = com + [0, 0, 0.6]  # above the plane
    acc3 = np.array([*acc, 0.0])  # constant height
    p = zmp_lipm(com[None], acc3[None], gravity_in_slope(slope))[0]
    force = acc3 - _gravity_by_hand(slope)  # per unit mass
    lever = com - np.array([*p, 0.0])
    np.testing.assert_allclose(np.cross(lever, force), 0.0, atol=1e-9)


@pytest.mark.parametrize("slope_deg", [10.0, 25.0, -15.0])
def test_static_point_mass_on_a_slope_by_hand(slope_deg):
    """At rest the ZMP is the CoM projected along the vertical: x − h tan θs, y."""
    slope = np.deg2rad(slope_deg)
    com = np.array([[0.02, -0.01, 0.15]])
    p = zmp_lipm(com, np.zeros((1, 3)), gravity_in_slope(slope))[0]
    np.testing.assert_allclose(p, [0.02 - 0.15 * np.tan(slope), -0.01], atol=1e-15)


@pytest.mark.parametrize("slope_deg", [15.0, -10.0])
def test_lipm_matches_the_multibody_zmp_on_a_slope_at_slow_steps(spec, slope_deg):
    """At 2 s steps on a slope both ZMPs sit downhill of the CoM; the LIPM keeps within 2 mm.

    Dropping the LIPM's slope term would put it c_z tan θs (≈ 35 mm at 15°) off.
    """
    plan = plan_walk(spec, GaitParams.nominal(spec, 2.0, slope=np.deg2rad(slope_deg)))
    distance = np.hypot(*(plan.zmp - plan.zmp_lipm).T)
    rms = np.sqrt(np.mean(distance**2))
    print(f"LIPM vs multibody ZMP at T=2 s on {slope_deg} deg: RMS {rms * 1e3:.2f} mm")
    assert rms < 2e-3
    shift = plan.com[:, 0] - plan.zmp_lipm[:, 0]  # CoM ahead of the ZMP uphill, behind downhill
    assert np.sign(np.median(shift)) == np.sign(slope_deg)


def test_cop_and_friction_ratio_of_light_and_vanishing_normal_forces():
    """A light foot still has a CoP and a ratio; no normal force has neither (NaN, inf)."""
    from slopewalk.planner.zmp import cop_of_wrench, friction_ratio

    force = np.array([[0.03, -0.04, 0.5], [0.1, 0.0, 0.0], [0.1, 0.0, -0.2]])  # [N]
    moment = np.array([[0.01, -0.02, 0.0], [0.01, 0.02, 0.0], [0.0, 0.0, 0.0]])  # [N m]
    point = np.array([[0.1, 0.2, 0.0]] * 3)
    cop = cop_of_wrench(force, moment, point)
    # about the origin M0 = M + p × F; the CoP is (−M0_y, M0_x) / F_z
    m0 = moment[0] + np.cross(point[0], force[0])
    np.testing.assert_allclose(cop[0], [-m0[1] / 0.5, m0[0] / 0.5], rtol=1e-12)
    assert np.isnan(cop[1:]).all()
    ratio = friction_ratio(force)
    assert ratio[0] == pytest.approx(0.05 / 0.5, rel=1e-12)
    assert np.isinf(ratio[1:]).all()
