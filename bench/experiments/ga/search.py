"""The pymoo driver of the gait problem: GA (sec. VI), NSGA-II front, random search.

The problem itself (variables, bounds, objective, penalty) is defined in
``planner/gait_search.py``, which stays numpy-only as DESIGN.md asks of ``planner``;
this module adds pymoo. A problem is anything with ``bounds`` (``xl``, ``xu``) and
``measure(X) -> Measurement``, so a synthetic problem drives the same code in
the tests. Each generation's population is planned in one vectorised
``measure`` call (a pymoo ``Problem``, not an ``ElementwiseProblem``).

Mapping of the paper's MATLAB ``ga`` settings onto pymoo 0.6:

* population 130 → ``pop_size=130``, ``n_offsprings=130``: each generation
  mates 130 children; 500 generations → ``("n_gen", 500)``, i.e. 130 × 500 =
  65,000 evaluations counting the initial population as generation 1.
* crossover fraction 0.95 (MATLAB: the share of the non-elite children made by
  crossover, the rest by mutation alone) → ``SBX(prob=0.95)``: each mating pair
  is crossed with probability 0.95, otherwise its children are copies of the
  parents that only mutation changes. SBX keeps its defaults (``eta=15``,
  ``prob_var=0.5``); MATLAB's default ``crossoverscattered`` has no equivalent
  for real variables.
* mutation rate 0.05 (MATLAB ``mutationuniform``: each gene mutates with
  probability 0.05) → ``PM(prob=1.0, prob_var=0.05)``: every child is offered
  mutation, each of its variables is mutated with probability 0.05, by
  polynomial mutation (``eta=20``) instead of a uniform redraw.
* selection: binary tournament on (constraint violation, objective); survival:
  pymoo's (μ + λ) truncation of parents and children, which is stronger elitism
  than MATLAB's 5 % elite count. Duplicates are eliminated (and re-mated).
  The GA runs as ``ga/operators.py``'s ``ArrayGA``: pymoo's GA on arrays, with pymoo's
  operators and the same comparisons, without pymoo's per-individual Python, and
  with mating rounds sized for the expected share of duplicates (the same
  operators and the same rule for which children are kept, in fewer rounds;
  ``batched=False`` is pymoo's run bit for bit).
  NSGA-II keeps pymoo's algorithm.
* seed → ``seed=`` of the algorithm: pymoo 0.6 draws every random number from
  one ``numpy.random.Generator`` seeded with it, and the planner is
  deterministic, so a seed fixes the run bit for bit.

A Ctrl-C is held until the generation's compiled evaluation has returned
(``batch.executor.held_interrupts``) and raised as ``KeyboardInterrupt`` between
two generations.
"""

from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass, field

import numpy as np
from pymoo.algorithms.moo.nsga2 import NSGA2
from pymoo.core.problem import Problem
from pymoo.operators.crossover.sbx import SBX
from pymoo.operators.mutation.pm import PM
from tqdm import tqdm

from slopewalk.bench.batch.executor import held_interrupts
from slopewalk.bench.experiments.ga.operators import ArrayDuplicates, ArrayGA
from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.gait_search import CONSTRAINTS, objectives, pareto_objectives


