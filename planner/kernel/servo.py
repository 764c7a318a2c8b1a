"""The servo loop through time and the servo's static fixed point, compiled.

``integrate`` is the time loop of ``servo_loop.servo_walk`` (``servo_loop._integrate``,
its readable numpy twin, held equal by tests/planner/test_kernel_servo.py): backward
Euler on the plan's time base, the output clipped at ±τ_max, the legs' roles swapped
at each change of stance, and in double support the second sole held (a plastic
impact stops it, then J v = 0), and after lift-off kept where it is while the plane
pushes it (``_trailing``). Its linear systems (8 × 8, the 12 × 12 KKT system of
the held sole, the 4 × 4 impact) are solved by LU with partial pivoting, written
out (``_solve``): where they are regular, as on every walk measured (the held rows'
smallest singular value ≥ 0.1 on the default walks), that is the one solution
numpy's ``solve``, ``lstsq`` and ``pinv`` find; where one is singular ``integrate``
says so and the caller runs the numpy twin (its minimum-norm solutions). LAPACK
through numba cost a minute of compiling and 24 µs per step; this, ~1 µs. ``fixed_point`` is the
iteration of ``compliance.compliant_walk`` on the compiled torques
(``dynamics.torques``). Units as the numpy twins: rad, rad/s, N m, s.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from slopewalk.planner.kernel import dynamics as dy

_KW = {"cache": True, "error_model": "numpy", "nogil": True}
_EPS = 2.220446049250313e-16  # float64 machine epsilon (numpy's lstsq cut-off: eps · max(M, N))


@njit(**_KW)
def _lu(a):
    """LU with partial pivoting of a (LAPACK's ``getrf``, unblocked): the factors in one
    matrix (L's multipliers below the diagonal), the row swapped into each column, and
    whether a is regular: False where a pivot is below 1e-13 of a's largest entry (the
    factors are then unfinished)."""
    n = a.shape[0]
    a = a.copy()
    pivot = np.empty(n, dtype=np.int64)
    scale = 0.0
    for r in range(n):
        for c in range(n):
            scale = max(scale, abs(a[r, c]))
    for c in range(n):
        p = c
        for r in range(c + 1, n):
            if abs(a[r, c]) > abs(a[p, c]):
                p = r
        pivot[c] = p
        if not abs(a[p, c]) > 1e-13 * scale:
            return a, pivot, False
        if p != c:
            for k in range(n):
                a[c, k], a[p, k] = a[p, k], a[c, k]
        for r in range(c + 1, n):
            f = a[r, c] / a[c, c]
            a[r, c] = f
            for k in range(c + 1, n):
                a[r, k] -= f * a[c, k]
    return a, pivot, True


@njit(**_KW)
def _lu_solve(lu, pivot, b):
    """x of a x = b from ``_lu``'s factors (``getrs``): the row swaps, then L's
    elimination column by column, then back substitution; each entry of b meets the same
    operations in the same order as in an elimination made beside the factorisation."""
    n = lu.shape[0]
    x = b.copy()
    for c in range(n):
        p = pivot[c]
        if p != c:
            x[c], x[p] = x[p], x[c]
    for c in range(n):
        for r in range(c + 1, n):
            x[r] -= lu[r, c] * x[c]
    for c in range(n - 1, -1, -1):
        s = x[c]
        for k in range(c + 1, n):
            s -= lu[c, k] * x[k]
        x[c] = s / lu[c, c]
    return x


@njit(**_KW)
def _solve(a, b):
    """x of a x = b by LU with partial pivoting (LAPACK's ``gesv``, unblocked: ``_lu``,
    ``_lu_solve``), and whether a is regular (``_lu``)."""
    lu, pivot, ok = _lu(a)
    if not ok:
        return b.copy(), False
    return _lu_solve(lu, pivot, b), True


@njit(**_KW)
def _mv(a, x, out):
    """out = a x (plain loops: numba's ``@`` compiles BLAS bindings, seconds)."""
    for i in range(a.shape[0]):
        s = 0.0
        for k in range(a.shape[1]):
            s += a[i, k] * x[k]
        out[i] = s
    return out


@njit(**_KW)
def _constrained(matrix, rhs, jac, target):
    """``servo_loop._constrained``: matrix x − jacᵀ λ = rhs, jac x = target: x, λ, and
    whether the system is regular (then its one solution is numpy's minimum-norm one)."""
    dof, rows = matrix.shape[0], jac.shape[0]
    kkt = np.zeros((dof + rows, dof + rows))
    b = np.empty(dof + rows)
    for i in range(dof):
        b[i] = rhs[i]
        for k in range(dof):
            kkt[i, k] = matrix[i, k]
        for r in range(rows):
            kkt[i, dof + r] = -jac[r, i]
            kkt[dof + r, i] = jac[r, i]
    for r in range(rows):
        b[dof + r] = target[r]
    x, ok = _solve(kkt, b)
    out, wrench = np.empty(dof), np.empty(rows)
    for i in range(dof):
        out[i] = x[i]
    for r in range(rows):
        wrench[r] = x[dof + r]
    return out, wrench, ok


@njit(**_KW)
def _landed(mass, jac, rate):
    """``servo_loop._landed``: joint rates after the plastic impact that stops the sole
    (J M⁻¹ Jᵀ p = J q̇, q̇⁺ = q̇ − M⁻¹ Jᵀ p), and whether J M⁻¹ Jᵀ is regular (then its
    pseudo-inverse is its inverse)."""
    rows, dof = jac.shape
    speed = _mv(jac, rate, np.empty(rows))
    moving = False
    for r in range(rows):
        moving = moving or abs(speed[r]) > 0
    if not moving:
        return rate, True
    mj = np.empty((dof, rows))
    lu, pivot, ok = _lu(mass)  # one factorisation for the rows' solves
    if not ok:
        return rate, False
    row = np.empty(dof)
    for r in range(rows):
        for k in range(dof):
            row[k] = jac[r, k]
        col = _lu_solve(lu, pivot, row)
        for k in range(dof):
            mj[k, r] = col[k]
    jmj = np.zeros((rows, rows))
    for r in range(rows):
        for s in range(rows):
            for k in range(dof):
                jmj[r, s] += jac[r, k] * mj[k, s]
    p, good = _solve(jmj, speed)
    out = _mv(mj, p, np.empty(dof))
    for k in range(dof):
        out[k] = rate[k] - out[k]
    return out, ok and good


@njit(**_KW)
def _system(m, c, kk, force, d, v, h):
    """The backward-Euler step's system (m + h c + h² kk) a = force − c v − kk (δ + h v)
    (``servo_loop._system``): (matrix, rhs)."""
    dof = d.shape[0]
    ahead = np.empty(dof)
    for i in range(dof):
        ahead[i] = d[i] + h * v[i]
    cv, kd = _mv(c, v, np.empty(dof)), _mv(kk, ahead, np.empty(dof))
    matrix, rhs = np.empty((dof, dof)), np.empty(dof)
    for i in range(dof):
        rhs[i] = force[i] - cv[i] - kd[i]
        for k in range(dof):
            matrix[i, k] = m[i, k] + h * c[i, k] + h * h * kk[i, k]
    return matrix, rhs


@njit(inline="always", **_KW)  # no library of its own (``kernel`` doc)
def _step(m, c, kk, force, d, v, h, jac, held):
    """``servo_loop._backward_euler``: (v', δ', a) of one step, and whether every system
    solved was regular; ``held``: the sole held."""
    dof = d.shape[0]
    ok = True
    if held:
        v, ok = _landed(m, jac, v)
    matrix, rhs = _system(m, c, kk, force, d, v, h)
    if held:
        target = _mv(jac, v, np.empty(jac.shape[0]))
        for r in range(jac.shape[0]):
            target[r] = -target[r] / h
        a, _, good = _constrained(matrix, rhs, jac, target)
    else:
        a, good = _solve(matrix, rhs)
    vn, dn = np.empty(dof), np.empty(dof)
    for i in range(dof):
        vn[i] = v[i] + h * a[i]
        dn[i] = d[i] + h * vn[i]
    return vn, dn, a, ok and good


_NORMAL = 1  # servo_loop.NORMAL: the normal force's row in λ (HELD = x, z, roll, pitch)
_TANGENT = 0  # servo_loop.TANGENT: the force along the plane


@njit(inline="always", **_KW)  # no library of its own (``kernel`` doc)
def _trailing(m, c, kk, force, d, v, h, jac, qd_ref, friction):
    """``servo_loop._trailing``: the step with the lifting sole kept on the plane,
    J (q̇_ref + v') = 0, or the free step where the plane would pull (λ_z ≤ 0) or hold it
    past the friction cone (|λ_x| > μ λ_z); (v', δ', a, whether every system was regular,
    whether the plane still holds it, and the plane's normal force and |force along it| [N]
    that decided it: ``servo_loop.friction_decides``'s record)."""
    dof = d.shape[0]
    lifted = np.empty(dof)
    for i in range(dof):
        lifted[i] = qd_ref[i] + v[i]
    matrix, rhs = _system(m, c, kk, force, d, v, h)
    target = _mv(jac, lifted, np.empty(jac.shape[0]))
    for r in range(jac.shape[0]):
        target[r] = -target[r] / h
    a, wrench, good = _constrained(matrix, rhs, jac, target)
    if not good:
        return v, d, a, False, False, np.nan, np.nan
    normal, along = wrench[_NORMAL], abs(wrench[_TANGENT])
    held = normal > 0.0 and along <= friction * normal
    if not held:
        # held, False here: the bool variable, as at ``integrate``'s call of ``_step``
        vn, dn, a, ok = _step(m, c, kk, force, d, v, h, jac, held)
        return vn, dn, a, ok, False, normal, along
    vn, dn = np.empty(dof), np.empty(dof)
    for i in range(dof):
        vn[i] = v[i] + h * a[i]
        dn[i] = d[i] + h * vn[i]
    return vn, dn, a, True, True, normal, along


@njit(**_KW)
def _terms(k, mass, gravity_k, velocity_c, need, qd_ref, tau_ff, gains, d, v, m, c, kk, force, raw):
    """The step's matrices m, c, kk and force of ``servo_loop._integrate``, the request raw."""
    kp, kv, damping, armature, limit = gains[0], gains[1], gains[2], gains[3], gains[4]
    dof = d.shape[0]
    for i in range(dof):
        raw[i] = -kp * d[i] - kv * (qd_ref[k, i] + v[i]) + tau_ff[k, i]
        free = abs(raw[i]) <= limit
        held = 0.0 if free else min(max(raw[i], -limit), limit)
        for j in range(dof):
            m[i, j], c[i, j], kk[i, j] = mass[k, i, j], velocity_c[k, i, j], gravity_k[k, i, j]
        m[i, i] += armature
        c[i, i] += damping + (kv if free else 0.0)
        kk[i, i] += kp if free else 0.0
        force[i] = held + (tau_ff[k, i] - kv * qd_ref[k, i] if free else 0.0) - need[k, i]


@njit(**_KW)
def _reversed(x):
    """x in reverse order (the legs swap roles: Table-I order reverses)."""
    n = x.shape[0]
    out = np.empty(n)
    for i in range(n):
        out[i] = x[n - 1 - i]
    return out


@njit(**_KW)
def _let_go(d):
    """Whether the loop has let go of the plan: δ not finite or |δ| ≥ π somewhere."""
    for x in d:
        if not abs(x) < np.pi:
            return True
    return False


@njit(**_KW)
def integrate(mass, gravity_k, velocity_c, need, qd_ref, tau_ff, dt, stance, both, jac, gains, d):
    """``servo_loop._integrate``: the servo loop's δ, δ̇, δ̈, request, where the second
    sole is held on the plane, the friction checks of the lifting sole ((n, 2): the
    plane's normal force and |force along it| [N] where the check was made, NaN
    elsewhere), whether it held,
    and whether every linear system on the way was regular (False: a step met a
    singular one, where numpy's minimum-norm solution is not LU's; the caller reruns
    the numpy twin).

    gains: (kp, kv, damping, armature, τ_max, μ); d: δ at the first sample (rest).
    """
    n, dof = need.shape
    delta, rate = np.zeros((n, dof)), np.zeros((n, dof))
    accel, loop = np.zeros((n, dof)), np.zeros((n, dof))
    held = np.zeros(n, dtype=np.bool_)
    checks = np.full((n, 2), np.nan)
    m, c, kk = np.empty((dof, dof)), np.empty((dof, dof)), np.empty((dof, dof))
    force, raw = np.empty(dof), np.empty(dof)
    v = np.zeros(dof)
    trailing = False  # the sole lifting off is still on the plane, loaded
    for k in range(n):
        h = dt[k]
        if k and stance[k] != stance[k - 1]:
            d, v = _reversed(d), _reversed(v)
        _terms(
            k, mass, gravity_k, velocity_c, need, qd_ref, tau_ff, gains, d, v, m, c, kk, force, raw
        )
        if trailing and not both[k] and h > 0:
            v, d, a, ok, trailing, normal, along = _trailing(
                m, c, kk, force, d, v, h, jac[k], qd_ref[k], gains[5]
            )
            checks[k, 0], checks[k, 1] = normal, along
        else:
            v, d, a, ok = _step(m, c, kk, force, d, v, h, jac[k], both[k] and h > 0)
            trailing = both[k]
        held[k] = trailing
        if not ok:
            return delta, rate, accel, loop, held, checks, True, False
        if _let_go(d):
            for r in range(k, n):
                for i in range(dof):
                    delta[r, i], rate[r, i] = delta[k - 1, i], 0.0
                    accel[r, i], loop[r, i] = 0.0, loop[k - 1, i]
            return delta, rate, accel, loop, held, checks, False, True
        for i in range(dof):
            delta[k, i], rate[k, i], accel[k, i], loop[k, i] = d[i], v[i], a[i], raw[i]
    return delta, rate, accel, loop, held, checks, True, True


@njit(**_KW)
def fixed_point(chain, gravity, q, qd, qdd, side, sole, share, rate_terms, kp, tol, most):
    """``compliance.compliant_walk``'s iteration: δ = −(τ(q + δ) + rate terms) / kp.

    Returns δ [rad] (n, 8), the iterations made and the last largest change [rad] (NaN
    once any change is, as numpy's max). Written in loops: numba's array expressions
    cost ~3 s of compiling here.
    """
    n, dof = q.shape
    delta, moved = np.zeros((n, dof)), np.empty((n, dof))
    change, iterations = np.inf, 0
    while iterations < most and not change < tol:
        for k in range(n):
            for i in range(dof):
                moved[k, i] = q[k, i] + delta[k, i]
        tau = dy.torques(chain, gravity, moved, qd, qdd, side, sole, share)
        change = 0.0
        for k in range(n):
            for i in range(dof):
                new = -(tau[k, i] + rate_terms[k, i]) / kp
                step = abs(new - delta[k, i])
                if change == change and not step <= change:
                    change = step  # NaN stays NaN
                delta[k, i] = new
        iterations += 1
        if not np.isfinite(change):
            break
    return delta, iterations, change
