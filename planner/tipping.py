"""Tipping predictor: the support's rocking about its edges while and after the ZMP is outside.

The paper's test is binary: the ZMP leaves the support polygon or not. A brief
excursion need not tip the robot, and several brief ones can. While the ZMP (the
point where the ground reaction would have to act for the plan to be followed)
lies beyond the support's edge, the ground can push only at that edge; the
unbalanced moment turns the whole robot about it (cf. Goswami's foot-rotation
indicator). The joints keep the planned pose (measured in MuJoCo: the pelvis
turns with the stance foot to within 0.1°), so the robot rocks as one rigid body
on its support, about two axes of the plane (small angles, each on its own):

* roll θ_y about a line along x: the support's extreme lines y = y_max, y_min
  (the outer sole edges, the stance foot's inner edge in single support);
* pitch θ_x about a line along y: x = x_max (toe), x = x_min (heel).

θ > 0 leans the robot towards the + side about the + line, θ < 0 towards the
− side about the − line. With u the axis coordinate (y for roll, x for pitch),
e the pivot line, z_u the ZMP and c the CoM, both sides obey

    I_e θ̈ = F_n (z_u − e) + K_e θ

F_n the planned normal ground force, I_e the robot's moment of inertia about the
pivot line (``edge_inertia``) and K_e the gravity stiffness of the rotation:
turning the robot by θ about the line is, in the robot's frame, gravity turned
by −θ, which moves the ZMP and the normal force; from the potential energy,

    K_e = m g (h cos α + (c_x − e) sin α)   (pitch; α the slope, h the CoM height)
    K_e = m g h cos α                      (roll)

(an uphill walker falling backwards over its heel has the larger K). The moment
restores once the ZMP is back inside by more than K_e θ / F_n.

The rotation's history is carried, not reset:

* Landing (θ back through 0): the support line on the other side meets the
  plane. The impact's impulse acts there, so the angular momentum about that
  line is kept (Housner's rocking block), and the robot rocks on about it with
  θ̇⁺ = r θ̇⁻, r = 1 − m (e_old − e_new)(c_u − e_new) / I_new;
  r ≤ 0 (the CoM far out over the new line) lands it dead. Measured in MuJoCo
  (``tests/sim/test_tipping_mujoco.py``): a block rocks on as this law says.
  So an excursion past one edge and then one past the other, a step later,
  add up: the rocking of a fast walk is pumped step after step.
* Rest: when a landing's rocking speed is less than one sample of the new side's
  restoring moment takes away, the robot stays flat (θ = θ̇ = 0); flat, it
  starts again only where the ZMP is outside the support lines.
* Floor give: the simulator's floor is soft (MuJoCo's soft contacts: each sole
  corner a spring of stiffness k_c, derived from the solver's solref/solimp
  in ``bench/sim/floor.py``). It turns the support by the give angle
  θ_g = F_n (p − m) / k_rot before any edge lifts, p the CoP (the ZMP while
  flat, the pivot line while turning), m the corners' centroid and
  k_rot = k_c Σ (u_i − m)² over the support's sole corners (measured in MuJoCo:
  70 N m/rad in pitch, 26 in roll for the default foot, against 65 and 23
  derived). The give adds to the tilt and gravity acts on the whole of it,
  I_e θ̈ = F_n (z_u − e) + K_e (θ + θ_g): a walk leaning on a heel starts its
  rotation already turned by the give, which the inverted pendulum amplifies.
  ``floor_stiffness`` None is a rigid floor (θ_g = 0).
* Prop: in single support the swing sole, at height s over the plane, blocks a
  rotation towards it once it reaches the plane: θ ≤ s / ℓ (ℓ the distance from
  the pivot to the swing sole's far edge beyond it). It lands without bounce
  (MuJoCo's contacts are critically damped) and carries load from then on.

``tip`` is predicted when the tilt √(θ_x² + θ_y²) (lift and give) passes the simulator's tip
angle. The rotation is integrated sample by sample (semi-implicit Euler on the
plan's time base; ``_rocking_loop``, run compiled as ``kernel.rocking``); a rotation
past ``FALLEN`` is reported as that.

Not modelled: a slanted edge of the double-support hull (a rotation about it is
both axes at once; the extreme lines are the sole edges of feet parallel to x),
and the servos' deflection while the support turns (the walk judged is given:
``servo_loop`` integrates the loop's sway along the plan, the support held flat).

I_e = Σ_k m_k d_k² + ê·I_k ê over the 9 links, d_k the distance of link k's
CoM from the line and I_k its inertia about its CoM, both in S.
"""

