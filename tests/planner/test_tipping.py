"""Tipping predictor: the one-sided integrator against closed forms, the edge inertia's
parallel-axis property, and the rocking of synthetic excursions: landing law, gravity
stiffness on a slope, the floor's give and the swing sole's prop."""

from dataclasses import replace

import numpy as np
import pytest

from slopewalk.planner import tipping
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.kinematics import Chain, gravity_in_slope
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.tipping import (
    PITCH,
    ROLL,
    edge_inertia,
    excursion_integral,
    foot_rotation,
    give_stiffness,
    gravity_stiffness,
    landing_restitution,
    line_inertia,
    rocking,
    support_lines,
)


def test_constant_push_integrates_to_a_parabola():
    t = np.linspace(0.0, 0.2, 2001)
    x = excursion_integral(t, np.full(t.size, 0.5), 0.02)
    np.testing.assert_allclose(x[-1], 0.5 * 0.2**2 / (2 * 0.02), rtol=2e-3)


def test_feedback_grows_as_a_hyperbolic_cosine():
    """I ẍ = D + k x from rest: x = D/k (cosh(ωt) − 1), ω = sqrt(k/I)."""
    t = np.linspace(0.0, 0.3, 30001)
    drive, inertia, k = 0.2, 0.02, 1.0
    x = excursion_integral(t, np.full(t.size, drive), inertia, k)
    expected = drive / k * (np.cosh(np.sqrt(k / inertia) * t[-1]) - 1)
    np.testing.assert_allclose(x[-1], expected, rtol=2e-3)


def test_a_pull_back_lands_and_stays_down():
    t = np.linspace(0.0, 1.0, 1001)
    drive = np.where(t < 0.1, 1.0, -1.0)
    x = excursion_integral(t, drive, 0.05)
    assert x.max() > 0
    landed = np.flatnonzero((t > 0.1) & (x == 0))[0]
    assert np.all(x[landed:] == 0)  # pushed onto the plane it does not sink or bounce


def test_edge_inertia_obeys_the_parallel_axis_theorem(spec):
    plan = plan_walk(spec, GaitParams.nominal(spec, 1.0, steps=1))
    rows = np.array([100, 700])
    direction = np.array([[1.0, 0.0], [1.0, 0.0]])
    near, far = np.zeros((2, 2)), np.array([[0.0, 0.5], [0.0, 0.5]])
    gap = edge_inertia(plan, rows, far, direction) - edge_inertia(plan, rows, near, direction)
    com = plan.com[rows]
    expected = spec.total_mass * ((com[:, 1] - 0.5) ** 2 - com[:, 1] ** 2)
    np.testing.assert_allclose(gap, expected, rtol=1e-9)
    # about a line through the CoM's foot point the point masses alone are not the whole story
    at_com = edge_inertia(plan, rows, com[:, :2], direction)
    assert np.all(at_com > spec.total_mass * com[:, 2] ** 2)


def test_edge_inertia_is_the_same_from_any_point_of_the_line(spec):
    """The line is fixed by one point and its direction: sliding the point 0.3 m along the
    line (both in-plane directions, oblique too) leaves the moment of inertia unchanged."""
    plan = plan_walk(spec, GaitParams.nominal(spec, 1.0, steps=1))
    rows = np.array([100, 400, 700])
    direction = np.array([[1.0, 0.0], [0.0, 1.0], [0.6, 0.8]])
    point = np.array([[0.02, -0.05], [0.1, 0.03], [-0.04, 0.06]])
    here = edge_inertia(plan, rows, point, direction)
    there = edge_inertia(plan, rows, point + 0.3 * direction, direction)
    np.testing.assert_allclose(there, here, rtol=1e-9)


