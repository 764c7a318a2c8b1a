"""Drivers of the compiled sample pipeline: a plan's series, a GA population's scores.

``series`` fills one row per sample (``sample.ROW`` floats) for each individual of
a population (one thread): the plan's time series. ``scores`` (``prange``, one thread
per individual) reduces the same
rows per individual to the GA's numbers - joint work Σ∫|τθ̇|dt [J] (trapezoid over
the samples), minimum ZMP margin [m] and the worst joint-limit excursion [rad] -
and refines the margin between samples: at every interior local minimum of the
sampled margin it searches the bracket of the two neighbouring samples by
safeguarded parabolic interpolation, so a dip between samples is not missed. The
GA's samples include both one-sided limits of every phase change and a probe next
to each (``tables.limit_samples``), so a margin that still falls going inwards
from a phase end is such a minimum too.

Measured on random admissible gaits at −30…35°: at 100 samples per step the refined
minimum is within 2e-5 mm below a 20 µs brute-force plan's, and never above the
1 ms plan's, which misses the SSP side of each phase change by up to 1 ms (on
22.5° that is up to 0.08 mm of margin; more for a near-singular swing leg).

What ``scores`` adds to its blocks is kept to vector loops and one pass per
individual: the joint-limit extremes lane by lane (``sample.keep_extremes``), a
block's margins and powers copied whole, then one pass in time order for the minimum
and the trapezoid, the samples' phase neighbours found once per call. Measured (one
thread, load ~1.8): the blocks alone ~70 ns per sample, ``scores`` ~75 (it was ~25%
above its blocks: the extremes were a scalar reduction after every block, 12 ns).

The Python side (``KernelWalk``) builds the tables once per robot and timeline.
Calls into the parallel kernels are serialised by a lock: each already uses every
core, and numba's fallback threading layer (workqueue) aborts on concurrent
launches from several Python threads (e.g. a Dask worker's thread pool).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np
from numba import njit, prange

from slopewalk.planner.joints import JOINT_KINDS
from slopewalk.planner.kernel import cache
from slopewalk.planner.kernel import sample as sm
from slopewalk.planner.kernel import tables as tb
from slopewalk.planner.kinematics import gravity_in_slope
from slopewalk.planner.spec import RobotSpec
from slopewalk.planner.trajectory import Timeline

REFINE_ITERATIONS = 12  # parabolic steps per local minimum at most
SKIP_SAFETY = 8.0  # depth factor of the bound that skips a minimum (``_refine_all``)
REFINE_TOL = 1e-7  # [s] stop when the bracket's best point moves less than this
SERIES_BLOCK = 256  # samples per task of ``series`` at least
_LAUNCH = threading.Lock()


@njit(cache=True, error_model="numpy", nogil=True)
def _footprints(landing, x, hip_width):
    """y of each step's stance sole [m] (``trajectory.footprint_y``), shape (N,).

    ``landing``: λ per unit tilt at each touch-down of the hold and sway profiles,
    (2, N); the individual's lean blends them by its sway share.
    """
    n = landing.shape[1]
    tilt, w = x[tb.TILT_X], x[tb.SWAY_SHARE]
    y = np.empty(n)
    y[0] = -hip_width / 2
    for k in range(1, n):
        towards = 1.0 if (k - 1) % 2 == 0 else -1.0
        lean = landing[0, k - 1] + w * (landing[1, k - 1] - landing[0, k - 1])
        y[k] = y[k - 1] + towards * hip_width / np.cos(tilt * lean)
    return y


@njit(cache=True, error_model="numpy", nogil=True)
def series(
    pf, pi, landing, geometry, dh_a, d5, mass, com, inertia, gravity, X, inputs, index, count,
    size, double, n,
):  # fmt: skip
    """Rows of every sample for every individual, shape (P, n, ROW).

    The samples are the blocks of a ``tables.Blocks`` of n samples, in (individual, run
    of blocks) tasks. One thread: a plan is a few ms, and ``parallel=True`` cost ~6 s
    of compiling (the parfor lowering) in every trial's first command; a sweep's
    workers fill the cores with trials anyway.
    """
    P, nb = X.shape[0], count.size
    out = np.empty((P, n, sm.ROW))
    parts = max(1, min(nb * sm.BLOCK // SERIES_BLOCK, 64 // P))
    per = -(-nb // parts)
    for task in range(P * parts):
        p, part = task // parts, task % parts
        w = sm.scratch()
        x = X[p]
        y = _footprints(landing, x, geometry[tb.HIP_WIDTH])
        for b in range(part * per, min(nb, (part + 1) * per)):
            sm.evaluate_block(
                inputs, b, size[b], double[b], y, geometry, dh_a, d5, mass, com, inertia,
                gravity, x, w,
            )  # fmt: skip
            sm.write_rows(mass, gravity, count[b], w, out[p], index[b])
    return out


@njit(cache=True, error_model="numpy", nogil=True, inline="always")
def _margin_at(args, x, y, piece, t, scratch):
    """Signed ZMP margin [m] of individual x at time t [s] of ``piece`` (one-sample block).

    The block's length is computed (1), not written as a literal, and the support kind
    is an int as in a ``Blocks``: other argument types would compile another version of
    the whole pipeline.
    """
    pf, pi, geometry, dh_a, d5, mass, com, inertia, gravity = args
    sm.load_sample(pf, pi, piece, t, 0, scratch)
    one = 1 + 0 * piece
    sm.evaluate_loaded(
        one, 1 - pi[piece, tb.SSP], y, geometry, dh_a, d5, mass, com, inertia, gravity, x,
        scratch,
    )  # fmt: skip
    return sm.margin(scratch, 0)


@njit(cache=True, error_model="numpy", nogil=True, inline="always")
def _refine(args, x, y, pa, ta, fa, pb, tb_, fb, pc, tc, fc, scratch):
    """Smallest margin in [ta, tc] around the sampled minimum fb at tb_ (parabolic search).

    Returns (margin [m], samples evaluated).
    """
    t1a = args[0][pa, tb.T1]
    best = fb
    a, b, c = ta, tb_, tc
    count = 0
    for _ in range(REFINE_ITERATIONS):
        count += 1
        num = (b - a) ** 2 * (fb - fc) - (b - c) ** 2 * (fb - fa)
        den = (b - a) * (fb - fc) - (b - c) * (fb - fa)
        u = b - 0.5 * num / den if den != 0 else np.nan
        if not (a < u < c) or abs(u - b) < 0.5 * REFINE_TOL:  # golden step into the larger side
            u = b + 0.381966 * (c - b) if (c - b) > (b - a) else b - 0.381966 * (b - a)
        piece = pa if u <= t1a else pc
        fu = _margin_at(args, x, y, piece, u, scratch)
        moved = abs(u - b)
        if fu < fb:
            if u < b:
                c, fc = b, fb
            else:
                a, fa = b, fb
            b, fb = u, fu
        elif u < b:
            a, fa = u, fu
        else:
            c, fc = u, fu
        best = min(best, fu)
        if moved < REFINE_TOL:
            break
    return best, count


@njit(cache=True, error_model="numpy", nogil=True, inline="always")
def _refine_all(args, x, y, pieces, times, inner, margin, low, scratch):
    """Smallest margin [m] found by refining the local minima of the sampled ``margin``.

    ``low`` is the smallest sampled margin [m], where the search starts from; ``inner``
    (``_inner``) marks the samples with a neighbour of their phase on either side.

    A minimum is bracketed by its two neighbours within its phase; next to each
    phase end the samples hold a probe (``tables.limit_samples``), so a margin that
    still falls going inwards from an end is such a minimum too. Only the walk's
    minimum matters, so the minima are refined lowest first, and one is skipped when
    it cannot reach below the lowest margin found so far: a margin convex in its
    bracket stays above m_j − (max(m_(j−1), m_(j+1)) − m_j) (the lines through the
    samples bound it), and the skip asks for ``SKIP_SAFETY`` times that depth.
    Measured on 20,000 random individuals of the GA's box at −30…35°: with the
    factor 8 every margin above −0.5 m equals that of refining every minimum (with
    2, one was 2.9 mm too high); only margins of kilometres, where a near-zero
    vertical force sends the ZMP away, come out less deep.
    Returns (margin [m], samples evaluated).
    """
    n = times.size
    found_at = np.empty(n, dtype=np.int64)
    count = 0
    for j in range(1, n - 1):
        if inner[j] and margin[j] < margin[j - 1] and margin[j] <= margin[j + 1]:
            found_at[count] = j
            count += 1
    minima = found_at[:count]
    order = np.argsort(margin[minima])
    evaluated = 0
    for k in range(count):
        j = minima[order[k]]
        depth = max(margin[j - 1], margin[j + 1]) - margin[j]
        if margin[j] - SKIP_SAFETY * depth >= low:
            continue
        found = _refine(
            args, x, y, pieces[j - 1], times[j - 1], margin[j - 1], pieces[j], times[j],
            margin[j], pieces[j + 1], times[j + 1], margin[j + 1], scratch,
        )  # fmt: skip
        low, evaluated = min(low, found[0]), evaluated + found[1]
    return low, evaluated


@njit(cache=True, error_model="numpy", nogil=True)
def _inner(pi, pieces, times):
    """Whether sample j has a sample of its phase before and after it in time, (n,)."""
    n = times.size
    inner = np.zeros(n, dtype=np.bool_)
    for j in range(1, n - 1):
        ph = pi[pieces[j], tb.PHASE]
        left = pi[pieces[j - 1], tb.PHASE] == ph and times[j - 1] < times[j]
        right = pi[pieces[j + 1], tb.PHASE] == ph and times[j + 1] > times[j]
        inner[j] = left and right
    return inner


@njit(cache=True, error_model="numpy", nogil=True)
def _contact(by_block, at, pi, pieces, loaded):
    """(largest friction ratio [-], largest slide of a loaded foot in double support [m]) of
    one individual's rows (``scores``), the samples taken in time order through ``at``."""
    friction, slide, x0, y0, run = 0.0, 0.0, 0.0, 0.0, False
    for j in range(at.size):
        k = at[j]
        friction = max(friction, by_block[2, k])
        if pi[pieces[j], tb.SSP] == 0 and by_block[5, k] > loaded:
            if not run:
                x0, y0, run = by_block[3, k], by_block[4, k], True
            slide = max(slide, np.hypot(by_block[3, k] - x0, by_block[4, k] - y0))
        else:
            run = False
    return friction, slide