from __future__ import annotations

import numpy as np

from slopewalk.planner.kinematics import Chain, gravity_in_slope
from slopewalk.planner.zmp import foot_corners

FALLEN = np.pi / 2  # [rad]: a rotation past this is reported as this (the robot is down)
ROLL, PITCH = 1, 0  # axis coordinate of each rotation: y for roll, x for pitch


def excursion_integral(t, drive, inertia, feedback=0.0) -> np.ndarray:
    """One-sided integral x(t) of I ẍ = drive + k x, with x ≥ 0 (stops when back at 0).

    Args:
        t: Sample times [s], (n,).
        drive: Generalised force [N m or N], (n,): positive pushes x away from 0.
        inertia: Inertia about the motion [kg m² or kg], (n,) or scalar, > 0.
        feedback: k, the force per unit x that x itself adds [N m/rad or N/m], (n,)
            or scalar, ≥ 0 (the inverted pendulum's m g h for a rotation).

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


def edge_inertia(plan, rows, edge_point, edge_direction) -> np.ndarray:
    """Moment of inertia of the robot about a line on the plane [kg m²], at plan samples ``rows``.

    Args:
        plan: The walk (``slopewalk.planner.plan.Plan``).
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


def landing_restitution(mass, com, old_line, new_line, new_inertia) -> float:
    """θ̇⁺ / θ̇⁻ of a rigid body rocking from ``old_line`` onto ``new_line`` (Housner), ≥ 0.

    The landing impulse acts on the new line, so the angular momentum about it is
    kept: I_new θ̇⁺ = (I_new − m (e_old − e_new)(c − e_new)) θ̇⁻.

    Args:
        mass: m [kg].
        com: c, the CoM's coordinate across the lines [m].
        old_line, new_line: e_old, e_new [m], same coordinate.
        new_inertia: I_new, about the new line [kg m²].

    Returns:
        The ratio; 0 when the body lands dead (the CoM far out over the new line).
    """
    r = 1.0 - mass * (old_line - new_line) * (com - new_line) / new_inertia
    return max(float(r), 0.0)


def support_lines(plan, axis: int) -> tuple[np.ndarray, np.ndarray]:
    """The support's extreme lines along ``axis`` (ROLL: y, PITCH: x) [m]: (lower, upper), (n,)."""
    coordinate = plan.polygon[..., axis]
    return coordinate.min(axis=1), coordinate.max(axis=1)


