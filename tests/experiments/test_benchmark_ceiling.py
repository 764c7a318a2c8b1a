"""``benchmark sweep``'s ceiling: the fraction of raw a sweep of nothing but its start and its
rollouts would reach, against hand-worked cases."""

import pytest

from slopewalk.bench.experiments.benchmark import ceiling_figures


def _ceiling(start_s: float, rollout_fraction: float, steps=100_000.0, raw=50_000.0) -> float:
    figures = {
        "sim_steps": steps,
        "raw_steps_per_s": raw,
        "worker_start_s": start_s,
        "rollout_cpu_fraction_of_raw": rollout_fraction,
    }
    return ceiling_figures(figures)["fraction_of_raw_ceiling"]


def test_with_no_start_the_ceiling_is_the_rollouts_own_fraction():
    assert _ceiling(0.0, 0.8) == pytest.approx(0.8)
    assert _ceiling(0.0, 1.0) == pytest.approx(1.0)


def test_a_start_as_long_as_the_rollouts_halves_it():
    # 100k steps at 0.5 of a 50k/s capacity take 4 s; a 4 s start doubles the wall time
    assert _ceiling(4.0, 0.5) == pytest.approx(0.25)


def test_a_measured_default_sweep_worked_by_hand():
    # one run on the 2-core development VM: 259,440 steps, 172,336 raw steps/s, a 1.27 s
    # start, rollouts at 0.847 of raw: 1.274 s + 1.778 s of rollouts for what raw steps
    # in 1.505 s
    assert _ceiling(1.27358, 0.846799, 259_440.0, 172_336.0) == pytest.approx(0.4934, abs=2e-4)
