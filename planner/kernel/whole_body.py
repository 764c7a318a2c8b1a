"""The whole-body walk's model and time loop, compiled.

``mass_and_stiffness`` is ``whole_body._mass_and_stiffness`` per sample (M = Σ m Jvᵀ Jv +
Jωᵀ I Jω, the base's turning stiffness, its coupling to the joints and the joints'
Hessian; numpy's batched products over the samples move ~10 MB temporaries and took ~50 ms
of a 4.4 s walk's ~80 ms). Where the twin sums each link's Jacobians, this sums the links
past each joint once (mass, first and second moments, inertia; the pull of gravity and
the d'Alembert forces) and reads every entry from those sums: 12.1 -> 8.3 ms for the 4.4 s
walk, ~4 ms of it allocating and writing the two 4.3 MB results.
``integrate`` is ``whole_body._integrate`` (its readable numpy twin, held equal by
tests/planner/test_whole_body.py): backward Euler on the plan's time base of the linear
system x = (z, roll, pitch of the stance sole; the 8 joints' q − q_ref), the servo's
output clipped at ±τ_max, the 8 sole corners unilateral springs and dampers made implicit
where they push at the step's end, the second sole held along the plane while it carries
load, and the state re-expressed about the new stance sole at each change of stance. Its
11 × 11 systems are solved by ``servo._solve`` (LU with partial pivoting, written out):
where they are regular that is numpy's ``solve``; where one is singular ``integrate``
says so and the caller runs the numpy twin. Per sample the arrays are indexed first
(contiguous rows). Units as the twin's: m, rad, N, N m, s.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from slopewalk.planner.kernel import servo

_KW = {"cache": True, "error_model": "numpy", "nogil": True}
BASE = 3  # z, roll, pitch of the stance sole (``whole_body.BASE``)


@njit(**_KW)
def _pushes(corner, height, nominal, k_c, c_c, position, rate, out):
    """Each corner's spring and damper push for ``position`` moving at ``rate`` [N], (8,):
    f_nom − k_c (height + z) − c_c ż where the spring is pressed, else the spring's own
    f_nom − k_c (height + z) ≤ 0 (``whole_body._pushes``)."""
    dof = position.shape[0]
    for c in range(8):
        z = 0.0
        zd = 0.0
        for j in range(dof):
            z += corner[c, j] * position[j]
            zd += corner[c, j] * rate[j]
        spring = nominal[c] - k_c * (height[c] + z)
        out[c] = spring - c_c * zd if spring > 0 else spring
    return out


@njit(**_KW)
def _swapped(point, turn, y):
    """``whole_body._swapped``: ``y`` about the second sole, which becomes the stance one."""
    dof = y.shape[0]
    out = np.empty(dof)
    z = roll = pitch = 0.0
    for j in range(dof):
        z += point[2, j] * y[j]
        roll += turn[0, j] * y[j]
        pitch += turn[1, j] * y[j]
    out[0], out[1], out[2] = z, roll, pitch
    for i in range(dof - BASE):
        out[BASE + i] = y[dof - 1 - i]
    return out


@njit(**_KW)
def _add_outer(matrix, row, scale):
    """matrix += scale · row rowᵀ, skipping the row's zeros (a stance corner moves with the
    base's 3 coordinates only: 9 of its 121 products are not zero)."""
    for i in range(row.shape[0]):
        if row[i] == 0.0:
            continue
        for j in range(row.shape[0]):
            if row[j] != 0.0:
                matrix[i, j] += scale * row[i] * row[j]


@njit(**_KW)
def _joint_rows(k, x, v, mass, stiffness, loop, gains, work):
    """The step's M, C, K and force without the ground (``whole_body._step``'s first half),
    into ``work``'s m, c, stiff and force."""
    need, gravity_k, velocity_c, ff, qd, single = loop
    kp, kv, damping, armature, limit = gains
    m, c, stiff, force = work[0], work[1], work[2], work[3]
    m[:, :] = mass[k]
    c[:, :] = 0.0
    stiff[:, :] = stiffness[k]
    force[:] = 0.0
    for i in range(x.shape[0] - BASE):
        r = BASE + i
        m[r, r] += armature
        for j in range(x.shape[0] - BASE):
            c[r, BASE + j] = velocity_c[k, i, j]
            if single[k]:  # the loop's exact linearisation
                stiff[r, BASE + j] = gravity_k[k, i, j]
        raw = -kp * x[r] - kv * (qd[k, i] + v[r]) + ff[k, i]
        free = abs(raw) <= limit
        c[r, r] += damping + (kv if free else 0.0)
        stiff[r, r] += kp if free else 0.0
        held = 0.0 if free else min(max(raw, -limit), limit)
        force[r] = held + ((ff[k, i] - kv * qd[k, i]) if free else 0.0) - need[k, i]


