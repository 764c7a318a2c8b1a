"""The servo loop on a floating base over two unilateral soft soles: the whole-body walk whose
``tip`` the predictor adds (``verdict.predict``'s ``body_tip``; issue 22).

The predictor's servo loop (``servo_loop.py``) bolts the chain to the planned stance
sole and holds the second sole bilaterally; its rocking (``tipping.py``) turns the
robot as one rigid body about the support's edges, on the walk the bolted loop made. What
MuJoCo's robot does that neither can is the two at once: the servos give while the soles
lift, land early or late, bounce the load back onto the old foot and carry a turn through
a landing (results/README.md, stops 33-49). Here the two are one linear system:

    x = (z, roll, pitch of the stance sole about its sole point; δ, the 8 joints' q − q_ref)

linearised about the plan. The whole robot's mass matrix comes from the links' Jacobians
(its joint block is the loop's M, exactly, in single support); the stiffness of the base's
turn is that of gravity and the plan's d'Alembert forces on every link,
Σ m ((g'·r) I − sym(g' rᵀ)), g' = g − a_k, r the link's CoM from the sole point, and its
coupling to the joints −Σ m (∂c/∂q_j × g'); the joint block is the loop's K_g in single
support and the potential's Hessian in double support, where the loop's holds the plan's
split. The ground is the soft floor's 8 sole corners (the simulator's corner
stiffness k_c, damper 2 τ ζ² k_c, τ its contact time and ζ its damping ratio: MuJoCo's
``solref`` gives a contact damping B over stiffness K of 2 d_max τ ζ², so the damper is
that of MuJoCo's contact to d_max's factor, 0.95; ``floor_spring``): a corner pushes
f = f_nom + k_c (−z) − 2 τ ζ² k_c ż where that is positive, none otherwise, z its height
off the plane, f_nom the plan's load on it (each sole's planned normal force spread
bilinearly over its corners at the planned CoP, clamped to the sole: the ground cannot push
beyond it, so a planned ZMP outside the sole leaves its moment unbalanced and the base
turns); and only while its spring is pressed, f_nom + k_c (−z) > 0: MuJoCo's contact
exists only for a geom in the plane, its damper with it. (Until stop 58 the damper pushed
a corner still above the plane that came down fast: at the joint damping's high end a
swing sole lagging 1.6 mm above the plane at its touch-down hovered there on 3-4 N for
0.1 s, on its toe, and the robot tipped in the model only; results/README.md.)
The second sole is held along x by a stiff spring while it carries load (held
along y too, the nominal 2 s ``servo`` walk rolls 9.4° and tips at 1.63 s, where MuJoCo's
rolls 2°: its lateral slide is first order in its roll, the servo loop's doc), in double
support and from the swing's apex on (``Model.held``): a sole that lands early is loaded
more and more, as the double support it lands into holds it. Not while it lifts off: the
plan carries the swing sole on from rest there, and the hold in these coordinates dragged
the unloading trailing sole along with it, however little it carried, where friction
holds it by at most μ times its load; so held, it propped the robot back onto itself for
0.1 s and pitched the stance sole 2-3°, where MuJoCo's trailing foot unloads within 0.04 s
and its stance sole stays flat (results/README.md, stop 56). The servo
is the loop's: kp, kv, damping, armature, its feed-forward and its clip. Backward Euler on
the plan's time base, the corners in contact implicit; at each touch-down the roles swap
and the state is re-expressed about the new stance sole. The time loop runs on the
compiled kernel (``kernel.whole_body``); ``_integrate`` here is its readable twin, held
equal by tests/planner/test_whole_body.py.

``tip_time`` reads the walk as the simulator reads MuJoCo's (``bench/sim/events.py``): the
first time a sole carrying at least ``LOADED_FRACTION`` of the weight is turned past
``TIP_ANGLE``. Measured (results/README.md, stop 49): on the nominal 2 s ``servo`` walk it
rolls the robot 1.9° in the first single support (MuJoCo 2.0°, the rocking alone tips
there) and splits the load 4.24 / 2.33 N at the end of the double support (MuJoCo
4.23 / 2.35). Designed on the design sets, its tip frozen as an added event there before
the reported sets were run once (stop 49); the known faults are in the same section.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from slopewalk.planner.compliance import torque_at_rest
from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.kinematics import GRAVITY, Chain, gravity_in_slope
from slopewalk.planner.per_plan import once_per_plan
from slopewalk.planner.plan import Plan
from slopewalk.planner.servo_loop import _loop_model, _settled_offset
from slopewalk.planner.verdict import LOADED_FRACTION, TIP_ANGLE

BASE = 3  # z, roll, pitch of the stance sole
DOF = BASE + 8
TANGENT_FACTOR = 4.0  # the second sole's hold along the plane, in corner stiffnesses
FALLEN = 0.5  # [rad] the base turned this far: the robot is down, the walk held from there


@dataclass(frozen=True)
class Model:
    """The linear system along a plan, per sample k of n.

    Attributes:
        mass: M [kg, kg m, kg m²], (n, DOF, DOF).
        stiffness: Gravity's and the plan's d'Alembert stiffness [N/m … N m/rad],
            (n, DOF, DOF): base turn, its coupling to the joints, and the joints' Hessian
            (used in double support).
        corner: ∂z/∂x of the 8 sole corners (stance 0-3, second 4-7), (8, DOF, n).
        height: The corners' planned height off the plane [m], (8, n): the swing sole's
            in single support, else 0.
        nominal: Each corner's planned load, clamped to its sole [N], (8, n).
        ideal: The same unclamped (negative where the planned CoP is off the sole), (8, n).
        second_point: ∂p/∂x of the second sole point, (3, DOF, n).
        second_turn: ∂θ/∂x of the second sole, (3, DOF, n).
        held: Where the second sole, loaded, is held along x (module doc), (n,).
    """

    mass: np.ndarray
    stiffness: np.ndarray
    corner: np.ndarray
    height: np.ndarray
    nominal: np.ndarray
    ideal: np.ndarray
    second_point: np.ndarray
    second_turn: np.ndarray
    held: np.ndarray


@dataclass(frozen=True)
class Walk:
    """The model's walk: x (n, DOF), each corner's load [N] (n, 8), each sole's tilt off the
    plane [rad] and load [N] (n,), and the robot's weight [N]."""

    x: np.ndarray
    force: np.ndarray
    stance_tilt: np.ndarray
    second_tilt: np.ndarray
    stance_load: np.ndarray
    second_load: np.ndarray
    weight: float


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b over axis 0 (3, ...)."""
    return np.stack(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


def rotation_stiffness(mass: np.ndarray, arm: np.ndarray, gravity: np.ndarray) -> np.ndarray:
    """∂²V/∂φ² [N m/rad] of point masses turned by φ about the origin, V = −Σ m g'·c:
    Σ m ((g'·r) I − sym(g' rᵀ)), (3, 3, n).

    Args:
        mass: m_k [kg], (K,). arm: r_k, each CoM from the pivot [m], (K, 3, n).
        gravity: g'_k, the acceleration each feels [m/s²], (K, 3, n).
    """
    along = (gravity * arm).sum(axis=1)  # (K, n)
    out = np.empty((3, 3, arm.shape[-1]))
    for a in range(3):
        for b in range(3):
            sym = 0.5 * (gravity[:, a] * arm[:, b] + arm[:, a] * gravity[:, b])
            out[a, b] = (mass[:, None] * ((along if a == b else 0.0) - sym)).sum(axis=0)
    return out


def _com(plan: Plan, chain: Chain, R: np.ndarray, o: np.ndarray) -> np.ndarray:
    """Each link's CoM [m] (9, 3, n) (the chain's side by the stance at each sample)."""
    right = np.asarray(plan.stance).astype(bool)
    arm = np.where(right, chain.com[1][..., None], chain.com[0][..., None])  # (9, 3, n)
    return o[:9] + (R[:9] * arm[:, None]).sum(axis=2)


def _links(plan: Plan, chain: Chain, R: np.ndarray, o: np.ndarray):
    """Each link's CoM [m] (9, 3, n) and inertia about it in S [kg m²] (9, 3, 3, n)."""
    right = np.asarray(plan.stance).astype(bool)
    inertia = np.empty((9, 3, 3, plan.t.size))
    for side, where in ((0, ~right), (1, right)):
        i = np.einsum("kijn,kjl,kmln->kimn", R[:9], chain.inertia[side], R[:9])
        inertia[..., where] = i[..., where]
    return _com(plan, chain, R, o), inertia


