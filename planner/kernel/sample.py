"""One sample of the analytic pipeline, compiled: gait → IK → FK → Newton-Euler → ZMP → margin.

``evaluate_sample`` computes, for one individual (``tables.COLUMNS``) at one time of
one gait piece (``tables.GaitTable``), every series of ``plan.Plan`` at that
instant and writes it into one row of ``ROW`` floats (layout below). The maths is
that of the readable modules, written per sample with scalars:

* gait: the piece's cubics and their derivatives (``tables``), the tilted-plane
  heights of ``ik.tilted_plane_height``;
* IK (``ik.two_link_ik``): sines and cosines of the leg angles come from the law of
  cosines and angle addition, no trigonometric call; the angles themselves (atan2)
  only for the joint vector q;
* FK (``kinematics.Chain.poses``): Table I's rows with their known twists (0, ∓π/2);
* Newton-Euler (``newton_euler.inverse_dynamics_poses``) with every vector in S,
  then the DSP split of the ground wrench (``newton_euler.swing_wrench_torques``);
* multibody ZMP of eq. (4) (``zmp.zmp_multibody``), the support polygon and its
  signed margin (``zmp.support_polygon``, ``zmp.signed_margin``), the friction
  ratio, the LIPM ZMP and the CoP of the Newton-Euler wrench.

All vectors are in the slope frame S [m, m/s, m/s², N, N m]; angles [rad].
"""

from __future__ import annotations

import numpy as np
from numba import njit

from planner.kernel import tables as tb

# Row layout: where each quantity sits in the row written by ``evaluate_sample``.
Q, QD, QDD, TAU = 0, 8, 16, 24  # (8,) each: Table-I order [rad, rad/s, rad/s², N m]
ZMP, ZMP_LIPM, COP = 32, 34, 36  # (2,) each [m]
COM, COM_ACC = 38, 41  # (3,) whole-body CoM [m] and its acceleration [m/s²]
STANCE_SOLE, SWING_SOLE = 44, 47  # (3,) [m]
POLYGON = 50  # (8, 2) support polygon vertices [m]
MARGIN = 66  # signed ZMP margin [m], positive inside
GROUND, STANCE_FORCE, SWING_FORCE = 67, 70, 73  # (3,) [N]
FRICTION = 76  # |F_t| / F_n of the total ground force
POWER = 77  # Σ |τ θ̇| [W]
POWER_JOINTS = 78  # (8,) |τ_i θ̇_i| [W]
LEG_DISTANCE = 86  # (2,) hip-ankle distance of the stance and swing legs [m]
ROW = 88
SCRATCH = 21  # rows of the scratch array ``evaluate_sample`` works in

_KW = {"cache": True, "error_model": "numpy", "nogil": True}


@njit(**_KW)
def _cubic(pf, piece, col, tau):
    """Value and first two τ-derivatives of c0 + c1 τ + c2 τ² + c3 τ³ (pf[piece, col:col+4])."""
    c0, c1, c2, c3 = pf[piece, col], pf[piece, col + 1], pf[piece, col + 2], pf[piece, col + 3]
    p = c0 + tau * (c1 + tau * (c2 + tau * c3))
    v = c1 + tau * (2.0 * c2 + 3.0 * tau * c3)
    a = 2.0 * c2 + 6.0 * tau * c3
    return p, v, a


@njit(**_KW)
def _tilted_height(hp, hv, ha, k, s, c, lv, la):
    """``ik.tilted_plane_height``: z' = (h − k sin λ) / cos λ with its two rates."""
    ap = hp - k * s
    av = hv - k * c * lv
    aa = ha - k * (c * la - s * lv * lv)
    sec = 1.0 / c
    bv = s * sec * sec * lv
    ba = s * sec * sec * la + (1.0 + s * s) * sec * sec * sec * lv * lv
    return ap * sec, av * sec + ap * bv, aa * sec + 2.0 * av * bv + ap * ba


