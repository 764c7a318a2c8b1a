"""Closed-form inverse kinematics of the two legs (eq. 3), with exact joint rates.

Each leg is a planar two-link chain (shank L1 from ankle to knee, thigh L2 from
knee to hip) in its own frontal-tilted plane. For the ankle-to-hip vector
(u, w) in that plane (u forward, w along the tilted "up"):

    ψ = atan2(u, w)                         angle of the ankle-hip line from up
    d = √(u² + w²)
    φ = arccos((L1² + d² − L2²) / (2 L1 d)) angle between that line and the shank
    β_shank = ψ + φ                          shank angle from up (knee ahead of the line)
    β_thigh = atan2(u − L1 sin β_shank, w − L1 cos β_shank)

which is eq. (3) of the paper (θ2 = ψ − φ, θ3 = 2φ when L1 = L2) written in
this package's joint signs: the paper's knee-behind sign flips to the
human-like knee of the Bioloid. With the pelvis upright and the feet parallel to
the plane the joint angles follow (``joints.py`` for the signs):

    hip pitch = β_thigh,  knee = β_shank − β_thigh,  ankle pitch = −β_shank.

Rates come from the two-link Jacobian, β̇ = J⁻¹ ṗ and β̈ = J⁻¹ (p̈ − J̇ β̇), so
q̇ and q̈ are exact (no finite differences).

A knee offset k (``RobotSpec.knee_offset``: the knee axis k ahead of the hip–ankle line
at the zero pose) keeps the IK closed-form: the ankle→knee vector is
S (sin β_s, cos β_s) + k (cos β_s, −sin β_s) = L1' (sin(β_s + γ_s), cos(β_s + γ_s)) with
L1' = √(S² + k²), γ_s = atan2(k, S), and the knee→hip vector likewise
L2' (sin(β_t − γ_t), cos(β_t − γ_t)), L2' = √(T² + k²), γ_t = atan2(k, T) (S, T the
shank and thigh along the line). ``leg_ik`` solves the two-link chain of the effective
links L1', L2' and shifts its angles by the constants γ_s, γ_t: rates unchanged. Its
branch keeps the effective links bent forward (φ ≥ 0), so the knee angle is at least
−(γ_s + γ_t): a knee behind the line (k < 0) bends at least |γ_s + γ_t| on this branch
(31° for k = −30 mm on the Bioloid's 111 mm links, 5° for −14 mm on 0.3 m links), the
other branch, which bends it less, is not taken.
"""

from __future__ import annotations

import numpy as np

from slopewalk.planner.errors import UnreachableError
from slopewalk.planner.trajectory import Curve


def two_link_ik(
    target: tuple[Curve, Curve], shank: float, thigh: float, t: np.ndarray, *, strict: bool = True
):
    """Shank and thigh angles (and rates) that put the hip at ``target`` from the ankle.

    Args:
        target: (u, w) ankle-to-hip vector in the leg plane [m], each Curve of shape (n,).
        shank, thigh: Link lengths L1, L2 [m].
        t: Sample times [s], shape (n,), to name the sample in errors.
        strict: Raise on an unreachable target; otherwise return NaN angles there.

    Returns:
        (β_shank, β_thigh) as Curves [rad, rad/s, rad/s²], each shape (n,).

    Raises:
        UnreachableError: a target farther than L1 + L2 (or nearer than |L1 − L2|).
    """
    u, w = target
    d = np.hypot(u.p, w.p)
    bad = (d >= shank + thigh) | (d <= abs(shank - thigh))
    if strict and np.any(bad):
        i = int(np.argmax(bad))
        raise UnreachableError(
            f"unreachable hip target at t = {t.flat[i]:.4f} s: hip-ankle "
            f"distance {d.flat[i]:.4f} m, the leg reaches ({abs(shank - thigh):.4f}, "
            f"{shank + thigh:.4f}) m"
        )
    d = np.where(bad, np.nan, d)
    psi = np.arctan2(u.p, w.p)
    phi = np.arccos((shank**2 + d**2 - thigh**2) / (2 * shank * d))
    bs = psi + phi
    bt = np.arctan2(u.p - shank * np.sin(bs), w.p - shank * np.cos(bs))
    # p = L1 (sin bs, cos bs) + L2 (sin bt, cos bt);  J = ∂p/∂(bs, bt)
    j11, j12 = shank * np.cos(bs), thigh * np.cos(bt)
    j21, j22 = -shank * np.sin(bs), -thigh * np.sin(bt)
    det = j11 * j22 - j12 * j21

    def solve(ru, rw):
        return (j22 * ru - j12 * rw) / det, (-j21 * ru + j11 * rw) / det

    vs, vt = solve(u.v, w.v)
    # J̇ β̇ = −(L1 sin bs vs² + L2 sin bt vt², L1 cos bs vs² + L2 cos bt vt²)
    cu = -(shank * np.sin(bs) * vs**2 + thigh * np.sin(bt) * vt**2)
    cw = -(shank * np.cos(bs) * vs**2 + thigh * np.cos(bt) * vt**2)
    as_, at = solve(u.a - cu, w.a - cw)
    return Curve(bs, vs, as_), Curve(bt, vt, at)


