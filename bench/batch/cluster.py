"""A Dask cluster as the executor of a batch: its workers, their code, their losses.

``slopewalk sweep --cluster ADDRESS`` (and ``envelope``) run their jobs on the workers of
a Dask scheduler (how to start one: docs/cluster.md). ``open_cluster`` connects a
``distributed.Client`` and gives a ``Cluster``, the ``concurrent.futures.Executor`` that
``executor.FuturesPool`` feeds, which also:

- waits at most ``join_timeout`` seconds for a first worker, and stops a run whose
  workers have all been gone that long, with one line that says how to start one;
- checks that every worker, those that join later included, runs this slopewalk: its
  version and a sha256 of its source (``code_identity``); a worker that differs stops
  the run with one line naming it. Each job checks it too before it runs (``_run_checked``),
  so no row ever comes from other code, even in the moments before a new worker is asked;
- keeps ``window()`` jobs in flight: ``in_flight`` if given, else ``PER_THREAD`` per
  worker thread connected, read again every ``REFRESH_S`` (so neither the client's
  cores nor its ``--workers`` matter);
- says which workers the scheduler removed while jobs ran and which of this client's
  jobs each was running or held queued (``lost_workers``). Dask gives those jobs to
  the other workers, so their rows still come, from elsewhere.

Paths travel to the workers as they are and a worker's working directory is its own,
so the caller makes them absolute (``run.run_batch`` does, for the recordings).
"""

from __future__ import annotations

import contextlib
import hashlib
import math
import threading
import time
from collections.abc import Iterator
from concurrent.futures import CancelledError, Executor, Future
from functools import lru_cache
from pathlib import Path

import slopewalk.planner as planner_package
from slopewalk.bench.batch.executor import ExecutorError, one_line
from slopewalk.bench.digest import code_digest
from slopewalk.bench.flags import JOIN_TIMEOUT_S

PER_THREAD = 2  # jobs in flight per worker thread: one running, the next already there
REFRESH_S = 2.0  # [s] how often the workers connected are asked for again
CONNECT_TIMEOUT_S = 10.0  # [s] to reach the scheduler
SOURCE_PATTERNS = ("**/*.py", "**/*.toml")
DOCS = "docs/cluster.md"


