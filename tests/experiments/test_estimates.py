"""The first estimates of a sweep's and an envelope's time count the analytic work per trial
(the plan and the predictors), the workers' start and a cold kernel's compiling, not only
the simulator's steps (which made a sweep's "about 4 s" take 25 s and more)."""

import pytest

from slopewalk.bench.experiments.envelope import run as envelope
from slopewalk.bench.experiments.sweep import run as sweep


def test_the_sweep_estimate_counts_the_analytic_work_per_step(monkeypatch):
    steps, workers = 259_440, 2  # the default sweep's trials
    with_analytic = sweep.first_estimate_s(steps, workers, compile_s=0.0)
    monkeypatch.setattr(sweep, "ANALYTIC_S_PER_STEP", 0.0)
    rollout_only = sweep.first_estimate_s(steps, workers, compile_s=0.0)
    assert with_analytic - rollout_only == pytest.approx(steps * 20e-6 / workers)
    assert rollout_only == pytest.approx(steps / sweep.ROLLOUT_RATE / workers + 2.5)


def test_a_cold_kernel_adds_its_compile_time_to_both_estimates():
    assert sweep.first_estimate_s(1000, 2, compile_s=30.0) == pytest.approx(
        sweep.first_estimate_s(1000, 2, compile_s=0.0) + 30.0
    )
    assert envelope.first_estimate_s(192, 2, compile_s=70.0) == pytest.approx(
        192 * envelope.CELL_S / 2 + sweep.WORKER_START_S + 70.0
    )
