"""Where the simulated CoP leaves the analytic ZMP: the error of a slow flat walk by phase.

``cop_error_report(spec)`` plays flat ground at 2 s steps (μ 1, 4 steps) and writes
markdown that takes the CoP − ZMP distance (``trial.compare``'s, over the samples
where the robot stands) apart:

* by phase window (``phase_windows``): the first and last ``WINDOW`` of each single
  support (after lift-off, before touch-down), the first ``WINDOW`` of each double
  support that starts with a touch-down, and the rest of each phase; per window its
  share of the samples, RMS, max and share of the mean square (the windows partition
  the samples, so the shares add up to the total);
* the cases: ``stiff`` (positions only), ``stiff`` with the floor's give and sink fed
  forward (``playback.floor_feedforward``, no torque), ``stiff_ff`` (torque, give and sink:
  the swing sole lands at the planned touch-down, ``slopewalk.bench.sim.touchdown``), ``stiff_ff``
  with the give fed forward but not the sink, and ``stiff_ff`` with its ankles aimed as
  on a rigid floor (torque only); per case each swing foot's first contact against the
  planned touch-down and its normal velocity there (``support.touch_downs``), and the
  unplanned support split into foot-time touching while planned lifted and lifted while
  planned down, the latter on the landing and the unloading foot of each double support;
* the servo's sag in ``stiff``: the stance leg's joints late in single support lag their
  command by (τ + kv q̇) / kp, which a positions-only mode keeps (``stiff_ff`` feeds it
  forward);
* what ``stiff``'s and ``servo_ff``'s commands lack, term by term (``command_terms``);
* the plan's own ZMP jumps at the phase changes (its lean's cubic changes λ̈ there);
* the soft contact: the same walks with MuJoCo's contact time constant (``solref``,
  0.02 s by default) and time step made smaller (a stiffer floor, finer steps);
* double support: how far the plan moves its rear sole sideways there
  (``planner.verdict``'s ``foot_slide``), how far the simulated foot slides, and the
  share of the double support that foot spends at the friction limit.
"""

from __future__ import annotations

import numpy as np

from slopewalk.bench.experiments.cop_error.command_terms import friction_section, ladder_section
from slopewalk.bench.experiments.cop_error.flat_walk import (
    FRICTION,
    STEP_TIME,
    STEPS,
    Case,
    run_case,
)
from slopewalk.bench.experiments.cop_error.landing import landing_section
from slopewalk.bench.sim.support import touch_downs
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.joints import LEFT
from slopewalk.planner.plan import Plan, plan_walk
from slopewalk.planner.spec import RobotSpec

WINDOW = 0.05  # [s] the transient after / before a phase change
# (actuator mode, the floor fed forward (None: as the mode does), label); the floor's
# feedforward: "rigid" none, "give" the ankles' turns, "sink" the give and the sink
CASES = (
    ("stiff", None, "stiff"),
    ("stiff", "sink", "stiff, the floor's give and sink fed forward"),
    ("stiff_ff", None, "stiff_ff"),
    ("stiff_ff", "give", "stiff_ff, the give fed forward, not the sink"),
    ("stiff_ff", "rigid", "stiff_ff, ankles aimed as on a rigid floor"),
)
# (solref time constant [s], time step [s]); MuJoCo keeps the time constant ≥ 2 steps
CONTACTS = ((0.02, 0.001), (0.02, 0.00025), (0.01, 0.0005), (0.005, 0.00025), (0.002, 0.00025))
WINDOWS = (
    "single support, first 50 ms",
    "single support, middle",
    "single support, last 50 ms",
    "double support, first 50 ms after touch-down",
    "double support, rest",
)


def phase_windows(plan: Plan, t: np.ndarray) -> np.ndarray:
    """Index into ``WINDOWS`` of each time ``t`` [s] of the walk, (m,)."""
    idx = np.clip(np.searchsorted(plan.t, t), 0, plan.t.size - 1)
    double = plan.double_support[idx]
    change = plan.t[np.flatnonzero(np.diff(plan.double_support.astype(int))) + 1]
    k = np.searchsorted(change, t, side="right")  # changes at or before t
    since = np.where(k > 0, t - change[np.maximum(k - 1, 0)], np.inf)
    until = np.where(k < change.size, change[np.minimum(k, change.size - 1)] - t, np.inf)
    window = np.where(since < WINDOW, 0, np.where(until < WINDOW, 2, 1))
    return np.where(double, np.where(since < WINDOW, 3, 4), window)