def _accelerations(plan: Plan, com: np.ndarray) -> np.ndarray:
    """The links' CoM accelerations [m/s²] (9, 3, n), not differenced across a stance change
    (the chain's links swap places there): the nearest sample of the same stance instead."""
    acc = np.gradient(np.gradient(com, plan.t, axis=2), plan.t, axis=2)
    stance = np.asarray(plan.stance)
    n = stance.size
    near = np.zeros(n, dtype=bool)
    for shift in (1, 2, 3):
        near[shift:] |= stance[shift:] != stance[:-shift]
        near[:-shift] |= stance[:-shift] != stance[shift:]
    for k in np.flatnonzero(near):
        for j in (k - 4, k + 4, k - 5, k + 5):
            if 0 <= j < n and not near[j] and stance[j] == stance[k]:
                acc[..., k] = acc[..., j]
                break
    return acc


def _joints(chain: Chain, R: np.ndarray, o: np.ndarray):
    """Joint i's axis (sign_i z of frame i + 1) and a point on it (o_{i+1}), (8, 3, n) each."""
    axes = np.stack([chain.theta_sign[i] * R[i + 1, :, 2] for i in range(8)])
    return axes, o[1:9]


def _point_jacobian(point: np.ndarray, pivot: np.ndarray, axes, origins, joints) -> np.ndarray:
    """∂p/∂x (3, DOF, n) of ``point`` (3, n), moved by the base about ``pivot`` and by the
    joints in ``joints``."""
    jac = np.zeros((3, DOF, point.shape[-1]))
    r = point - pivot
    jac[2, 0] = 1.0
    jac[1, 1], jac[2, 1] = -r[2], r[1]  # e_x × r
    jac[0, 2], jac[2, 2] = r[2], -r[0]  # e_y × r
    for i in joints:
        jac[:, BASE + i] = _cross(axes[i], point - origins[i])
    return jac