@lru_cache(maxsize=1)
def code_identity() -> str:
    """This process's slopewalk, e.g. "0.1.0 3f2a9c01be47": the installed version and the
    first 12 hex digits of a sha256 over the source digests (``digest.code_digest``,
    ``.py`` and ``.toml``) of the planner and the bench. Two processes that play a trial
    alike show the same."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        installed = version("slopewalk")
    except PackageNotFoundError:
        installed = "unknown"
    roots = (Path(planner_package.__path__[0]), _BENCH)
    digests = "".join(code_digest(SOURCE_PATTERNS, root) for root in roots)
    return f"{installed} {hashlib.sha256(digests.encode()).hexdigest()[:12]}"


_BENCH = Path(__file__).resolve().parents[1]


def _worker_identity() -> str:
    """``code_identity`` as a worker computes it (run there by ``Client.run``)."""
    return code_identity()


def _run_checked(identity: str, fn, *args, **kwargs):
    """``fn(*args, **kwargs)`` on a worker, if its ``code_identity`` is ``identity``.

    Raises:
        ExecutorError: the worker runs other code (its job is lost, never a row).
    """
    theirs = code_identity()
    if theirs != identity:
        raise ExecutorError(
            f"a worker runs slopewalk {theirs}, this client {identity}; install the same "
            f"version on every node ({DOCS})"
        )
    return fn(*args, **kwargs)


class Cluster(Executor):
    """The workers of a Dask scheduler as an executor (module doc); ``open_cluster`` makes one.

    Args:
        client: A connected ``distributed.Client``.
        address: The scheduler's address, for messages.
        in_flight: Jobs submitted at a time, >= 1; None: ``PER_THREAD`` per worker thread.
        join_timeout: [s] how long a run waits with no worker before it stops, > 0.
    """

    def __init__(self, client, address: str, *, in_flight: int | None, join_timeout: float):
        self.client, self.address = client, address
        self.in_flight, self.join_timeout = in_flight, join_timeout
        self._lock = threading.Lock()
        self._running: dict[str, tuple[object, Future]] = {}  # Dask key -> its two futures
        self._losses: list[tuple[str, str, tuple[Future, ...]]] = []
        self._threads: dict[str, int] = {}  # worker address -> threads, as last asked
        self._checked: set[str] = set()  # workers whose code_identity is ours
        self._asked = -math.inf  # when the workers were last asked for
        self._alone_since: float | None = None  # since when no worker is connected
        client.subscribe_topic("all", self._on_event)

    # --- the executor -----------------------------------------------------------------------

    def submit(self, fn, /, *args, **kwargs) -> Future:
        """Run ``fn(*args, **kwargs)`` on a worker; a ``concurrent.futures.Future`` of it."""
        task = self.client.submit(_run_checked, code_identity(), fn, *args, pure=False, **kwargs)
        future: Future = Future()
        with self._lock:
            self._running[task.key] = (task, future)

        def settle(_task) -> None:  # in a thread of the client's, once the task is done
            with self._lock:
                self._running.pop(task.key, None)
            if not future.set_running_or_notify_cancel():
                return
            try:
                future.set_result(task.result())
            except CancelledError:
                future.set_exception(ExecutorError("cancelled by the scheduler"))
            except BaseException as err:
                future.set_exception(err)

        def cancel(done: Future) -> None:
            if done.cancelled():
                task.cancel()

        future.add_done_callback(cancel)
        task.add_done_callback(settle)
        return future

    def window(self) -> int:
        """Jobs to keep in flight now: ``in_flight``, or ``PER_THREAD`` per worker thread.

        Raises:
            ExecutorError: no worker for ``join_timeout`` seconds, or one runs other code.
        """
        self._ask_workers()
        return self.in_flight or max(1, PER_THREAD * sum(self._threads.values()))

    def lost_workers(self) -> list[tuple[str, str, tuple[Future, ...]]]:
        """(worker, cause, the futures it ran or held) per worker removed since the last call."""
        self._ask_workers()
        with self._lock:
            losses, self._losses = self._losses, []
        return losses

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        with self._lock:
            running = [future for _, future in self._running.values()]
        if cancel_futures:
            for future in running:
                future.cancel()

    # --- the workers ------------------------------------------------------------------------

    def wait_for_workers(self) -> None:
        """Return once a worker is connected and runs our code.

        Raises:
            ExecutorError: none joined within ``join_timeout`` seconds.
        """
        try:
            self.client.wait_for_workers(1, timeout=self.join_timeout)
        except TimeoutError:  # distributed's WorkerStartTimeoutError is one
            raise ExecutorError(self._no_worker("joined")) from None
        except Exception as err:
            raise ExecutorError(f"cluster {self.address}: {one_line(err)}") from None
        self._asked = -math.inf
        self._ask_workers()

    def _no_worker(self, what: str) -> str:
        return (
            f"cluster {self.address}: no worker {what} within {self.join_timeout:g} s "
            f"(--join-timeout); start one on each node with 'dask worker {self.address}' "
            f"({DOCS})"
        )

    def _ask_workers(self) -> None:
        """Read the workers and their threads (every ``REFRESH_S``); check the new ones' code."""
        now = time.monotonic()
        if now - self._asked < REFRESH_S:
            return
        self._asked = now
        self._threads = dict(self.client.nthreads())
        if not self._threads:
            self._alone_since = self._alone_since or now
            if now - self._alone_since > self.join_timeout:
                raise ExecutorError(self._no_worker("connected"))
            return
        self._alone_since = None
        new = sorted(set(self._threads) - self._checked)
        if new:
            self._check_code(new)

    def _check_code(self, workers: list[str]) -> None:
        """Refuse a worker whose slopewalk is not this client's (``code_identity``)."""
        ours = code_identity()
        found = self.client.run(_worker_identity, workers=workers, on_error="return")
        for worker in workers:
            theirs = found.get(worker)
            if theirs is None:  # gone before it answered; asked again if it comes back
                continue
            if isinstance(theirs, BaseException):
                raise ExecutorError(
                    f"cluster {self.address}: worker {worker} cannot run slopewalk "
                    f"({one_line(theirs)}); install this slopewalk there ({DOCS})"
                )
            if theirs != ours:
                raise ExecutorError(
                    f"cluster {self.address}: worker {worker} runs slopewalk {theirs}, this "
                    f"client {ours}; install the same version on every node ({DOCS})"
                )
            self._checked.add(worker)

    def _on_event(self, event) -> None:
        """A scheduler event (in the client's thread): note each worker removed."""
        _, message = event
        if not isinstance(message, dict) or message.get("action") != "remove-worker":
            return
        cause = (
            "closed by its owner or the scheduler"
            if message.get("expected")
            else "died or stopped answering"
        )
        with self._lock:
            held = tuple(
                self._running[key][1]
                for key in message.get("processing-tasks", ())
                if key in self._running
            )
            self._losses.append((str(message.get("worker", "?")), cause, held))
        self._asked = -math.inf  # the window follows the threads left


@contextlib.contextmanager
def open_cluster(
    address: str, *, in_flight: int | None = None, join_timeout: float = JOIN_TIMEOUT_S
) -> Iterator[Cluster]:
    """A ``Cluster`` on the Dask scheduler at ``address``, once a worker has joined.

    Args:
        address: e.g. ``tcp://host:8786``.
        in_flight: Jobs submitted at a time; None: ``PER_THREAD`` per worker thread.
        join_timeout: [s] the longest wait for a worker, at the start and later.

    Raises:
        ExecutorError: Dask is not installed, the address is malformed or cannot be
            reached, no worker joins in time, or a worker runs other code.
    """
    try:
        from distributed import Client
    except ImportError:
        raise ExecutorError("--cluster needs Dask: pip install 'dask[distributed]'") from None
    from distributed.comm.addressing import parse_address, parse_host_port

    try:  # a malformed address, refused before a Client exists (its __del__ would hang)
        scheme, location = parse_address(address, strict=True)
        if scheme in ("tcp", "tls"):
            parse_host_port(location)
    except ValueError as err:
        raise ExecutorError(
            f"cluster {address!r}: not a scheduler address like tcp://host:8786 ({err})"
        ) from None
    try:
        client = Client(address, timeout=CONNECT_TIMEOUT_S, set_as_default=False)
    except Exception as err:
        raise ExecutorError(f"cluster {address!r}: cannot connect ({one_line(err)})") from None
    try:
        cluster = Cluster(client, address, in_flight=in_flight, join_timeout=join_timeout)
        cluster.wait_for_workers()
        yield cluster
    finally:
        client.close()