@njit(**_KW)
def _two_link(up, uv, ua, wp, wv, wa, l1, l2):
    """``ik.two_link_ik`` for one sample: (cos, sin, rate, acc) of β_shank and β_thigh.

    Then the hip-ankle distance [m] and the two angles [rad]. NaNs where the target
    is out of reach.
    """
    d2 = up * up + wp * wp
    d = np.sqrt(d2)
    reach = (d < l1 + l2) and (d > abs(l1 - l2))
    if not reach:
        d = np.nan
    cpsi, spsi = wp / d, up / d
    cphi = (l1 * l1 + d * d - l2 * l2) / (2.0 * l1 * d)
    sphi = np.sqrt(1.0 - cphi * cphi)
    cs = cpsi * cphi - spsi * sphi  # β_shank = ψ + φ
    ss = spsi * cphi + cpsi * sphi
    eu, ew = up - l1 * ss, wp - l1 * cs
    n = np.sqrt(eu * eu + ew * ew)
    ct, st = ew / n, eu / n
    j11, j12, j21, j22 = l1 * cs, l2 * ct, -l1 * ss, -l2 * st
    det = j11 * j22 - j12 * j21
    vs = (j22 * uv - j12 * wv) / det
    vt = (-j21 * uv + j11 * wv) / det
    ru = ua + (l1 * ss * vs * vs + l2 * st * vt * vt)
    rw = wa + (l1 * cs * vs * vs + l2 * ct * vt * vt)
    as_ = (j22 * ru - j12 * rw) / det
    at = (-j21 * ru + j11 * rw) / det
    # the angles as ik.two_link_ik has them: β_shank = ψ + φ is not wrapped to (−π, π]
    bs = np.arctan2(up, wp) + np.arccos(cphi)
    bt = np.arctan2(eu, ew)
    return cs, ss, vs, as_, ct, st, vt, at, np.sqrt(d2), bs, bt


