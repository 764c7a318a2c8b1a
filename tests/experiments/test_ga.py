"""The GA of sec. VI: wiring proven on a known optimum, bounds from kinematics, seeds, CLI."""

import json
import subprocess
import sys
from dataclasses import dataclass, replace

import numpy as np
import pytest
from pymoo.algorithms.moo.nsga2 import NSGA2
from pymoo.algorithms.soo.nonconvex.ga import GA

from slopewalk.bench.experiments.ga.operators import ArrayGA
from slopewalk.bench.experiments.ga.search import (
    GaSettings,
    _drive,
    _PymooProblem,
    non_dominated,
    random_search,
    run_ga,
    run_nsga2,
)
from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.gait_search import (
    PENALTY,
    Bounds,
    GaitProblem,
    Measurement,
    extended_corners,
    ga_params,
    gait_bounds,
    joint_gap,
    joint_limit_excess,
    knee_distance_range,
    leg_vectors,
    objectives,
)
from slopewalk.planner.joints import JOINT_KINDS
from slopewalk.planner.plan import evaluate, plan_walk
from slopewalk.planner.trajectory import Timeline

# ---------------------------------------------------------------- synthetic problem


@dataclass(frozen=True)
class Bowl:
    """Same interface as GaitProblem: a smooth bowl whose minimum lies outside a feasible ball.

    work = |x − a|², margin = r − |x − c|; the constrained optimum is the point of
    the ball nearest to a: c + r (a − c)/|a − c|.
    """

    a: tuple = (0.9, 0.8, -0.5)
    c: tuple = (0.3, 0.4, 0.1)
    r: float = 0.25
    bounds: Bounds = Bounds((0.0, 0.0, -1.0), (1.0, 1.0, 1.0))

    def measure(self, X) -> Measurement:
        X = np.atleast_2d(X)
        work = ((X - self.a) ** 2).sum(axis=1)
        margin = self.r - np.linalg.norm(X - self.c, axis=1)
        return Measurement(work, margin, np.full(len(X), -1.0))

    @property
    def optimum(self) -> np.ndarray:
        a, c = np.array(self.a), np.array(self.c)
        return c + self.r * (a - c) / np.linalg.norm(a - c)


@pytest.mark.parametrize("constraint", ["penalty", "margin"])
def test_ga_finds_the_constrained_optimum_of_a_bowl(constraint):
    bowl = Bowl()
    # A GA guarantees convergence in probability, not from one seed: a single run's
    # path hinges on last-bit rounding (BLAS kernels differ between machines), so the
    # claim is about the best of independent seeds, each of which must be feasible.
    results = [
        run_ga(bowl, GaSettings(population=60, generations=150, constraint=constraint, seed=s))
        for s in range(5)
    ]
    for result in results:
        assert result.best.feasible
        assert result.evaluations == 60 * 150
        assert np.all(np.diff(result.history) <= 0)  # best so far never gets worse
    best = min(results, key=lambda r: r.best.work).best
    # the optimum sits on the constraint's boundary, where the paper's operators
    # (5 % mutation per variable) converge slowly: 3 % of the box, 1 % in objective
    np.testing.assert_allclose(best.x, bowl.optimum, atol=0.03)
    assert best.work == pytest.approx(((bowl.optimum - bowl.a) ** 2).sum(), rel=0.01)


def test_penalty_run_without_a_feasible_point_says_so():
    bowl = Bowl(r=-0.1)  # an empty feasible set: the margin is negative everywhere
    result = run_ga(bowl, GaSettings(population=10, generations=5))
    assert not result.best.feasible
    assert result.best.objective >= PENALTY
    assert not result.feasible_history.any()


def test_nsga2_front_is_non_dominated_and_spans_the_trade_off():
    front = run_nsga2(Bowl(), GaSettings(population=30, generations=20))
    assert np.all(np.diff(front.work) >= 0) and np.all(np.diff(front.margin) > 0)
    assert front.work.size >= 10
    work, margin = np.array([1.0, 2.0, 1.5, 3.0]), np.array([0.0, 1.0, 0.5, 0.5])
    assert non_dominated(work, margin).tolist() == [0, 2, 1]


# ---------------------------------------------------------------- the gait problem


@pytest.fixture(scope="module")
def problem(spec):
    return GaitProblem(spec, ga_params(spec, 1.0, np.deg2rad(22.5)))


