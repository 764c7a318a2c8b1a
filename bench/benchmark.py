"""Speed figures, measured in one run and printed as ``name: value`` lines.

``planner``: time to plan one 4-step walk at 1 ms resolution (``plan_ms``);
GA-population evaluations per second at 100 samples per step (``evals_per_s``)
and the speed-up of the vectorised batch over calling the single-walk planner in
a Python loop on the same individuals (``speedup_vs_loop``).
"""

from __future__ import annotations

import time

import numpy as np

from planner.plan import evaluate, plan_walk
from planner.spec import load_spec
from planner.trajectory import GaitParams

NOMINAL_STEP_TIME = 1.0  # [s]
POPULATION = 130  # the paper's GA population
SAMPLES_PER_STEP = 100


def _best_of(fn, repeats: int) -> float:
    """Shortest wall time of ``repeats`` calls [s] (the least disturbed run)."""
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def random_population(spec, size: int, seed: int = 0) -> np.ndarray:
    """Individuals (Hz [m], lift [m], tilt [rad]) spread around the nominal gait."""
    rng = np.random.default_rng(seed)
    return np.column_stack(
        [
            rng.uniform(0.17, 0.22, size),
            rng.uniform(0.2, 0.8, size) * spec.thigh,
            np.deg2rad(rng.uniform(4.0, 14.0, size)),
        ]
    )


def planner_figures() -> dict:
    spec = load_spec()
    params = GaitParams.nominal(spec, NOMINAL_STEP_TIME)
    plan_s = _best_of(lambda: plan_walk(spec, params), 5)
    coarse = GaitParams.nominal(spec, NOMINAL_STEP_TIME, dt=NOMINAL_STEP_TIME / SAMPLES_PER_STEP)
    population = random_population(spec, POPULATION)
    batch_s = _best_of(lambda: evaluate(spec, coarse, population), 3)

    def loop():
        for hz, lift, tilt in population:
            plan_walk(
                spec,
                GaitParams.nominal(
                    spec, NOMINAL_STEP_TIME, dt=coarse.dt, hip_height=hz, swing_lift=lift, tilt=tilt
                ),
            )

    loop_s = _best_of(loop, 1)
    return {
        "plan_samples": plan_walk(spec, params).t.size,
        "plan_ms": plan_s * 1e3,
        "population": POPULATION,
        "samples_per_eval": coarse.steps * SAMPLES_PER_STEP + int(0.4 * SAMPLES_PER_STEP) + 1,
        "evals_per_s": POPULATION / batch_s,
        "loop_evals_per_s": POPULATION / loop_s,
        "speedup_vs_loop": loop_s / batch_s,
    }


def sim_figures() -> dict:
    """Raw mj_step rate of the trial scene vs a whole trial's rate, measured in one run.

    ``trial_steps_per_s`` covers planning, the rollout, sensor decoding, event
    detection and the comparison; ``rollout_steps_per_s`` plays a batch of trials
    through ``mujoco.rollout`` on 2 threads.
    """
    import mujoco

    from bench.playback import build_model, play_many
    from bench.trial import TrialSpec, run_trial

    spec = load_spec()
    params = GaitParams.nominal(spec, NOMINAL_STEP_TIME)
    plan = plan_walk(spec, params)
    model = build_model(plan, friction=1.0, actuators="stiff", timestep=0.001)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    raw_steps = 5000
    raw_s = _best_of(lambda: [mujoco.mj_step(model, data) for _ in range(raw_steps)], 3)
    holder = {}

    def trial():
        holder["result"] = run_trial(spec, TrialSpec(params))

    trial_s = _best_of(trial, 3)
    steps = holder["result"].sim_steps
    batch = [
        plan_walk(spec, GaitParams.nominal(spec, NOMINAL_STEP_TIME, hip_height=hz))
        for hz in np.linspace(0.19, 0.21, 8)
    ]
    batch_s = _best_of(
        lambda: play_many(batch, friction=[1.0] * 8, actuators=["stiff"] * 8, threads=2), 2
    )
    raw_rate, trial_rate = raw_steps / raw_s, steps / trial_s
    return {
        "trial_steps": steps,
        "raw_steps_per_s": raw_rate,
        "trial_steps_per_s": trial_rate,
        "ratio": trial_rate / raw_rate,
        "rollout_trials": len(batch),
        "rollout_threads": 2,
        "rollout_steps_per_s": len(batch) * steps / batch_s,
    }


def run(what: str) -> dict:
    """Figures of one benchmark by name."""
    return {"planner": planner_figures, "sim": sim_figures}[what]()
