"""Flat numeric tables the compiled kernel reads: gait pieces, chain constants, samples.

The walk is cut into pieces on which every parameter-free shape of
``trajectory.Timeline`` is one cubic polynomial of the local time τ = t − t0 [s]:
per step a DSP, then the SSP in two halves (the swing splines have a knot at
mid-swing, the "sway" tilt too), and the closing DSP. Every knot of every spline
is a piece boundary, so on a piece each shape is exactly c0 + c1 τ + c2 τ² + c3 τ³
and the kernel evaluates the gait at any time in closed form.

Shapes (columns ``HIP_X`` … ``SWAY``, each 4 coefficients): hip x relative to
the stance ankle per unit step length [-], swing ankle x relative to the stance
ankle per unit step length [-], swing sole height per unit lift [-], lean λ per
unit tilt of the "hold" profile [-], the stance foot's share of the ground wrench
[-] (``plan._stance_share``), and λ per unit tilt of the "sway" profile [-]. The
sagittal shapes are per unit step length because an individual of the extended
gait family carries its own step length L (every x of the walk is linear in L),
and both lean profiles are kept because its lean is the blend (1 − w)·hold + w·sway
(``COLUMNS``). Times in seconds, angles in radians; positions in the slope frame S.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline

from slopewalk.planner.joints import LEFT, RIGHT
from slopewalk.planner.kinematics import Chain, SpecMemo
from slopewalk.planner.sole import MAX_SOLE_VERTICES, edge_normals, outline
from slopewalk.planner.spec import RobotSpec
from slopewalk.planner.trajectory import Timeline

# float columns of a piece
T0, T1, STANCE_X, TOWARDS = 0, 1, 2, 3
HIP_X, SWING_X, LIFT, TILT, SHARE, SWAY = 4, 8, 12, 16, 20, 24
PIECE_FLOATS = 28
# int columns of a piece
STEP, SIDE, SSP, FOOT, PHASE = 0, 1, 2, 3, 4
PIECE_INTS = 5
# columns of an individual x: Hz [m], Szmax [m], tilt [rad] (the paper's GA variables),
# then the extended family's pelvis offset δ [m] (added to the hip's x in S at every
# instant), step length L [m] and sway share w [-] (lean = (1 − w)·hold + w·sway).
HZ, LIFT_X, TILT_X, PELVIS, STEP_LENGTH, SWAY_SHARE = range(6)
COLUMNS = 6
# geometry vector
SHANK, THIGH, HIP_WIDTH, ANKLE_HEIGHT, HEEL, TOE, HALF_WIDTH, SOLE_OFFSET, KNEE_OFFSET = range(9)
# then the sole (``sole.outline``): its vertex count M, 1.0 if it is the spec's rectangle
# (no ``sole_polygon``: the SSP margin in closed form), the vertices about the sole's
# centre x0, y0, x1, … and the outward unit normals of edges k → k+1, each padded with
# zeros to ``sole.MAX_SOLE_VERTICES``.
# The room is a literal here, not ``sole.MAX_SOLE_VERTICES`` read at compile time: the
# kernel's cache keys on the kernel's own files (``cache``), so a constant the compiled
# code freezes must live in one of them; the two are held equal on import.
MAX_VERTICES = 8
assert MAX_VERTICES == MAX_SOLE_VERTICES, "planner/sole.py and planner/kernel/tables.py"
SOLE_COUNT, SOLE_RECTANGLE = 9, 10
SOLE_XY = 11
SOLE_NORMAL = SOLE_XY + 2 * MAX_VERTICES
GEOMETRY = SOLE_NORMAL + 2 * MAX_VERTICES
# A block (``Blocks``): at most BLOCK samples, in rows of BLOCK floats per input: the
# sample's time [s], then its piece's floats (T0, T1, STANCE_X, TOWARDS, the shapes:
# the same columns as ``GaitTable.floats``, T1 replaced by the time), its stance side
# (0.0 left / 1.0 right) and its footprint index (as a float).
BLOCK = 64
IN_T, IN_SIDE, IN_FOOT = T1, PIECE_FLOATS, PIECE_FLOATS + 1
INPUTS = PIECE_FLOATS + 2
_ALIGN = 8  # a block's length is padded to a multiple of this (one AVX-512 vector)

# The Table-I structure the kernel is written for (kinematics.Chain.from_spec).
_ALPHA = np.array([0, -np.pi / 2, 0, 0, 0, 0, 0, np.pi / 2])
_SIGN = np.array([-1, 1, 1, 1, -1, -1, -1, -1], dtype=float)
_OFFSET = np.array([0, 0, 0, 0, np.pi, 0, 0, 0])


@dataclass(frozen=True)
class GaitTable:
    """The walk as pieces (see module doc).

    Attributes:
        floats: Per piece t0, t1 [s], stance x per unit step length [-], towards-swing
            sign (+1: the swing hip is at +y_S), then 6 shapes × 4 coefficients,
            shape (K, 28).
        ints: Per piece step index (N = closing DSP), stance side (0 left / 1 right),
            in SSP (0/1), footprint index, phase index, shape (K, 5).
        landing: λ per unit tilt at each touch-down k = 0..N-1 [-] of the "hold" (row
            0) and "sway" (row 1) profiles, shape (2, N).
        steps: N.
        default: The timeline's step length [m] and sway share (0 "hold", 1 "sway"):
            what a 3-column (paper family) individual walks with.
    """

    floats: np.ndarray
    ints: np.ndarray
    landing: np.ndarray
    steps: int
    default: tuple

    @classmethod
    def of(cls, timeline: Timeline) -> GaitTable:
        T, N = timeline.step_time, timeline.steps
        dsp, ssp = timeline.dsp_time, timeline.ssp_fraction * timeline.step_time
        end = timeline.t[-1]
        hip = CubicSpline(  # per unit step length
            np.append(np.arange(N) * T, end),
            np.append((2 * np.arange(N) - 1) / 4, (2 * N - 1) / 4),
            bc_type="clamped",
        )
        swing = CubicSpline([0.0, 0.5, 1.0], [-0.5, 0.0, 0.5], bc_type="clamped")
        lift = CubicSpline([0.0, 0.5, 1.0], [0.0, 1.0, 0.0], bc_type="clamped")
        lean = np.where(np.arange(N) % 2 == 0, 1.0, -1.0)
        knots = np.concatenate([[0.0], (np.arange(N) + 1 - timeline.ssp_fraction / 2) * T])
        sway = CubicSpline(
            np.append(knots, end), np.concatenate([[0.0], lean, [0.0]]), bc_type="clamped"
        )
        rows_f, rows_i = [], []
        for k in range(N + 1):
            start = k * T
            spans = [(start, start + dsp, 0)]
            if k < N:
                mid = start + dsp + ssp / 2
                spans += [(start + dsp, mid, 1), (mid, start + T, 1)]
            for t0, t1, in_ssp in spans:
                f = np.zeros(PIECE_FLOATS)
                stance_k = min(k, N - 1)
                side = RIGHT if stance_k % 2 == 0 else LEFT
                f[T0], f[T1] = t0, t1
                f[STANCE_X] = stance_k / 2
                f[TOWARDS] = 1.0 if side == RIGHT else -1.0
                f[HIP_X : HIP_X + 4] = _cubic(lambda t, nu: hip(t, nu), t0, t1)
                f[HIP_X] -= f[STANCE_X]
                if in_ssp:

                    def in_s(spline, t0_ssp=start + dsp):
                        return lambda t, nu: spline((t - t0_ssp) / ssp, nu) / ssp**nu

                    f[SWING_X : SWING_X + 4] = _cubic(in_s(swing), t0, t1)
                    f[LIFT : LIFT + 4] = _cubic(in_s(lift), t0, t1)
                    f[SHARE] = 1.0
                else:
                    f[SWING_X] = -0.5 if k < N else 0.5
                    smooth = np.array([0.0, 0.0, 3 / dsp**2, -2 / dsp**3])
                    if k == 0:
                        f[SHARE : SHARE + 4] = 0.5 * smooth + [0.5, 0, 0, 0]
                    elif k == N:
                        f[SHARE : SHARE + 4] = [1.0, 0, 0, 0] - 0.5 * smooth
                    else:
                        f[SHARE : SHARE + 4] = smooth
                f[SWAY : SWAY + 4] = _cubic(lambda t, nu: sway(t, nu), t0, t1)
                before = 0.0 if k == 0 else lean[k - 1]
                after = lean[k] if k < N else 0.0
                if in_ssp:
                    f[TILT] = after
                else:
                    span = after - before
                    f[TILT : TILT + 4] = [before, 0.0, 3 * span / dsp**2, -2 * span / dsp**3]
                rows_f.append(f)
                rows_i.append([k, side, in_ssp, stance_k, 2 * k + in_ssp])
        floats, ints = np.array(rows_f), np.array(rows_i, dtype=np.int64)
        first = np.searchsorted(floats[:, T0], (np.arange(N) + 1) * T - 1e-9 * T)
        landing = np.stack([floats[first, TILT], floats[first, SWAY]])
        default = (float(timeline.step_length), 1.0 if timeline.tilt_profile == "sway" else 0.0)
        return cls(floats, ints, landing, N, default)

    def individuals(self, X) -> np.ndarray:
        """Population X as the kernel's (P, ``COLUMNS``) array.

        X may have 3 columns (Hz, Szmax, tilt: the paper's family, completed with no
        pelvis offset, the timeline's step length and its tilt profile's sway share)
        or all 6.
        """
        X = np.atleast_2d(np.asarray(X, dtype=float))
        if X.ndim != 2 or X.shape[1] not in (3, COLUMNS):
            raise ValueError(f"population of shape {X.shape}: must be (P, 3) or (P, {COLUMNS})")
        if X.shape[1] == 3:
            rest = np.broadcast_to(np.array([0.0, *self.default]), (X.shape[0], 3))
            X = np.concatenate([X, rest], axis=1)
        return np.ascontiguousarray(X)

    def piece_of(self, timeline: Timeline) -> np.ndarray:
        """Piece index of each sample of ``timeline.t``, by the Timeline's own phase rule."""
        step, in_ssp = timeline.step, timeline.in_ssp
        ssp = timeline.ssp_fraction * timeline.step_time
        tau = timeline.t - step * timeline.step_time - timeline.dsp_time
        return np.where(in_ssp, 3 * step + 1 + (tau > ssp / 2), 3 * step)