@njit(cache=True, parallel=True, error_model="numpy")
def scores(
    pf, pi, landing, geometry, dh_a, d5, mass, com, inertia, gravity, limits, X, pieces, times,
    inputs, index, count, size, double, refine, loaded,
):  # fmt: skip
    """Work [J], minimum margin [m], joint gap [rad], samples evaluated, largest friction ratio
    [-] and largest planned slide of a loaded foot in double support [m], each shape (P,).

    The samples: (pieces, times) in time order, in blocks (``tables.Blocks``: inputs,
    index, count, size, double).
    ``limits``: (lower, upper) [rad] of each Table-I joint, shape (8, 2); the gap is the
    worst max(lower − q, q − upper) of the pitch joints (q2..q7) over the samples,
    from the extremes of tan(q/2) (``sample``: increasing in q on (−π, π)).
    Unreachable individuals get work = inf, margin = −inf, gap = inf.
    The friction ratio is |F_t| / F_n of the total ground force (inf where F_n ≤ 0). The
    slide: in each run of double-support samples where the second foot carries more than
    ``loaded`` [N], the distance its sole moves in the plane from the run's first sample
    (``planner.verdict.planned_slide``, at these samples); unreachable: both inf.
    """
    P, n, nb = X.shape[0], times.size, count.size
    work_out, margin_out, gap_out = np.empty(P), np.empty(P), np.empty(P)
    friction_out, slide_out = np.empty(P), np.empty(P)
    count_out = np.full(P, n, dtype=np.int64)
    args = (pf, pi, geometry, dh_a, d5, mass, com, inertia, gravity)
    inner = _inner(pi, pieces, times)
    half_step = np.zeros(n)  # half the time step before each sample [s] (0 at the first)
    for j in range(1, n):
        half_step[j] = 0.5 * (times[j] - times[j - 1])
    at = np.empty(n, dtype=np.int64)  # where sample j sits in the block-ordered rows
    for b in range(nb):
        for k in range(count[b]):
            at[index[b, k]] = b * sm.BLOCK + k
    for p in prange(P):
        scratch = sm.scratch()
        # margin, power, friction ratio, second sole x and y, its normal force, per lane
        by_block = np.empty((6, nb * sm.BLOCK))
        x = X[p]
        y = _footprints(landing, x, geometry[tb.HIP_WIDTH])
        sm.start_extremes(scratch)
        bad = False
        done = 0
        for b in range(nb):
            sm.evaluate_block(
                inputs, b, size[b], double[b], y, geometry, dh_a, d5, mass, com, inertia,
                gravity, x, scratch,
            )  # fmt: skip
            # the padding lanes repeat a block's last sample: read them too (whole vectors)
            lanes = slice(b * sm.BLOCK, (b + 1) * sm.BLOCK)
            nans = sm.keep_block(scratch, size[b], by_block[0, lanes], by_block[1, lanes])
            sm.keep_extremes(scratch, size[b])
            sm.keep_contact(scratch, size[b], by_block[2:, lanes])
            done += count[b]
            if nans:  # out of reach: no need to go on
                bad = True
                count_out[p] = done
                break
        if bad:
            work_out[p], margin_out[p], gap_out[p] = np.inf, -np.inf, np.inf
            friction_out[p], slide_out[p] = np.inf, np.inf
            continue
        friction_out[p], slide_out[p] = _contact(by_block, at, pi, pieces, loaded)
        margin = np.empty(n)
        low, total, previous = np.inf, 0.0, 0.0
        for j in range(n):  # time order: trapezoid of the power, smallest sampled margin
            m, pw = by_block[0, at[j]], by_block[1, at[j]]
            margin[j] = m
            low = min(low, m)
            total += half_step[j] * (pw + previous)
            previous = pw
        gap = -np.inf
        for i in range(6):
            high, low_h = sm.extremes(scratch, i)
            q_high, q_low = 2.0 * np.arctan(high), 2.0 * np.arctan(low_h)
            gap = max(gap, limits[i + 1, 0] - q_low, q_high - limits[i + 1, 1])
        if refine:
            low, extra = _refine_all(args, x, y, pieces, times, inner, margin, low, scratch)
            count_out[p] += extra
        work_out[p], margin_out[p], gap_out[p] = total, low, gap
    return work_out, margin_out, gap_out, count_out, friction_out, slide_out