@njit(**_KW)
def _step(k, h, x, v, anchor, model, loop, gains, floor, forces, work):
    """One backward-Euler step at sample k (``whole_body._step``): x and v advanced in place;
    returns the second sole's anchor along the plane (nan: not held) and whether the system
    was regular; the corners' loads into ``forces[k]``. ``work``: the step's arrays, made
    once per walk (a step's own ~25 small arrays took half its time)."""
    mass, stiffness, corner, height, nominal, ideal, point, held = model
    k_c, c_c, tangent = floor
    dof = x.shape[0]
    _joint_rows(k, x, v, mass, stiffness, loop, gains, work)
    m, c, stiff, force = work[0], work[1], work[2], work[3]
    lhs, ahead, after = work[4], work[5], work[6]
    moved, rhs, cv, kx = work[7], work[8], work[9], work[10]
    for j in range(dof):
        for cr in range(8):
            force[j] -= corner[k, cr, j] * ideal[k, cr]
    for j in range(dof):
        moved[j] = x[j] + h * v[j]
    _pushes(corner[k], height[k], nominal[k], k_c, c_c, moved, v, ahead)
    second = False
    for cr in range(8):
        if ahead[cr] > 0:
            row = corner[k, cr]
            _add_outer(stiff, row, k_c)
            _add_outer(c, row, c_c)
            for j in range(dof):
                force[j] += row[j] * (nominal[k, cr] - k_c * height[k, cr])
            second |= cr >= 4
    if second and held[k]:  # loaded, where held (``whole_body.Model.held``): along x
        along = point[k, 0]
        if np.isnan(anchor):
            anchor = 0.0
            for j in range(dof):
                anchor += along[j] * x[j]
        _add_outer(stiff, along, tangent * k_c)
        _add_outer(c, along, tangent * c_c)
        for j in range(dof):
            force[j] += along[j] * tangent * k_c * anchor
    else:
        anchor = np.nan
    for i in range(dof):
        for j in range(dof):
            lhs[i, j] = m[i, j] + h * c[i, j] + h * h * stiff[i, j]
    servo._mv(c, v, cv)
    servo._mv(stiff, moved, kx)
    for j in range(dof):
        rhs[j] = force[j] - cv[j] - kx[j]
    a, regular = servo._solve(lhs, rhs)
    for j in range(dof):
        v[j] = v[j] + h * a[j]
    for j in range(dof):
        x[j] = x[j] + h * v[j]
    _pushes(corner[k], height[k], nominal[k], k_c, c_c, x, v, after)
    for cr in range(8):
        forces[k, cr] = max(after[cr], 0.0) if ahead[cr] > 0 else 0.0
    return anchor, regular


