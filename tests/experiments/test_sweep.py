"""Sweeps: the file format, the resumable table, local and Dask runs, the command line."""

import contextlib
import csv
import os
import signal
import subprocess
import sys
import time
from concurrent.futures import Future, ThreadPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

import pytest

from bench.cli import main
from bench.experiments.sweep import run_one, run_sweep
from bench.experiments.sweep_config import (
    DEFAULT_SWEEP,
    SWEEPS_DIR,
    SweepError,
    load_sweep,
    sweep_from_dict,
)
from bench.experiments.sweep_table import COLUMNS, SweepTable
from planner.spec import default_spec_path

SMOKE = SWEEPS_DIR / "smoke.toml"
OUTCOME = [c for c in COLUMNS if c != "wall_s"]  # wall_s is the only column allowed to differ


def _parse(data: dict, base_dir: Path = Path(".")):
    return sweep_from_dict(data, base_dir=base_dir, source="s.toml")


def _table(path: Path) -> dict[str, dict]:
    """Rows of a sweep.csv by trial_id, without wall_s."""
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        assert tuple(reader.fieldnames) == COLUMNS
        return {r["trial_id"]: {c: r[c] for c in OUTCOME} for r in reader}


def _rows_in(path: Path) -> int:
    try:
        return max(0, path.read_bytes().count(b"\n") - 1)
    except FileNotFoundError:
        return 0


def _short_legged_robot(directory: Path) -> Path:
    """The paper's biped with a 1 cm shank: no plan reaches its hips.

    The nominal hip-ankle distance, 0.757 (L1 + L2) = 0.092 m, is shorter than the
    leg folds (L1 − L2 = 0.101 m), so the hip target is out of reach.
    """
    text = default_spec_path().read_text().replace("\nshank = 0.111", "\nshank = 0.01")
    path = directory / "short.toml"
    path.write_text(text)
    return path


# --- the file format ---------------------------------------------------------------------------


def test_grid_is_the_product_and_defaults_fill_the_rest():
    config = _parse({"grid": {"step_time": [1.0, 0.5], "friction": [0.4, 0.6, 1.0]}})
    assert len(config.trials) == 6
    assert {(t.step_time, t.friction) for t in config.trials} == {
        (s, f) for s in (1.0, 0.5) for f in (0.4, 0.6, 1.0)
    }
    t = config.trials[0]
    assert (t.slope_deg, t.actuators, t.robot, t.mass_scale) == (0.0, "stiff", "default", ())
    assert (t.steps, t.seed, config.steps, config.seed) == (4, 0, 4, 0)


def test_trials_and_grids_are_a_deduplicated_union():
    config = _parse(
        {
            "steps": 2,
            "seed": 7,
            "grid": [{"slope": [0, 10]}, {"step_time": [1.0, 0.5]}],
            "trial": [{"step_time": 0.4, "friction": 0.4, "actuators": "servo"}, {"slope": 10}],
        }
    )
    # (1, 0) appears in both grids and (1, 10) in a grid and a [[trial]]: each runs once
    keys = [(t.step_time, t.slope_deg, t.friction, t.actuators) for t in config.trials]
    assert keys == [
        (1.0, 0.0, 1.0, "stiff"),
        (1.0, 10.0, 1.0, "stiff"),
        (0.5, 0.0, 1.0, "stiff"),
        (0.4, 0.0, 0.4, "servo"),
    ]
    assert len({t.trial_id for t in config.trials}) == 4
    assert all(t.steps == 2 and t.seed == 7 for t in config.trials)


def test_trial_id_is_stable_and_follows_every_input():
    a = _parse({"trial": [{"step_time": 0.5}]}).trials[0]
    assert a.trial_id == _parse({"trial": [{"step_time": 0.5}]}).trials[0].trial_id
    others = [
        {"trial": [{"step_time": 0.6}]},
        {"trial": [{"step_time": 0.5, "slope": 1}]},
        {"trial": [{"step_time": 0.5, "friction": 0.9}]},
        {"trial": [{"step_time": 0.5, "actuators": "servo"}]},
        {"trial": [{"step_time": 0.5, "mass_scale": {"pelvis": 2}}]},
        {"trial": [{"step_time": 0.5}], "steps": 3},
        {"trial": [{"step_time": 0.5}], "seed": 1},
    ]
    ids = {_parse(d).trials[0].trial_id for d in others}
    assert len(ids) == len(others) and a.trial_id not in ids


