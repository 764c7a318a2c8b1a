"""The whole-body walk's model and time loop, compiled.

``mass_and_stiffness`` is ``whole_body._mass_and_stiffness`` per sample (the links'
Jacobians, M = Σ m Jvᵀ Jv + Jωᵀ I Jω, the base's turning stiffness, its coupling to the
joints and the joints' Hessian; numpy's batched products over the samples move ~10 MB
temporaries and took ~50 ms of a 4.4 s walk's ~80 ms).
``integrate`` is ``whole_body._integrate`` (its readable numpy twin, held equal by
tests/planner/test_whole_body.py): backward Euler on the plan's time base of the linear
system x = (z, roll, pitch of the stance sole; the 8 joints' q_ref − q), the servo's
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
    f_nom − k_c (height + z) − c_c ż (``whole_body._pushes``)."""
    dof = position.shape[0]
    for c in range(8):
        z = 0.0
        zd = 0.0
        for j in range(dof):
            z += corner[c, j] * position[j]
            zd += corner[c, j] * rate[j]
        out[c] = nominal[c] - k_c * (height[c] + z) - c_c * zd
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
    mass, stiffness, corner, height, nominal, ideal, point = model
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
    if second:  # the second sole carries load: held along x
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
    need, gravity_k, velocity_c, ff, qd, dt, stance, double_support,
    gains, floor, fallen, start,
):  # fmt: skip
    """``whole_body._integrate`` (module doc): the states (n, DOF), the corners' loads [N]
    (n, 8) and whether every system was regular (else the results are unfinished).

    Per sample k: mass, stiffness (n, DOF, DOF); corner (n, 8, DOF); height, nominal, ideal
    (n, 8); second_point, second_turn (n, 3, DOF); need, ff, qd (n, 8); gravity_k,
    velocity_c (n, 8, 8); dt, stance, double_support (n,). gains: kp, kv, damping,
    armature, τ_max; floor: k_c, c_c (and the tangential hold's factor, see the caller);
    fallen: the base turn [rad] past which the walk is held; start: x at rest (DOF,).
    """
    n, dof = dt.shape[0], start.shape[0]
    states, forces = np.zeros((n, dof)), np.zeros((n, 8))
    x, v, anchor = start.copy(), np.zeros(dof), np.nan
    model = (mass, stiffness, corner, height, nominal, ideal, second_point)
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
def _cross_into(a, b0, b1, b2, out, col):
    """out[:, col] = a × (b0, b1, b2), written out (no array made: numba allocates each)."""
    out[0, col] = a[1] * b2 - a[2] * b1
    out[1, col] = a[2] * b0 - a[0] * b2
    out[2, col] = a[0] * b1 - a[1] * b0


@njit(**_KW)
def _jacobians(c, pivot, axes, origins, link, jv, jw):
    """Link ``link``'s CoM ``c`` [m]: its linear and angular Jacobians into ``jv``, ``jw``
    (3, DOF), their first BASE + link columns (the rest stay zero); returns r = c − pivot."""
    used = BASE + link
    r0, r1, r2 = c[0] - pivot[0], c[1] - pivot[1], c[2] - pivot[2]
    jv[:, :used] = 0.0
    jw[:, :used] = 0.0
    jv[2, 0] = 1.0
    jv[1, 1], jv[2, 1] = -r2, r1  # e_x × r
    jv[0, 2], jv[2, 2] = r2, -r0  # e_y × r
    jw[0, 1] = jw[1, 2] = 1.0
    for i in range(link):
        o = origins[i]
        _cross_into(axes[i], c[0] - o[0], c[1] - o[1], c[2] - o[2], jv, BASE + i)
        jw[0, BASE + i] = axes[i, 0]
        jw[1, BASE + i] = axes[i, 1]
        jw[2, BASE + i] = axes[i, 2]
    return r0, r1, r2


