"""pymoo's GA operators with the per-individual Python taken out, same draws, same results.

pymoo 0.6 keeps a population as an array of ``Individual`` objects and reads it
through ``Population.get``, which calls ``Individual.get`` (``hasattr``,
``getattr``) once per individual and attribute. Between two calls of the compiled
kernel that cost the GA about as much as scoring the 130 children: the survival
reads (F, cv) of 260 individuals, every mating round reads X of the parents and of
the children made so far for the duplicate test (about three rounds per
generation), the binary tournament compares in a Python loop, and the optimum of
the population is recomputed after every generation.

The replacements below read each attribute once per individual into an array and
do the rest with numpy. They make the same comparisons in the same order and draw
from the algorithm's random generator exactly when and as often as pymoo's do
(the tournament draws only at ties, in tournament order), so a seed gives the same
run bit for bit as with pymoo's own operators (``tests/experiments/test_ga.py``
holds a run equal to one with pymoo's).
"""

from __future__ import annotations

import numpy as np
from pymoo.algorithms.soo.nonconvex.ga import GA, FitnessSurvival
from pymoo.core.duplicate import DefaultDuplicateElimination
from pymoo.operators.selection.tournament import TournamentSelection
from pymoo.util import default_random_state
from pymoo.util.misc import cdist


def _values(pop, name: str) -> np.ndarray:
    """``pop.get(name)`` for X, F or CV: one attribute read per individual."""
    return np.array([getattr(ind, name) for ind in pop])


class ArrayDuplicates(DefaultDuplicateElimination):
    """``DefaultDuplicateElimination`` (Euclidean distance ≤ 1e-16 to an earlier one).

    Each population's X is read once per call instead of once per comparison; the
    parents, passed in every mating round of a generation, are read once per
    generation.
    """

    def __init__(self) -> None:
        super().__init__()
        self._parents, self._parents_X = None, None

    def _X(self, pop) -> np.ndarray:
        if pop is self._parents:
            return self._parents_X
        return _values(pop, "X")

    def do(self, pop, *args, return_indices=False, to_itself=True):
        if return_indices or len(pop) == 0:
            return super().do(pop, *args, return_indices=return_indices, to_itself=to_itself)
        X = _values(pop, "X")
        keep = np.ones(len(pop), dtype=bool)
        if to_itself:
            D = cdist(X, X)
            D[np.triu_indices(len(X))] = np.inf
            keep &= ~np.any(np.where(np.isnan(D), np.inf, D) <= self.epsilon, axis=1)
        for i, other in enumerate(args):
            if len(other) == 0:
                continue
            if not keep.any():
                break
            if i == 0 and other is not self._parents:  # the parents come first (infill)
                self._parents, self._parents_X = other, _values(other, "X")
            D = cdist(X[keep], self._X(other))
            still = ~np.any(np.where(np.isnan(D), np.inf, D) <= self.epsilon, axis=1)
            keep[np.flatnonzero(keep)[~still]] = False
        return pop[keep]


@default_random_state
def compare_by_cv_and_fitness(pop, P, random_state=None, **kwargs):
    """pymoo's ``comp_by_cv_and_fitness`` on arrays: winner index per tournament, (n, 1).

    A tournament between a and b is decided by the constraint violation if either
    violates, else by the objective; the smaller wins, a tie (or NaN) is drawn by
    ``random_state.choice([a, b])``, in tournament order as pymoo draws them.
    """
    cv = _values(pop, "CV")[:, 0]
    F = _values(pop, "F")[:, 0]
    a, b = P[:, 0], P[:, 1]
    by_cv = (cv[a] > 0.0) | (cv[b] > 0.0)
    va = np.where(by_cv, cv[a], F[a])
    vb = np.where(by_cv, cv[b], F[b])
    S = np.where(va < vb, a, b)
    for i in np.flatnonzero(~(va < vb) & ~(va > vb)):
        S[i] = random_state.choice([a[i], b[i]])
    return S[:, None].astype(int)


class ArraySurvival(FitnessSurvival):
    """``FitnessSurvival``: the (μ + λ) truncation by (cv, F), reading each value once."""

    def _do(self, problem, pop, n_survive=None, **kwargs):
        F = _values(pop, "F")
        cv = _values(pop, "CV")[:, 0]
        S = np.lexsort([F[:, 0], cv])
        pop.set("rank", np.argsort(S))
        return pop[S[:n_survive]]


class ArrayGA(GA):
    """pymoo's GA with the operators above; ``opt`` is set once, when the run ends.

    pymoo recomputes ``opt`` (the population's best) after every generation for its
    display and result; neither is used while the run goes (termination is by
    generation count), so ``finish`` computes it once at the end.
    """

    def __init__(self, **kwargs):
        kwargs.setdefault("selection", TournamentSelection(func_comp=compare_by_cv_and_fitness))
        kwargs.setdefault("survival", ArraySurvival())
        super().__init__(**kwargs)

    def _set_optimum(self) -> None:
        pass

    def finish(self) -> None:
        """Set ``opt`` as pymoo's GA would have after the last generation."""
        GA._set_optimum(self)