def test_mass_scale_groups_multiply(spec):
    config = _parse(
        {"grid": {"mass_scale": [{"all": 10}, {"legs": 2}, {"all": 10, "legs": 2}, {"foot": 3}]}}
    )
    masses = [
        {n: t.spec.links[n].mass / spec.links[n].mass for n in spec.links} for t in config.trials
    ]
    assert masses[0] == pytest.approx(dict.fromkeys(spec.links, 10.0))
    assert masses[1] == pytest.approx({"pelvis": 1, "thigh": 2, "shank": 2, "ankle": 2, "foot": 2})
    assert masses[2]["pelvis"] == pytest.approx(10) and masses[2]["shank"] == pytest.approx(20)
    assert masses[3] == pytest.approx({"pelvis": 1, "thigh": 1, "shank": 1, "ankle": 1, "foot": 3})
    assert [t.mass_scale_text for t in config.trials] == [
        "all=10",
        "legs=2",
        "all=10;legs=2",
        "foot=3",
    ]


def test_robot_paths_are_relative_to_the_sweep_file(tmp_path):
    _short_legged_robot(tmp_path)
    (tmp_path / "s.toml").write_text('[grid]\nrobot = ["short.toml", "default"]\n')
    config = load_sweep(tmp_path / "s.toml")
    assert [t.robot for t in config.trials] == ["short.toml", "default"]
    assert config.trials[0].spec.shank == 0.01 and config.trials[1].spec.shank == 0.111


def test_shipped_sweeps_parse():
    paper = load_sweep()
    assert Path(paper.source) == DEFAULT_SWEEP
    # 8 step times + 9 slopes at 3 frictions, flat 1 s counted once, + 2 mass cases
    assert len(paper.trials) == (8 + 9 - 1) * 3 + 2
    assert {t.mass_scale_text for t in paper.trials} == {"none", "all=10", "legs=2"}
    smoke = load_sweep(SMOKE)
    assert 3 <= len(smoke.trials) <= 4 and smoke.steps == 1


@pytest.mark.parametrize(
    "data, message",
    [
        ({"grid": {"step_time": [1.0]}, "stepz": 3}, "unknown key stepz"),
        ({"grid": {"sloap": [0]}}, "unknown key grid.sloap"),
        ({"trial": [{}, {"mu": 0.5}]}, "unknown key trial[1].mu"),
        ({"grid": {"mass_scale": [{"arms": 2}]}}, "mass_scale: unknown group 'arms'"),
        ({"grid": {"step_time": [1.0, 0]}}, "grid.step_time = 0 s: must be > 0"),
        ({"grid": {"step_time": [-1]}}, "step_time = -1 s: must be > 0"),
        ({"grid": {"slope": [60]}}, "grid.slope = 60 deg: must lie in (-60, 60) deg"),
        ({"trial": [{"slope": -75}]}, "trial[0].slope = -75 deg: must lie in (-60, 60)"),
        ({"grid": {"friction": [0.5, 0]}}, "grid.friction = 0: must be > 0"),
        ({"grid": {"actuators": ["soft"]}}, "actuators = 'soft': must be one of stiff, servo"),
        ({"grid": {"mass_scale": [{"legs": 0}]}}, "mass_scale.legs = 0: must be > 0"),
        ({"grid": {"robot": ["missing.toml"]}}, "grid.robot: robot spec"),
        ({"grid": {"slope": 5}}, "grid.slope = 5: must be a non-empty list"),
        ({"grid": {"friction": ["high"]}}, "grid.friction = 'high': must be a finite number"),
        ({"grid": {}, "steps": 0}, "steps = 0: must be an integer >= 1"),
        ({"steps": 2}, "no trials"),
        ({"grid": {"step_time": [0.005]}}, "step time 0.005 s: must lie in [0.01, 60] s"),
    ],
)
def test_bad_sweep_files_are_refused_naming_the_key(data, message):
    with pytest.raises(SweepError) as err:
        _parse(data)
    assert message in str(err.value)
    assert "\n" not in str(err.value)


