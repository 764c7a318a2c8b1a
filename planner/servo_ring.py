"""The servo loop's ring outlasting a step: a landing that finds the robot still ringing.

A position loop without feed-forward (the ``servo`` mode) holds every load on its
spring: where the load moves from leg to leg in one go (a touchdown, a lift-off) the
joints' deflection jumps by Δτ / kp, and the loaded chain rings. Its free motion is the
servo loop's joint equation (``servo_loop``) without the walk's drive,

    (M + A) δ̈ + D δ̇ + (K_g + kp) δ = 0,        D = d + kv,

with M, K_g the chain's mass matrix and gravity stiffness about the planned pose
(rooted at the stance sole), A the rotor inertia, d the joints' damping and kv the
velocity gain (on the joint speed, so it damps the same way). Each of its modes decays
as exp(−σ t); the slowest, σ = −max Re λ over the eigenvalues λ of the first-order
system (``slowest_decay``), outlasts the others, and the ring has decayed by
``RING_DECAYS`` of its time constants after

    t_settle = RING_DECAYS / σ.

For the joint alone (M = K_g = 0, underdamped) σ = D / (2 A): the AX-12A's 5.2 /s.
With the links on it the modes carry the links' inertia too and decay more slowly:
on the design sets' GA gaits, just before a landing, the slowest mode rings at about
2.2–2.5 Hz (MuJoCo's joints: 2.3–2.8 Hz, ``servo_loop``) and decays at 2.6–3.5 /s.

``servo_loop`` integrates that ring at the joints, but with the stance sole bolted
to the plane and every landing plastic, so it does not see what the ring does to the
robot standing on its soles: measured in MuJoCo (results/README.md, stop 35), the
robot lands hard on the ringing leg, bounces back onto the old stance foot and falls.
So a landing that comes less than t_settle after the one before it is predicted
``ring`` (``unsettled_landing``), t_settle taken at the pose just before that landing
(single support, the chain about to land).

Measured on the design sets only (results/README.md, stops 37 and 38): MuJoCo's
boundary between walking and falling in ``servo`` lies at a fixed number of decays of
the loaded chain's slowest mode, not of the joint's own: 33 GA gaits of the design
envelopes (``ga-dev``, ``ga-dev2``) re-timed to 2.5–4.5 time constants of the joint
alone, with the armature ×0.75, ×1, ×1.5 and ×2, walk where T σ ≳ 1.8 at every
armature (the lowest T σ of a walker 1.71–1.82), while their boundary in the joint's
own time constants moves from about 4.1 (×0.75) to below 2.5 (×2). ``RING_DECAYS`` =
1.8 agrees with MuJoCo on 505 of the 573 trials no other predicted event decides
(1.6: 467, 2.0: 476; 3 of the joint's own time constants, stop 37's check: 381).

With feed-forward (``servo_ff``) the loop is fed the planned torque, load jumps
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

RING_DECAYS = 1.8  # time constants of the loaded chain's slowest mode (module doc)


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


def slowest_decay(mass: np.ndarray, gravity_k: np.ndarray, loop: RingLoop) -> float:
    """σ [1/s] of the slowest mode of (M + A) δ̈ + D δ̇ + (K_g + kp) δ = 0 (module doc):
    −max Re λ of its first-order system. ≤ 0 where the loop does not bring the chain back
    (no damping, or a pose the spring cannot hold against gravity).

    Args:
        mass: M [kg m²], (n, n), the chain's mass matrix.
        gravity_k: K_g [N m/rad], (n, n), ∂τ/∂q of the chain.
        loop: The servo loop.
    """
    n = mass.shape[0]
    eye = np.eye(n)
    inertia = mass + loop.armature * eye
    if not np.all(np.isfinite(inertia)) or abs(np.linalg.det(inertia)) < 1e-300:
        # a singular M + A (a joint with no inertia at all) or a non-finite one: no ring
        # mode to measure, σ 0 (settle_times: 0 s for a massless loop, inf otherwise)
        return 0.0
    spring = np.linalg.solve(inertia, gravity_k + loop.stiffness * eye)
    drag = np.linalg.solve(inertia, loop.damping * eye)
    state = np.block([[np.zeros((n, n)), eye], [-spring, -drag]])
    return float(-np.linalg.eigvals(state).real.max())


def landing_rows(plan) -> np.ndarray:
    """The sample before each touch-down of ``plan`` (``trajectory.Timeline.touch_downs``),
    shape (N,): the chain about to land, where ``settle_times`` takes its matrices."""
    return np.maximum(Timeline.of(plan.params).touch_downs - 1, 0)


def settle_times(mass: np.ndarray, gravity_k: np.ndarray, loop: RingLoop) -> np.ndarray:
    """t_settle [s] of the chain at each of a walk's landings, shape (N,): ``RING_DECAYS``
    / σ (``slowest_decay``); inf where σ ≤ 0, 0 where the loop has no inertia to ring
    (A = 0 and a massless chain).

    Args:
        mass: M [kg m²] at the samples ``landing_rows`` gives, (N, n, n)
            (``servo_loop.linearised_at``).
        gravity_k: K_g [N m/rad] at the same samples, (N, n, n).
        loop: The servo loop.
    """
    settle = np.empty(mass.shape[0])
    for k in range(mass.shape[0]):
        sigma = slowest_decay(mass[k], gravity_k[k], loop)
        massless = loop.armature == 0 and not np.any(mass[k])
        settle[k] = 0.0 if massless else (RING_DECAYS / sigma if sigma > 0 else np.inf)
    return settle


def unsettled_landing(plan, settle: np.ndarray) -> tuple[int, float] | None:
    """(sample index, t_settle [s]) of the first touch-down of ``plan`` that comes less
    than its t_settle after the one before it, or None; ``settle``: t_settle [s] at each
    touch-down, (N,) (``settle_times``)."""
    downs = Timeline.of(plan.params).touch_downs
    early = np.flatnonzero(np.diff(plan.t[downs]) < np.asarray(settle, dtype=float)[1:])
    if early.size == 0:
        return None
    k = early[0] + 1
    return int(downs[k]), float(settle[k])