@dataclass(frozen=True)
class GaSettings:
    """How to search: the paper's GA settings by default.

    Attributes:
        population: Individuals per generation, ≥ 2.
        generations: Generations including the initial one, ≥ 1.
        seed: Seed of the run's random generator, ≥ 0.
        constraint: "penalty" (paper, eq. 6), "margin" or "stability" (the most stable gait)
            (``slopewalk.planner.gait_search.objectives``).
        crossover: Probability that a mating pair is crossed (SBX), in [0, 1].
        mutation: Probability that one variable of a child is mutated (PM), in [0, 1].
    """

    population: int = 130
    generations: int = 500
    seed: int = 0
    constraint: str = "penalty"
    crossover: float = 0.95
    mutation: float = 0.05

    def __post_init__(self) -> None:
        if not (isinstance(self.population, int) and self.population >= 2):
            raise SlopewalkError(f"population {self.population!r}: must be an integer >= 2")
        if not (isinstance(self.generations, int) and self.generations >= 1):
            raise SlopewalkError(f"generations {self.generations!r}: must be an integer >= 1")
        if not (isinstance(self.seed, int) and self.seed >= 0):
            raise SlopewalkError(f"seed {self.seed!r}: must be an integer >= 0")
        if self.constraint not in CONSTRAINTS:
            raise SlopewalkError(
                f"constraint {self.constraint!r}: must be one of {', '.join(CONSTRAINTS)}"
            )
        for name in ("crossover", "mutation"):
            if not 0 <= getattr(self, name) <= 1:
                raise SlopewalkError(f"{name} {getattr(self, name)!r}: must lie in [0, 1]")

    @property
    def evaluations(self) -> int:
        return self.population * self.generations

    def operators(self) -> dict:
        """pymoo operators and sizes of this setting (see the module doc)."""
        return {
            "pop_size": self.population,
            "n_offsprings": self.population,
            "crossover": SBX(prob=self.crossover),
            "mutation": PM(prob=1.0, prob_var=self.mutation),
            "eliminate_duplicates": ArrayDuplicates(),
        }


@dataclass
class _Log:
    """Every individual evaluated in a run, in order (X, work, margin, joint gap, friction
    gap, slide gap, F, CV; ``gait_search.Measurement``)."""

    X: list = field(default_factory=list)
    work: list = field(default_factory=list)
    margin: list = field(default_factory=list)
    gap: list = field(default_factory=list)
    friction_gap: list = field(default_factory=list)
    slide_gap: list = field(default_factory=list)
    F: list = field(default_factory=list)
    cv: list = field(default_factory=list)

    def add(self, X, m, F, cv) -> None:
        self.X.append(X)
        self.work.append(m.work)
        self.margin.append(m.margin)
        self.gap.append(m.joint_gap)
        self.friction_gap.append(m.friction_gap)
        self.slide_gap.append(m.slide_gap)
        self.F.append(F)
        self.cv.append(cv)

    def arrays(self) -> dict:
        return {
            k: np.concatenate(getattr(self, k))
            for k in ("X", "work", "margin", "gap", "friction_gap", "slide_gap", "F", "cv")
        }


class _PymooProblem(Problem):
    """A ``planner.gait_search`` problem seen by pymoo: the whole population per call."""

    def __init__(self, problem, mode: str):
        self.inner, self.mode, self.log = problem, mode, _Log()
        n_constr = {"penalty": 0, "margin": 4, "stability": 3, "pareto": 3}[mode]
        n_obj = 2 if mode == "pareto" else 1
        b = problem.bounds
        super().__init__(n_var=b.xl.size, n_obj=n_obj, n_ieq_constr=n_constr, xl=b.xl, xu=b.xu)

    def _evaluate(self, X, out, *args, **kwargs):
        m = self.inner.measure(X)
        if self.mode == "pareto":
            F, G = pareto_objectives(m)
        else:
            F, G = objectives(m, self.mode)
        cv = np.zeros(len(X)) if G is None else np.maximum(G, 0).sum(axis=1)
        self.log.add(np.array(X), m, F if F.ndim == 1 else F[:, 0], cv)
        out["F"] = F if F.ndim == 2 else F[:, None]
        if G is not None:
            out["G"] = G


@dataclass(frozen=True)
class Best:
    """The best individual of a run and what the planner says of it.

    Attributes:
        x: (Hz [m], Szmax [m], tilt [rad]), shape (3,).
        work: Joint work [J]. margin: Minimum ZMP margin [m]. joint_gap: [rad], ≤ 0 admissible.
        objective: The treatment's objective value (penalty mode: w + p).
        feasible: Admissible and the ZMP inside the polygon at every sample.
    """

    x: np.ndarray
    work: float
    margin: float
    joint_gap: float
    objective: float
    feasible: bool


