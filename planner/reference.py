"""Plan a walk: splines → IK → Newton-Euler → ZMP, support polygon, margin, work.

``plan_walk(spec, params)`` returns a ``Plan`` of time series for one walk;
``evaluate(spec, params, population)`` runs the same pipeline for a whole GA
population at once (the samples of all individuals form one flat batch).

Double-support load split (stated assumption): during each DSP the ground
wrench moves from the foot that was loaded to the foot that will be, along a
smoothstep s(t) = 3x² − 2x³ of the phase x ∈ [0, 1]. Each foot carries a scaled
copy of the total wrench (share s for the new stance foot, 1 − s for the other),
so both see the same CoP and the torques are continuous at every phase change.
The walk starts with the load shared equally (s: ½ → 1 in the first DSP) and the
closing DSP returns to equal shares (1 → ½). The ZMP does not depend on the split.

Joint work (eq. 7): the paper writes Σ∫ τ θ̇ dt, which over a step is only the
change of mechanical energy (zero for a periodic gait). We report the energy the
actuators spend, Σ∫ |τ θ̇| dt, per joint and in total.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass

import numpy as np

from planner.ik import tilted_plane_height, two_link_ik
from planner.joints import JOINT_NAMES, RIGHT, stance_swing_to_left_right
from planner.kinematics import Chain, gravity_in_slope
from planner.newton_euler import cross, inverse_dynamics_poses, swing_wrench_torques
from planner.spec import RobotSpec
from planner.trajectory import Curve, GaitParams, Timeline, footprint_y
from planner.zmp import (
    cop_of_wrench,
    foot_corners,
    friction_ratio,
    signed_margin,
    support_polygon,
    zmp_lipm,
    zmp_multibody,
)


@dataclass(frozen=True)
class Plan:
    """The analytic prediction for one walk; arrays over n samples, vectors in S.

    Attributes:
        t: Sample times [s], (n,).
        q, qd, qdd: Joint angles [rad], rates, accelerations, Table-I order, (n, 8).
        tau: Joint torques [N m], (n, 8).
        zmp: Multibody ZMP, eq. (4) [m], (n, 2).
        zmp_lipm: LIPM ZMP, eq. (5) [m], (n, 2).
        cop_ne: CoP of the Newton-Euler ground wrench [m], (n, 2).
        com, com_acc: Whole-body CoM [m] and its acceleration [m/s²], (n, 3).
        stance: Stance leg, 0 left / 1 right, (n,).
        double_support: True in DSP, (n,).
        stance_sole, swing_sole: Sole points under the ankles [m], (n, 3).
        polygon: Support polygon vertices, counter-clockwise [m], (n, 8, 2).
        margin: Signed ZMP distance to the polygon edge [m], positive inside, (n,).
        ground_force: Total ground force [N], (n, 3).
        stance_force, swing_force: Ground force on each foot (DSP split) [N], (n, 3).
        friction_ratio: |F_t| / F_n of the total ground force, (n,).
        work: Σ∫|τ θ̇| dt per joint [J], (8,).
    """

    params: GaitParams
    spec: RobotSpec
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    zmp: np.ndarray
    zmp_lipm: np.ndarray
    cop_ne: np.ndarray
    com: np.ndarray
    com_acc: np.ndarray
    stance: np.ndarray
    double_support: np.ndarray
    stance_sole: np.ndarray
    swing_sole: np.ndarray
    polygon: np.ndarray
    margin: np.ndarray
    ground_force: np.ndarray
    stance_force: np.ndarray
    swing_force: np.ndarray
    friction_ratio: np.ndarray
    work: np.ndarray

    @property
    def q_left_right(self) -> np.ndarray:
        """Joint angles in the MJCF's order (``joints.MJCF_JOINTS``) [rad], (n, 8)."""
        return stance_swing_to_left_right(self.q, self.stance)

    @property
    def stable(self) -> bool:
        """Analytic verdict: ZMP inside the support polygon at every sample."""
        return bool(np.all(self.margin >= 0))

    def summary(self) -> dict:
        """Scalars a user reads first: margins, peak torques, work, verdict."""
        peak = np.abs(self.tau).max(axis=0)
        return {
            "verdict": "stable" if self.stable else "zmp_outside",
            "min_margin_m": float(self.margin.min()),
            "time_of_min_margin_s": float(self.t[np.argmin(self.margin)]),
            "peak_torque_Nm": dict(zip(JOINT_NAMES, peak.round(4).tolist(), strict=True)),
            "peak_torque_over_stall": float(peak.max() / self.spec.stall_torque),
            "work_J": float(self.work.sum()),
            "max_friction_ratio": float(self.friction_ratio.max()),
            "max_lipm_distance_m": float(np.hypot(*(self.zmp - self.zmp_lipm).T).max()),
        }

    def save_npz(self, file) -> None:
        """Write the series and a ``meta`` JSON string (spec and gait parameters).

        Args:
            file: A path or a binary file object (``np.savez_compressed`` target).
        """
        meta = {
            "params": asdict(self.params),
            "spec": _spec_dict(self.spec),
            "joint_names": list(JOINT_NAMES),
            "summary": self.summary(),
        }
        arrays = {
            k: getattr(self, k)
            for k in (
                "t",
                "q",
                "qd",
                "qdd",
                "tau",
                "zmp",
                "zmp_lipm",
                "cop_ne",
                "com",
                "com_acc",
                "stance",
                "double_support",
                "stance_sole",
                "swing_sole",
                "margin",
                "ground_force",
                "friction_ratio",
                "work",
            )
        }
        np.savez_compressed(file, q_left_right=self.q_left_right, meta=json.dumps(meta), **arrays)


