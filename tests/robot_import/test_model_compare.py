"""``slopewalk robot compare``: its variants of the model scene and its measures.

Independent references: the map's held angles (a welded joint stays there; one held by
its actuator gives under the load by torque / kp), MuJoCo's own option defaults, the
gait's hip height (the planned pelvis origin's height above the plane), and offsets
planted on the plan's own pelvis and footprints (the measures return them).
"""

from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np
import pytest
from model_reference import held_at_first_pose

from slopewalk.bench.cli import main
from slopewalk.bench.experiments.model_compare import (
    VARIANTS,
    _footprints,
    pelvis_rms,
    planned_pelvis,
)
from slopewalk.bench.robot_import.scene import model_scene
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.kinematics import rotation_slope_to_world
from slopewalk.planner.plan import plan_walk

ROBOTS = Path(__file__).resolve().parents[1] / "robots"


@pytest.fixture(scope="module")
def walker():
    scene = model_scene(ROBOTS / "walker.xml", ROBOTS / "walker-map.toml")
    gait = replace(GaitParams.nominal(scene.spec, 1.0, slope=np.deg2rad(6.0)), steps=2)
    return scene, plan_walk(scene.spec, gait)


def _held_give(scene, plan) -> float:
    """Largest held joint's distance to its map angle [rad] after 0.3 s at the first pose."""
    model, data = held_at_first_pose(scene, plan, actuators="servo", steps=300)
    return max(
        abs(data.qpos[model.joint(name).qposadr[0]] - angle)
        for name, angle in scene.fit.held.items()
    )


def test_welded_held_joints_stay_at_their_angles_where_actuated_ones_give(walker):
    scene, plan = walker
    actuated = _held_give(scene, plan)  # hip roll and yaw under the legs' load, kp 30
    welded = _held_give(replace(scene, welded=True), plan)
    assert actuated > 1e-3, actuated
    assert welded < 1e-4, welded


def test_twin_contact_sets_the_twins_cone_and_impratio_the_model_keeps_its_own(walker):
    scene, plan = walker
    own = scene.build(plan, friction=1.0, actuators="servo", timestep=1e-3)
    twin = replace(scene, twin_contact=True).build(
        plan, friction=1.0, actuators="servo", timestep=1e-3
    )
    default = mujoco.MjModel.from_xml_string("<mujoco/>").opt  # walker.xml sets neither
    assert (own.opt.cone, own.opt.impratio) == (default.cone, default.impratio)
    assert (twin.opt.cone, twin.opt.impratio) == (mujoco.mjtCone.mjCONE_ELLIPTIC, 10.0)


def test_pelvis_and_footprint_measures_return_a_planted_offset(walker):
    _, plan = walker
    pelvis = planned_pelvis(plan)
    np.testing.assert_allclose(pelvis[:, 2], plan.params.hip_height, atol=1e-9)  # Hz
    offset = np.array([0.003, -0.004, 0.002])  # [m] in S
    R = rotation_slope_to_world(plan.params.slope)
    sole = np.empty((plan.t.size, 2, 3))
    rows = np.arange(plan.t.size)
    sole[rows, plan.stance] = plan.stance_sole + offset
    sole[rows, 1 - plan.stance] = plan.swing_sole
    series = {
        "t": plan.t,
        "qpos": np.column_stack([(pelvis + offset) @ R.T, np.zeros((plan.t.size, 4))]),
        "sole": sole,
    }
    standing = np.ones(plan.t.size, bool)
    np.testing.assert_allclose(pelvis_rms(plan, series, standing), np.abs(offset), atol=1e-9)
    prints = _footprints(plan, series, standing)
    assert prints["footprints"] == plan.params.steps
    assert prints["footprint_max"] == pytest.approx(np.hypot(*offset[:2]), abs=1e-9)


@pytest.mark.slow
def test_robot_compare_reports_every_variant(tmp_path, capsys):
    out = tmp_path / "c.md"
    argv = ["robot", "compare", str(ROBOTS / "walker_motors.urdf"),
            "--map", str(ROBOTS / "walker_motors-map.toml"), "--step-time", "3", "--steps", "2",
            "--tilt", "9", "--hip-height", "0.37", "--out", str(out)]  # fmt: skip
    assert main(argv) == 0
    table = [line for line in out.read_text().splitlines() if line.startswith("| ")][1:]
    cells = [[c.strip() for c in line.strip("|").split("|")] for line in table]
    assert [row[0] for row in cells] == [v for v, *_ in VARIANTS]
    assert cells[0][1] == "stable"  # the twin walks the step it was planned for


def test_robot_compare_refuses_a_mode_the_model_cannot_play(capsys):
    argv = ["robot", "compare", str(ROBOTS / "walker.xml"), "--step-time", "1",
            "--actuators", "stiff"]  # fmt: skip
    assert main(argv) == 2
    assert "use servo or servo_ff" in capsys.readouterr().err