def _heights_jacobian(points: np.ndarray, pivot: np.ndarray, axes, origins) -> np.ndarray:
    """∂z/∂x (8, DOF, n) of the 8 sole corners ``points`` (8, 3, n): the z row of
    ``_point_jacobian`` for all of them at once, the stance sole's (0-3) moved by the base
    alone, the second sole's (4-7) by the joints too (the z of axis_i × (p − o_i))."""
    r = points - pivot[None]
    jac = np.zeros((8, DOF, points.shape[-1]))
    jac[:, 0] = 1.0
    jac[:, 1], jac[:, 2] = r[:, 1], -r[:, 0]  # (e_x × r)_z, (e_y × r)_z
    x, y = points[4:, 0, None], points[4:, 1, None]  # (4, 1, n)
    jac[4:, BASE:] = axes[:, 0] * (y - origins[:, 1]) - axes[:, 1] * (x - origins[:, 0])
    return jac


def _mass_and_stiffness(plan, chain, com, inertia, axes, origins, felt):
    """M (n, DOF, DOF) and the base-turn and joint-Hessian stiffness (n, DOF, DOF); ``felt``
    the acceleration each link feels, g − a [m/s²] (9, 3, n)."""
    n = plan.t.size
    pivot = plan.stance_sole.T
    jv = np.stack([_point_jacobian(com[k], pivot, axes, origins, range(k)) for k in range(9)])
    jw = np.zeros((9, 3, DOF, n))
    jw[:, 0, 1] = jw[:, 1, 2] = 1.0
    for k in range(9):
        for i in range(k):
            jw[k, :, BASE + i] = axes[i]
    m = chain.mass
    # Σ m Jvᵀ Jv + Σ Jωᵀ I Jω, as batched products over the samples (einsum's loops: 5x slower)
    lin = (np.sqrt(m)[:, None, None, None] * jv).reshape(27, DOF, n).transpose(2, 0, 1)
    ang = np.ascontiguousarray(jw.transpose(3, 0, 1, 2))
    spun = (inertia.transpose(3, 0, 1, 2) @ ang).reshape(n, 27, DOF)
    mass = lin.transpose(0, 2, 1) @ lin + ang.reshape(n, 27, DOF).transpose(0, 2, 1) @ spun
    stiffness = np.zeros((n, DOF, DOF))
    turn = rotation_stiffness(m, com - pivot[None], felt)
    stiffness[:, 1:3, 1:3] = turn[:2, :2].transpose(2, 0, 1)
    for j in range(8):
        moment = -(
            m[None, :, None]
            * _cross(jv[:, :, BASE + j].transpose(1, 0, 2), felt.transpose(1, 0, 2))
        ).sum(axis=1)
        stiffness[:, 1:3, BASE + j] = stiffness[:, BASE + j, 1:3] = moment[:2].T
    for i in range(8):
        for j in range(i, 8):
            twice = sum(
                m[k] * (felt[k] * _cross(axes[i], _cross(axes[j], com[k] - origins[j]))).sum(axis=0)
                for k in range(j + 1, 9)
            )
            stiffness[:, BASE + i, BASE + j] = stiffness[:, BASE + j, BASE + i] = -twice
    return mass, stiffness


