"""The spec's joint damping (``[servo] damping``): read and checked, played by MuJoCo's
joints, and the loop the predictor integrates taking the same value (MuJoCo's compiled
model is the reference)."""

import tomllib
from dataclasses import replace

import mujoco
import pytest

from slopewalk.bench.sim.model import scene_xml, servo_settings
from slopewalk.bench.sim.prediction import _loop_of
from slopewalk.planner.errors import SpecError
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.spec import default_spec_path, load_spec, spec_from_dict

BACK_EMF = 1.5 / 6.18  # [N m s/rad]: the AX-12A's stall torque over its no-load speed


def _joint_damping(spec, actuators="servo"):
    model = mujoco.MjModel.from_xml_string(scene_xml(spec, actuators=actuators))
    hinges = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    return [float(model.dof_damping[model.jnt_dofadr[j]]) for j in hinges]


def test_without_the_key_the_joint_is_damped_by_the_back_emf(spec):
    assert spec.damping is None
    assert spec.joint_damping == pytest.approx(BACK_EMF, rel=1e-12)
    assert _joint_damping(spec) == pytest.approx([BACK_EMF] * 8, rel=1e-5)
    assert "damping" not in spec.as_dict()  # the ids of every spec without it are unchanged


@pytest.mark.parametrize("damping", [0.12, 0.56, 0.0])
def test_mujocos_joints_and_the_predictors_loop_take_the_specs_damping(spec, damping):
    moved = replace(spec, damping=damping)
    assert moved.as_dict()["damping"] == damping
    assert _joint_damping(moved) == pytest.approx([damping] * 8, abs=1e-9)
    assert _joint_damping(moved, "servo_ff") == pytest.approx([damping] * 8, abs=1e-9)
    assert servo_settings(moved, "servo").damping == damping
    plan = plan_walk(moved, GaitParams(step_time=1.0, slope=0.0))
    assert _loop_of(plan, servo_settings(moved, "servo"))["damping"] == damping
    # the stiff modes are the bench's own loop, not the servo's: no joint damping
    assert _joint_damping(moved, "stiff") == [0.0] * 8


def _with_servo(line: str):
    data = tomllib.loads(default_spec_path().read_text())
    key, value = line.split(" = ")
    data["servo"][key] = tomllib.loads(f"v = {value}")["v"]
    return spec_from_dict(data)


def test_the_key_is_read_and_optional():
    assert _with_servo("damping = 0.4").joint_damping == 0.4
    assert _with_servo("damping = 0").joint_damping == 0.0  # an undamped joint is a joint
    assert load_spec().damping is None


@pytest.mark.parametrize(
    "line, fragment",
    [
        ("damping = -0.1", "servo.damping -0.1 N m s/rad: must lie in [0, 10000] N m s/rad"),
        ("damping = nan", "servo.damping nan N m s/rad"),
        ("damping = inf", "servo.damping inf N m s/rad"),
        ("damping = 1e9", "servo.damping 1000000000.0 N m s/rad"),
        ('damping = "high"', "servo.damping 'high'"),
        ("damping = true", "servo.damping True"),
        ("dampng = 0.3", "unknown key servo.dampng (did you mean servo.damping?"),
    ],
)
def test_a_bad_damping_is_refused_in_one_line(line, fragment):
    with pytest.raises(SpecError) as err:
        _with_servo(line)
    assert fragment in str(err.value)
    assert "\n" not in str(err.value)