def test_bounds_come_from_the_kinematics(spec, problem):
    params, b = problem.params, problem.bounds
    d_min, d_max = knee_distance_range(spec)
    kappa = np.pi - np.arccos((spec.shank**2 + spec.thigh**2 - d_min**2) / (2 * spec.shank**2))
    assert kappa == pytest.approx(spec.joint_limits["knee"][1])  # law of cosines
    # the longest leg keeps the knee bent by the AX-12A's compliance band, 1.5 N m / 9.26 N m/rad
    band = 1.5 / 9.26
    assert d_max == pytest.approx(np.sqrt(2 * spec.thigh**2 * (1 + np.cos(band))))
    assert b.lower[1] == pytest.approx(0.085 * np.sin(np.deg2rad(5.0)))  # Lh sin(tip angle)
    assert b.upper[2] == pytest.approx(-b.lower[2]) == pytest.approx(0.6)  # ankle roll limit
    tilts = np.linspace(b.lower[2], b.upper[2], 61)
    ones = np.ones_like(tilts)

    def reachable(hz):
        work, _ = evaluate(spec, params, np.column_stack([hz * ones, b.lower[1] * ones, tilts]))
        return np.isfinite(work).any()

    assert reachable(b.upper[0] + 1e-4)  # the bent-knee cap lies inside the legs' reach
    timeline = Timeline.of(params)

    def knees_ok(hz, lift):  # some tilt keeps both knees within limits and reach all walk long
        u, w, _, _ = leg_vectors(spec, timeline, hz, lift, tilts)
        d = np.hypot(u, w)
        return ((d >= d_min) & (d < d_max)).all(axis=(1, 2)).any()

    assert knees_ok(b.lower[0] + 1e-4, b.lower[1]) and not knees_ok(b.lower[0] - 1e-4, b.lower[1])
    assert knees_ok(b.upper[0] - 1e-4, b.lower[1]) and not knees_ok(b.upper[0] + 1e-4, b.lower[1])
    assert not knees_ok(b.upper[0] - 1e-4, b.upper[1] + 1e-3)
    assert gait_bounds(spec, params) == b


def test_extended_bounds_come_from_the_foot_the_slope_and_the_thigh(spec, problem):
    """δ spans the sole about the ankle, widened into the slope by the straight leg's height
    times tan θs; L half to one thigh, w hold to sway; Hz and Szmax widen to what the corners
    of the flat-ground box admit, so the paper's box lies inside. Lengths scale with the
    robot."""
    ext = GaitProblem(spec, problem.params, family="extended").bounds
    assert ext.names == ("hip_height", "swing_lift", "tilt", "pelvis_offset", "step_length",
                         "sway_share")  # fmt: skip
    lean = (spec.ankle_height + spec.thigh + spec.shank) * np.tan(np.deg2rad(22.5))
    assert ext.lower[3:] == pytest.approx((-spec.heel_offset, 0.5 * spec.thigh, 0.0))
    assert ext.upper[3:] == pytest.approx((spec.ankle_to_toe + lean, spec.thigh, 1.0))
    down = gait_bounds(spec, ga_params(spec, 1.0, np.deg2rad(-22.5)), "extended")
    assert (down.lower[3], down.upper[3]) == pytest.approx(
        (-spec.heel_offset - lean, ext.lower[3] + spec.foot_length)
    )
    flat = gait_bounds(spec, ga_params(spec, 1.0, 0.0), "extended")
    assert (flat.lower[3], flat.upper[3]) == pytest.approx((-spec.heel_offset, spec.ankle_to_toe))
    paper = problem.bounds
    assert ext.lower[2] == paper.lower[2] and ext.upper[2] == paper.upper[2]
    assert ext.lower[0] < paper.lower[0] and ext.upper[0] > paper.upper[0]
    assert ext.lower[1] == paper.lower[1] and ext.upper[1] > paper.upper[1]
    timeline = Timeline.of(problem.params)
    d_min, d_max = knee_distance_range(spec)
    tilts = np.linspace(ext.lower[2], ext.upper[2], 61)

    def knees_ok(hz):  # some corner of (δ, L, w) and some tilt keep both knees in range
        for corner in extended_corners(spec):  # δ within the sole: the flat-ground box
            u, w, _, _ = leg_vectors(spec, timeline, hz, ext.lower[1], tilts, *corner)
            d = np.hypot(u, w)
            if ((d >= d_min) & (d < d_max)).all(axis=(1, 2)).any():
                return True
        return False

    assert knees_ok(ext.lower[0] + 1e-4) and not knees_ok(ext.lower[0] - 1e-4)
    big = replace(
        spec, thigh=2 * spec.thigh, shank=2 * spec.shank, foot_length=2 * spec.foot_length,
        ankle_to_toe=2 * spec.ankle_to_toe, ankle_height=2 * spec.ankle_height,
    )  # fmt: skip
    wide = gait_bounds(big, ga_params(big, 1.0, problem.params.slope), "extended")
    np.testing.assert_allclose(wide.xl[3:5], 2 * ext.xl[3:5], rtol=1e-12)
    np.testing.assert_allclose(wide.xu[3:5], 2 * ext.xu[3:5], rtol=1e-12)


