"""The compiled kernel against the numpy reference; the GA's margin against finer plans."""

import os
import shutil
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from slopewalk.planner.gait import GaitParams
from slopewalk.planner.gait_search import GaitProblem, ga_params, joint_gap, search_limits
from slopewalk.planner.kernel import sample as sm
from slopewalk.planner.kernel.run import kernel_walk
from slopewalk.planner.kernel.tables import T0, T1, GaitTable, limit_samples
from slopewalk.planner.plan import plan_walk, score
from slopewalk.planner.reference import evaluate_reference, solve_reference
from slopewalk.planner.sole import outline
from slopewalk.planner.trajectory import Timeline

ROOT = Path(__file__).resolve().parents[2]
SLOPES_DEG = (-30.0, -12.0, 0.0, 17.5, 35.0)
# (row slice of the kernel, key of the reference)
SERIES = {
    "q": (sm.Q, 8),
    "qd": (sm.QD, 8),
    "qdd": (sm.QDD, 8),
    "tau": (sm.TAU, 8),
    "zmp": (sm.ZMP, 2),
    "zmp_lipm": (sm.ZMP_LIPM, 2),
    "cop_ne": (sm.COP, 2),
    "com": (sm.COM, 3),
    "com_acc": (sm.COM_ACC, 3),
    "swing_sole": (sm.SWING_SOLE, 3),
    "polygon": (sm.POLYGON, None),  # 4 floats per sole vertex (``sole.outline``)
    "margin": (sm.MARGIN, 1),
    "ground_force": (sm.GROUND, 3),
    "swing_force": (sm.SWING_FORCE, 3),
    "friction_ratio": (sm.FRICTION, 1),
}


def _population(spec, params, size, seed, family="paper"):
    """Random individuals in the family's box, reachable and within the joint limits."""
    problem = GaitProblem(spec, params, family=family)
    rng = np.random.default_rng(seed)
    draws = 8 if family == "paper" else 64  # a few % of the extended box is admissible
    X = rng.uniform(problem.bounds.xl, problem.bounds.xu, (draws * size, problem.bounds.xl.size))
    m = problem.measure(X)  # the search's joint limits: the knee bent by the servo's band
    X = X[np.isfinite(m.work) & (m.joint_gap <= 0)][:size]
    assert len(X) == size
    return X


def _kernel_equals_reference(spec, params, timeline, X):
    rows = kernel_walk(spec, timeline).series(params.slope, X)
    reference = solve_reference(spec, timeline, params.slope, *X.T, strict=False)
    for key, (start, width) in SERIES.items():
        width = 4 * len(outline(spec)) if width is None else width
        _close(
            key, rows[..., start : start + width], reference[key].reshape(rows.shape[:2] + (-1,))
        )
    _close("stance_sole", rows[..., sm.STANCE_SOLE : sm.STANCE_SOLE + 3], reference["stance_sole"])
    power = rows[..., sm.POWER_JOINTS : sm.POWER_JOINTS + 8]
    _close("work", np.trapezoid(power, timeline.t, axis=1), reference["work"])
    work, margin, _ = kernel_walk(spec, timeline).scores(
        params.slope, X, samples="grid", refine=False
    )
    ref_work, ref_margin = evaluate_reference(spec, params, X)
    _close("total work", work, ref_work)
    _close("min margin", margin, ref_margin)


def _close(name, kernel, reference, rtol=1e-9):
    """Equal within rtol of the series' own finite scale; NaN and ±inf at the same places."""
    kernel, reference = np.asarray(kernel, dtype=float), np.asarray(reference, dtype=float)
    finite = np.isfinite(reference)
    assert np.array_equal(finite, np.isfinite(kernel)), name
    assert np.array_equal(kernel[~finite], reference[~finite], equal_nan=True), name
    if not finite.any():
        return
    scale = np.abs(reference[finite]).max() or 1.0
    error = np.abs(kernel[finite] - reference[finite]).max() / scale
    assert error <= rtol, f"{name}: relative error {error:.2e}"


@pytest.mark.parametrize("profile", ["hold", "sway"])
@pytest.mark.parametrize("slope_deg", SLOPES_DEG)
def test_kernel_equals_the_numpy_reference(spec, slope_deg, profile):
    """Every series of random admissible walks, to 1e-9 of its scale; work and min margin too."""
    step_time = 0.5 + (slope_deg + 30) / 65  # 0.5 … 1.5 s across the slopes
    params = ga_params(spec, step_time, np.deg2rad(slope_deg), tilt_profile=profile)
    X = _population(spec, params, 12, seed=int(slope_deg + 100))
    X[:, 2] *= np.where(np.arange(len(X)) % 2, 1.0, -1.0)  # both signs of the tilt
    _kernel_equals_reference(spec, params, Timeline.of(params), X)


