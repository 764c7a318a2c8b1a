"""The chain's dynamics at given joint motion, compiled: torques and their linearisation.

``compliance._Dynamics.torque`` and ``servo_loop.linearised`` / ``support_jacobian``
(the readable numpy twins, held equal by tests/planner/test_kernel_servo.py) run the
analytic pipeline on joint angles, rates and accelerations that are not a gait's:
the walk a servo reaches. Here the same maths runs on the plan kernel's per-block
stages (``sample._kinematics``, ``_outward``, ``_inward``: FK, the outward and the
inward Newton-Euler recursion with the double-support split), loaded with the given
q, q̇, q̈ instead of the gait's IK (``_load``): every sample's DH cos/sin of
θ_i = sign_i q_i + offset_i, its rates, its stance side and sole, and the swing
foot's share s of the ground wrench (the stance share 1 − s is what the block holds).

``linearised`` takes per block the base pass and the 40 passes of the finite
differences the numpy twin takes over whole arrays (q̈ + e_j; q ± STEP e_j;
q̇ ± STEP e_j), and the second sole's pose Jacobian from the q ± STEP e_j passes'
frames. A pass costs ~0.1 µs per sample against ~2 µs in numpy.

All vectors in the slope frame S [m, m/s, m/s², N, N m]; angles [rad].
"""

from __future__ import annotations

import numpy as np
from numba import njit

from slopewalk.planner.kernel import sample as sp

_KW = {"cache": True, "error_model": "numpy", "nogil": True}
B = sp.B
_SIGN = (-1.0, 1.0, 1.0, 1.0, -1.0, -1.0, -1.0, -1.0)  # θ_i = sign_i q_i + offset_i
_OFFSET = (0.0, 0.0, 0.0, 0.0, np.pi, 0.0, 0.0, 0.0)
_F8 = sp._FR + 8 * sp.FRAME  # frame 8 (the swing ankle): R[r, c] at 3 r + c, origin 9..11


@njit(**_KW)
def _angle(w, i, j, qi):
    """DH cos/sin of row i at sample j of the block from joint angle qi [rad]."""
    theta = _SIGN[i] * qi + _OFFSET[i]
    w[sp._CT + i * B + j] = np.cos(theta)
    w[sp._ST + i * B + j] = np.sin(theta)


@njit(**_KW)
def _load(q, qd, qdd, side, sole, share, start, n, w):
    """Samples start..start+n−1 into the block's input rows (module doc)."""
    for j in range(n):
        k = start + j
        w[sp._SIDE + j] = float(side[k])
        w[sp._XS + j], w[sp._YS + j] = sole[k, 0], sole[k, 1]
        w[sp._SHARE + j] = 1.0 - share[k]
        for i in range(8):
            w[sp._QD + i * B + j] = qd[k, i]
            w[sp._QDD + i * B + j] = qdd[k, i]
            _angle(w, i, j, q[k, i])


@njit(inline="always", **_KW)  # no library of its own (``kernel`` doc)
def _pass(chain, gravity, n, w):
    """FK and Newton-Euler of the loaded block; torques in the ``sample._TAU`` rows."""
    geometry, dh_a, d5, mass, com, inertia = chain
    sp._kinematics(geometry, dh_a, d5, n, w)
    sp._outward(com, inertia, gravity, n, w)
    # double support as the int a ``tables.Blocks`` holds (a literal True would compile a
    # second ``_inward``, seconds of compiling for the same code)
    sp._inward(mass, 1 + 0 * n, n, w)


@njit(inline="always", **_KW)  # no library of its own (``kernel`` doc)
def torques(chain, gravity, q, qd, qdd, side, sole, share):
    """Joint torques [N m], Table-I order, (n, 8): ``compliance._Dynamics.torque``.

    Args:
        chain: ``ChainTable`` fields (geometry, a, d5, mass, com, inertia) as a tuple.
        gravity: Gravity in S [m/s²], (3,).
        q, qd, qdd: Joint angles [rad], rates, accelerations, (n, 8).
        side: Stance side per sample, 0 left / 1 right, (n,).
        sole: Stance sole point in S [m], (n, 3) (on the plane).
        share: The swing foot's share of the ground wrench, (n,): 0 in single support.
    """
    n = q.shape[0]
    out = np.empty((n, 8))
    w = sp.scratch()
    for start in range(0, n, B):
        m = min(B, n - start)
        _load(q, qd, qdd, side, sole, share, start, m, w)
        _pass(chain, gravity, m, w)
        for j in range(m):
            for i in range(8):
                out[start + j, i] = w[sp._TAU + i * B + j]
    return out


@njit(**_KW)
def _tau(w, m, out):
    for i in range(8):
        for j in range(m):
            out[i, j] = w[sp._TAU + i * B + j]


