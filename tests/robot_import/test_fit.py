"""``slopewalk robot import``: what it finds on the test models and what it refuses.

Models that must be refused are the hand-written walker with one thing changed, so
each refusal has exactly one cause; each is refused in one line that names the joint
and the measured misfit.
"""

from pathlib import Path

import pytest

from slopewalk.bench.cli import main
from slopewalk.bench.robot_import.fit import fit_model
from slopewalk.bench.robot_import.mapfile import RobotImportError, RobotMap, load_map
from slopewalk.planner.spec import load_spec

ROBOTS = Path(__file__).resolve().parents[1] / "robots"
WALKER = (ROBOTS / "walker.xml").read_text()
NO_ROLL = ['<joint name="l_ank_r" axis="-1 0 0"/>', '<position name="l_ank_r" joint="l_ank_r"/>']


def test_detection_finds_the_legs_their_signs_and_the_geometry():
    """walker.xml: its own names, pitch axes along −y on the left, hip yaw/roll above."""
    fit = fit_model(ROBOTS / "walker.xml")
    left = {k: (j.name, j.sign) for k, j in fit.legs["left"].items()}
    assert left == {"hip_pitch": ("l_leg_pitch", -1.0), "knee": ("l_knee_joint", 1.0),
                    "ankle_pitch": ("l_ank_p", -1.0), "ankle_roll": ("l_ank_r", -1.0)}  # fmt: skip
    assert fit.legs["right"]["ankle_roll"].sign == 1.0
    assert set(fit.held) == {"neck_yaw", "l_shoulder", "l_elbow", "r_shoulder", "r_elbow",
                             "l_hip_yaw", "l_hip_roll", "r_hip_yaw", "r_hip_roll"}  # fmt: skip
    g = fit.geometry  # the file's numbers: hips 0.12 apart, thigh 0.2, shank 0.19, ...
    expected = {"thigh": 0.2, "shank": 0.19, "hip_width": 0.12, "ankle_height": 0.04,
                "ankle_to_toe": 0.08, "foot_length": 0.14, "foot_width": 0.07,
                "sole_offset": 0.012, "knee_offset": 0.0}  # fmt: skip
    assert g == pytest.approx(expected, abs=1e-12)


def _refused(tmp_path, old, new, robot_map=None) -> str:
    """The refusal of walker.xml with ``old`` replaced by ``new`` (lists: in turn)."""
    text = WALKER
    for a, b in zip(*((old, new) if isinstance(old, list) else ([old], [new])), strict=True):
        assert a in text
        text = text.replace(a, b)
    path = tmp_path / "bad.xml"
    path.write_text(text)
    with pytest.raises(RobotImportError) as err:
        fit_model(path, robot_map)
    message = str(err.value)
    assert "\n" not in message
    return message


def test_refuses_a_leg_without_ankle_roll(tmp_path):
    message = _refused(tmp_path, NO_ROLL, ["", ""])
    assert message.startswith("left leg: no ankle roll joint below its last pitch joint")


def test_refuses_roll_before_pitch(tmp_path):
    pitch, roll = '<joint name="l_ank_p" axis="0 -1 0"/>', '<joint name="l_ank_r" axis="-1 0 0"/>'
    message = _refused(tmp_path, [pitch, roll, "@"], ["@", pitch, roll])  # swap the two
    assert "left ankle roll 'l_ank_r' comes before the ankle pitch" in message


def test_refuses_a_tilted_hip_pitch_axis(tmp_path):
    """20° of tilt (the issue measured 15-35° on public models) is named with its size."""
    message = _refused(
        tmp_path, '<joint name="l_leg_pitch" axis="0 -1 0"/>',
        '<joint name="l_leg_pitch" axis="0 -0.9396926207859084 0.3420201433256687"/>',
    )  # fmt: skip
    assert message.startswith("left hip pitch 'l_leg_pitch' axis angle off the y axis: 20 deg")


# walker.xml with both knees 14 mm behind the hip–ankle line, the ankles kept under the hips
KNEES_BEHIND = (
    [f'<body name="{s}_shin" pos="0 0 -0.2">' for s in "lr"]
    + [f'<body name="{s}_ankle_link" pos="0 0 -0.19">' for s in "lr"],
    [f'<body name="{s}_shin" pos="-0.014 0 -0.2">' for s in "lr"]
    + [f'<body name="{s}_ankle_link" pos="0.014 0 -0.19">' for s in "lr"],
)


def test_measures_knees_behind_the_hip_axis(tmp_path):
    """Both knees 14 mm behind the hip–ankle line: carried as geometry.knee_offset, the thigh
    and shank along the line, and the report says so."""
    text = WALKER
    for a, b in zip(*KNEES_BEHIND, strict=True):
        text = text.replace(a, b)
    path = tmp_path / "knees.xml"
    path.write_text(text)
    fit = fit_model(path)
    assert fit.geometry["knee_offset"] == pytest.approx(-0.014, abs=1e-12)
    assert (fit.geometry["thigh"], fit.geometry["shank"]) == pytest.approx((0.2, 0.19), abs=1e-12)
    out = tmp_path / "knees.toml"
    assert main(["robot", "import", str(path), "--out", str(out)]) == 0
    assert load_spec(out).knee_offset == pytest.approx(-0.014, abs=1e-12)
    assert "knee: the axis 14.0 mm behind the hip-ankle line" in out.read_text()


def test_refuses_one_knee_behind_the_hip_axis(tmp_path):
    """One knee off the line, the other on it: legs that are not mirror images."""
    message = _refused(tmp_path, KNEES_BEHIND[0][1::2], KNEES_BEHIND[1][1::2])  # the right
    assert message.startswith("knee_offset left vs right: 14 mm (tolerance 0.001 mm)")


def test_refuses_an_ankle_ahead_of_the_hip_axis(tmp_path):
    message = _refused(tmp_path, '<body name="r_shin" pos="0 0 -0.2">',
                       '<body name="r_shin" pos="-0.014 0 -0.2">')  # fmt: skip
    assert message.startswith("right ankle pitch 'r_ank_p' axis ahead of the hip pitch axis")
    assert ": 14 mm (tolerance 0.001 mm)" in message


def test_refuses_a_held_yaw_inside_the_leg_that_turns_the_knee():
    robot_map = load_map(ROBOTS / "walker_motors-map.toml")
    held = {**robot_map.held, "L_HipYaw": 0.25}
    turned = RobotMap(joints=robot_map.joints, held=held, servo=robot_map.servo)
    with pytest.raises(
        RobotImportError, match=r"left knee 'L_Knee' axis angle off the y axis: 14.32 deg"
    ):
        fit_model(ROBOTS / "walker_motors.urdf", turned)


def test_cli_writes_a_spec_the_planner_reads(tmp_path, capsys):
    out = tmp_path / "walker.toml"
    assert main(["robot", "import", str(ROBOTS / "walker.xml"), "--out", str(out)]) == 0
    spec = load_spec(out)
    assert spec.name == "walker" and spec.stiffness == 30.0
    report = capsys.readouterr().out
    assert "joint_limits.knee: the model has no range; the default robot's" in report
    assert "centred +12.0 mm outward of the ankle (geometry.sole_offset)" in report
    assert spec.foot_width == pytest.approx(0.07) and spec.sole_offset == pytest.approx(0.012)
    bad = tmp_path / "bad.xml"
    bad.write_text(WALKER.replace(NO_ROLL[0], "").replace(NO_ROLL[1], ""))
    assert main(["robot", "import", str(bad)]) == 2
    assert capsys.readouterr().err.startswith("slopewalk: error: left leg: no ankle roll joint")