@pytest.mark.parametrize("slope_deg", (-12.0, 17.5))
def test_kernel_equals_the_numpy_reference_with_a_sole_polygon(spec, slope_deg):
    """A hexagonal sole 8 mm outward of the ankle (``geometry.sole_polygon``): every
    series, polygon and margin included, of random extended walks, to 1e-9 of its scale."""
    hexagon = ((0.04, -0.012), (0.04, 0.028), (0.0, 0.035), (-0.045, 0.028), (-0.045, -0.012),
               (0.0, -0.019))  # fmt: skip
    spec = replace(spec, sole_offset=0.008, sole_polygon=hexagon)
    params = ga_params(spec, 0.8, np.deg2rad(slope_deg))
    X = _population(spec, params, 12, seed=int(slope_deg + 300), family="extended")
    X[:, 2] *= np.where(np.arange(len(X)) % 2, 1.0, -1.0)
    _kernel_equals_reference(spec, params, Timeline.of(params), X)


@pytest.mark.parametrize("slope_deg", (-30.0, -15.0, 0.0, 15.0, 22.5, 35.0))
def test_kernel_equals_the_numpy_reference_on_extended_gaits(spec, slope_deg):
    """Random admissible (Hz, Szmax, tilt, δ, L, w) of the extended box: every series,
    the work and the minimum margin, to 1e-9 of their scale, at each slope."""
    step_time = 0.5 + (slope_deg + 30) / 65
    params = ga_params(spec, step_time, np.deg2rad(slope_deg))
    X = _population(spec, params, 12, seed=int(slope_deg + 200), family="extended")
    X[:, 2] *= np.where(np.arange(len(X)) % 2, 1.0, -1.0)
    X[:2, 5] = (0.0, 1.0)  # both named ends of the sway share
    assert np.ptp(X[:, 3]) > 0.02 and np.ptp(X[:, 4]) > 0.02  # δ and L really vary
    _kernel_equals_reference(spec, params, Timeline.of(params), X)


@pytest.mark.parametrize("sole_offset", [0.012, -0.009])  # [m] outward of the ankle
def test_kernel_equals_the_numpy_reference_with_a_sole_beside_the_ankle(spec, sole_offset):
    """A sole centred off its ankle (an imported robot's): the polygon and the margin of
    every series, to 1e-9 of their scale, in both support phases and both stance sides."""
    spec = replace(spec, sole_offset=sole_offset)
    params = ga_params(spec, 1.0, np.deg2rad(8.0))
    X = _population(spec, params, 8, seed=300, family="extended")
    X[:, 2] *= np.where(np.arange(len(X)) % 2, 1.0, -1.0)
    _kernel_equals_reference(spec, params, Timeline.of(params), X)


# [m] ahead of the hip–ankle line; a knee ahead lets the knee's limit fold the leg so far
# that few of the extended box's gaits stay within the hip and ankle limits: the paper's
@pytest.mark.parametrize("knee_offset, family", [(-0.030, "extended"), (0.014, "paper")])
def test_kernel_equals_the_numpy_reference_with_the_knees_off_the_leg_line(
    spec, knee_offset, family
):
    """Knees behind (a real humanoid's) or ahead of the hip–ankle line: the IK's effective
    links and angle shifts, the DH rows' b, every series, the work and the minimum margin,
    to 1e-9 of their scale, both support phases and stance sides."""
    spec = replace(spec, knee_offset=knee_offset)
    params = ga_params(spec, 0.9, np.deg2rad(12.0))
    X = _population(spec, params, 8, seed=301, family=family)
    X[:, 2] *= np.where(np.arange(len(X)) % 2, 1.0, -1.0)
    rows = kernel_walk(spec, Timeline.of(params)).series(params.slope, X)
    assert np.isfinite(rows[..., sm.Q : sm.Q + 8]).all()  # every individual walks
    _kernel_equals_reference(spec, params, Timeline.of(params), X)


@pytest.mark.parametrize("profile, share", [("hold", 0.0), ("sway", 1.0)])
def test_six_columns_of_the_paper_family_are_its_three(spec, profile, share):
    """(Hz, Szmax, tilt) on a walk of ``profile`` is (…, 0, L, w of the profile): the kernel's
    rows are the same, whichever profile the walk of the six columns was built with."""
    params = ga_params(spec, 0.8, np.deg2rad(10.0), tilt_profile=profile)
    X = _population(spec, params, 4, seed=3)
    full = np.column_stack([X, np.zeros(4), np.full(4, params.step_length), np.full(4, share)])
    other = replace(params, tilt_profile="sway" if profile == "hold" else "hold", sway_share=None)
    rows = kernel_walk(spec, Timeline.of(params)).series(params.slope, X)
    rows6 = kernel_walk(spec, Timeline.of(other)).series(params.slope, full)
    np.testing.assert_allclose(rows6, rows, rtol=0, atol=1e-12)


