"""The servo loop's dynamics along a planned walk: the sway a soft position loop adds.

``compliance.compliant_walk`` finds the pose where a servo of stiffness kp holds the
torques the walk needs, a static fixed point. A soft loop (the AX-12A's kp = 9.26
N m/rad on a rotor inertia A = 0.0232 kg m², damped only by the motor's back-EMF
d = stall torque / no-load speed = 0.243 N m s/rad) is a lightly damped
mass-spring: the joint's own mode has ω = √(kp / A) ≈ 20 rad/s (3.2 Hz) and
ζ = d / (2 √(kp A)) ≈ 0.27; loaded by the robot leaning on the stance ankle it
is lower (≈ 2.5 Hz). Every jump of the torque the walk needs (the clamped cubic
splines' accelerations jump at each via point, and A q̈ with them) rings that
mode, and a static fixed point cannot see it. Measured in MuJoCo (default robot,
servo, 2 s steps on flat ground): the joints ring at 2.5–2.8 Hz about the static
fixed point, 0.4–1.0° RMS, and the contact CoP rolls onto the stance foot's inner
edge 7–10 mm beyond where the fixed point's ZMP stays; the joints' departure from
the fixed point peaks at 2.3–2.8 Hz (above the gait's own 0.5 Hz harmonics),
0.4–1.0° RMS. This model on the same walk: 2.3–3.3 Hz, 0.2–0.85° RMS, and it
brings the reached walk's ZMP margin from 3.3 mm (fixed point) to −0.5 mm
(1.5 s steps: 2.0 to −3.8 mm).

Model: the joint equation of the whole chain (rooted at the planned stance sole,
the double-support load split of the plan, as in ``compliance``), linearised about
the plan, q = q_ref + δ:

    (M + A) δ̈ + (C + d) δ̇ + K_g δ = u − (τ_ref + A q̈_ref + d q̇_ref)

with τ_ref the Newton–Euler torque of the plan, M = ∂τ/∂q̈ its mass matrix,
K_g = ∂τ/∂q its gravity (and load) stiffness, C = ∂τ/∂q̇ its velocity terms, all
evaluated along the plan (n, 8, 8), and u the servo's output

    u = clip(kp (−δ) − kv (q̇_ref + δ̇) + τ_ff, ±τ_max)

clipped as MuJoCo clips the actuator force (``forcerange``). It is integrated by
backward Euler on the plan's time base (1 ms: ω dt ≈ 0.02, numerical damping
ω dt / 2 ≈ 0.01, small against ζ); a joint whose output is clipped at a sample
gets the constant ±τ_max in that row. The walk it returns (q_ref + δ and its rates
and accelerations, re-run through the analytic pipeline) carries the sway's ZMP,
which the tipping predictor judges like any other. Saturation thereby acts through
what it does (the joint falls behind, the ZMP moves) rather than through "the
torque exceeds the limit somewhere".

Not modelled: the joints' dry friction (``friction_loss``, 0.011 N m, < 1 % of
the stall torque), and the closed chain of double support (both feet on the
ground constrain the legs' sway; here the plan's load split drives each leg).
"""

from __future__ import annotations

import numpy as np

from planner.compliance import CompliantWalk, _Dynamics
from planner.errors import SlopewalkError
from planner.plan import Plan

STEP = 1e-6  # [rad, rad/s]: central-difference step for K_g and C (τ is smooth in q, q̇)


def linearised(plan: Plan) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """τ_ref (n, 8) and M, K_g, C (n, 8, 8) of ``plan``'s chain along the plan (module doc).

    Column j of each matrix is ∂τ/∂(q̈_j, q_j, q̇_j): M exactly (τ is linear in q̈),
    K_g and C by central differences.
    """
    dyn = _Dynamics(plan)
    q, qd, qdd = plan.q, plan.qd, plan.qdd
    tau = dyn.torque(q, qd, qdd)
    n = q.shape[1]
    mass = np.empty((q.shape[0], n, n))
    stiffness = np.empty_like(mass)
    velocity = np.empty_like(mass)
    for j in range(n):
        e = np.zeros(n)
        e[j] = 1.0
        mass[:, :, j] = dyn.torque(q, qd, qdd + e) - tau
        stiffness[:, :, j] = (
            dyn.torque(q + STEP * e, qd, qdd) - dyn.torque(q - STEP * e, qd, qdd)
        ) / (2 * STEP)
        velocity[:, :, j] = (
            dyn.torque(q, qd + STEP * e, qdd) - dyn.torque(q, qd - STEP * e, qdd)
        ) / (2 * STEP)
    return tau, mass, stiffness, velocity