class LinkMoments:
    """The links' mass distribution at every sample of a plan, for inertias about lines.

    Computed once per plan (one pass of forward kinematics), so the four support lines'
    inertias of ``foot_rotation`` cost a few vector operations each, not four passes of
    ``edge_inertia`` (which recomputed the frames and turned every link's inertia into
    S with einsums: 37 ms per line on a 4,400-sample walk, against ~1 ms here).

    Attributes:
        mass: m_k [kg], (9,).
        com: c_k, each link's CoM in S [m], (9, 3, n).
        spin: ê·I_k ê summed over the links for ê = x and ê = y of S [kg m²], (2, n):
            row 0 for lines along x (roll), row 1 for lines along y (pitch).
    """

    def __init__(self, plan):
        chain = Chain.from_spec(plan.spec)
        stance = np.asarray(plan.stance)
        R, o = chain.poses(plan.q, plan.stance_sole, stance)  # (10, 3, 3, n), (10, 3, n)
        R = R[:9]
        self.mass = chain.mass
        # A link's CoM offset and inertia are constant in its DH frame for each stance
        # leg: each side's pair is applied to all samples by batched 3 × 3 products and
        # the stance picks per sample, with no (n, 9, 3, 3) gather of the tensors (the
        # class: 9.4 → 6.0 ms a walk on the default sweep's, 2.3 ms of it the poses).
        right = stance.astype(bool)
        com, spin = np.empty((2, 9, 3, R.shape[-1])), np.empty((2, 2, R.shape[-1]))
        for side in (0, 1):
            c = chain.com[side]  # (9, 3): R_k c_k = Σ_j (column j of R_k) c_kj
            com[side] = o[:9] + sum(R[:, :, j] * c[:, None, j, None] for j in range(3))
            # the axis ê = row r of S in link k's frame is R_k[r, :]; ê·I ê = Σ_ij R_ri I_ij R_rj
            for r in (0, 1):
                row = R[:, r]  # (9, 3, n)
                spin[side, r] = (row * (chain.inertia[side] @ row)).sum(axis=(0, 1))
        self.com = np.where(right, com[1], com[0])
        self.spin = np.where(right, spin[1], spin[0])

    def about_line(self, axis: int, position: np.ndarray) -> np.ndarray:
        """I_e [kg m²], (n,): about the line u = ``position`` (n,) of ``axis`` on the plane.

        ROLL (u = y) turns about a line along x: d_k² = (y_k − e)² + z_k²; PITCH (u = x)
        about one along y: d_k² = (x_k − e)² + z_k² (``edge_inertia``'s I_e).
        """
        across = self.com[:, axis] - position
        height = self.com[:, 2]
        distance2 = across * across + height * height  # (9, n)
        return self.mass @ distance2 + self.spin[1 - axis]


def line_inertia(plan, axis: int, position: np.ndarray, moments=None) -> np.ndarray:
    """``edge_inertia`` about the line u = ``position`` (n,) of ``axis`` at every sample [kg m²].

    ``moments``: the plan's ``LinkMoments``, if already computed.
    """
    moments = LinkMoments(plan) if moments is None else moments
    return moments.about_line(axis, position)


def gravity_stiffness(plan, axis: int, line: np.ndarray) -> np.ndarray:
    """K_e [N m/rad], (n,): the moment per radian gravity adds to a rotation about ``line``."""
    g = gravity_in_slope(plan.params.slope)  # (g_x, 0, g_z) in S, g_z < 0
    mass = plan.spec.total_mass
    k = -mass * g[2] * plan.com[:, 2]
    if axis == PITCH:
        k = k - mass * g[0] * (plan.com[:, 0] - line)
    return k


def give_stiffness(plan, axis: int, corner_stiffness: float) -> tuple[np.ndarray, np.ndarray]:
    """k_rot [N m/rad] and the corners' centroid m [m] of the soft support, (n,) each.

    The support's springs are the stance sole's 4 corners, and the other sole's 4 in
    double support, each of stiffness ``corner_stiffness`` [N/m].
    """
    spec = plan.spec
    shape = (spec.heel_offset, spec.ankle_to_toe, spec.foot_width / 2)
    stance = foot_corners(plan.stance_sole, *shape, spec.sole_shift(plan.stance))[..., axis]
    other = foot_corners(plan.swing_sole, *shape, spec.sole_shift(1 - plan.stance))[..., axis]
    both = plan.double_support[:, None]
    count = np.where(both, 8, 4)[:, 0]
    centroid = (stance.sum(axis=1) + np.where(both, other, 0.0).sum(axis=1)) / count
    spread = ((stance - centroid[:, None]) ** 2).sum(axis=1)
    spread += np.where(both, (other - centroid[:, None]) ** 2, 0.0).sum(axis=1)
    return corner_stiffness * spread, centroid


