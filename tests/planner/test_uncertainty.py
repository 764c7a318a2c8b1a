"""The spec's ranges of its estimated values: read, checked, and the spec at either end."""

import math
import tomllib

import pytest

from slopewalk.planner.errors import SpecError
from slopewalk.planner.spec import default_spec_path, load_spec, spec_from_dict
from slopewalk.planner.uncertainty import (
    known_keys,
    load_uncertainty,
    spec_at,
    uncertain_values,
    value_of,
)


def _data():
    return tomllib.loads(default_spec_path().read_text())


def test_the_default_spec_states_a_range_for_its_estimates():
    values = load_uncertainty()
    keys = [u.key for u in values]
    # the estimates the spec's comments name: foot width, masses, joint limits, servo
    for key in ("geometry.foot_width", "links.pelvis.mass", "joint_limits.ankle_pitch.upper",
                "servo.stall_torque", "servo.stiffness", "servo.damping", "contact.timeconst",
                "contact.dampratio"):  # fmt: skip
        assert key in keys
    # the paper's lengths are given, not estimated
    assert "geometry.thigh" not in keys and "geometry.foot_length" not in keys
    spec = load_spec()
    for u in values:
        assert u.low < u.high
        assert u.low <= u.nominal <= u.high
    width = next(u for u in values if u.key == "geometry.foot_width")
    assert (width.low, width.nominal, width.high, width.unit) == (
        0.050,
        spec.foot_width,
        0.070,
        "m",
    )


def test_a_spec_with_the_table_is_the_same_robot_as_without():
    data = _data()
    with_table = spec_from_dict(data)
    del data["uncertain"]
    assert spec_from_dict(data) == with_table
    assert with_table.as_dict() == spec_from_dict(data).as_dict()  # ids unchanged


def test_spec_at_changes_one_value_only():
    spec = load_spec()
    wide = spec_at(spec, "geometry.foot_width", 0.07)
    assert wide.foot_width == 0.07
    assert wide.as_dict() | {"foot_width": spec.foot_width} == spec.as_dict()
    # a heavier part of the same shape: the inertia scales with the mass (I = m (b² + c²)/12)
    heavy = spec_at(spec, "links.pelvis.mass", 0.48)
    assert heavy.links["pelvis"].mass == 0.48
    for a, b in zip(heavy.links["pelvis"].inertia, spec.links["pelvis"].inertia, strict=True):
        assert math.isclose(a, 2 * b, rel_tol=1e-12)
    assert heavy.links["thigh"] == spec.links["thigh"]
    high = spec_at(spec, "links.pelvis.com.z", 0.045)
    assert high.links["pelvis"].com == (0.0, 0.0, 0.045)
    limit = spec_at(spec, "joint_limits.ankle_pitch.upper", 1.3)
    assert limit.joint_limits["ankle_pitch"] == (-1.4, 1.3)
    assert limit.joint_limits["knee"] == spec.joint_limits["knee"]
    assert spec_at(spec, "servo.stall_torque", 1.2).stall_torque == 1.2
    soft = spec_at(spec, "contact.timeconst", 0.04)
    assert (soft.contact_timeconst, soft.contact_dampratio) == (0.04, spec.contact_dampratio)
    assert soft.as_dict() == spec.as_dict() | {"contact_timeconst": 0.04}
    assert spec_at(spec, "contact.dampratio", 0.5).contact_dampratio == 0.5
    # the joint damping: the back-EMF's where the spec gives none, the key's once moved
    assert value_of(spec, "servo.damping") == (spec.stall_torque / spec.no_load_speed, "N m s/rad")
    damped = spec_at(spec, "servo.damping", 0.56)
    assert (damped.joint_damping, damped.stall_torque) == (0.56, spec.stall_torque)
    assert damped.as_dict() == spec.as_dict() | {"damping": 0.56}


def _refused(table) -> str:
    with pytest.raises(SpecError) as err:
        uncertain_values(load_spec(), table)
    text = str(err.value)
    assert "\n" not in text
    return text


