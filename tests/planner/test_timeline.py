"""The walk's timeline against the numbers the README and the design promise.

Measured from the plan's outputs (phase flags, sole positions, CoM, rates), never
from ``Timeline`` itself: the default walk is 4 steps (``--steps`` default, the
sweeps' ``steps = 4``); each step is a DSP of 40 % then an SSP of 60 % of the step
time, then one closing DSP; the first stance foot is the right one and stances
alternate; the swing foot advances L = thigh length and rises to 0.6 × thigh; the
hip (and so the CoM) advances L/2 per step; the walk starts and ends at rest.
"""

import numpy as np
import pytest

from slopewalk.planner.gait import GaitParams
from slopewalk.planner.joints import LEFT, RIGHT
from slopewalk.planner.kinematics import Chain
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.trajectory import Timeline, footprint_y

DEFAULT_STEPS = 4  # README: `--steps N`, CLI help "(4)"; docs/sweep-format.md: default 4
DSP_SHARE, SSP_SHARE = 0.4, 0.6  # README: "each step is a DSP (40 %) then an SSP (60 %)"


def _runs(flag: np.ndarray) -> list[tuple[int, int]]:
    """(first, last) sample index of each run of True in ``flag``."""
    edges = np.diff(np.concatenate([[0], flag.astype(int), [0]]))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1, strict=True))


@pytest.mark.parametrize(
    "step_time, slope_deg, profile", [(1.0, 0.0, "hold"), (0.6, 12.0, "sway"), (2.0, -20.0, "hold")]
)
def test_default_walk_has_the_promised_timeline(spec, step_time, slope_deg, profile):
    params = GaitParams.nominal(spec, step_time, slope=np.deg2rad(slope_deg), tilt_profile=profile)
    plan = plan_walk(spec, params)
    T, dt, L = step_time, params.dt, spec.thigh
    assert params.steps == DEFAULT_STEPS
    ssp, dsp = _runs(~plan.double_support), _runs(plan.double_support)
    assert len(ssp) == DEFAULT_STEPS  # one single support per step
    assert len(dsp) == DEFAULT_STEPS + 1  # one per step, and the closing one
    assert plan.t[-1] == pytest.approx((DEFAULT_STEPS + DSP_SHARE) * T, abs=1e-9)
    np.testing.assert_allclose(np.diff(plan.t), dt, rtol=1e-9)  # sampled at dt throughout
    # at the start the feet stand under the hips, the right one at -Lh/2 (pelvis at y = 0)
    np.testing.assert_allclose(plan.stance_sole[0, 1], -spec.hip_width / 2, atol=1e-12)
    np.testing.assert_allclose(plan.swing_sole[0, 1], spec.hip_width / 2, atol=1e-9)
    # phase durations, to one sample: the flags change at the sample after the boundary
    for a, b in ssp:
        assert plan.t[b] - plan.t[a] + dt == pytest.approx(SSP_SHARE * T, abs=1.01 * dt)
    for a, b in dsp:
        assert plan.t[b] - plan.t[a] + dt == pytest.approx(DSP_SHARE * T, abs=1.01 * dt)
    for k, (a, b) in enumerate(ssp):
        assert plan.t[a] == pytest.approx(k * T + DSP_SHARE * T, abs=1.01 * dt)
        # stances alternate from the right foot; the closing DSP keeps the last
        assert set(plan.stance[a : b + 1]) == {RIGHT if k % 2 == 0 else LEFT}
        # stance sole k·L/2 along the slope; the swing sole advances L and lifts 0.6·L1
        np.testing.assert_allclose(plan.stance_sole[a, 0], k * L / 2, atol=1e-12)
        # at b + 1 the foot that swung has landed: the next stance foot (the swing foot
        # of the closing DSP after the last step)
        switched = plan.stance[b + 1] != plan.stance[b]
        lift_off = plan.swing_sole[a - 1]
        landed = plan.stance_sole[b + 1] if switched else plan.swing_sole[b + 1]
        assert landed[0] - lift_off[0] == pytest.approx(L, abs=1e-9)
        assert plan.swing_sole[a : b + 1, 2].max() == pytest.approx(0.6 * spec.thigh, abs=1e-6)
        assert abs(lift_off[2]) < 1e-9 and abs(plan.swing_sole[b, 2]) < 1e-4
        assert np.hypot(*(plan.swing_sole[b] - landed)[:2]) < 1e-3  # it lands where it went
    assert set(plan.stance[dsp[-1][0] :]) == {RIGHT if DEFAULT_STEPS % 2 else LEFT}


@pytest.mark.parametrize("steps", [1, 2, 4, 7])
def test_distance_walked_and_rest_at_both_ends(spec, steps):
    """The CoM advances N·L/2 along the slope; rates are zero at start and end."""
    params = GaitParams.nominal(spec, 0.8, slope=np.deg2rad(8.0), steps=steps)
    plan = plan_walk(spec, params)
    L = spec.thigh
    advance = plan.com[-1, 0] - plan.com[0, 0]
    assert advance == pytest.approx(steps * L / 2, abs=1e-9)
    # the feet: at the start L/2 apart, the left behind; at the end the last swing foot
    # has landed N·L/2 ahead of where the right foot started
    feet_start = sorted([plan.stance_sole[0, 0], plan.swing_sole[0, 0]])
    feet_end = sorted([plan.stance_sole[-1, 0], plan.swing_sole[-1, 0]])
    np.testing.assert_allclose(feet_start, [-L / 2, 0.0], atol=1e-9)
    np.testing.assert_allclose(feet_end, [(steps - 1) * L / 2, steps * L / 2], atol=1e-9)
    for k in (0, -1):
        np.testing.assert_allclose(plan.qd[k], 0.0, atol=1e-12)
    # the body is at rest, not only the joints: CoM velocity from FK by differences
    chain = Chain.from_spec(spec)
    ends = np.r_[0:3, plan.t.size - 3 : plan.t.size]
    frames = chain.frames(plan.q[ends], plan.stance_sole[ends], plan.stance[ends])
    com = chain.center_of_mass(frames, plan.stance[ends])
    dt = params.dt
    for v in (com[1] - com[0], com[-1] - com[-2]):
        assert np.abs(v / dt).max() < 0.02 * L / params.step_time  # [m/s], a sliver of walking


def test_lateral_footprints_by_hand_for_one_robot_and_a_population(spec):
    """Feet land Lh / cos λ apart (legs parallel, no hip roll); a population row by row.

    Hold profile: the lean at each touch-down is ±tilt, so for three steps the right foot
    starts at −Lh/2, the left lands at −Lh/2 + Lh / cos(tilt), the right back at −Lh/2.
    """
    Lh = spec.hip_width
    timeline = Timeline.of(GaitParams.nominal(spec, 0.8, steps=3))
    tilts = np.array([0.14, 0.2, 0.05])  # [rad]
    for tilt in tilts:
        expected = [-Lh / 2, -Lh / 2 + Lh / np.cos(tilt), -Lh / 2]
        np.testing.assert_allclose(footprint_y(timeline, Lh, tilt), expected, atol=1e-12)
    rows = footprint_y(timeline, Lh, tilts)
    assert rows.shape == (3, 3)
    for k, tilt in enumerate(tilts):
        np.testing.assert_allclose(rows[k], footprint_y(timeline, Lh, tilt), atol=1e-15)