# --- the table ---------------------------------------------------------------------------------


def test_table_appends_whole_rows_and_survives_a_torn_line(tmp_path):
    path = tmp_path / "sweep.csv"
    row = {"trial_id": "abc", "friction": 0.1 + 0.2, "error": 'says "no", twice\nover lines'}
    with SweepTable.open(path) as table:
        assert table.rows == {}
        table.append(row)
    with SweepTable.open(path) as table:
        back = table.rows["abc"]
    assert float(back["friction"]) == 0.1 + 0.2  # exact round trip
    assert back["error"] == 'says "no", twice over lines'
    with open(path, "ab") as f:  # a crash inside a write: the last line has no newline
        f.write(b"def,0.5,0.0")
    with SweepTable.open(path) as table:
        assert list(table.rows) == ["abc"]
    assert path.read_bytes().endswith(b"\n")


def test_table_refuses_other_columns_and_a_second_writer(tmp_path):
    path = tmp_path / "sweep.csv"
    path.write_text("a,b\n1,2\n")
    with pytest.raises(SweepError, match="not a sweep table"), SweepTable.open(path):
        pass
    other = tmp_path / "other.csv"
    with SweepTable.open(other), pytest.raises(SweepError, match="another sweep"):
        with SweepTable.open(other):
            pass


def test_a_failing_trial_is_an_error_row(tmp_path):
    _short_legged_robot(tmp_path)
    trial = _parse({"trial": [{"robot": "short.toml", "step_time": 0.5}]}, tmp_path).trials[0]
    row = run_one(trial)
    assert row["analytic_verdict"] == row["simulated_verdict"] == "error"
    assert row["error"].startswith("unreachable hip target") and "\n" not in row["error"]
    assert row["robot"] == "short.toml" and row["trial_id"] == trial.trial_id


def test_recording_per_trial(tmp_path):
    pytest.importorskip("bench.report.recording")
    trial = load_sweep(SMOKE).trials[0]
    row = run_one(trial, str(tmp_path))
    assert row["error"] == ""
    assert (tmp_path / f"{trial.trial_id}.rrd").stat().st_size > 0
    assert [p.name for p in tmp_path.iterdir()] == [f"{trial.trial_id}.rrd"]


# --- whole sweeps ------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The smoke sweep run once, uninterrupted, on one local worker."""
    out = tmp_path_factory.mktemp("reference")
    assert main(["sweep", str(SMOKE), "--workers", "1", "--out", str(out)]) == 0
    return _table(out / "sweep.csv")


def test_reference_run_is_complete(reference):
    smoke = load_sweep(SMOKE)
    assert list(reference) == [t.trial_id for t in smoke.trials]  # rewritten in file order
    for row in reference.values():
        assert row["simulated_verdict"] in ("stable", "tip", "slip", "fall", "diverged")
        assert row["error"] == "" and float(row["work_J"]) > 0 and int(row["sim_steps"]) > 0


def test_killed_sweep_resumes_and_loses_nothing(tmp_path, reference):
    out = tmp_path / "out"
    table = out / "sweep.csv"
    command = [sys.executable, "-m", "bench.cli", "sweep", str(SMOKE), "--workers", "1"]
    command += ["--out", str(out)]
    proc = subprocess.Popen(
        command, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    try:
        deadline = time.monotonic() + 60
        while _rows_in(table) < 1 and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.002)
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)  # the sweep and its worker, mid-trial
        proc.wait()
    assert 1 <= _rows_in(table) < len(reference), "the sweep was not killed midway"
    partial = _table(table)
    assert all(partial[i] == reference[i] for i in partial)
    resumed = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert resumed.returncode == 0, resumed.stderr
    assert f"{len(reference) - len(partial)} of {len(reference)} trials to run" in resumed.stderr
    assert _table(table) == reference