def _cubic(f, t0: float, t1: float) -> np.ndarray:
    """Coefficients (c0..c3) in τ = t − t0 of a cubic piece given as f(t, derivative order).

    Evaluated at the piece's midpoint (never ambiguous at a knot), then shifted to t0.
    """
    tm = 0.5 * (t0 + t1)
    b0, b1, b2, b3 = (float(f(tm, nu)) / fact for nu, fact in enumerate((1, 1, 2, 6)))
    d = t0 - tm
    return np.array(
        [b0 + d * (b1 + d * (b2 + d * b3)), b1 + d * (2 * b2 + 3 * d * b3), b2 + 3 * d * b3, b3]
    )


@dataclass(frozen=True)
class ChainTable:
    """The robot's constants in the kernel's layout.

    Attributes:
        geometry: shank, thigh, hip width, ankle height, heel, toe [m], half foot width [m],
            sole offset [m] (the sole's centre outward of the ankle, ``RobotSpec.sole_offset``),
            knee offset [m] (the knee ahead of the hip–ankle line, ``RobotSpec.knee_offset``:
            the DH rows' b, ``kinematics.Chain.b``, and the IK's effective links), then the
            sole polygon (``SOLE_COUNT``, ``SOLE_RECTANGLE``, ``SOLE_XY``, ``SOLE_NORMAL``).
        a: DH a_{i-1} [m], (8,). d5: DH d of the swing hip row per stance side [m], (2,).
        mass: Link masses of DH frames 0..8 [kg], (9,).
        com: Link CoMs in their DH frame [m], (2, 9, 3).
        inertia: Principal moments about the CoM along the DH axes [kg m²], (9, 3): the
            spec's body axes are S-aligned at q = 0, where every DH frame is a signed
            permutation of S, so the inertia is diagonal in DH axes.
    """

    geometry: np.ndarray
    a: np.ndarray
    d5: np.ndarray
    mass: np.ndarray
    com: np.ndarray
    inertia: np.ndarray

    @classmethod
    def of(cls, spec: RobotSpec) -> ChainTable:
        """The table of ``spec``, remembered for the last few specs as ``Chain.from_spec``
        does (a RobotSpec is frozen; the kernel only reads the arrays): a trial asks for it
        5 times, 0.3-0.8 ms each."""
        return _TABLES.get(spec, cls._build)

    @classmethod
    def _build(cls, spec: RobotSpec) -> ChainTable:
        chain = Chain.from_spec(spec)
        assert np.allclose(chain.alpha, _ALPHA) and np.array_equal(chain.theta_sign, _SIGN)
        assert np.allclose(chain.theta_offset, _OFFSET)
        assert not np.delete(chain.d, 4, axis=1).any()
        k = spec.knee_offset
        assert np.array_equal(chain.b, [0, 0, -k, k, 0, k, -k, 0])
        assert np.array_equal(chain.inertia[0], chain.inertia[1])
        diagonal = np.einsum("kii->ki", chain.inertia[0])
        off = chain.inertia[0] - np.einsum("ki,ij->kij", diagonal, np.eye(3))
        assert np.abs(off).max() <= 1e-12 * diagonal.max()
        sole = outline(spec)
        room = np.zeros((2, MAX_VERTICES, 2))
        room[0, : len(sole)], room[1, : len(sole)] = sole, edge_normals(sole)
        shape = [len(sole), float(spec.sole_polygon is None)]
        geometry = np.array(
            [
                spec.shank,
                spec.thigh,
                spec.hip_width,
                spec.ankle_height,
                spec.heel_offset,
                spec.ankle_to_toe,
                spec.foot_width / 2,
                spec.sole_offset,
                spec.knee_offset,
                *shape,
                *room.reshape(-1),
            ]
        )
        return cls(
            geometry,
            chain.a.copy(),
            chain.d[:, 4].copy(),
            chain.mass.copy(),
            chain.com.copy(),
            np.ascontiguousarray(diagonal),
        )


