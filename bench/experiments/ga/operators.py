"""pymoo's GA run on arrays: its operators and random draws, without its per-individual Python.

pymoo 0.6 keeps a population as an array of ``Individual`` objects. Building them,
and reading and writing their attributes through ``Population.get``/``set`` (one
``getattr``/``setattr`` per individual and attribute), cost the paper-setting GA
10–14 ms per generation on this machine, as much as scoring the 130 children
with the compiled planner: Crossover and Mutation read X from the parents and
write it into new individuals, every mating round (duplicates are re-mated: late
in the paper-setting run 85 % of the children copy a parent, and a generation takes
about 25 rounds) reads the parents again for the duplicate test,
the evaluator and survival read and write F, G and CV of every individual, and
the optimum is recomputed after every generation.

``ArrayGA`` runs the same algorithm as ``pymoo.algorithms.soo.nonconvex.ga.GA``
on (n, n_var) arrays of X, F and CV:

* start: ``FloatRandomSampling`` (one ``random((n, n_var))`` draw in the bounds),
  duplicates removed, evaluated; the initial population is not truncated;
* mating, repeated until ``n_offsprings`` unique children exist (at most 100
  rounds, as pymoo's ``Mating``): binary tournaments on pymoo's
  ``random_permutations`` decided by (CV, F) as ``comp_by_cv_and_fitness`` does;
  the crossover's own ``_do`` on the parents' (2, n_matings, n_var) array after
  ``Crossover.do``'s draw of which pairs cross; the mutation's own ``_do`` after
  ``Mutation.do``'s draw of which children mutate; children equal (Euclidean
  distance ≤ 1e-16) to an earlier child, a parent or a child of an earlier round
  dropped; the round's surplus cut from its end;
* survival: the (μ + λ) truncation of parents then children by (CV, F), as
  ``FitnessSurvival``'s lexsort.

With ``batched=False`` every random number is drawn from the same
``numpy.random.Generator`` (seeded with the run's seed), at the same moment and
in the same amount as pymoo draws it, so a seed gives pymoo's run bit for bit;
``tests/experiments/test_ga.py`` holds a run equal to one of pymoo's own GA. The
operators (SBX, PM) stay pymoo's: this module calls their array methods and
never re-implements them. That run spent 6 ms per generation outside the planner
on the idle 2-core machine, nearly all of it in pymoo's SBX and PM on the one or
two pairs of each of ~25 late mating rounds (~0.14 ms a round, whatever its size).

Batched mating (``batched=True``, what ``ga.run_ga`` runs) changes one thing: a
round mates enough pairs for the children still missing divided by the share of
unique children in the previous round, so a generation takes 1.8 rounds instead
of 24.5 (paper setting, 22.5°) and the driver ~1 ms. The children kept are still
the first unique ones of a stream of tournament-crossover-mutation draws, as
many as pymoo keeps; what differs is only where the stream is cut into rounds,
so which random numbers make which child: tournament entrants come from
``random_permutations`` of the population per round, and a bigger round spreads
its permutations over more tournaments. Until a round meets a duplicate the two
are the same run; the test holds that. ``slopewalk benchmark ga`` runs both on the
paper's 22.5° case (``pymoo_mating_*``), and ``results/optimize/README.md`` gives
both over seeds and slopes.

``ArrayDuplicates`` is pymoo's duplicate test for its own algorithms (NSGA-II),
reading each population's X once per call.
"""

from __future__ import annotations

import math

import numpy as np
from pymoo.core.duplicate import DefaultDuplicateElimination
from pymoo.core.variable import get
from pymoo.util.misc import cdist, random_permutations

EPSILON = 1e-16  # distance at or below which two individuals are duplicates (pymoo's default)
MAX_ROUNDS = 100  # mating rounds per generation at most (pymoo's GeneticAlgorithm)
MIN_SHARE = 1 / 16  # floor of the unique share that sizes a batched round (16x its need at most)


