"""The whole-body model (bench/experiments/whole_body.py) against independent references:
the servo loop's own linearisation (its mass matrix from the compiled Newton-Euler's finite
differences), hand-derived statics, and MuJoCo's nominal 2 s ``servo`` walk as measured."""

from __future__ import annotations

import numpy as np
import pytest

from slopewalk.bench.experiments import whole_body as wb
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.servo_loop import _plan_linearisation


@pytest.fixture(scope="module")
def slow_walk(spec):
    return plan_walk(spec, GaitParams.nominal(spec, 2.0, slope=0.0))


def test_its_joint_block_is_the_servo_loops_mass_matrix_in_single_support(spec):
    """From the links' Jacobians here, from ∂τ/∂q̈ of the Newton-Euler pass there; in double
    support the loop's holds the plan's split and differs by design."""
    plan = plan_walk(spec, GaitParams.nominal(spec, 1.0, slope=np.deg2rad(10.0)))
    mass = wb.model_of(plan).mass
    mine = mass[:, wb.BASE :, wb.BASE :]
    loop = _plan_linearisation(plan)[1]
    single = ~plan.double_support
    scale = np.abs(loop[single]).max()
    np.testing.assert_allclose(mine[single], loop[single], rtol=0, atol=1e-9 * scale)
    # the base rows: the robot's mass on z, and M symmetric positive definite
    np.testing.assert_allclose(mass[:, 0, 0], spec.total_mass, rtol=1e-12)
    assert np.all(np.linalg.eigvalsh(mass[::200]) > 0)


@pytest.mark.parametrize("height, sign", [(0.2, -1.0), (-0.2, 1.0)])
def test_a_point_mass_turning_has_the_pendulums_stiffness(height, sign):
    """Hand-derived: m at r = (0, 0, h) under g = (0, 0, −g): roll and pitch stiffness
    −m g h (upright: it falls; hanging: it returns), none about the vertical."""
    mass, g = np.array([2.0]), 9.81
    arm = np.array([[[0.0], [0.0], [height]]])
    gravity = np.array([[[0.0], [0.0], [-g]]])
    k = wb.rotation_stiffness(mass, arm, gravity)[..., 0]
    np.testing.assert_allclose(np.diag(k), [sign * 2.0 * g * 0.2] * 2 + [0.0], atol=1e-12)
    np.testing.assert_allclose(k - np.diag(np.diag(k)), 0.0, atol=1e-12)


def test_a_point_mass_beside_the_pivot_couples_roll_and_pitch_only_through_gravity():
    """Hand-derived: r = (a, 0, 0) under g = (0, 0, −g): V = −m g·c has V_φφ =
    m ((g·r) I − sym(g rᵀ)) = m diag(0, 0, 0) + m (g a/2)(e_x e_zᵀ + e_z e_xᵀ)."""
    a, g = 0.1, 9.81
    k = wb.rotation_stiffness(
        np.array([1.0]), np.array([[[a], [0.0], [0.0]]]), np.array([[[0.0], [0.0], [-g]]])
    )[..., 0]
    want = np.zeros((3, 3))
    want[0, 2] = want[2, 0] = 0.5 * g * a
    np.testing.assert_allclose(k, want, atol=1e-12)


def test_the_planned_loads_carry_the_planned_force_at_the_planned_zmp(spec):
    """The corners' ideal loads add up to the planned normal force, and their moment puts it
    at the planned ZMP; clamped to the soles they are never negative."""
    plan = plan_walk(spec, GaitParams.nominal(spec, 0.6, slope=np.deg2rad(15.0)))
    model = wb.model_of(plan)
    normal = plan.ground_force[:, 2]
    np.testing.assert_allclose(model.ideal.sum(axis=0), normal, rtol=0, atol=1e-9)
    # each corner's position on the plane, from its height Jacobian's turn columns:
    # ∂z/∂roll = y − y0, ∂z/∂pitch = −(x − x0) about the stance sole point
    y = model.corner[:, 1] + plan.stance_sole[:, 1]
    x = -model.corner[:, 2] + plan.stance_sole[:, 0]
    second = np.where(plan.double_support, plan.swing_force[:, 2], 0.0)
    loaded = normal - second > 0.1  # the stance sole's CoP makes up the rest of the moment
    zmp = np.stack([(model.ideal * x).sum(0), (model.ideal * y).sum(0)]) / np.where(
        loaded, normal, 1
    )
    # to 0.1 mm: the second sole's planned centre is its sole point's, its corners the FK's
    np.testing.assert_allclose(zmp[:, loaded].T, plan.zmp[loaded], rtol=0, atol=1e-4)
    assert (model.nominal >= 0).all()


def test_the_nominal_slow_servo_walk_rolls_and_splits_its_load_as_mujoco(spec, slow_walk):
    """Measured in MuJoCo (default robot, ``servo``, 2 s steps on flat ground; results/README.md,
    stops 33-34): the robot rolls about 2° in the first single support and recovers, and at
    the end of a double support after a landing the stance foot carries 4.23 N and the
    lifting one 2.35 N (the servo loop's bolted chain: 0.0 and 6.6 N). The predictor's
    rocking tips in the first single support (1.25 s); MuJoCo's robot tips at 3.53 s."""
    walked = wb.trial_walk(slow_walk, friction=1.0, actuators="servo")
    t = slow_walk.t
    first_single = (t > 0.8) & (t < 2.0)
    roll = np.rad2deg(np.abs(walked.x[first_single, 1]).max())
    assert 1.0 < roll < 3.0
    second_double = np.flatnonzero((t > 2.0) & (t < 3.0) & slow_walk.double_support)
    end = second_double[-1] - 20  # 20 ms before the lift-off
    assert walked.stance_load[end] == pytest.approx(4.23, abs=0.3)
    assert walked.second_load[end] == pytest.approx(2.35, abs=0.3)
    tip = wb.tip_time(slow_walk, walked)
    assert tip is None or tip > 2.0  # not in the first single support, as in MuJoCo


def test_a_tip_is_a_loaded_sole_past_the_tip_angle(slow_walk):
    """As the simulator's: a sole turned past TIP_ANGLE counts only while it carries
    LOADED_FRACTION of the weight."""
    n = slow_walk.t.size
    tilt, load = np.zeros(n), np.full(n, 6.0)
    tilt[1000:] = np.deg2rad(6.0)
    unloaded = np.zeros(n)
    walked = wb.Walk(np.zeros((n, wb.DOF)), np.zeros((n, 8)), tilt, tilt, unloaded, load, 6.5)
    assert wb.tip_time(slow_walk, walked) == pytest.approx(slow_walk.t[1000])
    light = wb.Walk(
        np.zeros((n, wb.DOF)), np.zeros((n, 8)), tilt, tilt, unloaded, 0.5 * load / 6, 6.5
    )
    assert wb.tip_time(slow_walk, light) is None


def test_a_file_that_is_not_a_sweep_table_is_one_error_line(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("a,b\n1,2\n")
    assert wb.main(["bench/experiments/sweeps/paper.toml", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "not a sweep table" in err


@pytest.mark.parametrize(
    "workers, says",
    [
        ("0", "0: must be an integer in [1, 1024]"),
        ("x", "'x' is not an integer"),
        ("2000", "2000: must be an integer in [1, 1024]"),
    ],
)
def test_a_bad_worker_count_is_one_error_line(workers, says, capsys):
    """The batch commands' own --workers check (``flags.WORKERS``)."""
    with pytest.raises(SystemExit) as stop:
        wb.main(["bench/experiments/sweeps/paper.toml", "t.csv", "--workers", workers])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert says in err and err.count("\n") == 1