_TABLES: SpecMemo[ChainTable] = SpecMemo()  # ChainTable.of's memory


def grid_samples(table: GaitTable, timeline: Timeline) -> tuple[np.ndarray, np.ndarray]:
    """The plan's samples: ``timeline.t`` with the Timeline's phase rule.

    Returns:
        (piece index (n,), t [s] (n,)).
    """
    return table.piece_of(timeline), timeline.t.copy()


PROBE = 1e-3  # a probe's distance from a piece's end, in units of its sample spacing


def limit_samples(table: GaitTable, timeline: Timeline) -> tuple[np.ndarray, np.ndarray]:
    """The GA's samples: the grid of ``timeline`` plus both one-sided limits of every phase.

    Each piece gets the grid times strictly inside it, and each end of a phase (DSP,
    SSP) is a sample of the piece on its side, so every phase change is seen from both
    sides (last DSP sample, first SSP sample at the same instant); next to each such
    end a probe ``PROBE`` of the sample spacing inside: where the margin still falls
    going inwards from an end, the probe is a local minimum of the samples and
    ``run.scores`` refines the bracket (end, probe, next sample). The knot between the
    SSP's two pieces, where the gait is continuous to its accelerations and so the
    margin too, is one sample (of the first piece). Sorted by time, pieces in order.
    (The knot's second copy and its probes were 12 of 479 samples at 100 per step, and
    put the SSP's 252 others in 5 blocks of 64 rather than 4.)

    Returns:
        (piece index (m,), t [s] (m,)).
    """
    t = timeline.t
    eps = 1e-9 * timeline.step_time
    phase = table.ints[:, PHASE]
    pieces, times = [], []
    for k, (t0, t1) in enumerate(table.floats[:, [T0, T1]]):
        inner = t[(t > t0 + eps) & (t < t1 - eps)]
        first, last = (inner[0], inner[-1]) if inner.size else (t1, t0)
        starts = k == 0 or phase[k - 1] != phase[k]
        ends = k == len(phase) - 1 or phase[k + 1] != phase[k]
        head = [t0, t0 + PROBE * (first - t0)] if starts else []
        tail = [t1 - PROBE * (t1 - last), t1] if ends else [t1]  # a knot inside a phase: once
        ts = np.concatenate([head, inner, tail])
        pieces.append(np.full(ts.size, k))
        times.append(ts)
    return np.concatenate(pieces), np.concatenate(times)


