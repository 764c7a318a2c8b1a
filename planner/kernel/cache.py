"""Where the compiled kernel is cached, each module under its own key, and the cold start's line.

numba keys a cached function by its own source file only, not by the files of the
functions it calls: a changed ``sample.py`` would meet a cached ``run.py`` compiled
against the old one. So each kernel module's key (``module_key``) is a hash of its
file and of the kernel files it imports, transitively (``dependencies``, read from
its ``from slopewalk.planner.kernel import …`` lines): an edit recompiles the modules
that see it and no other (``servo.py``: the servo loop alone, ~7 s, not the whole
kernel's ~30). ``KernelLocator`` is numba's locator for ``NUMBA_CACHE_DIR`` with that
key as the source stamp, put first in numba's list of locators (``install``); numba
drops a module's cached functions when the stamp it stored differs.

``Entry`` names what one kind of command compiles (``ENTRIES``: a plan, a GA's scores,
a trial's predictors); numba compiles a function at its first call, so a command
compiles only the entries it calls. The drivers call ``first_use`` before an entry's
call, which prints one line to stderr when its code is not cached
(``slopewalk: compiling the kernel (once, about N s)``, N the sum of the compile
times, measured on the 2-core machine (docs/benchmark.md) and scaled by this machine's
pace now (``planner/pace.py``), of the cold entries the command expects, ``expect``),
and ``compiled`` after it. The mark is a file in the cache folder named by the entry's
modules' keys, so an edit or an emptied cache makes the line come back. Where two or
more of the command's entries are cold, ``first_use`` has them compiled side by side
first, one process each (``prepare``: about the longest's time, not the sum), and the
line says that; a sweep or an envelope does the same before its workers start
(``Batch.kernel``).
"""

from __future__ import annotations

import hashlib
import os
import re
import subprocess
import sys
import time
from dataclasses import dataclass
from functools import cache
from pathlib import Path

from numba.core import caching, config

from slopewalk.planner import pace
from slopewalk.planner.kernel.location import default_dir

KERNEL = Path(__file__).parent
_IMPORT = re.compile(r"^from slopewalk\.planner\.kernel import (\w+)", re.MULTILINE)


@cache
def dependencies(module: str) -> frozenset[str]:
    """The kernel modules ``module`` (a file stem of planner/kernel) imports, transitively
    (this module, which compiles nothing, left out)."""
    text = (KERNEL / f"{module}.py").read_text()
    found = {m for m in _IMPORT.findall(text) if m != "cache" and (KERNEL / f"{m}.py").exists()}
    for name in tuple(found):
        found |= dependencies(name)
    return frozenset(found - {module})


@cache
def module_key(module: str) -> str:
    """Hash of ``module``'s source and of its kernel dependencies' (module doc)."""
    digest = hashlib.sha256()
    for name in sorted(dependencies(module) | {module}):
        digest.update(name.encode() + b"\0" + (KERNEL / f"{name}.py").read_bytes())
    return digest.hexdigest()[:16]


def _root() -> str:
    """numba's cache folder: ``NUMBA_CACHE_DIR`` as numba read it, else ``default_dir``."""
    return getattr(config, "CACHE_DIR", "") or str(default_dir())


class KernelLocator(caching.UserProvidedCacheLocator):
    """numba's ``NUMBA_CACHE_DIR`` locator for the kernel's files, stamped with ``module_key``."""

    def __init__(self, py_func, py_file):
        super().__init__(py_func, py_file)
        self._cache_path = os.path.join(_root(), self.get_suitable_cache_subpath(py_file))

    def get_source_stamp(self):
        return module_key(Path(self._py_file).stem)

    @classmethod
    def from_function(cls, py_func, py_file):
        if Path(py_file).resolve().parent != KERNEL.resolve():
            return None
        # numba's own check of the source file and the folder, without its parent's
        # "only where NUMBA_CACHE_DIR is set" (``_root`` falls back to ours)
        return super(caching.UserProvidedCacheLocator, cls).from_function(py_func, py_file)


