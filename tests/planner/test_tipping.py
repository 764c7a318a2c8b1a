"""Tipping predictor: the one-sided integrator against closed forms, the edge inertia's
parallel-axis property, and rotations of synthetic excursions."""

from dataclasses import replace

import numpy as np
import pytest

from planner.plan import plan_walk
from planner.tipping import edge_inertia, excursion_integral, foot_rotation, nearest_edge
from planner.trajectory import GaitParams


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


def test_nearest_edge_of_a_square():
    square = np.array([[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]])
    point, direction = nearest_edge(np.array([[0.5, -0.2]]), square)
    np.testing.assert_allclose(point, [[0.0, 0.0]])
    np.testing.assert_allclose(direction, [[1.0, 0.0]])


def test_a_walk_inside_its_polygon_does_not_turn(spec):
    plan = plan_walk(spec, GaitParams.nominal(spec, 2.0, steps=1))
    assert plan.margin.min() > 0
    assert np.all(foot_rotation(plan) == 0)


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