@njit(**_KW)
def integrate(
    mass, stiffness, corner, height, nominal, ideal, second_point, second_turn,
    need, gravity_k, velocity_c, ff, qd, dt, stance, double_support, held,
    gains, floor, fallen, start,
):  # fmt: skip
    """``whole_body._integrate`` (module doc): the states (n, DOF), the corners' loads [N]
    (n, 8) and whether every system was regular (else the results are unfinished).

    Per sample k: mass, stiffness (n, DOF, DOF); corner (n, 8, DOF); height, nominal, ideal
    (n, 8); second_point, second_turn (n, 3, DOF); need, ff, qd (n, 8); gravity_k,
    velocity_c (n, 8, 8); dt, stance, double_support, held (n,). gains: kp, kv, damping,
    armature, τ_max; floor: k_c, c_c (and the tangential hold's factor, see the caller);
    fallen: the base turn [rad] past which the walk is held; start: x at rest (DOF,).
    """
    n, dof = dt.shape[0], start.shape[0]
    states, forces = np.zeros((n, dof)), np.zeros((n, 8))
    x, v, anchor = start.copy(), np.zeros(dof), np.nan
    model = (mass, stiffness, corner, height, nominal, ideal, second_point, held)
    loop = (need, gravity_k, velocity_c, ff, qd, ~double_support)
    square, row, corners = np.zeros((4, dof, dof)), np.zeros((5, dof)), np.zeros((2, 8))
    # m, c, K, force, lhs, the corners' pushes ahead and after, x + h v, rhs, C v, K (x + h v)
    work = (
        square[0], square[1], square[2], row[0], square[3], corners[0], corners[1],
        row[1], row[2], row[3], row[4],
    )  # fmt: skip
    for k in range(n):
        if k > 0 and stance[k] != stance[k - 1]:
            x = _swapped(second_point[k - 1], second_turn[k - 1], x)
            v = _swapped(second_point[k - 1], second_turn[k - 1], v)
            anchor = np.nan
        if dt[k] > 0:
            anchor, regular = _step(k, dt[k], x, v, anchor, model, loop, gains, floor, forces, work)
            if not regular:
                return states, forces, False
        states[k] = x
        finite = np.isfinite(x).all()
        if not (finite and max(abs(x[1]), abs(x[2])) < fallen):
            for j in range(k + 1, n):
                states[j] = x
                forces[j] = forces[k]
            break
    return states, forces, True


@njit(**_KW)
def _pull_sums(m, com, felt, out):
    """Sums over the links from each one to the last of what gravity and the d'Alembert
    forces pull with (g, each link's ``felt``): ``out[L]`` = Σ_{L' ≥ L} of m c gᵀ (9, row
    major), m g (3) and m g·c (1); ``out[links]`` zero. The stiffness reads them."""
    links = com.shape[0]
    out[links, :] = 0.0
    for link in range(links - 1, -1, -1):
        c, g, w = com[link], felt[link], m[link]
        for a in range(3):
            for b in range(3):
                out[link, 3 * a + b] = out[link + 1, 3 * a + b] + w * c[a] * g[b]
            out[link, 9 + a] = out[link + 1, 9 + a] + w * g[a]
        out[link, 12] = out[link + 1, 12] + w * (c[0] * g[0] + c[1] * g[1] + c[2] * g[2])


@njit(**_KW)
def _body_sums(m, com, rotation, local_inertia, pivot, half, out):
    """Sums over the links from each one to the last of what moves with a turn: ``out[L]``
    = Σ_{L' ≥ L} of m (1), m r (3), m r rᵀ (9, row major) and R I Rᵀ (9), r = c − pivot,
    I a link's inertia about its CoM in its frame, R its frame; ``out[links]`` zero.
    ``half``: (3, 3) scratch, R I."""
    links = com.shape[0]
    out[links, :] = 0.0
    for link in range(links - 1, -1, -1):
        w, rot, own = m[link], rotation[link], local_inertia[link]
        r0, r1, r2 = com[link, 0] - pivot[0], com[link, 1] - pivot[1], com[link, 2] - pivot[2]
        out[link, 0] = out[link + 1, 0] + w
        out[link, 1] = out[link + 1, 1] + w * r0
        out[link, 2] = out[link + 1, 2] + w * r1
        out[link, 3] = out[link + 1, 3] + w * r2
        for a in range(3):
            ra = r0 if a == 0 else (r1 if a == 1 else r2)
            out[link, 4 + 3 * a] = out[link + 1, 4 + 3 * a] + w * ra * r0
            out[link, 5 + 3 * a] = out[link + 1, 5 + 3 * a] + w * ra * r1
            out[link, 6 + 3 * a] = out[link + 1, 6 + 3 * a] + w * ra * r2
        for a in range(3):  # R I, then its product with Rᵀ: R I Rᵀ
            for d in range(3):
                half[a, d] = rot[a, 0] * own[0, d] + rot[a, 1] * own[1, d] + rot[a, 2] * own[2, d]
        for a in range(3):
            for b in range(3):
                turned = half[a, 0] * rot[b, 0] + half[a, 1] * rot[b, 1] + half[a, 2] * rot[b, 2]
                out[link, 13 + 3 * a + b] = out[link + 1, 13 + 3 * a + b] + turned


