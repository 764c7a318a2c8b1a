"""Speed figures, measured in one run and printed as ``name: value`` lines.

``planner``: the compiled kernel (``planner/kernel``). ``plan_ms``: one 4-step walk
at 1 ms after warm-up; ``evals_per_s``: a GA population (130) at the GA's
resolution (100 samples per step, the one-sided limits at phase changes and the
margin refinement), on ``threads`` threads, with ``ns_per_sample`` (wall time ×
threads per sample), ``cpu_ns_per_sample`` and ``evals_per_cpu_s`` (from this
process's CPU time, which moves less with other jobs' load) and ``samples_per_eval``
(including the refinement's extra samples);
``numpy_evals_per_s``: the numpy reference (``planner/reference.py``) on the same
population in the same run, and ``speedup`` of the kernel over it. ``compile_s``:
the first plan and the first population score in a fresh process with an empty
numba cache (a temporary ``NUMBA_CACHE_DIR``); ``cached_start_s``: the same first
calls in a fresh process once that cache is filled; ``cached_process_s``: that
whole process, interpreter and imports included; ``warm_command_s``: a whole
``slopewalk plan`` command then (``_warm_command_s``); ``compile_<entry>_s`` each entry
point alone in an empty cache (``entry_compiles``).

``controller``: closed-loop steps/s (numpy controller through ``slopewalk.bench.sim.env``)
vs the open-loop rollout's on the nominal trial (``controller_figures``).

``ga``: the paper's full GA setting at one slope (``evaluations``, ``wall_s`` of
the search, ``process_wall_s`` of a fresh ``python`` process doing it, start-up
included, and ``driver_ms_per_gen``, the time per generation spent outside the
planner: pymoo's operators, the objective treatment and the log; ``pymoo_mating_*``
and ``batched_speedup``: the same search with pymoo's own mating rounds).

``sweep``: the default sweep end to end on all cores (``trials``, ``wall_s``,
``trials_per_s``) and its simulated steps per second as a share of the raw
``mj_step`` capacity measured in the same run (``fraction_of_raw``); and what a
10^6-trial grid costs before its first trial (``grid_1e6_count_s``: parse,
check, count and take the first trial; ``grid_1e6_peak_MB``: Python memory
allocated meanwhile), which was 134 s and 2.75 GB when grids were expanded;
and where one trial's CPU time goes (``trial_part_figures``).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

from slopewalk.planner.gait import GaitParams
from slopewalk.planner.kernel.run import kernel_walk
from slopewalk.planner.plan import evaluate, plan_walk
from slopewalk.planner.reference import evaluate_reference
from slopewalk.planner.spec import load_spec
from slopewalk.planner.trajectory import Timeline

NOMINAL_STEP_TIME = 1.0  # [s]
POPULATION = 130  # the paper's GA population
SAMPLES_PER_STEP = 100


def _best_of(fn, repeats: int, *, clock=time.perf_counter) -> float:
    """Shortest time of ``repeats`` calls [s] by ``clock`` (the least disturbed run)."""
    best = np.inf
    for _ in range(repeats):
        start = clock()
        fn()
        best = min(best, clock() - start)
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


_FIRST_CALLS = """
import json, time
start = time.perf_counter()
import numpy as np
from slopewalk.planner.plan import evaluate, plan_walk
from slopewalk.planner.spec import load_spec
from slopewalk.planner.gait import GaitParams
spec = load_spec()
imported = time.perf_counter()
plan_walk(spec, GaitParams.nominal(spec, 1.0))
evaluate(spec, GaitParams.nominal(spec, 1.0, dt=0.01), np.array([[0.2, 0.06, 0.2]]))
done = time.perf_counter()
print(json.dumps({"import_s": imported - start, "first_calls_s": done - imported}))
"""


def _warm_command_s(cache: str, runs: int = 3) -> float:
    """Wall time [s] of a whole ``slopewalk plan`` command (``python -m slopewalk``, as
    the console script runs it: start, imports, the cached kernel's load, the nominal
    walk planned and written, the exit) in a fresh process once ``cache`` holds the
    kernel; the median of ``runs``."""
    env = dict(os.environ, NUMBA_CACHE_DIR=cache)
    with tempfile.TemporaryDirectory() as out:
        command = [sys.executable, "-m", "slopewalk", "plan", "--step-time", "1"]
        command += ["--out", os.path.join(out, "plan.npz")]
        return _median_run_s(command, runs, env)


def _median_run_s(command: list[str], runs: int, env: dict | None = None) -> float:
    """Median wall time [s] of ``runs`` runs of ``command`` in a fresh process each."""
    walls = []
    for _ in range(runs):
        start = time.perf_counter()
        subprocess.run(command, env=env, capture_output=True, check=True)
        walls.append(time.perf_counter() - start)
    return sorted(walls)[runs // 2]


def _fresh_process(cache: str) -> tuple[dict, float]:
    """Run the first calls in a new interpreter with NUMBA_CACHE_DIR=cache; (figures, wall)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=cache)
    start = time.perf_counter()
    out = subprocess.run(
        [sys.executable, "-c", _FIRST_CALLS], env=env, capture_output=True, text=True, check=True
    )
    return json.loads(out.stdout), time.perf_counter() - start


