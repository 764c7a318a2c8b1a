"""Plan a walk: splines → IK → Newton-Euler → ZMP, support polygon, margin, work.

``plan_walk(spec, params)`` returns a ``Plan`` of time series for one walk;
``evaluate(spec, params, population)`` scores a whole GA population. Both run
the same compiled kernel (``planner/kernel``); ``planner/reference.py`` is the
readable numpy pipeline a test holds it equal to.

Where the GA's scores are exact: ``evaluate`` samples the walk at ``params.dt``
plus both one-sided limits of every phase change (the last DSP and the first SSP
sample at the same instant) and refines the margin at every local minimum between
samples, so its minimum margin is that of the continuous walk, never above the
margin of a finer plan of the same gait.

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

import io
import json
import os
import sys
import time
import tracemalloc
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace

import numpy as np

from slopewalk.planner.errors import GaitError, SlopewalkError, UnreachableError
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.joints import JOINT_NAMES, stance_swing_to_left_right
from slopewalk.planner.kernel import sample as sm
from slopewalk.planner.kernel.run import kernel_walk
from slopewalk.planner.kinematics import GRAVITY
from slopewalk.planner.sole import outline
from slopewalk.planner.spec import RobotSpec
from slopewalk.planner.trajectory import Timeline
from slopewalk.planner.verdict import predict


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
        polygon: Support polygon vertices, counter-clockwise [m], (n, 2M, 2) for a sole of M
            vertices (``sole.outline``: 4 for the rectangle), repeats allowed.
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
            "beyond_robot": self.beyond_robot(),
        }

    def ground_pull(self) -> str | None:
        """Why this walk's ZMP, margin and friction ratio do not exist, or None.

        A foot on the plane can only push (a unilateral contact). Where the planned
        ground force normal to the plane is <= 0 the walk asks the ground to pull: the
        robot would leave it. The ZMP and |F_t|/F_n divide by that normal force, so there
        they are numbers without a physical meaning (at 0.2 s steps a margin of -68 m, a
        friction ratio of inf). For the nominal gait this starts below about 0.33 s steps.
        """
        normal = self.ground_force[:, 2]
        if normal.min() > 0:
            return None
        first, worst = int(np.argmax(normal <= 0)), int(np.argmin(normal))
        weight = self.spec.total_mass * GRAVITY
        return (
            f"the walk asks the ground to pull: from t = {self.t[first]:.3f} s the planned "
            f"force normal to the plane falls to {normal[worst] / weight:.2f} x the robot's "
            f"weight (t = {self.t[worst]:.3f} s), but a foot can only push, so the robot would "
            "leave the ground and its ZMP, margin and friction ratio do not exist there "
            "(a longer step time asks less)"
        )

    def beyond_robot(self) -> list[str]:
        """The physical limits of the robot this walk passes, one line each (none: []).

        - the ground would have to pull (``ground_pull``);
        - a joint needs more torque than the spec's servo gives at stall (its [servo]
          ``stall_torque``): that servo cannot make the walk (the bench's ``stiff``
          actuators have their own limit and may still play it);
        - the ZMP leaves the support polygon by more than the robot is tall (ankle height
          + thigh + shank, the highest its CoM can be): the normal force is then a small
          share of the weight and the margin is no distance a foot could tip over.
        """
        notes = [pull] if (pull := self.ground_pull()) is not None else []
        peak = np.abs(self.tau).max(axis=0)
        j, stall = int(np.argmax(peak)), self.spec.stall_torque
        if peak[j] > stall:
            notes.append(
                f"{JOINT_NAMES[j]} needs {peak[j]:.3g} N m, {peak[j] / stall:.3g} x the servo's "
                f"stall torque {stall:g} N m ({self.spec.name} [servo]): that servo cannot "
                "make this walk"
            )
        height = self.spec.ankle_height + self.spec.leg_reach
        if pull is None and -self.margin.min() > height:
            weight = self.spec.total_mass * GRAVITY
            notes.append(
                f"the ZMP leaves the support by {-self.margin.min():.3g} m, more than the "
                f"robot is tall ({height:.3g} m): the ground carries as little as "
                f"{self.ground_force[:, 2].min() / weight:.2f} x its weight, and the margin "
                "is no distance a foot could tip over"
            )
        return notes

    def save_npz(self, file) -> None:
        """Write the series and a ``meta`` JSON string (spec and gait parameters).

        Args:
            file: A path or a binary file object (``np.savez_compressed`` target).
        """
        meta = {
            "params": asdict(self.params)
            | {"tilt_profile": self.params.lean_profile, "sway_share": self.params.lean_share},
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
        GaitError: a length no pose of ``spec`` reaches (``GaitParams.check_fits``).
        UnreachableError: the hip height or lift asks a leg for more than it reaches.
    """
    params.check_fits(spec)
    timeline = Timeline.of(params)
    walk = kernel_walk(spec, timeline)
    rows = walk.series(params.slope, columns(params, gait_row(params)))[0]
    _check_reach(spec, timeline.t, rows[:, sm.LEG_DISTANCE : sm.LEG_DISTANCE + 2])

    def cols(start, width, shape=()):
        return np.ascontiguousarray(rows[:, start : start + width]).reshape((-1, *shape))

    power = rows[:, sm.POWER_JOINTS : sm.POWER_JOINTS + 8]
    vertices = 2 * len(outline(spec))  # the support polygon's: each sole vertex twice
    series = {
        "t": timeline.t.copy(),
        "q": cols(sm.Q, 8, (8,)),
        "qd": cols(sm.QD, 8, (8,)),
        "qdd": cols(sm.QDD, 8, (8,)),
        "tau": cols(sm.TAU, 8, (8,)),
        "zmp": cols(sm.ZMP, 2, (2,)),
        "zmp_lipm": cols(sm.ZMP_LIPM, 2, (2,)),
        "cop_ne": cols(sm.COP, 2, (2,)),
        "com": cols(sm.COM, 3, (3,)),
        "com_acc": cols(sm.COM_ACC, 3, (3,)),
        "stance": timeline.stance.copy(),
        "double_support": ~timeline.in_ssp,
        "stance_sole": cols(sm.STANCE_SOLE, 3, (3,)),
        "swing_sole": cols(sm.SWING_SOLE, 3, (3,)),
        "polygon": cols(sm.POLYGON, 2 * vertices, (vertices, 2)),
        "margin": rows[:, sm.MARGIN].copy(),
        "ground_force": cols(sm.GROUND, 3, (3,)),
        "stance_force": cols(sm.STANCE_FORCE, 3, (3,)),
        "swing_force": cols(sm.SWING_FORCE, 3, (3,)),
        "friction_ratio": rows[:, sm.FRICTION].copy(),
        "work": np.trapezoid(power, timeline.t, axis=0),
    }
    return Plan(params=params, spec=spec, **series)


