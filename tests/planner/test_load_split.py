"""The double-support load split: its invariants, and the split torques against MuJoCo.

The rule (``planner/plan.py``, README): in each DSP the ground wrench moves from the
foot that was loaded to the foot that will be along a smoothstep s = 3x² − 2x³ of the
DSP phase x; each foot carries a scaled copy of the total wrench; the walk starts and
ends with equal shares. Stated as invariants, each checked here against a reference
that does not come from the planner's split code:

* the feet's forces sum to the total, and each is (its share) × (the total);
* each foot's share follows the rule, written out again sample by sample from the
  README's numbers (T, 40 % DSP, N steps);
* the shares are continuous through every phase change (SSP ↔ DSP, stance switch):
  no sample-to-sample jump larger than the smoothstep's own steepest step;
* the torques of both legs equal MuJoCo's inverse dynamics of the stance-rooted
  chain with the swing foot's share of MuJoCo's own total wrench imposed on it.
"""

import numpy as np
import pytest
from mj_reference import StanceRootedInverse

from slopewalk.planner.gait import GaitParams
from slopewalk.planner.joints import LEFT, RIGHT
from slopewalk.planner.kinematics import gravity_in_slope
from slopewalk.planner.plan import plan_walk

CASES = [  # step time [s], slope [deg], tilt profile, steps
    (1.0, 10.0, "hold", 4),
    (0.5, -15.0, "sway", 3),
    (0.8, 0.0, "hold", 1),
]


# per test, not per module: mutmut maps each test to the code its fixtures run
@pytest.fixture(params=CASES, ids=lambda c: f"T{c[0]}-{c[1]}deg-{c[2]}-N{c[3]}")
def walk(spec, request):
    step_time, slope_deg, profile, steps = request.param
    params = GaitParams.nominal(
        spec, step_time, slope=np.deg2rad(slope_deg), tilt_profile=profile, steps=steps
    )
    return plan_walk(spec, params)


def _right_share_by_the_rule(t, step_time, ssp_fraction, steps) -> np.ndarray:
    """Share of the total ground wrench on the right foot, sample by sample (README rule)."""
    dsp = (1 - ssp_fraction) * step_time
    out = np.empty(t.size)
    for i, ti in enumerate(t):
        k = min(int(np.floor(ti / step_time + 1e-9)), steps)
        phase = ti - k * step_time
        x = min(max(phase / dsp, 0.0), 1.0)
        s = 3 * x**2 - 2 * x**3
        stance_k = RIGHT if k % 2 == 0 else LEFT  # step 0 stands on the right foot
        if k == steps:  # closing DSP: the last stance foot goes from 1 to 1/2
            last = RIGHT if (steps - 1) % 2 == 0 else LEFT
            on_last = 1 - 0.5 * s
            out[i] = on_last if last == RIGHT else 1 - on_last
        elif phase > dsp + 1e-12:  # SSP: all on the stance foot
            out[i] = 1.0 if stance_k == RIGHT else 0.0
        elif k == 0:  # first DSP: from equal shares to all on the right foot
            out[i] = 0.5 + 0.5 * s
        else:  # the new stance foot takes s, the old one keeps 1 - s
            out[i] = s if stance_k == RIGHT else 1 - s
    return out


def _foot_forces(plan) -> np.ndarray:
    """Ground force on (left, right) [N], (n, 2, 3)."""
    left_is_stance = (plan.stance == LEFT)[:, None]
    left = np.where(left_is_stance, plan.stance_force, plan.swing_force)
    right = np.where(left_is_stance, plan.swing_force, plan.stance_force)
    return np.stack([left, right], axis=1)


def test_feet_sum_to_the_total_and_each_is_a_scaled_copy(walk):
    feet = _foot_forces(walk)
    total = walk.ground_force
    np.testing.assert_allclose(feet.sum(axis=1), total, rtol=0, atol=1e-12)
    share = np.einsum("nfi,ni->nf", feet, total) / np.einsum("ni,ni->n", total, total)[:, None]
    np.testing.assert_allclose(feet, share[..., None] * total[:, None, :], rtol=0, atol=1e-12)
    assert np.all(share >= -1e-12) and np.all(share <= 1 + 1e-12)