def test_a_population_must_have_its_familys_columns(spec, problem):
    with pytest.raises(SlopewalkError, match=r"the paper family has 3 variables"):
        problem.measure(np.zeros((2, 6)))
    extended = GaitProblem(spec, problem.params, family="extended")
    with pytest.raises(SlopewalkError, match=r"the extended family has 6 variables"):
        extended.measure(np.zeros((2, 3)))
    with pytest.raises(SlopewalkError, match=r"gait family 'wide': must be one of paper, extended"):
        GaitProblem(spec, problem.params, family="wide")


def test_joint_check_agrees_with_the_planned_joint_angles(spec, problem):
    """joint_gap rebuilds the IK targets; the plan's joint angles must agree (no drift)."""
    timeline = Timeline.of(problem.params)
    rng = np.random.default_rng(3)
    checked = admissible = 0
    for x in rng.uniform(problem.bounds.xl, problem.bounds.xu, (16, 3)):
        params = GaitParams.nominal(
            spec, 1.0, slope=problem.params.slope, dt=problem.params.dt,
            hip_height=x[0], swing_lift=x[1], tilt=x[2],
        )  # fmt: skip
        try:
            plan = plan_walk(spec, params)
        except SlopewalkError:
            assert joint_gap(spec, timeline, x[None])[0] == np.inf
            continue
        limits = dict(spec.joint_limits)  # the search keeps the knee bent by the servo's band
        limits["knee"] = (1.5 / 9.26, limits["knee"][1])
        expected = max(
            np.maximum(lo - plan.q[:, i], plan.q[:, i] - hi).max()
            for i, (lo, hi) in ((i, limits[JOINT_KINDS[i]]) for i in range(1, 7))
        )
        gap = joint_gap(spec, timeline, x[None])[0]
        assert gap == pytest.approx(expected, abs=1e-9)
        excess = joint_limit_excess(spec, plan.q)
        assert gap > 0 or all(v == 0 for v in excess.values())
        checked += 1
        admissible += gap <= 0
    assert checked >= 8 and 0 < admissible < checked


def test_objectives_are_finite_and_rank_infeasible_last():
    m = Measurement(
        work=np.array([1.0, 0.5, np.inf, 2.0]),
        margin=np.array([0.002, -0.001, -np.inf, 0.003]),
        joint_gap=np.array([-0.01, -0.01, np.inf, 0.004]),
    )
    F, G = objectives(m, "penalty")
    assert G is None and np.all(np.isfinite(F))
    np.testing.assert_allclose(F, [1.0, 0.5 + PENALTY, 2 * PENALTY, 2.0 + PENALTY])
    F, G = objectives(m, "margin")
    assert np.all(np.isfinite(F)) and np.all(np.isfinite(G))
    np.testing.assert_allclose(G[:, 0], [-0.002, 0.001, 1.0, -0.003])
    F, G = objectives(m, "stability")  # the most stable gait: F = -margin, G = joint gap
    np.testing.assert_allclose(F, [-0.002, 0.001, 1.0, -0.003])
    np.testing.assert_allclose(G[:, 0], [-0.01, -0.01, 1.0, 0.004])
    with pytest.raises(SlopewalkError, match="constraint 'x'"):
        objectives(m, "x")


def test_stability_treatment_finds_the_largest_admissible_margin(problem):
    """The GA's most stable gait beats the best gait of a random search on the same budget.

    Over seeds 0-7 (1600 evaluations each; smaller budgets are noisy on this
    non-smooth objective). One seed's path hinges on last-bit rounding: seed 0 beat
    random search by 3 mm, then lost by 0.05 mm after a change of the kernel's
    rounding. Measured over the 8 seeds: the GA wins 6, by 1.0 mm on average
    (4.7 vs 3.6 mm). Asserted: it wins most seeds and on average.
    """
    ga, rnd = [], []
    for seed in range(8):
        settings = GaSettings(population=40, generations=40, seed=seed, constraint="stability")
        best = run_ga(problem, settings).best
        assert best.joint_gap <= 0
        assert best.objective == pytest.approx(-best.margin)
        ga.append(best.margin)
        rs = random_search(problem, settings)
        admissible = (rs.log["gap"] <= 0) & np.isfinite(rs.log["margin"])
        rnd.append(rs.log["margin"][admissible].max())
    ga, rnd = np.array(ga), np.array(rnd)
    assert (ga > rnd).sum() >= 5 and ga.mean() > rnd.mean(), (ga, rnd)


