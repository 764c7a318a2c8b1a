"""The readable numpy pipeline: splines → IK → Newton-Euler → ZMP, margin, work.

This is the reference the compiled kernel (``planner/kernel``) is held equal to
(tests/planner/test_kernel.py): the same maths written as whole-array numpy over a
flat batch of P·n samples, one module per concept (``trajectory``, ``ik``,
``kinematics``, ``newton_euler``, ``zmp``). ``plan.plan_walk`` and
``plan.evaluate`` run the kernel; nothing but the tests and the benchmark's
``numpy_evals_per_s`` runs this.

The stated modelling choices (double-support load split, joint work) are
those of ``planner.plan``'s module docstring; this path implements the same.
"""

from __future__ import annotations

import numpy as np

from slopewalk.planner.gait import GaitParams
from slopewalk.planner.ik import leg_ik, tilted_plane_height
from slopewalk.planner.joints import RIGHT, principal_angle
from slopewalk.planner.kinematics import Chain, gravity_in_slope
from slopewalk.planner.newton_euler import cross, inverse_dynamics_poses, swing_wrench_torques
from slopewalk.planner.sole import edge_normals, outline
from slopewalk.planner.trajectory import Curve, Timeline, blend, footprint_y
from slopewalk.planner.zmp import (
    cop_of_wrench,
    friction_ratio,
    signed_margin,
    sole_vertices,
    support_polygon,
    zmp_lipm,
    zmp_multibody,
)


def evaluate_reference(spec, params: GaitParams, population) -> tuple[np.ndarray, np.ndarray]:
    """Work [J] and minimum margin [m] of each individual at ``params``' grid, shape (P,).

    The numpy twin of ``plan.evaluate`` without its one-sided limits and refinement:
    the margin is the minimum over ``Timeline.of(params).t`` only.

    Args:
        population: Rows (Hz, Szmax, tilt) (the paper family, at ``params``' step
            length, pelvis offset and sway share) or (Hz, Szmax, tilt, δ, L, w)
            (``gait_search.EXTENDED``), shape (P, 3) or (P, 6).
    """
    pop = np.atleast_2d(np.asarray(population, dtype=float))
    walk = solve_reference(
        spec, Timeline.of(params), params.slope, *pop.T, strict=False, light=True
    )
    work, margin = walk["work"].sum(axis=1), walk["margin"].min(axis=1)
    bad = ~np.isfinite(work) | ~np.isfinite(margin)
    return np.where(bad, np.inf, work), np.where(bad, -np.inf, margin)


