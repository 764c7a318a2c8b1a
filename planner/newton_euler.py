"""Newton-Euler iterative inverse dynamics of the stance-rooted chain (sec. V-A).

The stance foot (link 0) is fixed to the plane; links 1..8 follow the DH frames
of ``kinematics.Chain``. The recursion of the paper (outward velocities and
accelerations, inward forces and moments, τ_i = n_i · ẑ_i) is carried out with
every vector expressed in the slope frame S, so it vectorises over samples
without per-link frame changes:

    outward   ω_i  = ω_{i-1} + q̇_i u_i
              ω̇_i  = ω̇_{i-1} + ω_{i-1} × q̇_i u_i + q̈_i u_i
              a_i  = a_{i-1} + ω̇_{i-1} × r_i + ω_{i-1} × (ω_{i-1} × r_i)     (frame origins)
              a_ci = a_i + ω̇_i × c_i + ω_i × (ω_i × c_i)                      (link CoMs)
              F_i  = m_i (a_ci − g),   N_i = I_i ω̇_i + ω_i × I_i ω_i
    inward    f_i  = F_i + f_{i+1} − F_ext,i
              n_i  = N_i + c_i × F_i + n_{i+1} + r_{i+1} × f_{i+1} − (moment of F_ext,i)
              τ_i  = n_i · u_i

u_i is the joint axis in S with the sign of q_i (θ_i = ±q_i + const); r_i the
vector between frame origins; c_i the CoM offset from its frame origin.
Gravity enters as a base acceleration −g (so F_i is the net force the rest
of the chain must supply).

Double support: the recursion gives the whole ground reaction at the stance
foot. The planner then moves a share of it to the other foot by a stated rule
(``plan.py``); since the dynamics are linear in that wrench its effect on the
torques is the closed form of ``swing_wrench_torques``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slopewalk.planner.kinematics import Chain


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product of (..., 3) arrays (faster than np.cross for small rows)."""
    ax, ay, az = a[..., 0], a[..., 1], a[..., 2]
    bx, by, bz = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx], axis=-1)


@dataclass(frozen=True)
class Dynamics:
    """Result of the recursion over n samples, all vectors in S.

    Attributes:
        tau: Joint torques [N m], Table-I order, shape (n, 8); the torque the actuator
            applies to the child link about +axis (the MJCF sign).
        stance_force: Ground force on the stance foot [N], shape (n, 3).
        stance_moment: Ground moment on the stance foot about its sole point [N m], (n, 3).
        com: Link CoM positions [m], (n, 9, 3).
        omega, omega_dot: Link angular velocity [rad/s] and acceleration [rad/s²], (n, 9, 3).
        com_acc: Link CoM accelerations [m/s²] (true, gravity not included), (n, 9, 3).
        momentum_rate: Rate of each link's angular momentum about its CoM,
            Ḣ_i = I_i ω̇_i + ω_i × I_i ω_i [N m], (n, 9, 3).
    """

    tau: np.ndarray
    stance_force: np.ndarray
    stance_moment: np.ndarray
    com: np.ndarray
    omega: np.ndarray
    omega_dot: np.ndarray
    com_acc: np.ndarray
    momentum_rate: np.ndarray


def inverse_dynamics(
    chain: Chain,
    frames: np.ndarray,
    qd: np.ndarray,
    qdd: np.ndarray,
    stance: np.ndarray,
    gravity: np.ndarray,
) -> Dynamics:
    """Joint torques and ground wrench of the chain, given its motion.

    Args:
        chain: The robot's DH chain and inertials.
        frames: DH frames 0..8 and the swing sole in S, shape (n, 10, 4, 4) (``Chain.frames``).
        qd, qdd: Joint rates [rad/s] and accelerations [rad/s²], shape (n, 8).
        stance: Stance leg, 0 left / 1 right, shape (n,).
        gravity: Gravity vector in S [m/s²], shape (3,).

    Returns:
        ``Dynamics``.
    """
    R = np.ascontiguousarray(frames[:, :, :3, :3].transpose(1, 2, 3, 0))
    o = np.ascontiguousarray(frames[:, :, :3, 3].transpose(1, 2, 0))
    return inverse_dynamics_poses(chain, R, o, qd, qdd, stance, gravity)