@njit(**_KW)
def _mass(body, turn, shift, start, out):
    """M (DOF, DOF) at one sample from the links' sums (``_body_sums``).

    Column k of the Jacobians moves the links from ``start[k]`` on, each as a twist:
    angular velocity ``turn[k]`` and, at a point r from the pivot, linear velocity
    turn[k] × r + shift[k] (the base's z: 0 and e_z; its roll and pitch: e_x, e_y and 0;
    joint i: a_i and −a_i × (o_i − pivot)). So, summed over the links both columns move
    (from start[l] on, k ≤ l), M_kl = Σ m (w_k × r + b_k)·(w_l × r + b_l) + w_kᵀ I w_l
    = w_k·(J w_l + h × b_l) + b_k·(w_l × h + m b_l), with m, h = Σ m r, J = tr(S) 1 − S +
    Σ R I Rᵀ and S = Σ m r rᵀ over those links: six products a pair, where the links'
    Jacobians (the numpy twin's form) cost a sum over the links for each."""
    dof = turn.shape[0]
    for col in range(dof):
        sums = body[start[col]]
        mass, h0, h1, h2 = sums[0], sums[1], sums[2], sums[3]
        trace = sums[4] + sums[8] + sums[12]
        w, b = turn[col], shift[col]
        # u = J w + h × b, v = w × h + m b
        u0 = (trace - sums[4] + sums[13]) * w[0] + (sums[14] - sums[5]) * w[1]
        u0 += (sums[15] - sums[6]) * w[2] + h1 * b[2] - h2 * b[1]
        u1 = (sums[16] - sums[7]) * w[0] + (trace - sums[8] + sums[17]) * w[1]
        u1 += (sums[18] - sums[9]) * w[2] + h2 * b[0] - h0 * b[2]
        u2 = (sums[19] - sums[10]) * w[0] + (sums[20] - sums[11]) * w[1]
        u2 += (trace - sums[12] + sums[21]) * w[2] + h0 * b[1] - h1 * b[0]
        v0 = w[1] * h2 - w[2] * h1 + mass * b[0]
        v1 = w[2] * h0 - w[0] * h2 + mass * b[1]
        v2 = w[0] * h1 - w[1] * h0 + mass * b[2]
        for k in range(col + 1):
            wk, bk = turn[k], shift[k]
            value = wk[0] * u0 + wk[1] * u1 + wk[2] * u2 + bk[0] * v0 + bk[1] * v1 + bk[2] * v2
            out[k, col] = out[col, k] = value


