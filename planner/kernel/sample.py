"""Blocks of samples of the analytic pipeline, compiled: gait, IK, FK, Newton-Euler, ZMP, margin.

``evaluate_block`` computes, for one individual (``tables.COLUMNS``) at up to
``BLOCK`` samples of one support kind (``tables.Blocks``: each sample carries its
time and its gait piece's coefficients, so a block takes samples of several pieces
and steps, and is full), what ``plan.Plan`` holds at those instants. The samples
are the innermost loop of every stage and every stage is one branch-free loop over
them, with the chain's known structure (the DH twists 0, ∓π/2, the one non-zero
offset d5) hoisted out of it, so the loops vectorise (SIMD over samples). Quantities
live in structure-of-arrays scratch (``Scratch``: one row of ``BLOCK`` floats per
scalar). The maths is that of the readable modules:

* gait: the piece's cubics and their derivatives (``tables``), the tilted-plane
  heights of ``ik.tilted_plane_height``;
* IK (``ik.leg_ik``): sines and cosines of the leg angles come from the law of
  cosines and angle addition, no trigonometric call (a knee offset: the effective
  links' angles turned by the constant γ_s, γ_t, as cos/sin of γ = S/L', k/L'); the
  angles themselves (atan2, acos) only for a plan's joint vector q. A score needs the
  joint angles only for the joint-limit check, and takes it from
  tan(q/2) = sin q / (1 + cos q), which is increasing in q on (−π, π): the extremes
  of q over the samples are those of tan(q/2), turned back into angles once per
  individual (``run``);
* FK (``kinematics.Chain.poses``): Table I's rows with their known twists;
* Newton-Euler (``newton_euler.inverse_dynamics_poses``) with every vector in S,
  then the DSP split of the ground wrench (``newton_euler.swing_wrench_torques``);
* the multibody ZMP of eq. (4) (``zmp.zmp_multibody``) as the CoP of the recursion's
  ground wrench, the point of the plane where its tangential moment vanishes: the
  same sums (Σ m_i (a_i − g) = F, Σ q_i × m_i (a_i − g) + Ḣ_i = the moment about the
  origin of S), which the recursion has already added up (summing them apart cost
  2-3 ns per sample); the numpy reference sums eq. (4) link by link and a test holds
  the two equal. Then the support polygon and its signed margin
  (``zmp.support_polygon``, ``zmp.signed_margin``), the friction ratio and the LIPM ZMP.

All vectors are in the slope frame S [m, m/s, m/s², N, N m]; angles [rad].

Layout of the scratch: one flat array ``w`` of rows of ``BLOCK`` floats, row r holding
one quantity over the block (w[r + j] at sample j, r a multiple of ``BLOCK``), every
row offset a compile-time constant (but in the outward recursion's loop over links,
``_outward``). The compiler then sees that the rows a loop writes never overlap the
rows it reads, which it must know to vectorise the loop (rows of separate arrays, or
of a 2-D array with run-time strides, it cannot tell apart); and every stage bounds
its loops' trip count by ``BLOCK`` (``min(n, B)``), since a row's distance from the
next is then at least the trip count: without the bound the compiler must assume the
rows may overlap and leaves the loops scalar.

Measured per sample on one core (block of 64, numba 0.68, Zen 5 AVX-512, load ~2):
copying the block's inputs 1 ns, gait and IK 11 ns in SSP and 20 in DSP (of which ~9
ns libm's sin/cos of λ, a scalar loop: numba vectorises them only through SVML, which
llvmlite 0.50's wheels are built without, and its ``-vector-library`` option had no
effect with glibc's libmvec either; a branch-free sin/cos of our own measured 13 ns
but would be a home-made copy of libm, so it is not used; in SSP the "hold" lean's λ
is constant and sin/cos run once per step), FK 8.5-10, outward recursion 20-22,
inward 12.5-15 (SSP: no swing split) or 13.5-19 (DSP), margin 1 (SSP) or 6 (DSP); a
whole block ~63-70 ns in SSP, ~79-87 in DSP (was 73-78 for either). A block's cost
is far from proportional to its samples: the samples past the last multiple of 8 run
scalar (~400-900 ns each), and each stage has a fixed cost, so a block of 64 cost 73
ns per sample, one of 33 (the GA's SSP pieces at 100 samples per step) 108 and one of 43
(its DSPs) 113, before blocks took several pieces: hence full blocks, padded to a
multiple of 8. A larger block does not help (128: 79 ns, the scratch outgrows the
caches), a smaller one neither (32: 92 ns).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from slopewalk.planner.kernel import tables as tb

# Row layout of a plan sample (``write_rows``): where each quantity sits.
Q, QD, QDD, TAU = 0, 8, 16, 24  # (8,) each: Table-I order [rad, rad/s, rad/s², N m]
ZMP, ZMP_LIPM, COP = 32, 34, 36  # (2,) each [m]
COM, COM_ACC = 38, 41  # (3,) whole-body CoM [m] and its acceleration [m/s²]
STANCE_SOLE, SWING_SOLE = 44, 47  # (3,) [m]
MARGIN = 50  # signed ZMP margin [m], positive inside
GROUND, STANCE_FORCE, SWING_FORCE = 51, 54, 57  # (3,) [N]
FRICTION = 60  # |F_t| / F_n of the total ground force
POWER = 61  # Σ |τ θ̇| [W]
POWER_JOINTS = 62  # (8,) |τ_i θ̇_i| [W]
LEG_DISTANCE = 70  # (2,) hip-ankle distance of the stance and swing legs [m]
# support polygon vertices [m]: (2M, 2) of a sole of M vertices (``tables.SOLE_COUNT``),
# room for ``tables.MAX_VERTICES``; the columns past 4M are NaN
POLYGON = 72
POLYGON_FLOATS = 4 * tb.MAX_VERTICES
ROW = POLYGON + POLYGON_FLOATS

BLOCK = tb.BLOCK  # samples per block at most
B = BLOCK  # one row of the scratch

# Scalar rows (offsets into the scratch; n consecutive rows are n·B apart)
_QD, _QDD = 0 * B, 8 * B  # joint rates and accelerations (8 rows each)
_CT, _ST = 16 * B, 24 * B  # cos/sin of the DH angle θ_i of row i (8 each)
_HALF = 32 * B  # tan(q/2) of the pitch joints q2..q7 (6)
_LAM = 38 * B  # λ
_SHARE = 39 * B  # stance share of the ground wrench
_SW = 40 * B  # swing sole (3)
_DIST = 43 * B  # hip-ankle distances (2)
_IK = 45 * B  # (u, w, cos φ, e_u, e_w) of the stance leg, then of the swing leg (10)
_OMEGA, _DOMEGA, _ACC = 55 * B, 58 * B, 61 * B  # ω, ω̇, acceleration − g of a joint origin
_F, _M = 64 * B, 67 * B  # inward force and moment (3 each)
_SM = 70 * B  # ground moment about the stance sole point (3)
_FS, _MS = 73 * B, 76 * B  # the swing foot's share of the ground wrench (3 + 3)
_ZX, _ZY = 79 * B, 80 * B  # ZMP
_POWER = 81 * B
_MARGIN = 82 * B
_VERT = 83 * B  # polygon vertices x0, y0, x1, … (POLYGON_FLOATS)
_TAURAW = _VERT + POLYGON_FLOATS * B  # m · u of each joint before the swing split (9: row 0 unused)
_TAU = _TAURAW + 9 * B  # joint torques (8)
_SEG = _TAU + 8 * B  # smallest squared distance of the ZMP to a polygon edge
_XS, _YS = _SEG + B, _SEG + 2 * B  # the stance sole's x and y
_COUNT = _SEG + 3 * B  # w[_COUNT]: the support polygon's vertex count 2M (one float)
_IN = _SEG + 4 * B  # the block's inputs (``tables.Blocks``: INPUTS rows)
_SIDE = _IN + tb.IN_SIDE * B  # stance side, 0.0 left / 1.0 right
_SCALARS = _IN + tb.INPUTS * B
# Frames 0..8 from _FR, FRAME rows each: 3 r + c is R[r, c] (column c the frame's axis
# x, y, z; row r its S component), 9..11 the origin.
FRAME = 12 * B
_FR = _SCALARS
N_LINK = 9
# Links 0..8 from _LK, LINK rows each: CoM offset c (3), CoM acceleration − g (3), rate
# of angular momentum about the CoM (3). (Link i's joint axis u_i is ±z of frame i,
# ``_AXIS_SIGN``: read from the frame, not copied.)
_C, _A, _H = 0 * B, 3 * B, 6 * B
LINK = 9 * B
_LK = _FR + N_LINK * FRAME
# Running extremes of tan(q/2) of q2..q7 per lane of the block, over an individual's
# blocks (``start_extremes``, ``keep_extremes``): maxima (6 rows), then minima (6).
_EXT = _LK + N_LINK * LINK
SCRATCH = _EXT + 12 * B

_KW = {"cache": True, "error_model": "numpy", "nogil": True}

# Joint axis sign of link i (θ_i = sign q_i + offset): −1 on 1 and 5..8.
_AXIS_SIGN = (1.0, -1.0, 1.0, 1.0, 1.0, -1.0, -1.0, -1.0, -1.0)


@njit(**_KW)
def scratch():
    """A fresh scratch for one block (module layout), shape (SCRATCH,)."""
    return np.empty(SCRATCH)


@njit(**_KW)
def load_sample(pf, pi, piece, t, j, w):
    """The inputs of sample j of the scratch: time t [s] on ``piece`` (``tables.Blocks``)."""
    for c in range(tb.PIECE_FLOATS):
        w[_IN + c * B + j] = pf[piece, c]
    w[_IN + tb.IN_T * B + j] = t
    w[_IN + tb.IN_SIDE * B + j] = pi[piece, tb.SIDE]
    w[_IN + tb.IN_FOOT * B + j] = pi[piece, tb.FOOT]


@njit(**_KW)
def _cubic(w, col, j, tau):
    """Value and first two τ-derivatives of c0 + c1 τ + c2 τ² + c3 τ³ (input rows col..col+3)."""
    r = _IN + col * B + j
    c0, c1, c2, c3 = w[r], w[r + B], w[r + 2 * B], w[r + 3 * B]
    p = c0 + tau * (c1 + tau * (c2 + tau * c3))
    v = c1 + tau * (2.0 * c2 + 3.0 * tau * c3)
    a = 2.0 * c2 + 6.0 * tau * c3
    return p, v, a


@njit(**_KW)
def _half_tan(sn, c):
    """tan(q/2) from sin q and cos q, in the form without cancellation on each half."""
    # one division, its operands chosen (a vector loop would run both of two divisions)
    num, den = (sn, 1.0 + c) if c >= 0 else (1.0 - c, sn)
    return num / den


@njit(inline="always", **_KW)  # inlined in numba's IR: a call would stop vectorisation
def _leg(up, uv, ua, wq, wv, wa, l1, l2):
    """``ik.two_link_ik`` of one leg at one sample, without trigonometric calls.

    (u, w): hip − ankle along x_S and the tilted plane's normal [m] and two rates.
    Returns cos, sin, rate, acceleration of β_shank and of β_thigh, the hip-ankle
    distance [m], and cos φ (the law-of-cosines angle at the ankle). NaNs where the
    target is out of reach.
    """
    d2 = up * up + wq * wq
    d = np.sqrt(d2)
    d = d if (d < l1 + l2) and (d > abs(l1 - l2)) else np.nan
    # divisions, not reciprocals: a plan's joint angles stay those of ``ik.two_link_ik``
    # to the bit (products with reciprocals, ~1.5 ns per sample faster, moved them by an
    # ulp, and that flipped 4 of the paper sweep's 50 simulated verdicts)
    cpsi, spsi = wq / d, up / d
    cphi = (l1 * l1 + d * d - l2 * l2) / (2.0 * l1 * d)
    sphi = np.sqrt(1.0 - cphi * cphi)
    cs = cpsi * cphi - spsi * sphi  # β_shank = ψ + φ
    ss = spsi * cphi + cpsi * sphi
    eu, ew = up - l1 * ss, wq - l1 * cs
    norm = np.sqrt(eu * eu + ew * ew)
    ct, st = ew / norm, eu / norm
    j11, j12, j21, j22 = l1 * cs, l2 * ct, -l1 * ss, -l2 * st
    det = j11 * j22 - j12 * j21
    vs = (j22 * uv - j12 * wv) / det
    vt = (-j21 * uv + j11 * wv) / det
    ru = ua + (l1 * ss * vs * vs + l2 * st * vt * vt)
    rw = wa + (l1 * cs * vs * vs + l2 * ct * vt * vt)
    as_ = (j22 * ru - j12 * rw) / det
    at = (-j21 * ru + j11 * rw) / det
    return cs, ss, vs, as_, ct, st, vt, at, np.sqrt(d2), cphi, eu, ew


# long: a numba kernel whose stages are loops over the block, timed as one (module doc)
@njit(**_KW)
def _gait_ik(x, y, geometry, n, w):
    """Gait in closed form and the IK of both legs: rates, DH cos/sin, tan(q/2), λ, share.

    Also the stance sole's position (``_XS``, ``_YS``) from the individual's footprints
    y [m] (``run._footprints``).
    """
    n = min(n, B)  # a bound on the trip count (module doc)
    # the effective links and the cos/sin of their angles γ_s, γ_t to the links' own axes
    # (``ik.leg_ik``); without a knee offset l1, l2 are shank, thigh and cos γ = 1, sin γ = 0
    # exactly, so every turn below leaves its operands' bits as they were
    knee = geometry[tb.KNEE_OFFSET]
    l1, l2 = np.hypot(geometry[tb.SHANK], knee), np.hypot(geometry[tb.THIGH], knee)
    cgs, sgs = geometry[tb.SHANK] / l1, knee / l1
    cgt, sgt = geometry[tb.THIGH] / l2, knee / l2
    lh, lan = geometry[tb.HIP_WIDTH], geometry[tb.ANKLE_HEIGHT]
    hz, lift, tilt = x[tb.HZ], x[tb.LIFT_X], x[tb.TILT_X]
    step, sway, pelvis = x[tb.STEP_LENGTH], x[tb.SWAY_SHARE], x[tb.PELVIS]
    t_row, t0_row = _IN + tb.IN_T * B, _IN + tb.T0 * B
    for j in range(n):  # a gather: a loop of its own
        w[_YS + j] = y[int(w[_IN + tb.IN_FOOT * B + j])]
    for j in range(n):
        tau = w[t_row + j] - w[t0_row + j]
        mp, mv, ma = _cubic(w, tb.TILT, j, tau)
        wp, wv, wa = _cubic(w, tb.SWAY, j, tau)
        w[_LAM + j] = tilt * (mp + sway * (wp - mp))
        w[_XS + j] = step * w[_IN + tb.STANCE_X * B + j]
    # sin and cos of λ: a scalar loop of its own (libm calls do not vectorise), called
    # once per run of equal λ: a block's samples are in time order, and with the "hold"
    # lean (the paper's) λ is one constant through each SSP
    last, sl, cl = np.nan, np.nan, np.nan
    for j in range(n):
        lam = w[_LAM + j]
        if lam != last:
            last, sl, cl = lam, np.sin(lam), np.cos(lam)
        w[_ST + j], w[_CT + j] = sl, cl
    for j in range(n):
        tau = w[t_row + j] - w[t0_row + j]
        towards = w[_IN + tb.TOWARDS * B + j]
        k_hip = 0.5 * towards * lh  # the pelvis centre's lateral lever
        k_sole = towards * lh  # the swing sole's
        hxp, hxv, hxa = _cubic(w, tb.HIP_X, j, tau)
        sxp, sxv, sxa = _cubic(w, tb.SWING_X, j, tau)
        lp, lv, la = _cubic(w, tb.LIFT, j, tau)
        mp, mv, ma = _cubic(w, tb.TILT, j, tau)
        wp, wv, wa = _cubic(w, tb.SWAY, j, tau)
        w[_SHARE + j] = _cubic(w, tb.SHARE, j, tau)[0]
        hxp, hxv, hxa = step * hxp + pelvis, step * hxv, step * hxa
        sxp, sxv, sxa = step * sxp, step * sxv, step * sxa
        lamv, lama = tilt * (mv + sway * (wv - mv)), tilt * (ma + sway * (wa - ma))
        sl, cl = w[_ST + j], w[_CT + j]
        # tilted-plane heights z' = (h − k sin λ) / cos λ with rates (ik.tilted_plane_height)
        sec = 1.0 / cl
        bv = sl * sec * sec * lamv
        ba = sl * sec * sec * lama + (1.0 + sl * sl) * sec * sec * sec * lamv * lamv
        zh, zv, za = lift * lp, lift * lv, lift * la
        ap, av = zh - k_sole * sl, zv - k_sole * cl * lamv
        aa = za - k_sole * (cl * lama - sl * lamv * lamv)
        zp, zv, za = ap * sec, av * sec + ap * bv, aa * sec + 2.0 * av * bv + ap * ba
        ap, av = hz - lan - k_hip * sl, -k_hip * cl * lamv
        aa = -k_hip * (cl * lama - sl * lamv * lamv)
        hp, hv, ha = ap * sec, av * sec + ap * bv, aa * sec + 2.0 * av * bv + ap * ba
        # IK of both legs (stance: ankle → hip; swing: its ankle → hip)
        cs, ss, vs, as_, ct, st, vt, at, dst, cphi, eu, ew = _leg(hxp, hxv, hxa, hp, hv, ha, l1, l2)
        # (u, w) turned by −γ_s and (e_u, e_w) by +γ_t, so that ``joint_angles``'s atan2
        # give the links' own angles β_s = β_s' − γ_s, β_t = β_t' + γ_t
        w[_IK + j], w[_IK + B + j] = hxp * cgs - hp * sgs, hp * cgs + hxp * sgs
        w[_IK + 2 * B + j] = cphi
        w[_IK + 3 * B + j], w[_IK + 4 * B + j] = eu * cgt + ew * sgt, ew * cgt - eu * sgt
        cs, ss = cs * cgs + ss * sgs, ss * cgs - cs * sgs
        ct, st = ct * cgt - st * sgt, st * cgt + ct * sgt
        up, wq = hxp - sxp, hp - zp
        cs2, ss2, vs2, as2, ct2, st2, vt2, at2, dsw, cphi, eu, ew = _leg(
            up, hxv - sxv, hxa - sxa, wq, hv - zv, ha - za, l1, l2
        )
        w[_IK + 5 * B + j], w[_IK + 6 * B + j] = up * cgs - wq * sgs, wq * cgs + up * sgs
        w[_IK + 7 * B + j] = cphi
        w[_IK + 8 * B + j], w[_IK + 9 * B + j] = eu * cgt + ew * sgt, ew * cgt - eu * sgt
        cs2, ss2 = cs2 * cgs + ss2 * sgs, ss2 * cgs - cs2 * sgs
        ct2, st2 = ct2 * cgt - st2 * sgt, st2 * cgt + ct2 * sgt
        w[_DIST + j], w[_DIST + B + j] = dst, dsw
        # joint rates and accelerations in Table-I order
        w[_QD + j], w[_QD + 7 * B + j] = -lamv, -lamv
        w[_QD + B + j], w[_QD + 2 * B + j], w[_QD + 3 * B + j] = -vs, vs - vt, vt
        w[_QD + 4 * B + j], w[_QD + 5 * B + j], w[_QD + 6 * B + j] = vt2, vs2 - vt2, -vs2
        w[_QDD + j], w[_QDD + 7 * B + j] = -lama, -lama
        w[_QDD + B + j], w[_QDD + 2 * B + j], w[_QDD + 3 * B + j] = -as_, as_ - at, at
        w[_QDD + 4 * B + j], w[_QDD + 5 * B + j], w[_QDD + 6 * B + j] = at2, as2 - at2, -as2
        # cos/sin of θ_i = sign_i q_i + offset_i, by angle addition
        c3, s3 = cs * ct + ss * st, ss * ct - cs * st  # θ3 = β_s − β_t
        c6, s6 = ct2 * cs2 + st2 * ss2, st2 * cs2 - ct2 * ss2  # θ6 = β_t2 − β_s2
        w[_CT + B + j], w[_ST + B + j] = cs, -ss
        w[_CT + 2 * B + j], w[_ST + 2 * B + j] = c3, s3
        w[_CT + 3 * B + j], w[_ST + 3 * B + j] = ct, st
        w[_CT + 4 * B + j], w[_ST + 4 * B + j] = -ct2, st2
        w[_CT + 5 * B + j], w[_ST + 5 * B + j] = c6, s6
        w[_CT + 6 * B + j], w[_ST + 6 * B + j] = cs2, ss2
        w[_CT + 7 * B + j], w[_ST + 7 * B + j] = cl, sl
        # tan(q/2) of q2..q7 = (−β_s, β_s − β_t, β_t, β_t2, β_s2 − β_t2, −β_s2)
        w[_HALF + j] = _half_tan(-ss, cs)
        w[_HALF + B + j] = _half_tan(s3, c3)
        w[_HALF + 2 * B + j] = _half_tan(st, ct)
        w[_HALF + 3 * B + j] = _half_tan(st2, ct2)
        w[_HALF + 4 * B + j] = _half_tan(-s6, c6)
        w[_HALF + 5 * B + j] = _half_tan(-ss2, cs2)


@njit(**_KW)
def _principal(q):
    """q wrapped to (−π, π] [rad], values inside untouched (``joints.principal_angle``)."""
    return q if (-np.pi < q <= np.pi) or q != q else np.pi - (np.pi - q) % (2.0 * np.pi)


@njit(**_KW)
def joint_angles(w, n, out, index, base):
    """The joint vector q [rad] of the block into out[index[j], base:base+8] (a plan's rows).

    From ``ik.two_link_ik``'s angles, β_shank = atan2(u, w) + acos(cos φ), each joint
    as its principal value (``joints.principal_angle``).
    """
    for j in range(n):
        lam = w[_LAM + j]
        bs = np.arctan2(w[_IK + j], w[_IK + B + j]) + np.arccos(w[_IK + 2 * B + j])
        bt = np.arctan2(w[_IK + 3 * B + j], w[_IK + 4 * B + j])
        bs2 = np.arctan2(w[_IK + 5 * B + j], w[_IK + 6 * B + j]) + np.arccos(w[_IK + 7 * B + j])
        bt2 = np.arctan2(w[_IK + 8 * B + j], w[_IK + 9 * B + j])
        q = (-lam, -bs, bs - bt, bt, bt2, bs2 - bt2, -bs2, -lam)
        for i in range(8):
            out[index[j], base + i] = _principal(q[i])


@njit(**_KW)
def _kinematics(geometry, dh_a, d5, n, w):
    """Frames 0..8 (``kinematics.Chain.poses``, its rows' b the knee offset) and the swing
    sole point."""
    n = min(n, B)  # a bound on the trip count (module doc)
    lan, k = geometry[tb.ANKLE_HEIGHT], geometry[tb.KNEE_OFFSET]
    # frame 0: columns x0 = z_S, y0 = −y_S, z0 = x_S; origin at the stance ankle
    for j in range(n):
        w[_FR + j], w[_FR + B + j], w[_FR + 2 * B + j] = 0.0, 0.0, 1.0
        w[_FR + 3 * B + j], w[_FR + 4 * B + j], w[_FR + 5 * B + j] = 0.0, -1.0, 0.0
        w[_FR + 6 * B + j], w[_FR + 7 * B + j], w[_FR + 8 * B + j] = 1.0, 0.0, 0.0
        w[_FR + 9 * B + j], w[_FR + 10 * B + j] = w[_XS + j], w[_YS + j]
        w[_FR + 11 * B + j] = lan
    # one call per row, its index and twist literals, inlined (numba IR) so that every
    # offset is a constant (see ``_outward``); Table I's twists RotX(α) as cos α, sin α:
    # α = −π/2 on row 2 (index 1), +π/2 on row 8 (index 7), 0 elsewhere
    _frame(0, 1.0, 0.0, dh_a[0], 0.0, d5, n, w)
    _frame(1, 0.0, -1.0, dh_a[1], 0.0, d5, n, w)
    _frame(2, 1.0, 0.0, dh_a[2], -k, d5, n, w)
    _frame(3, 1.0, 0.0, dh_a[3], k, d5, n, w)
    _frame(4, 1.0, 0.0, dh_a[4], 0.0, d5, n, w)
    _frame(5, 1.0, 0.0, dh_a[5], k, d5, n, w)
    _frame(6, 1.0, 0.0, dh_a[6], -k, d5, n, w)
    _frame(7, 0.0, 1.0, dh_a[7], 0.0, d5, n, w)
    f = _FR + 8 * FRAME
    for j in range(n):  # swing sole: ankle_height along x8
        w[_SW + j] = w[f + 9 * B + j] + w[f + j] * lan
        w[_SW + B + j] = w[f + 10 * B + j] + w[f + 3 * B + j] * lan
        w[_SW + 2 * B + j] = w[f + 11 * B + j] + w[f + 6 * B + j] * lan


@njit(inline="always", **_KW)
def _frame(i, ca, sa, a, b, d5, n, w):
    """Frame i + 1 from frame i by row i of Table I: RotX(α) Trans(a, b, d) RotZ(θ).

    ca, sa: cos α, sin α of the row (Table I's twist), literals at the call: a tuple
    read at a literal index compiles an overload per index (~50 ms each).

    d is 0 but on row 4, where it is d5 of the sample's stance side; b is the knee
    offset's shift (``kinematics`` module doc), added only where it is not 0 (so a leg
    without one keeps eq. (1)'s sums, bit for bit).
    """
    n = min(n, B)  # a bound on the trip count (module doc)
    f, g = _FR + i * FRAME, _FR + (i + 1) * FRAME  # frame i, frame i + 1
    d_left, d_right = (d5[0], d5[1]) if i == 4 else (0.0, 0.0)
    for j in range(n):
        d = d_right if w[_SIDE + j] > 0.5 else d_left
        x0, x1, x2 = w[f + j], w[f + 3 * B + j], w[f + 6 * B + j]
        y0, y1, y2 = w[f + B + j], w[f + 4 * B + j], w[f + 7 * B + j]
        z0, z1, z2 = w[f + 2 * B + j], w[f + 5 * B + j], w[f + 8 * B + j]
        # RotX(α) of the row
        yt0, yt1, yt2 = ca * y0 + sa * z0, ca * y1 + sa * z1, ca * y2 + sa * z2
        zt0, zt1, zt2 = ca * z0 - sa * y0, ca * z1 - sa * y1, ca * z2 - sa * y2
        w[g + 9 * B + j] = w[f + 9 * B + j] + x0 * a + zt0 * d
        w[g + 10 * B + j] = w[f + 10 * B + j] + x1 * a + zt1 * d
        w[g + 11 * B + j] = w[f + 11 * B + j] + x2 * a + zt2 * d
        c, sn = w[_CT + i * B + j], w[_ST + i * B + j]
        w[g + j] = x0 * c + yt0 * sn
        w[g + 3 * B + j] = x1 * c + yt1 * sn
        w[g + 6 * B + j] = x2 * c + yt2 * sn
        w[g + B + j] = yt0 * c - x0 * sn
        w[g + 4 * B + j] = yt1 * c - x1 * sn
        w[g + 7 * B + j] = yt2 * c - x2 * sn
        w[g + 2 * B + j], w[g + 5 * B + j], w[g + 8 * B + j] = zt0, zt1, zt2
    if b != 0.0:  # the knee offset: along the twisted y axis of frame i
        for j in range(n):
            w[g + 9 * B + j] += b * (ca * w[f + B + j] + sa * w[f + 2 * B + j])
            w[g + 10 * B + j] += b * (ca * w[f + 4 * B + j] + sa * w[f + 5 * B + j])
            w[g + 11 * B + j] += b * (ca * w[f + 7 * B + j] + sa * w[f + 8 * B + j])


@njit(inline="always", **_KW)
def _link(i, com, inertia, n, w):
    """Link i ≥ 1 of the outward recursion: ω, ω̇ and a − g carried from joint origin
    i − 1 to origin i (rotation about u_i), then the link's CoM offset, CoM
    acceleration − g and Ḣ (link 0: ``_outward``).

    The CoM in the DH frame is that of the sample's stance side.
    """
    n = min(n, B)  # a bound on the trip count (module doc)
    f, lk, e = _FR + i * FRAME, _LK + i * LINK, _FR + (i - 1) * FRAME
    qd, qdd = _QD + (i - 1) * B, _QDD + (i - 1) * B
    sign = _AXIS_SIGN[i]
    l0, l1, l2 = com[0, i, 0], com[0, i, 1], com[0, i, 2]
    r0, r1, r2 = com[1, i, 0], com[1, i, 1], com[1, i, 2]
    i0, i1, i2 = inertia[i, 0], inertia[i, 1], inertia[i, 2]  # principal, DH axes
    for j in range(n):
        right = w[_SIDE + j] > 0.5
        cb0, cb1, cb2 = (r0, r1, r2) if right else (l0, l1, l2)
        r00, r01, r02 = w[f + j], w[f + B + j], w[f + 2 * B + j]
        r10, r11, r12 = w[f + 3 * B + j], w[f + 4 * B + j], w[f + 5 * B + j]
        r20, r21, r22 = w[f + 6 * B + j], w[f + 7 * B + j], w[f + 8 * B + j]
        wx, wy, wz = w[_OMEGA + j], w[_OMEGA + B + j], w[_OMEGA + 2 * B + j]
        dx, dy, dz = w[_DOMEGA + j], w[_DOMEGA + B + j], w[_DOMEGA + 2 * B + j]
        ax, ay, az = w[_ACC + j], w[_ACC + B + j], w[_ACC + 2 * B + j]
        ux, uy, uz = sign * r02, sign * r12, sign * r22
        rx = w[f + 9 * B + j] - w[e + 9 * B + j]
        ry = w[f + 10 * B + j] - w[e + 10 * B + j]
        rz = w[f + 11 * B + j] - w[e + 11 * B + j]
        t0, t1, t2 = wy * rz - wz * ry, wz * rx - wx * rz, wx * ry - wy * rx
        ax += dy * rz - dz * ry + wy * t2 - wz * t1
        ay += dz * rx - dx * rz + wz * t0 - wx * t2
        az += dx * ry - dy * rx + wx * t1 - wy * t0
        q1, q2 = w[qd + j], w[qdd + j]
        sx, sy, sz = q1 * ux, q1 * uy, q1 * uz
        dx, dy, dz = (
            dx + wy * sz - wz * sy + q2 * ux,
            dy + wz * sx - wx * sz + q2 * uy,
            dz + wx * sy - wy * sx + q2 * uz,
        )
        wx, wy, wz = wx + sx, wy + sy, wz + sz
        w[_ACC + j], w[_ACC + B + j], w[_ACC + 2 * B + j] = ax, ay, az
        w[_DOMEGA + j], w[_DOMEGA + B + j], w[_DOMEGA + 2 * B + j] = dx, dy, dz
        w[_OMEGA + j], w[_OMEGA + B + j], w[_OMEGA + 2 * B + j] = wx, wy, wz
        cx = r00 * cb0 + r01 * cb1 + r02 * cb2
        cy = r10 * cb0 + r11 * cb1 + r12 * cb2
        cz = r20 * cb0 + r21 * cb1 + r22 * cb2
        t0, t1, t2 = wy * cz - wz * cy, wz * cx - wx * cz, wx * cy - wy * cx
        # Ḣ = R I Rᵀ ω̇ + ω × R I Rᵀ ω = R (I ω̇' + ω' × I ω') with ω' = Rᵀ ω, ω̇' = Rᵀ ω̇
        # in the link's principal axes (one product with R fewer)
        b0 = r00 * wx + r10 * wy + r20 * wz
        b1 = r01 * wx + r11 * wy + r21 * wz
        b2 = r02 * wx + r12 * wy + r22 * wz
        k0, k1, k2 = i0 * b0, i1 * b1, i2 * b2
        h0 = i0 * (r00 * dx + r10 * dy + r20 * dz) + (b1 * k2 - b2 * k1)
        h1 = i1 * (r01 * dx + r11 * dy + r21 * dz) + (b2 * k0 - b0 * k2)
        h2 = i2 * (r02 * dx + r12 * dy + r22 * dz) + (b0 * k1 - b1 * k0)
        w[lk + _C + j], w[lk + _C + B + j], w[lk + _C + 2 * B + j] = cx, cy, cz
        w[lk + _A + j] = ax + dy * cz - dz * cy + wy * t2 - wz * t1
        w[lk + _A + B + j] = ay + dz * cx - dx * cz + wz * t0 - wx * t2
        w[lk + _A + 2 * B + j] = az + dx * cy - dy * cx + wx * t1 - wy * t0
        w[lk + _H + j] = r00 * h0 + r01 * h1 + r02 * h2
        w[lk + _H + B + j] = r10 * h0 + r11 * h1 + r12 * h2
        w[lk + _H + 2 * B + j] = r20 * h0 + r21 * h1 + r22 * h2


@njit(**_KW)
def _outward(com, inertia, gravity, n, w):
    """Outward recursion: ω, ω̇ and a − g from joint to joint, each link's terms (``_link``)."""
    n = min(n, B)  # a bound on the trip count (module doc)
    for j in range(n):
        w[_OMEGA + j] = w[_OMEGA + B + j] = w[_OMEGA + 2 * B + j] = 0.0
        w[_DOMEGA + j] = w[_DOMEGA + B + j] = w[_DOMEGA + 2 * B + j] = 0.0
        w[_ACC + j], w[_ACC + B + j], w[_ACC + 2 * B + j] = -gravity[0], -gravity[1], -gravity[2]
    # A loop over links 1..8, i a run-time value: this loop vectorises so (20 ns per
    # sample, as with one inlined call per link, its index a literal), and two copies of
    # ``_link`` compile in 1.9 s instead of 7 s for the 17 copies of the per-link calls
    # (``_link`` and a separate advance). Not so from link 0 (140 ns: the rows of
    # link i − 1 are then at offsets that may be negative, and a possibly negative index
    # is wrapped, which stops vectorising), nor for ``_frame`` and ``_backward`` (FK 32
    # vs 8 ns per sample, ``_inward`` 46 vs 13, for reasons not found): they keep one
    # inlined call per row or link, each index a literal.
    # Link 0 (the stance foot) does not move: its CoM offset is that of frame 0, its
    # acceleration − g is −g and its Ḣ zero (``_link`` with ω = ω̇ = 0, without the
    # products of zeros).
    l0, l1, l2 = com[0, 0, 0], com[0, 0, 1], com[0, 0, 2]
    r0, r1, r2 = com[1, 0, 0], com[1, 0, 1], com[1, 0, 2]
    for j in range(n):
        right = w[_SIDE + j] > 0.5
        cb0, cb1, cb2 = (r0, r1, r2) if right else (l0, l1, l2)
        w[_LK + _C + j] = w[_FR + j] * cb0 + w[_FR + B + j] * cb1 + w[_FR + 2 * B + j] * cb2
        w[_LK + _C + B + j] = (
            w[_FR + 3 * B + j] * cb0 + w[_FR + 4 * B + j] * cb1 + w[_FR + 5 * B + j] * cb2
        )
        w[_LK + _C + 2 * B + j] = (
            w[_FR + 6 * B + j] * cb0 + w[_FR + 7 * B + j] * cb1 + w[_FR + 8 * B + j] * cb2
        )
        w[_LK + _A + j], w[_LK + _A + B + j] = -gravity[0], -gravity[1]
        w[_LK + _A + 2 * B + j] = -gravity[2]
        w[_LK + _H + j] = w[_LK + _H + B + j] = w[_LK + _H + 2 * B + j] = 0.0
    _links(1, N_LINK, com, inertia, n, w)


@njit(**_KW)
def _links(first, stop, com, inertia, n, w):
    """Links first..stop − 1 of the outward recursion (``_link``), from the running ω, ω̇
    and a − g the block holds at joint origin first − 1; 1 ≤ first. One compiled copy of
    ``_link`` for ``_outward`` and for ``dynamics.linearised``'s partial passes (each
    inlined copy costs seconds of compiling)."""
    n = min(n, B)  # a bound on the trip count (module doc)
    for i in range(1, N_LINK):  # i from a literal 1 (``_outward``: it vectorises)
        if first <= i < stop:
            _link(i, com, inertia, n, w)


@njit(**_KW)
def _inward(mass, double, n, w):
    """Inward recursion, the DSP split of the ground wrench, torques, power, ZMP.

    In SSP (``double`` 0) the swing foot's share is zero and the torques are the
    recursion's (``_swing_split`` would subtract products of zeros).
    """
    n = min(n, B)  # a bound on the trip count (module doc)
    for j in range(n):
        w[_F + j] = w[_F + B + j] = w[_F + 2 * B + j] = 0.0
        w[_M + j] = w[_M + B + j] = w[_M + 2 * B + j] = 0.0
    # one call per link, its index a literal (see ``_outward``); the swing split
    # vectorises as a loop
    _backward(8, -1.0, mass, n, w)
    _backward(7, -1.0, mass, n, w)
    _backward(6, -1.0, mass, n, w)
    _backward(5, -1.0, mass, n, w)
    _backward(4, 1.0, mass, n, w)
    _backward(3, 1.0, mass, n, w)
    _backward(2, 1.0, mass, n, w)
    _backward(1, -1.0, mass, n, w)
    _backward(0, 1.0, mass, n, w)
    for j in range(n):
        fx, fy, fz = w[_F + j], w[_F + B + j], w[_F + 2 * B + j]
        # moment about the stance sole point (x0 points up, so the sole is o0 − Lan z_S)
        lan = w[_FR + 11 * B + j]
        sm0, sm1, sm2 = w[_M + j] - lan * fy, w[_M + B + j] + lan * fx, w[_M + 2 * B + j]
        w[_SM + j], w[_SM + B + j], w[_SM + 2 * B + j] = sm0, sm1, sm2
        # DSP split: the swing foot carries the share 1 − s of the total wrench
        other = 1.0 - w[_SHARE + j]
        xs, ys = w[_XS + j], w[_YS + j]
        w0, w1, w2 = w[_SW + j], w[_SW + B + j], w[_SW + 2 * B + j]
        e0 = (ys - w1) * fz + w2 * fy
        e1 = -w2 * fx - (xs - w0) * fz
        e2 = (xs - w0) * fy - (ys - w1) * fx
        w[_FS + j], w[_FS + B + j], w[_FS + 2 * B + j] = other * fx, other * fy, other * fz
        w[_MS + j] = other * (sm0 + e0)
        w[_MS + B + j] = other * (sm1 + e1)
        w[_MS + 2 * B + j] = other * (sm2 + e2)
        # ZMP: the moment about the origin of S is sm + (xs, ys, 0) × F (eq. (4), module doc)
        w[_ZX + j] = -(sm1 - xs * fz) / fz
        w[_ZY + j] = (sm0 + ys * fz) / fz
        w[_POWER + j] = 0.0
    if double:
        for i in range(1, N_LINK):
            _swing_split(i, n, w)
    else:
        for i in range(1, N_LINK):
            _unsplit(i, n, w)


@njit(inline="always", **_KW)
def _backward(i, sign, mass, n, w):
    """Link i of the inward recursion: force and moment at origin i, m · u_i.

    sign: ``_AXIS_SIGN[i]``, a literal at the call (``_frame``'s α)."""
    n = min(n, B)  # a bound on the trip count (module doc)
    m_i = mass[i]
    f, lk = _FR + i * FRAME, _LK + i * LINK
    # where the child's force acts: the next origin, or the swing sole for the last link
    nxt = _SW if i == N_LINK - 1 else _FR + (i + 1) * FRAME + 9 * B
    for j in range(n):
        fx, fy, fz = w[_F + j], w[_F + B + j], w[_F + 2 * B + j]
        ax, ay, az = w[lk + _A + j], w[lk + _A + B + j], w[lk + _A + 2 * B + j]
        cx, cy, cz = w[lk + _C + j], w[lk + _C + B + j], w[lk + _C + 2 * B + j]
        Fx, Fy, Fz = m_i * ax, m_i * ay, m_i * az
        ox, oy, oz = w[f + 9 * B + j], w[f + 10 * B + j], w[f + 11 * B + j]
        px, py, pz = w[nxt + j] - ox, w[nxt + B + j] - oy, w[nxt + 2 * B + j] - oz
        mx = w[lk + _H + j] + (cy * Fz - cz * Fy) + w[_M + j] + (py * fz - pz * fy)
        my = w[lk + _H + B + j] + (cz * Fx - cx * Fz) + w[_M + B + j] + (pz * fx - px * fz)
        mz = w[lk + _H + 2 * B + j] + (cx * Fy - cy * Fx) + w[_M + 2 * B + j] + (px * fy - py * fx)
        w[_M + j], w[_M + B + j], w[_M + 2 * B + j] = mx, my, mz
        w[_F + j], w[_F + B + j], w[_F + 2 * B + j] = Fx + fx, Fy + fy, Fz + fz
        w[_TAURAW + i * B + j] = sign * (
            mx * w[f + 2 * B + j] + my * w[f + 5 * B + j] + mz * w[f + 8 * B + j]
        )


@njit(inline="always", **_KW)
def _swing_split(i, n, w):
    """Torque of joint i (row i of Table I) less the swing foot's share of the wrench; power."""
    n = min(n, B)  # a bound on the trip count (module doc)
    f, sign = _FR + i * FRAME, _AXIS_SIGN[i]
    for j in range(n):
        fs0, fs1, fs2 = w[_FS + j], w[_FS + B + j], w[_FS + 2 * B + j]
        rx = w[_SW + j] - w[f + 9 * B + j]
        ry = w[_SW + B + j] - w[f + 10 * B + j]
        rz = w[_SW + 2 * B + j] - w[f + 11 * B + j]
        c0, c1, c2 = ry * fs2 - rz * fs1, rz * fs0 - rx * fs2, rx * fs1 - ry * fs0
        t_i = w[_TAURAW + i * B + j] - sign * (
            w[f + 2 * B + j] * (c0 + w[_MS + j])
            + w[f + 5 * B + j] * (c1 + w[_MS + B + j])
            + w[f + 8 * B + j] * (c2 + w[_MS + 2 * B + j])
        )
        w[_TAU + (i - 1) * B + j] = t_i
        w[_POWER + j] += abs(t_i * w[_QD + (i - 1) * B + j])


@njit(inline="always", **_KW)
def _unsplit(i, n, w):
    """Torque of joint i (row i of Table I) in SSP, where the swing foot carries nothing; power."""
    n = min(n, B)  # a bound on the trip count (module doc)
    for j in range(n):
        t_i = w[_TAURAW + i * B + j]
        w[_TAU + (i - 1) * B + j] = t_i
        w[_POWER + j] += abs(t_i * w[_QD + (i - 1) * B + j])


@njit(**_KW)
def _margin(geometry, double, n, w):
    """``zmp.support_polygon`` of the two soles and ``zmp.signed_margin`` of the ZMP.

    The sole is the outline of M vertices of ``tables.SOLE_XY`` (the spec's rectangle or
    its ``sole_polygon``); each vertex is written twice (incoming edge, outgoing edge),
    moved by the swing sole's offset in DSP where that edge faces it (the hull of both
    soles), as ``support_polygon`` writes them. In SSP on the rectangle the margin has a
    closed form; otherwise it is that of a 2M-vertex convex polygon. A sole of 4 vertices
    (the rectangle) runs loops of a literal trip count, so the compiler unrolls them and
    every row offset is a constant again (module doc: the inner loops vectorise); another
    M runs the same loops over a run-time count, slower.
    """
    n = min(n, B)  # a bound on the trip count (module doc)
    corners = int(geometry[tb.SOLE_COUNT])
    w[_COUNT] = 2.0 * corners
    if corners == 4:
        for v in range(8):
            _vertex(geometry, double, v, 4, n, w)
    else:
        for v in range(2 * corners):
            _vertex(geometry, double, v, corners, n, w)
    if not double and geometry[tb.SOLE_RECTANGLE] == 1.0:  # an axis-aligned rectangle
        heel, toe, half = geometry[tb.HEEL], geometry[tb.TOE], geometry[tb.HALF_WIDTH]
        offset = geometry[tb.SOLE_OFFSET]  # each sole's centre, outward of its sole point
        for j in range(n):
            px, py = w[_ZX + j], w[_ZY + j]
            xs, ys = w[_XS + j], w[_YS + j] + offset * (1.0 - 2.0 * w[_SIDE + j])
            rx0, rx1 = px - (xs - heel), (xs + toe) - px
            ry0, ry1 = py - (ys - half), (ys + half) - py
            inside = min(min(rx0, rx1), min(ry0, ry1))
            ox, oy = max(max(-rx0, -rx1), 0.0), max(max(-ry0, -ry1), 0.0)
            m = inside if inside >= 0 else -np.sqrt(ox * ox + oy * oy)
            w[_MARGIN + j] = m if (px == px and py == py) else np.nan
    elif corners == 4:
        _polygon_margin(8, n, w)
    else:
        _polygon_margin(2 * corners, n, w)


@njit(inline="always", **_KW)
def _vertex(geometry, double, v, corners, n, w):
    """Support polygon vertex v (of 2 ``corners``) at the block's samples (``_margin``)."""
    n = min(n, B)  # a bound on the trip count (module doc)
    offset = geometry[tb.SOLE_OFFSET]  # each sole's centre, outward of its sole point
    k = v // 2  # the corner, and the edge whose facing moves this copy of it
    edge = (k - 1 + corners) % corners if v % 2 == 0 else k
    cx, cy = geometry[tb.SOLE_XY + 2 * k], geometry[tb.SOLE_XY + 2 * k + 1]
    nx, ny = geometry[tb.SOLE_NORMAL + 2 * edge], geometry[tb.SOLE_NORMAL + 2 * edge + 1]
    for j in range(n):
        shift = offset * (1.0 - 2.0 * w[_SIDE + j])  # the stance sole's; the swing's: −
        xs, ys = w[_XS + j], w[_YS + j] + shift
        dx = (w[_SW + j] - xs) if double else 0.0
        dy = (w[_SW + B + j] - shift - ys) if double else 0.0
        facing = dx * nx + dy * ny > 0
        w[_VERT + 2 * v * B + j] = xs + cx + (dx if facing else 0.0)
        w[_VERT + (2 * v + 1) * B + j] = ys + cy + (dy if facing else 0.0)


@njit(inline="always", **_KW)
def _polygon_margin(count, n, w):
    """``zmp.signed_margin`` of the ZMP to the ``count``-vertex polygon in the _VERT rows."""
    for j in range(n):
        w[_MARGIN + j] = np.inf  # the smallest signed distance to an edge's line
        w[_SEG + j] = np.inf
    for v in range(count):
        a, b = _VERT + 2 * v * B, _VERT + 2 * ((v + 1) % count) * B
        for j in range(n):
            px, py = w[_ZX + j], w[_ZY + j]
            vx, vy = w[a + j], w[a + B + j]
            ex, ey = w[b + j] - vx, w[b + B + j] - vy
            rx, ry = px - vx, py - vy
            length2 = ex * ex + ey * ey
            length = np.sqrt(length2)
            line = (ex * ry - ey * rx) / length if length > 1e-12 else np.inf
            w[_MARGIN + j] = min(w[_MARGIN + j], line)
            u = (rx * ex + ry * ey) / length2 if length2 > 1e-24 else 0.0
            u = min(max(u, 0.0), 1.0)
            gx, gy = rx - u * ex, ry - u * ey
            w[_SEG + j] = min(w[_SEG + j], gx * gx + gy * gy)
    for j in range(n):
        px, py = w[_ZX + j], w[_ZY + j]
        line = w[_MARGIN + j]
        m = line if line >= 0 else -np.sqrt(w[_SEG + j])
        w[_MARGIN + j] = m if (px == px and py == py) else np.nan


@njit(inline="always", **_KW)
def evaluate_block(
    inputs, block, n, double, y, geometry, dh_a, d5, mass, com, inertia, gravity, x, w
):  # fmt: skip
    """The pipeline at the first n samples of block ``block`` of ``tables.Blocks``.

    Args:
        inputs: ``Blocks.inputs``; block: the block; n: its padded size (≤ ``BLOCK``).
        double: The block's samples are in double support.
        Others: see ``evaluate_loaded``.
    """
    size = tb.INPUTS * B
    rows = inputs[block * size : (block + 1) * size]  # (a run-time offset from 0 would
    for k in range(size):  # be taken for a possibly negative index: no vectorising)
        w[_IN + k] = rows[k]
    evaluate_loaded(n, double, y, geometry, dh_a, d5, mass, com, inertia, gravity, x, w)


@njit(inline="always", **_KW)  # no library of its own (``kernel`` doc)
def evaluate_loaded(n, double, y, geometry, dh_a, d5, mass, com, inertia, gravity, x, w):
    """The pipeline at the n ≤ ``BLOCK`` samples whose inputs the scratch holds.

    The inputs (``tables.Blocks``, ``load_sample``) give each sample's time and piece;
    all samples are of one support kind (``double``: DSP). Afterwards the scratch holds
    what a score reads (``margin``, ``power``, ``half_angle``), and ``write_rows``
    writes a plan's rows from it.

    Args:
        y: y of each step's stance sole for this individual [m], (N,).
        geometry, dh_a, d5, mass, com, inertia: ``ChainTable`` fields.
        gravity: Gravity in S [m/s²], (3,).
        x: The individual (``tables.COLUMNS``), (6,).
        w: Scratch (``scratch``).
    """
    _gait_ik(x, y, geometry, n, w)
    _kinematics(geometry, dh_a, d5, n, w)
    _outward(com, inertia, gravity, n, w)
    _inward(mass, double, n, w)
    _margin(geometry, double, n, w)


@njit(**_KW)
def write_rows(mass, gravity, n, w, out, index):
    """A plan's rows (module layout) of the block's first n samples into out[index[j]]."""
    joint_angles(w, n, out, index, Q)
    for j in range(n):
        row = out[index[j]]
        xs, ys = w[_XS + j], w[_YS + j]
        for i in range(8):
            row[QD + i], row[QDD + i] = w[_QD + i * B + j], w[_QDD + i * B + j]
            row[TAU + i] = w[_TAU + i * B + j]
            row[POWER_JOINTS + i] = abs(w[_TAU + i * B + j] * w[_QD + i * B + j])
        row[ZMP], row[ZMP + 1] = w[_ZX + j], w[_ZY + j]
        row[STANCE_SOLE], row[STANCE_SOLE + 1], row[STANCE_SOLE + 2] = xs, ys, 0.0
        for k in range(3):
            row[SWING_SOLE + k] = w[_SW + k * B + j]
        floats = 2 * int(w[_COUNT])  # the sole's 4M; NaN past them
        for k in range(POLYGON_FLOATS):
            row[POLYGON + k] = w[_VERT + k * B + j] if k < floats else np.nan
        row[MARGIN] = w[_MARGIN + j]
        row[POWER] = w[_POWER + j]
        row[LEG_DISTANCE], row[LEG_DISTANCE + 1] = w[_DIST + j], w[_DIST + B + j]
        fx, fy, fz = w[_F + j], w[_F + B + j], w[_F + 2 * B + j]
        fs0, fs1, fs2 = w[_FS + j], w[_FS + B + j], w[_FS + 2 * B + j]
        row[GROUND], row[GROUND + 1], row[GROUND + 2] = fx, fy, fz
        row[SWING_FORCE], row[SWING_FORCE + 1], row[SWING_FORCE + 2] = fs0, fs1, fs2
        row[STANCE_FORCE], row[STANCE_FORCE + 1] = fx - fs0, fy - fs1
        row[STANCE_FORCE + 2] = fz - fs2
        row[FRICTION] = np.hypot(fx, fy) / fz if fz > 0 else np.inf
        mt = cmx = cmy = cmz = amx = amy = amz = 0.0
        for i in range(N_LINK):
            f, lk = _FR + i * FRAME, _LK + i * LINK
            m_i = mass[i]
            mt += m_i
            cmx += m_i * (w[f + 9 * B + j] + w[lk + _C + j])
            cmy += m_i * (w[f + 10 * B + j] + w[lk + _C + B + j])
            cmz += m_i * (w[f + 11 * B + j] + w[lk + _C + 2 * B + j])
            amx += m_i * w[lk + _A + j]
            amy += m_i * w[lk + _A + B + j]
            amz += m_i * w[lk + _A + 2 * B + j]
        cmx, cmy, cmz = cmx / mt, cmy / mt, cmz / mt
        amx, amy, amz = amx / mt + gravity[0], amy / mt + gravity[1], amz / mt + gravity[2]
        row[COM], row[COM + 1], row[COM + 2] = cmx, cmy, cmz
        row[COM_ACC], row[COM_ACC + 1], row[COM_ACC + 2] = amx, amy, amz
        row[ZMP_LIPM] = cmx - cmz * (amx - gravity[0]) / (-gravity[2])
        row[ZMP_LIPM + 1] = cmy - cmz * (amy - gravity[1]) / (-gravity[2])
        # CoP of the Newton-Euler wrench: moment about the stance sole moved to the origin
        sm0, sm1 = w[_SM + j], w[_SM + B + j]
        fzc = fz if fz > 0 else np.nan
        row[COP], row[COP + 1] = -(sm1 - xs * fz) / fzc, (sm0 + ys * fz) / fzc


@njit(**_KW)
def margin(w, j):
    """Signed ZMP margin [m] of sample j of the block just evaluated."""
    return w[_MARGIN + j]


@njit(**_KW)
def power(w, j):
    """Σ |τ θ̇| [W] of sample j of the block just evaluated."""
    return w[_POWER + j]


@njit(**_KW)
def half_angle(w, k, j):
    """tan(q/2) of pitch joint q_{k+2} (k = 0..5) at sample j of the block just evaluated."""
    return w[_HALF + k * B + j]


@njit(**_KW)
def start_extremes(w):
    """Reset the running extremes of tan(q/2) (``keep_extremes``) to (−inf, inf)."""
    for j in range(6 * B):
        w[_EXT + j] = -np.inf
        w[_EXT + 6 * B + j] = np.inf


@njit(**_KW)
def keep_extremes(w, n):
    """Fold the first n samples' tan(q/2) of q2..q7 into the running extremes, per lane.

    Lane by lane (a vector loop; the reduction over lanes is ``extremes``, once per
    individual): a reduction into one maximum per joint after every block ran scalar,
    12 ns per sample.
    """
    n = min(n, B)  # a bound on the trip count (module doc)
    for k in range(6):
        for j in range(n):
            h = w[_HALF + k * B + j]
            high, low = w[_EXT + k * B + j], w[_EXT + (6 + k) * B + j]
            w[_EXT + k * B + j] = h if h > high else high
            w[_EXT + (6 + k) * B + j] = h if h < low else low


@njit(**_KW)
def extremes(w, k):
    """(largest, smallest) tan(q/2) of pitch joint q_{k+2} (k = 0..5) kept so far."""
    high, low = -np.inf, np.inf
    for j in range(B):
        high = max(high, w[_EXT + k * B + j])
        low = min(low, w[_EXT + (6 + k) * B + j])
    return high, low


@njit(**_KW)
def keep_contact(w, n, out):
    """Contact numbers of the first n samples of the block just evaluated, rows of out (4, ≥ n):
    the friction ratio |F_t| / F_n of the total ground force (inf where F_n ≤ 0), the second
    (swing) foot's sole x and y in S [m] and the normal force on it [N]."""
    n = min(n, B)  # a bound on the trip count (module doc)
    for j in range(n):
        fx, fy, fz = w[_F + j], w[_F + B + j], w[_F + 2 * B + j]
        out[0, j] = np.hypot(fx, fy) / fz if fz > 0 else np.inf
        out[1, j], out[2, j] = w[_SW + j], w[_SW + B + j]
        out[3, j] = w[_FS + 2 * B + j]


@njit(**_KW)
def keep_block(w, n, margins, powers):
    """Margins [m] and Σ|τθ̇| [W] of the first n samples into margins, powers ((≥ n,) each).

    Returns how many of them are NaN (out of reach).
    """
    n = min(n, B)  # a bound on the trip count (module doc)
    nans = 0
    for j in range(n):
        m, p = w[_MARGIN + j], w[_POWER + j]
        margins[j], powers[j] = m, p
        nans += (m != m) + (p != p)
    return nans