# One entry point's first call in a fresh process (``entry_compile_figures``): the kernel
# code it compiles (planner/kernel/cache.py ENTRIES) and nothing else.
_ENTRY_CALLS = {
    "plan": "plan_walk(spec, GaitParams.nominal(spec, 1.0))",
    "scores": (
        "evaluate(spec, GaitParams.nominal(spec, 1.0, dt=0.01), np.array([[0.2, 0.06, 0.2]]))"
    ),
    "trial": "run_trial(spec, TrialSpec(GaitParams.nominal(spec, 1.0)))",
    # what ``slopewalk sweep`` does on a cold cache before its workers start
    "sweep": "cache.prepare('plan', 'predictors', workers=2)",
}
_ENTRY = """
import json, resource, time
import numpy as np
from slopewalk.planner.kernel import cache
from slopewalk.planner.plan import evaluate, plan_walk
from slopewalk.planner.spec import load_spec
from slopewalk.planner.gait import GaitParams
from slopewalk.bench.sim.trial import run_trial
from slopewalk.bench.sim.trial_spec import TrialSpec
spec = load_spec()
def cpu_s():  # this process and its finished children (``cache.prepare``'s), user + system
    own = resource.getrusage(resource.RUSAGE_SELF)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime
wall, cpu = time.perf_counter(), cpu_s()
CALL
print(json.dumps({"s": time.perf_counter() - wall, "cpu_s": cpu_s() - cpu}))
"""


def entry_compiles() -> dict[str, dict]:
    """Each entry point's first call, in a fresh process with its own empty numba cache.

    Per entry ("plan": ``plan_walk``, "scores": the GA's ``evaluate``, "trial":
    ``run_trial``, the plan and the trial's predictors, "sweep": what ``slopewalk sweep``
    compiles before its workers start, the plan's and the predictors' entries side by
    side, ``cache.prepare``), each compiling only what it calls: ``s`` (wall) and
    ``cpu_s`` (that process's CPU time and its children's, which moves less with other
    jobs' load); the trial also ``warm_s``, its call again in a fresh process
    once its cache is filled.
    """
    out = {}
    for name, call in _ENTRY_CALLS.items():
        code = _ENTRY.replace("CALL", call)
        with tempfile.TemporaryDirectory() as cache:
            env = dict(os.environ, NUMBA_CACHE_DIR=cache)
            runs = [
                json.loads(
                    subprocess.run(
                        [sys.executable, "-c", code],
                        env=env,
                        capture_output=True,
                        text=True,
                        check=True,
                    ).stdout  # fmt: skip
                )
                for _ in range(2 if name == "trial" else 1)
            ]
        out[name] = dict(runs[0], warm_s=runs[-1]["s"])
    return out


