"""DH forward kinematics of the stance-foot-to-swing-foot chain (Table I, eq. 1-2).

Frames follow Craig's modified DH convention, which is the matrix of eq. (1):
``T(i-1 → i) = RotX(α_{i-1}) · TransX(a_{i-1}) · RotZ(θ_i) · TransZ(d_i)``.

The table keeps the structure of the paper's Table I (the same a, α, d pattern:
two ankle axes, shank ``l``, thigh ``l``, a hip offset ``d = Lh`` along the hip
axis, thigh, shank, two ankle axes). The paper prints only the symbols; the
constant offsets and signs here are derived so that ``q = 0`` is the robot
standing straight and each ``q`` is the MJCF joint angle (see ``joints.py``):

    row  a_{i-1}  α_{i-1}  d_i       θ_i          joint
    1    0        0        0         −q1          stance ankle roll  (axis +x_S at q=0)
    2    0        −π/2     0          q2          stance ankle pitch (axis −y_S)
    3    shank    0        0          q3          stance knee
    4    thigh    0        0          q4          stance hip pitch
    5    0        0        σ·Lh      π − q5       swing hip pitch (σ = +1: stance left)
    6    thigh    0        0         −q6          swing knee
    7    shank    0        0         −q7          swing ankle pitch
    8    0        π/2      0         −q8          swing ankle roll (axis −x_S)

(The paper's "−(π/2 + θ5)" and "−θ6" in rows 5-6 are the same idea with its own
frame choice: the swing leg is walked down, so its angles enter with a minus sign.)

Real legs put the knee axis a distance k ahead of (k > 0) or behind the hip–ankle line
(``RobotSpec.knee_offset``). Each row then carries one more constant, b_{i-1}, a shift
along the twisted y axis: ``T = RotX(α) · Trans(a, b, d) · RotZ(θ)``. Rows 3, 4, 6, 7
have b = −k, +k, +k, −k (the twisted y of rows 3-4 is −x_S at q = 0, of rows 6-7 +x_S),
every other row b = 0; with k = 0 the table is eq. (1) exactly, the frames stay
axis-aligned at q = 0 and a link's inertia stays diagonal in its DH axes.

Frame 0 sits at the stance ankle centre with x0 = z_S (up), y0 = −y_S, z0 = x_S.
Everything is expressed in the slope frame S (x up the slope, y left, z the plane
normal; the stance foot lies flat on the plane). ``slope_to_world`` is eq. (2)'s
rotation: S is the world frame turned about its y axis by −θs.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Generic, TypeVar

import numpy as np

from slopewalk.planner.joints import LEFT
from slopewalk.planner.spec import RobotSpec

N_JOINTS = 8
# Link attached to each DH frame 0..8 (frame 0 is the stance foot, fixed to the plane).
CHAIN_LINKS = (
    ("stance", "foot"),
    ("stance", "ankle"),
    ("stance", "shank"),
    ("stance", "thigh"),
    ("pelvis", "pelvis"),
    ("swing", "thigh"),
    ("swing", "shank"),
    ("swing", "ankle"),
    ("swing", "foot"),
)
# Orientation of frame 0 in S: columns x0 = z_S, y0 = −y_S, z0 = x_S.
ROTATION_FRAME0_IN_SLOPE = np.array([[0.0, 0.0, 1.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0]])
# Orientation of the swing sole frame (S-aligned when the foot is flat) in DH frame 8.
ROTATION_SOLE_IN_FRAME8 = np.array([[0.0, 0.0, -1.0], [0.0, -1.0, 0.0], [-1.0, 0.0, 0.0]])


def dh_transform(a, alpha, d, theta, b=0.0) -> np.ndarray:
    """Homogeneous transform of eq. (1) (Craig's modified DH), vectorised.

    Args:
        a: Link length a_{i-1} [m], any shape (broadcast together).
        alpha: Link twist α_{i-1} [rad].
        d: Link offset d_i [m].
        theta: Joint angle θ_i [rad].
        b: Shift along the twisted y axis [m] (the knee offset, module doc); 0 is eq. (1).

    Returns:
        T of frame i in frame i-1, shape (*broadcast, 4, 4).
    """
    a, alpha, d, theta, b = np.broadcast_arrays(
        *(np.asarray(x, dtype=float) for x in (a, alpha, d, theta, b))
    )
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    T = np.zeros(a.shape + (4, 4))
    T[..., 0, 0], T[..., 0, 1], T[..., 0, 3] = ct, -st, a
    T[..., 1, 0], T[..., 1, 1], T[..., 1, 2] = st * ca, ct * ca, -sa
    T[..., 2, 0], T[..., 2, 1], T[..., 2, 2] = st * sa, ct * sa, ca
    T[..., 1, 3], T[..., 2, 3] = ca * b - sa * d, sa * b + ca * d
    T[..., 3, 3] = 1.0
    return T


def rotation_slope_to_world(slope: float) -> np.ndarray:
    """Rotation taking S-coordinates to world coordinates, shape (3, 3).

    Args:
        slope: Inclination θs [rad]; positive walks uphill along +x_S.
    """
    c, s = np.cos(slope), np.sin(slope)
    return np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])


GRAVITY = 9.81  # [m/s²]: g, the one value of the planner, the bench and MuJoCo's default


def gravity_in_slope(slope: float, g: float = GRAVITY) -> np.ndarray:
    """Gravity vector in S [m/s²], shape (3,): (−g sin θs, 0, −g cos θs)."""
    return rotation_slope_to_world(slope).T @ np.array([0.0, 0.0, -g])


_Built = TypeVar("_Built")


class SpecMemo(Generic[_Built]):
    """What was built from each of the last few specs, by the spec's identity (a RobotSpec
    is frozen; what is kept must only be read): ``Chain.from_spec``'s and
    ``kernel.tables.ChainTable.of``'s memory."""

    def __init__(self, size: int = 8):
        self._kept: dict[int, tuple[RobotSpec, _Built]] = {}
        self._size = size

    def get(self, spec: RobotSpec, build: Callable[[RobotSpec], _Built]) -> _Built:
        """``build(spec)``, or what it gave for this very spec before."""
        hit = self._kept.get(id(spec))
        if hit is not None and hit[0] is spec:
            return hit[1]
        built = build(spec)
        if len(self._kept) >= self._size:
            self._kept.pop(next(iter(self._kept)))
        self._kept[id(spec)] = (spec, built)
        return built


