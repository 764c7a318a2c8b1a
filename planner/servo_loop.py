"""The servo loop's dynamics along a planned walk: the sway a soft position loop adds.

``compliance.compliant_walk`` finds the pose where a servo of stiffness kp holds the
torques the walk needs, a static fixed point. A soft loop (the AX-12A's kp = 9.26
N m/rad on a rotor inertia A = 0.0232 kg m², damped only by the motor's back-EMF
d = stall torque / no-load speed = 0.243 N m s/rad) is a lightly damped
mass-spring: the joint's own mode has ω = √(kp / A) ≈ 20 rad/s (3.2 Hz) and
ζ = d / (2 √(kp A)) ≈ 0.27, lower with the links on it. Every jump of the torque
the walk needs rings that mode, and a static fixed point cannot see it: the
clamped cubic splines' accelerations jump at each via point (and A q̈ with them),
and above all the load jumps at lift-off. In double support both soles are flat on
the plane: the legs form a closed chain that holds the sway (with no hip roll
joint the frontal chain cannot move at all), and the load on each foot is what the
chain's compliance makes it, not the plan's smooth split. Measured in MuJoCo
(default robot, ``servo``, 2 s steps on flat ground): the foot about to lift still
carries 2.4 N (37 % of the weight) at the end of double support, where the plan
has it at 0, and unloads within 0.1 s; the stance leg then takes the load in one
go, the robot sways towards the swing side and the contact CoP sits on the stance
sole's inner edge for 0.4 s (where the fixed point's ZMP stays 5–10 mm inside);
the joints' departure from the fixed point peaks at 2.3–2.8 Hz, 0.4–1.0° RMS.

Model: the joint equation of the chain rooted at the planned stance sole,
linearised about the plan, q = q_ref + δ:

    (M + A) δ̈ + (C + d) δ̇ + K_g δ = u − (τ_ref + A q̈_ref + d q̇_ref) + Jᵀ λ

with τ_ref the Newton–Euler torque of the plan (with its double-support split),
M = ∂τ/∂q̈ its mass matrix, K_g = ∂τ/∂q its gravity (and load) stiffness,
C = ∂τ/∂q̇ its velocity terms, all along the plan (n, 8, 8), and u the servo's output

    u = clip(kp (−δ) − kv (q̇_ref + δ̇) + τ_ff, ±τ_max)

clipped as MuJoCo clips the actuator force (``forcerange``). In double support
the second sole stays where it is: J δ̇ = 0 with J its pose's Jacobian (rows x, z,
roll, pitch: ``HELD``), λ the ground's wrench beyond the plan's split; touching
down, the sole stops in a plastic impact (``_landed``). After lift-off the plan lifts
that sole, but the plane is unilateral: the sole stays where it is, J (q̇_ref + δ̇) = 0,
for as long as the plane pushes it (λ_z > 0), and the loop's sway is the closed chain's
until then (``_trailing``; ``CompliantWalk.held``). Measured in MuJoCo (default robot,
``servo``, 2 s steps, ``tests/sim/test_trailing_sole.py``): the trailing foot stays loaded
77–92 ms past the planned lift-off, the loop holds its sole 73–120 ms. Released at the
planned lift-off, as before, the load jumped onto the stance leg in one step and rang
the joint mode: on a random gait of the design draw (2 s, 10°, 15° lean) that swing put
the ZMP 5 mm past the stance sole's inner edge and the predicted support tilt to 10.5°,
where MuJoCo's CoP stays inside and its foot tilts 2.2°. The plane holds the sole along
itself by friction alone: where the hold would need a tangential force past the friction
cone, |λ_x| > μ λ_z, the sole slides and is let go too (the free step). Without that
bound, on GA gaits of the design set that carry the trailing sole back against a
downhill lean (extended family, pelvis offset ≈ −100 mm, −12.5 … −27.5°), the hold
lasted the whole single support with |λ_x| up to 700 N against λ_z of 4–500 N, the
stiff loop fought it with 50 N m and the predictor called a tip of 90° where MuJoCo's
robot walks with its soles tilting 0.2°. Otherwise λ = 0 in single support.
Integrated by backward Euler on the plan's time base (1 ms: ω dt ≈ 0.02, numerical
damping ω dt / 2 ≈ 0.01, small against ζ); a joint whose output is clipped gets the
constant ±τ_max in its row. The walk returned (q_ref + δ and its rates and
accelerations, re-run through the analytic pipeline) carries the sway's ZMP, which
the tipping predictor judges like any other; saturation acts through what it does
(the joint falls behind, the ZMP moves).

The same walk in this model: the ZMP passes the inner edge by 5.5 mm at lift-off
(the fixed point keeps 3.3 mm of margin), and the joint angles come 0.2–0.8° RMS
from MuJoCo's on the stance leg (the fixed point: 0.4–1.0°); the swing ankle is
worse (0.9–1.0° against 0.7°). It predicts the tip one step early (1.25 s, MuJoCo
3.53 s): MuJoCo's robot rolls 2° in the first single support and recovers.

Not modelled: the joints' dry friction (``friction_loss``, 0.011 N m, < 1 % of the
stall torque), a double-support sole lifting or sliding (the constraint is
bilateral until lift-off), and the swing sole touching the plane again in single
support (``strike``). Known wrong (results/README.md, stop 33): the held sole is held
where the loop's sag left it at the touchdown, not on the plane (J δ̇ = 0 only, not
J δ = 0): on the nominal 2 s ``servo`` walk 3.6 mm above it, so every double support
after the first has the lifting foot carry the whole weight (MuJoCo: 2.35 of 6.6 N);
closing the chain at the touchdown fixes the split but costs `servo` verdicts on the
design set, and is not in yet. Missing (results/README.md, stop 35): the robot moving as a
whole on its soles. The stance sole is bolted to the plane and a landing is plastic, so
the bounce a landing makes on the lightly damped servos is not in the walk: on fast
(0.35-0.55 s) ``servo`` gaits MuJoCo's robot lands hard, falls back onto the old stance
foot and fails (24 of the 28 design-set trials predicted stable: 14 falls, 6 tips, 4
slips), and walks with the joints' damping tripled; the loop takes that damping divided
by 3 to call them.
"""

