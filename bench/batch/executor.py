"""Run many independent jobs in parallel, one at a time per worker, surviving kills and crashes.

The generic half of a sweep (``sweep.py``) and of any other long batch of
trials: this module knows nothing of trials or tables. A job is a key (a
string) and the arguments of one call of a top-level function ``fn``; results
come back as ``(key, result)`` pairs in the order they finish, from jobs taken
lazily from an iterable (a million-job grid is never held as a list).

Two ways to run them:

- ``LocalPool``: worker processes forked from one server process
  (``multiprocessing``'s ``forkserver``; ``spawn`` where there is none). The server is
  a fresh interpreter, as a spawned worker is: it and the workers forked from it
  inherit no file descriptor of the caller, so never the lock of a results table,
  which an ``flock`` shares with every process that holds the same open file. The
  server imports, once, the job function's module and the pool's ``preload`` modules
  (``SERVER_PRELOAD`` first, which ties the server's life to the caller's), so a
  worker starts without the ~1.3 s of imports a spawned one pays each time, and
  ``start_server`` lets a command start it before its own imports, so the two import
  side by side. Each
  worker is given one job at a time over its own pipe (jobs that share work a worker
  keeps, a sweep's trials of one plan, go to one worker in a row: ``run``'s ``group``),
  so when a worker dies
  (a segfault in a native library, ``os._exit``, the OOM killer, ``kill -9``)
  the pool knows which job it held: that job comes back as a ``Lost`` with the
  cause ("worker died: signal 9 (SIGKILL)"), a fresh worker takes its place and
  the other jobs go on. Workers die with the main process: Linux's
  ``PR_SET_PDEATHSIG`` (set through ``ctypes``) kills a worker with SIGKILL
  when its parent exits, and a thread in each worker that watches its parent
  pid is the fallback elsewhere. Workers ignore SIGINT: Ctrl-C reaches the
  whole process group, and the main process decides.
- ``FuturesPool``: any ``concurrent.futures.Executor``, e.g. a Dask cluster's
  (``cluster.py``); at most ``window`` jobs are submitted at a time.
  An executor cannot say which job a lost worker held, so a failed future
  comes back as a ``Lost`` with ``known=False``: the caller should not blame
  the job for it. (Dask's ``KilledWorker``, raised for a task that its
  workers died running several times over, is the exception: ``known=True``.)
  An executor that says more (``cluster.Cluster``) sets the window itself
  (its ``window()``) and tells which workers it lost and which jobs each held
  (its ``lost_workers()``); the pool passes each on as a ``WorkerLost``.

``interruptible()`` turns SIGTERM (and SIGINT) into an ``Interrupted``
exception in the main thread, so a terminated run stops like a Ctrl-C one:
the caller keeps what it has written and exits non-zero with one line.
``held_interrupts()`` holds a Ctrl-C until the end of a block of compiled calls
(numba would turn it into a ``SystemError``; see there).
The progress display that goes with it is ``progress.py``.
"""

from __future__ import annotations

import contextlib
import ctypes
import itertools
import multiprocessing
import os
import pickle
import signal
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, Executor
from concurrent.futures import wait as wait_futures
from dataclasses import dataclass
from multiprocessing.connection import wait as wait_ready
from typing import Any

from slopewalk.planner.errors import SlopewalkError

PR_SET_PDEATHSIG = 1  # linux/prctl.h
START_METHOD = "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() else "spawn"
SERVER_PRELOAD = "slopewalk.bench.batch.server"  # the server dies with its caller (module doc)
# what a kernel batch's server imports after the job's module: a trial's cached kernel entries
KERNEL_PRELOAD = "slopewalk.planner.kernel.preload"
PARENT_POLL_S = 0.5  # [s] how often a worker checks that its parent lives (fallback)
WAIT_S = 0.5  # [s] longest wait of the main loop before it looks again
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
CLEAN_EXIT_S = 2.0  # [s] how long a pool left normally waits for its idle workers to exit
LOOKAHEAD = 64  # jobs a grouped run looks through for a worker's own group (``LocalPool.run``)
MAX_FAILED_STARTS = 3  # workers in a row that die before they are ready: the pool gives up