def by_window(case: Case, plan: Plan) -> list[tuple[str, float, float, float, float]]:
    """(window, share of samples, RMS [m], max [m], share of the mean square) per window."""
    s = case.result.series
    standing = s["standing"]
    t = s["t"][standing]
    distance = np.hypot(*(s["cop"] - s["zmp_analytic"]).T)[standing]
    window = phase_windows(plan, t)
    total = np.sum(distance**2)
    rows = []
    for w, name in enumerate(WINDOWS):
        d = distance[window == w]
        if d.size:
            rms = float(np.sqrt(np.mean(d**2)))
            rows.append((name, d.size / t.size, rms, float(d.max()), np.sum(d**2) / total))
    return rows


def zmp_jumps(plan: Plan) -> tuple[float, float, float]:
    """Largest jump of the planned ZMP at a lift-off and at a touch-down, and the
    median change from one sample to the next elsewhere [m]."""
    step = np.hypot(*np.diff(plan.zmp, axis=0).T)
    change = np.diff(plan.double_support.astype(int))
    lift = step[change == -1].max()
    touch = step[change == 1].max()
    return float(lift), float(touch), float(np.median(step[change == 0]))


def double_support_slide(plan: Plan, case: Case) -> tuple[float, float, float]:
    """(planned rear-sole slide, simulated slide of that foot [m], share of the double
    support that foot spends at the friction limit), the largest over the double supports
    that start with a touch-down."""
    rec, s = case.recording, case.recording.sensors
    planned, simulated, limited = 0.0, 0.0, []
    dsp = (1 - plan.params.ssp_fraction) * plan.params.step_time
    for k in range(1, plan.params.steps):
        start = k * plan.params.step_time
        in_plan = (plan.t >= start) & (plan.t < start + dsp)
        planned = max(planned, np.ptp(plan.swing_sole[in_plan, 1]))
        rows = (rec.t >= start) & (rec.t < start + dsp)
        rear = 1 if plan.stance[np.flatnonzero(in_plan)[0]] == LEFT else 0
        simulated = max(simulated, np.ptp(s.sole[rows, rear, 1]))
        force = s.foot_force[rows, rear]
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = np.hypot(force[:, 0], force[:, 1]) / force[:, 2]
        limited.append(np.mean(ratio[force[:, 2] > 0] >= 0.99 * FRICTION))
    return float(planned), float(simulated), float(np.mean(limited))


