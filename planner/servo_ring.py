"""The servo loop's ring outlasting a step: a landing that finds the robot still ringing.

A position loop without feed-forward (the ``servo`` mode) holds every load on its
spring: where the load moves from leg to leg (each double support hands the weight to
the leg that has just landed) the joints' deflection moves by Δτ / kp, and the loaded
chain rings. Its free motion is the servo loop's joint equation (``servo_loop``) without
the walk's drive,

    (M + A) δ̈ + D δ̇ + (K_g + kp) δ = 0,        D = d + kv,

with M, K_g the chain's mass matrix and gravity stiffness about the planned pose
(rooted at the stance sole), A the rotor inertia, d the joints' damping and kv the
velocity gain (on the joint speed, so it damps the same way). Its modes go as e^{λt};
the slowest, λ the eigenvalue of the first-order system with the largest real part
(``slowest_mode``; σ = −Re λ, ``slowest_decay``), outlasts the others. For the joint
alone (M = K_g = 0, underdamped) σ = D / (2 A): the AX-12A's 5.2 /s. With the links on
it the modes carry the links' inertia too: on the design sets' GA gaits, just before a
landing, the slowest mode rings at about 1.8-2.6 Hz (MuJoCo's joints: 2.3-2.8 Hz,
``servo_loop``) and decays at 1.4-6.7 /s over the joint damping's range.

The plan hands the load over in the double support that follows a touch-down, along
the stance share's cubic s(u) = 3u² − 2u³, u = t / t_d over the double support's t_d
(``reference._stance_share``). Driven by that transfer, the mode is left ringing, when
it ends, with the share

    r = |∫₀¹ s'(u) e^{a(1−u)} du| = |6 (e^a (a − 2) + a + 2) / a³|,   a = λ t_d,

of the ring a sudden load step would have started (1 as t_d → 0; small where the
transfer takes several of the ring's periods), and that decays as e^{Re λ (T − t_d)}
until the next touch-down, T after the last (``transfer_residual``). So the next landing
finds the robot still ringing with

    R = r e^{Re λ (T − t_d)}

of the load step's ring (``landing_residuals``), λ taken at the pose just before that
landing (single support, the chain about to land). Where R passes ``RING_RESIDUAL`` the
landing is predicted ``ring`` (``unsettled_landing``): ``servo_loop`` integrates that
ring at the joints, but with the stance sole bolted to the plane and every landing
plastic, so it does not see what the ring does to the robot standing on its soles:
measured in MuJoCo (results/README.md, stop 35), the robot lands hard on the ringing leg,
bounces back onto the old stance foot and falls.

Measured on the design sets' gaits only (results/README.md, stops 37, 38 and 57): 33 GA
gaits of the design envelopes (``ga-dev``, ``ga-dev2``) re-timed to 0.5-1.4 s and played
in MuJoCo with the armature ×0.75, ×1.5 and ×2, the joint damping at 0.12, 0.243 and
0.56 N m s/rad, kp ×0.7 and ×1.3, the contact's damping ratio and the joints' dry
friction at their ends (3234 trials). MuJoCo's boundary between walking and falling
follows the armature as the ring's decay does, but the damping much less: at d = 0.12
the gaits walk from about 0.75 s, at 0.243 from 0.67 s, at 0.56 from 0.5 s or faster. The
decay alone (stop 38: a landing less than 1.8 time constants 1/σ after the last, the
transfer's shape left out) put that boundary at 1.26, 0.62 and 0.27 s; R at
``RING_RESIDUAL`` = 0.155 puts it at about 0.9, 0.65 and under 0.5 s (still late at the
damping's low end) and where MuJoCo's is at every armature, and decides those trials as
MuJoCo does in 2927 of 3234 (the decay count: 2856; no check at all: 2802), the design
sets' ``servo`` trials in 2172 of 2492 (the decay count: 2152). Not explained: a softer
loop (kp ×0.7) walks faster steps than either says, its ring larger and slower (R decides
178 of its 231 trials as MuJoCo does, the decay count 193).

With feed-forward (``servo_ff``) the loop is fed the planned torque, load transfer
included, and its spring takes only what the plan gets wrong: no ring of that size
(stop 37's design sets: 38 of 72 ``servo_ff`` gaits with T < 0.57 s walk). So the check
is made for a loop without feed-forward only (``bench/sim/prediction.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.trajectory import Timeline

RING_RESIDUAL = 0.155  # [-] share of a load step's ring a landing may find left (module doc)


@dataclass(frozen=True)
class RingLoop:
    """The servo loop whose ring the check follows (module doc).

    Attributes:
        armature: Rotor inertia A per joint [kg m²], ≥ 0.
        damping: Joint damping + velocity gain D [N m s/rad], ≥ 0.
        stiffness: kp [N m/rad], ≥ 0.
    """

    armature: float
    damping: float
    stiffness: float

    def __post_init__(self) -> None:
        for name, unit in (
            ("armature", "kg m^2"),
            ("damping", "N m s/rad"),
            ("stiffness", "N m/rad"),
        ):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise SlopewalkError(f"{name} {value!r} {unit}: must be a finite number >= 0")


def slowest_mode(mass: np.ndarray, gravity_k: np.ndarray, loop: RingLoop) -> complex:
    """λ [1/s] of the slowest mode of (M + A) δ̈ + D δ̇ + (K_g + kp) δ = 0 (module doc): the
    eigenvalue of its first-order system with the largest real part, Im λ ≥ 0. Re λ ≥ 0
    where the loop does not bring the chain back (no damping, or a pose the spring cannot
    hold against gravity); 0 where M + A is singular or not finite (no mode to measure).

    Args:
        mass: M [kg m²], (n, n), the chain's mass matrix.
        gravity_k: K_g [N m/rad], (n, n), ∂τ/∂q of the chain.
        loop: The servo loop.
    """
    n = mass.shape[0]
    eye = np.eye(n)
    inertia = mass + loop.armature * eye
    if not np.all(np.isfinite(inertia)) or abs(np.linalg.det(inertia)) < 1e-300:
        return 0j
    spring = np.linalg.solve(inertia, gravity_k + loop.stiffness * eye)
    drag = np.linalg.solve(inertia, loop.damping * eye)
    state = np.block([[np.zeros((n, n)), eye], [-spring, -drag]])
    roots = np.linalg.eigvals(state)
    slowest = roots[np.argmax(roots.real)]
    return complex(slowest.real, abs(slowest.imag))


def slowest_decay(mass: np.ndarray, gravity_k: np.ndarray, loop: RingLoop) -> float:
    """σ = −Re λ [1/s] of ``slowest_mode``: ≤ 0 where the loop does not bring the chain
    back, 0 where M + A is singular (arguments as ``slowest_mode``'s)."""
    return float(-slowest_mode(mass, gravity_k, loop).real)


def transfer_residual(mode: complex, transfer: float, interval: float) -> float:
    """R [-]: the share of a sudden load step's ring that mode λ [1/s] still rings with
    ``interval`` [s] after a load transfer began that followed the plan's cubic over
    ``transfer`` [s] (module doc): |6 (e^a (a − 2) + a + 2) / a³| e^{Re λ (interval −
    transfer)}, a = λ · transfer (1 + a/2 for |a| < 1e-3, where the closed form cancels).
    """
    a = complex(mode) * transfer
    if abs(a) < 1e-3:
        left = abs(1 + a / 2)
    else:
        left = abs(6 * (np.exp(a) * (a - 2) + a + 2) / a**3)
    return float(left * np.exp(complex(mode).real * (interval - transfer)))


def landing_rows(plan) -> np.ndarray:
    """The sample before each touch-down of ``plan`` (``trajectory.Timeline.touch_downs``),
    shape (N,): the chain about to land, where ``landing_residuals`` takes its matrices."""
    return np.maximum(Timeline.of(plan.params).touch_downs - 1, 0)


def landing_residuals(plan, mass: np.ndarray, gravity_k: np.ndarray, loop: RingLoop) -> np.ndarray:
    """R [-] at each touch-down k = 0..N-1 of ``plan``, shape (N,): the share of a load
    step's ring the transfer after touch-down k − 1 leaves at touch-down k
    (``transfer_residual``, λ from the chain just before touch-down k); 0 at the first
    (no landing before it) and wherever the loop has no inertia to ring (A = 0 and a
    massless chain).

    Args:
        plan: The walk (its touch-downs and its double support's duration).
        mass: M [kg m²] at the samples ``landing_rows`` gives, (N, n, n)
            (``servo_loop.linearised_at``).
        gravity_k: K_g [N m/rad] at the same samples, (N, n, n).
        loop: The servo loop.
    """
    timeline = Timeline.of(plan.params)
    downs = plan.t[timeline.touch_downs]
    left = np.zeros(mass.shape[0])
    for k in range(1, mass.shape[0]):
        if loop.armature == 0 and not np.any(mass[k]):
            continue
        mode = slowest_mode(mass[k], gravity_k[k], loop)
        left[k] = transfer_residual(mode, timeline.dsp_time, downs[k] - downs[k - 1])
    return left


def unsettled_landing(plan, residual: np.ndarray) -> tuple[int, float] | None:
    """(sample index, R) of the first touch-down of ``plan`` that finds more than
    ``RING_RESIDUAL`` of a load step's ring left, or None; ``residual``: R at each
    touch-down, (N,) (``landing_residuals``)."""
    downs = Timeline.of(plan.params).touch_downs
    ringing = np.flatnonzero(np.asarray(residual, dtype=float) > RING_RESIDUAL)
    if ringing.size == 0:
        return None
    k = ringing[0]
    return int(downs[k]), float(residual[k])
