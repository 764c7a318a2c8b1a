"""``sweep`` and ``envelope`` on an unmodified model (``--model``), through the CLI.

Independent reference: ``slopewalk trial --model`` of the same cell, a separate command
and process path (its own flags, gait and ``TrialSpec``); a sweep row on the model must
hold the same simulated outcome at the table's precision (the same MuJoCo code plays
both, so nothing but a difference in what is played can move a digit). Resuming checks
the model by its files' digest: rows of another model, or of the twin, are refused.
"""

import csv
import json
import math
import shutil
from pathlib import Path

import pytest

from slopewalk.bench.cli import main
from slopewalk.bench.experiments.envelope.config import envelope_from_dict
from slopewalk.bench.experiments.sweep.config import load_sweep, sweep_from_dict
from slopewalk.bench.experiments.sweep.run import run_one
from slopewalk.bench.robot_import.mapfile import RobotImportError
from slopewalk.bench.robot_import.model_file import ModelFile, contents_digest
from slopewalk.bench.tables.sweep import DECIMALS, OUTCOMES
from slopewalk.bench.tables.table import text

ROBOTS = Path(__file__).parents[1] / "robots"
WALKER, MAP = ROBOTS / "walker.xml", ROBOTS / "walker-map.toml"
SWEEP = "steps = 1\n[grid]\nstep_time = [1.0]\nslope = [0, 6]\n"
CELL = ["--step-time", "1", "--steps", "1", "--actuators", "servo_ff"]


def _run(argv, capsys) -> tuple[int, str]:
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exit_:
        code = exit_.code
    return code, capsys.readouterr().err


