"""The job executor: one job per worker at a time, deaths cost only their job, nothing inherited."""

import ctypes
import fcntl
import itertools
import os
import signal
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor

import pytest
from conftest import left_in_session, session_pids

from slopewalk.bench.batch.executor import (
    LOOKAHEAD,
    START_METHOD,
    FuturesPool,
    Interrupted,
    LocalPool,
    Lost,
    WorkerLost,
    _pick,
    death_cause,
    interruptible,
    stop_server,
)

FORKSERVER = pytest.mark.skipif(START_METHOD != "forkserver", reason="no fork server here: spawn")


def job(kind: str, value: int):
    """The test's job (top level, so spawned workers import it): some of them kill their worker."""
    if kind == "exit":
        os._exit(3)
    if kind == "segfault":
        ctypes.string_at(0)  # reads address 0: SIGSEGV
    if kind == "raise":
        raise ValueError(f"bad value {value}")
    if kind == "sleep":
        time.sleep(value)
    return value * 2


def open_inodes(_kind: str, _value: int) -> set[tuple[int, int]]:
    """(device, inode) of every file this process has open."""
    out = set()
    for name in os.listdir("/proc/self/fd"):
        try:
            st = os.stat(f"/proc/self/fd/{name}")
        except OSError:
            continue
        out.add((st.st_dev, st.st_ino))
    return out


def test_a_dying_job_costs_only_itself_and_the_others_finish():
    jobs = [(f"ok{i}", ("ok", i)) for i in range(6)]
    jobs[1] = ("exit", ("exit", 0))
    jobs[3] = ("segfault", ("segfault", 0))
    jobs[4] = ("raise", ("raise", 7))
    with LocalPool(job, workers=2) as pool:
        results = dict(pool.run(jobs))
    assert results.pop("exit") == Lost("worker died: exit code 3")
    assert results.pop("segfault") == Lost("worker died: signal 11 (SIGSEGV)")
    assert results.pop("raise") == Lost("ValueError: bad value 7")
    assert results == {"ok0": 0, "ok2": 4, "ok5": 10}


def test_a_job_that_always_kills_its_worker_does_not_stop_the_pool():
    jobs = [("exit", ("exit", 0))] * 5 + [("ok", ("ok", 21))]
    with LocalPool(job, workers=1) as pool:
        results = list(pool.run(jobs))
    assert results[:5] == [("exit", Lost("worker died: exit code 3"))] * 5
    assert results[5] == ("ok", 42)


def test_jobs_are_taken_lazily_and_leaving_stops_the_workers():
    taken = itertools.count()
    endless = ((str(i), ("ok", i)) for i in taken)
    with LocalPool(job, workers=2) as pool:
        for n, _ in enumerate(pool.run(endless), start=1):
            if n == 5:
                break
        processes = [w.process for w in pool._pool]
    assert next(taken) <= 5 + 2 + 1  # what was asked for, plus one in flight per worker
    assert all(not p.is_alive() for p in processes)


def test_a_worker_takes_its_own_group_first_then_one_no_busy_worker_is_on():
    """``_pick``: the next jobs' groups, the worker's last group, the busy workers' groups."""
    assert _pick(["b", "a", "a"], "a", {"b"}) == 1  # its own group, though not first
    assert _pick(["b", "b", "c"], "a", {"b"}) == 2  # not the group another worker is on
    assert _pick(["b", "b"], "a", {"b"}) == 0  # only that: it still works, never waits
    assert _pick(["b", "c"], None, set()) == 0  # a fresh worker among idle ones: in order


def grouped_job(group: str, i: int) -> tuple[str, int]:
    """The grouped test's job: its group and the worker that ran it."""
    time.sleep(0.02)
    return group, os.getpid()