@pytest.mark.parametrize("slope_deg", (-20.0, 0.0, 22.5))
def test_extended_columns_reproduce_the_walks_they_name(spec, slope_deg):
    """A 6-column individual walks the timeline its step length and sway share name.

    (Hz, Szmax, tilt, 0, L, w) on a walk of step length L0 and hold profile must give,
    series by series, the 3-column walk of a timeline with step length L and, for
    w = 0 / 1, the hold / sway profile: L scales every x of the walk and w blends the
    two lean profiles (and their footprints). A pelvis offset δ moves the hip and
    nothing else: the IK'd legs put the stance ankle -> hip vector δ further along x_S.
    """
    params = ga_params(spec, 1.0, np.deg2rad(slope_deg))
    X = _population(spec, params, 6, seed=3)
    length = 0.8 * spec.thigh
    walk = kernel_walk(spec, Timeline.of(params))
    for share, profile in ((0.0, "hold"), (1.0, "sway")):
        other = replace(params, step_length=length, tilt_profile=profile)
        expected = kernel_walk(spec, Timeline.of(other)).series(other.slope, X)
        rest = np.tile([0.0, length, share], (len(X), 1))
        got = walk.series(params.slope, np.concatenate([X, rest], axis=1))
        _close(profile, got, expected)
    # δ: compare the hip x of the stance leg from its joint angles (planar sagittal chain)
    base = walk.series(params.slope, X)
    delta = 0.004
    moved = walk.series(
        params.slope, np.concatenate([X, np.tile([delta, params.step_length, 0.0], (len(X), 1))], 1)
    )

    def hip_x(rows):  # stance ankle -> hip along x_S from q2 (ankle pitch), q3 (knee)
        q2, q3 = rows[..., sm.Q + 1], rows[..., sm.Q + 2]
        return spec.shank * np.sin(-q2) + spec.thigh * np.sin(-q2 - q3)

    lean = np.cos(base[..., sm.Q])  # the roll lean shortens nothing along x: check it is common
    np.testing.assert_allclose(lean, np.cos(moved[..., sm.Q]), rtol=0, atol=1e-15)
    np.testing.assert_allclose(hip_x(moved) - hip_x(base), delta, rtol=0, atol=1e-12)
    np.testing.assert_allclose(
        moved[..., sm.SWING_SOLE : sm.SWING_SOLE + 3],
        base[..., sm.SWING_SOLE : sm.SWING_SOLE + 3],
        rtol=0,
        atol=1e-12,
    )


def test_plan_walk_is_the_reference_plan(spec):
    """The Plan the CLI writes (1 ms, nominal gait on 22.5°) equals the numpy pipeline's."""
    params = GaitParams.nominal(spec, 1.0, slope=np.deg2rad(22.5))
    plan = plan_walk(spec, params)
    x = np.array([[params.hip_height], [params.swing_lift], [params.tilt]])
    reference = solve_reference(spec, Timeline.of(params), params.slope, *x, strict=True)
    for key in (*SERIES, "stance", "double_support", "stance_sole", "stance_force", "work", "t"):
        _close(key, getattr(plan, key), reference[key][0])


@pytest.mark.parametrize("family", ["paper", "extended"])
def test_joint_gap_equals_the_numpy_joint_check(spec, family):
    params = ga_params(spec, 1.0, np.deg2rad(22.5))
    problem = GaitProblem(spec, params, family=family)
    size = (400, problem.bounds.xl.size)
    X = np.random.default_rng(5).uniform(problem.bounds.xl, problem.bounds.xu, size)
    timeline = Timeline.of(params)
    walk = kernel_walk(spec, timeline)
    limits = search_limits(spec)
    _, _, gap = walk.scores(params.slope, X, samples="grid", limits=limits)  # joint_gap's samples
    reference = joint_gap(spec, timeline, X)
    assert np.isinf(gap).any() and (gap > 0).any() and (gap <= 0).any()
    np.testing.assert_allclose(gap, reference, atol=1e-12, rtol=0)
    # the GA's samples (grid, piece ends, probes) see at least as much
    _, _, ga_gap = score(spec, params, X, limits=limits)
    finite = np.isfinite(gap)
    assert np.array_equal(np.isfinite(ga_gap), finite)
    assert (ga_gap[finite] >= gap[finite] - 1e-12).all()