# long: the readable twin of planner/kernel, its stages in the kernel's order (module doc)
def solve_reference(
    spec, timeline, slope, hip_height, lift, tilt, pelvis_offset=None, step_length=None,
    sway_share=None, *, strict, light=False,
) -> dict:  # fmt: skip
    """The pipeline for P parameter sets at once; every array gets a leading P axis.

    Args:
        spec: The robot. timeline: The walk's timing. slope: [rad].
        hip_height, lift, tilt: Hz [m], Szmax [m], tilt [rad], each shape (P,).
        pelvis_offset, step_length, sway_share: δ [m], L [m], w [-], each shape (P,);
            None: the timeline's (the paper family).
        strict: Raise ``UnreachableError`` on an unreachable target (else NaN there).
        light: Return only ``work`` (P, 8) and ``margin`` (P, n).

    Returns:
        The fields of ``plan.Plan`` by name, each with a leading P axis.
    """
    P, n = np.size(hip_height), timeline.t.size
    chain = Chain.from_spec(spec)
    gravity = gravity_in_slope(slope)

    def col(x, default=None):  # one value per individual, as a column (P, 1)
        x = default if x is None else x
        return np.broadcast_to(np.asarray(x, dtype=float).reshape(-1, 1), (P, 1))

    def flat(a):  # (n,) or (P, n) → the flat batch of P·n samples
        return np.broadcast_to(a, (P, n)).reshape(-1)

    zeros = np.zeros((P, n))
    delta = col(pelvis_offset, timeline.pelvis_offset)
    length = col(step_length, timeline.step_length)
    share = col(sway_share, timeline.sway_share)
    unit = timeline.per_unit  # shapes per unit step length (linear in L), δ = 0

    stance = flat(timeline.stance)
    lean = blend(unit.hold_shape, unit.sway_shape, share).scaled(col(tilt))
    towards_swing = np.where(timeline.stance == RIGHT, 1.0, -1.0)  # +1: swing hip at +y
    z_swing = tilted_plane_height(
        timeline.lift_shape.scaled(col(lift)), towards_swing * spec.hip_width, lean
    )
    pelvis = Curve(col(hip_height) - spec.ankle_height + zeros, zeros, zeros)
    hip_w = tilted_plane_height(pelvis, towards_swing * spec.hip_width / 2, lean)
    hip_u = unit.hip_x.scaled(length)
    hip_u = Curve(hip_u.p + delta, hip_u.v, hip_u.a)
    sx = unit.swing_x.scaled(length)
    stance_target = (
        Curve(*(flat(x) for x in (hip_u.p, hip_u.v, hip_u.a))),
        Curve(flat(hip_w.p), flat(hip_w.v), flat(hip_w.a)),
    )
    swing_target = (
        Curve(
            *(
                flat(h - s)
                for h, s in zip((hip_u.p, hip_u.v, hip_u.a), (sx.p, sx.v, sx.a), strict=True)
            )
        ),
        Curve(flat(hip_w.p - z_swing.p), flat(hip_w.v - z_swing.v), flat(hip_w.a - z_swing.a)),
    )
    t_flat = flat(timeline.t)
    with np.errstate(invalid="ignore", divide="ignore"):
        legs = [
            leg_ik(target, spec, t_flat, strict=strict) for target in (stance_target, swing_target)
        ]
    (bs, bt), (bs2, bt2) = legs
    lam = Curve(flat(lean.p), flat(lean.v), flat(lean.a))
    q, qd, qdd = (
        np.stack([-lam_, -s, s - t, t, t2, s2 - t2, -s2, -lam_], axis=1)
        for lam_, s, t, s2, t2 in (
            (lam.p, bs.p, bt.p, bs2.p, bt2.p),
            (lam.v, bs.v, bt.v, bs2.v, bt2.v),
            (lam.a, bs.a, bt.a, bs2.a, bt2.a),
        )
    )
    q = principal_angle(q)  # the joints' configuration (``planner.joints``)

    feet_y = footprint_y(timeline, spec.hip_width, col(tilt)[:, 0], share[:, 0])  # (P, N)
    step = np.minimum(timeline.step, timeline.steps - 1)
    stance_sole = np.stack(
        [flat(length * unit.stance_x), feet_y[:, step].reshape(-1), np.zeros(P * n)], axis=1
    )
    R, o = chain.poses(q, stance_sole, stance)
    dyn = inverse_dynamics_poses(chain, R, o, qd, qdd, stance, gravity)

    # DSP split: the swing foot takes the share 1 - s of the total wrench.
    swing_sole = o[9].T
    other = flat(1.0 - _stance_share(timeline))[:, None]
    swing_force = other * dyn.stance_force
    swing_moment = other * (dyn.stance_moment + cross(stance_sole - swing_sole, dyn.stance_force))
    tau = dyn.tau + swing_wrench_torques(chain, R, o, swing_force, swing_moment)

    coms = dyn.com
    zmp = zmp_multibody(chain.mass, coms, dyn.com_acc, dyn.momentum_rate, gravity)
    double = flat(~timeline.in_ssp)
    sole = outline(spec)  # the sole polygon (default: the rectangle) about the sole's centre
    polygon = support_polygon(
        sole_vertices(stance_sole, sole, spec.sole_shift(stance)),
        sole_vertices(swing_sole, sole, spec.sole_shift(1 - stance)),
        double,
        edge_normals(sole),
    )
    margin = signed_margin(zmp, polygon)
    power = np.abs(tau * qd).reshape(P, n, 8)
    work = np.trapezoid(power, timeline.t, axis=1)
    out = {"work": work, "margin": margin.reshape(P, n)}
    if light:
        return out
    mass = chain.mass.sum()
    com = np.einsum("k,nki->ni", chain.mass, coms) / mass
    com_acc = np.einsum("k,nki->ni", chain.mass, dyn.com_acc) / mass
    ground = dyn.stance_force  # the total; the DSP split only moves part of it to the swing foot
    stance_force = ground - swing_force
    series = {
        "t": flat(timeline.t),
        "q": q,
        "qd": qd,
        "qdd": qdd,
        "tau": tau,
        "zmp": zmp,
        "zmp_lipm": zmp_lipm(com, com_acc, gravity),
        "cop_ne": cop_of_wrench(ground, dyn.stance_moment, stance_sole),
        "com": com,
        "com_acc": com_acc,
        "stance": stance,
        "double_support": double,
        "stance_sole": stance_sole,
        "swing_sole": swing_sole,
        "polygon": polygon,
        "margin": margin,
        "ground_force": ground,
        "stance_force": stance_force,
        "swing_force": swing_force,
        "friction_ratio": friction_ratio(ground),
    }
    out.update({k: v.reshape((P, n) + v.shape[1:]) for k, v in series.items()})
    return out


def _stance_share(timeline: Timeline) -> np.ndarray:
    """Share s of the ground wrench on the current stance foot per sample, shape (n,)."""
    dsp = timeline.dsp_time
    tau = timeline.t - timeline.step * timeline.step_time
    x = np.clip(tau / dsp, 0.0, 1.0)
    smooth = 3 * x**2 - 2 * x**3
    start = np.where(timeline.step == 0, 0.5, 0.0)
    share = start + (1.0 - start) * smooth
    share = np.where(timeline.step == timeline.steps, 1.0 - 0.5 * smooth, share)
    return np.where(timeline.in_ssp, 1.0, share)
