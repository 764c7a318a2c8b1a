"""A plan played on the unmodified test models (``robot_import.scene``), against MuJoCo.

Independent references: the model's total mass from MuJoCo (the feet carry the whole
weight when the robot stands at the plan's first pose), and the plan's own joint angles
(the decoded angles, in the planner's signs, track them on the model's own actuators or
on the servos added to a motors-only URDF).
"""

from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np
import pytest
from model_reference import held_at_first_pose

from slopewalk.bench.robot_import.scene import model_scene
from slopewalk.bench.sim.playback import play
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import plan_walk

ROBOTS = Path(__file__).resolve().parents[1] / "robots"
# walker_motors.urdf has motors only: the scene adds servos from the map's [servo] table.
# Without the servo's rotor (armature, back-EMF damping) its kv is explicit under the
# URDF's Euler integrator and chatters on the 0.04 kg ankle cross: the feet's load swings
# between 25 and 190 N at the step rate, and this test fails.
MODELS = {
    "walker": (ROBOTS / "walker.xml", ROBOTS / "walker-map.toml"),
    "walker_motors": (ROBOTS / "walker_motors.urdf", ROBOTS / "walker_motors-map.toml"),
}


@pytest.mark.parametrize("name", sorted(MODELS))
def test_first_pose_stands_on_the_plane_and_joints_track_the_plan(name):
    scene = model_scene(*MODELS[name])
    spec, fit = scene.spec, scene.fit
    gait = replace(GaitParams.nominal(spec, 1.0, slope=np.deg2rad(5.0)), steps=1, tilt=0.0)
    plan = plan_walk(spec, gait)
    recording = play(plan, actuators="servo_ff", settle=0.3, hold=0.0, scene=scene)
    s, t = recording.sensors, recording.t
    weight = mujoco.mj_getTotalmass(fit.model) * 9.81
    standing = (t > -0.1) & (t < 0.0)  # the end of the settle, the first pose held
    load = s.foot_force[standing, :, 2].sum(axis=1)
    np.testing.assert_allclose(load, weight, rtol=0.05)
    np.testing.assert_allclose(s.sole[standing, :, 2], 0.0, atol=2e-3)  # soles on the plane
    # a joint with its sign wrong would sit 2|q| off (the knees are bent ~45 deg); what is
    # left is the loop's error under the model's kp and the floor's give (not fed forward)
    error = np.abs(s.q[standing] - plan.q_left_right[0]).max()
    assert error < np.deg2rad(3.0), f"{np.rad2deg(error):.2f} deg"


def test_the_floor_feedforward_knows_every_corner_of_a_two_box_sole():
    """``ModelScene.floor``'s sole corners are where MuJoCo puts the feet's contacts."""
    scene = model_scene(*MODELS["walker"])
    spec, fit = scene.spec, scene.fit
    plan = plan_walk(spec, replace(GaitParams.nominal(spec, 1.0), steps=1))
    model, data = held_at_first_pose(scene, plan, actuators="servo_ff", steps=100)
    corners = np.array(scene.floor(model).corners)  # (2, 8, 2): two boxes of 4 corners
    assert corners.shape == (2, 8, 2)
    for foot, side in enumerate(("l", "r")):
        site = model.site(f"{side}_sole")
        R, p = data.site_xmat[site.id].reshape(3, 3), data.site_xpos[site.id]
        centre = np.array([(spec.ankle_to_toe - spec.heel_offset) / 2, spec.sole_shift(foot)])
        body = model.body(fit.model.body(fit.feet[("left", "right")[foot]]).name).id
        touching = [
            (data.contact[k].pos - p) @ R
            for k in range(data.ncon)
            if body in model.geom_bodyid[[data.contact[k].geom1, data.contact[k].geom2]]
        ]
        assert len(touching) >= 3
        for point in touching:  # each contact sits on a predicted corner (the sole sinks < 2 mm)
            gap = np.linalg.norm(corners[foot] - (point[:2] - centre), axis=1).min()
            assert gap < 2e-3, f"{side}: contact {point[:2]} is {gap * 1e3:.1f} mm off every corner"


def test_the_specs_contact_is_the_floors_under_an_imported_model():
    """A spec's ``[contact]`` (here set on the spec the map gives) is the solref of MuJoCo's
    foot contacts on the model's own scene, and the floor feed-forward reads it back."""
    scene = model_scene(*MODELS["walker"])
    model, _ = held_at_first_pose(scene, _plan(scene), actuators="servo_ff", steps=10)
    default = scene.floor(model)
    assert (default.timeconst, default.dampratio) == (0.02, 1.0)
    scene = replace(scene, spec=replace(scene.spec, contact_timeconst=0.04, contact_dampratio=0.5))
    model, data = held_at_first_pose(scene, _plan(scene), actuators="servo_ff", steps=100)
    assert data.ncon >= 6
    for k in range(data.ncon):
        assert tuple(data.contact[k].solref) == (0.04, 0.5)
    floor = scene.floor(model)
    assert (floor.timeconst, floor.dampratio) == (0.04, 0.5)


def _plan(scene):
    return plan_walk(scene.spec, replace(GaitParams.nominal(scene.spec, 1.0), steps=1))


def test_an_imported_models_own_sole_contact_is_the_trials(tmp_path):
    """A model whose soles set their own ``solref``: the import writes it as the spec's
    [contact] (one without keeps none), and the trial's floor, whose priority would put
    MuJoCo's default in its place, takes it: MuJoCo's foot contacts carry the model's."""
    from slopewalk.bench.robot_import.write import import_robot
    from slopewalk.planner.spec import load_spec

    walker, walker_map = MODELS["walker"]
    text, notes = import_robot(walker, walker_map)
    assert "[contact]" not in text and not any(n.startswith("contact") for n in notes)
    own = tmp_path / "walker.xml"
    sole = '<geom type="box" contype="1" conaffinity="1"'
    assert sole in walker.read_text()
    own.write_text(walker.read_text().replace(sole, sole + ' solref="0.03 0.8"'))
    text, notes = import_robot(own, walker_map)
    assert "contact: the soles' own solref, 0.03 s and 0.8" in notes
    spec_path = tmp_path / "walker.toml"
    spec_path.write_text(text)
    spec = load_spec(spec_path)
    assert (spec.contact_timeconst, spec.contact_dampratio) == (0.03, 0.8)
    scene = model_scene(own, walker_map)  # the spec the import writes
    assert scene.spec == spec
    model, data = held_at_first_pose(scene, _plan(scene), actuators="servo_ff", steps=100)
    assert data.ncon >= 6
    for k in range(data.ncon):
        assert tuple(data.contact[k].solref) == (0.03, 0.8)


def test_the_specs_damping_is_what_the_added_servos_give_a_motors_only_model():
    """A motors-only URDF's joints get the servo the scene adds: its rotor and its damping,
    the spec's ``[servo] damping`` where given (here set on the spec the map gives), else the
    back-EMF's, on top of the URDF's own ``<dynamics>``."""
    scene = model_scene(*MODELS["walker_motors"])
    base, _ = held_at_first_pose(scene, _plan(scene), actuators="servo", steps=1)
    moved = replace(scene, spec=replace(scene.spec, damping=0.5))
    model, _ = held_at_first_pose(moved, _plan(moved), actuators="servo", steps=1)
    for name, _ in scene.joints():
        dof = model.jnt_dofadr[model.joint(name).id]
        added = model.dof_damping[dof] - base.dof_damping[dof]
        assert added == pytest.approx(0.5 - scene.spec.joint_damping, abs=1e-9)