def _values(pop, name: str) -> np.ndarray:
    """``pop.get(name)`` for X, F or CV: one attribute read per individual."""
    return np.array([getattr(ind, name) for ind in pop])


def _near(D: np.ndarray) -> np.ndarray:
    """Rows of a distance matrix with an entry ≤ ``EPSILON`` (NaN counts as far)."""
    return np.any(D <= EPSILON, axis=1)  # NaN <= EPSILON is False


def unique(X: np.ndarray, *others: np.ndarray) -> np.ndarray:
    """Mask of the rows of X that duplicate neither an earlier row of X nor a row of ``others``.

    pymoo's ``DefaultDuplicateElimination.do(pop, *others)``, on arrays. A row is
    kept when it is near no earlier row of X (kept or not) and no row of ``others``;
    the tests are independent, so this one runs them in the order that costs least:
    against ``others`` first, then only the rows still kept against the earlier rows
    of X (pymoo tests X against itself first, at n² distances, which a batched round
    of ~1,000 children would make the dearest step).
    """
    keep = np.ones(len(X), dtype=bool)
    for other in others:
        if len(other) == 0 or not keep.any():
            continue
        kept = np.flatnonzero(keep)
        keep[kept[_near(cdist(X[kept], other))]] = False
    kept = np.flatnonzero(keep)
    if kept.size:
        D = cdist(X[kept], X)
        D[np.arange(len(X))[None, :] >= kept[:, None]] = np.inf  # only earlier rows count
        keep[kept[_near(D)]] = False
    return keep


class ArrayDuplicates(DefaultDuplicateElimination):
    """``DefaultDuplicateElimination`` reading each population's X once per call.

    The parents, passed in every mating round of a generation, are read once per
    generation.
    """

    def __init__(self) -> None:
        super().__init__(epsilon=EPSILON)
        self._parents, self._parents_X = None, None

    def _X(self, pop, first: bool) -> np.ndarray:
        if first and pop is not self._parents:  # the parents come first (infill)
            self._parents, self._parents_X = pop, _values(pop, "X")
        return self._parents_X if pop is self._parents else _values(pop, "X")

    def do(self, pop, *args, return_indices=False, to_itself=True):
        if return_indices or not to_itself or len(pop) == 0:
            return super().do(pop, *args, return_indices=return_indices, to_itself=to_itself)
        others = [self._X(o, i == 0) if len(o) else np.empty((0, 0)) for i, o in enumerate(args)]
        return pop[unique(_values(pop, "X"), *others)]


def tournament_winners(cv: np.ndarray, F: np.ndarray, P: np.ndarray, rng) -> np.ndarray:
    """Winner index of each binary tournament (rows of P), as ``comp_by_cv_and_fitness``.

    A tournament between a and b is decided by the constraint violation if either
    violates, else by the objective; the smaller wins, a tie (or NaN) is drawn by
    ``rng.choice([a, b])``, in tournament order as pymoo draws them.
    """
    a, b = P[:, 0], P[:, 1]
    by_cv = (cv[a] > 0.0) | (cv[b] > 0.0)
    va = np.where(by_cv, cv[a], F[a])
    vb = np.where(by_cv, cv[b], F[b])
    S = np.where(va < vb, a, b)
    for i in np.flatnonzero(~(va < vb) & ~(va > vb)):
        S[i] = rng.choice([a[i], b[i]])
    return S


