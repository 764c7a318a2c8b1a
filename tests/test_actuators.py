"""The actuator modes: one registry (bench/actuators.py) that every other module reads."""

import subprocess
import sys
from pathlib import Path

import pytest

from slopewalk.bench.actuators import ACTUATOR_MODES, MODES, ActuatorMode, modes_where
from slopewalk.bench.sim.model import SceneError, Servo, mode, servo_settings

ROOT = Path(__file__).resolve().parents[1]


def test_servo_settings_follow_the_modes_attributes(spec):
    for m in MODES.values():
        servo = servo_settings(spec, m.name)
        assert servo.feedforward == m.feedforward and servo.armature == spec.armature
        if m.gains == "stiff":
            assert (servo.kp, servo.kv, servo.force_limit) == (200.0, 2.0, 50.0)
        else:
            assert (servo.kp, servo.kv, servo.force_limit, servo.frictionloss) == (
                spec.stiffness,
                spec.velocity_gain,
                spec.stall_torque,
                spec.friction_loss,
            )
    assert ACTUATOR_MODES == ("stiff", "servo", "stiff_ff", "servo_ff")
    assert modes_where(gains="stiff") == ("stiff", "stiff_ff")
    assert modes_where(gains="spec", feedforward=True) == ("servo_ff",)


@pytest.mark.parametrize("name", ["servo_FF", "", None, ["stiff"]])
def test_an_unknown_mode_is_one_scene_error_line(name):
    with pytest.raises(SceneError) as err:
        mode(name)
    assert str(err.value) == f"actuators {name!r}: must be one of stiff, servo, stiff_ff, servo_ff"


def test_a_mode_names_a_known_gain_source():
    with pytest.raises(ValueError, match="gains 'soft'"):
        ActuatorMode("soft", "soft", False, "no such loop")


# A fifth mode added the way a maintainer would: one line in bench/actuators.py's MODES,
# nothing else edited. The patched module is installed before anything imports it.
FIFTH = '        ActuatorMode("servo_stiff", "stiff", True, "a fifth mode, one line"),\n'
SCRIPT = """
import sys, types
from pathlib import Path
import slopewalk.bench
name = "slopewalk.bench.actuators"
module = types.ModuleType(name)
module.__file__ = str(Path(slopewalk.bench.__file__).with_name("actuators.py"))
sys.modules[name] = slopewalk.bench.actuators = module
exec(compile(sys.argv[1], module.__file__, "exec"), module.__dict__)

import argparse
from slopewalk.bench import flags
from slopewalk.bench.experiments.envelope.config import envelope_from_dict
from slopewalk.bench.experiments.sweep.config import sweep_from_dict
from slopewalk.bench.report.fidelity import modes_where
from slopewalk.bench.sim.model import ACTUATOR_MODES, scene_xml, servo_settings
from slopewalk.bench.tables.envelope import COLUMNS
from slopewalk.planner.spec import load_spec

spec, here = load_spec(), Path(".")
assert ACTUATOR_MODES[-1] == "servo_stiff", ACTUATOR_MODES
print("servo_settings", servo_settings(spec, "servo_stiff") == servo_settings(spec, "stiff_ff"))
print("scene", "<general" in scene_xml(spec, actuators="servo_stiff"))
p = argparse.ArgumentParser()
flags.add_sim_flags(p)
print("flag", p.parse_args(["--actuators", "servo_stiff"]).actuators == "servo_stiff")
sweep = sweep_from_dict({"grid": {"actuators": ["servo_stiff"]}}, base_dir=here)
print("sweep", [t.label for t in sweep.trials] == ["T=1 s slope=0 mu=1 servo_stiff"])
envelope = envelope_from_dict({"grid": {"step_time": [1.0], "slope": [0]}}, base_dir=here)
print("envelope", envelope.modes[-1] == "servo_stiff")
print("columns", "maxmargin_servo_stiff_verdict" in COLUMNS)
print("reports", modes_where(gains="stiff") == ("stiff", "stiff_ff", "servo_stiff"))
"""


def test_a_fifth_mode_is_one_line_in_the_registry(tmp_path):
    source = (ROOT / "bench" / "actuators.py").read_text()
    last = (
        '        ActuatorMode("servo_ff", "spec", True, "servo, the plan\'s torque fed forward"),\n'
    )
    assert last in source
    out = subprocess.run(
        [sys.executable, "-c", SCRIPT, source.replace(last, last + FIFTH)],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        check=True,
    ).stdout
    checks = dict(line.split() for line in out.splitlines())
    assert checks == dict.fromkeys(
        ("servo_settings", "scene", "flag", "sweep", "envelope", "columns", "reports"), "True"
    )


def test_the_servo_record_is_what_servo_settings_builds(spec):
    assert servo_settings(spec, "stiff") == Servo(200.0, 2.0, 50.0, armature=spec.armature)