from __future__ import annotations

import numpy as np

from slopewalk.planner.compliance import CompliantWalk, _Dynamics, torque_at_rest
from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.kinematics import Chain
from slopewalk.planner.per_plan import once_per_plan
from slopewalk.planner.plan import Plan

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


def support_jacobian(plan: Plan) -> np.ndarray:
    """∂(second sole's pose)/∂q along the plan, (n, 6, 8): rows x, y, z [m/rad], then the
    sole's rotation vector in S [rad/rad], by central differences of the chain's poses."""
    chain = Chain.from_spec(plan.spec)
    q, n = plan.q, plan.q.shape[1]
    jac = np.empty((q.shape[0], 6, n))
    for j in range(n):
        e = np.zeros(n)
        e[j] = STEP
        Rp, op = chain.poses(q + e, plan.stance_sole, plan.stance)
        Rm, om = chain.poses(q - e, plan.stance_sole, plan.stance)
        jac[:, :3, j] = ((op[9] - om[9]) / (2 * STEP)).T
        # R₊ R₋ᵀ ≈ I + [2 STEP ω]ₓ: its skew part is the rotation per radian
        W = np.einsum("ikn,jkn->nij", Rp[9], Rm[9])
        jac[:, 3:, j] = np.stack([W[:, 2, 1] - W[:, 1, 2], W[:, 0, 2] - W[:, 2, 0],
                                  W[:, 1, 0] - W[:, 0, 1]], axis=1) / (4 * STEP)  # fmt: skip
    return jac


# The rows the flat second sole holds in double support: x, z, roll and pitch. Its lateral
# slide (y) is its roll times the ankle height to first order (no hip roll joint), the
# rest of it second order in the lean, and no joint turns the sole in yaw.
HELD = [0, 2, 3, 4]


def _constrained(matrix, rhs, jac, target, wrench=False):
    """Solve matrix x − jacᵀ λ = rhs, jac x = target (min-norm where jac is rank deficient).

    Returns x, or (x, λ) with ``wrench``: λ the held rows' wrench on the sole.
    """
    dof, rows = matrix.shape[0], jac.shape[0]
    kkt = np.zeros((dof + rows, dof + rows))
    kkt[:dof, :dof], kkt[:dof, dof:], kkt[dof:, :dof] = matrix, -jac.T, jac
    solution = np.linalg.lstsq(kkt, np.concatenate([rhs, target]), rcond=None)[0]
    return (solution[:dof], solution[dof:]) if wrench else solution[:dof]