def _rank(best):
    """Feasible first, then by work; infeasible ones by how far the ZMP leaves the polygon."""
    return (not best.feasible, best.work if best.feasible else -best.margin)


def test_ga_beats_random_search_on_the_same_budget(problem):
    """800 evaluations (40 x 20), seeds 0-3, the margin treatment for both searches.

    Only ~0.3 % of the box is feasible at 22.5° (the pitch-joint limits cut most
    of it): with the paper's penalty a small GA that sees no feasible gait drifts
    towards low-work infeasible ones, so the test uses the margin treatment;
    results/optimize/README.md compares the treatments on the full budget.
    """
    ga, rnd = [], []
    for seed in range(4):
        settings = GaSettings(population=40, generations=20, seed=seed, constraint="margin")
        ga.append(run_ga(problem, settings).best)
        rnd.append(random_search(problem, settings).best)
    print(f"\nGA {[_rank(b) for b in ga]}\nrandom {[_rank(b) for b in rnd]}")
    assert sum(_rank(g) < _rank(r) for g, r in zip(ga, rnd, strict=True)) >= 3
    assert sum(b.feasible for b in ga) >= 3


def test_same_seed_same_result_bit_for_bit(problem):
    settings = GaSettings(population=12, generations=4, seed=7, constraint="margin")
    first, second = run_ga(problem, settings), run_ga(problem, settings)
    assert np.array_equal(first.best.x, second.best.x)
    assert np.array_equal(first.log["X"], second.log["X"])
    assert np.array_equal(first.history, second.history)
    other = run_ga(problem, GaSettings(population=12, generations=4, seed=8, constraint="margin"))
    assert not np.array_equal(first.log["X"], other.log["X"])


@dataclass(frozen=True)
class Terraces(Bowl):
    """The bowl with its work rounded to 0.02: many tournaments are ties, drawn at random."""

    def measure(self, X) -> Measurement:
        m = super().measure(X)
        return Measurement(np.round(m.work / 0.02) * 0.02, m.margin, m.joint_gap)


@pytest.mark.parametrize("constraint", ["penalty", "margin"])
def test_array_operators_make_the_same_run_as_pymoo_s(constraint):
    # ga/operators.py replaces pymoo's tournament, survival and duplicate test by array
    # versions that must compare, eliminate and draw exactly as pymoo's do
    terraces = Terraces(r=0.1)
    settings = GaSettings(population=30, generations=40, seed=3, constraint=constraint)
    ours = run_ga(terraces, settings, batched=False)
    problem = _PymooProblem(terraces, constraint)
    _drive(
        GA(**settings.operators() | {"eliminate_duplicates": True}), problem, settings, False, ""
    )
    theirs = problem.log.arrays()
    assert np.array_equal(ours.log["X"], theirs["X"])
    assert np.array_equal(ours.log["F"], theirs["F"])


def _matings(problem, settings: GaSettings, batched: bool) -> list[tuple]:
    """(parents, children, mating rounds) of each generation after the first of a run."""
    pymoo_problem = _PymooProblem(problem, settings.constraint)
    ops = settings.operators()
    ga = ArrayGA(ops["pop_size"], ops["n_offsprings"], ops["crossover"], ops["mutation"],
                 batched=batched)  # fmt: skip
    ga.setup(pymoo_problem, termination=("n_gen", settings.generations), seed=settings.seed)
    rounds, children = [], ga._children
    ga._children = lambda n: rounds.append(n) or children(n)
    ga.next()
    out = []
    while ga.has_next():
        parents, before, logged = ga.X.copy(), len(rounds), len(pymoo_problem.log.X)
        ga.next()
        out.append((parents, pymoo_problem.log.X[logged], len(rounds) - before))
    return out


