"""The floor's give and sink: a sole's 4 corners on MuJoCo's soft contact.

MuJoCo's contacts are soft constraints. A contact of impedance d, reference
time constant τ and damping ratio ζ (``solref``), with d from ``solimp`` at its
penetration r, is solved so that its acceleration obeys

    a + d (b v + k r) = (1 − d) a₀,   b = 2 / (d_max τ),   k = d / (d_max² τ² ζ²)

and its force is f = (a_ref − a₀) / (Â + R), with R = Â (1 − d) / d the solver's
regulariser and Â the contact's approximate inverse mass, the translational
``body_invweight0`` of the foot (the floor, the world, adds none). At rest
(a = v = 0) the force holding a penetration r is

    f(r) = d(r)² r / ((1 − d(r)) Â d_max² τ² ζ²)     [N]   (0 for r ≤ 0)

per contact (``SoftFloor.corner_force``); a box sole on the plane touches at its four
corners. f / r at a uniformly loaded sole's penetration is the corner stiffness k_c: for the
default robot (τ 0.02 s, ζ 1, d 0.9…0.95 over 1 mm, Â 3.6 kg⁻¹) k_c ≈ 6700 N/m
(``tests/sim/test_floor.py`` holds it to the tilt MuJoCo gives a standing robot);
``planner.tipping`` turns it into the floor's give.

A sole loaded by F_n with its CoP p off the centroid m of its corners sinks and turns
(``sole_equilibrium``): the penetration of the corner at (x_i, y_i) from m is
r_i = r₀ − θ_x y_i + θ_y x_i, and (r₀, θ_x, θ_y) solve

    Σ f(r_i) = F_n,   Σ f(r_i) y_i = F_n (p_y − m_y),   Σ f(r_i) x_i = F_n (p_x − m_x)

(Newton's method from the linear solution θ_x = −F_n (p_y − m_y) / (k_c w²),
θ_y = F_n (p_x − m_x) / (k_c l²), w, l the sole's width and length). The linear
solution is not enough in a walk: its CoP sits 80 % of the way to a sole corner late in
each single support, the inner corners carry almost nothing and the softer d there
turns the sole 15 % further (7.75 vs 6.74 mrad of roll at 2 s steps, MuJoCo 7.78),
and the sole point under the ankle sinks 0.10 mm, not the uniform 0.25 mm. The CoP of
a sole's forces cannot leave the sole, so the offset is held a hair (1e-9 of the half
size) inside it: where the plan's split puts a foot's share beyond its edge, that foot
stands on the edge, its far corners just touching.

The give fed forward (``give_feedforward``, played by the "_ff" actuator modes): unless
the ankle turns the other way, the whole robot above the sole turns with it: the
stance foot's give of 0.3–0.45° in a slow walk tilts the robot towards the swing foot,
whose sole, ~0.1 m away, meets the plane ~1 mm early (~50 ms before the planned
touch-down), takes half the weight at once and throws the CoP ~40 mm off the planned
ZMP. Turning each ankle by its foot's give (roll by θ_x, pitch by θ_y / cos(roll), the
pitch axis sitting on the rolled ankle) keeps the legs, the body and the swing foot
where the plan has them. The sink left (the robot stands lower by the stance sole's
sink under its ankle) is ``slopewalk.bench.sim.touchdown``'s.

Each foot's load and CoP come from the plan: in single support the stance foot
carries the whole ground force at the ZMP; in double support each foot carries
the plan's share F_i (``planner.plan``'s load split) at p_i = m_i + (p − m̄), with
m̄ = Σ F_i m_i / Σ F_i: the shares' moments add up to the planned ZMP's, and p_i
is the ZMP itself when a foot carries everything, so the hand-over from foot to
foot adds no jump (the give jumps only where the planned ZMP does: at the phase
changes, where the lean's acceleration steps). First order: the sole turns about
its corners' centroid, the ankle about its axis an ankle height above it (a 0.25 mm
horizontal shift at 7.8 mrad for the default robot).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from slopewalk.bench.sim.contact import FOOT_GEOMS
from slopewalk.planner.joints import LEFT
from slopewalk.planner.kinematics import GRAVITY


def impedance(r, solimp) -> tuple[np.ndarray, np.ndarray]:
    """MuJoCo's impedance d at penetration ``r`` [m] (scalar or array) for ``solimp``
    (d0, d_width, width, mid, p), and its slope dd/dr [1/m] (0 outside the width)."""
    d0, dmax, width, mid, power = (float(v) for v in solimp[:5])
    r = np.asarray(r, dtype=float)
    if width <= 0:
        return np.full(r.shape, dmax), np.zeros(r.shape)
    x = np.clip(r / width, 0.0, 1.0)
    low = x <= mid
    with np.errstate(divide="ignore", invalid="ignore"):
        y = np.where(
            low,
            x**power / mid ** (power - 1) if mid > 0 else 1.0,
            1 - (1 - x) ** power / (1 - mid) ** (power - 1),
        )
        dy = np.where(
            low,
            power * x ** (power - 1) / mid ** (power - 1) if mid > 0 else 0.0,
            power * (1 - x) ** (power - 1) / (1 - mid) ** (power - 1),
        )
    slope = np.where((r > 0) & (r < width), (dmax - d0) * dy / width, 0.0)
    return d0 + y * (dmax - d0), slope


@dataclass(frozen=True)
class SoftFloor:
    """The foot-floor contact's constants, read from a compiled scene (module doc).

    Attributes:
        timeconst: ``solref`` time constant τ [s].
        dampratio: ``solref`` damping ratio ζ [-].
        solimp: (d0, d_max, width [m], midpoint, power) of the impedance.
        inverse_mass: Â, the foot's translational ``body_invweight0`` [1/kg].
        corners: Each sole's (left, right) contact corners (x, y) in the sole's axes from
            the centre of the spec's sole rectangle [m], (2, k, 2); None: that rectangle's
            4 corners (the twin's box sole). An imported model's sole of several boxes
            touches at all their corners (``robot_import.scene.ModelScene.floor``).
    """

    timeconst: float
    dampratio: float
    solimp: tuple[float, float, float, float, float]
    inverse_mass: float
    corners: tuple | None = None

    @classmethod
    def of_scene(cls, model: mujoco.MjModel) -> SoftFloor:
        """The constants of a compiled scene's foot contacts: the floor's ``solref`` and
        ``solimp`` (its ``priority`` 1 makes them the contact's, ``model.py``; the spec's
        ``[contact]``), the left foot's inverse mass."""
        floor = model.geom("floor").id
        timeconst, dampratio = (float(v) for v in model.geom_solref[floor])
        d0, d_max, width, midpoint, power = (float(v) for v in model.geom_solimp[floor][:5])
        solimp = (d0, d_max, width, midpoint, power)
        foot = model.geom(FOOT_GEOMS[0])
        inverse_mass = float(model.body_invweight0[model.geom_bodyid[foot.id], 0])
        return cls(timeconst, dampratio, solimp, inverse_mass)

    @property
    def scale(self) -> float:
        """1 / (Â d_max² τ² ζ²) [N/m]: f(r) = scale · d² r / (1 − d) (module doc)."""
        dmax = self.solimp[1]
        return 1.0 / (self.inverse_mass * dmax**2 * self.timeconst**2 * self.dampratio**2)

    def corner_force(self, r) -> tuple[np.ndarray, np.ndarray]:
        """Static force f(r) [N] of one corner at penetration ``r`` [m] and df/dr [N/m]."""
        r = np.asarray(r, dtype=float)
        d, dd = impedance(r, self.solimp)
        pressed = r > 0
        force = np.where(pressed, self.scale * d**2 * r / (1 - d), 0.0)
        slope = self.scale * ((2 * d * dd * r + d**2) * (1 - d) + d**2 * r * dd) / (1 - d) ** 2
        return force, np.where(pressed, slope, 0.0)


def corner_stiffness(model: mujoco.MjModel, weight: float) -> float:
    """k_c [N/m] of one sole corner of the compiled scene, loaded by a quarter of ``weight`` [N].

    f / r at the corner's static penetration (a fixed point: the penetration sets d, d
    the stiffness), with ``SoftFloor.of_scene``'s constants.
    """
    floor = SoftFloor.of_scene(model)
    r, stiffness = 0.0, 0.0
    for _ in range(20):
        d = float(impedance(r, floor.solimp)[0])
        stiffness = floor.scale * d**2 / (1 - d)
        r_next = weight / 4 / stiffness
        if abs(r_next - r) < 1e-9:
            break
        r = r_next
    return float(stiffness)


def scene_corner_stiffness(model: mujoco.MjModel) -> float:
    """``corner_stiffness`` of a compiled scene under the robot's own weight."""
    mass = float(np.sum(model.body_mass))
    return corner_stiffness(model, mass * GRAVITY)


def sole_equilibrium(
    floor: SoftFloor,
    load,
    offset,
    *,
    length: float,
    width: float,
    corners=None,
    iterations: int = 50,
) -> np.ndarray:
    """(r₀ [m], θ_x [rad], θ_y [rad]) of soles at rest on their corners, (n, 3) (module doc).

    Args:
        load: Normal load F_n of each sole [N], (n,); ≤ 0: in the air, all zero.
        offset: Its CoP from the centre of the sole rectangle, (x, y) in the sole's axes
            [m], (n, 2); held a hair inside the rectangle.
        length, width: The sole's size l, w [m].
        corners: The contact corners (x, y) from that centre [m], (k, 2); None: the
            rectangle's 4 corners. r₀ is the penetration at the centre.
    """
    load = np.asarray(load, dtype=float)
    half = np.array([length, width]) / 2 * (1 - 1e-9)
    offset = np.clip(np.asarray(offset, dtype=float), -half, half)
    if corners is None:
        corners = np.column_stack([[1, 1, -1, -1], [1, -1, 1, -1]]) * half / (1 - 1e-9)
    x, y = np.asarray(corners, dtype=float).T
    moments = np.stack([np.ones(x.size), y, x])  # (3, k): Σf, Σf y, Σf x of the corner forces
    turns = np.stack([np.ones(x.size), -y, x], axis=1)  # (k, 3): ∂r_i / ∂(r₀, θ_x, θ_y)
    target = load[:, None] * np.column_stack([np.ones_like(load), offset[:, 1], offset[:, 0]])
    loaded = load > 0
    k = floor.corner_force(2.5e-4)[0] / 2.5e-4  # a linear start, at a typical penetration
    u = np.linalg.solve(k * moments @ turns, target.T).T
    u[~loaded] = 0.0
    for _ in range(iterations):
        force, slope = floor.corner_force(u @ turns.T)  # (n, k) each
        residual = force @ moments.T - target
        if not np.any(np.abs(residual[loaded]) > 1e-12 * np.maximum(load[loaded, None], 1.0)):
            break
        jacobian = np.einsum("ki,ni,ij->nkj", moments, slope, turns)
        jacobian[~loaded] = np.eye(3)
        residual[~loaded] = 0.0
        u = u - np.linalg.solve(jacobian, residual[..., None])[..., 0]
    return u


def foot_loads(plan) -> tuple[np.ndarray, np.ndarray]:
    """Each foot's (left, right) sole point [m], (n, 2, 2), and planned normal load [N], (n, 2).

    The stance foot carries ``plan.stance_force``, the other foot ``plan.swing_force``
    in double support and nothing in single support (``planner.plan``'s load split).
    """
    left = (plan.stance == LEFT)[:, None]
    sole = np.stack(
        [
            np.where(left, plan.stance_sole[:, :2], plan.swing_sole[:, :2]),
            np.where(left, plan.swing_sole[:, :2], plan.stance_sole[:, :2]),
        ],
        axis=1,
    )
    stance = np.maximum(plan.stance_force[:, 2], 0.0)
    other = np.where(plan.double_support, np.maximum(plan.swing_force[:, 2], 0.0), 0.0)
    load = np.column_stack(
        [np.where(left[:, 0], stance, other), np.where(left[:, 0], other, stance)]
    )
    return sole, load


def foot_deflection(plan, floor: SoftFloor) -> tuple[np.ndarray, np.ndarray]:
    """Planned turn and sink of each sole (left, right) on the soft floor, on ``plan.t``.

    Returns:
        (θ_x, θ_y) about x_S and y_S [rad], (n, 2, 2), and the sink of the sole point
        under the ankle along −z_S [m], (n, 2) (``sole_equilibrium`` under each foot's
        planned load and CoP, module doc); zero for a foot in the air.
    """
    spec = plan.spec
    sole, load = foot_loads(plan)
    ahead = (spec.ankle_to_toe - spec.heel_offset) / 2  # the centroid ahead of the sole point
    beside = spec.sole_shift(np.array([LEFT, 1 - LEFT]))  # each centroid outward of its point
    centroid = sole + np.stack([np.full(2, ahead), beside], axis=1)
    total = load.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.einsum("nf,nfi->ni", load, centroid) / total[:, None]
    offset = np.where(total[:, None] > 0, plan.zmp - mean, 0.0)  # p_i − m_i, the same for both
    turn = np.zeros((plan.t.size, 2, 2))
    sink = np.zeros((plan.t.size, 2))
    for foot in (0, 1):
        r0, theta_x, theta_y = sole_equilibrium(
            floor, load[:, foot], offset, length=spec.foot_length, width=spec.foot_width,
            corners=None if floor.corners is None else floor.corners[foot],
        ).T  # fmt: skip
        turn[:, foot] = np.column_stack([theta_x, theta_y])
        # the sole point sits `ahead` behind the centroid and `beside` inward of it
        sink[:, foot] = r0 - theta_y * ahead + theta_x * beside[foot]
    return turn, sink


def give_feedforward(plan, turn: np.ndarray) -> np.ndarray:
    """Ankle turns that cancel each sole's give, MJCF joint order [rad], (n, 8) on ``plan.t``.

    Ankle roll by θ_x and ankle pitch by θ_y / cos(roll) of ``turn`` (``foot_deflection``'s
    (n, 2, 2), module doc); the hips and knees are left as planned.
    """
    roll = plan.q_left_right[:, [3, 7]]  # (n, 2) ankle rolls, left and right
    out = np.zeros((plan.t.size, 8))
    out[:, [2, 6]] = turn[..., 1] / np.cos(roll)
    out[:, [3, 7]] = turn[..., 0]
    return out