class ExecutorError(SlopewalkError):
    """The pool itself failed (e.g. a worker could not start); no job is to blame."""


class Interrupted(KeyboardInterrupt):
    """The run was asked to stop by a signal (SIGINT or SIGTERM)."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


@dataclass(frozen=True)
class Lost:
    """A job that returned nothing: its worker died, or the executor lost it.

    Attributes:
        cause: One line, e.g. "worker died: signal 9 (SIGKILL)".
        known: True when the job was certainly the one its dead worker held
            (``LocalPool``); False when an executor reported a failure that
            may have nothing to do with the job (``FuturesPool``).
    """

    cause: str
    known: bool = True


@dataclass(frozen=True)
class WorkerLost:
    """A worker an executor lost while jobs ran; the executor ran its jobs again elsewhere.

    Attributes:
        worker: The worker's address, e.g. "tcp://10.0.0.7:40123".
        cause: One line, e.g. "died or stopped answering".
        keys: The jobs it was running or held queued, resubmitted to the other workers.
    """

    worker: str
    cause: str
    keys: tuple[str, ...]


def one_line(err: BaseException) -> str:
    """An exception as one line: its type and message (the message alone for our errors)."""
    text = " ".join(str(err).split())
    if isinstance(err, SlopewalkError):
        return text
    return f"{type(err).__name__}: {text}" if text else type(err).__name__


_stop: dict[str, Any] = {"defer": 0, "pending": None}  # see _deferred_stop


@contextlib.contextmanager
def interruptible() -> Iterator[None]:
    """Within the block, SIGTERM and SIGINT raise ``Interrupted`` in the main thread."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, _frame):
        if _stop["defer"]:
            _stop["pending"] = signum
            return
        raise Interrupted(signum)

    previous = {s: signal.signal(s, handler) for s in STOP_SIGNALS}
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)


@contextlib.contextmanager
def _deferred_stop() -> Iterator[None]:
    """A stop signal in the block raises ``Interrupted`` only when the block is done."""
    _stop["defer"] += 1
    try:
        yield
    finally:
        _stop["defer"] -= 1
    pending, _stop["pending"] = _stop["pending"], None
    if pending is not None and not _stop["defer"]:
        raise Interrupted(pending)


