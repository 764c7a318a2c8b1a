"""The paper's claims, each checked analytically and in simulation; the confusion table.

``write_report(out, rows, specs, trials)`` turns a sweep's rows (``sweep.csv``) into
``claims.md``, ``confusion.md`` and the figures of ``figures.py``. Where a claim
needs more than the sweep holds (a trace, a torque split, the GA cases) it plans
(no simulation), takes the walks ``experiments.claim_trials`` played, or reads the GA
results written by ``slopewalk optimize`` into ``results/optimize/``.

The report describes exactly the table it is given: one section per robot (the
table's ``robot`` column) when the table holds another robot than the paper's, and
each claim only where that robot's rows hold the cases it needs (e.g. the slope claim
needs t_c = 1 s, μ = 1, stiff at 0°, 15°, 18°, 22.5°, 25° and 30°); else its row says
``not in this sweep`` and which cases are missing, and quotes no number.

Numbers are written at fixed precision (never ``%g`` of a computed value, whose
digits follow floating-point noise: a ZMP shift of 1.39e-13 mm is 0.0000 mm), and
the sweep's values come from ``sweep.csv`` as written (``tables/sweep.py``), so a
regenerated report has the same bytes when nothing changed.
"""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from slopewalk.bench.actuators import DEFAULT_MODE
from slopewalk.bench.files import atomic_path
from slopewalk.bench.report import claim_axes as ax
from slopewalk.bench.report import figures
from slopewalk.bench.sim.model import servo_settings
from slopewalk.bench.tables.sweep import SIMULATED_VERDICTS
from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import Plan, plan_walk
from slopewalk.planner.spec import RobotSpec
from slopewalk.planner.verdict import PAPER_VERDICTS

NOMINAL_STEP_TIME = 1.0  # [s]
SIM_VERDICTS = SIMULATED_VERDICTS  # the sweep table's, "error" included
DEFAULT_ROBOT = "default"  # the sweep table's ``robot`` for the paper's biped
NOT_IN_SWEEP = "not in this sweep"
STEP_TIME_CASES = (0.5, 0.4)  # [s], flat, μ = 1: the step-time claim's
SLOPE_CASES = (0.0, 15.0, 18.0, 22.5, 25.0, 30.0)  # [deg], t_c = 1 s, μ = 1: the slope claim's
DEFAULT_SOURCE = "the default sweep, `bench/experiments/sweeps/paper.toml`"


def robots(rows) -> list[str]:
    """The table's robots (its ``robot`` column), in the order of their first row."""
    return list(dict.fromkeys(r.get("robot", DEFAULT_ROBOT) for r in rows))


def _missing(line: list[dict], key: str, needed) -> list[float]:
    """The values of ``needed`` that no row of ``line`` has as ``key``."""
    have = {r[key] for r in line}
    return [v for v in needed if v not in have]


def _absent(claim: str, paper: str, needs: str, evidence: str = "-") -> dict:
    """A claim whose cases this sweep does not hold: no number, the cases it needs."""
    return _claim(
        claim, paper, f"{NOT_IN_SWEEP}: needs {needs}", "-", NOT_IN_SWEEP, evidence, "-", "-"
    )


def _line(rows, **where) -> list[dict]:
    """Rows matching ``where`` (no mass scaling, the default actuators unless asked), sorted."""
    where = {"mass_scale": "", "actuators": DEFAULT_MODE, **where}
    out = [r for r in rows if all(r.get(k) == v for k, v in where.items())]
    return sorted(out, key=lambda r: (r["step_time"], r["slope_deg"]))


def _fmt_list(values) -> str:
    return ", ".join(f"{v:g}" for v in values) or "none"


def _yes(analytic: bool | None, simulated: bool | None) -> str:
    """The agree cell: whether the analytic and the simulated result bear the claim out."""
    word = {True: "yes", False: "no", None: "-"}
    return f"analytic {word[analytic]}, simulated {word[simulated]}"


def _claim(claim, paper, analytic, simulated, agree, evidence, axes_text, basis) -> dict:
    """One row. ``axes_text``: the smallest lateral and sagittal margins of the walks the
    row is about (``claim_axes.axes``); ``basis``: what the finding rests on
    (``claim_axes.BASIS`` words)."""
    return {
        "claim": claim,
        "paper": paper,
        "analytic": analytic,
        "simulated": simulated,
        "agree": agree,
        "evidence": evidence,
        "axes": axes_text,
        "basis": basis,
    }


def _nominal(spec: RobotSpec, step_time: float, slope_deg: float = 0.0, rows=None) -> Plan:
    """The nominal gait's plan (the sweep's steps of that case when ``rows`` hold it)."""
    steps = next((int(r["steps"]) for r in rows or [] if r.get("steps")), None)
    extra = {"steps": steps} if steps else {}
    return plan_walk(
        spec, GaitParams.nominal(spec, step_time, slope=np.deg2rad(slope_deg), **extra)
    )


STEP_TIME_CLAIM = (
    "flat ground: stable down to 0.5 s, not at 0.4 s",
    "stable for t_c ≥ 0.5 s; ZMP almost entirely outside at 0.4 s",
)
SLOPE_CLAIM = (
    "slopes: inside up to 15°, towards the rear at 18° and 22.5°, outside beyond 22.5°",
    "inside ≤ 15°; rear edge at 18°, 22.5°; outside > 22.5°",
)


