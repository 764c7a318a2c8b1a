"""The kernel cache's per-module keys and the cold start's one line (planner/kernel/cache.py)."""

import shutil

import pytest

from slopewalk.planner import pace
from slopewalk.planner.kernel import cache


@pytest.fixture
def kernel_copy(tmp_path, monkeypatch):
    """The kernel's sources in a folder of their own, for edits; the keys recomputed."""
    folder = tmp_path / "kernel"
    shutil.copytree(cache.KERNEL, folder, ignore=shutil.ignore_patterns("__py*"))
    monkeypatch.setattr(cache, "KERNEL", folder)
    cache.dependencies.cache_clear()
    cache.module_key.cache_clear()
    yield folder
    cache.dependencies.cache_clear()
    cache.module_key.cache_clear()


def _keys():
    cache.module_key.cache_clear()
    return {m: cache.module_key(m) for m in ("tables", "sample", "run", "dynamics", "servo")}


def test_an_edit_changes_the_keys_of_the_modules_that_see_it_and_no_other(kernel_copy):
    assert cache.dependencies("servo") == {"dynamics", "sample", "tables"}
    assert cache.dependencies("run") == {"sample", "tables"}
    before = _keys()
    with open(kernel_copy / "dynamics.py", "a") as f:
        f.write("\n# an edit\n")
    after = _keys()
    assert {m for m in before if before[m] != after[m]} == {"dynamics", "servo"}
    with open(kernel_copy / "tables.py", "a") as f:
        f.write("\n# an edit\n")
    assert all(a != b for a, b in zip(after.values(), _keys().values(), strict=True))


@pytest.fixture
def cold(tmp_path, monkeypatch):
    """An empty cache folder and a fresh process's memory of what it has seen."""
    monkeypatch.setattr(cache.config, "CACHE_DIR", str(tmp_path / "numba"))
    monkeypatch.setattr(cache, "_WARM", set())
    monkeypatch.setattr(cache, "_DONE", set())
    monkeypatch.setattr(cache, "_EXPECTED", [()])
    # one process compiling at first use (tests/planner/test_kernel_warm.py: side by side)
    monkeypatch.setattr(cache, "prepare", lambda *names, **kw: 0.0)


def _lines(capsys):
    return [line for line in capsys.readouterr().err.splitlines() if line]


def test_a_cold_command_says_once_what_it_compiles_and_a_warm_one_nothing(
    cold, capsys, monkeypatch
):
    monkeypatch.setattr(pace, "slowdown", lambda: 1.7)  # a machine 1.7x the reference's time
    cache.expect("plan", "predictors")
    cache.first_use("plan")
    seconds = 1.7 * (cache.ENTRIES["plan"].seconds + cache.ENTRIES["predictors"].seconds)
    assert _lines(capsys) == [f"slopewalk: compiling the kernel (once, about {seconds:.0f} s)"]
    cache.compiled("plan")
    cache.first_use("plan")
    cache.first_use("predictors")  # the same command's second entry: covered by the line
    cache.compiled("predictors")
    assert _lines(capsys) == []
    # a new process with both entries cached
    cache._WARM.clear()
    cache.first_use("plan")
    cache.first_use("predictors")
    assert _lines(capsys) == []


def test_a_second_process_compiling_at_the_same_time_prints_no_second_line(cold, capsys):
    cache.first_use("scores")
    assert len(_lines(capsys)) == 1
    cache._WARM.clear()  # another worker of the same sweep, before the first has finished
    cache.first_use("scores")
    assert _lines(capsys) == []