def test_shares_follow_the_stated_rule(walk):
    """Each foot's share against the rule written out from T, f and N (not from plan.py)."""
    p = walk.params
    right = _right_share_by_the_rule(walk.t, p.step_time, p.ssp_fraction, p.steps)
    feet = _foot_forces(walk)
    total = walk.ground_force
    share = np.einsum("nfi,ni->nf", feet, total) / np.einsum("ni,ni->n", total, total)[:, None]
    np.testing.assert_allclose(share[:, 1], right, rtol=0, atol=1e-9)
    np.testing.assert_allclose(share[:, 0], 1 - right, rtol=0, atol=1e-9)
    assert right[0] == pytest.approx(0.5) and right[-1] == pytest.approx(0.5)  # start, end at rest
    ssp = ~walk.double_support
    assert np.all((share[ssp] == 0) | (share[ssp] == 1))  # one foot carries everything in SSP


def test_shares_are_continuous_through_every_phase_change(walk):
    """No jump at SSP ↔ DSP or at a stance switch beyond the smoothstep's steepest step.

    The steepest step of s = 3x² − 2x³ over one sample is 1.5 dt / T_dsp; a split that
    hands the load over at the wrong sample, or restarts from the wrong foot, jumps by
    up to 1 there.
    """
    p = walk.params
    feet = _foot_forces(walk)
    total = walk.ground_force
    share = np.einsum("nfi,ni->nf", feet, total) / np.einsum("ni,ni->n", total, total)[:, None]
    steepest = 1.5 * p.dt / ((1 - p.ssp_fraction) * p.step_time)
    jumps = np.abs(np.diff(share, axis=0)).max(axis=1)
    changes = np.flatnonzero(
        np.diff(walk.double_support.astype(int)) | np.diff(walk.stance.astype(int))
    )
    assert changes.size >= 2 * p.steps
    assert jumps.max() <= steepest * (1 + 1e-6), (jumps.max(), steepest)
    assert jumps[changes].max() <= steepest * (1 + 1e-6)


def test_split_torques_match_mj_inverse_with_the_swing_share_imposed(spec, walk):
    """DSP: τ = MuJoCo's inverse dynamics with the swing foot loaded by its share.

    MuJoCo gives the total ground wrench of the stance-rooted chain (no split); the swing
    foot gets (1 − s) of it, moved to the swing sole point, imposed through ``mj_jac``;
    what is left on the root is the stance foot's share s of the same wrench.
    """
    p = walk.params
    mj = StanceRootedInverse(spec, gravity_in_slope(p.slope))
    right = _right_share_by_the_rule(walk.t, p.step_time, p.ssp_fraction, p.steps)
    on_swing = np.where(walk.stance == RIGHT, 1 - right, right)
    double = np.flatnonzero(walk.double_support & (on_swing > 0.05))[::9]
    assert double.size > 10 and set(walk.stance[double]) == {0, 1}.intersection(walk.stance)
    worst = 0.0
    for k in double:
        args = (walk.q[k], walk.qd[k], walk.qdd[k], walk.stance[k], walk.stance_sole[k])
        total = mj(*args)
        lever = walk.stance_sole[k] - total.swing_sole  # total moment moved to the swing sole
        swing = (
            on_swing[k] * total.force,
            on_swing[k] * (total.moment + np.cross(lever, total.force)),
        )
        loaded = mj(*args, swing_wrench=swing)
        np.testing.assert_allclose(walk.tau[k], loaded.tau, rtol=1e-7, atol=1e-9)
        np.testing.assert_allclose(loaded.force, (1 - on_swing[k]) * total.force, atol=1e-9)
        np.testing.assert_allclose(loaded.moment, (1 - on_swing[k]) * total.moment, atol=1e-9)
        np.testing.assert_allclose(walk.swing_force[k], swing[0], rtol=0, atol=1e-9)
        worst = max(worst, np.abs(loaded.tau - total.tau).max())
    print(f"largest torque change from the split in these samples: {worst:.3f} N m")
    assert worst > 0.05  # the split matters: the test would see a wrong one