def _walked(row) -> bool:
    """Whether a sweep row's robot walked the plan: the strict verdict (``walk``) where the
    table has it, else (a table written before it) the balance verdict ``stable``."""
    return row.get("walk", "walked" if row["simulated_verdict"] == "stable" else "") == "walked"


def _strict(line: list[dict], walked: list, what: str, unit: str) -> str:
    """The claims' "walks": the strict verdict's cases, and what stopped the others that
    kept their balance (``walk`` column), e.g. "walked the plan at 2 s (strict; 1 s
    overload)"."""
    if "walk" not in line[0]:
        return "strict walk verdict not in this table"
    key = "step_time" if what == "t_c" else "slope_deg"
    failed = [
        f"{r[key]:g}{unit} {r['walk']}"
        for r in line
        if r["simulated_verdict"] == "stable" and r["walk"] != "walked"
    ]
    return (
        f"walked the plan (strict verdict) at {what} = {_fmt_list(walked)}{unit * bool(walked)}"
        + (f" ({', '.join(failed)})" if failed else "")
    )


def step_time_claim(rows, spec: RobotSpec) -> dict:
    flat = _line(rows, slope_deg=0.0, friction=1.0)
    if missing := _missing(flat, "step_time", STEP_TIME_CASES):
        return _absent(
            *STEP_TIME_CLAIM,
            f"flat ground, μ = 1, stiff, t_c = {_fmt_list(STEP_TIME_CASES)} s "
            f"(missing {_fmt_list(missing)} s)",
        )
    ok_a = [r["step_time"] for r in flat if r["analytic_verdict"] == "stable"]
    ok_s = [r["step_time"] for r in flat if r["simulated_verdict"] == "stable"]
    ok_w = [r["step_time"] for r in flat if _walked(r)]
    by_t = {r["step_time"]: r for r in flat}
    plans = [(f"{t:g} s", _nominal(spec, t, 0.0, [by_t[t]])) for t in STEP_TIME_CASES]
    sagittal = {t: ax.axis_minima(p)[1] for t, (_, p) in zip(STEP_TIME_CASES, plans, strict=True)}
    front = sagittal[0.5] >= 0 > sagittal[0.4]
    decides = (
        "; the lateral limit decides every step time outside"
        if all(ax.decided_by(p) in ("lateral", "neither") for _, p in plans)
        else ""
    )

    def agrees(key, walks="stable"):
        return (
            by_t.get(0.5, {}).get(key, walks) == walks
            and by_t.get(0.4, {}).get(key, walks) != walks
        )

    return _claim(
        *STEP_TIME_CLAIM,
        f"ZMP inside the polygon at t_c = {_fmt_list(ok_a)} s; min margin at 0.5 s "
        f"{by_t.get(0.5, {}).get('analytic_min_margin_mm', float('nan')):.1f} mm"
        f"{decides}",
        f"no tip/slip/fall at t_c = {_fmt_list(ok_s)} s; {_strict(flat, ok_w, 't_c', ' s')} "
        "(μ = 1)",
        _yes(
            agrees("analytic_verdict"),
            agrees("walk", "walked") if "walk" in flat[0] else agrees("simulated_verdict"),
        )
        + f"; front to back: {'yes' if front else 'no'} (sagittal inside at 0.5 s, "
        "outside at 0.4 s)",
        "stability_map.png, sweep.csv (slope 0)",
        ax.labelled_axes(plans),
        f"lateral: {ax.SHAPE} (the lean is 12° at every step time, so its sway's "
        f"acceleration grows as 1/t_c²) and {ax.ESTIMATE} (the 60 mm foot width); "
        f"sagittal: {ax.PHYSICS}",
    )