@pytest.mark.parametrize(
    "table, fragment",
    [
        ({"geometry": {"foot_width": [0.07, 0.05]}}, "uncertain.geometry.foot_width [0.07, 0.05] m: low must be < high"),  # noqa: E501
        ({"geometry": {"foot_width": [0.06, 0.06]}}, "low must be < high"),
        ({"geometry": {"foot_width": [0.07, 0.08]}}, "must hold the spec's value 0.06 m (low <= value <= high)"),  # noqa: E501
        ({"geometry": {"foot_width": [0.05]}}, "uncertain.geometry.foot_width [0.05]: must be a list [low, high] of 2 numbers [m]"),  # noqa: E501
        ({"geometry": {"foot_width": ["a", 0.07]}}, "must be a list [low, high] of 2 numbers"),
        ({"geometry": {"foot_width": [True, 0.07]}}, "must be a list [low, high] of 2 numbers"),
        ({"geometry": {"foot_width": 0.06}}, "must be a list [low, high]"),
        ({"geometry": {"foot_widht": [0.05, 0.07]}}, "unknown key uncertain.geometry.foot_widht"),
        ({"links": {"pelvis": {"com": [0.0, 0.05]}}}, "unknown key uncertain.links.pelvis.com"),
        ({"geometry": {"foot_width": [-0.01, 0.07]}}, "uncertain.geometry.foot_width low end -0.01 m: geometry.foot_width"),  # noqa: E501
        ({"joint_limits": {"ankle_pitch": {"upper": [-1.5, 1.5]}}}, "uncertain.joint_limits.ankle_pitch.upper low end -1.5 rad: joint_limits.ankle_pitch"),  # noqa: E501
        ({"servo": {"stall_torque": [0.0, 1.6]}}, "low end 0 N m: servo.stall_torque"),
        ({"contact": {"timeconst": [0.0, 0.04]}}, "uncertain.contact.timeconst low end 0 s: contact.timeconst"),  # noqa: E501
        ({"contact": {"stiffness": [1, 2]}}, "unknown key uncertain.contact.stiffness"),
        ({"servo": {"damping": [0.3, 0.5]}}, "must hold the spec's value 0.242718 N m s/rad"),
        ({"servo": {"damping": [-0.1, 0.5]}}, "uncertain.servo.damping low end -0.1 N m s/rad: servo.damping"),  # noqa: E501
        ([1, 2], "uncertain = [1, 2]: must be a table [uncertain]"),
    ],
)  # fmt: skip
def test_a_bad_range_is_refused_in_one_line(table, fragment):
    assert fragment in _refused(table)


def test_dotted_and_quoted_keys_are_the_same_key():
    spec = load_spec()
    nested = uncertain_values(spec, {"geometry": {"foot_width": [0.05, 0.07]}})
    quoted = uncertain_values(spec, {"geometry.foot_width": [0.05, 0.07]})
    assert nested == quoted


def test_load_uncertainty_names_the_file(tmp_path):
    text = default_spec_path().read_text()
    path = tmp_path / "r.toml"
    path.write_text(text.replace("geometry.foot_width = [0.050, 0.070]",
                                 "geometry.foot_width = [0.065, 0.070]"))  # fmt: skip
    with pytest.raises(
        SpecError, match=r"^robot spec '.*r\.toml': uncertain\.geometry\.foot_width"
    ):
        load_uncertainty(path)
    plain = tmp_path / "plain.toml"
    plain.write_text(text[: text.index("[uncertain]")])
    assert load_uncertainty(plain) == ()


def test_every_known_key_is_a_value_of_the_spec():
    spec = load_spec()
    for key in known_keys(spec):
        value, _ = value_of(spec, key)
        assert spec_at(spec, key, value) == spec  # the spec at its own value is the spec
        assert spec_at(spec, key, value + 1e-3) != spec  # and any other is not