def _rows(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def walker_sweep(tmp_path_factory):
    """A 2-trial sweep on walker.xml, run once through the CLI: (folder, sweep file)."""
    root = tmp_path_factory.mktemp("walker_sweep")
    config = root / "walker.toml"
    config.write_text(SWEEP)
    argv = ["sweep", config, "--model", WALKER, "--map", MAP, "--out", root / "run"]
    assert main([str(a) for a in [*argv, "--workers", "1"]]) == 0
    return root, config


def test_sweep_rows_say_the_model_and_equal_trial_on_the_model(walker_sweep, tmp_path, capsys):
    root, _ = walker_sweep
    rows = _rows(root / "run" / "sweep.csv")
    assert [r["slope_deg"] for r in rows] == ["0.0", "6.0"]
    digest = "sha256:" + contents_digest(WALKER, MAP)[:16]
    for row in rows:
        assert (row["model"], row["model_digest"], row["robot"]) == ("walker", digest, "imported")
        assert row["actuators"] == "servo_ff" and row["error"] == ""
        out = tmp_path / f"t{row['slope_deg']}.json"
        argv = ["trial", "--model", WALKER, "--map", MAP, *CELL, "--slope", row["slope_deg"]]
        assert _run([*argv, "--out", out], capsys)[0] == 0
        trial = json.loads(out.read_text())
        assert trial["model"]["name"] == "walker"
        assert trial["model"]["sha256"] == contents_digest(WALKER, MAP)
        compared = 0
        for column in OUTCOMES:
            if not isinstance(column.source, str) or column.source not in trial:
                continue
            value = trial[column.source]
            value = math.nan if value is None else value
            if column.scale is not None:
                value = float(value * column.scale)
            assert text(column.name, value, DECIMALS) == row[column.name], column.name
            compared += 1
        assert compared >= 20
        kinds = dict.fromkeys(e["kind"] for e in sorted(trial["events"], key=lambda e: e["time"]))
        assert row["events"] == ";".join(kinds)


def test_resume_refuses_rows_of_another_model_or_of_the_twin(walker_sweep, tmp_path, capsys):
    root, config = walker_sweep
    run = tmp_path / "run"
    shutil.copytree(root / "run", run)
    table = (run / "sweep.csv").read_bytes()
    edited = tmp_path / "walker.xml"  # the same robot, other bytes: another model to a digest
    edited.write_text(WALKER.read_text() + "<!-- edited -->\n")
    for model, said in (
        (["--model", edited, "--map", MAP], "are not trials of"),
        (["--model", WALKER], "are not trials of"),  # the same model without its map
        ([], "not a sweep table"),  # the twin
    ):
        code, err = _run(["sweep", config, *model, "--out", run, "--resume"], capsys)
        assert code == 2 and err.count("\n") == 1 and said in err, err
        assert not model or " on model walker (sha256:" in err, err
    assert (run / "sweep.csv").read_bytes() == table and not (run / "sweep.partial.csv").exists()
    # a twin's unfinished run in the folder, resumed on the model: said so
    twin = tmp_path / "twin"
    twin.mkdir()
    lines = table.decode().splitlines()
    (twin / "sweep.partial.csv").write_text(
        "".join(line.rsplit(",", 2)[0] + "\n" for line in lines[:2])
    )
    code, err = _run(["sweep", config, "--model", WALKER, "--map", MAP, "--out", twin], capsys)
    assert code == 2 and "its rows were played on the spec's twin, not on a model" in err, err


def test_a_model_changed_after_the_start_is_an_error_row_not_another_models(tmp_path):
    model = tmp_path / "walker.xml"
    shutil.copy(WALKER, model)
    config = load_sweep_text(SWEEP, tmp_path, ModelFile.of(model, MAP))
    trial = config.trials[0]
    assert trial.model.path == str(model) and Path(trial.model.map_path).is_absolute()
    model.write_text(WALKER.read_text().replace("walker", "walker2", 1))
    row = run_one(trial)  # as a worker runs it
    assert row["simulated_verdict"] == "error" and row["model"] == "walker"
    assert "the model or map changed" in row["error"], row["error"]
    with pytest.raises(RobotImportError, match="unreadable here"):
        model.unlink()
        trial.model.check()


def test_the_model_and_its_map_enter_the_ids_the_twin_keeps_its_own(tmp_path):
    other_map = tmp_path / "map.toml"
    other_map.write_text(MAP.read_text().replace("neck_yaw = 0.4", "neck_yaw = 0.3"))
    twin = load_sweep_text(SWEEP, tmp_path, None)
    ids = {
        name: [t.trial_id for t in load_sweep_text(SWEEP, tmp_path, model).trials]
        for name, model in (
            ("map", ModelFile.of(WALKER, MAP)),
            ("other map", ModelFile.of(WALKER, other_map)),
            ("no map", ModelFile.of(WALKER)),
        )
    }
    all_ids = [i for v in ids.values() for i in v] + [t.trial_id for t in twin.trials]
    assert len(set(all_ids)) == len(all_ids) == 8
    # the twin's ids are the ones a sweep without a model always had
    assert twin.trials[0].model is None and "model" not in twin.trials[0].inputs()


def test_a_sweep_file_names_its_model_relative_to_itself_and_the_flag_replaces_it(tmp_path):
    shutil.copy(WALKER, tmp_path / "w.xml")
    shutil.copy(MAP, tmp_path / "w-map.toml")
    text = 'model = "w.xml"\nmap = "w-map.toml"\n' + SWEEP
    config = load_sweep_text(text, tmp_path, None)
    assert config.model.path == str(tmp_path / "w.xml")
    assert config.model.digest == contents_digest(WALKER, MAP)
    flag = ModelFile.of(WALKER)  # --model without --map: the file's map is not used
    assert load_sweep_text(text, tmp_path, flag).model == flag


def test_an_envelope_on_a_model_plays_the_modes_it_can_and_marks_its_cells(tmp_path):
    grid = {"step_time": [1.0], "slope": [0]}
    model = ModelFile.of(WALKER, MAP)
    config = envelope_from_dict({"grid": grid}, base_dir=tmp_path, model=model)
    twin = envelope_from_dict({"grid": grid}, base_dir=tmp_path)
    assert config.modes == ("servo", "servo_ff") and config.cells[0].robot == "imported"
    assert config.cells[0].cell_id != twin.cells[0].cell_id
    assert config.cells[0].inputs()["model"] == "walker"


def load_sweep_text(text: str, base_dir: Path, model):
    import tomllib

    return sweep_from_dict(tomllib.loads(text), base_dir=base_dir, model=model)


def test_load_sweep_takes_the_flag(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(SWEEP)
    assert load_sweep(path, model=ModelFile.of(WALKER)).trials[0].robot == "imported"


@pytest.mark.slow  # an envelope on the imported model, GA and trials; .ci/run runs it
def test_envelope_on_a_model_through_the_cli_marks_its_table_and_documents(tmp_path, capsys):
    config = tmp_path / "walker-env.toml"
    config.write_text(
        "steps = 2\n[grid]\nstep_time = [3.0]\nslope = [0]\n"
        "[search]\npopulation = 10\ngenerations = 3\n"
    )
    out = tmp_path / "env"
    argv = ["envelope", config, "--model", WALKER, "--map", MAP, "--out", out, "--workers", "1"]
    code, err = _run([*argv, "--convergence"], capsys)  # a search again, of the same model
    assert code == 0, err
    (row,) = _rows(out / "envelope.csv")
    assert (row["model"], row["robot"], row["error"]) == ("walker", "imported", "")
    assert row["model_digest"] == "sha256:" + contents_digest(WALKER, MAP)[:16]
    played = [row[f"maxmargin_{m}_verdict"] for m in ("servo", "servo_ff")]
    assert all(played) and not row["maxmargin_stiff_verdict"], row
    (again,) = _rows(out / "convergence.csv")
    assert (again["model"], again["model_digest"]) == ("walker", row["model_digest"])
    assert (out / "convergence.md").exists()
    boundaries = (out / "boundaries.md").read_text()
    assert f"played on the unmodified model walker ({row['model_digest']})" in boundaries


def test_controllers_refuse_an_envelope_played_on_a_model(tmp_path, capsys):
    """The controllers step the twin's scene: an envelope of a model is refused, not
    walked on the twin in its place."""
    from slopewalk.bench.experiments.envelope.controllers import EnvelopeTableError, table_jobs

    table = ROBOTS.parents[1] / "results" / "robots" / "walker" / "envelope" / "envelope.csv"
    with pytest.raises(EnvelopeTableError, match="was played on the model walker"):
        table_jobs(table)
    config = tmp_path / "walker-env.toml"
    config.write_text(f'model = "{WALKER}"\n[grid]\nstep_time = [3.0]\nslope = [0]\n')
    code, err = _run(["controllers", "--envelope", config, "--out", tmp_path / "c.md"], capsys)
    assert code == 2 and "names the model walker: the controllers step the twin's" in err, err


def test_a_recording_on_the_model_redraws_its_own_bodies_where_the_sensors_saw_them(
    tmp_path, capsys
):
    """``trial --model --record --video``: the model's own qpos (``model_qpos``) is
    recorded, and MuJoCo's kinematics of it put the pelvis where the trial's pelvis sensor
    saw it, every row (settling and walk); the .rrd and the .mp4 are written."""
    import mujoco
    import numpy as np

    from slopewalk.bench.robot_import.scene import model_scene
    from slopewalk.bench.sim.trial import simulated_rows
    from slopewalk.planner.gait import GaitParams
    from slopewalk.planner.plan import plan_walk

    av = pytest.importorskip("av")
    out = {k: tmp_path / f"t.{k}" for k in ("json", "npz", "rrd", "mp4")}
    argv = ["trial", "--model", WALKER, "--map", MAP, *CELL, "--out", out["json"]]
    argv += ["--series", out["npz"], "--record", out["rrd"], "--video", out["mp4"]]
    code, err = _run([*argv, "--video-fps", "4", "--video-size", "96x64"], capsys)
    assert code == 0, err
    assert out["rrd"].stat().st_size > 0
    with av.open(str(out["mp4"])) as video:  # 0.5 s settling + 1.4 s walk at 4 frames/s
        frames = [f.to_ndarray(format="rgb24") for f in video.decode(video=0)]
    assert len(frames) == 8 and frames[0].shape == (64, 96, 3)
    assert not np.array_equal(frames[0], frames[-1])  # the model moves (and falls)
    sim = simulated_rows(dict(np.load(out["npz"])))
    scene = model_scene(WALKER, MAP)
    plan = plan_walk(scene.spec, GaitParams.nominal(scene.spec, 1.0, steps=1))
    model = scene.build(plan, friction=1.0, actuators="servo_ff", timestep=0.001)
    assert sim["model_qpos"].shape == (sim["t"].size, model.nq)
    data = mujoco.MjData(model)
    pelvis = np.empty((sim["t"].size, 3))
    for k, qpos in enumerate(sim["model_qpos"]):
        data.qpos[:] = qpos
        mujoco.mj_kinematics(model, data)
        pelvis[k] = data.site("slopewalk_pelvis").xpos
    np.testing.assert_allclose(pelvis, sim["qpos"][:, :3], rtol=0, atol=1e-12)