def slope_claim(rows, spec: RobotSpec) -> dict:
    line = _line(rows, step_time=NOMINAL_STEP_TIME, friction=1.0)
    if missing := _missing(line, "slope_deg", SLOPE_CASES):
        return _absent(
            *SLOPE_CLAIM,
            f"t_c = {NOMINAL_STEP_TIME:g} s, μ = 1, stiff at slopes {_fmt_list(SLOPE_CASES)}° "
            f"(missing {_fmt_list(missing)}°)",
        )
    inside = [r["slope_deg"] for r in line if r["analytic_verdict"] == "stable"]
    stable = [r["slope_deg"] for r in line if r["simulated_verdict"] == "stable"]
    walked = [r["slope_deg"] for r in line if _walked(r)] if "walk" in line[0] else stable
    rear, plans = [], []
    by_slope = {r["slope_deg"]: r for r in line}
    for slope in (0.0, 15.0, 18.0, 22.5):
        plan = _nominal(spec, NOMINAL_STEP_TIME, slope, [by_slope[slope]])
        ssp = ~plan.double_support
        rear.append(
            f"{slope:g}°: {np.mean(plan.zmp[ssp, 0] - plan.stance_sole[ssp, 0]) * 1e3:+.1f}"
        )
        plans.append((f"{slope:g}°", plan))
    margins = {r["slope_deg"]: r["analytic_min_margin_mm"] for r in line}

    def word(ok):
        """yes: inside to 22.5° and not beyond; partly: inside to 15° and not beyond 22.5°."""
        if {15.0, 18.0, 22.5} <= set(ok) and not {25.0, 30.0} & set(ok):
            return "yes"
        return "partly" if 15.0 in ok and not {25.0, 30.0} & set(ok) else "no"

    return _claim(
        *SLOPE_CLAIM,
        f"inside at {_fmt_list(inside)}°; min margin at 18°: {margins[18.0]:.1f} mm, at 22.5°: "
        f"{margins[22.5]:.1f} mm; mean SSP ZMP x from the ankle [mm]: {'; '.join(rear)}",
        f"stable at {_fmt_list(stable)}°; {_strict(line, walked, 'slopes', '°')} (μ = 1)",
        f"analytic {word(inside)}, simulated {word(walked)}",
        "stability_map.png, zmp_traces.png, sweep.csv (t_c = 1 s)",
        ax.labelled_axes(plans[1:]),
        f"sagittal: {ax.PHYSICS} (gravity along the plane moves the ZMP back by c_z tan θs) "
        f"and {ax.SHAPE} (the hip spline holds the single-support ZMP ~20 mm ahead of the "
        "ankle on flat ground; crouching is the family's only sagittal knob)",
    )


MASS_CASES = (  # (mass_scale, claim, paper)
    ("all=10", "10× mass on every link leaves the ZMP unchanged", "ZMP trace unchanged"),
    ("legs=2", "doubling the swing-leg mass pushes the ZMP outside", "ZMP outside the polygon"),
)


def mass_claims(rows, spec: RobotSpec, mass_servo=None) -> list[dict]:
    """The paper's mass cases at t_c = 1 s on flat ground, each where the sweep holds it.

    ``mass_servo``: ``claim_trials.mass_servo_trials`` (the 10× robot in the spec-servo
    modes with its servo unscaled and scaled ×10), shown beside the sweep's stiff walk."""
    base = plan_walk(spec, GaitParams.nominal(spec, NOMINAL_STEP_TIME))
    nominal = _line(rows, step_time=NOMINAL_STEP_TIME, slope_deg=0.0)
    same = {r["friction"]: r["simulated_verdict"] for r in nominal}
    out = []
    for scale, claim, paper in MASS_CASES:
        sim = _line(rows, step_time=NOMINAL_STEP_TIME, slope_deg=0.0, mass_scale=scale)
        if not sim:
            out.append(
                _absent(
                    claim,
                    paper,
                    f"t_c = {NOMINAL_STEP_TIME:g} s on flat ground, stiff, with "
                    f"mass_scale {{{scale.replace('=', ' = ')}}}",
                )
            )
            continue
        group, factor = scale.split("=")
        plan = plan_walk(spec.with_mass_scale({group: float(factor)}), base.params)
        shift = np.hypot(*(plan.zmp - base.zmp).T).max() * 1e3
        sim_text = ", ".join(
            f"{r['simulated_verdict']} (μ {r['friction']:g}, RMS {r['zmp_rms_mm']:.1f} mm)"
            for r in sim
        )
        compared = all(r["friction"] in same for r in sim)  # the nominal masses at that μ
        basis = f"{ax.PHYSICS} (the ZMP of eq. (4) is invariant to a uniform mass scale)"
        if scale == "all=10":  # unchanged: same verdict as the nominal masses at that μ
            agree = _yes(
                shift < 1e-6,
                all(same[r["friction"]] == r["simulated_verdict"] for r in sim)
                if compared
                else None,
            )
            if mass_servo:
                sim_text += (
                    " (stiff); spec servo at 1 s, μ 1: " + ax.mass_servo_text(mass_servo) + ""
                )
                agree += (
                    "; with the servo scaled ×10 "
                    + ("yes" if ax.mass_servo_same(mass_servo) else "no")
                    + " (the nominal robot's walks exactly)" * ax.mass_servo_same(mass_servo)
                )
                basis += (
                    f"; simulated: {ax.ESTIMATE} (an unscaled servo is a weaker robot, not a "
                    "heavier one)"
                )
        else:  # pushed out: unstable where the nominal masses were stable
            agree = _yes(
                plan.margin.min() < 0 <= base.margin.min(),
                all(r["simulated_verdict"] != "stable" for r in sim),
            )
        out.append(
            _claim(
                claim,
                paper,
                f"max ZMP shift {shift:.4f} mm; min margin {plan.margin.min() * 1e3:.1f} mm "
                f"(nominal {base.margin.min() * 1e3:.1f} mm)",
                sim_text
                + (
                    "; both legs doubled: the swing leg is not a fixed body when the "
                    "stance alternates"
                    if scale == "legs=2"
                    else ""
                ),
                agree,
                "sweep.csv (mass_scale)",
                f"{scale.replace('=', ' × ')}: {ax.axes(plan)}; nominal: {ax.axes(base)}",
                basis
                if scale == "all=10"
                else f"{ax.PHYSICS} and {ax.ESTIMATE} (the legs' masses: the nominal gait "
                "has little lateral margin to lose)",
            )
        )
    return out


