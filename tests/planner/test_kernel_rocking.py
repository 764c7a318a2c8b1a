"""The compiled rocking loop (planner/kernel/rocking.py) against its numpy reference
(tipping._rocking_loop), on drawn walks and judged ZMP series that make the support
rock: excursions past either line, landings on the other, the swing sole's prop, the
floor's give and a fall past FALLEN.

The kernel is the reference's statements in the same order, compiled without
fast-math, so the same IEEE operations: held equal to 1e-12 rad (they agree to the bit
here; the tolerance only leaves room for a compiler that contracts a product and a sum).
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.tipping import FALLEN, PITCH, ROLL, LinkMoments, rocking

CORNER_STIFFNESS = 2.0e4  # [N/m], of the order of the simulator's soft floor (floor.py)


def _judged(plan, amplitude: float, period: float, seed: int) -> np.ndarray:
    """The plan's ZMP pushed by a sway of ``amplitude`` [m] and ``period`` [s] and
    noise of a tenth of it: excursions past both lines, back and forth."""
    rng = np.random.default_rng(seed)
    phase = 2 * np.pi * plan.t / period
    sway = amplitude * np.column_stack([np.sin(phase + 1.0), np.sin(phase)])
    return plan.zmp + sway + 0.1 * amplitude * rng.standard_normal(plan.zmp.shape)


def _both(plan, axis, zmp, clearance, floor, moments):
    """Both loops' θ; and the samples each says the swing sole props, which must agree."""
    props = np.zeros(plan.t.size, dtype=bool), np.zeros(plan.t.size, dtype=bool)
    got = rocking(plan, axis, zmp, clearance, floor, moments, props[0], compiled=True)
    want = rocking(plan, axis, zmp, clearance, floor, moments, props[1], compiled=False)
    np.testing.assert_array_equal(props[0], props[1])
    return got, want


@settings(max_examples=12, deadline=None)
@given(
    step_time=st.floats(0.5, 1.5),
    slope_deg=st.floats(-15.0, 25.0),
    amplitude=st.floats(0.0, 0.08),
    period=st.floats(0.2, 2.0),
    lift=st.floats(0.0, 1.0),
    soft=st.booleans(),
    seed=st.integers(0, 2**32 - 1),
)
def test_the_compiled_loop_is_the_reference_on_drawn_walks(
    spec, step_time, slope_deg, amplitude, period, lift, soft, seed
):
    gait = GaitParams.nominal(spec, step_time, steps=2, slope=np.deg2rad(slope_deg), dt=0.002)
    plan = plan_walk(spec, gait)
    zmp = _judged(plan, amplitude, period, seed)
    clearance = lift * plan.swing_sole[:, 2]  # 0: the swing sole props at once
    moments = LinkMoments(plan)
    floor = CORNER_STIFFNESS if soft else None
    for axis in (ROLL, PITCH):
        got, want = _both(plan, axis, zmp, clearance, floor, moments)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    ("amplitude", "lift", "regime"),
    [(0.0, 1.0, "flat"), (0.03, 1.0, "rocks"), (0.03, 0.2, "propped"), (0.2, 1.0, "falls")],
)
def test_the_compiled_loop_is_the_reference_in_each_regime(spec, amplitude, lift, regime):
    """Each branch of the loop taken, and each regime shows in the series (so the equality
    above is not that of two zero series)."""
    plan = plan_walk(spec, GaitParams.nominal(spec, 1.0, steps=2, slope=np.deg2rad(10)))
    zmp = _judged(plan, amplitude, 0.8, seed=1)
    clearance = lift * plan.swing_sole[:, 2]
    moments = LinkMoments(plan)
    for axis in (ROLL, PITCH):
        got, want = _both(plan, axis, zmp, clearance, CORNER_STIFFNESS, moments)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
        rigid, rigid_want = _both(plan, axis, zmp, clearance, None, moments)
        np.testing.assert_allclose(rigid, rigid_want, rtol=0, atol=1e-12)
        if regime == "flat":
            assert np.abs(rigid).max() == 0.0 and np.abs(got).max() > 0.0  # the give alone
        elif regime == "rocks":
            assert rigid.max() > 0.0 > rigid.min()  # both lines, landing from one on the other
            assert np.abs(rigid).max() < FALLEN
        elif regime == "falls":
            assert np.abs(rigid).max() == FALLEN
    if regime == "propped":  # the swing sole stops a turn: the tilt held at height / beyond
        free = rocking(plan, ROLL, zmp, plan.swing_sole[:, 2], None, moments)
        assert np.abs(rigid).max() < np.abs(free).max()
        props = np.zeros(plan.t.size, dtype=bool)
        rocking(plan, PITCH, zmp, clearance, None, moments, props)
        assert props.any()  # and the samples are marked, the same by both loops (_both)
