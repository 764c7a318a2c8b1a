"""Robot spec loading and refusal of malformed specs with one clear line."""

import re
import tomllib

import numpy as np
import pytest

from slopewalk.planner.errors import SpecError
from slopewalk.planner.spec import default_spec_path, load_spec, spec_from_dict


def _data():
    with open(default_spec_path(), "rb") as f:
        return tomllib.load(f)


def test_default_spec_is_the_papers_biped(spec):
    assert (spec.thigh, spec.shank, spec.hip_width) == (0.111, 0.111, 0.085)
    assert (spec.ankle_height, spec.ankle_to_toe, spec.foot_length) == (0.032, 0.049, 0.100)
    assert 0.5 < spec.total_mass < 0.9  # an 8-servo Bioloid biped weighs well under 1 kg


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda d: d["geometry"].pop("thigh"), "missing key geometry.thigh"),
        (lambda d: d["geometry"].update(shank=-0.1), "geometry.shank -0.1 m: must lie in (0, 5] m"),
        (lambda d: d["links"]["foot"].update(mass=-1.0), "links.foot.mass -1.0 kg"),
        (lambda d: d["links"]["thigh"].update(inertia=[1e-5, -1e-5, 1e-5]), "positive definite"),
        (lambda d: d["links"]["thigh"].update(inertia=[1e-5, 1e-5, 1e-3]), "triangle"),
        (lambda d: d.pop("servo"), "missing table [servo]"),
        (lambda d: d["joint_limits"].update(knee=[1.0, 0.0]), "joint_limits.knee"),
        (lambda d: d["servo"].pop("stiffness"), "missing key servo.stiffness"),
        (lambda d: d["servo"].update(stiffness=0.0), "servo.stiffness 0.0 N m/rad: must lie in"),
        (lambda d: d["servo"].update(velocity_gain=-1.0), "servo.velocity_gain -1.0 N m s/rad"),
        (lambda d: d["servo"].update(armature=float("nan")), "servo.armature nan kg m^2"),
        (lambda d: d["servo"].update(friction_loss=True), "servo.friction_loss True"),
        (lambda d: d["servo"].update(stifness=9.0), "did you mean servo.stiffness?"),
        (
            lambda d: d["geometry"].update(sole_offset=0.03),
            "geometry.sole_offset 0.03 m: must lie in (-0.03, 0.03) m",
        ),
        (lambda d: d["geometry"].update(sole_offset="1"), "geometry.sole_offset '1'"),
        (
            lambda d: d["geometry"].update(knee_offset=-0.111),
            "geometry.knee_offset -0.111 m: must lie in (-0.111, 0.111) m",
        ),
        (lambda d: d["geometry"].update(knee_offset=True), "geometry.knee_offset True"),
        (lambda d: d["geometry"].update(knee_ofset=0.01), "did you mean geometry.knee_offset?"),
    ],
)
def test_malformed_spec_is_refused(edit, message):
    data = _data()
    edit(data)
    with pytest.raises(SpecError, match=re.escape(message)) as err:
        spec_from_dict(data)
    assert "\n" not in str(err.value)


def test_missing_file(tmp_path):
    with pytest.raises(SpecError, match="no such file"):
        load_spec(tmp_path / "nope.toml")


def test_mass_scale_groups(spec):
    legs = spec.with_mass_scale({"legs": 2})
    assert legs.links["pelvis"].mass == spec.links["pelvis"].mass
    assert legs.links["foot"].mass == 2 * spec.links["foot"].mass
    mixed = spec.with_mass_scale({"all": 10, "foot": 1})
    assert mixed.links["pelvis"].mass == 10 * spec.links["pelvis"].mass
    assert mixed.links["foot"].mass == spec.links["foot"].mass
    with pytest.raises(SpecError, match="mass scale group 'arms'"):
        spec.with_mass_scale({"arms": 2})


def test_servo_constants_are_the_ax12a(spec):
    """kp = stall torque over the 32-step compliance slope of 0.29 deg; no D term."""
    assert spec.stiffness == pytest.approx(spec.stall_torque / np.deg2rad(32 * 0.29), rel=1e-3)
    assert (spec.velocity_gain, spec.armature, spec.friction_loss) == (0.0, 0.0232, 0.011)