class ArrayGA:
    """pymoo's single-objective GA on arrays (module doc), driven like a pymoo algorithm.

    ``setup(problem, termination=("n_gen", G), seed=s)``, then ``next()`` while
    ``has_next()``: the first call samples and evaluates the initial population,
    each later one mates, evaluates and survives one generation, so G calls make
    the G generations of pymoo's ``("n_gen", G)``. ``problem`` is a pymoo
    ``Problem`` (bounds ``xl``, ``xu``; ``evaluate``).

    Attributes:
        X, F, CV: The current population: (n, n_var), (n, 1) objective, (n,) violation.
    """

    def __init__(self, pop_size, n_offsprings, crossover, mutation, *, batched=True):
        if crossover.n_parents != 2 or crossover.n_offsprings != 2:
            raise ValueError("ArrayGA needs a crossover of 2 parents into 2 children")
        self.pop_size, self.n_offsprings = pop_size, n_offsprings
        self.crossover, self.mutation, self.batched = crossover, mutation, batched

    def setup(self, problem, termination, seed) -> ArrayGA:
        kind, self.generations = termination
        if kind != "n_gen":
            raise ValueError(f"termination {termination!r}: ArrayGA stops after ('n_gen', G)")
        self.problem, self.rng, self.done = problem, np.random.default_rng(seed), 0
        self.share = 1.0  # share of unique children in the last mating round
        self.values = ["F"] + (["G"] if problem.n_ieq_constr > 0 else [])
        return self

    def has_next(self) -> bool:
        return self.done < self.generations

    def next(self) -> None:
        if self.done == 0:
            p = self.problem
            X = p.xl + (p.xu - p.xl) * self.rng.random((self.pop_size, p.n_var))
            X = X[unique(X)]
            self.X, self.F, self.CV = X, *self._evaluate(X)
        else:
            X = self._mate()
            F, CV = self._evaluate(X)
            X, F, CV = (np.concatenate(v) for v in ((self.X, X), (self.F, F), (self.CV, CV)))
            keep = np.lexsort([F[:, 0], CV])[: self.pop_size]
            self.X, self.F, self.CV = X[keep], F[keep], CV[keep]
        self.done += 1

    def _evaluate(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(F (n, 1), CV (n,)): pymoo's CV is the sum of the positive parts of G."""
        out = self.problem.evaluate(X, return_values_of=self.values, return_as_dictionary=True)
        G = out.get("G")
        cv = np.zeros(len(X)) if G is None else np.maximum(0.0, G).sum(axis=1)
        return out["F"], cv

    def _mate(self) -> np.ndarray:
        """``n_offsprings`` unique children of the current population (module doc: rounds).

        A round mates enough pairs for the children still missing; when ``batched``,
        that count is divided by the share of unique children in the last round
        (floored at ``MIN_SHARE``), so a converged population, whose children mostly
        copy a parent, still gets its children in one or two rounds.
        """
        off = np.empty((0, self.problem.n_var))
        for _ in range(MAX_ROUNDS):
            missing = self.n_offsprings - len(off)
            if missing <= 0:
                break
            n_matings = math.ceil(missing / 2 / (self.share if self.batched else 1.0))
            children = self._children(n_matings)
            keep = unique(children, self.X, off)
            self.share = max(keep.mean(), MIN_SHARE)
            off = np.concatenate([off, children[keep][:missing]])
        return off

    def _children(self, n_matings: int) -> np.ndarray:
        """Tournament, crossover and mutation of one mating round, (2 n_matings, n_var)."""
        rng = self.rng
        n_random = n_matings * 2 * 2  # two parents per mating, two entrants per tournament
        P = random_permutations(math.ceil(n_random / len(self.X)), len(self.X), random_state=rng)
        S = tournament_winners(self.CV, self.F[:, 0], P[:n_random].reshape(-1, 2), rng)
        X = np.swapaxes(self.X[S.reshape(n_matings, 2)], 0, 1)  # (parent, mating, variable)
        # Crossover.do: which pairs cross, then the operator on all pairs; a pair that does
        # not cross passes both parents on (two children of two parents: no draw)
        cross = rng.random(n_matings) < get(self.crossover.prob, size=n_matings)
        Xp = X.copy()
        if cross.any():
            Xp[:, cross] = self.crossover._do(self.problem, X, random_state=rng)[:, cross]
        Xp = Xp.reshape(-1, X.shape[-1])
        # Mutation.do: the operator on all children, then which children keep its result
        mutated = self.mutation._do(self.problem, Xp, random_state=rng)
        keep = rng.random(len(Xp)) <= get(self.mutation.prob, size=len(Xp))
        Xp[keep] = mutated[keep]
        return Xp