def _mass_and_stiffness_compiled(plan, chain, R, com, axes, origins, felt):
    """``_mass_and_stiffness`` on the kernel (``kernel.whole_body.mass_and_stiffness``), from
    the links' frames ``R`` (10, 3, 3, n), which it turns their inertia with (numpy's einsum
    for that: 7 ms a walk)."""
    from slopewalk.planner.kernel import whole_body

    return whole_body.mass_and_stiffness(
        np.ascontiguousarray(chain.mass, dtype=float),
        _rows(com),
        _rows(R[:9]),
        np.ascontiguousarray(chain.inertia, dtype=float),
        np.asarray(plan.stance).astype(bool).astype(np.int64),
        *(_rows(a) for a in (axes, origins, plan.stance_sole.T, felt)),
    )


def _corners(plan, R, o, axes, origins):
    """The 8 corners' ∂z/∂x (8, DOF, n) and planned heights (8, n); the second sole point's
    ∂p/∂x and the second sole's ∂θ/∂x (3, DOF, n) each."""
    spec, n = plan.spec, plan.t.size
    heel, toe, half = spec.heel_offset, spec.ankle_to_toe, spec.foot_width / 2
    along = np.array([-heel, toe, toe, -heel])[:, None]
    across = np.array([-half, -half, half, half])[:, None]
    pivot = plan.stance_sole.T
    points = np.zeros((8, 3, n))
    points[:4, 0] = pivot[0] + along
    points[:4, 1] = pivot[1] + spec.sole_shift(plan.stance) + across
    offset = np.zeros((4, 3, n))
    offset[:, 0] = along
    offset[:, 1] = spec.sole_shift(1 - plan.stance) + across
    points[4:] = o[9][None] + np.einsum("ijn,cjn->cin", R[9], offset)
    corner = _heights_jacobian(points, pivot, axes, origins)
    height = np.zeros((8, n))
    height[4:] = np.where(plan.double_support, 0.0, np.maximum(points[4:, 2], 0.0))
    turn = np.zeros((3, DOF, n))
    turn[0, 1] = turn[1, 2] = 1.0
    turn[:, BASE:] = axes.transpose(1, 0, 2)
    return corner, height, _point_jacobian(o[9], pivot, axes, origins, range(8)), turn


def _planned_loads(plan: Plan):
    """Each corner's planned load [N], (8, n): clamped to its sole (nominal) and not (ideal).

    The second sole carries its planned share at its centre; the stance sole the rest at
    the CoP that puts the total at the planned ZMP."""
    spec = plan.spec
    heel, toe, half = spec.heel_offset, spec.ankle_to_toe, spec.foot_width / 2
    total = plan.ground_force[:, 2]
    second = np.where(plan.double_support, plan.swing_force[:, 2], 0.0)
    stance = total - second
    centre = np.stack(
        [
            plan.swing_sole[:, 0] + (toe - heel) / 2,
            plan.swing_sole[:, 1] + spec.sole_shift(1 - plan.stance),
        ]
    )
    loaded = stance > 0
    cop = np.where(
        loaded, (total * plan.zmp.T - second * centre) / np.where(loaded, stance, 1.0), 0.0
    )
    u = (cop[0] - plan.stance_sole[:, 0] + heel) / (heel + toe)
    w = (cop[1] - plan.stance_sole[:, 1] - spec.sole_shift(plan.stance) + half) / (2 * half)

    def spread(u, w):
        return np.stack([(1 - u) * (1 - w), u * (1 - w), u * w, (1 - u) * w]) * np.maximum(
            stance, 0
        )

    ideal, nominal = np.zeros((8, plan.t.size)), np.zeros((8, plan.t.size))
    ideal[:4], nominal[:4] = spread(u, w), spread(np.clip(u, 0, 1), np.clip(w, 0, 1))
    ideal[4:] = nominal[4:] = 0.25 * np.maximum(second, 0.0)
    return nominal, ideal