@njit(**_KW)
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@njit(**_KW)
def evaluate_sample(
    pf, pi, landing_y, geometry, dh_a, d5, mass, com, inertia, gravity, x, piece, t, row, work,
    full,
):  # fmt: skip
    """Write every series of ``plan.Plan`` at time ``t`` into ``row``.

    With ``full`` False only what the GA reads is written (q, τ, ZMP, margin, power
    and the leg distances); those values are the same either way.

    Args:
        pf, pi: Piece tables (``GaitTable.floats``, ``.ints``).
        landing_y: y of each step's stance sole for this individual [m], (N,).
        geometry, dh_a, d5, mass, com, inertia: ``ChainTable`` fields.
        gravity: Gravity in S [m/s²], (3,).
        x: The individual (``tables.COLUMNS``: Hz [m], Szmax [m], tilt [rad], pelvis
            offset [m], step length [m], sway share [-]), (6,).
        piece: Piece index; t: time [s] (in or at the ends of the piece).
        row: Output, (ROW,), layout in the module constants.
        work: Scratch, (SCRATCH, 16): rows 0-9 the frames (rotation row-major, then the
            origin), rows 10-18 the links, row 19 the torques, row 20 the polygon.
        full: Write every quantity (a plan) or only the GA's (a score).
    """
    tau = t - pf[piece, tb.T0]
    side = pi[piece, tb.SIDE]
    l1, l2 = geometry[tb.SHANK], geometry[tb.THIGH]
    lh, lan = geometry[tb.HIP_WIDTH], geometry[tb.ANKLE_HEIGHT]
    hz, lift, tilt = x[tb.HZ], x[tb.LIFT_X], x[tb.TILT_X]
    step, w = x[tb.STEP_LENGTH], x[tb.SWAY_SHARE]
    towards = pf[piece, tb.TOWARDS]

    # ---- gait at t (closed form)
    hxp, hxv, hxa = _cubic(pf, piece, tb.HIP_X, tau)
    hxp, hxv, hxa = step * hxp + x[tb.PELVIS], step * hxv, step * hxa
    sxp, sxv, sxa = _cubic(pf, piece, tb.SWING_X, tau)
    sxp, sxv, sxa = step * sxp, step * sxv, step * sxa
    lp, lv, la = _cubic(pf, piece, tb.LIFT, tau)
    mp, mv, ma = _cubic(pf, piece, tb.TILT, tau)
    wp, wv, wa = _cubic(pf, piece, tb.SWAY, tau)
    mp, mv, ma = mp + w * (wp - mp), mv + w * (wv - mv), ma + w * (wa - ma)
    share = _cubic(pf, piece, tb.SHARE, tau)[0]
    lam, lamv, lama = tilt * mp, tilt * mv, tilt * ma
    sl, cl = np.sin(lam), np.cos(lam)
    zp, zv, za = _tilted_height(lift * lp, lift * lv, lift * la, towards * lh, sl, cl, lamv, lama)
    hp, hv, ha = _tilted_height(hz - lan, 0.0, 0.0, 0.5 * towards * lh, sl, cl, lamv, lama)

    # ---- IK of both legs (stance: ankle → hip; swing: its ankle → hip)
    cs, ss, vs, as_, ct, st, vt, at, dst, bs, bt = _two_link(hxp, hxv, hxa, hp, hv, ha, l1, l2)
    cs2, ss2, vs2, as2, ct2, st2, vt2, at2, dsw, bs2, bt2 = _two_link(
        hxp - sxp, hxv - sxv, hxa - sxa, hp - zp, hv - zv, ha - za, l1, l2
    )
    q = (-lam, -bs, bs - bt, bt, bt2, bs2 - bt2, -bs2, -lam)
    qd = (-lamv, -vs, vs - vt, vt, vt2, vs2 - vt2, -vs2, -lamv)
    qdd = (-lama, -as_, as_ - at, at, at2, as2 - at2, -as2, -lama)
    for i in range(8):
        row[Q + i], row[QD + i], row[QDD + i] = q[i], qd[i], qdd[i]

    # ---- FK: cos/sin of θ_i = sign_i q_i + offset_i, by angle addition
    c3, s3 = cs * ct + ss * st, ss * ct - cs * st  # θ3 = β_s − β_t
    c6, s6 = ct2 * cs2 + st2 * ss2, st2 * cs2 - ct2 * ss2  # θ6 = β_t2 − β_s2
    cth = (cl, cs, c3, ct, -ct2, c6, cs2, cl)
    sth = (sl, -ss, s3, st, st2, s6, ss2, sl)
    # frame 0: columns x0 = z_S, y0 = −y_S, z0 = x_S; origin at the stance ankle
    ys = landing_y[pi[piece, tb.FOOT]]
    xs = step * pf[piece, tb.STANCE_X]
    x0, x1, x2 = 0.0, 0.0, 1.0
    y0, y1, y2 = 0.0, -1.0, 0.0
    z0, z1, z2 = 1.0, 0.0, 0.0
    o0, o1, o2 = xs, ys, lan
    _store(work, 0, x0, x1, x2, y0, y1, y2, z0, z1, z2, o0, o1, o2)
    for i in range(8):
        # RotX(α): α = −π/2 on row 2, +π/2 on row 8, else 0
        if i == 1:
            yt0, yt1, yt2, zt0, zt1, zt2 = -z0, -z1, -z2, y0, y1, y2
        elif i == 7:
            yt0, yt1, yt2, zt0, zt1, zt2 = z0, z1, z2, -y0, -y1, -y2
        else:
            yt0, yt1, yt2, zt0, zt1, zt2 = y0, y1, y2, z0, z1, z2
        d = d5[side] if i == 4 else 0.0
        a = dh_a[i]
        o0, o1, o2 = o0 + x0 * a + zt0 * d, o1 + x1 * a + zt1 * d, o2 + x2 * a + zt2 * d
        c, s = cth[i], sth[i]
        x0, x1, x2, y0, y1, y2 = (
            x0 * c + yt0 * s,
            x1 * c + yt1 * s,
            x2 * c + yt2 * s,
            yt0 * c - x0 * s,
            yt1 * c - x1 * s,
            yt2 * c - x2 * s,
        )
        z0, z1, z2 = zt0, zt1, zt2
        _store(work, i + 1, x0, x1, x2, y0, y1, y2, z0, z1, z2, o0, o1, o2)
    # swing sole: ankle_height along x8
    w0, w1, w2 = o0 + x0 * lan, o1 + x1 * lan, o2 + x2 * lan
    row[STANCE_SOLE], row[STANCE_SOLE + 1], row[STANCE_SOLE + 2] = xs, ys, 0.0
    row[SWING_SOLE], row[SWING_SOLE + 1], row[SWING_SOLE + 2] = w0, w1, w2

    _newton_euler(
        work, qd, qdd, side, mass, com, inertia, gravity, w0, w1, w2, xs, ys, share, row, full
    )
    _polygon_margin(geometry, xs, ys, w0, w1, w2, pi[piece, tb.SSP] == 0, row, work, full)
    row[LEG_DISTANCE], row[LEG_DISTANCE + 1] = dst, dsw