def test_dask_cluster_gives_the_same_table(tmp_path, reference):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=1,
        threads_per_worker=1,
        processes=False,
        protocol="tcp",
        dashboard_address=None,
    ) as cluster:
        address = cluster.scheduler_address
        assert address.startswith("tcp://")
        assert main(["sweep", str(SMOKE), "--cluster", address, "--out", str(tmp_path)]) == 0
    assert _table(tmp_path / "sweep.csv") == reference


class _LosesFirstTrial(ThreadPoolExecutor):
    """An executor whose first trial is lost with its worker (as when a process dies)."""

    def submit(self, fn, *args, **kwargs):
        if not hasattr(self, "lost"):
            self.lost = Future()
            self.lost.set_exception(BrokenProcessPool("a worker died"))
            return self.lost
        return super().submit(fn, *args, **kwargs)


def test_a_lost_trial_leaves_no_row_and_a_rerun_finishes_it(tmp_path):
    config = load_sweep(SMOKE)
    with _LosesFirstTrial(max_workers=1) as executor:
        summary = run_sweep(config, tmp_path, executor=executor, quiet=True)
    assert len(summary.lost) == 1 and "BrokenProcessPool: a worker died" in summary.lost[0]
    assert summary.ran == len(config.trials) - 1 == len(_table(tmp_path / "sweep.csv"))
    with ThreadPoolExecutor(max_workers=1) as executor:
        summary = run_sweep(config, tmp_path, executor=executor, quiet=True)
    assert (summary.ran, summary.resumed, summary.lost) == (1, len(config.trials) - 1, ())
    assert list(_table(tmp_path / "sweep.csv")) == [t.trial_id for t in config.trials]


def test_default_output_is_the_working_directorys_results(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "one.toml").write_text("steps = 1\n[[trial]]\nstep_time = 0.5\n")
    assert main(["sweep", "one.toml", "--workers", "1"]) == 0
    assert len(_table(tmp_path / "results" / "sweep.csv")) == 1
    assert "wrote" in capsys.readouterr().out


def test_error_rows_do_not_stop_the_sweep(tmp_path):
    _short_legged_robot(tmp_path)
    (tmp_path / "s.toml").write_text(
        'steps = 1\n[grid]\nrobot = ["short.toml", "default"]\nstep_time = [0.5]\n'
    )
    assert main(["sweep", str(tmp_path / "s.toml"), "--workers", "1", "--out", str(tmp_path)]) == 0
    rows = list(_table(tmp_path / "sweep.csv").values())
    assert [r["simulated_verdict"] == "error" for r in rows] == [True, False]
    assert rows[0]["error"].startswith("unreachable hip target")


# --- bad input at the command line -------------------------------------------------------------


@pytest.mark.parametrize(
    "config, flags, message",
    [
        ("[grid]\nslope = [0, 75]\n", [], "grid.slope = 75 deg: must lie in (-60, 60) deg"),
        ("[grid]\nfrction = [0.5]\n", [], "unknown key grid.frction"),
        ("[[trial]]\nrobot = 'nope.toml'\n", [], "no such file"),
        ("[grid\n", [], "not valid TOML"),
        (None, [], "no such file"),
        ("[[trial]]\n", ["--workers", "0"], "--workers: 0: must be an integer in [1, 1024]"),
        ("[[trial]]\n", ["--cluster", "localhost"], "not a scheduler address like tcp://"),
    ],
)
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, capsys, config, flags, message):
    path = tmp_path / "s.toml"
    if config is not None:
        path.write_text(config)
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as exited:
        sys.exit(main(["sweep", str(path), "--out", str(out), *flags]))
    assert exited.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("slopewalk") and message in err and err.count("\n") == 1
    assert not out.exists()


def test_bad_input_has_no_traceback(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text("[grid]\nfriction = [-1]\n")
    result = subprocess.run(
        [sys.executable, "-m", "bench.cli", "sweep", str(path), "--out", str(tmp_path / "out")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 2
    assert result.stderr == f"slopewalk: error: {path}: grid.friction = -1: must be > 0\n"
    assert "Traceback" not in result.stderr and not (tmp_path / "out").exists()