def planner_figures() -> dict:
    import numba

    with tempfile.TemporaryDirectory() as cache:
        cold, _ = _fresh_process(cache)
        warm, warm_wall = _fresh_process(cache)
        command_s = _warm_command_s(cache)
    entries = entry_compiles()
    spec = load_spec()
    params = GaitParams.nominal(spec, NOMINAL_STEP_TIME)
    plan_walk(spec, params)
    plan_s = _best_of(lambda: plan_walk(spec, params), 20)
    coarse = GaitParams.nominal(spec, NOMINAL_STEP_TIME, dt=NOMINAL_STEP_TIME / SAMPLES_PER_STEP)
    population = random_population(spec, POPULATION)
    evaluate(spec, coarse, population)
    batch_s = _best_of(lambda: evaluate(spec, coarse, population), 10)
    cpu_start = time.process_time()
    for _ in range(5):
        evaluate(spec, coarse, population)
    batch_cpu_s = (time.process_time() - cpu_start) / 5  # all threads of this process
    numpy_s = _best_of(lambda: evaluate_reference(spec, coarse, population), 3)
    walk = kernel_walk(spec, Timeline.of(coarse))
    per_eval = float(walk.scores(coarse.slope, population, counts=True)[3].mean())
    threads = numba.get_num_threads()
    return {
        "plan_samples": plan_walk(spec, params).t.size,
        "plan_ms": plan_s * 1e3,
        "population": POPULATION,
        "threads": threads,
        "samples_per_eval": per_eval,
        "evals_per_s": POPULATION / batch_s,
        "ns_per_sample": batch_s * threads / (POPULATION * per_eval) * 1e9,
        "cpu_ns_per_sample": batch_cpu_s / (POPULATION * per_eval) * 1e9,
        "evals_per_cpu_s": POPULATION / batch_cpu_s,
        "numpy_evals_per_s": POPULATION / numpy_s,
        "speedup": numpy_s / batch_s,
        "compile_s": cold["first_calls_s"],
        "cached_start_s": warm["first_calls_s"],
        "cached_process_s": warm_wall,
        "compile_plan_s": entries["plan"]["s"],
        "compile_plan_cpu_s": entries["plan"]["cpu_s"],
        "compile_scores_s": entries["scores"]["s"],
        "compile_scores_cpu_s": entries["scores"]["cpu_s"],
        "compile_trial_s": entries["trial"]["s"],
        "compile_trial_cpu_s": entries["trial"]["cpu_s"],
        "compile_sweep_s": entries["sweep"]["s"],
        "compile_sweep_cpu_s": entries["sweep"]["cpu_s"],
        "warm_trial_s": entries["trial"]["warm_s"],
        "warm_command_s": command_s,
        "load_1min": os.getloadavg()[0],
    }


def raw_step_rate(steps: int = 5000, repeats: int = 3, *, clock=time.perf_counter) -> float:
    """Raw ``mj_step`` rate [steps/s] of the nominal trial scene (flat, μ = 1, stiff).

    The robot stands in its home keyframe; best of ``repeats`` runs of ``steps``,
    timed by ``clock`` (wall time, or ``time.process_time`` for CPU time).
    """
    import mujoco

    from slopewalk.bench.sim.playback import build_model

    spec = load_spec()
    plan = plan_walk(spec, GaitParams.nominal(spec, NOMINAL_STEP_TIME))
    model = build_model(plan, friction=1.0, actuators="stiff", timestep=0.001)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    best = np.inf
    for _ in range(repeats):
        start = clock()
        for _ in range(steps):
            mujoco.mj_step(model, data)
        best = min(best, clock() - start)
    return steps / best


PAIRS = 5  # raw-and-trial pairs of ``sim_figures``' paired_ratio


