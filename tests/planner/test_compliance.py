"""Compliance-aware walk: the fixed point holds, it vanishes for a rigid servo, and it sags
by τ/kp to first order."""

import numpy as np
import pytest

from slopewalk.planner.compliance import compliant_walk
from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import plan_walk


@pytest.fixture(scope="module")
def plan(spec):
    return plan_walk(spec, GaitParams.nominal(spec, 1.0, steps=2))


def test_a_rigid_servo_reaches_the_plan(plan):
    walk = compliant_walk(plan, stiffness=1e9)
    assert walk.converged
    assert np.abs(walk.deflection).max() < 1e-8
    np.testing.assert_allclose(walk.plan.zmp, plan.zmp, atol=1e-8)
    np.testing.assert_allclose(walk.plan.tau, plan.tau, atol=1e-6)


def test_the_reached_pose_is_the_fixed_point(spec, plan):
    """kp (q_ref − q) equals the torque the reached walk needs, + A q̈ + (d + kv) q̇."""
    kp, kv, d, A = spec.stiffness, 0.05, 0.2, spec.armature
    walk = compliant_walk(plan, stiffness=kp, velocity_gain=kv, damping=d, armature=A)
    assert walk.converged and 3 <= walk.iterations < 60
    need = walk.plan.tau + A * plan.qdd + (d + kv) * plan.qd
    np.testing.assert_allclose(kp * walk.deflection, need, atol=1e-5)
    np.testing.assert_allclose(walk.loop_torque, need - kv * plan.qd, atol=1e-5)


def test_a_stiff_servo_sags_by_torque_over_kp(plan):
    kp = 1e4
    walk = compliant_walk(plan, stiffness=kp)
    np.testing.assert_allclose(walk.deflection * kp, plan.tau, atol=0.01 * np.abs(plan.tau).max())


def test_feeding_the_needed_torque_forward_leaves_no_sag(plan):
    walk = compliant_walk(plan, stiffness=9.26, feedforward=plan.tau)
    assert walk.iterations == 1 and np.abs(walk.deflection).max() < 1e-12


def test_the_ax12a_sags_its_swing_foot_into_the_plane(spec):
    """Flat 2 s steps with the spec's servo (kp 9.26): the swing sole would be ~11 mm below the
    plane just after lift-off, which the simulation shows as the swing foot never leaving it."""
    plan = plan_walk(spec, GaitParams.nominal(spec, 2.0))
    walk = compliant_walk(plan, stiffness=spec.stiffness, damping=spec.joint_damping)
    ssp = ~plan.double_support
    assert plan.swing_sole[ssp, 2].min() > -1e-9
    assert walk.plan.swing_sole[ssp, 2].min() < -0.005


def test_a_non_positive_stiffness_is_refused(plan):
    with pytest.raises(SlopewalkError, match="stiffness 0.0 N m/rad: must be > 0"):
        compliant_walk(plan, stiffness=0.0)