def test_batched_mating_gives_each_generation_unique_children_in_fewer_rounds():
    # late in a run most children copy a parent; a batched round mates for the expected
    # share of unique children, so the generation needs few rounds, and still gets
    # exactly its children, none of them a parent's or another child's copy
    settings = GaSettings(population=30, generations=150, seed=3, constraint="margin")
    runs = {b: _matings(Bowl(), settings, b) for b in (False, True)}
    for parents, children, _ in runs[True]:
        assert len(children) == settings.population
        pairs = np.vstack([parents, children])
        D = np.linalg.norm(children[:, None] - pairs[None], axis=-1)
        D[:, len(parents) :][np.diag_indices(len(children))] = np.inf  # a child and itself
        assert D.min() > 1e-16
    late = {b: np.mean([r for *_, r in run[-50:]]) for b, run in runs.items()}
    assert late[False] > 8 and late[True] < 3
    # until a round meets a duplicate, batched rounds are pymoo's: with this seed the
    # first mating needs one round, and gives the same children
    first = GaSettings(population=30, generations=2, seed=5, constraint="margin")
    (_, pymoo_children, rounds), = _matings(Bowl(), first, False)  # fmt: skip
    (_, batched_children, _), = _matings(Bowl(), first, True)  # fmt: skip
    assert rounds == 1 and np.array_equal(batched_children, pymoo_children)


def test_array_duplicates_make_the_same_nsga2_run_as_pymoo_s():
    settings = GaSettings(population=30, generations=30, seed=4)
    runs = []
    for duplicates in (settings.operators()["eliminate_duplicates"], True):
        problem = _PymooProblem(Terraces(r=0.1), "pareto")
        _drive(NSGA2(**settings.operators() | {"eliminate_duplicates": duplicates}), problem,
               settings, False, "")  # fmt: skip
        runs.append(problem.log.arrays()["X"])
    assert np.array_equal(*runs)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"population": 1}, "population 1: must be an integer >= 2"),
        ({"generations": 0}, "generations 0: must be an integer >= 1"),
        ({"seed": -1}, "seed -1: must be an integer >= 0"),
        ({"constraint": "soft"}, "constraint 'soft': must be one of penalty, margin"),
        ({"crossover": 1.5}, "crossover 1.5: must lie in [0, 1]"),
    ],
)
def test_settings_refuse_bad_values(kwargs, message):
    with pytest.raises(SlopewalkError, match=message.replace("[", r"\[").replace("]", r"\]")):
        GaSettings(**kwargs)


# ---------------------------------------------------------------- command line


def _run(*args):
    return subprocess.run(
        [sys.executable, "-m", "slopewalk.bench.cli", "optimize", *args],
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_cli_reports_an_infeasible_penalty_run_plainly(tmp_path):
    out = tmp_path / "best.json"
    result = _run(
        "--slope", "45", "--population", "6", "--generations", "2",
        "--friction", "0.5", "--pareto", "--out", str(out),
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert "feasible: NO" in result.stdout and "stays at the penalty" in result.stdout
    assert "slip predicted" in result.stdout
    report = json.loads(out.read_text())
    assert report["feasible"] is False and report["best"]["objective"] >= PENALTY
    assert report["evaluations"] == 12 and report["check"]["friction"] == 0.5
    assert report["check"]["slip_predicted"] is True  # tan 45° = 1 > 0.5
    assert (tmp_path / "best_pareto.csv").read_text().startswith("hip_height_m,")
    assert (tmp_path / "best_pareto.png").stat().st_size > 1000


def test_problem_definition_needs_neither_pymoo_nor_mujoco():
    code = (
        "import sys; sys.modules['pymoo'] = None; sys.modules['mujoco'] = None; "
        "import slopewalk.planner.gait_search"
    )
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0


def test_a_quiet_ga_makes_no_multiprocessing_lock(tmp_path):
    """A worker's GA without a progress bar leaves nothing to the resource tracker.

    A disabled tqdm bar still made a multiprocessing lock (a named semaphore); the
    envelope's workers, killed at the end of a run, then left "leaked semaphore"
    warnings on every `slopewalk envelope`. Run in a fresh interpreter (tqdm keeps its
    lock per process once made) whose start method is spawn, as in a worker (under
    fork a lock's name is unlinked at once and never registered).
    """
    script = tmp_path / "quiet_ga.py"
    script.write_text(
        "import multiprocessing\n"
        "import multiprocessing.resource_tracker as rt\n"
        "multiprocessing.set_start_method('spawn')  # as in a spawned worker\n"
        "made = []\n"
        "rt.register = lambda name, kind: made.append(kind)\n"
        "import numpy as np\n"
        "from slopewalk.bench.experiments.ga.search import GaSettings, run_ga\n"
        "from slopewalk.planner.gait_search import GaitProblem, ga_params\n"
        "from slopewalk.planner.spec import load_spec\n"
        "spec = load_spec()\n"
        "problem = GaitProblem(spec, ga_params(spec, 1.0, 0.0))\n"
        "run_ga(problem, GaSettings(population=8, generations=2, seed=0))\n"
        "print(made)\n"
    )
    result = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=300
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "[]"