LIPM_CLAIM = (
    "LIPM matches the multibody ZMP at slow steps and diverges at fast ones",
    "near-identical at low acceleration; at short t_c the 8-DOF model is unstable while "
    "the LIPM still predicts stability",
)


def lipm_series(rows) -> tuple[list[float], list[float], list[float]]:
    """Step times [s] of the flat μ = 1 rows and their LIPM RMS distances [mm]:
    (step times, multibody ZMP to LIPM, simulated CoP to LIPM), fastest first."""
    flat = _line(rows, slope_deg=0.0, friction=1.0)
    return (
        [r["step_time"] for r in flat],
        [r.get("lipm_rms_mm", np.nan) for r in flat],
        [r.get("cop_lipm_rms_mm", np.nan) for r in flat],
    )


def lipm_claim(rows, spec: RobotSpec) -> dict:
    """LIPM vs multibody ZMP from the slowest to the fastest flat step of the sweep."""
    times, analytic, simulated = lipm_series(rows)
    if len(times) < 2:
        return _absent(
            *LIPM_CLAIM,
            f"flat ground, μ = 1, stiff at two step times or more (this sweep: "
            f"{_fmt_list(times)} s)",
        )
    text = ", ".join(f"{t:g} s: {a:.1f}" for t, a in zip(times, analytic, strict=True))
    grows = analytic[0] > 5 * analytic[-1]
    in_range, axes_text, split = ax.lipm_in_range(spec, times)
    below = [t for t in times if t < ax.PAPER_RANGE[0]]
    return _claim(
        *LIPM_CLAIM,
        f"RMS distance ZMP to LIPM [mm]: {text}; {in_range}"
        + (f" ({_fmt_list(below)} s lie below the paper's range)" if below else ""),
        "RMS distance CoP to LIPM [mm]: "
        + ", ".join(f"{t:g} s: {s:.1f}" for t, s in zip(times, simulated, strict=True)),
        _yes(grows and bool(split), None).split(",")[0]
        + " (judged over the paper's 2–0.5 s)"
        + (
            "; simulated CoP vs LIPM grows too"
            if simulated[0] > simulated[-1]
            else "; simulated CoP vs LIPM does not grow"
        ),
        "lipm_vs_step_time.png",
        axes_text,
        f"{ax.PHYSICS} (the LIPM leaves out the limbs' own accelerations)",
    )


TORQUE_CLAIM = (
    "stance joints carry more torque than swing joints",
    "stance-leg torques substantially higher",
)


def torque_claim(plan, result) -> dict:
    """Stance vs swing joint torques, as peaks and as RMS over the walk (mean of 4 joints)."""
    sim = result.series["actuator_force"]
    idx = np.clip(np.searchsorted(plan.t, result.series["t"]), 0, plan.t.size - 1)
    stance_right = (plan.stance[idx] == 1)[:, None]
    left, right = np.abs(sim[:, :4]), np.abs(sim[:, 4:])
    tau = np.abs(plan.tau)

    def text(stance, swing):
        return (
            f"peak {stance.max(axis=0).mean():.3f} vs {swing.max(axis=0).mean():.3f} N m, "
            f"RMS {_rms(stance):.3f} vs {_rms(swing):.3f} N m (stance vs swing)"
        )

    rotor = np.abs(plan.tau + servo_settings(plan.spec, DEFAULT_MODE).armature * plan.qdd)
    return _claim(
        *TORQUE_CLAIM,
        text(tau[:, :4], tau[:, 4:]),
        text(np.where(stance_right, right, left), np.where(stance_right, left, right))
        + "; the servos' reflected rotor inertia (armature, which the paper's Newton-Euler "
        "leaves out) dominates the fast swing leg: Newton-Euler + armature × q̈ gives "
        + text(rotor[:, :4], rotor[:, 4:])
        + "; simulated peaks are touch-down transients",
        _yes(
            _rms(tau[:, :4]) > _rms(tau[:, 4:]),
            _rms(np.where(stance_right, right, left)) > _rms(np.where(stance_right, left, right)),
        ),
        "joint_torques.png",
        f"nominal 1 s: {ax.axes(plan)}",
        f"analytic: {ax.PHYSICS}; simulated: {ax.ESTIMATE} (the armature is scaled from "
        "another servo)",
    )


def _rms(x: np.ndarray) -> float:
    """Mean over joints of each joint's RMS."""
    return float(np.sqrt(np.mean(x**2, axis=0)).mean())