def install() -> None:
    """Put ``KernelLocator`` first in numba's locators (before any kernel function is made)."""
    old = "_CacheImpl"  # its name before numba 0.61
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, old)
    classes = impl._locator_classes
    if KernelLocator not in classes:
        classes.insert(0, KernelLocator)


@dataclass(frozen=True)
class Entry:
    """What one kind of command compiles: its modules and their compile time.

    Attributes:
        name: The entry point ("plan", "scores", "predictors").
        modules: The kernel modules whose functions it compiles.
        seconds: Cold compile time measured on the 2-core machine [s] (docs/benchmark.md).
    """

    name: str
    modules: tuple[str, ...]
    seconds: float

    def mark(self) -> Path:
        """The file that says this entry's functions are in the cache: per kernel source
        and per kernel folder, as numba files its cache under a hash of the folder's path
        (a second checkout of the same sources compiles into a cache of its own)."""
        folder = KernelLocator.get_suitable_cache_subpath(str(KERNEL / "run.py"))
        keys = "-".join([folder, *(module_key(m) for m in self.modules)])
        root = Path(_root())
        return root / "compiled" / f"{self.name}-{hashlib.sha256(keys.encode()).hexdigest()[:16]}"


# cold compile CPU s on the 2-core machine (docs/benchmark.md, compile_*_cpu_s): a plan
# 18.7 s, a trial 38 s (load ~3.6), the GA's scores 36 s (load ~3.6, 30-34 s at ~3)
ENTRIES = {
    "plan": Entry("plan", ("run",), 18.0),  # a plan's series (run.series)
    "scores": Entry("scores", ("run",), 30.0),  # a GA population's scores (run.scores)
    # a trial's dynamics, servo loop, support rocking and whole-body walk: the longest
    # process of ``prepare`` (stop 51, fresh caches): beside the plan's 36.3 s of wall time
    # at pace 0.85 (43 s at the reference pace), beside the plan's and the scores' 36.2 s at
    # pace 0.99 (37 s); alone 39 s of CPU (tools/compile_profile.py)
    "predictors": Entry("predictors", ("dynamics", "servo", "rocking", "whole_body"), 40.0),
}
_WARM: set[str] = set()  # entries asked about in this process
_DONE: set[str] = set()  # entries marked in this process
_EXPECTED: list[tuple[str, ...]] = [()]  # what the running command will compile (``expect``)
NOTICE_S = 600.0  # [s] another process's notice this recent covers this one's


def cold_seconds(*names: str, slots: int = 1, slowdown: float | None = None) -> float:
    """The compile time [s] of the entries of ``names`` whose code is not cached, on
    ``slots`` processes side by side (``prepare``), times ``slowdown`` (this machine's pace
    against the one the entries' seconds were measured on; None: ``pace.slowdown()``,
    measured): their sum spread over the processes, but never less than the longest
    entry's own process. The entries share ``sample``'s stages, which the first process
    to reach them compiles for all, so the spread sum is about right for the short ones;
    the predictors' process compiles its own ~30 s of CPU however many there are beside
    it, and bounds the wall time (stop 51: half the sum said 17 s for a sweep's compile
    that took 36 s). One slot: the sum."""
    cold = [ENTRIES[n].seconds for n in dict.fromkeys(names) if not ENTRIES[n].mark().exists()]
    if not cold:
        return 0.0
    slowdown = pace.slowdown() if slowdown is None else slowdown
    return max(max(cold), sum(cold) / max(1, min(slots, len(cold)))) * slowdown


def expect(*names: str) -> None:
    """The entries the running command compiles, for ``first_use``'s one line (the CLI)."""
    _EXPECTED[0] = names