def _held(plan: Plan) -> np.ndarray:
    """Where a loaded second sole is held along x (module doc), (n,): the double supports,
    and each single support from the swing sole's planned apex (its highest sample) on."""
    held = np.asarray(plan.double_support, dtype=bool).copy()
    single = np.flatnonzero(~held)
    for run in np.split(single, np.flatnonzero(np.diff(single) > 1) + 1):
        if run.size:
            held[run[np.argmax(plan.swing_sole[run, 2]) :]] = True
    return held


def model_of(plan: Plan, *, compiled: bool = True) -> Model:
    """The whole-body system along ``plan`` (module doc); ``compiled``: M and the stiffness
    on the kernel (``kernel.whole_body.mass_and_stiffness``), else their numpy twin."""
    chain = Chain.from_spec(plan.spec)
    R, o = chain.poses(plan.q, plan.stance_sole, plan.stance)
    com = _com(plan, chain, R, o)
    axes, origins = _joints(chain, R, o)
    felt = gravity_in_slope(plan.params.slope)[None, :, None] - _accelerations(plan, com)
    if compiled:
        from slopewalk.planner.kernel import cache

        cache.first_use("predictors")  # the walk's first kernel call
        mass, stiffness = _mass_and_stiffness_compiled(plan, chain, R, com, axes, origins, felt)
    else:
        inertia = _links(plan, chain, R, o)[1]
        mass, stiffness = _mass_and_stiffness(plan, chain, com, inertia, axes, origins, felt)
    corner, height, point, turn = _corners(plan, R, o, axes, origins)
    nominal, ideal = _planned_loads(plan)
    return Model(mass, stiffness, corner, height, nominal, ideal, point, turn, _held(plan))


def _rows(a: np.ndarray) -> np.ndarray:
    """``a`` with its per-sample (last) axis first, contiguous: the kernel's layout."""
    return np.ascontiguousarray(np.moveaxis(a, -1, 0), dtype=float)


@once_per_plan
def _plan_model(plan: Plan) -> Model:
    """``model_of`` on the kernel, once per plan object (``per_plan``: it depends on the plan
    alone, so a sweep's trials of one plan in several actuator modes share it; 14.8 MB for a
    4.4 s walk, let go with the plan)."""
    return model_of(plan)


@dataclass(frozen=True)
class _Loop:
    """The servo loop along the plan, as ``servo_loop`` linearises it (joint rows)."""

    need: np.ndarray  # τ_ref + A q̈_ref + d q̇_ref [N m], (n, 8)
    gravity_k: np.ndarray  # its K_g [N m/rad], (n, 8, 8)
    velocity_c: np.ndarray  # its C [N m s/rad], (n, 8, 8)
    feedforward: np.ndarray  # τ_ff [N m], (n, 8)
    gains: tuple  # kp, kv, damping, armature, τ_max


def floor_spring(
    corner_stiffness: float, contact_time: float, dampratio: float
) -> tuple[float, float]:
    """(k_c [N/m], c [N s/m]): a sole corner's spring and damper on a floor of that corner
    stiffness, contact time τ [s] and damping ratio ζ [-], c = 2 τ ζ² k_c (module doc)."""
    return corner_stiffness, 2 * contact_time * dampratio**2 * corner_stiffness