def ga_claims(optimize_dir: str | Path, spec: RobotSpec, simulate: Callable) -> list[dict]:
    """The GA's 22.5° and 30° cases, from ``slopewalk optimize`` reports in ``optimize_dir``.

    ``simulate(report, spec)`` plays each report's best gait through the MuJoCo bench
    (``experiments.claim_trials.play_ga_best``): (what it did, walked or None).
    """
    reports = _optimize_reports(optimize_dir)
    if not reports:
        where = Path(optimize_dir).name
        return [
            _claim(
                "GA cases (22.5°, 30°)",
                "see below",
                f"not checked: no `slopewalk optimize` reports in `{where}/` beside this "
                f"report (this table reads the GA's results from there, e.g. `slopewalk "
                f"optimize --slope 22.5 --out {where}/slope22.5.json`; it plays none itself)",
                "-",
                "not checked: no GA results",
                "-",
                "-",
                "-",
            )
        ]

    played: dict[int, tuple[str, bool | None]] = {}

    def play(report):  # each report's gait is played once, however often it is cited
        if id(report) not in played:
            played[id(report)] = simulate(report, spec)
        return played[id(report)]

    out = []
    nominal = [(p, r) for p, r in reports if abs(r["foot_length_m"] - spec.foot_length) < 1e-9]
    at = {round(r["slope_deg"], 3): (p, r) for p, r in nominal}  # degrees pass through radians
    if 22.5 in at:
        out.append(_ga_claim_22_5(*at[22.5], play, optimize_dir, spec))
    if 30.0 in at:
        out.append(_ga_claim_30(*at[30.0], reports, spec, play, optimize_dir))
    return out


def _optimize_reports(optimize_dir: str | Path) -> list[tuple[Path, dict]]:
    """(path, report) of every ``slopewalk optimize`` report there, the best search last."""
    reports = []
    for path in sorted(Path(optimize_dir).glob("**/*.json")):
        data = json.loads(path.read_text())
        if isinstance(data, dict) and "best" in data and "slope_deg" in data:
            reports.append((path, data))
    # For each case the best search wins: feasible first, then the larger margin.
    reports.sort(
        key=lambda item: (
            item[1]["feasible"],
            item[1].get("evaluations", 0),
            item[1]["best"]["min_margin_m"],
        )
    )
    return reports


def _constraint(report: dict) -> str:
    return report.get("settings", {}).get("constraint", "penalty")


def _describe(report: dict) -> str:
    """A report's best gait in one line: feasibility, parameters, work, margin, constraint."""
    b = report["best"]
    return (
        f"{'feasible' if report['feasible'] else 'INFEASIBLE'}: Hz {b['hip_height_m']:.3f}"
        f" m, Szmax {b['swing_lift_m']:.3f} m, θ1max {-b['tilt_deg']:.2f}° (lean "
        f"{b['tilt_deg']:.2f}°), work "
        f"{b['work_J']:.3f} J, min margin {b['min_margin_m'] * 1e3:.1f} mm"
        + _fine_check(report)
        + f" [{_constraint(report)} constraint]"
    )


def _ga_claim_22_5(path: Path, r: dict, play: Callable, optimize_dir, spec) -> dict:
    """The paper's 22.5° case: the GA's gait and whether its ZMP stays inside."""
    return _claim(
        "GA at 22.5°: θ1max = −9.18°, Hz = 0.151 m, Szmax = 0.013 m, ZMP inside",
        "θ1max −9.18°, Hz 0.151 m, Szmax 0.013 m; ZMP inside",
        _describe(r),
        play(r)[0],
        _yes(r["feasible"], play(r)[1]),
        _relative(path, optimize_dir),
        _report_axes(r, spec),
        f"{ax.ESTIMATE} (foot, masses, joint limits: the gait found differs from the paper's)",
    )


def _report_axes(report: dict, spec: RobotSpec) -> str:
    """``claim_axes.axes`` of a ``slopewalk optimize`` report's best gait on its foot."""
    robot = spec.with_foot_length(report["foot_length_m"], extend="both")
    robot = replace(robot, ankle_to_toe=report["ankle_to_toe_m"])
    best = report["best"]
    gait = GaitParams.nominal(
        robot, report["step_time_s"], slope=np.deg2rad(report["slope_deg"]),
        steps=report.get("steps", 4), hip_height=best["hip_height_m"],
        swing_lift=best["swing_lift_m"], tilt=np.deg2rad(best["tilt_deg"]),
    )  # fmt: skip
    try:
        return ax.axes(plan_walk(robot, gait))
    except SlopewalkError as err:
        return f"not plannable at 1 ms ({err})"


def _ga_claim_30(
    path: Path, r: dict, reports: list, spec: RobotSpec, play: Callable, optimize_dir
) -> dict:
    """The paper's 30° case: infeasible with the nominal foot, feasible 0.01 m longer."""
    longer = sorted(
        (r2["foot_length_m"], p2, r2)
        for p2, r2 in reports
        if round(r2["slope_deg"], 3) == 30.0 and r2["foot_length_m"] > spec.foot_length
    )
    first = next(((length, p2, r2) for length, p2, r2 in longer if r2["feasible"]), None)
    found = (
        f"first feasible with a {first[0] * 1e3:.0f} mm foot (ankle to toe "
        f"{first[2]['ankle_to_toe_m'] * 1e3:.0f} mm): {_describe(first[2])}"
        if first
        else "no longer foot tried made it feasible"
    )
    penalty_feasible = [
        r2["foot_length_m"]
        for _, r2 in reports
        if round(r2["slope_deg"], 3) == 30.0 and r2["feasible"] and _constraint(r2) == "penalty"
    ]
    found += (
        "; with the paper's step penalty the GA found no feasible 30° gait at any "
        "foot tried (the flat penalty hides how far from feasible a gait is)"
        if not penalty_feasible
        else ""
    )
    return _claim(
        "30°: no feasible gait until the foot is lengthened by 0.01 m",
        "best fitness stays at the penalty; feasible after +0.01 m of foot",
        f"nominal foot: {_describe(r)}; {found}",
        play(first[2])[0] if first else "-",
        _yes(
            bool(not r["feasible"] and first and first[0] <= spec.foot_length + 0.0100001),
            play(first[2])[1] if first else None,
        ),
        _relative(first[1] if first else path, optimize_dir),
        f"nominal foot: {_report_axes(r, spec)}"
        + (f"; {first[0] * 1e3:.0f} mm foot: {_report_axes(first[2], spec)}" if first else ""),
        f"{ax.ESTIMATE} (the foot's length: an estimate the 30° answer turns on)",
    )