def _landed(mass, jac, rate):
    """Joint rates after a plastic impact that stops the second sole (J q̇⁺ = 0).

    The impulse p = −(J M⁻¹ Jᵀ)⁺ J q̇ acts at the sole: q̇⁺ = q̇ + M⁻¹ Jᵀ p. Kept out of
    the recorded accelerations: an impulse has no ZMP (the tipping model's landing
    law is what such an impact does to a rocking support).
    """
    speed = jac @ rate
    if not np.abs(speed).max() > 0:
        return rate
    mj = np.linalg.solve(mass, jac.T)  # M⁻¹ Jᵀ
    return rate - mj @ (np.linalg.pinv(jac @ mj) @ speed)


def _system(m, c, kk, force, d, v, h):
    """The backward-Euler step's system (m + h c + h² kk) a = force − c v − kk (δ + h v):
    (matrix, rhs)."""
    return m + h * c + h * h * kk, force - c @ v - kk @ (d + h * v)


def _backward_euler(m, c, kk, force, d, v, h, jac):
    """One step of m a + c v' + kk δ' = force: v' = v + h a, δ' = δ + h v'; (v', δ', a).

    ``jac``: the held rows of the second sole's Jacobian where it stops and stays
    (J v' = 0, after ``_landed``), or None.
    """
    matrix, rhs = _system(m, c, kk, force, d, v, h)
    if jac is not None:
        v = _landed(m, jac, v)
        rhs = force - c @ v - kk @ (d + h * v)
        a = _constrained(matrix, rhs, jac, -jac @ v / h)
    else:
        a = np.linalg.solve(matrix, rhs)
    v = v + h * a
    return v, d + h * v, a


NORMAL = HELD.index(2)  # the held rows' normal force (z of S) in λ
TANGENT = HELD.index(0)  # and the force along the plane (x of S)


def _trailing(m, c, kk, force, d, v, h, jac, qd_ref, friction):
    """One step with the trailing sole kept where it is on the plane after lift-off, and
    whether the plane still holds it; (v', δ', a, held, λ_z, |λ_x|), the last two the
    plane's forces [N] that decided it (``friction_decides``).

    The plan lifts the sole at J q̇_ref; held, the sole stays put: J (q̇_ref + v') = 0.
    Where the plane would have to pull (λ_z ≤ 0) the sole has left it, and where it would
    have to hold it along itself past the friction cone (|λ_x| > μ λ_z, μ ``friction``)
    it slides; either way the step is the free one.
    """
    matrix, rhs = _system(m, c, kk, force, d, v, h)
    a, wrench = _constrained(matrix, rhs, jac, -jac @ (qd_ref + v) / h, wrench=True)
    normal, along = wrench[NORMAL], abs(wrench[TANGENT])
    if not _plane_holds(normal, along, friction):
        return (*_backward_euler(m, c, kk, force, d, v, h, None), False, normal, along)
    v = v + h * a
    return v, d + h * v, a, True, normal, along


def _plane_holds(normal, along, friction):
    """Whether the plane holds a lifting sole pressed with λ_z = ``normal`` and pushed along
    itself with |λ_x| = ``along`` [N] (scalars or arrays): λ_z > 0 and |λ_x| ≤ μ λ_z. One
    expression for ``_trailing`` and ``friction_decides``, so the two decide alike to the
    bit (``kernel.servo._trailing`` writes the same)."""
    return (normal > 0.0) & (along <= friction * normal)


def _loop_model(plan: Plan, both: np.ndarray, compiled: bool):
    """τ_ref, M, K_g, C and the held rows of the second sole's Jacobian, (n, 4, dof), at
    every sample of ``plan`` (``linearised``, ``support_jacobian``); the Jacobian is read
    only where ``both`` (the second sole held), on the numpy path zeros elsewhere."""
    if compiled:
        return _plan_linearisation(plan)
    tau, mass, gravity_k, velocity_c = linearised(plan)
    n, dof = plan.q.shape
    jac = support_jacobian(plan)[:, HELD] if both.any() else np.zeros((n, len(HELD), dof))
    return tau, mass, gravity_k, velocity_c, jac


