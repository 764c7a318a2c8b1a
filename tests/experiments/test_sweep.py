"""Whole sweeps: fresh runs and resumes, real signals and real processes, the command line."""

import contextlib
import csv
import io
import os
import signal
import subprocess
import sys
import time
from concurrent.futures import Future, ThreadPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

import pytest
from conftest import left_in_session

from slopewalk.bench.cli import main
from slopewalk.bench.experiments.sweep.config import (
    SWEEPS_DIR,
    load_sweep,
    sweep_from_dict,
)
from slopewalk.bench.experiments.sweep.run import SweepSummary, run_one, run_sweep
from slopewalk.bench.tables.sweep import (
    COLUMNS,
    CONTROLLER_COLUMNS,
    CONTROLLER_HEADER,
    HEADER,
    PREVIOUS_LAYOUTS,
    format_row,
    parse,
)
from slopewalk.bench.tables.table import TableError

SMOKE = SWEEPS_DIR / "smoke.toml"
SWEEP = [sys.executable, "-m", "slopewalk.bench.cli", "sweep"]
BANANA = format_row(
    {"trial_id": "0123456789ab", "analytic_verdict": "stable", "simulated_verdict": "banana"}
)


def _table(path: Path) -> dict[str, bytes]:
    """The rows of a sweep table by trial_id (as written)."""
    return parse(path.read_bytes(), path, torn_ok=True)[0]


def _rows_in(path: Path) -> int:
    try:
        return max(0, path.read_bytes().count(b"\n") - 1)
    except FileNotFoundError:
        return 0


def _children(pid: int) -> list[tuple[int, bytes]]:
    """(pid, cmdline) of the live child processes of ``pid``."""
    out = []
    for name in os.listdir("/proc"):
        if name.isdigit():
            try:
                stat = Path(f"/proc/{name}/stat").read_text()
                cmdline = Path(f"/proc/{name}/cmdline").read_bytes()
            except OSError:
                continue
            ppid = int(stat[stat.rindex(")") + 2 :].split()[1])
            if ppid == pid:
                out.append((int(name), cmdline))
    return out


def _workers(pid: int) -> list[int]:
    """Pids of the worker processes of ``pid``: forked by its fork server (or spawned by it)."""
    out = []
    for child, cmdline in _children(pid):
        if b"spawn_main" in cmdline:
            out.append(child)
        elif b"multiprocessing.forkserver" in cmdline:
            out += [worker for worker, _ in _children(child)]
    return out


def _busy_worker(pid: int, timeout: float = 10) -> int:
    """A worker of ``pid`` that is running (state R: in a trial, not waiting on its pipe)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        for worker in _workers(pid):
            with contextlib.suppress(OSError):
                stat = Path(f"/proc/{worker}/stat").read_text()
                if stat[stat.rindex(")") + 2] == "R":
                    return worker
        time.sleep(0.001)
    raise AssertionError("no worker is running a trial")


@contextlib.contextmanager
def _started(command: list[str], tmp_path: Path):
    """``command`` running in its own session, stderr to a file; killed whole on the way out."""
    err = tmp_path / "stderr.txt"
    with open(err, "w") as f:
        proc = subprocess.Popen(command, start_new_session=True, stdout=f, stderr=f)
    try:
        yield proc, err
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()


def _wait_rows(table: Path, n: int, proc, timeout: float = 60) -> None:
    deadline = time.monotonic() + timeout
    while _rows_in(table) < n and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.002)
    assert _rows_in(table) >= n, "the sweep wrote no row"


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The smoke sweep run once, uninterrupted, on one local worker: (rows, file bytes)."""
    out = tmp_path_factory.mktemp("reference")
    assert main(["sweep", str(SMOKE), "--workers", "1", "--out", str(out)]) == 0
    return _table(out / "sweep.csv"), (out / "sweep.csv").read_bytes()


# --- one trial ---------------------------------------------------------------------------------