def _relative(path: Path, optimize_dir) -> str:
    """``optimize/...`` as cited from results/ (never a machine-specific absolute path)."""
    root = Path(optimize_dir)
    return str(Path(root.name) / Path(path).relative_to(root))


def _fine_check(report: dict) -> str:
    """The GA's best re-planned at 1 ms (``slopewalk optimize`` stores it as ``check``)."""
    check = report.get("check")
    if not check:
        return ""
    text = (
        f" (re-planned at {check['dt_s'] * 1e3:g} ms: margin {check['min_margin_m'] * 1e3:.2f} mm"
    )
    if not check.get("within_joint_limits", True):
        text += ", outside the joint limits"
    return text + ")"


def confusion(rows) -> str:
    """Analytic × simulated verdict counts, and the reason for each disagreement."""
    counts = Counter((r["analytic_verdict"], r["simulated_verdict"]) for r in rows)
    lines = [
        "# Analytic vs simulated verdicts",
        "",
        "| analytic \\ simulated | " + " | ".join(SIM_VERDICTS) + " |",
        "|---|" + "---|" * len(SIM_VERDICTS),
    ]
    for a in PAPER_VERDICTS:
        lines.append(
            f"| {a} | " + " | ".join(str(counts.get((a, s), 0)) for s in SIM_VERDICTS) + " |"
        )
    lines += ["", "## Disagreements", ""]
    for r in rows:
        a, s = r["analytic_verdict"], r["simulated_verdict"]
        if (a == "stable") == (s == "stable"):
            continue
        if a == "stable" and s == "slip":
            why = (
                f"slip, which the ZMP criterion cannot see (required μ "
                f"{r['max_friction_ratio']:.2f}, μ {r['friction']:g})"
            )
        elif a == "stable":
            tracking = r.get("tracking_rms_deg", float("nan"))
            why = (
                f"analytic margin only {r['analytic_min_margin_mm']:.1f} mm, while the real CoP "
                f"departs from the plan (joint tracking {tracking:.2f}° RMS, early touch-down)"
            )
        else:
            why = (
                f"the plan's ZMP leaves the polygon by at most {-r['analytic_min_margin_mm']:.1f}"
                " mm; the ZMP test flags any excursion, however brief, while the robot tips only "
                "if it lasts long enough to rotate a foot"
            )
        lines.append(
            f"- t_c {r['step_time']:g} s, slope {r['slope_deg']:g}°, μ "
            f"{r['friction']:g}, {r['mass_scale'] or 'nominal masses'}: analytic {a}, "
            f"simulated {s} — {why}"
        )
    if rows and "predicted_verdict" in rows[0]:
        lines += _predicted_confusion(rows)
    if rows and "walk" in rows[0]:
        lines += walk_confusion(rows)
    return "\n".join(lines) + "\n"


def walk_confusion(rows) -> list[str]:
    """The strict walk verdict (``walk``, ``bench/sim/walk_check.py``) beside the balance
    verdict, and the plan's prediction of it (``predicted_walk``) against it."""
    from slopewalk.bench.sim.walk_check import WALK_VERDICTS

    walks = [*WALK_VERDICTS, *(v for v in SIM_VERDICTS[1:] if v != "error")]
    seen = [w for w in walks if any(r["walk"] == w for r in rows)]
    counts = Counter((r["simulated_verdict"], r["walk"]) for r in rows)
    lines = [
        "",
        "# Balance vs strict walk verdicts",
        "",
        "`walked`: the robot kept its balance and walked the plan: each landing within 5 mm "
        "of its planned footprint and turned less than moves its toe 5 mm, the swing foot "
        "on the plane at most 0.1 s of each single support, the pelvis at the planned end "
        "pose, every actuator under 0.99 of the spec's servo stall torque "
        "(`docs/verdicts.md`).",
        "",
        "| balance \\ walk | " + " | ".join(seen) + " |",
        "|---|" + "---|" * len(seen),
    ]
    for b in SIM_VERDICTS:
        if any(k[0] == b for k in counts):
            lines.append(f"| {b} | " + " | ".join(str(counts[(b, w)]) for w in seen) + " |")
    if "predicted_walk" in rows[0]:
        from slopewalk.bench.report.fidelity import walk_agreement

        lines += ["", walk_agreement(rows)]
    return lines