@dataclass(frozen=True)
class KernelWalk:
    """A robot and a timeline in the kernel's tables, with both sample lists.

    Attributes:
        timeline: The walk's timing.
        gait, chain: ``tables.GaitTable``, ``tables.ChainTable``.
        limits: Joint limits per Table-I joint [rad], (8, 2).
        grid: (pieces, t) of ``timeline.t`` (the plan's samples).
        limit: (pieces, t) of the grid plus one-sided limits at every piece end (the GA's).
        grid_blocks, limit_blocks: Those samples in blocks (``tables.Blocks``).
    """

    timeline: Timeline
    gait: tb.GaitTable
    chain: tb.ChainTable
    limits: np.ndarray
    grid: tuple[np.ndarray, np.ndarray]
    limit: tuple[np.ndarray, np.ndarray]
    grid_blocks: tb.Blocks
    limit_blocks: tb.Blocks

    @classmethod
    def of(cls, spec: RobotSpec, timeline: Timeline) -> KernelWalk:
        gait = tb.GaitTable.of(timeline)
        limits = np.array([spec.joint_limits[kind] for kind in JOINT_KINDS], dtype=float)
        grid, limit = tb.grid_samples(gait, timeline), tb.limit_samples(gait, timeline)
        return cls(
            timeline,
            gait,
            tb.ChainTable.of(spec),
            limits,
            grid,
            limit,
            tb.Blocks.of(gait, *grid),
            tb.Blocks.of(gait, *limit),
        )

    def _args(self, slope: float):
        g, c = self.gait, self.chain
        gravity = gravity_in_slope(slope)
        return (
            g.floats, g.ints, g.landing, c.geometry, c.a, c.d5, c.mass, c.com, c.inertia, gravity
        )  # fmt: skip

    def series(self, slope: float, X) -> np.ndarray:
        """Rows (``sample`` layout) at the grid samples, shape (P, n, ROW).

        X: the population, (P, 3) (paper family) or (P, 6) (``tables.COLUMNS``), as
        ``tables.GaitTable.individuals`` reads it.
        """
        X = self.gait.individuals(X)
        cache.first_use("plan")
        with _LAUNCH:
            out = series(*self._args(slope), X, *_fields(self.grid_blocks), self.grid[1].size)
        cache.compiled("plan")
        return out

    def scores(
        self, slope: float, X, *, samples: str = "limit", refine: bool = True, counts=False,
        contact=False, limits=None, loaded: float = np.inf,
    ):  # fmt: skip
        """(work [J], min margin [m], joint gap [rad]), each (P,); see ``scores``.

        Args:
            X: The population, (P, 3) or (P, 6) (``tables.GaitTable.individuals``).
            samples: "limit" (the GA's: grid plus one-sided limits) or "grid".
            refine: Refine the margin at every local minimum between samples.
            counts: Also return the samples evaluated per individual, (P,).
            contact: Also return the largest friction ratio [-] and the largest slide of
                a loaded foot in double support [m], each (P,) (after the counts).
            limits: Joint limits the gap is measured against [rad], (8, 2); None: the
                spec's (``limits``).
            loaded: Normal force [N] above which a second foot in double support counts
                as loaded for the slide (inf: no slide measured).
        """
        X = self.gait.individuals(X)
        pieces, times = self.limit if samples == "limit" else self.grid
        blocks = self.limit_blocks if samples == "limit" else self.grid_blocks
        bounds = self.limits if limits is None else np.asarray(limits, dtype=float)
        cache.first_use("scores")
        with _LAUNCH:
            out = scores(
                *self._args(slope), bounds, X, pieces, times, *_fields(blocks), refine,
                float(loaded),
            )  # fmt: skip
        cache.compiled("scores")
        head = out[:4] if counts else out[:3]
        return (*head, *out[4:]) if contact else head


def _fields(blocks: tb.Blocks) -> tuple:
    return blocks.inputs, blocks.index, blocks.count, blocks.size, blocks.double


_WALKS: dict = {}


def kernel_walk(spec: RobotSpec, timeline: Timeline) -> KernelWalk:
    """``KernelWalk.of``, remembered for the last few (spec, timing) pairs."""
    key = (
        id(spec),
        timeline.step_time,
        timeline.steps,
        timeline.step_length,
        timeline.ssp_fraction,
        timeline.dt,
        timeline.tilt_profile,
    )
    hit = _WALKS.get(key)
    if hit is not None and hit[0] is spec:
        return hit[1]
    if len(_WALKS) >= 32:
        _WALKS.pop(next(iter(_WALKS)))
    walk = KernelWalk.of(spec, timeline)
    _WALKS[key] = (spec, walk)
    return walk
