"""Tipping predictor: the foot's rotation about the support edge while the ZMP is outside.

The paper's test is binary: the ZMP leaves the support polygon or not. A brief
excursion need not tip the robot. While the ZMP (the point where the ground
reaction would have to act for the plan to be followed) lies a distance e beyond
the polygon's edge, the ground can push only at the edge, so an unbalanced moment
F_n e about that edge is left; it turns the whole robot about the edge
(cf. Goswami's foot-rotation indicator, FRI):

    I_edge θ̈ = F_n · (−margin + h θ)          θ ≥ 0 (the sole cannot sink into the plane)

with margin the signed ZMP margin (negative outside), F_n the planned normal
ground force, h the CoM's height above the plane and I_edge the robot's moment
of inertia about the edge line. The term h θ is the inverted pendulum's: turning
the robot by θ about the edge carries its CoM h θ further out over it, so a
rotation, once started, feeds itself (F_n h / I_edge ≈ 50 s⁻² for the default
robot: a time constant of 0.14 s, as long as an excursion). Once the ZMP is back
inside by more than h θ, the moment restores; the foot lands (θ = 0) and stops
(θ̇ = 0, no bounce).
The rotation is integrated sample by sample (semi-implicit Euler on the plan's
time base) through each excursion and after it until the foot is back down. The
pivot is fixed for one rotation: the moment is the ZMP's distance beyond that
edge's line (e = −margin while the ZMP is outside near it), so an excursion past
the opposite edge pushes the robot back, as it would.
``tip`` is predicted when θ passes the simulator's tip angle.

Small-angle model: sin θ ≈ θ, cos θ ≈ 1 (under 0.4 % at 5°); the pivot is the
polygon edge nearest to the ZMP when the excursion starts, and I_edge its value
then (the pose changes little within a rotation).

I_edge = Σ_k m_k d_k² + ê·I_k ê over the 9 links, d_k the distance of link k's
CoM from the edge line and I_k its inertia about its CoM, both in S.
"""

from __future__ import annotations

import numpy as np

from planner.kinematics import Chain


def excursion_integral(t, drive, inertia, feedback=0.0) -> np.ndarray:
    """One-sided integral x(t) of I ẍ = drive + k x, with x ≥ 0 (stops when back at 0).

    Args:
        t: Sample times [s], (n,).
        drive: Generalised force [N m or N], (n,): positive pushes x away from 0.
        inertia: Inertia about the motion [kg m² or kg], (n,) or scalar, > 0.
        feedback: k, the force per unit x that x itself adds [N m/rad or N/m], (n,)
            or scalar, ≥ 0 (the inverted pendulum's F_n h for a rotation).

    Returns:
        x at each sample [rad or m], (n,).
    """
    drive = np.asarray(drive, dtype=float)
    inertia = np.broadcast_to(np.asarray(inertia, dtype=float), drive.shape)
    feedback = np.broadcast_to(np.asarray(feedback, dtype=float), drive.shape)
    x, v = 0.0, 0.0
    out = np.zeros(drive.size)
    dt = np.diff(t, prepend=t[0])
    for k in range(drive.size):
        if x <= 0.0 and drive[k] <= 0.0:
            x, v = 0.0, 0.0  # resting on the plane, pushed onto it
        else:
            v += (drive[k] + feedback[k] * x) / inertia[k] * dt[k]
            x += v * dt[k]
            if x <= 0.0:
                x, v = 0.0, 0.0  # landed back
        out[k] = x
    return out


def nearest_edge(points, polygon) -> tuple[np.ndarray, np.ndarray]:
    """The polygon edge nearest to each point: a point on it and its unit direction.

    Args:
        points: (n, 2) [m].
        polygon: Counter-clockwise vertices, repeats allowed, (n, V, 2) [m].

    Returns:
        (edge start (n, 2) [m], unit direction (n, 2)).
    """
    a = polygon
    edge = np.roll(polygon, -1, axis=1) - a
    length = np.hypot(edge[..., 0], edge[..., 1])
    valid = length > 1e-12
    safe = np.where(valid, length, 1.0)
    rel = points[:, None, :] - a
    s = np.clip(np.einsum("nvi,nvi->nv", rel, edge) / safe**2, 0.0, 1.0)
    closest = a + s[..., None] * edge
    gap = np.where(valid, np.hypot(*(points[:, None, :] - closest).transpose(2, 0, 1)), np.inf)
    best = np.argmin(gap, axis=1)
    rows = np.arange(points.shape[0])
    return a[rows, best], edge[rows, best] / safe[rows, best, None]


