"""The extended gait family's three parameters, each against what it means by hand.

δ (pelvis offset) moves the hip and not the feet, and a static pose's ZMP moves with
its CoM; L (step length) scales every footprint and the hip's path; w (sway share)
blends the hold and sway leans, w = 0 and 1 being those two exactly. Each check runs
on the compiled plan (``plan_walk``) and on the numpy reference (``solve_reference``).
"""

import numpy as np
import pytest

from slopewalk.planner.gait import GaitParams
from slopewalk.planner.kinematics import Chain, gravity_in_slope
from slopewalk.planner.newton_euler import inverse_dynamics_poses
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.reference import solve_reference
from slopewalk.planner.trajectory import Timeline, footprint_y
from slopewalk.planner.zmp import zmp_multibody

SOURCES = ("kernel", "reference")
KEYS = ("q", "stance_sole", "swing_sole", "stance", "margin", "zmp")


def _walk(spec, params, source) -> dict:
    """The series of one walk by name, from the compiled plan or the numpy reference."""
    if source == "kernel":
        plan = plan_walk(spec, params)
        return {k: getattr(plan, k) for k in KEYS}
    x = [
        [params.hip_height], [params.swing_lift], [params.tilt], [params.pelvis_offset],
        [params.step_length], [params.lean_share],
    ]  # fmt: skip
    out = solve_reference(spec, Timeline.of(params), params.slope, *np.array(x), strict=True)
    return {k: out[k][0] for k in KEYS}


def _pelvis(spec, walk) -> np.ndarray:
    """The pelvis centre in S [m] from the DH chain posed at the walk's q, (n, 3)."""
    chain = Chain.from_spec(spec)
    frames = chain.frames(walk["q"], walk["stance_sole"], walk["stance"])
    return chain.pelvis_pose(frames, walk["stance"])[0]