@dataclass(frozen=True)
class RunResult:
    """Outcome of one search.

    Attributes:
        best: The best individual (feasible first, then least violation, then objective).
        evaluations: Individuals planned. wall_s: Wall time of the search [s].
        history: Best objective so far after each generation (or batch), shape (G,).
        feasible_history: Whether a feasible gait had been found by then, shape (G,).
        log: Every evaluated individual (keys X, work, margin, gap, friction_gap,
            slide_gap, F, cv).
    """

    best: Best
    evaluations: int
    wall_s: float
    history: np.ndarray
    feasible_history: np.ndarray
    log: dict

    @property
    def evals_per_s(self) -> float:
        return self.evaluations / self.wall_s if self.wall_s > 0 else float("inf")


def _feasible(log: dict) -> np.ndarray:
    """Admissible, ZMP inside and no constraint violated, per logged individual."""
    ok = np.isfinite(log["work"]) & np.isfinite(log["margin"])
    contact = (log["friction_gap"] <= 0) & (log["slide_gap"] <= 0)
    return ok & (log["margin"] >= 0) & (log["gap"] <= 0) & contact & (log["cv"] <= 0)


def _best_index(log: dict) -> int:
    """Index of the best individual: feasible first, then least violation, then objective."""
    return int(np.lexsort((log["F"], log["cv"], ~_feasible(log)))[0])


def _result(log: _Log, wall_s: float, batches: list[int]) -> RunResult:
    a = log.arrays()
    feasible = _feasible(a)
    i = _best_index(a)
    best = Best(
        x=a["X"][i].copy(),
        work=float(a["work"][i]),
        margin=float(a["margin"][i]),
        joint_gap=float(a["gap"][i]),
        objective=float(a["F"][i]),
        feasible=bool(feasible[i]),
    )
    history, found, key = [], [], None
    for start, end in zip(np.cumsum([0, *batches[:-1]]), np.cumsum(batches), strict=True):
        sub = {k: v[start:end] for k, v in a.items()}
        j = _best_index(sub)
        candidate = (not feasible[start + j], sub["cv"][j], sub["F"][j])
        key = candidate if key is None or candidate < key else key
        history.append(key[2])
        found.append(not key[0])
    return RunResult(best, len(a["F"]), wall_s, np.array(history), np.array(found), a)


def _drive(algorithm, pymoo_problem, settings: GaSettings, progress: bool, label: str):
    """Run ``algorithm`` for the settings' generations; returns (wall_s, batch sizes)."""
    algorithm.setup(pymoo_problem, termination=("n_gen", settings.generations), seed=settings.seed)
    batches = []
    log = pymoo_problem.log.F
    start = time.perf_counter()
    # no bar at all unless asked: even a disabled tqdm makes a multiprocessing lock, which a
    # worker killed at the end of a run leaves to the resource tracker's "leaked semaphore"
    # warning
    bar = tqdm(total=settings.generations, desc=label, unit="gen") if progress else None
    with bar or contextlib.nullcontext():
        while algorithm.has_next():
            before = len(log)
            with held_interrupts():  # a Ctrl-C stops the run between generations
                algorithm.next()
            batches.append(sum(len(x) for x in log[before:]))
            if bar is not None:
                bar.update(1)
    return time.perf_counter() - start, batches


def run_ga(
    problem, settings: GaSettings, *, progress: bool = False, batched: bool = True
) -> RunResult:
    """Minimise the problem's objective with pymoo's GA under ``settings`` (module doc).

    Args:
        problem: A ``slopewalk.planner.gait_search.GaitProblem`` or anything with its interface.
        progress: Show a tqdm bar (one tick per generation) on stderr.
        batched: Size the mating rounds by the last round's share of unique children
            (``ga/operators.py``'s ``ArrayGA``); False mates as pymoo does, bit for bit.
    """
    pymoo_problem = _PymooProblem(problem, settings.constraint)
    ops = settings.operators()
    algorithm = ArrayGA(
        ops["pop_size"], ops["n_offsprings"], ops["crossover"], ops["mutation"], batched=batched
    )
    wall_s, batches = _drive(algorithm, pymoo_problem, settings, progress, "GA")
    return _result(pymoo_problem.log, wall_s, batches)