def plan_walk(spec: RobotSpec, params: GaitParams) -> Plan:
    """Plan one walk of ``params.steps`` steps for ``spec`` (see module doc).

    Raises:
        UnreachableError: the hip height or lift asks a leg for more than it reaches.
    """
    timeline = Timeline.of(params)
    walk = _solve(
        spec,
        timeline,
        params.slope,
        np.array([params.hip_height]),
        np.array([params.swing_lift]),
        np.array([params.tilt]),
        strict=True,
    )
    return Plan(params=params, spec=spec, **{k: v[0] for k, v in walk.items()})


def evaluate(spec: RobotSpec, params: GaitParams, population) -> tuple[np.ndarray, np.ndarray]:
    """Work and minimum ZMP margin of every individual of a GA population, in one batch.

    Args:
        spec: The robot.
        params: Step time, slope, steps, sampling (its Hz, lift and tilt are ignored).
        population: Rows (hip_height [m], swing_lift [m], tilt [rad]), shape (P, 3).

    Returns:
        (work [J], min_margin [m]), each shape (P,); an individual whose legs cannot
        reach its targets gets work = inf and margin = −inf.
    """
    pop = np.atleast_2d(np.asarray(population, dtype=float))
    walk = _solve(
        spec,
        Timeline.of(params),
        params.slope,
        pop[:, 0],
        pop[:, 1],
        pop[:, 2],
        strict=False,
        light=True,
    )
    work, margin = walk["work"].sum(axis=1), walk["margin"].min(axis=1)
    bad = ~np.isfinite(work) | ~np.isfinite(margin)
    return np.where(bad, np.inf, work), np.where(bad, -np.inf, margin)


def _solve(spec, timeline, slope, hip_height, lift, tilt, *, strict, light=False) -> dict:
    """The pipeline for P parameter sets at once; every array gets a leading P axis."""
    P, n = hip_height.size, timeline.t.size
    chain = Chain.from_spec(spec)
    gravity = gravity_in_slope(slope)

    def col(x):  # one value per individual, as a column (P, 1)
        return np.asarray(x, dtype=float).reshape(P, 1)

    def flat(a):  # (n,) or (P, n) → the flat batch of P·n samples
        return np.broadcast_to(a, (P, n)).reshape(-1)

    zeros = np.zeros((P, n))

    stance = flat(timeline.stance)
    lean = timeline.tilt_shape.scaled(col(tilt))
    towards_swing = np.where(timeline.stance == RIGHT, 1.0, -1.0)  # +1: swing hip at +y
    z_swing = tilted_plane_height(
        timeline.lift_shape.scaled(col(lift)), towards_swing * spec.hip_width, lean
    )
    pelvis = Curve(col(hip_height) - spec.ankle_height + zeros, zeros, zeros)
    hip_w = tilted_plane_height(pelvis, towards_swing * spec.hip_width / 2, lean)
    hip_u, sx = timeline.hip_x, timeline.swing_x
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
            two_link_ik(target, spec.shank, spec.thigh, t_flat, strict=strict)
            for target in (stance_target, swing_target)
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

    feet_y = footprint_y(timeline, spec.hip_width, col(tilt)[:, 0])  # (P, N)
    step = np.minimum(timeline.step, timeline.steps - 1)
    stance_sole = np.stack(
        [flat(timeline.stance_x), feet_y[:, step].reshape(-1), np.zeros(P * n)], axis=1
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
    heel, toe, half = spec.heel_offset, spec.ankle_to_toe, spec.foot_width / 2
    polygon = support_polygon(
        foot_corners(stance_sole, heel, toe, half),
        foot_corners(swing_sole, heel, toe, half),
        double,
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


def _spec_dict(spec: RobotSpec) -> dict:
    d = asdict(spec)
    d["links"] = {k: asdict(v) for k, v in spec.links.items()}
    return d