def sim_figures() -> dict:
    """Raw mj_step rate of the trial scene vs a whole trial's rate, measured in one run.

    ``trial_steps_per_s`` covers planning, the rollout, sensor decoding, event
    detection and the comparison; ``cpu_ratio`` the same in CPU time, which moves less
    with the machine's other load; ``paired_ratio`` the median of ``PAIRS`` ratios, each
    of a raw run and a trial back to back (the best-of rates above can come from
    moments of different load); ``rollout_steps_per_s`` plays a batch of trials
    through ``mujoco.rollout`` on 2 threads.
    """
    from slopewalk.bench.sim.playback import play_many
    from slopewalk.bench.sim.trial import run_trial
    from slopewalk.bench.sim.trial_spec import TrialSpec

    spec = load_spec()
    params = GaitParams.nominal(spec, NOMINAL_STEP_TIME)
    raw_rate = raw_step_rate()
    holder = {}

    def trial():
        holder["result"] = run_trial(spec, TrialSpec(params))

    trial_s = _best_of(trial, 3)
    trial_cpu_s = _best_of(trial, 3, clock=time.process_time)  # this process's CPU time
    raw_cpu_rate = raw_step_rate(clock=time.process_time)
    steps = holder["result"].sim_steps

    def paired() -> float:  # raw stepping, then a trial, back to back: under one load
        raw = raw_step_rate(steps, 1)
        start = time.perf_counter()
        trial()
        return steps / (time.perf_counter() - start) / raw

    paired_ratio = float(np.median([paired() for _ in range(PAIRS)]))
    batch = [
        plan_walk(spec, GaitParams.nominal(spec, NOMINAL_STEP_TIME, hip_height=hz))
        for hz in np.linspace(0.19, 0.21, 8)
    ]
    batch_s = _best_of(
        lambda: play_many(batch, friction=[1.0] * 8, actuators=["stiff"] * 8, threads=2), 2
    )
    trial_rate = steps / trial_s
    return {
        "trial_steps": steps,
        "raw_steps_per_s": raw_rate,
        "trial_steps_per_s": trial_rate,
        "ratio": trial_rate / raw_rate,
        "trial_steps_per_cpu_s": steps / trial_cpu_s,
        "raw_steps_per_cpu_s": raw_cpu_rate,
        "cpu_ratio": steps / trial_cpu_s / raw_cpu_rate,
        "paired_ratio": paired_ratio,
        "rollout_trials": len(batch),
        "rollout_threads": 2,
        "rollout_steps_per_s": len(batch) * steps / batch_s,
    }


GA_SLOPE_DEG = 22.5  # the paper's re-optimised case


_GA_PROCESS = """
import json, time
start = time.perf_counter()
import numpy as np
from slopewalk.bench.experiments.ga.search import GaSettings, run_ga
from slopewalk.planner.gait_search import GaitProblem, ga_params
from slopewalk.planner.spec import load_spec
spec = load_spec()
problem = GaitProblem(spec, ga_params(spec, 1.0, np.deg2rad(%r)))
result = run_ga(problem, GaSettings())
print(json.dumps({"wall_s": time.perf_counter() - start, "feasible": bool(result.best.feasible)}))
"""


class _TimedProblem:
    """A problem whose ``measure`` calls are timed (to split the GA's wall time)."""

    def __init__(self, problem):
        self.inner, self.bounds, self.seconds, self.cpu_s = problem, problem.bounds, 0.0, 0.0

    def measure(self, X):
        start, cpu = time.perf_counter(), time.process_time()
        out = self.inner.measure(X)
        self.seconds += time.perf_counter() - start
        self.cpu_s += time.process_time() - cpu
        return out


def ga_figures() -> dict:
    """The paper's full GA (130 x 500 = 65,000 evaluations) at 22.5 deg.

    ``wall_s`` covers the search in this process (pymoo's operators included);
    ``process_wall_s`` a fresh interpreter importing everything and running the same
    search (warm numba cache); ``measure_s`` the planner's share of ``wall_s`` and
    ``driver_ms_per_gen`` the rest per generation; ``driver_cpu_ms_per_gen`` the same
    in this process's CPU time (the driver is single-threaded, so this moves less
    with other jobs' load than the wall-time split; it includes what the kernel's
    worker threads burn while the driver runs, i.e. spinning OpenMP workers, which
    ``planner/kernel/__init__.py`` puts to sleep). ``feasible`` and ``work_J`` say
    what it found, so a fast but broken run shows. ``pymoo_mating_*``: the same
    search with pymoo's one-for-one mating rounds (``run_ga(batched=False)``, pymoo's
    run bit for bit) in the same process, and ``batched_speedup`` its wall time over
    the batched run's.
    """
    from slopewalk.bench.experiments.ga.search import GaSettings, run_ga
    from slopewalk.planner.gait_search import GaitProblem, ga_params

    spec = load_spec()
    problem = GaitProblem(spec, ga_params(spec, NOMINAL_STEP_TIME, np.deg2rad(GA_SLOPE_DEG)))
    problem.measure(problem.bounds.xl[None])  # load the compiled kernel
    timed = _TimedProblem(problem)
    settings = GaSettings()
    cpu = time.process_time()
    result = run_ga(timed, settings)
    cpu = time.process_time() - cpu
    pymoo = run_ga(problem, settings, batched=False)
    start = time.perf_counter()
    code = _GA_PROCESS % GA_SLOPE_DEG
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    process_wall = time.perf_counter() - start
    return {
        "slope_deg": GA_SLOPE_DEG,
        "evaluations": result.evaluations,
        "wall_s": result.wall_s,
        "evals_per_s": result.evals_per_s,
        "measure_s": timed.seconds,
        "driver_ms_per_gen": (result.wall_s - timed.seconds) / settings.generations * 1e3,
        "driver_cpu_ms_per_gen": (cpu - timed.cpu_s) / settings.generations * 1e3,
        "process_wall_s": process_wall,
        "process_same_verdict": json.loads(out.stdout)["feasible"] == result.best.feasible,
        "feasible": result.best.feasible,
        "work_J": result.best.work,
        "margin_mm": result.best.margin * 1e3,
        "pymoo_mating_wall_s": pymoo.wall_s,
        "pymoo_mating_work_J": pymoo.best.work,
        "pymoo_mating_feasible": pymoo.best.feasible,
        "batched_speedup": pymoo.wall_s / result.wall_s,
        "load_1min": os.getloadavg()[0],
    }