def _settled_offset(
    rest: np.ndarray,
    stiffness0: np.ndarray,
    jac0: np.ndarray,
    closed: bool,
    settle_feedforward: np.ndarray | None,
    force_limit: float | None,
) -> np.ndarray:
    """q_ref − q [rad] where the robot settled, at rest in the static fixed point of the
    first pose: (kp + K_g) δ0 = τ_ff(settle) − τ(rest), the second sole held where
    ``closed``.

    ``rest`` is the torque that holds the first pose at rest [N m], (8,)
    (``compliance.torque_at_rest``); ``stiffness0`` kp + K_g at the first sample
    [N m/rad], (8, 8); ``jac0`` the held rows of the second sole's Jacobian there.
    ``settle_feedforward`` None: the torque at rest clipped to ±``force_limit`` [N m], or
    none where ``force_limit`` is None (a loop without feedforward).
    """
    if settle_feedforward is not None:
        held = np.asarray(settle_feedforward, float)
    else:
        held = (
            np.zeros_like(rest) if force_limit is None else np.clip(rest, -force_limit, force_limit)
        )
    f0 = -(rest - held)
    if closed:
        return _constrained(stiffness0, f0, jac0, np.zeros(len(HELD)))
    return np.linalg.solve(stiffness0, f0)


def servo_walk(
    plan: Plan,
    *,
    stiffness: float,
    velocity_gain: float = 0.0,
    damping: float = 0.0,
    armature: float = 0.0,
    force_limit: float = np.inf,
    feedforward: np.ndarray | None = None,
    closed_chain: bool = True,
    compiled: bool = True,
    friction: float = np.inf,
    settle_feedforward: np.ndarray | None = None,
    open_chain_too: bool = False,
) -> CompliantWalk:
    """The walk a servo loop makes, integrated through time (module doc).

    Args:
        plan: The planned walk (its ``q`` is the command); the walk starts at rest
            in the static fixed point of its first pose, where the robot settled:
            the loop holds the torque at rest (``compliance.torque_at_rest``), not
            the walk's first torque (that adds the first acceleration's inertia).
        stiffness: kp [N m/rad], > 0.
        velocity_gain: kv [N m s/rad] (on the joint speed).
        damping: Joint damping d [N m s/rad].
        armature: Rotor inertia A [kg m²].
        force_limit: The servo's torque limit τ_max [N m], > 0.
        feedforward: τ_ff fed into the loop [N m], Table-I order, (n, 8); None for none.
        closed_chain: In double support the second sole stays where it is on the plane
            (module doc); False: it moves with the sway, loaded by the plan's split.
        compiled: Linearise and integrate on the compiled kernel
            (``kernel.dynamics``, ``kernel.servo``); False: this module's numpy
            (``linearised``, ``support_jacobian``, ``_integrate``), the reference.
        friction: μ of the plane, > 0: how far along itself it holds a trailing sole
            (module doc); inf: without bound.
        settle_feedforward: τ_ff fed into the loop while the robot settled [N m],
            Table-I order, (8,); None: none without ``feedforward``, else the torque at
            rest clipped to ±τ_max (``playback.settle_feedforward``'s).
        open_chain_too: Also integrate the loop with the second sole never held, on the
            same linearisation, into ``open_deflection``: where the joints would take
            the two soles apart in double support (``verdict.double_support_tilt``).

    Returns:
        A ``CompliantWalk``: the walk made (``plan``), q_ref − q, ``converged`` False
        where a joint left the plan by π or more (the loop let go; the pose is held
        from there), and the loop's request kp (−δ) − kv q̇ + τ_ff before clipping
        (beyond ±τ_max the servo delivers ±τ_max).
    """
    if not stiffness > 0:
        raise SlopewalkError(f"stiffness {stiffness!r} N m/rad: must be > 0")
    if not force_limit > 0:
        raise SlopewalkError(f"force_limit {force_limit!r} N m: must be > 0")
    if not friction > 0:
        raise SlopewalkError(f"friction {friction!r}: must be > 0 (inf: no bound)")
    both = plan.double_support & closed_chain
    tau, mass, gravity_k, velocity_c, jac = _loop_model(plan, both, compiled)
    tau_ff = np.zeros_like(plan.q) if feedforward is None else np.asarray(feedforward, float)
    # what the joint needs beyond its own sway: τ_ref + A q̈_ref + d q̇_ref
    need = tau + armature * plan.qdd + damping * plan.qd
    gains = tuple(
        float(g) for g in (stiffness, velocity_gain, damping, armature, force_limit, friction)
    )
    model = (mass, gravity_k, velocity_c, need, tau_ff, jac)
    settle = (
        torque_at_rest(plan),
        settle_feedforward,
        None if feedforward is None else force_limit,
    )
    delta, rate, accel, loop, held, checks, finite = _loop(
        plan, model, both, gains, settle, compiled
    )
    dyn = _Dynamics(plan)
    walk = dyn.plan_of(plan.q + delta, plan.qd + rate, plan.qdd + accel, compiled=compiled)
    opened = None
    if open_chain_too:
        never = np.zeros_like(both)
        opened = -_loop(plan, model, never, gains, settle, compiled)[0]
    return CompliantWalk(walk, -delta, plan.q.shape[0], bool(finite), loop, held, opened, checks)