# long: to be split once the actuator-mode work in this module has landed (issue 20)
def cop_error_report(spec: RobotSpec, *, command: str = "") -> str:
    """Markdown of the flat 2 s walk's CoP error, decomposed (module doc)."""
    plan = plan_walk(spec, GaitParams.nominal(spec, STEP_TIME, steps=STEPS))
    cases = [run_case(plan, mode, label, floor_ff=ff) for mode, ff, label in CASES]
    lines = ["# CoP error on flat ground: where the simulated CoP leaves the analytic ZMP", ""]
    if command:
        lines += [f"Written by `{command}`.", ""]
    lines += [
        f"Flat ground, {STEP_TIME:g} s steps, μ {FRICTION:g}, {STEPS} steps, 1 ms; the distance "
        "of `slopewalk trial` (simulated CoP vs analytic ZMP while the robot stands). "
        "Module doc of `bench/experiments/cop_error/report.py` for each quantity.",
        "",
        "| case | RMS [mm] | max [mm] | unplanned support [s] (touching / lifted) | first "
        "contact vs planned touch-down [ms] | normal velocity there [mm/s] | joint tracking [°] |",
        "|---|---|---|---|---|---|---|",
    ]
    for c in cases:
        early, speed = touch_downs(plan, c.recording)
        r = c.result
        lines.append(
            f"| {c.label} | {r.zmp_rms * 1e3:.2f} | {r.zmp_max * 1e3:.1f} | "
            f"{r.unplanned_support_s:.3f} ({r.unplanned_contact_s:.3f} / "
            f"{r.missed_contact_s:.3f}) | {np.nanmean(early) * 1e3:+.0f} | "
            f"{np.nanmean(speed) * 1e3:+.1f} | {np.rad2deg(r.tracking_rms):.2f} |"
        )
    fed, plain = cases[2], cases[0]
    lost = [e.time for e in fed.result.events if e.kind in ("tip", "fall", "diverged")]
    lines += landing_section(plan, fed.recording, min(lost, default=np.inf), plain.recording)
    late = {c.label: {n: r for n, _, r, _, _ in by_window(c, plan)} for c in cases[2:4]}
    on_time, early = (late[c.label] for c in cases[2:4])
    lines += [
        "",
        f"Against {cases[3].label}, landing on time moves error out of the last 50 ms before "
        f"touch-down ({early[WINDOWS[2]] * 1e3:.2f} → {on_time[WINDOWS[2]] * 1e3:.2f} mm) into "
        f"the double support ({early[WINDOWS[4]] * 1e3:.2f} → {on_time[WINDOWS[4]] * 1e3:.2f} "
        f"mm; RMS {cases[3].result.zmp_rms * 1e3:.2f} → {fed.result.zmp_rms * 1e3:.2f} mm), and "
        f"its unplanned support from touching early to a landing foot in the air "
        f"({cases[3].result.unplanned_support_s:.3f} → {fed.result.unplanned_support_s:.3f} s).",
    ]
    for c in cases:
        lines += [
            "",
            f"## {c.label}: by phase",
            "",
            "| window | share of samples | RMS [mm] | max [mm] | share of the mean square |",
            "|---|---|---|---|---|",
        ]
        lines += [
            f"| {name} | {share:.1%} | {rms * 1e3:.2f} | {peak * 1e3:.1f} | {part:.0%} |"
            for name, share, rms, peak, part in by_window(c, plan)
        ]
    lines += ladder_section(plan)
    lines += friction_section(spec)
    lift, touch, typical = zmp_jumps(plan)
    lines += [
        "",
        "## The plan's ZMP at the phase changes",
        "",
        f"The planned ZMP jumps {touch * 1e3:.1f} mm at a touch-down and {lift * 1e3:.1f} mm "
        f"at a lift-off (elsewhere it moves {typical * 1e3:.2f} mm per 1 ms sample): the lean's "
        "cubic of the double support starts and ends with λ̈ = ±6·(2 tilt)/T_dsp², held at 0 "
        "through the single support, and the ZMP follows the accelerations. The simulated "
        "CoP cannot jump with it (finite servo and floor bandwidth); the first 50 ms after "
        "each change above hold that lag.",
    ]
    lines += [
        "",
        "## A stiffer contact and a finer time step (stiff_ff)",
        "",
        "| solref time constant [s] | time step [ms] | RMS [mm] | single support, middle | "
        "last 50 ms before touch-down | double support, rest | unplanned support [s] |",
        "|---|---|---|---|---|---|---|",
    ]
    for timeconst, timestep in CONTACTS:
        c = run_case(plan, "stiff_ff", "", timeconst=timeconst, timestep=timestep)
        rms = {name: r for name, _, r, _, _ in by_window(c, plan)}
        lines.append(
            f"| {timeconst:g} | {timestep * 1e3:g} | {c.result.zmp_rms * 1e3:.2f} | "
            f"{rms[WINDOWS[1]] * 1e3:.2f} | {rms[WINDOWS[2]] * 1e3:.2f} | "
            f"{rms[WINDOWS[4]] * 1e3:.2f} | {c.result.unplanned_support_s:.3f} |"
        )
    planned, simulated, limited = double_support_slide(plan, cases[2])
    lines += [
        "",
        "A stiffer floor takes the give away (single support converges), but the double "
        "support gets worse, not better: it is not the floor's compliance there.",
        "",
        "## Double support: the plan moves a loaded foot",
        "",
        f"The 8 joints have no hip roll, so the legs stay parallel and perpendicular to the "
        f"pelvis in the frontal plane, and two flat feet fix the lean: cos λ = hip width / "
        f"feet separation. The plan changes the lean in every double support and moves its "
        f"rear sole sideways by up to {planned * 1e3:.1f} mm to allow it; in MuJoCo the feet "
        f"stick, the loops fight, and that foot slides {simulated * 1e3:.1f} mm, at the "
        f"friction limit {limited:.0%} of the double support ({cases[2].label}). What the "
        "CoP does there follows that fight, not the plan's motion, and no command of this "
        "robot removes it without changing the planned motion.",
    ]
    return "\n".join(lines) + "\n"