_CHAINS: SpecMemo[Chain] = SpecMemo()  # Chain.from_spec's memory


@dataclass(frozen=True)
class Chain:
    """The DH chain and link inertials of one robot, for either stance leg.

    Link inertials are expressed in the DH frame their link is attached to;
    index ``side`` 0 is stance-left (σ = +1), 1 stance-right (σ = −1).

    Attributes:
        a, alpha: DH constants a_{i-1} [m], α_{i-1} [rad] of rows 1..8, shape (8,).
        b: Shift along the twisted y axis of rows 1..8 [m], shape (8,): the knee offset
            (module doc); all 0 for a leg whose knee is on the hip–ankle line.
        d: DH offsets d_i [m] per stance side, shape (2, 8).
        theta_sign, theta_offset: θ_i = sign·q_i + offset, shape (8,).
        mass: Link masses [kg] of frames 0..8, shape (9,).
        com: Link CoMs in their DH frame [m], shape (2, 9, 3).
        inertia: Inertia about the CoM in DH-frame axes [kg m²], shape (2, 9, 3, 3).
        ankle_height: Ankle centre above the sole [m].
    """

    a: np.ndarray
    alpha: np.ndarray
    d: np.ndarray
    theta_sign: np.ndarray
    theta_offset: np.ndarray
    mass: np.ndarray
    com: np.ndarray
    inertia: np.ndarray
    ankle_height: float
    b: np.ndarray

    @classmethod
    def from_spec(cls, spec: RobotSpec) -> Chain:
        """The chain of ``spec``, remembered for the last few specs (a RobotSpec is frozen;
        the arrays are read-only): a trial asks for it ~9 times, 1.3 ms each."""
        return _CHAINS.get(spec, cls._read_only)

    @classmethod
    def _read_only(cls, spec: RobotSpec) -> Chain:
        """``_build`` with every array made read-only (the chain is shared)."""
        chain = cls._build(spec)
        for value in vars(chain).values():
            if isinstance(value, np.ndarray):
                value.setflags(write=False)
        return chain

    @classmethod
    def _build(cls, spec: RobotSpec) -> Chain:
        a = np.array([0, 0, spec.shank, spec.thigh, 0, spec.thigh, spec.shank, 0], dtype=float)
        alpha = np.array([0, -np.pi / 2, 0, 0, 0, 0, 0, np.pi / 2])
        d = np.zeros((2, N_JOINTS))
        d[0, 4], d[1, 4] = spec.hip_width, -spec.hip_width
        sign = np.array([-1, 1, 1, 1, -1, -1, -1, -1], dtype=float)
        offset = np.array([0, 0, 0, 0, np.pi, 0, 0, 0])
        k = spec.knee_offset
        b = np.array([0, 0, -k, k, 0, k, -k, 0], dtype=float)
        chain = cls(
            a,
            alpha,
            d,
            sign,
            offset,
            np.zeros(9),
            np.zeros((2, 9, 3)),
            np.zeros((2, 9, 3, 3)),
            spec.ankle_height,
            b,
        )
        mass = np.array([spec.links[name].mass for _, name in CHAIN_LINKS])
        com = np.zeros((2, 9, 3))
        inertia = np.zeros((2, 9, 3, 3))
        for side in (0, 1):
            frames = chain.frames(np.zeros((1, N_JOINTS)), np.zeros((1, 3)), np.array([side]))[0]
            for i, body in enumerate(_body_frames_at_zero(spec, side)):
                link = spec.links[CHAIN_LINKS[i][1]]
                com_body = np.array(link.com)
                if CHAIN_LINKS[i][0] != "pelvis" and body["right_leg"]:
                    com_body[1] = -com_body[1]
                R_i, p_i = frames[i, :3, :3], frames[i, :3, 3]
                com[side, i] = R_i.T @ (body["origin"] + com_body - p_i)  # body axes = S at q=0
                inertia[side, i] = R_i.T @ link.inertia_matrix @ R_i
        return cls(a, alpha, d, sign, offset, mass, com, inertia, spec.ankle_height, b)

    def dh_parameters(self, q: np.ndarray, stance: np.ndarray):
        """DH (a, α, d, θ, b) of the 8 rows per sample, each shape (n, 8)."""
        q = np.asarray(q, dtype=float)
        theta = self.theta_sign * q + self.theta_offset
        n = q.shape[0]
        return (
            np.broadcast_to(self.a, (n, 8)),
            np.broadcast_to(self.alpha, (n, 8)),
            self.d[np.asarray(stance)],
            theta,
            np.broadcast_to(self.b, (n, 8)),
        )

    def frames(self, q: np.ndarray, stance_foot: np.ndarray, stance: np.ndarray) -> np.ndarray:
        """Poses of DH frames 0..8 and the swing sole frame in S.

        Args:
            q: Joint angles [rad], Table-I order, shape (n, 8).
            stance_foot: Stance sole point (under the ankle, on the plane) in S [m], shape (n, 3).
            stance: Stance leg, 0 left / 1 right, shape (n,).

        Returns:
            Homogeneous transforms in S, shape (n, 10, 4, 4): frames 0..8 then the swing sole.
        """
        R, o = self.poses(q, stance_foot, stance)
        n = R.shape[-1]
        out = np.zeros((n, 10, 4, 4))
        out[:, :, :3, :3] = R.transpose(3, 0, 1, 2)
        out[:, :, :3, 3] = o.transpose(2, 0, 1)
        out[:, :, 3, 3] = 1.0
        return out

    def poses(self, q, stance_foot, stance) -> tuple[np.ndarray, np.ndarray]:
        """``frames`` in sample-last layout, the fast path for large batches.

        Composes eq. (1) row by row with the sample axis contiguous:
        R_i = R_{i-1} RotX(α) RotZ(θ), o_i = o_{i-1} + R_{i-1} (a, cα b − sα d, sα b + cα d)
        (b: the knee offset's shift, module doc).

        Returns:
            Rotations (10, 3, 3, n) (frame axes as columns) and origins (10, 3, n), in S.
        """
        q = np.asarray(q, dtype=float)
        n = q.shape[0]
        theta = (self.theta_sign * q + self.theta_offset).T  # (8, n)
        d = self.d[np.asarray(stance)].T  # (8, n)
        ct, st = np.cos(theta), np.sin(theta)
        R = np.empty((10, 3, 3, n))
        o = np.empty((10, 3, n))
        R[0] = ROTATION_FRAME0_IN_SLOPE[:, :, None]
        o[0] = np.asarray(stance_foot, dtype=float).T
        o[0, 2] += self.ankle_height
        for i in range(N_JOINTS):
            ca, sa = np.cos(self.alpha[i]), np.sin(self.alpha[i])
            x, y, z = R[i, :, 0], R[i, :, 1], R[i, :, 2]  # parent axes, (3, n) each
            y_twisted = y * ca + z * sa if sa else y * ca
            z_twisted = z * ca - y * sa if sa else z * ca
            R[i + 1, :, 0] = x * ct[i] + y_twisted * st[i]
            R[i + 1, :, 1] = y_twisted * ct[i] - x * st[i]
            R[i + 1, :, 2] = z_twisted
            o[i + 1] = o[i] + x * self.a[i] + z_twisted * d[i]
            if self.b[i]:  # only where there is a knee offset: k = 0 leaves eq. (1) untouched
                o[i + 1] += y_twisted * self.b[i]
        # swing sole: ankle_height along x8, axes (−z8, −y8, −x8)
        R[9, :, 0], R[9, :, 1], R[9, :, 2] = -R[8, :, 2], -R[8, :, 1], -R[8, :, 0]
        o[9] = o[8] + R[8, :, 0] * self.ankle_height
        return R, o

    def pelvis_pose(self, frames: np.ndarray, stance: np.ndarray):
        """Pelvis body pose in S from ``frames`` (n, 10, 4, 4): origin (n, 3), rotation (n, 3, 3).

        The origin is midway between the hips (DH frames 4 and 5); the pelvis body is
        S-aligned at q = 0 and rigid with frame 4, so its rotation is R4(q) R4(0)ᵀ.
        """
        zero = self.frames(np.zeros((1, N_JOINTS)), np.zeros((1, 3)), np.asarray(stance)[:1])
        origin = (frames[:, 4, :3, 3] + frames[:, 5, :3, 3]) / 2
        return origin, frames[:, 4, :3, :3] @ zero[0, 4, :3, :3].T

    def link_coms(self, frames: np.ndarray, stance: np.ndarray) -> np.ndarray:
        """CoM of the 9 links in S [m], shape (n, 9, 3), from ``frames`` (n, 10, 4, 4)."""
        com = self.com[np.asarray(stance)]  # (n, 9, 3)
        return np.einsum("nkij,nkj->nki", frames[:, :9, :3, :3], com) + frames[:, :9, :3, 3]

    def center_of_mass(self, frames: np.ndarray, stance: np.ndarray) -> np.ndarray:
        """Whole-robot CoM in S [m], shape (n, 3)."""
        coms = self.link_coms(frames, stance)
        return np.einsum("k,nki->ni", self.mass, coms) / self.mass.sum()