def _predicted_confusion(rows) -> list[str]:
    """The predicted verdict (most severe predicted event) × simulated, and its disagreements."""
    from slopewalk.bench.report.fidelity import confusion_table, disagreement_cause
    from slopewalk.planner.verdict import VERDICT_KINDS

    lines = ["", "# Predicted vs simulated verdicts", ""]
    lines += confusion_table(rows, "predicted_verdict", ("stable", *VERDICT_KINDS))
    lines += ["", "## Disagreements", ""]
    for r in rows:
        if (r["predicted_verdict"] == "stable") != (r["simulated_verdict"] == "stable"):
            lines.append(
                f"- t_c {r['step_time']:g} s, slope {r['slope_deg']:g}°, μ {r['friction']:g}, "
                f"{r['mass_scale'] or 'nominal masses'}: {disagreement_cause(r)}"
            )
    return lines


def write_report(
    out: str | Path,
    rows: list[dict],
    specs: dict[str, RobotSpec],
    trials: dict[str, Any],
    ga_claims: list[dict] | None = None,
    *,
    envelope: tuple[list[dict], Path] | None = None,
    source: str | None = None,
) -> list[Path]:
    """Write claims.md, confusion.md and the figures into ``out``; return the paths.

    ``specs`` and ``trials``: each robot of the table (its ``robot`` column) by name,
    its spec and the walks its figures show (``experiments.claim_trials.claim_trials``,
    played only for the cases the table holds). Rows of trials that raised (verdict
    ``error``) are left out. ``ga_claims`` and ``envelope`` (the rows of an envelope
    table and its path as cited from ``out``) are the paper's robot's: they go in the
    ``default`` robot's section; with ``envelope`` claims 1 and 2 come from it first
    (``envelope_claims``), the GA rows cite its cells, and the sweep's claims are
    labelled as those of one hand-picked gait. ``source``: the sweep file the table
    came from, as the user named it; None: the default sweep. With one robot, the
    paper's, the claims are one table; else one section per robot, each figure of a
    walk one file per robot (``zmp_traces_<robot>.png``).
    """
    out = Path(out)
    rows = [r for r in rows if "error" not in (r["analytic_verdict"], r["simulated_verdict"])]
    names = robots(rows)
    sectioned = names != [DEFAULT_ROBOT]
    written = [figures.stability_map(rows, out / "stability_map.png")]
    series = {name: lipm_series([r for r in rows if r.get("robot", DEFAULT_ROBOT) == name])
              for name in names}  # fmt: skip
    if any(times for times, _, _ in series.values()):
        labelled = {(name if sectioned else None): s for name, s in series.items() if s[0]}
        written.append(figures.lipm_vs_step_time(labelled, out / "lipm_vs_step_time.png"))
    sections, every = [], []
    for name in names:
        suffix = f"_{_slug(name, names)}" if sectioned else ""
        mine = [r for r in rows if r.get("robot", DEFAULT_ROBOT) == name]
        claims, files = _robot_claims(
            out, mine, specs[name], trials[name], suffix,
            ga_claims if name == DEFAULT_ROBOT else None,
            envelope if name == DEFAULT_ROBOT else None,
        )  # fmt: skip
        written += files
        hz = GaitParams.nominal(specs[name], NOMINAL_STEP_TIME)
        nominal = (
            f"Nominal gait unless stated: Hz = {hz.hip_height:.2f} m, lift 0.6 × thigh, tilt "
            f"{np.rad2deg(hz.tilt):g}°, `hold` profile, stiff actuators. {AXES_NOTE}"
        )
        if sectioned:
            sections += ["", f"## Robot `{name}` ({specs[name].name})", "", nominal, ""]
            every += [{**c, "robot": name} for c in claims]
        else:
            sections += [nominal, ""]
            every += claims
        sections += _table(claims)
    table = ["# The paper's claims, analytic and simulated", "", _header(source, envelope, rows)]
    if DEFAULT_ROBOT not in names and (ga_claims or envelope is not None):
        table.append(
            "The GA cases and the envelope are the paper's robot's (`default`), which this "
            "sweep does not hold: not in this sweep."
        )
    table += sections
    for name, text in (("claims.md", "\n".join(table) + "\n"), ("confusion.md", confusion(rows))):
        with atomic_path(out / name) as tmp:
            tmp.write_text(text)
        written.append(out / name)
    with atomic_path(out / "claims.json") as tmp:
        tmp.write_text(json.dumps(every, indent=2))
    return [*written, out / "claims.json"]


AXES_NOTE = (
    "*Simulated*: *stable* / *tip* / *slip* / *fall* is the balance verdict (the robot stayed "
    "up); *walked* is the strict walk verdict of the sweep's rows (`walk` column, "
    "`docs/verdicts.md`): balanced, every landing on its planned footprint, the swing foot off "
    "the plane, the pelvis at the planned end pose and every actuator within the spec's servo "
    "stall torque; the sweep's rows bear a claim out only where the robot walked "
    "(the envelope's rows are judged by their balance verdict until the envelope is "
    "regenerated with its walk columns). "
    "*Smallest margin by axis*: over the walk, the signed distance along y_S (lateral) or "
    "x_S (sagittal) alone from the ZMP to the support polygon's boundary at the ZMP's other "
    "coordinate (`planner.zmp.axis_margins`), positive inside. *Rests on*: physics (any "
    "gait of this build), the gait family's shape (the paper's splines, fixed lean and hip "
    "path: another family can move it) or estimated spec values (what "
    "`planner/robots/bioloid.toml` marks as estimates)."
)