def test_the_ga_samples_see_both_sides_of_every_phase_change(spec):
    timeline = Timeline.of(ga_params(spec, 1.0, 0.0))
    table = GaitTable.of(timeline)
    pieces, t = limit_samples(table, timeline)
    in_ssp = table.ints[pieces, 2].astype(bool)
    changes = np.flatnonzero(np.diff(in_ssp.astype(int)))
    assert len(changes) == 2 * timeline.steps  # DSP→SSP and SSP→DSP in every step
    np.testing.assert_array_equal(t[changes], t[changes + 1])  # the same instant, both sides
    np.testing.assert_array_equal(table.floats[pieces[changes], T1], t[changes])
    np.testing.assert_array_equal(table.floats[pieces[changes + 1], T0], t[changes])


def test_ga_margin_is_the_walk_minimum(spec):
    """1,000 random admissible individuals at 5 slopes: the GA's margin vs finer plans.

    Never above the 1 ms plan's (so a gait feasible in the GA is feasible at 1 ms),
    and within 0.05 mm of a brute-force plan that resolves the minimum: the 1 ms plan
    with its phase-change limits where that already agrees, else the same at 20 µs.
    A near-singular swing leg (Hz close to its upper bound) moves the ZMP by metres
    per second just after lift-off, faster than a 1 ms plan resolves.
    """
    worst = {}
    for slope_deg in (-30.0, -10.0, 0.0, 22.5, 35.0):
        params = ga_params(spec, 1.0, np.deg2rad(slope_deg))
        X = _population(spec, params, 200, seed=11)
        _, margin, _ = score(spec, params, X)
        fine = kernel_walk(spec, Timeline.of(replace(params, dt=1e-3)))
        _, plan_1ms, _ = fine.scores(params.slope, X, samples="grid", refine=False)
        assert np.all(margin <= plan_1ms + 1e-12)
        _, brute, _ = fine.scores(params.slope, X, samples="limit", refine=False)
        far = np.abs(margin - brute) > 5e-5
        if far.any():
            dense = kernel_walk(spec, Timeline.of(replace(params, dt=2e-5)))
            _, brute[far], _ = dense.scores(params.slope, X[far], samples="limit", refine=False)
        error = np.abs(margin - brute)
        worst[slope_deg] = (error.max() * 1e3, far.sum(), (plan_1ms - margin).max() * 1e3)
        assert error.max() <= 5e-5, slope_deg
    print("\nslope: max |GA - brute force| [mm], resolved only at 20 µs, max 1 ms plan - GA [mm]")
    for slope_deg, (err, n_far, above) in worst.items():
        print(f"{slope_deg:6.1f}: {err:.2e}  {n_far:3d}  {above:.4f}")


@pytest.mark.slow  # compiles the kernel cold in a fresh HOME (about 30 s); .ci/run runs it
def test_kernel_runs_from_a_read_only_copy_and_caches_in_the_user_cache(tmp_path):
    """A read-only install, no NUMBA_CACHE_DIR: compiled code goes to ~/.cache/slopewalk/numba."""
    install = tmp_path / "site"
    shutil.copytree(
        ROOT / "planner", install / "slopewalk" / "planner", ignore=shutil.ignore_patterns("__py*")
    )
    shutil.copy(ROOT / "slopewalk" / "__init__.py", install / "slopewalk" / "__init__.py")
    for path in [install, *install.rglob("*")]:
        path.chmod(0o555 if path.is_dir() else 0o444)
    home = tmp_path / "home"
    home.mkdir()
    env = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "XDG_"))}
    env.update(HOME=str(home), PYTHONPATH=str(install), PYTHONDONTWRITEBYTECODE="1")
    code = (
        "import slopewalk.planner.plan as p, slopewalk.planner.spec as s, "
        "slopewalk.planner.gait as t;"
        "spec = s.load_spec(); plan = p.plan_walk(spec, t.GaitParams.nominal(spec, 1.0));"
        f"assert p.__file__.startswith({str(install)!r}); print(plan.t.size)"
    )
    try:
        result = subprocess.run(
            [sys.executable, "-c", code], env=env, capture_output=True, text=True, cwd=tmp_path
        )
    finally:
        for path in [install, *install.rglob("*")]:
            path.chmod(0o755)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "4401"
    assert list((home / ".cache" / "slopewalk" / "numba").rglob("*.nbi"))
    assert not list(install.rglob("*.nbi")) and not list(install.rglob("*.nbc"))


@pytest.mark.parametrize("preset, expected", [(None, "passive"), ("active", "active")])
def test_openmp_workers_sleep_between_kernel_calls_unless_the_user_says(preset, expected):
    """OMP_WAIT_POLICY defaults to passive (planner/kernel/__init__.py), before the pool starts."""
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    if preset:
        env["OMP_WAIT_POLICY"] = preset
    code = "import os, slopewalk.planner.kernel; print(os.environ['OMP_WAIT_POLICY'])"
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == expected