def sweep_figures() -> dict:
    """The default sweep (``bench/experiments/sweeps/paper.toml``) end to end on all cores.

    Runs into a temp dir.

    ``wall_s`` runs from starting the worker pool to the sorted table. The raw
    rate is measured in the same run, before and after the sweep, in a pool of
    the same size: every worker steps the nominal scene at once for about a
    second (``raw_step_rate``) and their rates add up to ``raw_steps_per_s``,
    the machine's raw stepping capacity under its load at the time.
    ``fraction_of_raw`` is the sweep's simulated steps per second over that
    capacity, i.e. the share left after planning, model building, sensor
    decoding, comparison, the table and idle workers at the end of the sweep.
    On a machine shared with other jobs the wall-time figures move with their
    load; ``cpu_fraction_of_raw`` (steps per CPU second of the sweep, workers
    and parent, over the raw steps per CPU second) moves less. ``first_estimate_s``:
    what the sweep's first line says it will take (``sweep.run.first_estimate_s``),
    and the wall time and the CPU time per worker over it.
    """
    import os
    import resource
    import tempfile
    from concurrent.futures import ProcessPoolExecutor

    from slopewalk.bench.batch.executor import stop_server
    from slopewalk.bench.experiments.sweep.config import load_sweep
    from slopewalk.bench.experiments.sweep.run import run_sweep

    config = load_sweep()
    workers = os.cpu_count() or 1

    def capacity() -> float:  # all workers stepping at once, ~1 s each, mean (not best) rate
        with ProcessPoolExecutor(max_workers=workers) as pool:
            rates = [pool.submit(raw_step_rate, 40_000, 1) for _ in range(workers)]
            return sum(f.result() for f in rates)

    def cpu_s() -> float:  # this process and its finished children, user + system [s]
        own, children = (
            resource.getrusage(resource.RUSAGE_SELF),
            resource.getrusage(resource.RUSAGE_CHILDREN),
        )
        return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime

    from slopewalk.bench.experiments.sweep.run import first_estimate_s
    from slopewalk.planner import pace

    estimate = first_estimate_s(config.trials.simulated_steps(), workers)
    before = capacity()
    stop_server()  # the workers' fork server starts inside the timed run, as in a command
    with tempfile.TemporaryDirectory() as out:
        start, start_cpu = time.perf_counter(), cpu_s()
        summary = run_sweep(config, out, workers=workers, quiet=True)
        wall = time.perf_counter() - start
        stop_server()  # its workers' CPU time reaches this process once it is waited for
        cpu = cpu_s() - start_cpu
    raw = (before + capacity()) / 2  # before and after the sweep: drifting load averages out
    raw_cpu = raw_step_rate(40_000, 1, clock=time.process_time)
    start_s = _worker_start_s()
    rate = summary.sim_steps / wall
    return {
        "trials": summary.total,
        "errors": summary.errors,
        "workers": workers,
        "wall_s": wall,
        "trials_per_s": summary.total / wall,
        "sim_steps": summary.sim_steps,
        "sim_steps_per_s": rate,
        "raw_steps_per_s": raw,
        "fraction_of_raw": rate / raw,
        "worker_start_s": start_s,
        "start_share": start_s / wall,
        "fraction_of_raw_after_start": summary.sim_steps / (wall - start_s) / raw,
        "cpu_s": cpu,
        "raw_steps_per_cpu_s": raw_cpu,
        "cpu_fraction_of_raw": summary.sim_steps / cpu / raw_cpu,
        "slowdown": pace.slowdown(),
        "first_estimate_s": estimate,
        "wall_over_estimate": wall / estimate,
        "cpu_over_estimate": cpu / workers / estimate,
    }