def _header(source: str | None, envelope, rows) -> str:
    """Where the table came from: the sweep file (and the envelope's table)."""
    if source is None:
        head = f"Regenerated by `slopewalk sweep` ({DEFAULT_SOURCE})"
    else:
        head = (
            f"Written by `slopewalk sweep --report` from the sweep file `{source}` "
            f"({len(rows)} trials of `sweep.csv`, robots: "
            + ", ".join(f"`{name}`" for name in robots(rows))
            + ")"
        )
    if envelope is not None:
        return head + (
            f"; the envelope's rows from `{envelope[1]}` (`slopewalk envelope`, "
            "`bench/experiments/envelopes/paper.toml`: the GA's best gait per cell)."
        )
    return head + (
        ". No envelope table at `envelope/envelope.csv` beside this report (`slopewalk "
        "envelope` writes it into `results/envelope/`): its claims are not included."
    )


def _robot_claims(out: Path, rows, spec, trials, suffix: str, ga_rows, envelope):
    """One robot's claims and the figures of its walks: (claims, files written)."""
    files = []
    zmp_name, torques_name = f"zmp_traces{suffix}.png", f"joint_torques{suffix}.png"
    if trials.cases:
        files.append(figures.zmp_traces(trials.cases, out / zmp_name))
    if trials.nominal is not None:
        files.append(
            figures.joint_torques(trials.nominal, trials.nominal_result, out / torques_name)
        )
        files.append(
            figures.joint_angles(
                trials.nominal, trials.nominal_result, out / f"joint_angles{suffix}.png"
            )
        )
        torque = torque_claim(trials.nominal, trials.nominal_result)
    else:
        torque = _absent(
            *TORQUE_CLAIM, f"t_c = {NOMINAL_STEP_TIME:g} s on flat ground, μ = 1, stiff"
        )
    nominal_claims = [step_time_claim(rows, spec), slope_claim(rows, spec)]
    ga_rows = list(ga_rows or [])
    found = []
    if envelope is not None:
        from slopewalk.bench.report.envelope_claims import envelope_cell_note, envelope_claims

        env_rows, cite = envelope[0], str(envelope[1])
        found = envelope_claims(env_rows, cite, spec)
        for c in nominal_claims:
            c["claim"] = "one hand-picked gait (the nominal one): " + c["claim"]
        for c in ga_rows:  # the GA's 22.5° and 30° cases cite the envelope's cell at 1 s
            slope = {"GA at 22.5": 22.5, "30°": 30.0}.get(c["claim"].split(":")[0][:10])
            if slope is not None and (note := envelope_cell_note(env_rows, slope, cite)):
                c["analytic"] += note
                c["evidence"] += f", {cite}"
    line = _line(rows, step_time=NOMINAL_STEP_TIME)
    slopes = {r["slope_deg"] for r in line}
    mus = {r["friction"] for r in line if r["slope_deg"] == 22.5}
    extra = [
        ax.friction_claim(rows, spec, line)
        if 22.5 in slopes and 1.0 in mus and len(mus) > 1
        else _absent(
            "friction: μ 0.4–0.6 may be insufficient on the incline (22.5°)",
            "0.4–0.6 may be insufficient",
            f"t_c = {NOMINAL_STEP_TIME:g} s, stiff, 22.5° at μ = 1 and a lower μ",
        )
    ]
    if trials.paper_ga is not None:
        ga_rows.insert(
            1, ax.paper_gait_claim(trials.paper_ga, "played by `slopewalk sweep` (claim_trials)")
        )
    claims = [
        *found,
        *nominal_claims,
        *extra,
        *ga_rows,
        *mass_claims(rows, spec, trials.mass_servo),
        lipm_claim(rows, spec),
        torque,
    ]
    for c in claims:  # this robot's figures
        c["evidence"] = (
            c["evidence"]
            .replace("zmp_traces.png", zmp_name)
            .replace("joint_torques.png", torques_name)
        )
    return claims, files


def _table(claims: list[dict]) -> list[str]:
    return [
        "| claim | paper | analytic here | simulated here | smallest margin by axis (the "
        "walks of the row) | bears the paper out? | rests on | shown in |",
        "|---|---|---|---|---|---|---|---|",
    ] + [
        f"| {c['claim']} | {c['paper']} | {c['analytic']} | {c['simulated']} | "
        f"{c.get('axes', '-')} | {c['agree']} | {c.get('basis', '-')} | {c['evidence']} |"
        for c in claims
    ]


def _slug(name: str, names: list[str]) -> str:
    """A file-name part for robot ``name``, unique among ``names`` (``robots/big.toml``:
    ``robots_big``; two names that give the same part get their position added)."""
    base = _slug_base(name)
    clash = any(_slug_base(other) == base for other in names if other != name)
    return f"{base}{names.index(name) + 1}" if clash else base


def _slug_base(name: str) -> str:
    stem = name[: -len(".toml")] if name.endswith(".toml") else name
    return "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in stem).strip("_") or "robot"