def edge_inertia(plan, rows, edge_point, edge_direction) -> np.ndarray:
    """Moment of inertia of the robot about a line on the plane [kg m²], at plan samples ``rows``.

    Args:
        plan: The walk (``planner.plan.Plan``).
        rows: Sample indices, (k,).
        edge_point: A point of each line on the plane, (k, 2) [m].
        edge_direction: Unit direction of each line in the plane, (k, 2).
    """
    chain = Chain.from_spec(plan.spec)
    stance = plan.stance[rows]
    frames = chain.frames(plan.q[rows], plan.stance_sole[rows], stance)
    coms = chain.link_coms(frames, stance)  # (k, 9, 3)
    axis = np.column_stack([edge_direction, np.zeros(len(rows))])  # (k, 3)
    origin = np.column_stack([edge_point, np.zeros(len(rows))])
    rel = coms - origin[:, None, :]
    along = np.einsum("kli,ki->kl", rel, axis)
    distance2 = np.einsum("kli,kli->kl", rel, rel) - along**2
    # link inertia in S: R_k I_k R_kᵀ, with I_k in its DH frame's axes
    R = frames[:, :9, :3, :3]
    inertia = chain.inertia[stance]  # (k, 9, 3, 3)
    local = np.einsum("klji,kj->kli", R, axis)  # axis in each link frame
    spin = np.einsum("kli,klij,klj->kl", local, inertia, local)
    return np.einsum("l,kl->k", chain.mass, distance2) + spin.sum(axis=1)


FALLEN = np.pi / 2  # [rad]: a rotation past this is reported as this (the robot is down)


def foot_rotation(plan, margin=None, zmp=None) -> np.ndarray:
    """Predicted rotation of the support about its edge [rad], (n,) (see module doc).

    A rotation starts when the ZMP leaves the polygon while the support lies flat;
    its pivot is the polygon edge nearest to the ZMP then, held until the support
    is flat again. It is driven by the ZMP's signed distance beyond that pivot's
    line, e (positive outside): I_edge θ̈ = F_n (e + h θ), I_edge taken at the start.

    Args:
        plan: The walk; its polygon, ground force, joint angles and CoM are used.
        margin, zmp: The ZMP series to judge, (n,) and (n, 2); default the plan's own.
    """
    margin = plan.margin if margin is None else margin
    zmp = plan.zmp if zmp is None else zmp
    normal = np.maximum(plan.ground_force[:, 2], 0.0)
    height = np.maximum(plan.com[:, 2], 0.0)
    dt = np.diff(plan.t, prepend=plan.t[0])
    theta = np.zeros(plan.t.size)
    outside = np.flatnonzero(margin < 0)
    if not outside.size:
        return theta
    x, v, pivot = 0.0, 0.0, None
    for k in range(outside[0], plan.t.size):
        if pivot is None:
            if not margin[k] < 0:
                continue
            point, direction = nearest_edge(zmp[k : k + 1], plan.polygon[k : k + 1])
            inertia = edge_inertia(plan, np.array([k]), point, direction)[0]
            inward = np.array([-direction[0, 1], direction[0, 0]])
            pivot = (point[0], inward, inertia)
        point, inward, inertia = pivot
        beyond = -float((zmp[k] - point) @ inward)
        v += normal[k] * (beyond + height[k] * x) / inertia * dt[k]
        x = min(x + v * dt[k], FALLEN)
        if x <= 0.0:
            x, v, pivot = 0.0, 0.0, None  # flat again (no bounce)
        theta[k] = x
    return theta