def friction_decides(walk: CompliantWalk, friction: float) -> bool:
    """Whether ``servo_walk`` on a plane of μ = ``friction`` (> 0) would make another walk
    than ``walk``, made with the same arguments at another μ.

    μ enters the loop only where a lifting sole is held (``_trailing``: held while
    λ_z > 0 and |λ_x| ≤ μ λ_z). Where each of those checks in ``walk``
    (``CompliantWalk.friction_checks``) comes out the same at ``friction``, every step
    is the same arithmetic, so the walk is the same to the bit: False. The open chain
    (``open_chain_too``) never holds a sole and does not depend on μ.
    """
    if not friction > 0:
        raise SlopewalkError(f"friction {friction!r}: must be > 0 (inf: no bound)")
    checks, held = walk.friction_checks, walk.held
    if checks is None or held is None:
        raise SlopewalkError("friction_decides: the walk has no friction checks (servo_walk's)")
    made = ~np.isnan(checks[:, 0])
    normal, along = checks[made, 0], checks[made, 1]
    return not np.array_equal(_plane_holds(normal, along, friction), held[made])


def _loop(plan: Plan, model: tuple, both: np.ndarray, gains: tuple, settle: tuple, compiled: bool):
    """``_integrate``'s δ, δ̇, δ̈, request, held, friction checks and finite for ``plan`` from
    where the robot
    settled, the second sole held where ``both``; ``model``: (M, K_g, C, need, τ_ff, the
    held rows of J) along the plan, ``settle``: (the torque at rest, ``settle_feedforward``,
    the limit it is clipped to or None without feed-forward), ``gains`` as ``_integrate``'s."""
    mass, gravity_k, velocity_c, need, tau_ff, jac = model
    k0 = gravity_k[0] + gains[0] * np.eye(plan.q.shape[1])
    rest, settle_feedforward, limit = settle
    d = _settled_offset(rest, k0, jac[0], both[0], settle_feedforward, limit)
    dt = np.diff(plan.t, prepend=plan.t[0])
    args = (mass, gravity_k, velocity_c, need, plan.qd, tau_ff, dt, plan.stance, both, jac)
    solved = _integrate_compiled(*args, gains, d) if compiled else None
    if solved is not None and solved[-1]:
        return solved[:-1]
    # the reference, or a singular system met on the compiled path (kernel.servo)
    jac = support_jacobian(plan)[:, HELD] if both.any() else jac
    return _integrate(*args[:-1], jac, gains, d)


@once_per_plan
def _plan_linearisation(plan: Plan):
    """``_loop_model``'s compiled τ_ref, M, K_g, C and held Jacobian rows at every sample of
    ``plan``; worked out once per plan object (``per_plan``: a sweep's trials of one plan
    at several frictions or actuator modes share it, none of them writes into it)."""
    tau, mass, gravity_k, velocity_c, jac = _linearised_compiled(plan)
    return tau, mass, gravity_k, velocity_c, np.ascontiguousarray(jac[:, HELD])


def _linearised_compiled(plan: Plan, rows: np.ndarray | None = None):
    """``linearised`` and ``support_jacobian`` on the compiled kernel (``kernel.dynamics``),
    at every sample of ``plan`` or at the sample indices ``rows`` only."""
    from slopewalk.planner.kernel import cache, dynamics

    cache.first_use("predictors")
    chain, gravity, side, sole, share = dynamics.plan_inputs(plan)
    take = slice(None) if rows is None else np.asarray(rows, dtype=np.int64)
    side, sole, share = (np.ascontiguousarray(a[take]) for a in (side, sole, share))
    q, qd, qdd = (np.ascontiguousarray(a[take], dtype=float) for a in (plan.q, plan.qd, plan.qdd))
    return dynamics.linearised(chain, gravity, q, qd, qdd, side, sole, share, STEP)