def swing_reach(plan, axis: int) -> tuple[np.ndarray, np.ndarray]:
    """The swing sole's extent along ``axis`` [m]: (lower, upper) edge, (n,) each."""
    sole = plan.swing_sole[:, axis]
    spec = plan.spec
    if axis == ROLL:
        half = spec.foot_width / 2
        centre = sole + spec.sole_shift(1 - plan.stance)
        return centre - half, centre + half
    return sole - spec.heel_offset, sole + spec.ankle_to_toe


def rocking(
    plan, axis: int, zmp=None, clearance=None, floor_stiffness=None, moments=None, props=None,
    compiled=True,
) -> np.ndarray:  # fmt: skip
    """Signed tilt of the robot on its support about ``axis``'s lines [rad], (n,) (module doc).

    Args:
        plan: The walk: polygon, ground force, CoM, joint angles, swing sole.
        axis: ROLL (lines along x, θ > 0 leans towards +y) or PITCH (towards +x).
        zmp: The ZMP series to judge, (n, 2) [m]; default the plan's own.
        clearance: Swing sole height over the plane [m], (n,); default the plan's.
        floor_stiffness: k_c of each sole corner on the soft floor [N/m], > 0; None: rigid.
        moments: The plan's ``LinkMoments``, if already computed.
        props: A boolean array (n,) or None; where given, the samples at which the swing
            sole props the rotation (the module doc's prop) are set True in it.
        compiled: Step through time on the compiled kernel (``kernel.rocking``, the
            same arithmetic); False: ``_rocking_loop``, the reference.

    Returns:
        θ + θ_g: the lift about the pivot line plus the floor's give.
    """
    zmp = plan.zmp if zmp is None else zmp
    clearance = plan.swing_sole[:, 2] if clearance is None else clearance
    lower, upper = support_lines(plan, axis)
    lines = (lower, upper)
    moments = LinkMoments(plan) if moments is None else moments
    inertia = tuple(moments.about_line(axis, e) for e in lines)
    stiffness = tuple(gravity_stiffness(plan, axis, e) for e in lines)
    mass = plan.spec.total_mass
    com = plan.com[:, axis]
    normal = np.maximum(plan.ground_force[:, 2], 0.0)
    z = zmp[:, axis]
    reach = swing_reach(plan, axis)
    single = ~plan.double_support
    height = np.maximum(clearance, 0.0)
    dt = np.diff(plan.t, prepend=plan.t[0])
    if floor_stiffness is None:
        compliance, centroid = np.zeros(plan.t.size), np.zeros(plan.t.size)
    else:
        k_rot, centroid = give_stiffness(plan, axis, floor_stiffness)
        compliance = normal / k_rot  # [rad/m]: give per metre of CoP offset
    flat_give = compliance * (np.clip(z, lower, upper) - centroid)
    series = (lines, inertia, stiffness, z, normal, com, compliance, centroid, flat_give, reach)
    propped = np.zeros(plan.t.size, dtype=np.bool_)
    if compiled:
        from slopewalk.planner.kernel.rocking import rocking_loop

        # one layout and dtype per argument: one compiled signature
        arrays = [
            np.ascontiguousarray(np.stack(a) if isinstance(a, tuple) else a, dtype=float)
            for a in series
        ]
        single = np.ascontiguousarray(single, dtype=np.bool_)
        height = np.ascontiguousarray(height, dtype=float)
        theta = rocking_loop(*arrays, single, height, dt, float(mass), FALLEN, propped)
    else:
        theta = _rocking_loop(*series, single, height, dt, mass, propped)
    if props is not None:
        props |= propped
    return theta