# A walk longer than this (100 s of walk at 1 ms) is measured before it is planned: its
# size and time are said first, and it is refused when it cannot fit in memory. Below it
# a plan takes a few seconds and a few hundred MB, and measuring would cost more than it tells.
LARGE_WALK_SAMPLES = 100_000
PROBE_STEP_TIME = 1.0  # [s] the probe walk: one step of the same gait, at most this long


@dataclass(frozen=True)
class Cost:
    """What a run will take, measured on a short probe of it and scaled by samples.

    Attributes:
        samples: Samples of the walk.
        bytes: Peak memory the run allocates [B] (the probe's peak per sample, traced).
        seconds: Wall time [s] (the probes' fixed part and their part per sample).
        available: Memory the machine has available now [B].
    """

    samples: int
    bytes: float
    seconds: float
    available: float

    def line(self, what: str) -> str:
        return (
            f"{what}: {self.samples:,} samples, about {self.bytes / 1e9:.2g} GB of memory "
            f"({self.available / 1e9:.3g} GB available) and {self.seconds:.0f} s"
        )

    def check(self, what: str) -> None:
        """Raise when the run would not fit in the memory available, in one line."""
        if self.bytes > self.available:
            raise GaitError(
                f"{self.line(what)}: does not fit in memory ({self.bytes / self.samples:,.0f} B "
                "per sample, measured on a one-step walk): fewer steps, shorter steps or a "
                "longer dt"
            )


def available_memory() -> float:
    """Memory available to a new allocation now [B]: Linux's MemAvailable (free memory
    and the page cache it may drop), else the free physical pages (``os.sysconf``)."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024
    except OSError:
        pass
    return float(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))


def measure_cost(run: Callable[[GaitParams], object], params: GaitParams) -> Cost:
    """The ``Cost`` of ``run(params)``, measured on probes of the same gait of one and two
    steps (each step at most ``PROBE_STEP_TIME`` long): one run to load what a first run
    loads (the compiled kernel, the simulator), one of each timed (time: the fixed part and
    the part per sample, from the two), then the two-step one traced (memory: its peak per
    sample, which the fixed part only makes larger)."""
    short = replace(params, steps=1, step_time=min(params.step_time, PROBE_STEP_TIME))
    long = replace(short, steps=2)
    run(short)
    seconds = []
    for probe in (short, long):
        start = time.perf_counter()
        run(probe)
        seconds.append(time.perf_counter() - start)
    per_sample = max(seconds[1] - seconds[0], 0.0) / (long.samples - short.samples)
    per_sample = per_sample or seconds[1] / long.samples
    fixed = max(seconds[0] - per_sample * short.samples, 0.0)
    tracing = tracemalloc.is_tracing()
    if not tracing:
        tracemalloc.start()
    tracemalloc.reset_peak()
    base = tracemalloc.get_traced_memory()[0]
    try:
        run(long)
        peak = tracemalloc.get_traced_memory()[1] - base
    finally:
        if not tracing:
            tracemalloc.stop()
    return Cost(
        params.samples,
        peak * params.samples / long.samples,
        fixed + per_sample * params.samples,
        available_memory(),
    )


def say_on_stderr(line: str) -> None:
    """A command's note before a long run (stderr: the output files stay the results)."""
    print(line, file=sys.stderr, flush=True)