def walk(
    plan: Plan,
    *,
    stiffness: float,
    velocity_gain: float,
    damping: float,
    armature: float,
    force_limit: float,
    feedforward: np.ndarray | None,
    corner_stiffness: float,
    contact_time: float,
    contact_dampratio: float = 1.0,
    compiled: bool = True,
) -> Walk:
    """The model's walk of ``plan`` played by a servo loop (``servo_loop.servo_walk``'s
    settings) on a soft floor of corner stiffness [N/m], contact time [s] and damping ratio
    [-] (module doc);
    ``compiled``: the model's M and stiffness and the time loop on the kernel
    (``kernel.whole_body``), else their numpy twins (``_integrate`` also where the kernel
    meets a singular system)."""
    for name, value in (
        ("stiffness", stiffness),
        ("force_limit", force_limit),
        ("corner_stiffness", corner_stiffness),
        ("contact_time", contact_time),
        ("contact_dampratio", contact_dampratio),
    ):
        if not (isinstance(value, (int, float, np.number)) and np.isfinite(value) and value > 0):
            raise SlopewalkError(f"whole_body.walk: {name} {value!r}: must be finite and > 0")
    model = _plan_model(plan) if compiled else model_of(plan, compiled=False)
    both = plan.double_support
    tau, _, gravity_k, velocity_c, jac = _loop_model(plan, both, True)
    ff = np.zeros_like(plan.q) if feedforward is None else np.asarray(feedforward, float)
    gains = (stiffness, velocity_gain, damping, armature, force_limit)
    loop = _Loop(tau + armature * plan.qdd + damping * plan.qd, gravity_k, velocity_c, ff, gains)
    rest = gravity_k[0] + stiffness * np.eye(8)
    limit = None if feedforward is None else force_limit
    start = np.zeros(DOF)
    start[BASE:] = _settled_offset(torque_at_rest(plan), rest, jac[0], both[0], None, limit)
    floor = floor_spring(corner_stiffness, contact_time, contact_dampratio)
    solved = _integrate_compiled(plan, model, loop, floor, start) if compiled else None
    states, forces = _integrate(plan, model, loop, floor, start) if solved is None else solved
    turn = np.einsum("ijn,nj->ni", model.second_turn, states)
    return Walk(
        states,
        forces,
        np.hypot(states[:, 1], states[:, 2]),
        np.hypot(turn[:, 0], turn[:, 1]),
        forces[:, :4].sum(axis=1),
        forces[:, 4:].sum(axis=1),
        plan.spec.total_mass * GRAVITY,
    )


def _integrate(plan: Plan, model: Model, loop: _Loop, floor: tuple, start: np.ndarray):
    """The time loop from the settled state ``start`` (module doc): the states (n, DOF) and
    the corners' loads [N] (n, 8); held from where the base turns past 0.5 rad (fallen) or
    leaves the finite numbers."""
    n = plan.t.size
    x, v = start.copy(), np.zeros(DOF)
    states, forces = np.zeros((n, DOF)), np.zeros((n, 8))
    dt = np.diff(plan.t, prepend=plan.t[0])
    anchor = None
    for k in range(n):
        if k and plan.stance[k] != plan.stance[k - 1]:
            x, v, anchor = _swapped(model, k - 1, x), _swapped(model, k - 1, v), None
        if dt[k] > 0:
            x, v, forces[k], anchor = _step(plan, model, loop, floor, k, dt[k], x, v, anchor)
        states[k] = x
        if not (np.isfinite(x).all() and np.abs(x[1:BASE]).max() < FALLEN):
            states[k:], forces[k:] = x, forces[k]
            break
    return states, forces


def _integrate_compiled(plan: Plan, model: Model, loop: _Loop, floor: tuple, start: np.ndarray):
    """``_integrate`` on the compiled kernel (``kernel.whole_body.integrate``); None where it
    met a singular system (``model_of`` has said the kernel's first use)."""
    from slopewalk.planner.kernel import whole_body

    states, forces, regular = whole_body.integrate(
        np.ascontiguousarray(model.mass),
        np.ascontiguousarray(model.stiffness),
        *(_rows(a) for a in (model.corner, model.height, model.nominal, model.ideal)),
        _rows(model.second_point),
        _rows(model.second_turn),
        *(np.ascontiguousarray(a, dtype=float) for a in (loop.need, loop.gravity_k)),
        *(np.ascontiguousarray(a, dtype=float) for a in (loop.velocity_c, loop.feedforward)),
        np.ascontiguousarray(plan.qd, dtype=float),
        np.diff(plan.t, prepend=plan.t[0]),
        np.ascontiguousarray(plan.stance, dtype=np.int64),
        np.ascontiguousarray(plan.double_support, dtype=np.bool_),
        np.ascontiguousarray(model.held, dtype=np.bool_),
        tuple(float(g) for g in loop.gains),
        (float(floor[0]), float(floor[1]), TANGENT_FACTOR),
        FALLEN,
        np.ascontiguousarray(start, dtype=float),
    )
    return (states, forces) if regular else None