def leg_ik(target: tuple[Curve, Curve], spec, t: np.ndarray, *, strict: bool = True):
    """``two_link_ik`` of one leg of ``spec``, its knee offset included (module doc).

    Args:
        target: (u, w) ankle-to-hip vector in the leg plane [m], each Curve of shape (n,).
        spec: The ``RobotSpec`` (shank, thigh, knee_offset).
        t: Sample times [s], shape (n,), to name the sample in errors.
        strict: Raise on an unreachable target; otherwise NaN angles there.

    Returns:
        (β_shank, β_thigh) as Curves [rad, rad/s, rad/s²]: each link's own axis (the
        ankle→hip line at the zero pose) from the leg plane's up axis.
    """
    bs, bt = two_link_ik(target, spec.shank_link, spec.thigh_link, t, strict=strict)
    # x − 0.0 and x + 0.0 are x: without a knee offset the angles are two_link_ik's, bit for bit
    return Curve(bs.p - spec.shank_tilt, bs.v, bs.a), Curve(bt.p + spec.thigh_tilt, bt.v, bt.a)


def leg_vector(spec, shank: np.ndarray, thigh: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ankle-to-hip vector (u, w) in the leg plane [m] of link angles β_shank, β_thigh [rad].

    The forward map ``leg_ik`` inverts: S (sin β_s, cos β_s) + T (sin β_t, cos β_t) plus the
    knee offset's k (cos β_s − cos β_t, sin β_t − sin β_s).
    """
    u = spec.shank * np.sin(shank) + spec.thigh * np.sin(thigh)
    w = spec.shank * np.cos(shank) + spec.thigh * np.cos(thigh)
    k = spec.knee_offset
    if k:  # without an offset the two-link sums, untouched
        u = u + k * (np.cos(shank) - np.cos(thigh))
        w = w + k * (np.sin(thigh) - np.sin(shank))
    return u, w


def tilted_plane_height(height: Curve, lateral, lean: Curve) -> Curve:
    """Height z' in the stance leg's tilted plane of a point at a given height in S.

    With the legs leaning by λ about x_S, a point whose rolled lateral coordinate
    is y' (relative to the stance ankle) and whose height over the stance ankle in
    S is h sits at z' = (h − y'·sin λ) / cos λ. Used for the swing ankle
    (y' = ±Lh, h = lift) and the pelvis centre (y' = ±Lh/2, h = Hz − Lan), so the
    configuration does not jump when the stance leg changes. Derivatives by the
    chain rule.

    Args:
        height: h(t) over the stance ankle, in S [m].
        lateral: y' [m], per sample or scalar.
        lean: λ(t) [rad].

    Returns:
        z'(t) as a Curve [m].
    """
    s, c = np.sin(lean.p), np.cos(lean.p)
    k = lateral
    A = Curve(
        height.p - k * s, height.v - k * c * lean.v, height.a - k * (c * lean.a - s * lean.v**2)
    )
    sec = 1.0 / c
    B = Curve(sec, s * sec**2 * lean.v, s * sec**2 * lean.a + (1 + s**2) * sec**3 * lean.v**2)
    return Curve(A.p * B.p, A.v * B.p + A.p * B.v, A.a * B.p + 2 * A.v * B.v + A.p * B.a)