@njit(**_KW)
def _store(work, i, x0, x1, x2, y0, y1, y2, z0, z1, z2, o0, o1, o2):
    """Frame i's rotation (rows of R, i.e. R[r, :] = (x_r, y_r, z_r)) and origin into work[i]."""
    work[i, 0], work[i, 1], work[i, 2] = x0, y0, z0
    work[i, 3], work[i, 4], work[i, 5] = x1, y1, z1
    work[i, 6], work[i, 7], work[i, 8] = x2, y2, z2
    work[i, 9], work[i, 10], work[i, 11] = o0, o1, o2


@njit(**_KW)
def _newton_euler(
    work, qd, qdd, side, mass, com, inertia, gravity, w0, w1, w2, xs, ys, share, row, full
):
    """Newton-Euler recursion in S, DSP split, torques, ZMP, forces, power (module doc)."""
    n_link = 9
    # per link: c (3), com acc with the gravity trick (3), momentum rate (3), axis (3)
    wx = wy = wz = 0.0  # ω
    dx = dy = dz = 0.0  # ω̇
    ax, ay, az = -gravity[0], -gravity[1], -gravity[2]
    for i in range(n_link):
        ux, uy, uz = work[i, 2], work[i, 5], work[i, 8]  # z_i
        if i > 0:
            sign = -1.0 if (i == 1 or i >= 5) else 1.0
            ux, uy, uz = sign * ux, sign * uy, sign * uz
            rx, ry, rz = (
                work[i, 9] - work[i - 1, 9],
                work[i, 10] - work[i - 1, 10],
                work[i, 11] - work[i - 1, 11],
            )
            t0, t1, t2 = _cross(wx, wy, wz, rx, ry, rz)
            e0, e1, e2 = _cross(dx, dy, dz, rx, ry, rz)
            g0, g1, g2 = _cross(wx, wy, wz, t0, t1, t2)
            ax, ay, az = ax + e0 + g0, ay + e1 + g1, az + e2 + g2
            q1, q2 = qd[i - 1], qdd[i - 1]
            sx, sy, sz = q1 * ux, q1 * uy, q1 * uz
            h0, h1, h2 = _cross(wx, wy, wz, sx, sy, sz)
            dx, dy, dz = dx + h0 + q2 * ux, dy + h1 + q2 * uy, dz + h2 + q2 * uz
            wx, wy, wz = wx + sx, wy + sy, wz + sz
        cb0, cb1, cb2 = com[side, i, 0], com[side, i, 1], com[side, i, 2]
        cx = work[i, 0] * cb0 + work[i, 1] * cb1 + work[i, 2] * cb2
        cy = work[i, 3] * cb0 + work[i, 4] * cb1 + work[i, 5] * cb2
        cz = work[i, 6] * cb0 + work[i, 7] * cb1 + work[i, 8] * cb2
        t0, t1, t2 = _cross(wx, wy, wz, cx, cy, cz)
        e0, e1, e2 = _cross(dx, dy, dz, cx, cy, cz)
        g0, g1, g2 = _cross(wx, wy, wz, t0, t1, t2)
        # Ḣ = R I Rᵀ ω̇ + ω × R I Rᵀ ω
        i0, i1, i2 = inertia[i, 0], inertia[i, 1], inertia[i, 2]  # principal, DH axes
        lw0 = work[i, 0] * wx + work[i, 3] * wy + work[i, 6] * wz
        lw1 = work[i, 1] * wx + work[i, 4] * wy + work[i, 7] * wz
        lw2 = work[i, 2] * wx + work[i, 5] * wy + work[i, 8] * wz
        ld0 = work[i, 0] * dx + work[i, 3] * dy + work[i, 6] * dz
        ld1 = work[i, 1] * dx + work[i, 4] * dy + work[i, 7] * dz
        ld2 = work[i, 2] * dx + work[i, 5] * dy + work[i, 8] * dz
        iw0, iw1, iw2 = i0 * lw0, i1 * lw1, i2 * lw2
        id0, id1, id2 = i0 * ld0, i1 * ld1, i2 * ld2
        Iw0 = work[i, 0] * iw0 + work[i, 1] * iw1 + work[i, 2] * iw2
        Iw1 = work[i, 3] * iw0 + work[i, 4] * iw1 + work[i, 5] * iw2
        Iw2 = work[i, 6] * iw0 + work[i, 7] * iw1 + work[i, 8] * iw2
        Id0 = work[i, 0] * id0 + work[i, 1] * id1 + work[i, 2] * id2
        Id1 = work[i, 3] * id0 + work[i, 4] * id1 + work[i, 5] * id2
        Id2 = work[i, 6] * id0 + work[i, 7] * id1 + work[i, 8] * id2
        k0, k1, k2 = _cross(wx, wy, wz, Iw0, Iw1, Iw2)
        work[10 + i, 0], work[10 + i, 1], work[10 + i, 2] = cx, cy, cz
        work[10 + i, 3], work[10 + i, 4], work[10 + i, 5] = ax + e0 + g0, ay + e1 + g1, az + e2 + g2
        work[10 + i, 6], work[10 + i, 7], work[10 + i, 8] = Id0 + k0, Id1 + k1, Id2 + k2
        work[10 + i, 9], work[10 + i, 10], work[10 + i, 11] = ux, uy, uz

    # ---- inward: f, m about origin i; τ_i = m · u_i
    fx = fy = fz = 0.0
    mx = my = mz = 0.0
    for i in range(n_link - 1, -1, -1):
        m_i = mass[i]
        Fx, Fy, Fz = m_i * work[10 + i, 3], m_i * work[10 + i, 4], m_i * work[10 + i, 5]
        if i == n_link - 1:
            px, py, pz = w0 - work[i, 9], w1 - work[i, 10], w2 - work[i, 11]
        else:
            px, py, pz = (
                work[i + 1, 9] - work[i, 9],
                work[i + 1, 10] - work[i, 10],
                work[i + 1, 11] - work[i, 11],
            )
        c0, c1, c2 = _cross(work[10 + i, 0], work[10 + i, 1], work[10 + i, 2], Fx, Fy, Fz)
        r0, r1, r2 = _cross(px, py, pz, fx, fy, fz)
        mx, my, mz = (
            work[10 + i, 6] + c0 + mx + r0,
            work[10 + i, 7] + c1 + my + r1,
            work[10 + i, 8] + c2 + mz + r2,
        )
        fx, fy, fz = Fx + fx, Fy + fy, Fz + fz
        if i >= 1:
            work[19, i - 1] = mx * work[10 + i, 9] + my * work[10 + i, 10] + mz * work[10 + i, 11]
    # moment about the stance sole point (x0 points up, so the sole is o0 − Lan z_S)
    lan = work[0, 11]
    sm0, sm1, sm2 = _cross(0.0, 0.0, lan, fx, fy, fz)
    sm0, sm1, sm2 = mx + sm0, my + sm1, mz + sm2
    # DSP split: the swing foot carries the share 1 − s of the total wrench
    other = 1.0 - share
    Fs0, Fs1, Fs2 = other * fx, other * fy, other * fz
    e0, e1, e2 = _cross(xs - w0, ys - w1, -w2, fx, fy, fz)
    Ms0, Ms1, Ms2 = other * (sm0 + e0), other * (sm1 + e1), other * (sm2 + e2)
    power = 0.0
    for i in range(1, n_link):
        c0, c1, c2 = _cross(w0 - work[i, 9], w1 - work[i, 10], w2 - work[i, 11], Fs0, Fs1, Fs2)
        t_i = work[19, i - 1] - (
            work[10 + i, 9] * (c0 + Ms0)
            + work[10 + i, 10] * (c1 + Ms1)
            + work[10 + i, 11] * (c2 + Ms2)
        )
        row[TAU + i - 1] = t_i
        p_i = abs(t_i * qd[i - 1])
        row[POWER_JOINTS + i - 1] = p_i
        power += p_i
    row[POWER] = power

    # ---- eq. (4) from link motion
    num_x = num_y = den = 0.0
    hx = hy = 0.0
    for i in range(n_link):
        m_i = mass[i]
        px, py, pz = (
            work[i, 9] + work[10 + i, 0],
            work[i, 10] + work[10 + i, 1],
            work[i, 11] + work[10 + i, 2],
        )
        gx, gy, gz = work[10 + i, 3], work[10 + i, 4], work[10 + i, 5]  # a − g
        den += m_i * gz
        num_x += m_i * (px * gz - gx * pz)
        num_y += m_i * (py * gz - gy * pz)
        hx += work[10 + i, 6]
        hy += work[10 + i, 7]
    row[ZMP], row[ZMP + 1] = (num_x - hy) / den, (num_y + hx) / den
    if not full:
        return

    # ---- ground forces, friction, whole-body CoM, LIPM, CoP of the NE wrench
    for j in range(3):
        row[GROUND + j] = (fx, fy, fz)[j]
        row[SWING_FORCE + j] = (Fs0, Fs1, Fs2)[j]
        row[STANCE_FORCE + j] = (fx - Fs0, fy - Fs1, fz - Fs2)[j]
    row[FRICTION] = np.hypot(fx, fy) / fz if fz > 0 else np.inf

    mt = cmx = cmy = cmz = amx = amy = amz = 0.0
    for i in range(n_link):
        m_i = mass[i]
        px, py, pz = (
            work[i, 9] + work[10 + i, 0],
            work[i, 10] + work[10 + i, 1],
            work[i, 11] + work[10 + i, 2],
        )
        gx, gy, gz = work[10 + i, 3], work[10 + i, 4], work[10 + i, 5]  # a − g
        mt += m_i
        cmx, cmy, cmz = cmx + m_i * px, cmy + m_i * py, cmz + m_i * pz
        amx, amy, amz = amx + m_i * gx, amy + m_i * gy, amz + m_i * gz
    cmx, cmy, cmz = cmx / mt, cmy / mt, cmz / mt
    amx, amy, amz = amx / mt + gravity[0], amy / mt + gravity[1], amz / mt + gravity[2]
    row[COM], row[COM + 1], row[COM + 2] = cmx, cmy, cmz
    row[COM_ACC], row[COM_ACC + 1], row[COM_ACC + 2] = amx, amy, amz
    row[ZMP_LIPM] = cmx - cmz * (amx - gravity[0]) / (-gravity[2])
    row[ZMP_LIPM + 1] = cmy - cmz * (amy - gravity[1]) / (-gravity[2])
    o0, o1, o2 = _cross(xs, ys, 0.0, fx, fy, fz)
    fzc = fz if fz > 0 else np.nan
    row[COP], row[COP + 1] = -(sm1 + o1) / fzc, (sm0 + o0) / fzc