@njit(**_KW)
def _sole_pose(w, m, origin, rotation):
    """The swing sole's origin (3, m) and rotation (3, 3, m), axes (−z8, −y8, −x8)."""
    for j in range(m):
        for r in range(3):
            origin[r, j] = w[sp._SW + r * B + j]
            for c in range(3):
                rotation[r, c, j] = -w[_F8 + (3 * r + 2 - c) * B + j]


@njit(**_KW)
def _jacobian_column(op, Rp, om, Rm, step, start, m, jj, jac):
    """Column jj of the second sole's pose Jacobian (``servo_loop.support_jacobian``).

    The rotation's part from the off-diagonal entries of W = R₊ R₋ᵀ, each summed from 0
    over its three products in order (as a 3 × 3 W of zeros added up, without allocating
    it per sample: the same numbers).
    """
    for j in range(m):
        for r in range(3):
            jac[start + j, r, jj] = (op[r, j] - om[r, j]) / (2 * step)
        w21 = w12 = w02 = w20 = w10 = w01 = 0.0
        for c in range(3):
            w21 += Rp[2, c, j] * Rm[1, c, j]
            w12 += Rp[1, c, j] * Rm[2, c, j]
            w02 += Rp[0, c, j] * Rm[2, c, j]
            w20 += Rp[2, c, j] * Rm[0, c, j]
            w10 += Rp[1, c, j] * Rm[0, c, j]
            w01 += Rp[0, c, j] * Rm[1, c, j]
        jac[start + j, 3, jj] = (w21 - w12) / (4 * step)
        jac[start + j, 4, jj] = (w02 - w20) / (4 * step)
        jac[start + j, 5, jj] = (w10 - w01) / (4 * step)


@njit(**_KW)
def _difference(plus, minus, step, start, m, jj, out):
    for i in range(8):
        for j in range(m):
            out[start + j, i, jj] = (plus[i, j] - minus[i, j]) / (2 * step)


@njit(**_KW)
def _links(first, stop, com, inertia, n, w, run):
    """Links first..stop − 1 of the outward recursion (``sample._link``), from the running
    ω, ω̇ and a − g at joint origin first − 1 in ``run`` (9 rows of B, ``sample._OMEGA``'s
    order); 1 ≤ first.

    A change of joint jj's q, q̇ or q̈ moves nothing before link jj + 1 (FK and the outward
    recursion run from the stance foot out), so its passes start there with the block's
    own running values: the same numbers as the whole recursion.
    """
    n = min(n, B)  # a bound on the trip count (``sample`` module doc)
    for r in range(9):
        for j in range(n):
            w[sp._OMEGA + r * B + j] = run[r, j]
    sp._links(first, stop, com, inertia, n, w)


@njit(**_KW)
def _dynamics(chain, gravity, first, n, w, run):
    """The outward recursion from link ``first`` (``_links``) and the inward one: ``_pass``
    on the frames already in the block."""
    geometry, dh_a, d5, mass, com, inertia = chain
    _links(first, sp.N_LINK, com, inertia, n, w, run)
    sp._inward(mass, 1 + 0 * n, n, w)  # an int, as in ``_pass``


