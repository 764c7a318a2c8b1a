"""Compliance-aware prediction: the walk a position servo of finite stiffness actually makes.

A position loop of stiffness kp reaches the commanded angle only where it needs
no torque. Each joint's equation with the loop's torque
kp (q_ref − q) − kv q̇ + τ_ff, its own damping d and rotor inertia A reads

    kp (q_ref − q) = τ(q, q̇, q̈) + A q̈ + (d + kv) q̇ − τ_ff

with τ the Newton–Euler torque of the walk actually made. Solved for q this is a
fixed point, q = q_ref − (τ(q) + A q̈ + (d + kv) q̇ − τ_ff) / kp, iterated from
q = q_ref until the largest change is below ``TOLERANCE``. Without feedforward
(τ_ff = 0) the servo sags by τ/kp; with it only what the clipped τ_ff does not
cover is left.

Quasi-static: the deflection changes the pose, the rates stay the plan's (q̇, q̈
of q_ref). Differentiating the deflection instead makes the map unstable: its
second difference at a 1 ms step multiplies the link inertia by 10⁶ s⁻², far
above any kp, and a torque step at a phase change would turn into an
acceleration spike the servo's own mass-spring dynamics smooth out in reality.
The map converges when kp exceeds the gravity stiffness of the chain (for the
default robot about m g h ≈ 1.3 N m/rad at the stance ankle, against kp 9.26).

Stated modelling choices: the stance sole stays where planned (the chain is rooted
there), the planned support polygon holds (the feet are on the ground where the
plan put them), and the double-support load split keeps the plan's shares. The
pass re-runs the analytic pipeline (Newton–Euler, multibody ZMP, margin, friction
ratio) on the deflected angles and returns it as a ``Plan``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.kinematics import Chain, gravity_in_slope
from slopewalk.planner.newton_euler import cross, inverse_dynamics_poses, swing_wrench_torques
from slopewalk.planner.plan import Plan
from slopewalk.planner.zmp import friction_ratio, signed_margin, zmp_lipm, zmp_multibody

TOLERANCE = 1e-7  # [rad], largest change of q between iterations at convergence
MAX_ITERATIONS = 60


@dataclass(frozen=True)
class CompliantWalk:
    """The compliance-aware prediction of one walk.

    Attributes:
        plan: The analytic series re-run on the reached angles (a ``Plan``; its ``q``
            is the reached q, ``tau`` the torque that walk needs).
        deflection: q_ref − q [rad], Table-I order, (n, 8).
        iterations: Fixed-point iterations made.
        converged: Whether the change fell below ``TOLERANCE``; False means no pose
            where the servo holds the torques it needs (the loop is too soft).
        loop_torque: kp (q_ref − q) − kv q̇ + τ_ff [N m], (n, 8): what the servo must
            deliver; beyond its limit it saturates.
        held: Where the loop through time (``servo_loop``) holds the second sole on the
            plane, (n,) bool: double support, and after lift-off while the plane still
            pushes it; None for the static fixed point.
        open_deflection: q_ref − q [rad], (n, 8), of the same loop with the second sole
            never held (``servo_loop.servo_walk``'s ``open_chain_too``); None if not asked.
        friction_checks: Where the loop through time decided whether the plane still
            holds a lifting sole, the plane's normal force and |force along it| [N] then,
            (n, 2), NaN elsewhere (``servo_loop.friction_decides``); None for the static
            fixed point.
    """

    plan: Plan
    deflection: np.ndarray
    iterations: int
    converged: bool
    loop_torque: np.ndarray
    held: np.ndarray | None = None
    open_deflection: np.ndarray | None = None
    friction_checks: np.ndarray | None = None


def compliant_walk(
    plan: Plan,
    *,
    stiffness: float,
    velocity_gain: float = 0.0,
    damping: float = 0.0,
    armature: float = 0.0,
    feedforward: np.ndarray | None = None,
    compiled: bool = True,
) -> CompliantWalk:
    """The walk a servo of stiffness kp reaches when commanded ``plan.q`` (see module doc).

    Args:
        plan: The planned walk (its ``q`` is the command).
        stiffness: kp [N m/rad], > 0.
        velocity_gain: kv [N m s/rad] (on the joint speed).
        damping: Joint damping d [N m s/rad].
        armature: Rotor inertia A [kg m²].
        feedforward: τ_ff fed into the loop [N m], Table-I order, (n, 8); None for none.
        compiled: Iterate on the compiled torques (``kernel.servo.fixed_point``); False:
            on this module's numpy ``_Dynamics``, the reference.
    """
    if not stiffness > 0:
        raise SlopewalkError(f"stiffness {stiffness!r} N m/rad: must be > 0")
    tau_ff = np.zeros_like(plan.q) if feedforward is None else np.asarray(feedforward)
    dynamics = _Dynamics(plan)
    qd, qdd = plan.qd, plan.qdd
    rate_terms = armature * qdd + (damping + velocity_gain) * qd - tau_ff
    if compiled:
        delta, iterations, change = _fixed_point_compiled(plan, rate_terms, stiffness)
    else:
        delta, iterations, change = _fixed_point(dynamics, plan, rate_terms, stiffness)
    converged = bool(change < TOLERANCE)
    walk = dynamics.plan_of(plan.q + delta, qd, qdd, compiled=compiled)
    loop = -stiffness * delta - velocity_gain * qd + tau_ff
    return CompliantWalk(walk, -delta, iterations, converged, loop)


def _fixed_point(dynamics, plan, rate_terms, stiffness):
    """δ = −(τ(q_ref + δ) + rate terms) / kp iterated from 0 (module doc): δ, iterations, change."""
    qd, qdd = plan.qd, plan.qdd
    delta = np.zeros_like(plan.q)
    change, iterations = np.inf, 0
    while iterations < MAX_ITERATIONS and not change < TOLERANCE:
        tau = dynamics.torque(plan.q + delta, qd, qdd)
        new = -(tau + rate_terms) / stiffness
        change = float(np.abs(new - delta).max()) if new.size else 0.0
        delta, iterations = new, iterations + 1
        if not np.isfinite(change):
            break
    return delta, iterations, change


def _fixed_point_compiled(plan, rate_terms, stiffness):
    """``_fixed_point`` on the compiled kernel (``kernel.servo.fixed_point``)."""
    from slopewalk.planner.kernel import cache, dynamics, servo

    cache.first_use("predictors")
    chain, gravity, side, sole, share = dynamics.plan_inputs(plan)
    q, qd, qdd = (np.ascontiguousarray(a, dtype=float) for a in (plan.q, plan.qd, plan.qdd))
    terms = np.ascontiguousarray(rate_terms, dtype=float)
    args = (chain, gravity, q, qd, qdd, side, sole, share, terms, float(stiffness))
    delta, iterations, change = servo.fixed_point(*args, TOLERANCE, MAX_ITERATIONS)
    return delta, int(iterations), float(change)


def torque_at_rest(plan: Plan) -> np.ndarray:
    """Joint torques [N m], Table-I order, (8,), that hold the plan's first pose at rest
    (q̇ = q̈ = 0) on its first stance sole with its first load split: what the robot
    needs while it settles before the walk. The plan's own first torque ``plan.tau[0]``
    adds the inertial torque of the walk's first acceleration (the splines start at
    rest, so q̈(0) grows as 1/T² with the step time T)."""
    q = plan.q[:1]
    return _Dynamics(plan)._solve(q, np.zeros_like(q), np.zeros_like(q), slice(0, 1))[1][0]


class _Dynamics:
    """The analytic pipeline of ``plan`` for other joint angles; stance sole and split fixed."""

    def __init__(self, plan: Plan):
        self.base = plan
        self.chain = Chain.from_spec(plan.spec)
        self.gravity = gravity_in_slope(plan.params.slope)
        ground_z = plan.ground_force[:, 2]
        # the plan's DSP share of the total wrench on the other foot (swing_force = share · total)
        self.share = np.where(ground_z != 0, plan.swing_force[:, 2] / ground_z, 0.0)[:, None]

    def _solve(self, q, qd, qdd, rows=slice(None)):
        """Newton–Euler on the plan's samples ``rows`` (q, q̇, q̈ given on those rows)."""
        p = self.base
        stance, stance_sole, share = p.stance[rows], p.stance_sole[rows], self.share[rows]
        R, o = self.chain.poses(q, stance_sole, stance)
        dyn = inverse_dynamics_poses(self.chain, R, o, qd, qdd, stance, self.gravity)
        swing_sole = o[9].T
        swing_force = share * dyn.stance_force
        swing_moment = share * (
            dyn.stance_moment + cross(stance_sole - swing_sole, dyn.stance_force)
        )
        tau = dyn.tau + swing_wrench_torques(self.chain, R, o, swing_force, swing_moment)
        return dyn, tau, swing_force, swing_sole

    def torque(self, q, qd, qdd):
        return self._solve(q, qd, qdd)[1]

    def plan_of(self, q, qd, qdd, *, compiled: bool = False) -> Plan:
        """``self.base`` at joint motion (q, q̇, q̈): its torques, ZMP, CoM and forces.

        compiled: on the compiled kernel (``kernel.dynamics.rows``); False: numpy.
        """
        if compiled:
            return self._plan_of_compiled(q, qd, qdd)
        dyn, tau, swing_force, swing_sole = self._solve(q, qd, qdd)
        mass = self.chain.mass
        zmp = zmp_multibody(mass, dyn.com, dyn.com_acc, dyn.momentum_rate, self.gravity)
        com = np.einsum("k,nki->ni", mass, dyn.com) / mass.sum()
        com_acc = np.einsum("k,nki->ni", mass, dyn.com_acc) / mass.sum()
        ground = dyn.stance_force
        return replace(
            self.base,
            q=q,
            qd=qd,
            qdd=qdd,
            tau=tau,
            zmp=zmp,
            zmp_lipm=zmp_lipm(com, com_acc, self.gravity),
            com=com,
            com_acc=com_acc,
            swing_sole=swing_sole,
            margin=signed_margin(zmp, self.base.polygon),
            ground_force=ground,
            stance_force=ground - swing_force,
            swing_force=swing_force,
            friction_ratio=friction_ratio(ground),
        )

    def _plan_of_compiled(self, q, qd, qdd) -> Plan:
        """``plan_of`` on the compiled kernel; the margin on the plan's own polygon."""
        from slopewalk.planner.kernel import dynamics
        from slopewalk.planner.kernel import sample as sm

        chain, gravity, side, sole, share = dynamics.plan_inputs(self.base)
        q, qd, qdd = (np.ascontiguousarray(a, dtype=float) for a in (q, qd, qdd))
        rows = dynamics.rows(chain, gravity, q, qd, qdd, side, sole, share)

        def cols(start, width):
            return np.ascontiguousarray(rows[:, start : start + width])

        zmp = cols(sm.ZMP, 2)
        return replace(
            self.base,
            q=q,
            qd=qd,
            qdd=qdd,
            tau=cols(sm.TAU, 8),
            zmp=zmp,
            zmp_lipm=cols(sm.ZMP_LIPM, 2),
            com=cols(sm.COM, 3),
            com_acc=cols(sm.COM_ACC, 3),
            swing_sole=cols(sm.SWING_SOLE, 3),
            margin=signed_margin(zmp, self.base.polygon),
            ground_force=cols(sm.GROUND, 3),
            stance_force=cols(sm.STANCE_FORCE, 3),
            swing_force=cols(sm.SWING_FORCE, 3),
            friction_ratio=rows[:, sm.FRICTION].copy(),
        )