def test_a_failing_trial_is_an_error_row(tmp_path, short_robot):
    data = {"trial": [{"robot": "short.toml", "step_time": 0.5}]}
    trial = sweep_from_dict(data, base_dir=tmp_path).trials[0]
    row = run_one(trial)
    assert row["analytic_verdict"] == row["simulated_verdict"] == "error"
    assert row["error"].startswith("unreachable hip target") and "\n" not in row["error"]
    assert row["robot"] == "short.toml" and row["trial_id"] == trial.trial_id


def test_recording_per_trial(tmp_path):
    pytest.importorskip("slopewalk.bench.sim.recording")
    trial = load_sweep(SMOKE).trials[0]
    row = run_one(trial, str(tmp_path))
    assert row["error"] == ""
    assert (tmp_path / f"{trial.trial_id}.rrd").stat().st_size > 0
    assert [p.name for p in tmp_path.iterdir()] == [f"{trial.trial_id}.rrd"]
    import numpy as np
    from rerun.chunk import RrdReader

    from slopewalk.bench.sim.recording import SWEEP_PLOT_RATE

    times = [  # a sweep's plots are decimated: every 10th sample of the 1 ms step
        t
        for chunk in RrdReader(tmp_path / f"{trial.trial_id}.rrd").store().stream()
        if chunk.entity_path == "/joints/l_knee/actual" and not chunk.is_static
        for t in chunk.to_record_batch().column("time").cast("int64").to_pylist()
    ]
    steps = np.diff(sorted(times))[:-1] / 1e9  # the last sample is kept, closer
    np.testing.assert_allclose(steps, 1 / SWEEP_PLOT_RATE, atol=1e-9)


# --- whole sweeps ------------------------------------------------------------------------------


def test_reference_run_is_complete(reference, tmp_path):
    """Every row holds what ``run_trial`` gives for its trial, in the table's units.

    The smoke cases' verdicts are part of the file's promise (stable and failing cases):
    1 s flat stable in both views; 0.4 s leaves the foot and slips; the servo on 15°
    falls; doubled leg masses leave the foot and tip.
    """
    from slopewalk.bench.sim.trial import run_trial

    rows, data = reference
    smoke = load_sweep(SMOKE)
    assert list(rows) == [t.trial_id for t in smoke.trials]  # written in file order
    assert data.startswith(HEADER)
    verdicts = []
    for trial in smoke.trials:
        line = rows[trial.trial_id]
        fields = dict(zip(COLUMNS, line.decode().rstrip("\n").split(","), strict=True))
        result = run_trial(trial.spec, trial.trial_spec())
        assert fields["error"] == "" and float(fields["work_J"]) > 0
        assert fields["analytic_verdict"] == result.analytic_verdict
        assert fields["simulated_verdict"] == result.simulated_verdict
        # 4 decimals of a millimetre in the table
        assert float(fields["zmp_rms_mm"]) == pytest.approx(result.zmp_rms * 1e3, abs=6e-5)
        assert float(fields["analytic_min_margin_mm"]) == pytest.approx(
            result.analytic_min_margin * 1e3, abs=6e-5
        )
        assert int(fields["sim_steps"]) == result.sim_steps
        verdicts.append((fields["analytic_verdict"], fields["simulated_verdict"]))
    assert verdicts == [
        ("stable", "stable"),
        ("zmp_outside", "slip"),
        ("stable", "fall"),
        ("zmp_outside", "tip"),
    ]


def test_a_fresh_run_plays_every_trial_and_writes_the_same_bytes(
    tmp_path, monkeypatch, capsys, reference
):
    monkeypatch.chdir(tmp_path)  # the default --out: ./results, as on a fresh clone
    table = tmp_path / "results" / "sweep.csv"
    for _ in range(2):
        assert main(["sweep", str(SMOKE), "--workers", "2"]) == 0
        assert "4 trials, 0 already done, 4 to run" in capsys.readouterr().err
        assert table.read_bytes() == reference[1]  # the same trials give the same bytes
    assert sorted(p.name for p in table.parent.iterdir()) == ["sweep.csv"]
    assert main(["sweep", str(SMOKE), "--resume"]) == 0  # asked for: nothing to run
    assert "4 trials, 4 already done, 0 to run" in capsys.readouterr().err
    assert table.read_bytes() == reference[1]


