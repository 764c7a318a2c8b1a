"""The GA's contact constraints (friction ratio, planned foot slide) and its bent-knee limit,
against the plan's own series and physical identities."""

import numpy as np
import pytest

from slopewalk.planner.gait import GaitParams
from slopewalk.planner.gait_search import GaitProblem, ga_params, min_knee_flexion
from slopewalk.planner.kernel.run import kernel_walk
from slopewalk.planner.kinematics import GRAVITY
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.trajectory import Timeline
from slopewalk.planner.verdict import LOADED_FRACTION, planned_slide

# (Hz [m], Szmax [m], tilt [rad]) of walks that lean far (a slide of several mm) and little
GAITS = ((0.19, 0.02, 0.55), (0.2, 0.012, 0.2), (0.17, 0.03, -0.45))


@pytest.mark.parametrize("slope_deg", [0.0, 20.0])
def test_kernel_friction_and_slide_equal_the_plans(spec, slope_deg):
    """At the plan's own samples the kernel's reductions are the plan's largest |F_t|/F_n and
    ``verdict.planned_slide`` (numpy, from the plan's swing sole and forces)."""
    loaded = LOADED_FRACTION * spec.total_mass * GRAVITY
    slides = []
    for hz, lift, tilt in GAITS:
        params = GaitParams.nominal(
            spec, 1.0, slope=np.deg2rad(slope_deg), steps=4, dt=0.005, hip_height=hz,
            swing_lift=lift, tilt=tilt,
        )  # fmt: skip
        plan = plan_walk(spec, params)
        walk = kernel_walk(spec, Timeline.of(params))
        *_, friction, slide = walk.scores(
            params.slope, np.array([[hz, lift, tilt]]), samples="grid", refine=False,
            contact=True, loaded=loaded,
        )  # fmt: skip
        assert friction[0] == pytest.approx(plan.friction_ratio.max(), abs=1e-12)
        assert slide[0] == pytest.approx(planned_slide(plan), abs=1e-12)
        slides.append(slide[0])
    assert max(slides) > 0.005 > min(slides)  # both sides of the slip threshold are tried


def test_no_gait_holds_on_a_plane_steeper_than_its_friction(spec):
    """A walk from rest to rest pushes along the plane on average m g sin θs against m g cos θs
    into it, so some sample needs |F_t|/F_n ≥ tan θs: at μ < tan 22.5° nothing is admissible,
    at μ = 1 the same gaits are held."""
    params = ga_params(spec, 1.0, np.deg2rad(22.5))
    X = np.array(GAITS)
    slippery = GaitProblem(spec, params, friction=0.9 * np.tan(np.deg2rad(22.5))).measure(X)
    assert (slippery.friction_gap > 0).all() and not slippery.admissible.any()
    held = GaitProblem(spec, params, friction=1.0).measure(X)
    assert (held.friction_gap < 0).all()
    ratio = held.friction_gap + 1.0
    assert (ratio >= np.tan(np.deg2rad(22.5))).all()


def test_the_search_keeps_the_knee_bent_by_the_servos_band(spec):
    """A hip height that puts the knee within stall / kp of straight is inadmissible, however
    reachable; a centimetre lower it is not (the knee's 1.5 N m / 9.26 N m/rad = 0.162 rad)."""
    assert min_knee_flexion(spec) == pytest.approx(1.5 / 9.26)
    params = ga_params(spec, 1.0, np.deg2rad(-10.0))
    problem = GaitProblem(spec, params)
    x = np.array([[0.2333557, 0.0169766, np.deg2rad(12.48058)], [0.22, 0.0169766, 0.2178]])
    m = problem.measure(x)
    assert np.isfinite(m.work).all()  # both reachable
    assert m.joint_gap[0] > 0 and m.joint_gap[1] <= 0
