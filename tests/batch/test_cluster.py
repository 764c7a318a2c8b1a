"""Sweeps on a real Dask cluster: a scheduler and two workers, each its own process.

The workers run in a folder of their own, as on other nodes, so a path that travels
relative lands there and not where the client looks. They are started with
``--no-nanny``, so a SIGKILL ends a worker for good (a nanny would start it again).
Every process is started in its own session and killed whole on the way out.
"""

import contextlib
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from slopewalk.bench.batch import cluster as cluster_module
from slopewalk.bench.batch.executor import ExecutorError
from slopewalk.bench.cli import main
from slopewalk.bench.robot_import.model_file import contents_digest

distributed = pytest.importorskip("distributed")
pytestmark = pytest.mark.slow  # about 40 s on the 2-core machine; .ci/run runs them

PYTHON = sys.executable
TINY = """\
description = "two one-step trials"
steps = 1
seed = 0
[grid]
step_time = [0.5]
friction = [0.6, 1.0]
"""
SIX = TINY.replace("friction = [0.6, 1.0]", "friction = [0.5, 0.6, 0.7, 0.8, 0.9, 1.0]")
START_S = 60.0  # [s] the longest wait for a process of the cluster to be up


@contextlib.contextmanager
def _process(command: list[str], cwd: Path, log: Path):
    """``command`` in its own session, output to ``log``; SIGKILLed whole on the way out."""
    with open(log, "w") as out:
        proc = subprocess.Popen(command, cwd=cwd, stdout=out, stderr=out, start_new_session=True)
    try:
        yield proc
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()