def _swapped(model: Model, k: int, y: np.ndarray) -> np.ndarray:
    """State (or rate) ``y`` at sample k re-expressed about the second sole, which becomes
    the stance one: its height and turn become the base's; the joints' Table-I order
    reverses (``servo_loop``)."""
    point = model.second_point[:, :, k] @ y
    turn = model.second_turn[:, :, k] @ y
    return np.concatenate([[point[2], turn[0], turn[1]], y[BASE:][::-1]])


def _step(plan, model: Model, loop: _Loop, floor, k: int, h: float, x, v, anchor):
    """One backward-Euler step at sample k: (x', v', the corners' loads, the second sole's
    anchor along the plane or None)."""
    kp, kv, damping, armature, limit = loop.gains
    k_c, c_c = floor
    raw = -kp * x[BASE:] - kv * (plan.qd[k] + v[BASE:]) + loop.feedforward[k]
    free = np.abs(raw) <= limit
    mass = model.mass[k].copy()
    mass[BASE:, BASE:] += armature * np.eye(8)
    c = np.zeros((DOF, DOF))
    c[BASE:, BASE:] = loop.velocity_c[k] + np.diag(damping + np.where(free, kv, 0.0))
    stiff = model.stiffness[k].copy()
    if not plan.double_support[k]:
        stiff[BASE:, BASE:] = loop.gravity_k[k]  # the loop's exact linearisation
    stiff[BASE:, BASE:] += np.diag(np.where(free, kp, 0.0))
    force = np.zeros(DOF)
    held = np.where(free, 0.0, np.clip(raw, -limit, limit))
    force[BASE:] = held + np.where(free, loop.feedforward[k] - kv * plan.qd[k], 0.0) - loop.need[k]
    jz = model.corner[:, :, k]
    force -= jz.T @ model.ideal[:, k]
    ahead = _pushes(model, k, floor, x + h * v, v)
    on = ahead > 0
    touching = jz[on]
    stiff += k_c * touching.T @ touching
    c += c_c * touching.T @ touching
    force += touching.T @ (model.nominal[on, k] - k_c * model.height[on, k])
    if model.held[k] and ahead[4:][on[4:]].sum() > 0:  # loaded, where held: along x
        along = model.second_point[:1, :, k]
        anchor = along @ x if anchor is None else anchor
        stiff += TANGENT_FACTOR * k_c * along.T @ along
        c += TANGENT_FACTOR * c_c * along.T @ along
        force += along.T @ (TANGENT_FACTOR * k_c * anchor)
    else:
        anchor = None
    a = np.linalg.solve(mass + h * c + h * h * stiff, force - c @ v - stiff @ (x + h * v))
    v = v + h * a
    x = x + h * v
    return x, v, np.where(on, np.maximum(_pushes(model, k, floor, x, v), 0.0), 0.0), anchor


def _pushes(model: Model, k: int, floor: tuple, position: np.ndarray, rate: np.ndarray):
    """What each corner's spring and damper would push at sample k for the state
    ``position`` moving at ``rate`` [N], (8,): f_nom − k_c (height + z) − c_c ż where the
    spring is pressed (f_nom − k_c (height + z) > 0), else the spring's own f_nom − k_c
    (height + z) ≤ 0 (module doc; ≤ 0 where the corner pushes nothing: a corner off the
    plane has no damper either, however fast it comes down)."""
    k_c, c_c = floor
    jz = model.corner[:, :, k]
    spring = model.nominal[:, k] - k_c * (model.height[:, k] + jz @ position)
    return np.where(spring > 0, spring - c_c * (jz @ rate), spring)


def tip_time(plan: Plan, walk: Walk) -> float | None:
    """When a sole carrying ``LOADED_FRACTION`` of the weight first turns past ``TIP_ANGLE``
    [s], as the simulator's ``tip`` (``bench/sim/events.py``); None: never."""
    loaded = LOADED_FRACTION * walk.weight
    tipped = (walk.stance_load > loaded) & (walk.stance_tilt > TIP_ANGLE)
    tipped |= (walk.second_load > loaded) & (walk.second_tilt > TIP_ANGLE)
    hit = np.flatnonzero(tipped)
    return float(plan.t[hit[0]]) if hit.size else None
