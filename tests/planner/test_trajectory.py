"""The nominal gait: derived from the spec, the paper's numbers for the paper's robot."""

import tomllib

import numpy as np
import pytest

from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.spec import default_spec_path, spec_from_dict


def _scaled_spec(factor: float):
    """The paper's robot with every length (geometry and link CoMs) times ``factor``."""
    with open(default_spec_path(), "rb") as f:
        data = tomllib.load(f)
    data["geometry"] = {k: v * factor for k, v in data["geometry"].items()}
    for link in data["links"].values():
        link["com"] = [c * factor for c in link["com"]]
    return spec_from_dict(data, source=f"bioloid x{factor:g}")


def test_nominal_gait_of_the_paper_robot_is_the_papers(spec):
    """Hz 0.20 m, Szmax 0.6·L1, L = L1, tilt 12°: the committed results rest on these."""
    gait = GaitParams.nominal(spec, 1.0)
    assert gait.hip_height == pytest.approx(0.20, abs=1e-12)
    assert gait.swing_lift == pytest.approx(0.6 * 0.111, abs=1e-12)
    assert gait.step_length == pytest.approx(0.111, abs=1e-12)
    assert gait.tilt == pytest.approx(np.deg2rad(12.0), abs=1e-12)


@pytest.mark.parametrize("factor", [2.0, 0.5])
def test_nominal_gait_scales_with_the_robot(spec, factor):
    """A robot scaled in all lengths walks the same joint angles: same knee bend, reachable."""
    big = _scaled_spec(factor)
    gait, scaled = GaitParams.nominal(spec, 1.0), GaitParams.nominal(big, 1.0)
    assert scaled.hip_height == pytest.approx(factor * gait.hip_height, rel=1e-12)
    assert scaled.swing_lift == pytest.approx(factor * gait.swing_lift, rel=1e-12)
    assert scaled.step_length == pytest.approx(factor * gait.step_length, rel=1e-12)
    assert scaled.tilt == gait.tilt
    # plan_walk is strict: it raises on a target out of reach. Every joint angle (the
    # knees' bend included) is the paper robot's; the ZMP need not scale (same T, same g).
    plan, plan_scaled = plan_walk(spec, gait), plan_walk(big, scaled)
    np.testing.assert_allclose(plan_scaled.q, plan.q, atol=1e-9)


def test_the_swing_sole_lands_at_rest_exactly_at_the_planned_touch_down(spec):
    """Height 0 and zero normal speed at each DSP start (the clamped end of the height spline)."""
    from slopewalk.planner.plan import plan_walk

    plan = plan_walk(spec, GaitParams.nominal(spec, 1.0, steps=2))
    dt = plan.params.dt
    speed = np.gradient(plan.swing_sole[:, 2], dt)
    for k in (1, 2):  # the touch-downs at t = k T
        i = int(round(k * plan.params.step_time / dt))
        assert plan.double_support[i] and not plan.double_support[i - 1]
        assert abs(plan.swing_sole[i, 2]) < 1e-9
        ssp = slice(i - int(plan.params.ssp_fraction * plan.params.step_time / dt) + 1, i)
        peak = np.abs(speed[ssp]).max()
        assert abs(speed[i - 1]) < 0.02 * peak  # 1 ms before: at rest to 2 % of the swing