def test_grouped_jobs_all_run_once_and_the_first_group_stays_with_one_worker():
    """Two workers, three groups of 4 jobs interleaved in the job order (a, b, c, a, ...):
    every job runs once, and the first job's group runs on the worker that took it (the
    other worker is never without another group's job until that group is done)."""
    jobs = [(f"{g}{i}", (g, i)) for i in range(4) for g in "abc"]
    assert len(jobs) < LOOKAHEAD
    with LocalPool(grouped_job, workers=2) as pool:
        results = list(pool.run(jobs, group=lambda g, _i: g))
    assert sorted(k for k, _ in results) == sorted(k for k, _ in jobs)
    assert len({pid for _, (g, pid) in results if g == "a"}) == 1


def test_workers_hold_no_file_of_the_parent(tmp_path):
    lock = tmp_path / "table.csv"
    fd = os.open(lock, os.O_RDWR | os.O_CREAT)
    fcntl.flock(fd, fcntl.LOCK_EX)
    try:
        st = os.fstat(fd)
        stop_server()  # the workers' fork server starts now, while the lock is held
        with LocalPool(open_inodes, workers=1) as pool:
            [(_, inodes)] = list(pool.run([("fds", ("", 0))]))
    finally:
        os.close(fd)
    assert (st.st_dev, st.st_ino) not in inodes  # so never the table's flock


def imported(_kind: str, module: str) -> tuple[bool, int]:
    """Whether ``module`` is imported in this worker before its job, and the worker's pid."""
    return module in sys.modules, os.getpid()  # the pid: a job's worker, for a failure's say


@FORKSERVER
def test_workers_start_with_the_preload_their_server_imported():
    stop_server()  # a fresh server, started by this pool with its preload
    module = "mailbox"  # nothing of the job's module (nor of the server's own) imports it
    jobs = [(str(i), ("", module)) for i in range(4)]
    with LocalPool(imported, workers=2, preload=(module,)) as pool:
        results = dict(pool.run(jobs))
    assert len(results) == 4 and all(seen for seen, _ in results.values())


SLOW_SERVER_SCRIPT = """
import time
from slopewalk.bench.batch.executor import start_server

if __name__ == "__main__":
    start_server(["slow_import"])  # the server sleeps 60 s importing it
    print("started", flush=True)
    time.sleep(60)
"""


@FORKSERVER
def test_the_fork_server_dies_with_its_killed_caller_even_while_importing(tmp_path):
    importing = tmp_path / "importing"
    (tmp_path / "slow_import.py").write_text(
        f"import pathlib, time\npathlib.Path({str(importing)!r}).touch()\ntime.sleep(60)\n"
    )
    script = tmp_path / "server.py"
    script.write_text(SLOW_SERVER_SCRIPT)
    path = os.pathsep.join(filter(None, [str(tmp_path), os.environ.get("PYTHONPATH")]))
    proc = subprocess.Popen(  # the server finds slow_import on PYTHONPATH (its sys.path's)
        [sys.executable, str(script)],
        start_new_session=True,
        stdout=subprocess.PIPE,
        text=True,
        env=dict(os.environ, PYTHONPATH=path),
    )
    try:
        assert proc.stdout.readline() == "started\n"
        deadline = time.monotonic() + 30
        while not importing.exists() and time.monotonic() < deadline:
            time.sleep(0.05)
        # the caller, the resource tracker and the fork server, asleep in its import
        assert len(session_pids(proc.pid)) == 3
        proc.kill()
        proc.wait()
        assert left_in_session(proc.pid, within=3) == [], "the fork server outlived its caller"
    finally:
        for pid in session_pids(proc.pid):
            os.kill(pid, signal.SIGKILL)


LOCK_SCRIPT = """
import multiprocessing
from slopewalk.bench.batch.executor import LocalPool

LOCKS = []


def make_lock(_key):
    LOCKS.append(multiprocessing.get_context().RLock())  # as numba does, starting its threads
    return len(LOCKS)


if __name__ == "__main__":
    with LocalPool(make_lock, workers=2) as pool:
        print(len([n for _, n in pool.run([(str(i), (i,)) for i in range(4)]) if n > 0]))
"""