def inverse_dynamics_poses(chain, R, o, qd, qdd, stance, gravity) -> Dynamics:
    """``inverse_dynamics`` on sample-last poses (``Chain.poses``), the fast path.

    Every vector is a (3, n) array with the sample axis contiguous, so each
    step of the recursion is a handful of whole-array operations.
    """
    n = qd.shape[0]
    qd, qdd = qd.T, qdd.T
    axis = [None] + [R[i, :, 2] * chain.theta_sign[i - 1] for i in range(1, 9)]  # u_i (3, n)
    right = np.asarray(stance)[None, :] == 1
    inertia = chain.inertia[0]  # (9, 3, 3) in DH axes; equal for both stance sides
    omega, omega_dot, com_acc, com_offset = [], [], [], []
    w = wd = np.zeros((3, n))
    acc = np.broadcast_to(-np.asarray(gravity, dtype=float)[:, None], (3, n))  # gravity trick
    for i in range(9):
        if i:
            spin = qd[i - 1] * axis[i]
            r = o[i] - o[i - 1]
            acc = acc + _cross(wd, r) + _cross(w, _cross(w, r))
            w, wd = w + spin, wd + _cross(w, spin) + qdd[i - 1] * axis[i]
        c = _rotate(R[i], np.where(right, chain.com[1, i][:, None], chain.com[0, i][:, None]))
        omega.append(w)
        omega_dot.append(wd)
        com_offset.append(c)
        com_acc.append(acc + _cross(wd, c) + _cross(w, _cross(w, c)))
    momentum_rate = []
    for i in range(9):
        Iw = _rotate(R[i], inertia[i] @ _rotate_back(R[i], omega[i]))
        Iwd = _rotate(R[i], inertia[i] @ _rotate_back(R[i], omega_dot[i]))
        momentum_rate.append(Iwd + _cross(omega[i], Iw))

    f = np.zeros((3, n))  # f_{i+1}: force of link i+1 on link i ...
    m = np.zeros((3, n))  # ... and its moment about origin i+1 (o[9] is the swing sole)
    tau = np.empty((8, n))
    for i in range(8, -1, -1):
        F = chain.mass[i] * com_acc[i]
        m = momentum_rate[i] + _cross(com_offset[i], F) + m + _cross(o[i + 1] - o[i], f)
        f = F + f
        if i >= 1:
            tau[i - 1] = np.einsum("in,in->n", m, axis[i])
    stance_sole = o[0] - chain.ankle_height * R[0, :, 0]  # x0 points up
    stance_moment = m + _cross(o[0] - stance_sole, f)
    com = [o[i] + com_offset[i] for i in range(9)]
    return Dynamics(
        tau.T,
        f.T,
        stance_moment.T,
        _links(com),
        _links(omega),
        _links(omega_dot),
        _links(com_acc) + gravity,
        _links(momentum_rate),
    )


def _links(vectors: list[np.ndarray]) -> np.ndarray:
    """Per-link (3, n) arrays → one (n, k, 3) array."""
    return np.stack(vectors).transpose(2, 0, 1)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product of (3, n) arrays."""
    return np.array(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


def _rotate(R: np.ndarray, v: np.ndarray) -> np.ndarray:
    """R v for R (3, 3, n) and v (3, n)."""
    return R[:, 0] * v[0] + R[:, 1] * v[1] + R[:, 2] * v[2]


def _rotate_back(R: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rᵀ v for R (3, 3, n) and v (3, n)."""
    return R[0] * v[0] + R[1] * v[1] + R[2] * v[2]


def swing_wrench_torques(chain: Chain, R, o, force, moment) -> np.ndarray:
    """Change of the joint torques when the ground also pushes on the swing foot.

    The inward recursion with only an external wrench (F, M) on link 8 at the
    swing sole point s gives n_i = −[(s − o_i) × F + M] on every link between, so
    τ_i = −u_i · [(s − o_i) × F + M] (a Jacobian-transpose product).

    Args:
        R, o: Sample-last poses of frames 0..9 (``Chain.poses``), (10, 3, 3, n), (10, 3, n).
        force: Ground force on the swing foot [N], shape (n, 3), in S.
        moment: Ground moment about the swing sole point [N m], shape (n, 3), in S.

    Returns:
        Torque change [N m], shape (n, 8), to add to ``Dynamics.tau``.
    """
    F, M = force.T, moment.T
    out = np.empty((8, F.shape[1]))
    for i in range(1, 9):
        axis = R[i, :, 2] * chain.theta_sign[i - 1]
        out[i - 1] = -np.einsum("in,in->n", axis, _cross(o[9] - o[i], F) + M)
    return out.T
