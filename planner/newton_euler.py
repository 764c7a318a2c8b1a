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

from planner.kinematics import Chain


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product of (..., 3) arrays (faster than np.cross for small rows)."""
    ax, ay, az = a[..., 0], a[..., 1], a[..., 2]
    bx, by, bz = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx], axis=-1)


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("...i,...i->...", a, b)


def _matvec(M: np.ndarray, v: np.ndarray) -> np.ndarray:
    return np.einsum("...ij,...j->...i", M, v)


@dataclass(frozen=True)
class Dynamics:
    """Result of the recursion over n samples, all vectors in S.

    Attributes:
        tau: Joint torques [N m], Table-I order, shape (n, 8); the torque the actuator
            applies to the child link about +axis (the MJCF sign).
        stance_force: Ground force on the stance foot [N], shape (n, 3).
        stance_moment: Ground moment on the stance foot about its sole point [N m], (n, 3).
        omega, omega_dot: Link angular velocity [rad/s] and acceleration [rad/s²], (n, 9, 3).
        com_acc: Link CoM accelerations [m/s²] (true, gravity not included), (n, 9, 3).
        inertia: Link inertia about its CoM in S axes [kg m²], (n, 9, 3, 3).
    """

    tau: np.ndarray
    stance_force: np.ndarray
    stance_moment: np.ndarray
    omega: np.ndarray
    omega_dot: np.ndarray
    com_acc: np.ndarray
    inertia: np.ndarray


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
    n = qd.shape[0]
    R = frames[:, :9, :3, :3]
    origin = frames[:, :9, :3, 3]
    axis = R[:, 1:, :, 2] * chain.theta_sign[None, :, None]  # u_i, (n, 8, 3)
    com_offset = np.einsum("nkij,nkj->nki", R, chain.com[stance])  # (n, 9, 3)
    inertia = R @ chain.inertia[stance] @ np.swapaxes(R, -1, -2)

    omega = np.zeros((n, 9, 3))
    omega_dot = np.zeros((n, 9, 3))
    acc = np.zeros((n, 9, 3))  # frame-origin accelerations, gravity trick included
    acc[:, 0] = -gravity
    for i in range(1, 9):
        w, wd = omega[:, i - 1], omega_dot[:, i - 1]
        spin = qd[:, i - 1, None] * axis[:, i - 1]
        omega[:, i] = w + spin
        omega_dot[:, i] = wd + cross(w, spin) + qdd[:, i - 1, None] * axis[:, i - 1]
        r = origin[:, i] - origin[:, i - 1]
        acc[:, i] = acc[:, i - 1] + cross(wd, r) + cross(w, cross(w, r))
    com_acc = acc + cross(omega_dot, com_offset) + cross(omega, cross(omega, com_offset))
    F = chain.mass[None, :, None] * com_acc
    Iw = _matvec(inertia, omega)
    N = _matvec(inertia, omega_dot) + cross(omega, Iw)

    f = np.zeros((n, 3))  # f_{i+1}: force of link i+1 on link i ...
    m = np.zeros((n, 3))  # ... and its moment about origin i+1
    tau = np.empty((n, 8))
    next_origin = origin[:, 8]
    for i in range(8, -1, -1):
        f_next, m_next = f, m
        f = F[:, i] + f_next
        m = N[:, i] + cross(com_offset[:, i], F[:, i]) + m_next
        m = m + cross(next_origin - origin[:, i], f_next)
        if i >= 1:
            tau[:, i - 1] = _dot(m, axis[:, i - 1])
        next_origin = origin[:, i]
    stance_sole = origin[:, 0] - chain.ankle_height * frames[:, 0, :3, 0]  # x0 points up
    stance_moment = m + cross(origin[:, 0] - stance_sole, f)
    return Dynamics(tau, f, stance_moment, omega, omega_dot, com_acc + gravity, inertia)


def swing_wrench_torques(chain: Chain, frames: np.ndarray, force, moment) -> np.ndarray:
    """Change of the joint torques when the ground also pushes on the swing foot.

    The inward recursion with only an external wrench (F, M) on link 8 at the
    swing sole point s gives n_i = −[(s − o_i) × F + M] on every link between, so
    τ_i = −u_i · [(s − o_i) × F + M] (a Jacobian-transpose product).

    Args:
        frames: DH frames and swing sole in S, shape (n, 10, 4, 4).
        force: Ground force on the swing foot [N], shape (n, 3), in S.
        moment: Ground moment about the swing sole point [N m], shape (n, 3), in S.

    Returns:
        Torque change [N m], shape (n, 8), to add to ``Dynamics.tau``.
    """
    axis = frames[:, 1:9, :3, 2] * chain.theta_sign[None, :, None]
    lever = frames[:, 9, None, :3, 3] - frames[:, 1:9, :3, 3]  # (n, 8, 3)
    return -_dot(axis, cross(lever, force[:, None, :]) + moment[:, None, :])