def _body_frames_at_zero(spec: RobotSpec, side: int) -> list[dict]:
    """Origins in S of the 9 chain links' body frames at q = 0, stance foot at the origin.

    Body frames are S-aligned at q = 0 (see ``robots/bioloid.toml``).
    """
    lateral = -1.0 if side == LEFT else 1.0  # direction from stance hip to swing hip, along y_S
    k = spec.knee_offset  # the knees ahead of the hip–ankle lines
    ankle = np.array([0.0, 0.0, spec.ankle_height])
    knee = ankle + [k, 0, spec.shank]
    hip = knee + [-k, 0, spec.thigh]
    swing_hip = hip + [0, lateral * spec.hip_width, 0]
    swing_knee = swing_hip + [k, 0, -spec.thigh]
    swing_ankle = swing_knee + [-k, 0, -spec.shank]
    stance_right = side != LEFT
    origins = [
        (ankle, stance_right),
        (ankle, stance_right),
        (knee, stance_right),
        (hip, stance_right),
        ((hip + swing_hip) / 2, False),
        (swing_hip, not stance_right),
        (swing_knee, not stance_right),
        (swing_ankle, not stance_right),
        (swing_ankle, not stance_right),
    ]
    return [{"origin": np.asarray(o, dtype=float), "right_leg": r} for o, r in origins]