def servo_walk(
    plan: Plan,
    *,
    stiffness: float,
    velocity_gain: float = 0.0,
    damping: float = 0.0,
    armature: float = 0.0,
    force_limit: float = np.inf,
    feedforward: np.ndarray | None = None,
) -> CompliantWalk:
    """The walk a servo loop makes, integrated through time (module doc).

    Args:
        plan: The planned walk (its ``q`` is the command); the walk starts at rest
            in the static fixed point of its first sample.
        stiffness: kp [N m/rad], > 0.
        velocity_gain: kv [N m s/rad] (on the joint speed).
        damping: Joint damping d [N m s/rad].
        armature: Rotor inertia A [kg m²].
        force_limit: The servo's torque limit τ_max [N m], > 0.
        feedforward: τ_ff fed into the loop [N m], Table-I order, (n, 8); None for none.

    Returns:
        A ``CompliantWalk``: the walk made (``plan``), q_ref − q, ``converged`` False
        where the integration left finite numbers, and the loop's (clipped) output.
    """
    if not stiffness > 0:
        raise SlopewalkError(f"stiffness {stiffness!r} N m/rad: must be > 0")
    if not force_limit > 0:
        raise SlopewalkError(f"force_limit {force_limit!r} N m: must be > 0")
    tau, mass, gravity_k, velocity_c = linearised(plan)
    tau_ff = np.zeros_like(plan.q) if feedforward is None else np.asarray(feedforward)
    n, dof = plan.q.shape
    eye = np.eye(dof)
    # what the joint needs beyond its own sway: τ_ref + A q̈_ref + d q̇_ref
    need = tau + armature * plan.qdd + damping * plan.qd
    dt = np.diff(plan.t, prepend=plan.t[0])
    delta = np.zeros((n, dof))
    rate = np.zeros((n, dof))
    accel = np.zeros((n, dof))
    loop = np.zeros((n, dof))
    # start at rest in the static fixed point of the first sample (the robot has settled)
    k0 = gravity_k[0] + stiffness * eye
    d = np.linalg.solve(k0, -(need[0] + velocity_gain * plan.qd[0] - tau_ff[0]))
    v = np.zeros(dof)
    finite = True
    for k in range(n):
        h = dt[k]
        raw = -stiffness * d - velocity_gain * (plan.qd[k] + v) + tau_ff[k]
        free = np.abs(raw) <= force_limit
        held = np.where(free, 0.0, np.clip(raw, -force_limit, force_limit))
        m = mass[k] + armature * eye
        c = velocity_c[k] + (damping + np.where(free, velocity_gain, 0.0)) * eye
        kk = gravity_k[k] + np.where(free, stiffness, 0.0) * eye
        force = held + np.where(free, tau_ff[k] - velocity_gain * plan.qd[k], 0.0) - need[k]
        # backward Euler: v' = v + h a, δ' = δ + h v'
        a = np.linalg.solve(m + h * c + h * h * kk, force - c @ v - kk @ (d + h * v))
        v = v + h * a
        d = d + h * v
        if not (np.isfinite(d).all() and np.abs(d).max() < np.pi):
            finite = False  # the loop has let go of the plan: hold the last pose
            delta[k:], rate[k:], accel[k:] = delta[k - 1], 0.0, 0.0
            loop[k:] = loop[k - 1]
            break
        delta[k], rate[k], accel[k] = d, v, a
        loop[k] = np.where(free, raw, held)
    dyn = _Dynamics(plan)
    walk = dyn.plan_of(plan.q + delta, plan.qd + rate, plan.qdd + accel)
    return CompliantWalk(walk, -delta, n, finite, loop)