def random_search(problem, settings: GaSettings) -> RunResult:
    """The baseline: as many uniform random individuals in the bounds as the GA evaluates.

    Drawn in batches of ``settings.population`` from ``default_rng(settings.seed)``,
    ranked with the same objective and constraint treatment as the GA.
    """
    rng = np.random.default_rng(settings.seed)
    log = _Log()
    xl, xu = problem.bounds.xl, problem.bounds.xu
    start = time.perf_counter()
    for _ in range(settings.generations):
        X = xl + rng.random((settings.population, xl.size)) * (xu - xl)
        with held_interrupts():
            m = problem.measure(X)
        F, G = objectives(m, settings.constraint)
        log.add(X, m, F, np.zeros(len(X)) if G is None else np.maximum(G, 0).sum(axis=1))
    return _result(log, time.perf_counter() - start, [settings.population] * settings.generations)


@dataclass(frozen=True)
class ParetoFront:
    """Non-dominated gaits of (work, −min margin): NSGA-II's final first front.

    Attributes:
        X: (Hz [m], Szmax [m], tilt [rad]) per gait, shape (k, 3), sorted by work.
        work: [J], shape (k,). margin: Minimum ZMP margin [m], shape (k,).
        evaluations, wall_s: Cost of the NSGA-II run.
    """

    X: np.ndarray
    work: np.ndarray
    margin: np.ndarray
    evaluations: int
    wall_s: float

    COLUMNS = ("hip_height_m", "swing_lift_m", "tilt_deg", "work_J", "min_margin_m")

    def rows(self) -> list[dict]:
        """One dict per gait, degrees for the tilt, for a CSV table."""
        return [
            {
                "hip_height_m": float(x[0]),
                "swing_lift_m": float(x[1]),
                "tilt_deg": float(np.rad2deg(x[2])),
                "work_J": float(w),
                "min_margin_m": float(m),
            }
            for x, w, m in zip(self.X, self.work, self.margin, strict=True)
        ]


def non_dominated(work: np.ndarray, margin: np.ndarray) -> np.ndarray:
    """Indices of the points no other point beats in both less work and more margin, by work."""
    order = np.lexsort((-margin, work))
    keep, best_margin = [], -np.inf
    for i in order:
        if margin[i] > best_margin:
            keep.append(i)
            best_margin = margin[i]
    return np.array(keep, dtype=int)


def run_nsga2(problem, settings: GaSettings, *, progress: bool = False) -> ParetoFront:
    """NSGA-II over (work, −min margin) with the GA's operators; joint limits as a constraint.

    The front is NSGA-II's answer: the admissible, non-dominated members of the
    final population (at most ``settings.population`` gaits), sorted by work.
    """
    pymoo_problem = _PymooProblem(problem, "pareto")
    algorithm = NSGA2(**settings.operators())
    wall_s, _ = _drive(algorithm, pymoo_problem, settings, progress, "NSGA-II")
    X, F, cv = algorithm.pop.get("X", "F", "CV")
    ok = np.flatnonzero(cv[:, 0] <= 0)
    work, margin = F[ok, 0], -F[ok, 1]
    keep = non_dominated(work, margin)
    evaluations = sum(len(f) for f in pymoo_problem.log.F)
    return ParetoFront(X[ok][keep], work[keep], margin[keep], evaluations, wall_s)


def pareto_figure(front: ParetoFront, title: str):
    """Energy vs stability margin of the front, as a matplotlib Figure (Agg backend)."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6, 4.2), layout="constrained")
    ax = fig.add_subplot()
    ax.plot(front.margin * 1e3, front.work, "o-", ms=3, lw=1)
    ax.axvline(0.0, color="0.5", lw=0.8, ls="--")
    ax.set_xlabel("minimum ZMP margin [mm]  (> 0: inside the support polygon)")
    ax.set_ylabel("joint work Σ∫|τ θ̇| dt [J]")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    return fig