def _worker_start_s(runs: int = 3) -> float:
    """Wall time [s] before a sweep's first worker can start, measured alone: a fresh
    interpreter importing what the sweep's fork server imports (``executor``'s
    ``SERVER_PRELOAD``, the trial job's module, ``KERNEL_PRELOAD``: the compiled entries
    loaded from numba's cache) and exiting; the median of ``runs``. No worker forks
    before the server has imported these, so every sweep pays this much wall time on top
    of its trials however many cores it has."""
    from slopewalk.bench.batch.executor import KERNEL_PRELOAD, SERVER_PRELOAD
    from slopewalk.bench.experiments.sweep.run import SWEEP_BATCH

    modules = (SERVER_PRELOAD, SWEEP_BATCH.fn.__module__, KERNEL_PRELOAD)
    return _median_run_s([sys.executable, "-c", "; ".join(f"import {m}" for m in modules)], runs)


def trial_part_figures() -> dict:
    """Where a sweep trial's CPU time goes: the default sweep's trials one after the other
    in this process, warm (after one trial), each part timed alone on its own
    CPU clock (``time.process_time``): planning, MuJoCo's playback (the rollout and the
    sensors' decoding), the analytic prediction (``predict_trial``: the servo loop's
    walk, the compliance fixed point, the predicted events; ``whole_body_cpu_ms`` its
    whole-body walk, timed again alone), and the whole trial as a
    sweep runs it (``run_trial``, the prediction on a thread beside the playback).
    Per trial, in ms; ``prediction_over_playback``: how much the analytic work costs
    against the physics it predicts; ``trial_cpu_fraction_of_raw``: the trials' simulated
    steps per CPU second of ``run_trial`` over raw ``mj_step``'s per CPU second, the
    sweep's ``cpu_fraction_of_raw`` without the workers' start, the table and the report.
    ``worker_trial_cpu_ms``: the trials as a sweep's worker runs them, a plan's trials in a
    row sharing its per-plan work (``_worker_trials_cpu_s``), where the parts above plan
    and predict every trial afresh.
    ``rollout_cpu_ms``: MuJoCo's rollout of each trial alone (``_rollout_alone``), the
    physics of the walk itself; ``rollout_cpu_fraction_of_raw``: its steps per CPU second
    over raw ``mj_step``'s, what a trial would keep with no other work at all (the walking
    robot steps slower than the standing one the raw rate times, docs/benchmark.md).
    The raw stepping of both fractions is paired with the trials: after each trial's
    parts, as many raw steps as it simulated, so a machine whose speed drifts through
    the run (the development VM's moves 2× within an hour) moves both sides alike.
    """
    from slopewalk.bench.experiments.sweep.config import load_sweep
    from slopewalk.bench.sim.playback import play
    from slopewalk.bench.sim.prediction import predict_trial
    from slopewalk.bench.sim.trial import run_trial

    trials = list(load_sweep().trials)
    first = trials[0]
    run_trial(first.spec, first.trial_spec())  # warm: caches, scenes, the kernel
    parts = dict.fromkeys(("plan", "playback", "rollout", "prediction", "whole_body", "trial"), 0.0)
    steps, raw_cpu_s = 0, 0.0

    def timed(part, fn, *args, **kwargs):
        start = time.process_time()
        value = fn(*args, **kwargs)
        parts[part] += time.process_time() - start
        return value

    for t in trials:
        plan = timed("plan", plan_walk, t.spec, t.gait())
        ground = {"friction": t.friction, "actuators": t.actuators}
        played = timed("playback", play, plan, **ground).t.size
        parts["rollout"] += _rollout_alone(plan, **ground)
        timed("prediction", predict_trial, plan, **ground)
        timed("whole_body", _whole_body_alone, plan, **ground)
        timed("trial", run_trial, t.spec, t.trial_spec())
        raw_cpu_s += played / raw_step_rate(played, 1, clock=time.process_time)
        steps += played
    parts["worker_trial"] = _worker_trials_cpu_s(trials)
    per = {part: 1e3 * cpu / len(trials) for part, cpu in parts.items()}
    return {
        "part_trials": len(trials),
        "plan_cpu_ms": per["plan"],
        "playback_cpu_ms": per["playback"],
        "rollout_cpu_ms": per["rollout"],
        "prediction_cpu_ms": per["prediction"],
        "whole_body_cpu_ms": per["whole_body"],
        "trial_cpu_ms": per["trial"],
        "worker_trial_cpu_ms": per["worker_trial"],
        "prediction_over_playback": per["prediction"] / per["playback"],
        "trial_cpu_fraction_of_raw": raw_cpu_s / parts["trial"],
        "rollout_cpu_fraction_of_raw": raw_cpu_s / parts["rollout"],
    }