def plan_checked(
    spec: RobotSpec, params: GaitParams, *, say: Callable[[str], object] = say_on_stderr
) -> tuple[Plan, list[str]]:
    """``plan_walk`` for a command: a large walk (``LARGE_WALK_SAMPLES``) has its size and
    time said through ``say`` first and is refused when it cannot fit in memory; a walk
    the ground would have to pull is refused (``Plan.ground_pull``). Returns the plan and
    the other limits of the robot it passes (``Plan.beyond_robot``).

    Raises:
        GaitError: too large for the memory available, or the ground would have to pull.
    """
    if params.samples > LARGE_WALK_SAMPLES:
        params.check_fits(spec)
        cost = measure_cost(lambda p: _planned_and_judged(spec, p), params)
        cost.check("plan")
        say(cost.line("plan"))
    plan = plan_walk(spec, params)
    return plan, refuse_pull(plan)


def refuse_pull(plan: Plan) -> list[str]:
    """``plan.beyond_robot()``, or GaitError when the ground would have to pull."""
    pull = plan.ground_pull()
    if pull is not None:
        raise GaitError(pull)
    return plan.beyond_robot()


def _planned_and_judged(spec: RobotSpec, params: GaitParams) -> None:
    """What ``slopewalk plan`` computes: the plan, its predicted events, its npz file."""
    plan = plan_walk(spec, params)
    predict(plan, friction=np.inf)
    plan.save_npz(io.BytesIO())


def _check_reach(spec: RobotSpec, t: np.ndarray, distance: np.ndarray) -> None:
    """Raise on the first sample where a leg (stance first, then swing) cannot reach."""
    lo, hi = spec.leg_shortest, spec.leg_reach
    for leg in (0, 1):
        d = distance[:, leg]
        bad = (d >= hi) | (d <= lo)
        if np.any(bad):
            i = int(np.argmax(bad))
            raise UnreachableError(
                f"unreachable hip target at t = {t[i]:.4f} s: hip-ankle "
                f"distance {d[i]:.4f} m, the leg reaches ({lo:.4f}, {hi:.4f}) m"
            )


def gait_row(params: GaitParams) -> np.ndarray:
    """The six kernel columns of one gait, shape (1, 6): (Hz [m], Szmax [m], tilt [rad],
    pelvis offset δ [m], step length L [m], sway share w [-])."""
    return np.array(
        [[params.hip_height, params.swing_lift, params.tilt, params.pelvis_offset,
          params.step_length, params.lean_share]]
    )  # fmt: skip


def columns(params: GaitParams, population) -> np.ndarray:
    """A population as the kernel's six columns, shape (P, 6).

    Rows of 3 (Hz, Szmax, tilt: the paper family) get ``params``' δ, L and w; rows of 6
    are taken as they are.

    Raises:
        SlopewalkError: any other shape.
    """
    pop = np.atleast_2d(np.asarray(population, dtype=float))
    if pop.ndim != 2 or pop.shape[1] not in (3, 6):
        raise SlopewalkError(
            f"population of shape {pop.shape}: must be (P, 3) (Hz, Szmax, tilt) or (P, 6) "
            "(and pelvis offset, step length, sway share)"
        )
    if pop.shape[1] == 6:
        return np.ascontiguousarray(pop)
    extra = [params.pelvis_offset, params.step_length, params.lean_share]
    return np.column_stack([pop, np.broadcast_to(extra, (len(pop), 3))])


def score(spec: RobotSpec, params: GaitParams, population, **contact):
    """Work, minimum ZMP margin and joint-limit gap of every individual of a population.

    Args:
        spec: The robot.
        params: Step time, slope, steps, sampling (its Hz, lift and tilt are ignored;
            its δ, L and w too for rows of 6).
        population: Rows (hip_height [m], swing_lift [m], tilt [rad]) of the paper
            family, shape (P, 3), at ``params``' pelvis offset, step length and sway
            share; or rows (…, pelvis_offset [m], step_length [m], sway_share [-]) of
            the extended family, shape (P, 6) (``columns``).

    Returns:
        (work [J], min_margin [m], joint_gap [rad]), each shape (P,). The margin is the
        continuous walk's (module doc); the gap is the worst excursion of a pitch joint
        (q2..q7) past its limit over the samples (≤ 0 inside the limits). An individual
        whose legs cannot reach its targets gets work = inf, margin = −inf, gap = inf.
        With ``contact`` (``KernelWalk.scores``'s contact=True, limits, loaded) also the
        largest friction ratio [-] and planned slide of a loaded foot [m], each (P,).
    """
    walk = kernel_walk(spec, Timeline.of(params))
    return walk.scores(params.slope, columns(params, population), **contact)


def evaluate(spec: RobotSpec, params: GaitParams, population) -> tuple[np.ndarray, np.ndarray]:
    """Work [J] and minimum ZMP margin [m] of every individual (``score`` without the gap)."""
    work, margin, _ = score(spec, params, population)
    return work, margin


def _spec_dict(spec: RobotSpec) -> dict:
    return spec.as_dict()