def notice(names, *, slots: int = 1) -> None:
    """Say ``first_use``'s one line for the cold entries of ``names``, unless another
    process of the same command said it less than ``NOTICE_S`` ago for each of them (a
    notice file next to each cold entry's mark stands for it)."""
    cold = [n for n in names if not ENTRIES[n].mark().exists()]
    if not cold:
        return
    paths = [ENTRIES[n].mark().with_suffix(".notice") for n in cold]
    try:
        paths[0].parent.mkdir(parents=True, exist_ok=True)
        if all(p.exists() and time.time() - p.stat().st_mtime < NOTICE_S for p in paths):
            return
        for path in paths:
            path.touch()
    except OSError:
        pass
    seconds = cold_seconds(*cold, slots=slots)
    print(f"slopewalk: compiling the kernel (once, about {seconds:.0f} s)", file=sys.stderr)
    sys.stderr.flush()


def first_use(name: str) -> None:
    """Before a call of entry ``name``: if its code is not cached, say so on stderr, once.

    The line sums the cold entries the command expects (``expect``; else ``name``'s
    alone). Once per cache and command: a notice file next to the mark stands for it,
    so the workers of a sweep compiling at the same time print one line between them.
    Where two or more of them are cold and there are cores for them, they are compiled
    side by side first (``prepare``), and the line says that time.
    """
    if name in _WARM:
        return
    _WARM.add(name)  # asked once per process; ``compiled`` marks it after the call
    if ENTRIES[name].mark().exists():
        return
    names = list(dict.fromkeys((*_EXPECTED[0], name)))
    _WARM.update(names)  # the line covers the command's other entries
    if prepare(*names) == 0.0:  # nothing to do side by side: compiled at first use
        notice(names)


def compiled(name: str) -> None:
    """After a call of entry ``name``: mark it warm (its code is in the cache now)."""
    if name in _DONE:
        return
    _DONE.add(name)
    mark = ENTRIES[name].mark()
    try:
        mark.parent.mkdir(parents=True, exist_ok=True)
        mark.touch()
    except OSError:
        pass  # an unwritable cache: numba recompiles each time


# a Ctrl-C ends an entry's process quietly (the command's own process says it was stopped);
# the collector frozen before the exit, whose last collection walks all numba made: 0.74 s
# of the command's wait after a plan's compile, 0.09 s frozen (``cli.command``'s reason)
_RUN = (
    "import signal; signal.signal(signal.SIGINT, signal.SIG_DFL); "
    "from slopewalk.planner.kernel.warm import compile_entry; compile_entry({!r}); "
    "import gc; gc.freeze()"
)


def _spawn(name: str) -> subprocess.Popen:
    """A process compiling entry ``name`` into this process's numba cache."""
    env = dict(os.environ, NUMBA_CACHE_DIR=_root())
    return subprocess.Popen([sys.executable, "-c", _RUN.format(name)], env=env)


def prepare(*names: str, workers: int | None = None) -> float:
    """Compile the cold entries of ``names`` side by side, one process each (module doc).

    Each process runs ``warm.compile_entry`` (its module doc says how they share the
    work), named in a string, so this module imports nothing of what it compiles.
    Nothing happens where fewer than two are cold, or on one core (returns 0): the
    command compiles at first use. Says ``notice``'s one line first (about the longest
    cold entry's time). Returns the wall time spent [s].
    """
    cold = sorted(
        (n for n in dict.fromkeys(names) if not ENTRIES[n].mark().exists()),
        key=lambda n: -ENTRIES[n].seconds,
    )
    slots = min(workers or os.cpu_count() or 1, len(cold))
    if slots < 2:
        return 0.0
    start = time.perf_counter()
    notice(cold, slots=slots)
    waiting, running = list(cold), list[subprocess.Popen]()
    try:
        while waiting or running:
            while waiting and len(running) < slots:
                running.append(_spawn(waiting.pop(0)))
            running[0].wait()  # longest first: the others end about as soon
            running = [p for p in running if p.poll() is None]
    except BaseException:  # stopped (Ctrl-C, SIGTERM): the entries' processes with it
        for process in running:
            process.kill()
        raise
    return time.perf_counter() - start