# long: one block's base pass and its 40 finite-difference passes, timed as one
@njit(**_KW)
def linearised(chain, gravity, q, qd, qdd, side, sole, share, step):
    """τ (n, 8), M, K_g, C (n, 8, 8) and the second sole's pose Jacobian (n, 6, 8).

    ``servo_loop.linearised`` and ``servo_loop.support_jacobian`` (module doc); step:
    the central differences' step [rad, rad/s]. Arguments as ``torques``.

    Per joint the passes that change q̈ or q̇ alone reuse the block's frames (FK depends
    on q only), and the joint's cos/sin are put back as they were: 3 FK passes per
    joint instead of 5. Every pass of joint jj starts the outward recursion at link
    jj + 1 from the block's running values there (``_links``), which then advance by
    that one link before joint jj + 1: the same numbers (each pass's inputs are the
    same, in another order), ~1/3 less outward work.
    """
    n = q.shape[0]
    tau, mass = np.empty((n, 8)), np.empty((n, 8, 8))
    stiff, vel, jac = np.empty((n, 8, 8)), np.empty((n, 8, 8)), np.empty((n, 6, 8))
    w = sp.scratch()
    base, plus, minus = np.empty((8, B)), np.empty((8, B)), np.empty((8, B))
    op, om, Rp, Rm = np.empty((3, B)), np.empty((3, B)), np.empty((3, 3, B)), np.empty((3, 3, B))
    cos, sin = np.empty(B), np.empty(B)
    run = np.empty((9, B))  # ω, ω̇, a − g at joint origin jj (before link jj + 1)
    geometry, dh_a, d5, com, inertia = chain[0], chain[1], chain[2], chain[4], chain[5]
    for start in range(0, n, B):
        m = min(B, n - start)
        _load(q, qd, qdd, side, sole, share, start, m, w)
        _pass(chain, gravity, m, w)
        _tau(w, m, base)
        for i in range(8):
            for j in range(m):
                tau[start + j, i] = base[i, j]
        for j in range(m):  # at the stance foot: at rest, a − g = −g (``sample._outward``)
            for r in range(6):
                run[r, j] = 0.0
            for r in range(3):
                run[6 + r, j] = -gravity[r]
        for jj in range(8):
            first = jj + 1
            row_dd, row_d = sp._QDD + jj * B, sp._QD + jj * B
            for j in range(m):  # the frames are the block's: q̈ and q̇ passes first
                w[row_dd + j] = qdd[start + j, jj] + 1.0
            _dynamics(chain, gravity, first, m, w, run)
            _tau(w, m, plus)
            for i in range(8):
                for j in range(m):
                    mass[start + j, i, jj] = plus[i, j] - base[i, j]
            for j in range(m):
                w[row_dd + j] = qdd[start + j, jj]
            for sign in (1.0, -1.0):
                for j in range(m):
                    w[row_d + j] = qd[start + j, jj] + sign * step
                _dynamics(chain, gravity, first, m, w, run)
                _tau(w, m, plus if sign > 0 else minus)
            _difference(plus, minus, step, start, m, jj, vel)
            for j in range(m):
                w[row_d + j] = qd[start + j, jj]
            ct, st = sp._CT + jj * B, sp._ST + jj * B
            for j in range(m):
                cos[j], sin[j] = w[ct + j], w[st + j]
            for sign in (1.0, -1.0):
                for j in range(m):
                    _angle(w, jj, j, q[start + j, jj] + sign * step)
                sp._kinematics(geometry, dh_a, d5, m, w)
                _dynamics(chain, gravity, first, m, w, run)
                _tau(w, m, plus if sign > 0 else minus)
                if sign > 0:
                    _sole_pose(w, m, op, Rp)
                else:
                    _sole_pose(w, m, om, Rm)
            _difference(plus, minus, step, start, m, jj, stiff)
            _jacobian_column(op, Rp, om, Rm, step, start, m, jj, jac)
            for j in range(m):  # q back, and the block's frames with it
                w[ct + j], w[st + j] = cos[j], sin[j]
            sp._kinematics(geometry, dh_a, d5, m, w)
            # link jj + 1 at the block's own motion: its terms back as the base pass left
            # them, and the running values on to joint origin jj + 1
            _links(first, first + 1, com, inertia, m, w, run)
            for r in range(9):
                for j in range(m):
                    run[r, j] = w[sp._OMEGA + r * B + j]
    return tau, mass, stiff, vel, jac


@njit(**_KW)
def rows(chain, gravity, q, qd, qdd, side, sole, share):
    """A plan's rows (``sample`` layout, (n, ``sample.ROW``)) at the given joint motion.

    ``compliance._Dynamics.plan_of``'s torques, ZMP, CoM, swing sole and ground forces
    (``sample.write_rows``); its Q (IK) rows, polygon and margin are not computed here
    (the caller keeps the given q and the plan's polygon).
    Arguments as ``torques``.
    """
    n = q.shape[0]
    out = np.empty((n, sp.ROW))
    w = np.zeros(sp.SCRATCH)  # rows write_rows reads but no pass fills (IK) stay 0
    for start in range(0, n, B):
        m = min(B, n - start)
        _load(q, qd, qdd, side, sole, share, start, m, w)
        _pass(chain, gravity, m, w)
        sp.write_rows(chain[3], gravity, m, w, out, np.arange(start, start + m))
    return out


def plan_inputs(plan) -> tuple:
    """(chain, gravity, side, sole, share) of ``plan`` for ``torques`` and ``linearised``.

    The swing foot's share is the plan's (``compliance._Dynamics``): its ground force
    over the total, 0 where the total is 0.
    """
    from slopewalk.planner.kernel.tables import ChainTable
    from slopewalk.planner.kinematics import gravity_in_slope

    t = ChainTable.of(plan.spec)
    chain = (t.geometry, t.a, t.d5, t.mass, t.com, t.inertia)
    ground_z = plan.ground_force[:, 2]
    loaded = ground_z != 0
    share = np.where(loaded, plan.swing_force[:, 2] / np.where(loaded, ground_z, 1.0), 0.0)
    side = np.ascontiguousarray(plan.stance, dtype=np.int64)
    sole = np.ascontiguousarray(plan.stance_sole, dtype=float)
    return chain, gravity_in_slope(plan.params.slope), side, sole, share
