"""Newton-Euler against MuJoCo's ``mj_inverse`` where every term of the recursion is alive.

``tests/sim/test_model.py`` compares the two on single-support samples of the ``hold``
tilt profile, where the roll rate is zero, so ω × (I ω) and ω × (q̇ u) vanish there.
Here: random joint states (angles, rates and accelerations of all 8 joints, either
stance leg, random slopes), the ``sway`` profile (rolling all the time) in single
support, and the total ground wrench in double support.
"""

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from mj_reference import StanceRootedInverse

from slopewalk.planner.gait import GaitParams
from slopewalk.planner.kinematics import Chain, gravity_in_slope
from slopewalk.planner.newton_euler import inverse_dynamics
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.zmp import cop_of_wrench

# Random states: angles within the joints' reach, rates and accelerations of a fast walk.
ANGLE = np.array([0.5, 0.8, 1.2, 0.8, 0.8, 1.2, 0.8, 0.5])  # [rad], half-ranges
ANGLE_MID = np.array([0, 0, 1.0, 0, 0, 1.0, 0, 0])  # knees flexed
RATE, ACCELERATION = 4.0, 60.0  # [rad/s], [rad/s²]
unit8 = hnp.arrays(np.float64, 8, elements=st.floats(-1, 1))


def _compare(spec, slope, q, qd, qdd, stance, sole):
    """(planner, MuJoCo) of tau, force, moment for one sample."""
    chain = Chain.from_spec(spec)
    g = gravity_in_slope(slope)
    frames = chain.frames(q[None], sole[None], np.array([stance]))
    dyn = inverse_dynamics(chain, frames, qd[None], qdd[None], np.array([stance]), g)
    mj = StanceRootedInverse(spec, g)(q, qd, qdd, stance, sole)
    ours = (dyn.tau[0], dyn.stance_force[0], dyn.stance_moment[0], dyn.omega[0], dyn.omega_dot[0])
    return ours, (mj.tau, mj.force, mj.moment, mj.omega, mj.omega_dot)


@pytest.mark.parametrize("knee", [0.0, -0.030])  # [m]: knees 30 mm behind the leg line too
@settings(max_examples=60, deadline=None, derandomize=True)
@given(
    slope=st.floats(-0.9, 0.9),
    stance=st.integers(0, 1),
    q=unit8,
    qd=unit8,
    qdd=unit8,
    sole=hnp.arrays(np.float64, 2, elements=st.floats(-0.3, 0.3)),
)
def test_random_states_match_mj_inverse(spec, knee, slope, stance, q, qd, qdd, sole):
    """Every joint moving, both stance legs, slopes to ±52°: torques, ground wrench, link spin
    (with ``knee``: the knee axes off the hip–ankle lines, geometry.knee_offset)."""
    spec = replace(spec, knee_offset=knee)
    sole3 = np.array([*sole, 0.0])
    ours, mj = _compare(
        spec, slope, ANGLE_MID + ANGLE * q, RATE * qd, ACCELERATION * qdd, stance, sole3
    )
    for name, a, b in zip(("tau", "force", "moment", "omega", "omega_dot"), ours, mj, strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-7, atol=1e-9, err_msg=name)


def test_pure_roll_rate_exercises_the_gyroscopic_terms(spec):
    """Only the ankle rolls spin, no accelerations, no gravity: torques are velocity terms only.

    With q̈ = 0 and g = 0, the torques come from ω × (I ω), ω × (q̇ u) and the
    centripetal terms alone; a recursion that drops either gyroscopic term is off here
    by a margin far above the tolerance (checked: > 1e-4 N m against 1e-9).
    """
    rng = np.random.default_rng(3)
    chain = Chain.from_spec(spec)
    for _ in range(10):
        q = ANGLE_MID + ANGLE * rng.uniform(-1, 1, 8)
        qd = np.zeros(8)
        qd[[0, 7]] = rng.uniform(-5, 5, 2)
        qd[[1, 4]] = rng.uniform(-3, 3, 2)  # a pitch rate crossing the roll rate
        stance, sole = int(rng.integers(2)), np.zeros(3)
        frames = chain.frames(q[None], sole[None], np.array([stance]))
        dyn = inverse_dynamics(chain, frames, qd[None], np.zeros((1, 8)), [stance], np.zeros(3))
        mj = StanceRootedInverse(spec, np.zeros(3))(q, qd, np.zeros(8), stance, sole)
        assert np.abs(mj.tau).max() > 1e-3  # the velocity terms are not negligible here
        np.testing.assert_allclose(dyn.tau[0], mj.tau, rtol=1e-7, atol=1e-9)
        np.testing.assert_allclose(dyn.stance_moment[0], mj.moment, rtol=1e-7, atol=1e-9)


@pytest.fixture  # per test: mutmut maps a test to the code its fixtures run
def sway_walk(spec):
    """A 0.6 s-step walk on 10° with the ``sway`` tilt: the legs roll through every phase."""
    params = GaitParams.nominal(spec, 0.6, slope=np.deg2rad(10.0), tilt_profile="sway")
    return plan_walk(spec, params)


def test_sway_walk_rolls(sway_walk):
    """The premise of the two tests below: roll rates far from zero in SSP and in DSP."""
    roll_rate = np.abs(sway_walk.qd[:, 0])
    assert roll_rate[~sway_walk.double_support].max() > 0.3  # [rad/s]
    assert roll_rate[sway_walk.double_support].max() > 0.3


def test_sway_single_support_torques_match_mj_inverse(spec, sway_walk):
    """SSP of a rolling walk: the plan's torques are the recursion's, MuJoCo's equal them."""
    plan = sway_walk
    mj = StanceRootedInverse(spec, gravity_in_slope(plan.params.slope))
    single = np.flatnonzero(~plan.double_support)[::11]
    assert set(plan.stance[single]) == {0, 1}
    for k in single:
        ref = mj(plan.q[k], plan.qd[k], plan.qdd[k], plan.stance[k], plan.stance_sole[k])
        np.testing.assert_allclose(plan.tau[k], ref.tau, rtol=1e-7, atol=1e-9)
        np.testing.assert_allclose(plan.ground_force[k], ref.force, rtol=1e-7, atol=1e-9)
        np.testing.assert_allclose(plan.swing_force[k], 0.0, atol=0.0)


def test_double_support_total_ground_wrench_matches_mj_inverse(spec, sway_walk):
    """DSP: MuJoCo's wrench on a stance-rooted chain is the total the two feet must supply.

    The plan's total ground force and the CoP of the total wrench (``cop_ne``, also the
    ZMP) equal MuJoCo's, whatever the split between the feet.
    """
    plan = sway_walk
    mj = StanceRootedInverse(spec, gravity_in_slope(plan.params.slope))
    double = np.flatnonzero(plan.double_support)[::7]
    assert set(plan.stance[double]) == {0, 1}
    for k in double:
        ref = mj(plan.q[k], plan.qd[k], plan.qdd[k], plan.stance[k], plan.stance_sole[k])
        cop = cop_of_wrench(ref.force[None], ref.moment[None], plan.stance_sole[k][None])[0]
        np.testing.assert_allclose(plan.ground_force[k], ref.force, rtol=1e-7, atol=1e-9)
        np.testing.assert_allclose(plan.stance_force[k] + plan.swing_force[k], ref.force, atol=1e-9)
        np.testing.assert_allclose(plan.cop_ne[k], cop, rtol=0, atol=1e-9)
        np.testing.assert_allclose(plan.zmp[k], cop, rtol=0, atol=1e-9)