@pytest.mark.parametrize("axis", [ROLL, PITCH])
def test_line_inertia_is_edge_inertia_about_the_same_line(spec, axis):
    """``LinkMoments`` (frames once per plan, d² = across² + height²) against the general
    ``edge_inertia`` (frames per call, d² = |r|² − (r·ê)²) about the support's lines of a
    walk up 10° in both stances and double support: the same sum in another order."""
    plan = plan_walk(spec, GaitParams.nominal(spec, 0.5, steps=2, slope=np.deg2rad(10)))
    rows = np.arange(plan.t.size)
    assert plan.double_support.any() and set(plan.stance) == {0, 1}
    for position in support_lines(plan, axis):
        point = np.zeros((rows.size, 2))
        point[:, axis] = position
        direction = np.zeros((rows.size, 2))
        direction[:, 1 - axis] = 1.0
        want = edge_inertia(plan, rows, point, direction)
        np.testing.assert_allclose(line_inertia(plan, axis, position), want, rtol=1e-12)


@pytest.mark.parametrize("axis", [ROLL, PITCH])
def test_line_inertia_takes_each_samples_own_stance_sides_inertia(spec, axis, monkeypatch):
    """The paper's links have the same inertia tensor in their DH axes on either stance
    leg, so a ``LinkMoments`` that took one side's for every sample would pass the test
    above. Here the right stance's tensors are turned 30° about x (products of inertia
    appear) and its CoM offsets moved: ``LinkMoments`` must still match ``edge_inertia``."""
    chain = Chain.from_spec(spec)
    c, s = np.cos(np.pi / 6), np.sin(np.pi / 6)
    turn = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    inertia, com = chain.inertia.copy(), chain.com.copy()
    inertia[1] = turn @ inertia[1] @ turn.T
    com[1] += [0.004, -0.003, 0.002]
    lopsided = replace(chain, inertia=inertia, com=com)
    monkeypatch.setattr(tipping.Chain, "from_spec", classmethod(lambda cls, spec: lopsided))
    plan = plan_walk(spec, GaitParams.nominal(spec, 0.5, steps=2, slope=np.deg2rad(10)))
    rows = np.arange(plan.t.size)
    assert set(plan.stance) == {0, 1}
    for position in support_lines(plan, axis):
        point = np.zeros((rows.size, 2))
        point[:, axis] = position
        direction = np.zeros((rows.size, 2))
        direction[:, 1 - axis] = 1.0
        want = edge_inertia(plan, rows, point, direction)
        np.testing.assert_allclose(line_inertia(plan, axis, position), want, rtol=1e-12)


def test_a_walk_inside_its_polygon_does_not_turn(spec):
    plan = plan_walk(spec, GaitParams.nominal(spec, 2.0, steps=1))
    assert plan.margin.min() > 0
    assert np.all(foot_rotation(plan) == 0)


def test_on_a_soft_floor_a_flat_support_gives_by_its_moment_over_its_stiffness(spec):
    """Flat on the floor the tilt is the give F_n (z − m) / k_rot: in single support the
    4 corners of a sole of width w, k_c each, make k_rot = k_c w² about its middle."""
    plan = plan_walk(spec, GaitParams.nominal(spec, 2.0, steps=1))
    k_c = 6500.0
    roll = rocking(plan, ROLL, floor_stiffness=k_c)
    k = int(np.searchsorted(plan.t, 1.2))  # single support, ZMP inside
    assert not plan.double_support[k]
    middle = plan.stance_sole[k, 1]
    expected = plan.ground_force[k, 2] * (plan.zmp[k, 1] - middle) / (k_c * spec.foot_width**2)
    assert abs(expected) > np.deg2rad(0.05)  # a give worth checking
    np.testing.assert_allclose(roll[k], expected, rtol=1e-9)
    k_rot, centre = give_stiffness(plan, ROLL, k_c)
    np.testing.assert_allclose(k_rot[k], k_c * spec.foot_width**2, rtol=1e-12)


