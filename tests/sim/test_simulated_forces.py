"""Simulated ground forces: their axes, the friction ratio built on them, and where the CoP lies.

* Axes: a walk that starts and ends at rest has zero net momentum change, so the
  time-average of the total ground force equals −m g in S: m g (sin θs, 0, cos θs).
  A force left in world axes, or with its tangential and normal axes mixed, fails.
* Friction ratio: |F_t| / F_n of that force, tangential = (x_S, y_S), normal = z_S.
* CoP: a normal-force-weighted mean of contact points lies in the convex hull of the
  soles actually touching the plane (from the simulated sole sites and the MJCF's
  foot box), whatever the plan says; see ``test_cop_outside_the_planned_polygon...``
  for why the margin to the *planned* polygon of a stable walk is about −50 mm.
"""

import mujoco
import numpy as np
import pytest
from scipy.spatial import ConvexHull

from slopewalk.bench.sim.model import scene_xml
from slopewalk.bench.sim.trial import run_trial
from slopewalk.bench.sim.trial_spec import TrialSpec
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.joints import SIDE_PREFIX
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.zmp import signed_margin

G = 9.81


@pytest.fixture  # per test: mutmut maps a test to the code its fixtures run
def slope_walk(spec):
    """Two 1 s steps on 10°, stiff actuators (stable): (plan, result)."""
    gait = GaitParams.nominal(spec, 1.0, slope=np.deg2rad(10.0), steps=2)
    result = run_trial(spec, TrialSpec(gait))
    assert result.simulated_verdict == "stable" and result.standing_fraction == 1.0
    return plan_walk(spec, gait), result


@pytest.fixture  # per test: mutmut maps a test to the code its fixtures run
def flat_walk(spec):
    """The slow flat walk of the README: 4 steps of 2 s."""
    gait = GaitParams.nominal(spec, 2.0)
    return plan_walk(spec, gait), run_trial(spec, TrialSpec(gait))


def test_mean_ground_force_is_the_weight_in_the_slope_frame(spec, slope_walk):
    plan, result = slope_walk
    slope = plan.params.slope
    force = result.series["foot_force"].sum(axis=1)  # (n, 3), both feet, in S
    weight = spec.total_mass * G
    expected = weight * np.array([np.sin(slope), 0.0, np.cos(slope)])
    np.testing.assert_allclose(force.mean(axis=0), expected, rtol=0, atol=1e-3 * weight)


def test_simulated_friction_ratio_is_tangential_over_normal(spec, slope_walk):
    plan, result = slope_walk
    force = result.series["foot_force"].sum(axis=1)[result.series["standing"]]
    ratio = np.hypot(force[:, 0], force[:, 1]) / force[:, 2]
    assert result.simulated_max_friction_ratio == pytest.approx(ratio.max(), rel=1e-12)
    # standing on 10° needs tan 10° all the time; walking needs more, but not the world
    assert np.median(ratio) == pytest.approx(np.tan(plan.params.slope), abs=0.03)


def _sole_rectangle(spec) -> np.ndarray:
    """Sole corners relative to the sole site, from the MJCF foot box, (4, 2)."""
    model = mujoco.MjModel.from_xml_string(scene_xml(spec))
    geom, site = model.geom(f"{SIDE_PREFIX[0]}foot"), model.site(f"{SIDE_PREFIX[0]}sole")
    c, (hx, hy) = (geom.pos - site.pos)[:2], geom.size[:2]
    return c + np.array([[hx, -hy], [hx, hy], [-hx, hy], [-hx, -hy]])


def _margin_to_touching_soles(spec, series) -> np.ndarray:
    """Signed distance of the simulated CoP to the hull of the soles in contact [m], (n,)."""
    rect = _sole_rectangle(spec)
    loaded = series["foot_force"][..., 2] > 0  # (n, 2)
    out = np.full(series["t"].size, np.nan)
    for k in np.flatnonzero(loaded.any(axis=1) & np.isfinite(series["cop"]).all(axis=1)):
        feet = np.flatnonzero(loaded[k])
        corners = np.concatenate([series["sole"][k, f, :2] + rect for f in feet])
        hull = corners[ConvexHull(corners).vertices]  # counter-clockwise
        out[k] = signed_margin(series["cop"][k][None], hull[None])[0]
    return out


def test_simulated_cop_lies_within_the_soles_in_contact(spec, flat_walk, slope_walk):
    """Measured: −0.05 mm at worst (contact points on the box's edges, the foot rolled a hair)."""
    for _, result in (flat_walk, slope_walk):
        margin = _margin_to_touching_soles(spec, result.series)
        assert np.isfinite(margin).mean() > 0.99
        print(f"CoP margin to the soles in contact: min {np.nanmin(margin) * 1e3:.2f} mm")
        assert np.nanmin(margin) > -0.5e-3


def test_cop_outside_the_planned_polygon_is_the_swing_foot_landing_early(spec, flat_walk):
    """The −50 mm CoP margin of the stable 2 s flat walk is an early touch-down.

    Near the end of each SSP the simulated swing sole reaches the plane ~50 ms before
    the planned touch-down (the plan still has it ~1 mm up; the stiff loop lags and the
    stance leg sags) and takes over half the weight while the planned polygon is still
    the stance foot alone. Excluding the planned-SSP samples where the swing foot
    carries load, the CoP stays within about a millimetre of the planned polygon.
    """
    plan, result = flat_walk
    series, t = result.series, result.series["t"]
    assert result.simulated_verdict == "stable"
    idx = np.clip(np.searchsorted(plan.t, t), 0, plan.t.size - 1)
    margin = signed_margin(np.nan_to_num(series["cop"]), plan.polygon[idx])
    assert margin.min() == pytest.approx(result.simulated_min_margin, abs=1e-12)
    weight = spec.total_mass * G
    fz = series["foot_force"][..., 2]
    on_swing = np.where(plan.stance[idx] == 0, fz[:, 1], fz[:, 0])
    ssp = ~plan.double_support[idx]
    early = ssp & (on_swing > 0.01 * weight)
    worst = np.argmin(margin)
    print(
        f"min CoP margin {margin.min() * 1e3:.1f} mm at t = {t[worst]:.3f} s, swing foot "
        f"carrying {on_swing[worst] / weight:.0%} of the weight; without early-contact "
        f"samples {margin[~early].min() * 1e3:.2f} mm"
    )
    assert margin.min() < -0.02  # the finding: far outside the planned stance foot ...
    assert early[worst] and on_swing[worst] > 0.3 * weight  # ... with the swing foot down
    assert margin[~early].min() > -2e-3  # elsewhere the CoP keeps to the plan's polygon