def _whole_body_alone(plan, *, friction: float, actuators: str):
    """The prediction's whole-body walk of a trial worked out afresh, as a plan's first trial
    pays it: its model (``whole_body.model_of``) and the walk (``body_walk``'s, without its
    once-per-plan memo, which ``predict_trial`` has just filled for this plan; the walk
    then reads the model memoised for the plan, made again here)."""
    from slopewalk.bench.sim.model import servo_settings
    from slopewalk.bench.sim.prediction import _body_walk, trial_floor
    from slopewalk.planner.whole_body import model_of

    model_of(plan)
    floor = trial_floor(plan, friction=friction, actuators=actuators)
    servo = servo_settings(plan.spec, actuators)
    return _body_walk.__wrapped__(plan, servo, *floor)  # functools.wraps' original


def _worker_trials_cpu_s(trials) -> float:
    """CPU time [s] of ``trials`` through the sweep's job (``run_one``) in their plan
    groups' order, as a worker of the sweep takes them (``SWEEP_BATCH.group``): the
    trials of one plan in a row, sharing its plan and per-plan work (``plan_of``)."""
    from slopewalk.bench.experiments.sweep.run import run_one

    start = time.process_time()
    for trial in sorted(trials, key=lambda t: repr(t.plan_group)):
        run_one(trial)
    return time.process_time() - start


def _rollout_alone(plan, *, friction: float, actuators: str) -> float:
    """CPU time [s] of ``plan``'s MuJoCo rollout alone: ``play``'s scene, first state and
    commands (``playback``'s own functions), one ``mujoco.rollout`` call on one thread, the
    scene's compile and the sensors' decoding left out."""
    import mujoco
    from mujoco import rollout

    from slopewalk.bench.sim.floor import SoftFloor
    from slopewalk.bench.sim.model import servo_settings
    from slopewalk.bench.sim.playback import (
        HOLD_TIME,
        SETTLE_TIME,
        build_model,
        commands_and_aim,
        initial_state,
    )

    timestep = 0.001  # ``play``'s
    model = build_model(plan, friction=friction, actuators=actuators, timestep=timestep)
    servo = servo_settings(plan.spec, actuators)
    floor = SoftFloor.of_scene(model)
    _, commands, _ = commands_and_aim(plan, timestep, SETTLE_TIME, HOLD_TIME, servo, floor)
    state, data = initial_state(model, plan), mujoco.MjData(model)
    start = time.process_time()
    rollout.rollout(model, data, state[None], commands[None])
    return time.process_time() - start