@dataclass(frozen=True)
class Blocks:
    """A sample list cut into blocks of ``BLOCK`` samples of one support kind (SSP or DSP).

    The samples of each kind are taken in time order, 64 at a time, and a block's last
    sample is repeated up to a multiple of 8, so the kernel's loops over a block run
    whole vectors; only a block's first ``count`` samples are read back.

    Attributes:
        inputs: Per block, per input (``IN_T`` … ``INPUTS``), a row of ``BLOCK``
            floats, flat (blocks × INPUTS × BLOCK,).
        index: Position of each sample of a block in the sample list, (blocks, BLOCK).
        count: Samples of each block, (blocks,); size: the padded length, (blocks,).
        double: 1 for a block of double-support samples, (blocks,).
    """

    inputs: np.ndarray
    index: np.ndarray
    count: np.ndarray
    size: np.ndarray
    double: np.ndarray

    @classmethod
    def of(cls, table: GaitTable, pieces: np.ndarray, times: np.ndarray) -> Blocks:
        ssp = table.ints[pieces, SSP]
        chunks = []
        for kind in (1, 0):
            where = np.flatnonzero(ssp == kind)
            chunks += [where[k : k + BLOCK] for k in range(0, where.size, BLOCK)]
        count = np.array([c.size for c in chunks], dtype=np.int64)
        size = -(-count // _ALIGN) * _ALIGN
        index = np.empty((len(chunks), BLOCK), dtype=np.int64)
        for b, c in enumerate(chunks):
            index[b, : c.size], index[b, c.size :] = c, c[-1]
        rows = np.empty((len(chunks), INPUTS, BLOCK))
        piece = pieces[index]
        rows[:, :PIECE_FLOATS] = np.moveaxis(table.floats[piece], 2, 1)
        rows[:, IN_T] = times[index]
        rows[:, IN_SIDE] = table.ints[piece, SIDE]
        rows[:, IN_FOOT] = table.ints[piece, FOOT]
        double = 1 - table.ints[pieces[index[:, 0]], SSP]
        return cls(rows.ravel(), index, count, size, double.astype(np.int64))
