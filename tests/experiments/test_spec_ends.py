"""Spec ends: a sweep's trials replayed with one estimated value at an end of its range."""

from pathlib import Path

import mujoco
import numpy as np
import pytest

from slopewalk.bench.experiments.sweep.config import SweepError, sweep_from_dict
from slopewalk.planner.spec import default_spec_path
from slopewalk.planner.uncertainty import load_uncertainty

RANGES = {u.key: u for u in load_uncertainty()}  # the paper's biped's [uncertain] table
DRAW = {"draw": {"family": ["paper"], "gaits": 1, "seed": 3}}
GRID = {"grid": {"step_time": [1.0], "slope": [5], "actuators": ["servo"]}}


def _parse(data: dict, base_dir: Path = Path(".")):
    return sweep_from_dict(data, base_dir=base_dir, source="s.toml")


@pytest.mark.parametrize(
    ("ends", "message"),
    [
        ("servo.armature:low", "spec_ends = 'servo.armature:low': must be a non-empty list"),
        ([], "spec_ends = []: must be a non-empty list"),
        (["nominal", "nominal"], "spec_ends = ['nominal', 'nominal']: must be a non-empty"),
        (["servo.armature:mid"], "spec_ends entry 'servo.armature:mid': must be"),
        ([":low"], "spec_ends entry ':low': must be"),
        ([1], "spec_ends entry 1: must be"),
        (
            ["servo.kp:low"],
            "spec_ends 'servo.kp:low': servo.kp is not in robot 'default''s [uncertain] table "
            "(it has: geometry.foot_width,",
        ),
    ],
)  # fmt: skip
def test_bad_spec_ends_are_refused_in_one_line(ends, message):
    with pytest.raises(SweepError) as err:
        _parse(GRID | {"spec_ends": ends})
    assert message in str(err.value)
    assert "\n" not in str(err.value)


def test_a_robot_without_an_uncertain_table_has_no_ends(tmp_path):
    text = default_spec_path().read_text().split("\n[uncertain]")[0]
    (tmp_path / "plain.toml").write_text(text)
    grid = {"grid": {"robot": ["plain.toml"]}, "spec_ends": ["servo.armature:low"]}
    with pytest.raises(SweepError, match=r"'plain.toml''s \[uncertain\] table \(it has: none\)"):
        _parse(grid, tmp_path)
    assert len(_parse(grid | {"spec_ends": ["nominal"]}, tmp_path).trials) == 1


def test_each_end_is_a_trial_on_the_spec_with_that_one_value_moved():
    ends = ["nominal", "servo.armature:low", "servo.stiffness:high", "links.thigh.mass:high"]
    config = _parse(GRID | DRAW | {"spec_ends": ends})
    nominal, armature, stiffness, thigh = config.trials
    assert [t.spec_end for t in config.trials] == ends
    assert nominal.trial_id == _parse(GRID | DRAW).trials[0].trial_id  # "nominal": the same trial
    assert len({t.trial_id for t in config.trials}) == 4
    assert armature.spec.armature == RANGES["servo.armature"].low != nominal.spec.armature
    assert stiffness.spec.stiffness == RANGES["servo.stiffness"].high != nominal.spec.stiffness
    assert thigh.spec.links["thigh"].mass == RANGES["links.thigh.mass"].high
    for trial in (armature, stiffness, thigh):  # every other value stays the nominal one
        moved = {k for k, v in trial.spec.as_dict().items() if nominal.spec.as_dict()[k] != v}
        assert len(moved) == 1
    # every replica walks the nominal trial's drawn gait, though the draw is seeded by the cell
    gaits = [t.gait_inputs() for t in config.trials]
    assert all(g == gaits[0] for g in gaits)
    assert armature.inputs()["spec_end"] == "servo.armature:low"
    assert "spec servo.armature:low" in armature.label and "spec" not in nominal.label


def test_the_end_applies_before_the_mass_scaling():
    grid = {"grid": {"mass_scale": [{"legs": 2}]}, "spec_ends": ["links.thigh.mass:low"]}
    (trial,) = _parse(grid).trials
    assert trial.spec.links["thigh"].mass == pytest.approx(2 * RANGES["links.thigh.mass"].low)
    assert trial.mass_scale_text == "legs=2"


def test_the_worker_plays_the_end_in_mujoco(monkeypatch):
    """What MuJoCo is given, not what the trial says: the scene compiled from the spec the
    sweep's worker hands ``run_trial`` has the end's rotor inertia on every leg joint."""
    import slopewalk.bench.sim.trial as trial_module
    from slopewalk.bench.experiments.sweep.run import run_one
    from slopewalk.bench.sim.model import scene_xml

    seen = []

    def capture(spec, trial, **_):
        seen.append(spec)
        raise RuntimeError("captured")

    monkeypatch.setattr(trial_module, "run_trial", capture)
    config = _parse(GRID | {"spec_ends": ["servo.armature:high", "nominal"]})
    for trial in config.trials:
        assert run_one(trial)["error"] == "RuntimeError: captured"
    armatures = []
    for spec in seen:
        model = mujoco.MjModel.from_xml_string(scene_xml(spec, actuators="servo"))
        armatures.append(model.dof_armature[6:])  # the 8 leg joints after the free base
    assert np.all(armatures[0] == RANGES["servo.armature"].high)
    assert np.all(armatures[1] == RANGES["servo.armature"].nominal)


def test_a_sweep_with_spec_ends_writes_the_column_last(tmp_path):
    from slopewalk.bench.experiments.sweep.run import run_sweep
    from slopewalk.bench.tables.table import read_table

    grid = {"steps": 1, "grid": {"step_time": [1.0]}}
    config = _parse(grid | {"spec_ends": ["nominal", "servo.stall_torque:low"]})
    run_sweep(config, tmp_path, workers=1, quiet=True)
    header = (tmp_path / "sweep.csv").read_text().split("\n")[0].split(",")
    assert header[-1] == "spec_end" and header.count("spec_end") == 1
    rows = read_table(tmp_path / "sweep.csv")
    assert [r["spec_end"] for r in rows] == ["nominal", "servo.stall_torque:low"]
    assert all(r["simulated_verdict"] != "error" for r in rows)


def test_a_table_of_spec_ends_resumes_and_refuses_the_nominal_layout(tmp_path):
    from slopewalk.bench.experiments.sweep.run import run_sweep
    from slopewalk.planner.errors import SlopewalkError

    grid = {"steps": 1, "grid": {"step_time": [1.0]}}
    ends = _parse(grid | {"spec_ends": ["nominal", "servo.stall_torque:low"]})
    run_sweep(ends, tmp_path / "ends", workers=1, quiet=True)
    table = tmp_path / "ends" / "sweep.csv"
    whole = table.read_bytes()
    (tmp_path / "ends" / "sweep.partial.csv").write_bytes(b"".join(whole.splitlines(True)[:2]))
    table.unlink()  # killed after its first row
    summary = run_sweep(ends, tmp_path / "ends", workers=1, quiet=True, resume=True)
    assert (summary.resumed, summary.ran) == (1, 1) and table.read_bytes() == whole
    run_sweep(_parse(grid), tmp_path / "nominal", workers=1, quiet=True)
    with pytest.raises(SlopewalkError, match="played on the nominal spec alone"):
        run_sweep(ends, tmp_path / "nominal", workers=1, quiet=True, resume=True)