def test_an_unfinished_run_is_resumed_only_when_asked(tmp_path, monkeypatch, capsys, reference):
    rows, data = reference
    monkeypatch.chdir(tmp_path)
    partial = tmp_path / "results" / "sweep.partial.csv"
    partial.parent.mkdir()
    partial.write_bytes(HEADER + b"".join(list(rows.values())[:2]))  # as a killed run leaves it
    before = partial.read_bytes()
    assert main(["sweep", str(SMOKE)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "holds an unfinished sweep (2 trials in sweep.partial.csv)" in err
    assert "add --resume to finish it" in err and partial.read_bytes() == before
    assert main(["sweep", str(SMOKE), "--workers", "1", "--resume"]) == 0
    assert "2 already done, 2 to run" in capsys.readouterr().err
    assert (tmp_path / "results" / "sweep.csv").read_bytes() == data and not partial.exists()
    # --out naming a directory with an unfinished run resumes it without the flag
    out = tmp_path / "elsewhere"
    out.mkdir()
    (out / "sweep.partial.csv").write_bytes(before)
    assert main(["sweep", str(SMOKE), "--workers", "1", "--out", str(out)]) == 0
    assert "2 already done, 2 to run" in capsys.readouterr().err
    assert (out / "sweep.csv").read_bytes() == data


@pytest.mark.parametrize(  # SIGTERM's path is the same pool kill; .ci/run runs it
    "how", [signal.SIGKILL, pytest.param(signal.SIGTERM, marks=pytest.mark.slow)]
)
def test_a_killed_sweep_leaves_no_worker_and_resumes_at_once(tmp_path, capsys, reference, how):
    out = tmp_path / "out"
    args = ["sweep", str(SMOKE), "--workers", "2", "--out", str(out)]
    with _started([*SWEEP, *args[1:]], tmp_path) as (proc, err):
        _wait_rows(out / "sweep.partial.csv", 1, proc)
        assert len(_workers(proc.pid)) == 2
        os.kill(proc.pid, how)  # the main process only: its workers must follow it
        code = proc.wait(timeout=30)
        resumed = main([*args, "--resume"])  # in this process: no second interpreter to start
        assert left_in_session(proc.pid) == [], "workers outlived their sweep"
    said = capsys.readouterr().err
    assert resumed == 0, said  # not refused: no one holds the lock
    assert " already done, " in said and not (out / "sweep.partial.csv").exists()
    assert (out / "sweep.csv").read_bytes() == reference[1]
    if how == signal.SIGTERM:  # handled like Ctrl-C: one line, a non-zero exit
        assert code == 128 + signal.SIGTERM
        last = err.read_text().splitlines()[-1]
        assert last.startswith("slopewalk: stopped by SIGTERM: ") and "--resume" in last
        assert "Traceback" not in err.read_text()
    else:
        assert code == -signal.SIGKILL


def test_a_killed_worker_costs_only_its_trial(tmp_path, capsys):
    config = tmp_path / "s.toml"
    config.write_text("steps = 2\n[grid]\nstep_time = [2.0]\nslope = [0, 5, 10, 15, 20]\n")
    out = tmp_path / "out"
    args = ["sweep", str(config), "--workers", "2", "--out", str(out)]
    with _started([*SWEEP, *args[1:]], tmp_path) as (proc, err):
        _wait_rows(out / "sweep.partial.csv", 2, proc)  # both workers are up
        os.kill(_busy_worker(proc.pid), signal.SIGKILL)
        assert proc.wait(timeout=120) == 0, err.read_text()
    rows = [line.decode() for line in _table(out / "sweep.csv").values()]
    assert len(rows) == 5
    died = [r for r in rows if "error,error" in r]
    assert len(died) == 1 and died[0].rstrip().endswith(",worker died: signal 9 (SIGKILL)")
    assert all(",stable," in r or ",zmp_outside," in r for r in rows if r not in died)
    summary = err.read_text()  # stdout and stderr
    assert "5 trials: 5 run, 0 already done, 1 errors, 0 lost" in summary
    assert "analytic / simulated / walk verdicts: error/error/error 1, " in summary
    assert main([*args, "--resume"]) == 0  # in this process: no second interpreter to start
    assert "5 already done, 0 to run" in capsys.readouterr().err


def test_a_stop_while_the_workers_start_is_the_runs_stop_and_leaves_nothing(tmp_path, monkeypatch):
    """Ctrl-C after the first line but before the workers were up (a cold compile, the fork
    server importing) escaped the run's own handling: "slopewalk: interrupted" and an empty
    partial table that made the next run ask for --resume. Now it is the run's stop."""
    from slopewalk.bench.batch import run as batch_run
    from slopewalk.bench.batch.executor import Interrupted
    from slopewalk.bench.batch.run import Stopped

    def starting(*args, **kwargs):  # the signal, as it lands in the workers' start
        raise Interrupted(signal.SIGINT)

    monkeypatch.setattr(batch_run, "LocalPool", starting)
    out = tmp_path / "out"
    try:
        run_sweep(load_sweep(SMOKE), out, workers=1, quiet=True)
        pytest.fail("not stopped")
    except Stopped as stop:
        assert "stopped by SIGINT before any of the trials finished" in stop.message
    except Interrupted:  # a KeyboardInterrupt would end pytest's session: fail this test alone
        pytest.fail("the stop escaped the run's own handling")
    assert list(out.iterdir()) == []
    monkeypatch.undo()
    assert run_sweep(load_sweep(SMOKE), out, workers=1, quiet=True).total == 4  # no --resume


def test_a_million_trial_grid_says_its_size_at_once_and_stops_on_ctrl_c(tmp_path):
    values = ", ".join(f"{0.4 + x / 100:.2f}" for x in range(100))
    config = tmp_path / "big.toml"
    config.write_text(
        f"steps = 1\n[grid]\nstep_time = [{values}]\nslope = [{values}]\nfriction = [{values}]\n"
    )
    out = tmp_path / "out"
    command = [*SWEEP, str(config), "--workers", "1", "--out", str(out)]
    with _started(command, tmp_path) as (proc, err):
        deadline = time.monotonic() + 60
        while "\n" not in err.read_text() and time.monotonic() < deadline:
            time.sleep(0.01)
        first = err.read_text().splitlines()[0]
        proc.send_signal(signal.SIGINT)
        code = proc.wait(timeout=30)  # a hang guard, not a speed goal
        assert left_in_session(proc.pid) == []
    assert first.startswith("sweep: 1000000 trials, 0 already done, 1000000 to run on 1 workers")
    assert " h at " in first  # the estimated time, before any trial
    assert code == 130 and "slopewalk: stopped by SIGINT" in err.read_text().splitlines()[-1]
    partial = out / "sweep.partial.csv"  # kept with the rows written, or gone if there are none
    assert _rows_in(partial) > 0 if partial.exists() else "nothing written" in err.read_text()


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
    assert (tmp_path / "sweep.csv").read_bytes() == reference[1]


class _LosesFirstTrial(ThreadPoolExecutor):
    """An executor whose first trial is lost with its worker (as when a process dies)."""

    def submit(self, fn, *args, **kwargs):
        if not hasattr(self, "lost"):
            self.lost = Future()
            self.lost.set_exception(BrokenProcessPool("a worker died"))
            return self.lost
        return super().submit(fn, *args, **kwargs)


def test_a_trial_an_executor_lost_leaves_no_row_and_resume_finishes_it(tmp_path, reference):
    config = load_sweep(SMOKE)
    with _LosesFirstTrial(max_workers=1) as executor:
        summary = run_sweep(config, tmp_path, executor=executor, quiet=True)
    assert len(summary.lost) == 1 and "BrokenProcessPool: a worker died" in summary.lost[0]
    assert summary.table == tmp_path / "sweep.partial.csv"
    assert summary.ran == len(config.trials) - 1 == len(_table(summary.table))
    with ThreadPoolExecutor(max_workers=1) as executor:
        summary = run_sweep(config, tmp_path, executor=executor, resume=True, quiet=True)
    assert (summary.ran, summary.resumed, summary.lost) == (1, len(config.trials) - 1, ())
    assert (tmp_path / "sweep.csv").read_bytes() == reference[1]


def test_the_verdict_line_is_never_empty():
    summary = SweepSummary(Path("t.csv"), 1, 0, 0, 0, ("x: lost",), 0, 1.0, {})
    assert summary.lines()[1] == "analytic / simulated / walk verdicts: none (no row written)"


def test_default_output_is_the_working_directorys_results(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "one.toml").write_text("steps = 1\n[[trial]]\nstep_time = 0.5\n")
    assert main(["sweep", "one.toml", "--workers", "1"]) == 0
    assert len(_table(tmp_path / "results" / "sweep.csv")) == 1
    assert "wrote" in capsys.readouterr().out


def test_error_rows_do_not_stop_the_sweep(tmp_path, short_robot):
    (tmp_path / "s.toml").write_text(
        'steps = 1\n[grid]\nrobot = ["short.toml", "default"]\nstep_time = [0.5]\n'
    )
    assert main(["sweep", str(tmp_path / "s.toml"), "--workers", "1", "--out", str(tmp_path)]) == 0
    rows = [line.decode() for line in _table(tmp_path / "sweep.csv").values()]
    assert ["error,error" in r for r in rows] == [True, False]
    assert ',"unreachable hip target at t = ' in rows[0]


# --- tables that are not ours ------------------------------------------------------------------


@pytest.mark.parametrize(
    "name, data, resume, message",
    [
        ("sweep.csv", os.urandom(4096).replace(b"\n", b"x"), False, "not a sweep table"),
        ("sweep.csv", b"\xff" * 4096, True, "not a sweep table (not UTF-8 text"),
        ("sweep.partial.csv", HEADER + b"0123456789ab,1\n", True, "line 2 has 2 fields"),
        ("sweep.csv", HEADER + BANANA, False, "line 2: simulated_verdict 'banana' is not one of"),
    ],
)
def test_a_table_that_is_not_a_sweep_table_is_refused_and_kept(
    tmp_path, capsys, name, data, resume, message
):
    (tmp_path / name).write_bytes(data)
    flags = ["--resume"] if resume else []
    assert main(["sweep", str(SMOKE), "--out", str(tmp_path), *flags]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and str(tmp_path / name) in err
    assert [p.name for p in tmp_path.iterdir()] == [name] and (tmp_path / name).read_bytes() == data


@pytest.mark.parametrize("layout", PREVIOUS_LAYOUTS[:2], ids=["wall_s", "no_fidelity"])
def test_a_table_of_a_previous_version_is_replaced_by_a_fresh_run_only(
    tmp_path, capsys, reference, layout
):
    rows, data = reference

    def previous(line: bytes) -> bytes:  # the older layout's columns, filled from a row
        row = dict(zip(COLUMNS, next(csv.reader([line.decode()])), strict=True))
        buffer = io.StringIO()
        csv.writer(buffer, lineterminator="\n").writerow(row.get(c, "0.5") for c in layout)
        return buffer.getvalue().encode()

    header = (",".join(layout) + "\n").encode()
    old = header + b"".join(previous(line) for line in rows.values())
    (tmp_path / "sweep.csv").write_bytes(old)
    assert main(["sweep", str(SMOKE), "--out", str(tmp_path), "--resume"]) == 2
    assert "written by an older slopewalk" in capsys.readouterr().err
    assert (tmp_path / "sweep.csv").read_bytes() == old
    assert main(["sweep", str(SMOKE), "--workers", "1", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "sweep.csv").read_bytes() == data


def test_rows_of_another_sweep_are_refused(tmp_path, capsys, reference):
    rows, _ = reference
    other = next(iter(rows.values())).replace(next(iter(rows)).encode(), b"feedfeedfeed", 1)
    table = tmp_path / "sweep.partial.csv"
    table.write_bytes(HEADER + other)
    assert main(["sweep", str(SMOKE), "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert f"{table}: 1 rows (e.g. trial_id feedfeedfeed) are not trials of {SMOKE}" in err
    assert table.read_bytes() == HEADER + other


# --- bad input at the command line -------------------------------------------------------------


@pytest.mark.parametrize(
    "config, flags, message",
    [
        ("[grid]\nslope = [0, 75]\n", [], "grid.slope = 75 deg: must lie in (-60, 60) deg"),
        ("[grid]\nfrction = [0.5]\n", [], "unknown key grid.frction"),
        ("[[trial]]\nrobot = 'nope.toml'\n", [], "no such file"),
        ("[grid\n", [], "not valid TOML"),
        ("[grid]\n", [], "grid is empty"),
        (None, [], "no such file"),
        ("DIR", [], "is a directory, not a sweep TOML"),
        (b"\x00\xff\xfe binary", [], "not UTF-8 text (byte 0xff at offset 1)"),
        ("[[trial]]\n", ["--workers", "0"], "--workers: 0: must be an integer in [1, 1024]"),
        ("[[trial]]\n", ["--cluster", "localhost"], "not a scheduler address like tcp://"),
        ("[[trial]]\n", ["--in-flight", "0"], "--in-flight: 0: must be an integer in [1, 100000]"),
        ("[[trial]]\n", ["--in-flight", "8"], "--in-flight 8: only with --cluster"),
        ("[[trial]]\n", ["--join-timeout", "0"], "--join-timeout: 0: must lie in (0, 86400] s"),
        ("[[trial]]\n", ["--join-timeout", "5"], "--join-timeout 5: only with --cluster"),
    ],
)
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, capsys, config, flags, message):
    path = tmp_path / "s.toml"
    if config == "DIR":
        path.mkdir()
    elif isinstance(config, bytes):
        path.write_bytes(config)
    elif config is not None:
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
        [
            sys.executable,
            "-m",
            "slopewalk.bench.cli",
            "sweep",
            str(path),
            "--out",
            str(tmp_path / "out"),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 2
    assert result.stderr == f"slopewalk: error: {path}: grid.friction = -1: must be > 0\n"
    assert "Traceback" not in result.stderr and not (tmp_path / "out").exists()


def test_a_closed_loop_sweep_has_a_controller_column(tmp_path):
    """Open loop and the plan as a controller: same verdicts, told apart by the last column."""
    policy = "slopewalk.bench.sim.env:open_loop"
    config = sweep_from_dict(
        {"steps": 1, "grid": {"step_time": [1.0, 0.4], "controller": ["none", policy]}},
        base_dir=tmp_path,
    )
    summary = run_sweep(config, tmp_path, workers=1, quiet=True)
    assert summary.errors == 0
    data = (tmp_path / "sweep.csv").read_bytes()
    assert data.startswith(CONTROLLER_HEADER)
    rows = parse(data, tmp_path, columns=CONTROLLER_COLUMNS)[0]
    by_input = {}
    for line in rows.values():
        fields = line.decode().rstrip("\n").split(",")
        verdict = fields[COLUMNS.index("simulated_verdict")]
        by_input.setdefault(fields[COLUMNS.index("step_time")], {})[fields[-1]] = verdict
    assert by_input == {
        "1.0": {"none": "stable", policy: "stable"},
        "0.4": {"none": by_input["0.4"]["none"], policy: by_input["0.4"]["none"]},
    }
    with pytest.raises(TableError, match="columns are those of a sweep with a controller key"):
        parse(data, tmp_path)  # an open-loop sweep will not resume into it


# --- command noise -----------------------------------------------------------------------------


def test_a_noisy_sweep_writes_each_seed_and_its_noise(tmp_path):
    """Two seeds of 0.05° noise (large, to move every row's numbers): two rows per trial,
    the noise column last, and the seeds' walks differ; the table reads as a noisy one."""
    from slopewalk.bench.tables.sweep import NOISE_COLUMNS, sweep_format

    config = tmp_path / "n.toml"
    config.write_text("seed = [0, 1]\ncommand_noise = 0.05\nsteps = 1\n[grid]\nstep_time = [1.0]\n")
    assert main(["sweep", str(config), "--workers", "1", "--out", str(tmp_path / "o")]) == 0
    table = tmp_path / "o" / "sweep.csv"
    rows = list(csv.DictReader(table.open()))
    assert table.read_text().splitlines()[0] == ",".join(NOISE_COLUMNS)
    assert [(r["seed"], r["command_noise_deg"]) for r in rows] == [("0", "0.05"), ("1", "0.05")]
    assert rows[0]["tracking_rms_deg"] != rows[1]["tracking_rms_deg"]
    assert len(sweep_format(NOISE_COLUMNS).read_rows(table)) == 2
    with pytest.raises(TableError, match="columns are those of a sweep with a command_noise key"):
        sweep_format(COLUMNS).read_rows(table)


def test_a_worker_plans_a_gait_once_for_its_frictions_and_modes_and_keeps_few_plans():
    """``plan_of``: the trials of one spec and gait get one plan object (the per-plan work
    is shared), a mass scaling is another robot and so another plan, and the worker keeps
    no more than ``PLANS_KEPT`` plans."""
    from slopewalk.bench.experiments.sweep import run

    data = {
        "steps": 1,
        "grid": [
            {"step_time": [1.0, 2.0], "slope": [0], "friction": [0.4, 1.0],
             "actuators": ["stiff", "servo"]},
            {"step_time": [1.0], "slope": [0], "friction": [1.0], "mass_scale": [{"all": 2}]},
        ],
    }  # fmt: skip
    trials = list(sweep_from_dict(data, base_dir=Path(".")).trials)
    groups: dict = {}
    for trial in trials:
        groups.setdefault(trial.plan_group, []).append(trial)
    assert len(groups) == 3  # two step times, and the heavier robot
    for members in groups.values():
        plans = {id(run.plan_of(t)) for t in members}
        assert len(plans) == 1  # kept while the group's trials run in a row
    assert len(run._plans) <= run.PLANS_KEPT
    for trial in trials:  # whatever it keeps, each trial walks its own robot and gait
        plan = run.plan_of(trial)
        assert plan.spec == trial.spec and plan.params == trial.gait()


def test_a_worker_holds_the_per_plan_work_of_the_plans_it_keeps_only():
    """A worker runs trials of two plans in turn: the work done once per plan (the loop's
    linearisation, the prediction) is let go with the plan it was done for, so a long
    sweep's worker does not grow (nothing kept may refer to its plan)."""
    import gc

    from slopewalk.bench.experiments.sweep import run
    from slopewalk.bench.sim import prediction
    from slopewalk.planner import servo_loop

    data = {"steps": 1, "grid": {"step_time": [1.0, 2.0], "slope": [0], "friction": [1.0, 0.6]}}
    for trial in sweep_from_dict(data, base_dir=Path(".")).trials:
        assert run.run_one(trial)["simulated_verdict"] != "error"
    gc.collect()
    for memo in (servo_loop._plan_linearisation, prediction._prediction_of):
        assert memo.plans_kept() <= run.PLANS_KEPT
