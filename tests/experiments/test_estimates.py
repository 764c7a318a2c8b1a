"""The first estimates of a sweep's and an envelope's time count the analytic work per trial
(the plan and the predictors), the workers' start and a cold kernel's compiling, not only
the simulator's steps (which made a sweep's "about 4 s" take 25 s and more), and follow
this machine's pace (``planner/pace.py``): constants from a fast hour said "about 26 s" for
a cold main job that took 54 s on a slow one."""

from pathlib import Path

import pytest

from slopewalk.bench.experiments.envelope import run as envelope
from slopewalk.bench.experiments.sweep import run as sweep
from slopewalk.planner import pace
from slopewalk.planner.kernel import cache


def test_the_sweep_estimate_counts_the_analytic_work_per_step(monkeypatch):
    steps, workers = 259_440, 2  # the default sweep's trials
    with_analytic = sweep.first_estimate_s(steps, workers, compile_s=0.0, slowdown=1.0)
    per_step = sweep.ANALYTIC_S_PER_STEP
    assert per_step > 0
    monkeypatch.setattr(sweep, "ANALYTIC_S_PER_STEP", 0.0)
    rollout_only = sweep.first_estimate_s(steps, workers, compile_s=0.0, slowdown=1.0)
    assert with_analytic - rollout_only == pytest.approx(steps * per_step / workers)
    assert rollout_only == pytest.approx(steps / sweep.ROLLOUT_RATE / workers + 2.5)


def test_a_cold_kernel_adds_its_compile_time_to_both_estimates():
    assert sweep.first_estimate_s(1000, 2, compile_s=30.0, slowdown=1.0) == pytest.approx(
        sweep.first_estimate_s(1000, 2, compile_s=0.0, slowdown=1.0) + 30.0
    )
    assert envelope.first_estimate_s(192, 2, compile_s=70.0, slowdown=1.0) == pytest.approx(
        192 * envelope.CELL_S / 2 + sweep.WORKER_START_S + 70.0
    )


def test_a_cold_envelope_counts_its_entries_compiled_side_by_side(tmp_path, monkeypatch):
    """An envelope's three cold entries compile one process per worker and core
    (``batch.run``'s ``prepare``): on 2 cores its estimate says their side-by-side time, not
    their sum one after the other (measured: 36.2 s side by side, where the sum of the
    entries' own times said 88 s at that pace)."""
    monkeypatch.setattr(cache, "_root", lambda: str(tmp_path))  # an empty cache: all cold
    monkeypatch.setattr(envelope.os, "cpu_count", lambda: 2)
    names = ("scores", "plan", "predictors")
    start = envelope.WORKER_START_S
    two = envelope.first_estimate_s(0, 2, slowdown=1.0) - start
    one = envelope.first_estimate_s(0, 1, slowdown=1.0) - start
    assert two == pytest.approx(cache.cold_seconds(*names, slots=2, slowdown=1.0))
    assert one == pytest.approx(sum(cache.ENTRIES[n].seconds for n in names))
    assert two < one


def test_a_report_after_the_trials_adds_its_time_per_robot():
    """The default main job writes the claims and figures after its trials (~10 s at pace
    2, which made the whole command take 2.05 times its first line's estimate)."""
    bare = sweep.first_estimate_s(1000, 2, compile_s=0.0, slowdown=1.0)
    assert sweep.first_estimate_s(
        1000, 2, compile_s=0.0, slowdown=1.0, report_robots=2
    ) == pytest.approx(bare + 2 * sweep.REPORT_S)


def test_the_first_line_counts_the_report_the_command_writes(tmp_path, monkeypatch, capsys):
    """``slopewalk sweep`` without CONFIG, or with ``--report``, writes a report on each
    robot of the sweep after its trials, and its first line says so in its estimate; a
    sweep without a report does not count one."""
    from slopewalk.bench import commands
    from slopewalk.bench.cli import main
    from slopewalk.bench.experiments.sweep.config import load_sweep

    monkeypatch.setattr(pace, "slowdown", lambda: 1.0)
    monkeypatch.setattr(sweep, "duration", lambda seconds: f"{seconds:.3f} s")
    monkeypatch.setattr(commands, "_write_claims", lambda *args: None)
    scaled = Path(load_sweep().source).parent / "robots" / "scaled.toml"
    config = tmp_path / "two.toml"  # two robots, one cheap trial each
    config.write_text(f'steps = 1\n[grid]\nrobot = ["default", "{scaled}"]\nstep_time = [0.3]\n')
    said = {}
    for flags in ([], ["--report"]):
        out = tmp_path / f"out{len(flags)}"
        assert main(["sweep", str(config), "--workers", "1", "--out", str(out), *flags]) == 0
        first = next(line for line in capsys.readouterr().err.splitlines() if "about" in line)
        said[bool(flags)] = float(first.split("about ")[1].split(" s")[0])
    assert ("the report after the trials" in first) and said[True] == pytest.approx(
        said[False] + 2 * sweep.REPORT_S, abs=2e-3
    )