@contextlib.contextmanager
def held_interrupts() -> Iterator[None]:
    """Within the block a Ctrl-C (SIGINT) is held, and raised when the block ends.

    For blocks that call compiled code which calls back into Python on its way
    out: numba boxes the arrays a kernel returns through ``_numba_unpickle``, the
    first Python code run after a long kernel, so a Ctrl-C during the kernel
    raises its ``KeyboardInterrupt`` inside that callback, and numba turns it
    into ``SystemError: ... returned a result with an exception set``: a
    traceback where the user should read ``slopewalk: interrupted``. Held, it is
    raised between two kernel calls instead. Under ``interruptible()`` its stop
    signals are held the same way (``_deferred_stop``); an ignored SIGINT (a
    pool worker's) stays ignored; outside the main thread nothing changes.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    if signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        with _deferred_stop():
            yield
        return
    held: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, _frame: held.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if held:
        raise KeyboardInterrupt


def death_cause(exitcode: int | None) -> str:
    """Why a worker process ended, from its ``exitcode`` (negative: killed by that signal)."""
    if exitcode is None:
        return "worker died"
    if exitcode < 0:
        try:
            name = signal.Signals(-exitcode).name
        except ValueError:
            name = "unknown signal"
        return f"worker died: signal {-exitcode} ({name})"
    return f"worker died: exit code {exitcode}"


def start_server(modules: Iterable[str]) -> None:
    """Start the fork server of this process's pools now, importing ``modules`` once
    (after ``SERVER_PRELOAD``; ``__main__`` is left out: a script's top level is not an
    import). Where it runs already, nothing changes: it keeps what it imported. The
    server and its workers end with this process. No server without ``forkserver``."""
    if START_METHOD != "forkserver":
        return
    from multiprocessing import forkserver

    names = [SERVER_PRELOAD, *dict.fromkeys(m for m in modules if m != "__main__")]
    forkserver.set_forkserver_preload(names)  # used only by the start below, if it starts
    forkserver.ensure_running()


def stop_server() -> None:
    """End this process's fork server, if it runs, and wait for it: the CPU time of the
    workers it forked then counts in this process's ``RUSAGE_CHILDREN`` (the benchmarks),
    and the next pool starts a fresh one."""
    if START_METHOD == "forkserver":
        from multiprocessing import forkserver

        # the one way there is (CPython's own tests use it; typeshed does not list it)
        forkserver._forkserver._stop()  # type: ignore[attr-defined]


# --- the worker side ------------------------------------------------------------------------------


def _die_with_parent(parent_pid: int) -> None:
    """Make this process end when ``parent_pid`` does: PR_SET_PDEATHSIG on the process that
    forked it (the fork server, which dies with ``parent_pid``: ``server.py``; or
    ``parent_pid`` itself, spawned), and a thread that watches both."""
    with contextlib.suppress(Exception):  # not Linux, or no libc: the thread below still watches
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    server = os.getppid()  # the main process, or the fork server it started

    def alive() -> bool:
        if os.getppid() != server:
            return False
        try:
            os.kill(parent_pid, 0)
        except ProcessLookupError:
            return False
        except OSError:
            pass
        return True

    if not alive():  # the parent died before the line above
        os._exit(1)

    def watch():
        while alive():
            time.sleep(PARENT_POLL_S)
        os._exit(1)

    threading.Thread(target=watch, daemon=True, name="parent-watch").start()


def _worker_main(conn, fn: Callable, parent_pid: int) -> None:
    """A worker: say ready, then run one job per message until told to stop or orphaned."""
    _die_with_parent(parent_pid)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the main process's to handle
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    try:
        conn.send(("ready", None, None))
        while (message := conn.recv()) is not None:
            key, args = message
            try:
                reply = (key, True, fn(*args))
            except Exception as err:  # fn should not raise; if it does, the job says why
                reply = (key, False, one_line(err))
            try:
                conn.send(reply)
            except (pickle.PicklingError, TypeError, AttributeError) as err:
                conn.send((key, False, f"result not sent: {one_line(err)}"))
    except (EOFError, OSError):  # the main process is gone or closed the pipe: nothing to say
        os._exit(0)


# --- the main side --------------------------------------------------------------------------------


class _Worker:
    def __init__(self, context, fn: Callable):
        ours, theirs = context.Pipe(duplex=True)
        self.conn = ours
        self.process = context.Process(
            target=_worker_main, args=(theirs, fn, os.getpid()), daemon=True
        )
        self.process.start()
        theirs.close()
        self.ready = False
        self.job: tuple[str, tuple] | None = None
        self.group: object = None  # its last job's group (``LocalPool.run``)

    def stop(self) -> None:
        with contextlib.suppress(Exception):
            self.process.kill()
        with contextlib.suppress(Exception):
            self.process.join(5)
        with contextlib.suppress(Exception):
            self.conn.close()


class LocalPool:
    """``workers`` spawned processes, one job at a time each (module doc).

    Use as a context manager; leaving it kills the workers at once.
    """

    def __init__(self, fn: Callable, *, workers: int | None = None, preload: tuple[str, ...] = ()):
        """
        Args:
            fn: A top-level function (picklable by reference); called as ``fn(*args)``.
            workers: Worker processes (default ``os.cpu_count()``), >= 1.
            preload: Modules the fork server imports after ``fn``'s (``start_server``).
        """
        self.fn = fn
        self.workers = workers or os.cpu_count() or 1
        if self.workers < 1:
            raise ExecutorError(f"workers = {self.workers}: must be >= 1")
        self._context = multiprocessing.get_context(START_METHOD)
        start_server((fn.__module__, *preload))
        self._pool: list[_Worker] = []
        self._failed_starts = 0  # in a row; a few are a killed worker, more a broken install

    def __enter__(self) -> LocalPool:
        return self

    def __exit__(self, *exc) -> None:
        self.close(clean=exc[0] is None)

    def close(self, *, clean: bool = False) -> None:
        """End every worker: killed now, or with ``clean`` (the pool left normally) told to
        stop and given ``CLEAN_EXIT_S`` to exit first, so their exit handlers run.

        A worker's exit handlers matter under the fork server: a lock made in it through
        ``multiprocessing`` (numba makes one as it starts its threads: an envelope's GA) is
        a named semaphore registered with the caller's resource tracker, and a killed
        worker leaves it there, which the tracker reports at the caller's exit as "leaked
        semaphore objects". Stopped or failed, the pool still kills at once.
        """
        if clean:
            for worker in self._pool:
                with contextlib.suppress(Exception):
                    worker.conn.send(None)  # its loop ends and the process exits by itself
            deadline = time.monotonic() + CLEAN_EXIT_S
            for worker in self._pool:
                with contextlib.suppress(Exception):
                    worker.process.join(max(0.0, deadline - time.monotonic()))
        for worker in self._pool:
            worker.stop()
        self._pool = []

    def run(
        self, jobs: Iterable[tuple[str, tuple]], group: Callable | None = None
    ) -> Iterator[tuple[str, object]]:
        """Run ``jobs`` (key, args) pairs; yield (key, result or ``Lost``) as each ends.

        ``group``: of a job's args, a hashable saying which jobs share work a worker keeps
        (a sweep's: the trials of one plan). A worker is then given, from the next
        ``LOOKAHEAD`` jobs, one of its last job's group first (``_pick``), so the
        group's jobs run in a row on one worker; None: the jobs in their order.

        Raises:
            ExecutorError: ``MAX_FAILED_STARTS`` workers in a row died before they
                were ready (a broken install).
        """
        jobs = iter(jobs)
        first = next(jobs, None)
        if first is None:
            return
        jobs = itertools.chain([first], jobs)
        ahead: list[tuple[object, tuple[str, tuple]]] = []  # the next (group, job), grouped
        retry: list[tuple[str, tuple]] = []  # jobs not delivered to a worker that had died
        more = True
        for _ in range(self.workers):
            self._start(len(self._pool))
        while True:
            for worker in self._pool:  # feed every ready, idle worker
                if more and worker.ready and worker.job is None:
                    job = retry.pop() if retry else self._next(worker, jobs, ahead, group)
                    if job is None:
                        more = False
                        break
                    worker.job = job
                    try:
                        worker.conn.send(job)
                    except OSError:  # it died idle: the job goes to the next worker
                        retry.append(job)
                        worker.job = None
            if not more and all(w.job is None for w in self._pool):
                return
            waits = [w.conn for w in self._pool] + [w.process.sentinel for w in self._pool]
            ready = set(wait_ready(waits, timeout=WAIT_S))
            for i, worker in enumerate(self._pool):
                if worker.conn in ready or worker.process.sentinel in ready:
                    outcome, dead = self._collect(worker)
                    if dead:
                        worker.stop()
                        self._start(i)
                    if outcome is not None:
                        yield outcome

    def _next(self, worker: _Worker, jobs: Iterator, ahead: list, group: Callable | None):
        """The next job for ``worker`` (``run``), or None when there is none left."""
        if group is None:
            return next(jobs, None)
        ahead.extend(
            (group(*job[1]), job) for job in itertools.islice(jobs, LOOKAHEAD - len(ahead))
        )
        if not ahead:
            return None
        others = {w.group for w in self._pool if w is not worker and w.job is not None}
        worker.group, job = ahead.pop(_pick([g for g, _ in ahead], worker.group, others))
        return job

    def _start(self, i: int) -> None:
        """A new worker in place ``i`` of the pool (appended at the end).

        SIGINT and SIGTERM wait until it is in the pool: stopped halfway, a
        spawn would leave a child reading its start-up data from a closed pipe.
        """
        with _deferred_stop():
            worker = _Worker(self._context, self.fn)
            if i < len(self._pool):
                self._pool[i] = worker
            else:
                self._pool.append(worker)

    def _collect(self, worker: _Worker) -> tuple[tuple[str, object] | None, bool]:
        """(the message from ``worker`` or its job as ``Lost`` if it died, whether it died)."""
        try:
            if worker.conn.poll():
                tag, ok, value = worker.conn.recv()
                if tag == "ready":
                    worker.ready = True
                    self._failed_starts = 0
                    return None, False
                worker.job = None
                return (tag, value if ok else Lost(value)), False
        except (EOFError, OSError):
            pass
        else:
            if worker.process.is_alive():
                return None, False  # woken by nothing: look again
        worker.process.join(WAIT_S)  # the pipe closed first; the exit code follows
        cause = death_cause(worker.process.exitcode)
        if not worker.ready:
            self._failed_starts += 1
            if self._failed_starts >= MAX_FAILED_STARTS:
                raise ExecutorError(f"workers cannot start ({cause})")
            return None, True
        if worker.job is None:  # died idle: nothing lost
            return None, True
        key, _ = worker.job
        worker.job = None
        return (key, Lost(cause)), True


def _pick(groups: list, mine: object, others: set) -> int:
    """Which of the next jobs (their ``groups``, in order) a worker takes: the first of its
    own last job's group ``mine``; else the first of a group no busy worker is on
    (``others``), so two workers do not split a group; else the first (a worker never
    waits for work while there is some)."""
    rules = (lambda g: g == mine, lambda g: g not in others)
    for wanted in rules if mine is not None else rules[1:]:
        for i, g in enumerate(groups):
            if wanted(g):
                return i
    return 0


class FuturesPool:
    """Any ``concurrent.futures`` executor, fed at most ``window`` jobs at a time.

    ``window``: an int, or None for the executor's own ``window()`` (a ``cluster.Cluster``:
    from the threads of its workers, asked again as they come and go) or else 64. An
    executor with a ``lost_workers()`` method (returning ``(worker, cause, futures)``
    triples since the last call) has each loss passed on by ``run`` as a ``WorkerLost``.
    """

    def __init__(self, fn: Callable, executor: Executor, *, window: int | None = None):
        self.fn, self.executor = fn, executor
        own = getattr(executor, "window", None)
        self.window: Callable[[], int] = (
            (lambda: window) if window is not None else own if callable(own) else (lambda: 64)
        )
        self._lost = getattr(executor, "lost_workers", None)
        self._pending: dict = {}

    def __enter__(self) -> FuturesPool:
        return self

    def __exit__(self, *exc) -> None:
        for future in self._pending:
            future.cancel()
        self._pending = {}

    def run(
        self, jobs: Iterable[tuple[str, tuple]], group: Callable | None = None
    ) -> Iterator[tuple[str | None, object]]:
        """As ``LocalPool.run``; a failed future is a ``Lost(cause, known=False)``, and a
        lost worker a ``(None, WorkerLost)`` pair (its jobs' results come later, from
        elsewhere). ``group`` is not used: the executor places the jobs."""
        jobs = iter(jobs)
        more = True
        while True:
            window = max(1, self.window())
            while more and len(self._pending) < window:
                job = next(jobs, None)
                if job is None:
                    more = False
                    break
                key, args = job
                self._pending[self.executor.submit(self.fn, *args)] = key
            yield from self._worker_losses()
            if not self._pending:
                return
            done, _ = wait_futures(list(self._pending), timeout=WAIT_S, return_when=FIRST_COMPLETED)
            for future in done:
                key = self._pending.pop(future)
                try:
                    yield key, future.result()
                except Exception as err:
                    # Dask's KilledWorker names the task whose workers kept dying: that one's fault
                    known = type(err).__name__ == "KilledWorker"
                    yield key, Lost(one_line(err), known=known)

    def _worker_losses(self) -> Iterator[tuple[None, WorkerLost]]:
        """The workers the executor says it lost since the last look, with our jobs they held."""
        for worker, cause, futures in self._lost() if self._lost is not None else ():
            keys = tuple(self._pending[f] for f in futures if f in self._pending)
            yield None, WorkerLost(worker, cause, keys)