def _rocking_loop(
    lines, inertia, stiffness, z, normal, com, compliance, centroid, flat_give, reach, single,
    height, dt, mass, props,
) -> np.ndarray:  # fmt: skip
    """``rocking``'s step through time (module doc): θ + θ_g [rad], (n,).

    Args:
        lines, inertia, stiffness: The (lower, upper) support lines [m], the inertias
            about them [kg m²] and their gravity stiffnesses [N m/rad], (n,) each.
        z: The judged ZMP's coordinate [m]; normal: F_n [N], ≥ 0; com: the CoM's
            coordinate [m]; compliance: give per metre of CoP offset [rad/m]; centroid:
            the sole corners' [m]; flat_give: the give while flat [rad]. (n,) each.
        reach: The swing sole's (lower, upper) edge [m], (n,) each; single: single
            support, (n,) bool; height: the swing sole's clearance, ≥ 0 [m], (n,).
        dt: Time step to each sample [s], (n,). mass: The robot's [kg].
        props: (n,) bool, set True at the samples where the swing sole props the rotation.
    """
    lower, upper = lines
    reach_low, reach_high = reach
    theta = np.zeros(z.size)
    x, v = 0.0, 0.0
    for k in range(z.size):
        if x == 0.0 and v == 0.0:  # flat: starts only with the ZMP past a line
            if lower[k] <= z[k] <= upper[k]:
                theta[k] = flat_give[k]
                continue
            side = 1 if z[k] > upper[k] else 0
        else:
            side = 1 if x > 0.0 or (x == 0.0 and v > 0.0) else 0
        e = lines[side][k]
        give = compliance[k] * (e - centroid[k])  # the CoP sits on the pivot line
        drive = normal[k] * (z[k] - e) + stiffness[side][k] * (x + give)
        v += drive / inertia[side][k] * dt[k]
        moved = x + v * dt[k]
        sign = 1.0 if side else -1.0
        if moved * sign <= 0.0:  # back through flat: the other line lands
            other = 1 - side
            e_new = lines[other][k]
            v = landing_restitution(mass, com[k], e, e_new, inertia[other][k]) * v
            pull = normal[k] * (z[k] - e_new) / inertia[other][k] * dt[k]
            x = 0.0
            if v == 0.0 or (v + pull) * v <= 0.0:
                v = 0.0  # the rocking dies on landing: flat
        else:
            x = moved
        if single[k] and x != 0.0:  # the swing sole props a rotation towards it
            beyond = (reach_high[k] - upper[k]) if x > 0 else (lower[k] - reach_low[k])
            if beyond > 0.0 and abs(x) * beyond > height[k]:
                x = np.copysign(height[k] / beyond, x)
                props[k] = True
                v = min(v, 0.0) if x > 0 else max(v, 0.0)
                if x == 0.0:
                    v = 0.0
        x = min(max(float(x), -FALLEN), FALLEN)  # np.clip on a scalar: 6 µs a sample
        theta[k] = x + (give if x != 0.0 or v != 0.0 else flat_give[k])
    return theta


def foot_rotation(
    plan, zmp=None, clearance=None, floor_stiffness=None, props=None, compiled=True
) -> np.ndarray:
    """Predicted tilt of the support off the plane [rad], (n,): √(roll² + pitch²), ≤ FALLEN.

    Args:
        plan: The walk (see ``rocking``).
        zmp: The ZMP series to judge, (n, 2) [m]; default the plan's own.
        clearance: Swing sole height over the plane [m], (n,); default the plan's.
        floor_stiffness: k_c of each sole corner [N/m]; None: a rigid floor.
        props: Boolean (n,) or None: where given, marks the samples at which the swing
            sole props the roll or the pitch (``rocking``).
        compiled: ``rocking``'s (False: the numpy reference).
    """
    moments = LinkMoments(plan)
    roll = rocking(plan, ROLL, zmp, clearance, floor_stiffness, moments, props, compiled)
    pitch = rocking(plan, PITCH, zmp, clearance, floor_stiffness, moments, props, compiled)
    return np.minimum(np.hypot(roll, pitch), FALLEN)