@pytest.mark.parametrize("factor", [0.5, 2.3])
def test_every_term_of_both_estimates_follows_the_measured_pace(tmp_path, monkeypatch, factor):
    """A machine ``factor`` times slower than the reference (as ``pace.slowdown`` measures
    it) takes ``factor`` times as long for the trials, the workers' start and the compile."""
    monkeypatch.setattr(cache, "_root", lambda: str(tmp_path))  # an empty cache: all cold
    monkeypatch.setattr(pace, "slowdown", lambda: factor)
    sweep_reference = sweep.first_estimate_s(259_440, 2, slowdown=1.0, report_robots=1)
    assert sweep.first_estimate_s(259_440, 2, report_robots=1) == pytest.approx(
        factor * sweep_reference
    )
    envelope_reference = envelope.first_estimate_s(192, 2, slowdown=1.0)
    assert envelope.first_estimate_s(192, 2) == pytest.approx(factor * envelope_reference)
    assert cache.cold_seconds("plan", "predictors", slots=2) == pytest.approx(
        factor * cache.cold_seconds("plan", "predictors", slots=2, slowdown=1.0)
    )


def test_the_pace_is_the_best_probe_over_the_reference_machines(monkeypatch):
    ticks = iter([0.0, 0.030, 1.0, 1.012, 2.0, 2.020])  # three probes: 30, 12, 20 ms
    assert pace.probe_s(10, 3, clock=lambda: next(ticks)) == pytest.approx(0.012)
    monkeypatch.setattr(pace, "probe_s", lambda: 2 * pace.REFERENCE_S)
    pace.slowdown.cache_clear()
    try:
        assert pace.slowdown() == pytest.approx(2.0)
    finally:
        pace.slowdown.cache_clear()


def test_the_time_left_runs_from_the_first_trial_not_from_the_compile(monkeypatch):
    """The progress lines' "about N left" extrapolates the trials' own rate: counted from
    the command's start, a cold compile made it say "about 3 min left" with 45 s to go."""
    from slopewalk.bench.experiments.sweep.config import load_sweep

    said, clock = {}, [0.0]

    def run_batch(*args, intro, after_row, **kwargs):
        said["intro"], said["after_row"] = intro, after_row
        raise _Caught

    monkeypatch.setattr(sweep, "run_batch", run_batch)
    monkeypatch.setattr(sweep.time, "perf_counter", lambda: clock[0])
    monkeypatch.setattr(sweep, "duration", lambda seconds: f"{seconds:.1f} s")
    config = load_sweep()
    with pytest.raises(_Caught):
        sweep.run_sweep(config, "unused", workers=2)
    said["intro"](0, 2)  # the default sweep's steps to run
    clock[0] = 40.0  # a 38 s compile and the workers' start, then the first trial ends
    assert said["after_row"]({"sim_steps": 5_000}, 49) == ""
    clock[0] = 41.0  # and the next, a second later: 5,000 steps/s from here on
    left = (config.trials.simulated_steps() - 10_000) / 5_000
    assert said["after_row"]({"sim_steps": 5_000}, 48) == f", about {left:.1f} s left"


@pytest.mark.parametrize("report_robots", [0, 1])
def test_a_clusters_first_line_says_the_worker_time_then_the_report_here(
    monkeypatch, report_robots
):
    """On a cluster (``--cluster``) its workers play the trials and this machine writes
    the report: the first line says the trials' worker time (one worker's, the cluster's
    size being its own), then the report's time here where there is one."""
    from slopewalk.bench.experiments.sweep.config import load_sweep

    said = {}

    def run_batch(*args, intro, after_row, **kwargs):
        said["intro"] = intro
        raise _Caught

    monkeypatch.setattr(sweep, "run_batch", run_batch)
    monkeypatch.setattr(pace, "slowdown", lambda: 1.0)
    monkeypatch.setattr(sweep, "duration", lambda seconds: f"{seconds:.3f} s")
    config = load_sweep()
    with pytest.raises(_Caught):
        sweep.run_sweep(config, "unused", executor=object(), report_robots=report_robots)
    line = said["intro"](0, 2)
    worker_s = sweep.first_estimate_s(config.trials.simulated_steps(), 1)
    here = f", then about {report_robots * sweep.REPORT_S:.3f} s here" if report_robots else ""
    assert f": about {worker_s:.3f} s of worker time{here} at " in line
    assert "workers" not in line.split(":")[1]  # the cluster's, not this machine's
    assert ("and the report after the trials" in line) == bool(report_robots)


def test_the_envelope_time_left_runs_from_the_first_cell(monkeypatch):
    """As the sweep's: an envelope's cold compile (the GA's entries too) is not a cell's."""
    clock = [70.0]  # the compile and the workers' start, then the first cell ends
    monkeypatch.setattr(envelope.time, "perf_counter", lambda: clock[0])
    monkeypatch.setattr(envelope, "duration", lambda seconds: f"{seconds:.1f} s")
    after_row = envelope._eta()
    assert after_row({}, 9) == ""
    clock[0] = 80.0  # the next, 10 s later
    assert after_row({}, 8) == ", about 80.0 s left"


class _Caught(Exception):
    pass