@njit(**_KW)
def _polygon_margin(geometry, xs, ys, w0, w1, w2, double, row, work, full):
    """``zmp.support_polygon`` of the two soles and ``zmp.signed_margin`` of the ZMP.

    In SSP the polygon is the stance sole's rectangle (its repeated vertices kept in
    the row, as ``support_polygon`` writes them) and the margin has a closed form.
    """
    heel, toe, half = geometry[tb.HEEL], geometry[tb.TOE], geometry[tb.HALF_WIDTH]
    px, py = row[ZMP], row[ZMP + 1]
    if not (double or full):
        row[MARGIN] = _rectangle_margin(px, py, xs, ys, heel, toe, half)
        return
    dx = (w0 - xs) if double else 0.0
    dy = (w1 - ys) if double else 0.0
    cx = (toe, toe, -heel, -heel)
    cy = (-half, half, half, -half)
    nx = (1.0, 0.0, -1.0, 0.0)  # outward normals of the edges i → i+1
    ny = (0.0, 1.0, 0.0, -1.0)
    for i in range(4):
        incoming = dx * nx[i - 1] + dy * ny[i - 1] > 0
        outgoing = dx * nx[i] + dy * ny[i] > 0
        vx, vy = xs + cx[i], ys + cy[i]
        work[20, 2 * (2 * i) + 0] = vx + dx if incoming else vx
        work[20, 2 * (2 * i) + 1] = vy + dy if incoming else vy
        work[20, 2 * (2 * i + 1) + 0] = vx + dx if outgoing else vx
        work[20, 2 * (2 * i + 1) + 1] = vy + dy if outgoing else vy
    for i in range(16):
        row[POLYGON + i] = work[20, i]
    if not double:  # the stance sole alone: an axis-aligned rectangle, in closed form
        row[MARGIN] = _rectangle_margin(px, py, xs, ys, heel, toe, half)
    else:
        row[MARGIN] = _convex_margin(work, px, py)
    if np.isnan(px) or np.isnan(py):
        row[MARGIN] = np.nan