def grid_figures() -> dict:
    """Cost of a 100 x 100 x 100 grid before its first trial (module doc)."""
    import tracemalloc
    from pathlib import Path

    from slopewalk.bench.experiments.sweep.config import sweep_from_dict

    values = [0.4 + i / 100 for i in range(100)]
    data = {"steps": 1, "grid": {"step_time": values, "slope": values, "friction": values}}
    tracemalloc.start()
    try:
        start = time.perf_counter()
        trials = sweep_from_dict(data, base_dir=Path(".")).trials
        count = len(trials)
        first = next(iter(trials)).trial_id
        wall = time.perf_counter() - start
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    return {
        "grid_trials": count,
        "grid_first_trial_id": first,
        "grid_1e6_count_s": wall,
        "grid_1e6_peak_MB": peak / 1e6,
    }


def controller_figures() -> dict:
    """Closed-loop vs open-loop simulation of the nominal trial (1 s steps, flat, 4 steps).

    ``rollout_steps_per_s``: ``playback.play``, the open-loop default (model build,
    one ``mujoco.rollout`` on the calling thread, sensor decoding).
    ``closed_loop_steps_per_s``: ``closed_loop.play_controller`` with the numpy
    controller ``ankle_cop_feedback`` (environment build, one ``mj_step``, observation
    and controller call per period, the recording); ``open_loop_policy_steps_per_s``
    the same with the plan as the policy (the environment's own cost). Best of 5
    each, in CPU time of this process (all of them run on its one thread), so other
    jobs on a shared machine move the figures less than wall time would;
    ``ratio`` = closed loop / rollout.
    """
    from slopewalk.bench.controllers import load_controller
    from slopewalk.bench.sim.closed_loop import play_controller
    from slopewalk.bench.sim.env import open_loop
    from slopewalk.bench.sim.playback import play
    from slopewalk.bench.sim.trial_spec import TrialSpec

    spec = load_spec()
    name = "slopewalk.bench.controllers.ankle_cop:ankle_cop_feedback"
    trial = TrialSpec(GaitParams.nominal(spec, NOMINAL_STEP_TIME), controller=name)
    plan = plan_walk(spec, trial.gait)
    steps = play(plan).t.size
    cpu = time.process_time
    rollout_s = _best_of(lambda: play(plan), 5, clock=cpu)
    policy = load_controller(name)
    closed_s = _best_of(lambda: play_controller(spec, trial, plan, controller=policy), 5, clock=cpu)
    plain_s = _best_of(
        lambda: play_controller(spec, trial, plan, controller=open_loop), 5, clock=cpu
    )
    return {
        "trial_steps": steps,
        "controller": name,
        "rollout_steps_per_s": steps / rollout_s,
        "closed_loop_steps_per_s": steps / closed_s,
        "open_loop_policy_steps_per_s": steps / plain_s,
        "ratio": rollout_s / closed_s,
    }


def run(what: str) -> dict:
    """Figures of one benchmark by name."""
    return {
        "planner": planner_figures,
        "sim": sim_figures,
        "ga": ga_figures,
        "sweep": lambda: _with_ceiling(grid_figures() | trial_part_figures() | sweep_figures()),
        "controller": controller_figures,
        "envelope": _envelope_figures,
    }[what]()


def ceiling_figures(figures: dict) -> dict:
    """The most ``fraction_of_raw`` the sweep of ``figures`` could reach on this machine if
    its workers did nothing but start and step MuJoCo: the start (``worker_start_s``),
    then every trial's rollout at its measured cost per step (``rollout_cpu_fraction_of_raw``
    of raw ``mj_step``'s) on all workers, busy to the end, with no planning, decoding,
    prediction, table or idle worker:

        sim_steps / (worker_start_s + sim_steps / (raw · rollout_fraction)) / raw

    raw the machine's stepping capacity (``raw_steps_per_s``). A goal above it cannot be
    met by the bench's own work on this machine and sweep."""
    steps, raw = figures["sim_steps"], figures["raw_steps_per_s"]
    rollouts_s = steps / (raw * figures["rollout_cpu_fraction_of_raw"])
    return {"fraction_of_raw_ceiling": steps / (figures["worker_start_s"] + rollouts_s) / raw}


def _with_ceiling(figures: dict) -> dict:
    return figures | ceiling_figures(figures)


def _envelope_figures() -> dict:
    from slopewalk.bench.experiments.envelope.benchmark import envelope_figures

    return envelope_figures()