@pytest.mark.parametrize("outside_mm, tips", [(5.0, False), (40.0, True)])
def test_a_long_excursion_tips_a_short_one_does_not(spec, outside_mm, tips):
    """The ZMP held e beyond the heel edge for 0.1 s: θ ≈ F_n e t² / (2 I) before feedback."""
    plan = plan_walk(spec, GaitParams.nominal(spec, 2.0, steps=1))
    k0 = int(np.searchsorted(plan.t, 1.0))  # single support
    zmp = plan.zmp.copy()
    heel = plan.stance_sole[k0, 0] - spec.heel_offset
    window = slice(k0, k0 + 100)
    zmp[window, 0] = heel - outside_mm / 1e3
    zmp[window, 1] = plan.stance_sole[k0, 1]
    margin = plan.margin.copy()
    margin[window] = -outside_mm / 1e3
    theta = foot_rotation(replace(plan, zmp=zmp, margin=margin))
    assert (np.rad2deg(theta.max()) > 5.0) == tips
    assert theta[:k0].max() == 0


def test_landing_restitution_of_a_block_is_housners():
    """A block of width 2b, CoM height h on its middle, I_c about the CoM: rocking from one
    edge onto the other keeps r = (I_c + m (h² − b²)) / (I_c + m (h² + b²))."""
    m, b, h, spin = 0.8, 0.05, 0.15, 0.002
    inertia_new = spin + m * (h**2 + b**2)
    r = landing_restitution(m, 0.0, b, -b, inertia_new)
    np.testing.assert_allclose(r, (spin + m * (h**2 - b**2)) / inertia_new, rtol=1e-12)
    assert landing_restitution(m, 0.0, 0.5, -0.5, spin + m * (0.01**2 + 0.5**2)) == 0.0


def test_gravity_stiffness_uphill_is_larger_over_the_heel(spec):
    """Turning about a line, gravity adds m g (h cos α + (c_x − e) sin α) per radian: the
    heel's stiffness exceeds the toe's by m g sin α times the sole length."""
    slope = np.deg2rad(20.0)
    plan = plan_walk(spec, GaitParams.nominal(spec, 1.0, slope=slope, steps=1))
    heel, toe = support_lines(plan, PITCH)
    gap = gravity_stiffness(plan, PITCH, heel) - gravity_stiffness(plan, PITCH, toe)
    g = -gravity_in_slope(slope)
    np.testing.assert_allclose(gap, spec.total_mass * g[0] * (toe - heel), rtol=1e-9)
    roll = gravity_stiffness(plan, ROLL, support_lines(plan, ROLL)[0])
    np.testing.assert_allclose(roll, spec.total_mass * g[2] * plan.com[:, 2], rtol=1e-12)


def _pushed(plan_or_zmp, rows, axis, value):
    zmp = getattr(plan_or_zmp, "zmp", plan_or_zmp).copy()
    zmp[rows, axis] = value
    return zmp


def test_the_rocking_lands_on_the_far_line_and_goes_on(spec):
    """A push past the upper line turns the robot; back flat, the lower line lands with
    θ̇⁺ = r θ̇⁻ and the robot rocks on onto it (a reset model would stay flat)."""
    plan = plan_walk(spec, GaitParams.nominal(spec, 2.0, steps=1))
    lower, upper = support_lines(plan, ROLL)
    k0 = int(np.searchsorted(plan.t, 1.0))
    push = slice(k0, k0 + 60)
    zmp = _pushed(plan, push, ROLL, upper[k0] + 0.03)
    release = slice(k0 + 60, None)
    zmp[release, ROLL] = (lower[k0] + upper[k0]) / 2
    roll = rocking(plan, ROLL, zmp=zmp)
    assert roll[push].max() > 0
    landed = k0 + 60 + int(np.flatnonzero(roll[k0 + 60 :] <= 0)[0])
    assert roll[landed + 5] < 0  # rocking on over the other line
    before = (roll[landed - 1] - roll[landed - 3]) / (plan.t[landed - 1] - plan.t[landed - 3])
    after = (roll[landed + 2] - roll[landed]) / (plan.t[landed + 2] - plan.t[landed])
    inertia = line_inertia(plan, ROLL, lower)[landed]
    r = landing_restitution(
        spec.total_mass, plan.com[landed, ROLL], upper[landed], lower[landed], inertia
    )
    assert 0.5 < r < 1.0
    np.testing.assert_allclose(after / before, r, rtol=0.1)