def test_a_pool_left_normally_leaves_its_callers_exit_quiet(tmp_path):
    """A lock a worker makes through ``multiprocessing`` (numba's, in an envelope's GA) is,
    under the fork server, a semaphore the caller's resource tracker holds until the
    worker's exit handlers drop it: killed workers made every envelope end with a "leaked
    semaphore objects" warning."""
    script = tmp_path / "locks.py"
    script.write_text(LOCK_SCRIPT)
    done = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "4"  # every job made its lock
    assert "leaked" not in done.stderr and "Warning" not in done.stderr, done.stderr


def test_a_failed_future_is_lost_without_blame():
    with ThreadPoolExecutor(1) as executor, FuturesPool(job, executor, window=2) as pool:
        results = dict(pool.run([("a", ("ok", 1)), ("b", ("raise", 2))]))
    assert results == {"a": 2, "b": Lost("ValueError: bad value 2", known=False)}


class _SmallCluster(ThreadPoolExecutor):
    """An executor that sets its own window and loses a worker holding its first future."""

    def __init__(self):
        super().__init__(4)
        self.futures, self.most = [], 0
        self.reported = False

    def window(self) -> int:
        return 2

    def submit(self, fn, *args):
        self.futures.append(super().submit(fn, *args))
        self.most = max(self.most, sum(not f.done() for f in self.futures))
        return self.futures[-1]

    def lost_workers(self):
        if self.reported or not self.futures:
            return []
        self.reported = True
        return [("tcp://node:1", "died", (self.futures[0],))]


def test_an_executor_sets_its_window_and_reports_its_lost_workers():
    jobs = [(k, ("sleep", 0.05)) for k in "abcdef"]
    with _SmallCluster() as executor, FuturesPool(job, executor) as pool:
        results = list(pool.run(jobs))
    assert executor.most <= 2 < len(jobs)  # the executor's window, not 64
    assert sorted(k for k, _ in results if k is not None) == list("abcdef")
    assert [r for k, r in results if k is None] == [WorkerLost("tcp://node:1", "died", ("a",))]


def test_sigterm_interrupts_like_sigint():
    with pytest.raises(Interrupted) as stop, interruptible():
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(5)
    assert stop.value.signum == signal.SIGTERM and isinstance(stop.value, KeyboardInterrupt)
    assert signal.getsignal(signal.SIGTERM) == signal.SIG_DFL


def test_death_causes_read_as_words():
    assert death_cause(-9) == "worker died: signal 9 (SIGKILL)"
    assert death_cause(1) == "worker died: exit code 1"


ORPHAN_SCRIPT = """
import time
from slopewalk.bench.batch.executor import LocalPool

def nap(seconds):
    time.sleep(seconds)

if __name__ == "__main__":
    with LocalPool(nap, workers=2) as pool:
        print("running", flush=True)
        for _ in pool.run([("a", (60,)), ("b", (60,))]):
            pass
"""


def test_busy_workers_die_with_their_killed_parent(tmp_path):
    script = tmp_path / "orphans.py"
    script.write_text(ORPHAN_SCRIPT)
    proc = subprocess.Popen(
        [sys.executable, str(script)], start_new_session=True, stdout=subprocess.PIPE, text=True
    )
    try:
        assert proc.stdout.readline() == "running\n"
        deadline = time.monotonic() + 30
        # the parent, its 2 workers, the resource tracker (and the workers' fork server)
        least = 5 if START_METHOD == "forkserver" else 4
        while len(session_pids(proc.pid)) < least and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(1.0)  # the workers are asleep in their 60 s jobs
        proc.kill()
        proc.wait()
        assert left_in_session(proc.pid, within=3) == [], "workers outlived their parent"
    finally:
        for pid in session_pids(proc.pid):
            os.kill(pid, signal.SIGKILL)