@njit(**_KW)
def _stiffness(pull, axes, origins, pivot, out):
    """The stiffness (DOF, DOF) at one sample from the links' pulls (``_pull_sums``): the
    base's turn, Σ m ((g·r) 1 − sym(g rᵀ)) over its roll and pitch, r = c − pivot; its
    coupling to joint j, −Σ_{L>j} m (∂c/∂q_j × g) = −(P_j − a_j Q_j); and the potential's
    Hessian over the joints, H_ij = −Σ_{L>j} m g·(a_i × (a_j × (c − o_j))) = −(a_i·P_j −
    (a_i·a_j) Q_j) for i ≤ j (link L moves with the joints before it), both by
    (a × r) × g = r (a·g) − a (r·g), with P_j = Σ m (g·a_j)(c − o_j) and Q_j = Σ m g·(c − o_j)
    over the links past joint j: O(joints · links) a sample, not the O(joints² · links) of
    each pair's crosses (the numpy twin's form)."""
    joints = axes.shape[0]
    top = pull[0]
    along = top[12] - (pivot[0] * top[9] + pivot[1] * top[10] + pivot[2] * top[11])  # Σ m g·r
    xx = top[0] - pivot[0] * top[9]  # Σ m r_x g_x
    yy = top[4] - pivot[1] * top[10]  # Σ m r_y g_y
    xy = top[1] - pivot[0] * top[10]  # Σ m r_x g_y
    yx = top[3] - pivot[1] * top[9]  # Σ m r_y g_x
    out[1, 1] = along - xx
    out[2, 2] = along - yy
    out[1, 2] = out[2, 1] = -0.5 * (xy + yx)
    for j in range(joints):
        rows, aj, oj = pull[j + 1], axes[j], origins[j]  # the links past joint j
        weight = rows[9] * aj[0] + rows[10] * aj[1] + rows[11] * aj[2]  # Σ m g·a_j
        p0 = rows[0] * aj[0] + rows[1] * aj[1] + rows[2] * aj[2] - oj[0] * weight
        p1 = rows[3] * aj[0] + rows[4] * aj[1] + rows[5] * aj[2] - oj[1] * weight
        p2 = rows[6] * aj[0] + rows[7] * aj[1] + rows[8] * aj[2] - oj[2] * weight
        q = rows[12] - (oj[0] * rows[9] + oj[1] * rows[10] + oj[2] * rows[11])
        out[1, BASE + j] = out[BASE + j, 1] = -(p0 - aj[0] * q)
        out[2, BASE + j] = out[BASE + j, 2] = -(p1 - aj[1] * q)
        for i in range(j + 1):
            ai = axes[i]
            cosine = ai[0] * aj[0] + ai[1] * aj[1] + ai[2] * aj[2]
            value = cosine * q - (ai[0] * p0 + ai[1] * p1 + ai[2] * p2)
            out[BASE + i, BASE + j] = out[BASE + j, BASE + i] = value


@njit(**_KW)
def mass_and_stiffness(m, com, rotation, local_inertia, side, axes, origins, pivot, felt):
    """``whole_body._mass_and_stiffness`` (its numpy twin) per sample: M and the base-turn
    and joint-Hessian stiffness, (n, DOF, DOF) each, from sums over the links past each
    joint (``_mass``, ``_stiffness``), not the links' Jacobians one by one.

    m: the links' masses [kg] (9,); per sample s: com, each link's CoM [m] (n, 9, 3);
    rotation, its frame's axes in the plane's frame (n, 9, 3, 3); local_inertia, each
    link's inertia about its CoM in its frame [kg m²], chain side first (2, 9, 3, 3), and
    side, the side at each sample (n,) (turned into the plane's frame here, R I Rᵀ,
    ``whole_body._links``); axes, origins: joint i's
    axis and a point on it (n, 8, 3); pivot, the stance sole point [m] (n, 3); felt, the
    acceleration each link feels, g − a [m/s²] (n, 9, 3). Link L moves with the base and
    the joints before it.
    """
    n, links, joints = com.shape[0], com.shape[1], axes.shape[1]
    dof = BASE + joints
    mass = np.zeros((n, dof, dof))
    stiffness = np.zeros((n, dof, dof))
    body = np.zeros((links + 1, 22))
    pull = np.zeros((links + 1, 13))
    turn = np.zeros((dof, 3))  # each column's twist: its turn and its shift at the pivot
    shift = np.zeros((dof, 3))
    start = np.zeros(dof, dtype=np.int64)  # the first link it moves
    half = np.zeros((3, 3))
    shift[0, 2] = 1.0  # z
    turn[1, 0] = turn[2, 1] = 1.0  # roll, pitch about the pivot
    for i in range(joints):
        start[BASE + i] = i + 1
    for s in range(n):
        p = pivot[s]
        for i in range(joints):
            a, o = axes[s, i], origins[s, i]
            turn[BASE + i] = a
            d0, d1, d2 = o[0] - p[0], o[1] - p[1], o[2] - p[2]  # −a × (o − pivot)
            shift[BASE + i, 0] = -(a[1] * d2 - a[2] * d1)
            shift[BASE + i, 1] = -(a[2] * d0 - a[0] * d2)
            shift[BASE + i, 2] = -(a[0] * d1 - a[1] * d0)
        _body_sums(m, com[s], rotation[s], local_inertia[side[s]], p, half, body)
        _mass(body, turn, shift, start, mass[s])
        _pull_sums(m, com[s], felt[s], pull)
        _stiffness(pull, axes[s], origins[s], p, stiffness[s])
    return mass, stiffness
