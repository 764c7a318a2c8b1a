"""Newton-Euler and ZMP against independent references: energy balance, statics, eq. (4)."""

import numpy as np
import pytest
from conftest import away_from_phase_changes

from slopewalk.planner.gait import GaitParams
from slopewalk.planner.kinematics import Chain, gravity_in_slope
from slopewalk.planner.newton_euler import inverse_dynamics
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.reference import solve_reference
from slopewalk.planner.trajectory import Timeline
from slopewalk.planner.zmp import cop_of_wrench, zmp_multibody


def _rate(x: np.ndarray, t: np.ndarray, stance: np.ndarray) -> np.ndarray:
    """Time derivative by central differences within each stance segment.

    The chain's links swap roles when the stance leg changes, so differences
    never straddle a switch (one-sided at segment ends).
    """
    out = np.empty_like(x)
    cuts = np.flatnonzero(np.diff(stance)) + 1
    for segment in np.split(np.arange(t.size), cuts):
        out[segment] = np.gradient(x[segment], t[segment], axis=0)
    return out


def _angular_velocity(R: np.ndarray, t: np.ndarray, stance: np.ndarray) -> np.ndarray:
    """ω in S from rotation matrices by central differences: [ω]× = Ṙ Rᵀ. (n, k, 3)"""
    Rdot = _rate(R, t, stance)
    W = Rdot @ np.swapaxes(R, -1, -2)
    return 0.5 * np.stack(
        [W[..., 2, 1] - W[..., 1, 2], W[..., 0, 2] - W[..., 2, 0], W[..., 1, 0] - W[..., 0, 1]],
        axis=-1,
    )


@pytest.mark.parametrize("step_time, slope_deg", [(1.0, 0.0), (0.6, 15.0)])
def test_power_balance(spec, step_time, slope_deg):
    """Σ τ·θ̇ = d/dt(KE + PE) − P_ground, with KE and PE from FK positions alone."""
    params = GaitParams.nominal(spec, step_time, slope=np.deg2rad(slope_deg), dt=2.5e-4)
    plan = plan_walk(spec, params)
    chain = Chain.from_spec(spec)
    frames = chain.frames(plan.q, plan.stance_sole, plan.stance)
    t = plan.t
    com = chain.link_coms(frames, plan.stance)  # (n, 9, 3)
    v = _rate(com, t, plan.stance)
    R = frames[:, :9, :3, :3]
    omega = _angular_velocity(R, t, plan.stance)
    inertia = R @ chain.inertia[plan.stance] @ np.swapaxes(R, -1, -2)
    g = gravity_in_slope(params.slope)
    kinetic = 0.5 * np.einsum("k,nki,nki->n", chain.mass, v, v) + 0.5 * np.einsum(
        "nki,nkij,nkj->n", omega, inertia, omega
    )
    potential = -np.einsum("k,nki,i->n", chain.mass, com, g)
    energy_rate = np.gradient(kinetic + potential, t)
    # the ground does work on the swing foot only when that foot moves while loaded
    sole_velocity = _rate(plan.swing_sole, t, plan.stance)
    ground_power = np.einsum("ni,ni->n", plan.swing_force, sole_velocity)
    actuator_power = np.einsum("nj,nj->n", plan.tau, plan.qd)
    error = actuator_power - (energy_rate - ground_power)
    keep = away_from_phase_changes(plan)
    relative = np.abs(error[keep]).max() / np.abs(actuator_power).max()
    print(
        f"power balance T={step_time} s slope={slope_deg} deg: max error "
        f"{np.abs(error[keep]).max():.3e} W of peak {np.abs(actuator_power).max():.3f} W, "
        f"relative {relative:.2e}"
    )
    assert relative < 1e-3


@pytest.mark.parametrize("slope_deg", [0.0, 20.0, -35.0])
def test_static_zmp_is_com_projected_along_gravity(spec, slope_deg):
    """At rest the ZMP (eq. 4) and the NE CoP are the CoM projected along g onto the plane."""
    rng = np.random.default_rng(7)
    n = 50
    q = rng.uniform(-0.4, 0.4, (n, 8))
    q[:, 2] = rng.uniform(0.1, 1.5, n)  # knees flexed
    stance = rng.integers(0, 2, n)
    sole = np.column_stack([rng.uniform(-0.1, 0.1, (n, 2)), np.zeros(n)])
    chain = Chain.from_spec(spec)
    g = gravity_in_slope(np.deg2rad(slope_deg))
    frames = chain.frames(q, sole, stance)
    dyn = inverse_dynamics(chain, frames, np.zeros((n, 8)), np.zeros((n, 8)), stance, g)
    com = chain.center_of_mass(frames, stance)
    expected = com[:, :2] - com[:, 2:3] * g[:2] / g[2]
    coms = chain.link_coms(frames, stance)
    zmp = zmp_multibody(chain.mass, coms, dyn.com_acc, np.zeros_like(coms), g)
    cop = cop_of_wrench(dyn.stance_force, dyn.stance_moment, sole)
    np.testing.assert_allclose(zmp, expected, atol=1e-12)
    np.testing.assert_allclose(cop, expected, atol=1e-12)
    np.testing.assert_allclose(dyn.stance_force, -chain.mass.sum() * np.tile(g, (n, 1)), atol=1e-12)


@pytest.mark.parametrize("step_time, slope_deg", [(2.0, 0.0), (0.5, 10.0), (0.4, 22.5)])
def test_multibody_zmp_equals_newton_euler_cop(spec, step_time, slope_deg):
    """Eq. (4) from link motion equals the CoP of the feet's ground wrenches from NE.

    Eq. (4) as the numpy reference sums it over the links; the CoP from the wrench of
    the compiled kernel's recursion (which takes its ZMP from that wrench) and of the
    reference's.
    """
    params = GaitParams.nominal(spec, step_time, slope=np.deg2rad(slope_deg))
    plan = plan_walk(spec, params)
    x = np.array([[params.hip_height], [params.swing_lift], [params.tilt]])
    reference = solve_reference(spec, Timeline.of(params), params.slope, *x, strict=True)
    eq4 = reference["zmp"][0]
    np.testing.assert_allclose(eq4, plan.cop_ne, atol=1e-9)
    np.testing.assert_allclose(eq4, reference["cop_ne"][0], atol=1e-9)


def test_lipm_matches_slow_and_departs_fast(spec):
    """LIPM ≈ multibody ZMP at 2 s steps; they separate at 0.4 s (paper sec. VII-E)."""
    rms = {}
    for step_time in (2.0, 0.4):
        plan = plan_walk(spec, GaitParams.nominal(spec, step_time))
        distance = np.hypot(*(plan.zmp - plan.zmp_lipm).T)
        rms[step_time] = np.sqrt(np.mean(distance**2))
        print(
            f"LIPM vs multibody ZMP at T={step_time} s: RMS {rms[step_time] * 1e3:.2f} mm, "
            f"max {distance.max() * 1e3:.2f} mm"
        )
    assert rms[2.0] < 2e-3
    assert rms[0.4] > 10 * rms[2.0]