@pytest.mark.parametrize("source", SOURCES)
@pytest.mark.parametrize("slope_deg", (0.0, 15.0, -15.0))
def test_the_pelvis_offset_moves_the_hip_by_delta_and_not_the_feet(spec, source, slope_deg):
    base = GaitParams.nominal(spec, 1.0, slope=np.deg2rad(slope_deg), steps=3)
    delta = 0.015
    a = _walk(spec, base, source)
    b = _walk(
        spec, GaitParams.nominal(spec, 1.0, slope=base.slope, steps=3, pelvis_offset=delta), source
    )
    shift = _pelvis(spec, b) - _pelvis(spec, a)
    np.testing.assert_allclose(shift[:, 0], delta, rtol=0, atol=1e-12)
    np.testing.assert_allclose(shift[:, 1:], 0.0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(b["stance_sole"], a["stance_sole"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(b["swing_sole"], a["swing_sole"], rtol=0, atol=1e-12)


@pytest.mark.parametrize("source", SOURCES)
@pytest.mark.parametrize("slope_deg", (0.0, 20.0))
def test_the_pelvis_offset_moves_a_static_poses_zmp_with_its_com(spec, source, slope_deg):
    """Held still (q̇ = q̈ = 0), eq. (4) is p = c_xy − c_z g_xy / g_z: the ZMP moves by the
    CoM's shift, less its height change times the slope's g_x / g_z. The CoM moves forward,
    by less than δ (the feet stay)."""
    slope = np.deg2rad(slope_deg)
    delta = 0.02
    gravity = gravity_in_slope(slope)
    chain = Chain.from_spec(spec)
    static = []
    for offset in (0.0, delta):
        params = GaitParams.nominal(spec, 1.0, slope=slope, steps=2, pelvis_offset=offset)
        walk = _walk(spec, params, source)
        keep = slice(None, None, 97)
        q, sole, stance = walk["q"][keep], walk["stance_sole"][keep], walk["stance"][keep]
        R, o = chain.poses(q, sole, stance)
        zero = np.zeros_like(q)
        dyn = inverse_dynamics_poses(chain, R, o, zero, zero, stance, gravity)
        com = np.einsum("k,nki->ni", chain.mass, dyn.com) / chain.mass.sum()
        zmp = zmp_multibody(chain.mass, dyn.com, dyn.com_acc, dyn.momentum_rate, gravity)
        static.append((com, zmp))
    (c0, z0), (c1, z1) = static
    dc = c1 - c0
    expected = dc[:, :2] - dc[:, 2:3] * gravity[:2] / gravity[2]
    np.testing.assert_allclose(z1 - z0, expected, rtol=0, atol=1e-12)
    assert np.all(dc[:, 0] > 0.2 * delta) and np.all(dc[:, 0] < delta)


@pytest.mark.parametrize("source", SOURCES)
def test_the_step_length_scales_the_footprints_and_the_hips_path(spec, source):
    """Stance soles at x = k L / 2, the swing sole from L/2 behind to L/2 ahead of its stance
    foot, the pelvis's x in proportion to L; the footprints' y do not depend on L."""
    walks = {}
    for share in (0.5, 1.0):
        L = share * spec.thigh
        params = GaitParams.nominal(spec, 1.0, slope=np.deg2rad(10.0), step_length=L)
        walk = _walk(spec, params, source)
        timeline = Timeline.of(params)
        k = np.minimum(timeline.step, params.steps - 1)
        np.testing.assert_allclose(walk["stance_sole"][:, 0], k * L / 2, rtol=0, atol=1e-12)
        lift_off = np.flatnonzero(np.diff(timeline.in_ssp.astype(int)) == 1) + 1
        touch = np.flatnonzero(np.diff(timeline.in_ssp.astype(int)) == -1)
        for i, ahead in ((lift_off, -L / 2), (touch, L / 2)):
            dx = walk["swing_sole"][i, 0] - walk["stance_sole"][i, 0]
            np.testing.assert_allclose(dx, ahead, rtol=0, atol=2e-4)  # one 1 ms sample away
        walks[share] = walk
    short, long = walks[0.5], walks[1.0]
    np.testing.assert_allclose(
        _pelvis(spec, long)[:, 0], 2 * _pelvis(spec, short)[:, 0], rtol=0, atol=1e-12
    )
    np.testing.assert_allclose(
        short["stance_sole"][:, 1], long["stance_sole"][:, 1], rtol=0, atol=1e-12
    )


def test_the_sway_share_ends_are_hold_and_sway_exactly(spec):
    for profile, share in (("hold", 0.0), ("sway", 1.0)):
        named = Timeline.of(GaitParams.nominal(spec, 0.9, tilt_profile=profile))
        shared = Timeline.of(GaitParams.nominal(spec, 0.9, sway_share=share))
        own = named.hold_shape if profile == "hold" else named.sway_shape
        for a, b in ((named.tilt_shape, own), (shared.tilt_shape, own)):
            for x, y in ((a.p, b.p), (a.v, b.v), (a.a, b.a)):
                np.testing.assert_array_equal(x, y)
        np.testing.assert_array_equal(shared.landing_shape, named.landing_shape)
    hold = Timeline.of(GaitParams.nominal(spec, 0.9))
    sway = Timeline.of(GaitParams.nominal(spec, 0.9, tilt_profile="sway"))
    assert np.abs(hold.tilt_shape.p - sway.tilt_shape.p).max() > 0.2  # two different shapes


@pytest.mark.parametrize("source", SOURCES)
def test_a_sway_share_between_blends_the_lean_and_the_footprints(spec, source):
    """q1 = q8 = −tilt((1 − w) hold + w sway) at every sample; each touch-down lands the
    swing sole Lh / cos λ_k beside the stance sole, λ_k the blend at the touch-down; at
    mid-SSP both shapes peak, so λ = ±tilt whatever w."""
    w, tilt = 0.3, np.deg2rad(10.0)
    params = GaitParams.nominal(spec, 0.9, sway_share=w, tilt=tilt)
    assert params.lean_profile == "blend"
    walk = _walk(spec, params, source)
    t = Timeline.of(params)
    lean = tilt * ((1 - w) * t.hold_shape.p + w * t.sway_shape.p)
    np.testing.assert_allclose(walk["q"][:, 0], -lean, rtol=0, atol=1e-12)
    np.testing.assert_allclose(walk["q"][:, 7], -lean, rtol=0, atol=1e-12)
    mid = np.searchsorted(t.t, (np.arange(params.steps) + 1 - params.ssp_fraction / 2) * 0.9)
    np.testing.assert_allclose(np.abs(lean[mid]), tilt, rtol=0, atol=1e-9)
    landing = (1 - w) * t.hold_shape.p[t.touch_downs] + w * t.sway_shape.p[t.touch_downs]
    side = np.where(np.arange(params.steps) % 2 == 0, 1.0, -1.0)
    y = -spec.hip_width / 2 + np.cumsum(side * spec.hip_width / np.cos(tilt * landing))
    np.testing.assert_allclose(footprint_y(t, spec.hip_width, tilt)[1:], y[:-1], atol=1e-15)
    k = np.minimum(t.step, params.steps - 1)
    feet = np.concatenate([[-spec.hip_width / 2], y[:-1]])[k]
    np.testing.assert_allclose(walk["stance_sole"][:, 1], feet, rtol=0, atol=1e-12)