def _scheduler(stack: contextlib.ExitStack, folder: Path) -> str:
    """A scheduler on a free port of 127.0.0.1 (port 0: the system picks); its address."""
    folder.mkdir(parents=True, exist_ok=True)
    info = folder / "scheduler.json"
    command = [PYTHON, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1"]
    command += ["--port", "0", "--no-dashboard", "--scheduler-file", str(info)]
    proc = stack.enter_context(_process(command, folder, folder / "scheduler.log"))
    deadline = time.monotonic() + START_S
    while not info.exists() or not info.read_text().strip():
        assert proc.poll() is None, (folder / "scheduler.log").read_text()
        assert time.monotonic() < deadline, "the scheduler did not start"
        time.sleep(0.05)
    return json.loads(info.read_text())["address"]


def _worker(stack: contextlib.ExitStack, address: str, folder: Path, name: str):
    """A one-thread worker named ``name`` working in ``folder`` (a node's own directory)."""
    command = [PYTHON, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1"]
    command += ["--no-nanny", "--no-dashboard", "--name", name, "--host", "127.0.0.1"]
    return stack.enter_context(_process(command, folder, folder / f"{name}.log"))


@pytest.fixture(scope="module")
def dask_cluster(tmp_path_factory):
    """A scheduler and two workers, separate processes: (address, {name: process}, their folder)."""
    root = tmp_path_factory.mktemp("cluster")
    nodes = root / "nodes"
    nodes.mkdir()
    with contextlib.ExitStack() as stack:
        address = _scheduler(stack, root / "scheduler")
        workers = {name: _worker(stack, address, nodes, name) for name in ("w0", "w1")}
        with distributed.Client(address, timeout=START_S, set_as_default=False) as client:
            client.wait_for_workers(2, timeout=START_S)
        yield address, workers, nodes


def _sweep_file(folder: Path, text: str) -> Path:
    path = folder / "tiny.toml"
    path.write_text(text)
    return path


def test_a_relative_out_records_where_the_client_looks_and_resumes(
    dask_cluster, tmp_path, monkeypatch, capsys
):
    address, _, nodes = dask_cluster
    monkeypatch.chdir(tmp_path)
    config = _sweep_file(tmp_path, TINY)
    flags = ["--cluster", address, "--out", "relrec", "--record"]
    assert main(["sweep", str(config), *flags]) == 0
    recordings = sorted((tmp_path / "relrec" / "recordings").glob("*.rrd"))
    rows = (tmp_path / "relrec" / "sweep.csv").read_text().splitlines()[1:]
    assert [r.name for r in recordings] == sorted(f"{r.split(',')[0]}.rrd" for r in rows)
    assert len(recordings) == 2 and not (nodes / "relrec").exists()
    recordings[0].unlink()  # resume finds the other recording and plays only this trial
    capsys.readouterr()
    assert main(["sweep", str(config), *flags, "--resume"]) == 0
    out = capsys.readouterr().out
    assert "2 trials: 1 run, 1 already done, 0 errors, 0 lost" in out
    assert recordings[0].exists()


def test_a_relative_model_reaches_the_workers_absolute_and_checked(
    dask_cluster, tmp_path, monkeypatch
):
    """``--model`` relative to the client's folder: the workers, in their own folder, play
    it (its absolute path and digest travel with each trial), every row marked with it."""
    address, _, _ = dask_cluster
    robots = Path(__file__).parents[1] / "robots"
    for name in ("walker.xml", "walker-map.toml"):
        (tmp_path / name).write_bytes((robots / name).read_bytes())
    monkeypatch.chdir(tmp_path)
    config = _sweep_file(tmp_path, "steps = 1\n[grid]\nstep_time = [1.0]\nslope = [0, 6]\n")
    flags = ["--cluster", address, "--out", "walker", "--model", "walker.xml"]
    assert main(["sweep", str(config), *flags, "--map", "walker-map.toml"]) == 0
    lines = (tmp_path / "walker" / "sweep.csv").read_text().splitlines()
    assert lines[0].endswith(",error,model,model_digest") and len(lines) == 3
    digest = contents_digest(robots / "walker.xml", robots / "walker-map.toml")[:16]
    assert all(line.endswith(f",,walker,sha256:{digest}") for line in lines[1:]), lines


def test_the_window_follows_the_workers_threads_not_this_machines_cores(dask_cluster, monkeypatch):
    address, _, _ = dask_cluster
    monkeypatch.setattr(os, "cpu_count", lambda: 256)  # the client's cores count for nothing
    with cluster_module.open_cluster(address) as cluster:
        assert cluster.window() == cluster_module.PER_THREAD * 2  # two workers, one thread each
    with cluster_module.open_cluster(address, in_flight=3) as cluster:
        assert cluster.window() == 3


def test_a_worker_with_other_code_is_refused_in_one_line(dask_cluster, monkeypatch):
    address, _, _ = dask_cluster
    monkeypatch.setattr(cluster_module, "code_identity", lambda: "0.0.1 000000000000")
    with pytest.raises(ExecutorError) as refused:
        with cluster_module.open_cluster(address):
            pass
    message = str(refused.value)
    assert "runs slopewalk 0.1.0 " in message and "this client 0.0.1 000000000000" in message
    assert "docs/cluster.md" in message and "\n" not in message


def test_a_job_on_a_worker_with_other_code_is_lost_never_run(dask_cluster, monkeypatch):
    """Each job checks the code of the worker it lands on (here, before the client asks)."""
    address, _, _ = dask_cluster
    monkeypatch.setattr(cluster_module, "code_identity", lambda: "0.0.1 000000000000")
    with distributed.Client(address, timeout=START_S, set_as_default=False) as client:
        cluster = cluster_module.Cluster(client, address, in_flight=None, join_timeout=5)
        future = cluster.submit(os.getpid)
        with pytest.raises(
            ExecutorError, match="a worker runs slopewalk 0.1.0 .*, this client 0.0.1"
        ):
            future.result(timeout=START_S)


def _busy_worker(address: str, names: dict[str, object], timeout: float = START_S) -> str:
    """The name of a worker the scheduler has a task on (running or queued there)."""
    deadline = time.monotonic() + timeout
    with distributed.Client(address, timeout=START_S, set_as_default=False) as client:
        while time.monotonic() < deadline:
            info = client.scheduler_info()["workers"]
            for worker, keys in client.processing().items():
                if keys and info.get(worker, {}).get("name") in names:
                    return info[worker]["name"]
            time.sleep(0.01)
    raise AssertionError("no worker holds a trial")


def test_a_killed_worker_is_reported_and_its_trials_finish_elsewhere(dask_cluster, tmp_path):
    """Run last in this module: it leaves one worker."""
    address, workers, _ = dask_cluster
    config = _sweep_file(tmp_path, SIX)
    out = tmp_path / "out"
    command = [PYTHON, "-m", "slopewalk.bench.cli", "sweep", str(config), "--out", str(out)]
    with _process([*command, "--cluster", address], tmp_path, tmp_path / "sweep.log") as sweep:
        victim = _busy_worker(address, workers)
        workers[victim].send_signal(signal.SIGKILL)
        assert sweep.wait(timeout=300) == 0, (tmp_path / "sweep.log").read_text()
    log = (tmp_path / "sweep.log").read_text()
    assert len((out / "sweep.csv").read_text().splitlines()) == 1 + 6  # every trial's row
    lost = [line for line in log.splitlines() if "lost (died or stopped answering)" in line]
    assert len(lost) == 2, log  # said when it happened, and again in the summary
    assert lost[0].startswith("sweep: worker tcp://127.0.0.1:")
    assert lost[1] == lost[0].removeprefix("sweep: ")
    assert "; resubmitted to the other workers, the " in lost[0]
    assert " trials it held: T=0.5 s" in lost[0]
    assert "6 trials: 6 run, 0 already done, 0 errors, 0 lost" in log


def test_no_worker_is_one_line_after_the_join_timeout(tmp_path, capsys):
    config = _sweep_file(tmp_path, TINY)
    with contextlib.ExitStack() as stack:
        address = _scheduler(stack, tmp_path / "lonely")
        flags = ["--cluster", address, "--join-timeout", "0.5", "--out", str(tmp_path / "o")]
        assert main(["sweep", str(config), *flags]) == 2
    err = capsys.readouterr().err
    assert err == (
        f"slopewalk: error: cluster {address}: no worker joined within 0.5 s (--join-timeout); "
        f"start one on each node with 'dask worker {address}' (docs/cluster.md)\n"
    )
    assert not (tmp_path / "o" / "sweep.partial.csv").exists()