@njit(**_KW)
def mass_and_stiffness(m, com, rotation, local_inertia, side, axes, origins, pivot, felt):
    """``whole_body._mass_and_stiffness`` (its numpy twin) per sample: M and the base-turn
    and joint-Hessian stiffness, (n, DOF, DOF) each.

    m: the links' masses [kg] (9,); per sample s: com, each link's CoM [m] (n, 9, 3);
    rotation, its frame's axes in the plane's frame (n, 9, 3, 3); local_inertia, each
    link's inertia about its CoM in its frame [kg m²], chain side first (2, 9, 3, 3), and
    side, the side at each sample (n,) (turned into the plane's frame here, R I Rᵀ,
    ``whole_body._links``); axes, origins: joint i's
    axis and a point on it (n, 8, 3); pivot, the stance sole point [m] (n, 3); felt, the
    acceleration each link feels, g − a [m/s²] (n, 9, 3). Link L moves with the base and
    the joints before it: its Jacobians' columns past BASE + L are zero, and skipped.
    """
    n, links, joints = com.shape[0], com.shape[1], axes.shape[1]
    dof = BASE + joints
    mass = np.zeros((n, dof, dof))
    stiffness = np.zeros((n, dof, dof))
    jv = np.zeros((3, dof))
    jw = np.zeros((3, dof))
    spun = np.zeros((3, dof))
    turned = np.zeros((3, 3))  # the link's inertia in the plane's frame
    inner = np.zeros((3, 1))
    outer = np.zeros((3, 1))
    for s in range(n):
        for link in range(links):
            used = BASE + link  # the columns that move it
            r0, r1, r2 = _jacobians(com[s, link], pivot[s], axes[s], origins[s], link, jv, jw)
            rot, own = rotation[s, link], local_inertia[side[s], link]
            for a in range(3):  # R I Rᵀ
                for b in range(3):
                    total = 0.0
                    for c_ in range(3):
                        for d in range(3):
                            total += rot[a, c_] * own[c_, d] * rot[b, d]
                    turned[a, b] = total
            for a in range(3):
                for b in range(used):
                    spun[a, b] = (
                        turned[a, 0] * jw[0, b] + turned[a, 1] * jw[1, b] + turned[a, 2] * jw[2, b]
                    )
            for a in range(used):
                for b in range(a, used):
                    lin = jv[0, a] * jv[0, b] + jv[1, a] * jv[1, b] + jv[2, a] * jv[2, b]
                    ang = jw[0, a] * spun[0, b] + jw[1, a] * spun[1, b] + jw[2, a] * spun[2, b]
                    mass[s, a, b] += m[link] * lin + ang
            g = felt[s, link]
            along = g[0] * r0 + g[1] * r1 + g[2] * r2
            # the base's turn: Σ m ((g'·r) I − sym(g' rᵀ)), its roll and pitch rows
            stiffness[s, 1, 1] += m[link] * (along - g[0] * r0)
            stiffness[s, 2, 2] += m[link] * (along - g[1] * r1)
            stiffness[s, 1, 2] -= m[link] * 0.5 * (g[0] * r1 + r0 * g[1])
            for j in range(link):  # its coupling to the joints: −Σ m (∂c/∂q_j × g'), x and y
                col = BASE + j
                stiffness[s, 1, col] -= m[link] * (jv[1, col] * g[2] - jv[2, col] * g[1])
                stiffness[s, 2, col] -= m[link] * (jv[2, col] * g[0] - jv[0, col] * g[2])
        for i in range(joints):  # the potential's Hessian
            for j in range(i, joints):
                twice = 0.0
                for link in range(j + 1, links):
                    c, o = com[s, link], origins[s, j]
                    _cross_into(axes[s, j], c[0] - o[0], c[1] - o[1], c[2] - o[2], inner, 0)
                    _cross_into(axes[s, i], inner[0, 0], inner[1, 0], inner[2, 0], outer, 0)
                    g = felt[s, link]
                    twice += m[link] * (
                        g[0] * outer[0, 0] + g[1] * outer[1, 0] + g[2] * outer[2, 0]
                    )
                stiffness[s, BASE + i, BASE + j] = -twice
        for a in range(dof):  # both triangles
            for b in range(a + 1, dof):
                mass[s, b, a] = mass[s, a, b]
                stiffness[s, b, a] = stiffness[s, a, b]
    return mass, stiffness