def test_two_excursions_a_step_apart_add_up(spec):
    """Pushes past alternate lines, each timed with the rocking, pump it: together they
    turn the robot further than either alone."""
    plan = plan_walk(spec, GaitParams.nominal(spec, 2.0, steps=1))
    lower, upper = support_lines(plan, ROLL)
    k0 = int(np.searchsorted(plan.t, 1.0))
    middle = (lower[k0] + upper[k0]) / 2
    zmp = _pushed(plan, slice(k0, None), ROLL, middle)
    zmp[k0 : k0 + 50, ROLL] = upper[k0] + 0.02
    first = rocking(plan, ROLL, zmp=zmp)
    back = k0 + 50 + int(np.flatnonzero(first[k0 + 50 :] <= 0)[0])
    zmp[back : back + 50, ROLL] = lower[k0] - 0.02
    both = rocking(plan, ROLL, zmp=zmp)
    alone = rocking(plan, ROLL, zmp=_pushed(zmp, slice(None, back), ROLL, middle))
    assert np.abs(both).max() > 1.2 * max(np.abs(first).max(), np.abs(alone).max())


def test_the_swing_sole_props_a_turn_towards_it(spec):
    """In single support a turn towards the swing foot stops where its sole reaches the
    plane: θ ≤ clearance / distance from the pivot line to the swing sole's far edge."""
    plan = plan_walk(spec, GaitParams.nominal(spec, 2.0, steps=1))
    lower, upper = support_lines(plan, ROLL)
    k0 = int(np.flatnonzero(~plan.double_support)[0]) + 20  # early single support
    stance_right = plan.swing_sole[k0, 1] > plan.stance_sole[k0, 1]
    beyond = upper[k0] + 0.04 if stance_right else lower[k0] - 0.04
    zmp = _pushed(plan, slice(k0, k0 + 200), ROLL, beyond)
    free = rocking(plan, ROLL, zmp=zmp, clearance=np.full(plan.t.size, 1.0))
    held = rocking(plan, ROLL, zmp=zmp)
    rows = slice(k0, k0 + 200)
    swing_y, half = plan.swing_sole[rows, 1], spec.foot_width / 2
    lever = swing_y + half - upper[rows] if stance_right else lower[rows] - (swing_y - half)
    cap = plan.swing_sole[rows, 2] / lever
    assert np.abs(held[rows]).max() < 0.8 * np.abs(free[rows]).max()
    assert np.all(np.abs(held[rows]) <= cap + 1e-12)
    assert np.any(np.isclose(np.abs(held[rows]), cap, rtol=1e-9))  # the prop binds


def test_gravity_acts_on_the_floors_give_too(spec):
    """The ZMP held just on the upper line: a rigid floor barely turns; on a soft one the
    support is already turned by the give θ_g, and gravity grows it as
    θ = θ_g (cosh(ω t) − 1) + θ_g, ω = √(K / I)."""
    plan = plan_walk(spec, GaitParams.nominal(spec, 2.0, steps=1))
    lower, upper = support_lines(plan, ROLL)
    k0 = int(np.searchsorted(plan.t, 1.1))
    rows = slice(k0, k0 + 100)
    zmp = plan.zmp.copy()
    zmp[rows, ROLL] = upper[rows] + 1e-6
    rigid = rocking(plan, ROLL, zmp=zmp)
    soft = rocking(plan, ROLL, zmp=zmp, floor_stiffness=6500.0)
    k_rot, centre = give_stiffness(plan, ROLL, 6500.0)
    give = plan.ground_force[k0, 2] * (upper[k0] - centre[k0]) / k_rot[k0]
    omega = np.sqrt(gravity_stiffness(plan, ROLL, upper)[k0] / line_inertia(plan, ROLL, upper)[k0])
    t = plan.t[k0 + 99] - plan.t[k0]
    expected = give * np.cosh(omega * t)
    np.testing.assert_allclose(soft[k0 + 99], expected, rtol=0.1)
    assert rigid[k0 + 99] < 0.05 * expected