def linearised_at(plan: Plan, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """M [kg m²] and K_g [N m/rad] of ``plan``'s chain at the sample indices ``rows``,
    (len(rows), 8, 8) each: ``linearised``'s at those samples (on the compiled kernel)."""
    _, mass, gravity_k, _, _ = _linearised_compiled(plan, rows)
    return mass, gravity_k


def _integrate_compiled(*args):
    """``_integrate`` on the compiled kernel (``kernel.servo.integrate``)."""
    from slopewalk.planner.kernel import servo

    arrays = [np.ascontiguousarray(a) for a in args[:-2]]
    return servo.integrate(*arrays, args[-2], np.ascontiguousarray(args[-1], dtype=float))


def _integrate(mass, gravity_k, velocity_c, need, qd_ref, tau_ff, dt, stance, both, jac, gains, d):
    """The servo loop's δ, δ̇, δ̈ and request kp (−δ) − kv q̇ + τ_ff through time (module doc).

    Args:
        mass, gravity_k, velocity_c: M, K_g, C along the plan, (n, 8, 8) (``linearised``).
        need: τ_ref + A q̈_ref + d q̇_ref [N m], (n, 8).
        qd_ref: The plan's joint rates [rad/s], (n, 8). tau_ff: Feedforward [N m], (n, 8).
        dt: Time step to each sample [s], (n,) (0 at the first).
        stance: Stance side per sample, (n,). both: The second sole held, (n,) bool.
        jac: Its held rows of the pose Jacobian, (n, 4, 8).
        gains: (kp, kv, damping, armature, τ_max, μ). d: δ at the first sample [rad], (8,).

    Returns:
        δ, δ̇, δ̈, the request (n, 8) each, where the second sole is held on the plane
        (n,) bool, the friction checks of a lifting sole (n, 2): λ_z and |λ_x| [N] where
        ``_trailing`` decided, NaN elsewhere, and False where the loop let go (|δ| ≥ π).
    """
    stiffness, velocity_gain, damping, armature, force_limit, friction = gains
    n, dof = need.shape
    eye = np.eye(dof)
    delta = np.zeros((n, dof))
    rate = np.zeros((n, dof))
    accel = np.zeros((n, dof))
    loop = np.zeros((n, dof))
    held_sole = np.zeros(n, dtype=bool)
    checks = np.full((n, 2), np.nan)
    v = np.zeros(dof)
    finite = True
    trailing = False  # the sole lifting off is still on the plane, loaded
    for k in range(n):
        h = dt[k]
        if k and stance[k] != stance[k - 1]:
            # the legs swap roles: Table-I order reverses (stance roll … ↔ … swing roll)
            d, v = d[::-1].copy(), v[::-1].copy()
        raw = -stiffness * d - velocity_gain * (qd_ref[k] + v) + tau_ff[k]
        free = np.abs(raw) <= force_limit
        held = np.where(free, 0.0, np.clip(raw, -force_limit, force_limit))
        m = mass[k] + armature * eye
        c = velocity_c[k] + (damping + np.where(free, velocity_gain, 0.0)) * eye
        kk = gravity_k[k] + np.where(free, stiffness, 0.0) * eye
        force = held + np.where(free, tau_ff[k] - velocity_gain * qd_ref[k], 0.0) - need[k]
        if trailing and not both[k] and h > 0:
            v, d, a, trailing, normal, along = _trailing(
                m, c, kk, force, d, v, h, jac[k], qd_ref[k], friction
            )
            checks[k] = normal, along
        else:
            hold = both[k] and h > 0
            v, d, a = _backward_euler(m, c, kk, force, d, v, h, jac[k] if hold else None)
            trailing = bool(both[k])
        held_sole[k] = trailing
        if not (np.isfinite(d).all() and np.abs(d).max() < np.pi):
            finite = False  # the loop has let go of the plan: hold the last pose
            delta[k:], rate[k:], accel[k:] = delta[k - 1], 0.0, 0.0
            loop[k:] = loop[k - 1]
            break
        delta[k], rate[k], accel[k] = d, v, a
        loop[k] = raw
    return delta, rate, accel, loop, held_sole, checks, finite