@njit(**_KW)
def _rectangle_margin(px, py, xs, ys, heel, toe, half):
    """Signed distance [m] of (px, py) to the sole rectangle around (xs, ys), inside > 0."""
    rx0, rx1 = px - (xs - heel), (xs + toe) - px
    ry0, ry1 = py - (ys - half), (ys + half) - py
    inside = min(min(rx0, rx1), min(ry0, ry1))
    ox, oy = max(max(-rx0, -rx1), 0.0), max(max(-ry0, -ry1), 0.0)
    return inside if inside >= 0 else -np.sqrt(ox * ox + oy * oy)


@njit(**_KW)
def _convex_margin(work, px, py):
    """Signed distance [m] of (px, py) to the 8-vertex polygon in work[20] (repeats allowed)."""
    line_min = np.inf
    for i in range(8):
        j = (i + 1) % 8
        ex, ey = work[20, 2 * j] - work[20, 2 * i], work[20, 2 * j + 1] - work[20, 2 * i + 1]
        length = np.sqrt(ex * ex + ey * ey)
        if length > 1e-12:
            rx, ry = px - work[20, 2 * i], py - work[20, 2 * i + 1]
            line_min = min(line_min, (ex * ry - ey * rx) / length)
    if line_min >= 0:
        return line_min
    seg2 = np.inf
    for i in range(8):
        j = (i + 1) % 8
        ex, ey = work[20, 2 * j] - work[20, 2 * i], work[20, 2 * j + 1] - work[20, 2 * i + 1]
        rx, ry = px - work[20, 2 * i], py - work[20, 2 * i + 1]
        length2 = ex * ex + ey * ey
        s = min(max((rx * ex + ry * ey) / length2, 0.0), 1.0) if length2 > 1e-24 else 0.0
        gx, gy = rx - s * ex, ry - s * ey
        seg2 = min(seg2, gx * gx + gy * gy)
    return -np.sqrt(seg2)
