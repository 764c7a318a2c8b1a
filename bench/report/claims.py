"""The paper's claims, each checked analytically and in simulation; the confusion table.

``write_report(out, rows, spec, trials)`` turns a sweep's rows (``sweep.csv``) into
``claims.md``, ``confusion.md`` and the figures of ``figures.py``. Where a claim
needs more than the sweep holds (a trace, a torque split, the GA cases) it plans
(no simulation), takes the walks ``experiments.claim_trials`` played, or reads the GA
results written by ``slopewalk optimize`` into ``results/optimize/``.

Numbers are written at fixed precision (never ``%g`` of a computed value, whose
digits follow floating-point noise: a ZMP shift of 1.39e-13 mm is 0.0000 mm), and
the sweep's values come from ``sweep.csv`` as written (``tables/sweep.py``), so a
regenerated report has the same bytes when nothing changed.
"""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from slopewalk.bench.actuators import DEFAULT_MODE
from slopewalk.bench.files import atomic_path
from slopewalk.bench.report import figures
from slopewalk.bench.sim.model import servo_settings
from slopewalk.bench.tables.sweep import SIMULATED_VERDICTS
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.spec import RobotSpec
from slopewalk.planner.verdict import PAPER_VERDICTS
from slopewalk.planner.zmp import signed_margin

NOMINAL_STEP_TIME = 1.0  # [s]
SIM_VERDICTS = SIMULATED_VERDICTS  # the sweep table's, "error" included


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


def _claim(claim, paper, analytic, simulated, agree, evidence) -> dict:
    return {
        "claim": claim,
        "paper": paper,
        "analytic": analytic,
        "simulated": simulated,
        "agree": agree,
        "evidence": evidence,
    }


def step_time_claim(rows) -> dict:
    flat = _line(rows, slope_deg=0.0, friction=1.0)
    ok_a = [r["step_time"] for r in flat if r["analytic_verdict"] == "stable"]
    ok_s = [r["step_time"] for r in flat if r["simulated_verdict"] == "stable"]
    by_t = {r["step_time"]: r for r in flat}

    def agrees(key):
        return (
            by_t.get(0.5, {}).get(key) == "stable"
            and by_t.get(0.4, {}).get(key, "stable") != "stable"
        )

    return _claim(
        "flat ground: stable down to 0.5 s, not at 0.4 s",
        "stable for t_c ≥ 0.5 s; ZMP almost entirely outside at 0.4 s",
        f"ZMP inside the polygon at t_c = {_fmt_list(ok_a)} s; min margin at 0.5 s "
        f"{by_t.get(0.5, {}).get('analytic_min_margin_mm', float('nan')):.1f} mm",
        f"no tip/slip/fall at t_c = {_fmt_list(ok_s)} s (μ = 1)",
        _yes(agrees("analytic_verdict"), agrees("simulated_verdict")),
        "stability_map.png, sweep.csv (slope 0)",
    )


def slope_claim(rows, spec: RobotSpec) -> dict:
    line = _line(rows, step_time=NOMINAL_STEP_TIME, friction=1.0)
    inside = [r["slope_deg"] for r in line if r["analytic_verdict"] == "stable"]
    stable = [r["slope_deg"] for r in line if r["simulated_verdict"] == "stable"]
    rear = []
    for slope in (0.0, 15.0, 18.0, 22.5):
        plan = plan_walk(spec, GaitParams.nominal(spec, NOMINAL_STEP_TIME, slope=np.deg2rad(slope)))
        ssp = ~plan.double_support
        rear.append(
            f"{slope:g}°: {np.mean(plan.zmp[ssp, 0] - plan.stance_sole[ssp, 0]) * 1e3:+.1f}"
        )

    def agrees(ok):
        return {15.0, 18.0, 22.5} <= set(ok) and not {25.0, 30.0} & set(ok)

    return _claim(
        "slopes: inside up to 15°, towards the rear at 18° and 22.5°, outside beyond 22.5°",
        "inside ≤ 15°; rear edge at 18°, 22.5°; outside > 22.5°",
        f"inside at {_fmt_list(inside)}°; mean SSP ZMP x from the ankle [mm]: {'; '.join(rear)}",
        f"stable at {_fmt_list(stable)}° (μ = 1)",
        _yes(agrees(inside), agrees(stable)),
        "stability_map.png, zmp_traces.png, sweep.csv (t_c = 1 s)",
    )


def mass_claims(rows, spec: RobotSpec) -> list[dict]:
    base = plan_walk(spec, GaitParams.nominal(spec, NOMINAL_STEP_TIME))
    out = []
    for scale, claim, paper in (
        ("all=10", "10× mass on every link leaves the ZMP unchanged", "ZMP trace unchanged"),
        ("legs=2", "doubling the swing-leg mass pushes the ZMP outside", "ZMP outside the polygon"),
    ):
        group, factor = scale.split("=")
        scaled = spec.with_mass_scale({group: float(factor)})
        plan = plan_walk(scaled, base.params)
        shift = np.hypot(*(plan.zmp - base.zmp).T).max() * 1e3
        sim = [r for r in rows if r["mass_scale"] == scale]
        sim_text = (
            ", ".join(
                f"{r['simulated_verdict']} (μ {r['friction']:g}, RMS {r['zmp_rms_mm']:.1f} mm)"
                for r in sim
            )
            or "not in the sweep"
        )
        nominal = [r for r in _line(rows, step_time=NOMINAL_STEP_TIME, slope_deg=0.0)]
        same = {r["friction"]: r["simulated_verdict"] for r in nominal}
        if scale == "all=10":  # unchanged: same verdict as the nominal masses at that μ
            agree = _yes(
                shift < 1e-6,
                all(same.get(r["friction"]) == r["simulated_verdict"] for r in sim)
                if sim
                else None,
            )
        else:  # pushed out: unstable where the nominal masses were stable
            agree = _yes(
                plan.margin.min() < 0 <= base.margin.min(),
                all(r["simulated_verdict"] != "stable" for r in sim) if sim else None,
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
            )
        )
    return out


def lipm_claim(rows, spec: RobotSpec, out: Path) -> dict:
    flat = _line(rows, slope_deg=0.0, friction=1.0)
    times = [r["step_time"] for r in flat]
    analytic = [r.get("lipm_rms_mm", np.nan) for r in flat]
    simulated = [r.get("cop_lipm_rms_mm", np.nan) for r in flat]
    figures.lipm_vs_step_time(times, analytic, simulated, out / "lipm_vs_step_time.png")
    fast = plan_walk(spec, GaitParams.nominal(spec, 0.4))
    lipm_margin = signed_margin(fast.zmp_lipm, fast.polygon).min() * 1e3
    text = ", ".join(f"{t:g} s: {a:.1f}" for t, a in zip(times, analytic, strict=True))
    grows = len(analytic) > 1 and analytic[0] > 5 * analytic[-1]
    return _claim(
        "LIPM matches the multibody ZMP at slow steps and diverges at fast ones",
        "near-identical at low acceleration; at short t_c the 8-DOF model is unstable while "
        "the LIPM still predicts stability",
        f"RMS distance ZMP to LIPM [mm]: {text}; at 0.4 s the LIPM ZMP's min margin is "
        f"{lipm_margin:.0f} mm (multibody {fast.margin.min() * 1e3:.0f} mm)",
        "RMS distance CoP to LIPM [mm]: "
        + ", ".join(f"{t:g} s: {s:.1f}" for t, s in zip(times, simulated, strict=True)),
        (
            "partly: analytic, the distance grows with speed but at 0.4 s the LIPM ZMP is outside "
            "too"
            if grows and lipm_margin < 0
            else _yes(grows, None).split(",")[0]
        )
        + "; simulated CoP vs LIPM grows too",
        "lipm_vs_step_time.png",
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
        "stance joints carry more torque than swing joints",
        "stance-leg torques substantially higher",
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
        return [
            _claim(
                "GA cases (22.5°, 30°)",
                "see below",
                f"no `slopewalk optimize` results in {optimize_dir}",
                "-",
                "not checked",
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
        out.append(_ga_claim_22_5(*at[22.5], play, optimize_dir))
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
        f" m, Szmax {b['swing_lift_m']:.3f} m, θ1max {b['tilt_deg']:.2f}°, work "
        f"{b['work_J']:.3f} J, min margin {b['min_margin_m'] * 1e3:.1f} mm"
        + _fine_check(report)
        + f" [{_constraint(report)} constraint]"
    )


def _ga_claim_22_5(path: Path, r: dict, play: Callable, optimize_dir) -> dict:
    """The paper's 22.5° case: the GA's gait and whether its ZMP stays inside."""
    return _claim(
        "GA at 22.5°: θ1max = −9.18°, Hz = 0.151 m, Szmax = 0.013 m, ZMP inside",
        "θ1max −9.18°, Hz 0.151 m, Szmax 0.013 m; ZMP inside",
        _describe(r),
        play(r)[0],
        _yes(r["feasible"], play(r)[1]),
        _relative(path, optimize_dir),
    )


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
    return "\n".join(lines) + "\n"


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
    spec: RobotSpec,
    trials: Any,
    ga_claims: list[dict] | None = None,
    *,
    envelope: tuple[list[dict], Path] | None = None,
) -> list[Path]:
    """Write claims.md, confusion.md and the figures into ``out``; return the paths.

    ``trials``: the walks the figures show (``experiments.claim_trials.claim_trials``).
    Rows of trials that raised (verdict ``error``) are left out. ``envelope``: the
    rows of an envelope table and its path as cited from ``out``; claims 1 and 2
    then come from it first (``envelope_claims``), the GA rows cite its cells, and
    the sweep's claims are labelled as those of one hand-picked gait.
    """
    out = Path(out)
    rows = [r for r in rows if "error" not in (r["analytic_verdict"], r["simulated_verdict"])]
    written = [figures.stability_map(rows, out / "stability_map.png")]
    written.append(figures.zmp_traces(trials.cases, out / "zmp_traces.png"))
    nominal, nominal_result = trials.nominal, trials.nominal_result
    written.append(figures.joint_torques(nominal, nominal_result, out / "joint_torques.png"))
    written.append(figures.joint_angles(nominal, nominal_result, out / "joint_angles.png"))
    nominal_claims = [step_time_claim(rows), slope_claim(rows, spec)]
    ga_rows = list(ga_claims or [])
    found = []
    if envelope is not None:
        from slopewalk.bench.report.envelope_claims import envelope_cell_note, envelope_claims

        env_rows, cite = envelope[0], str(envelope[1])
        found = envelope_claims(env_rows, cite)
        for c in nominal_claims:
            c["claim"] = "one hand-picked gait (the nominal one): " + c["claim"]
        for c in ga_rows:  # the GA's 22.5° and 30° cases cite the envelope's cell at 1 s
            slope = {"GA at 22.5": 22.5, "30°": 30.0}.get(c["claim"].split(":")[0][:10])
            if slope is not None and (note := envelope_cell_note(env_rows, slope, cite)):
                c["analytic"] += note
                c["evidence"] += f", {cite}"
    claims = [
        *found,
        *nominal_claims,
        *ga_rows,
        *mass_claims(rows, spec),
        lipm_claim(rows, spec, out),
        torque_claim(nominal, nominal_result),
    ]
    written.append(out / "lipm_vs_step_time.png")
    table = [
        "# The paper's claims, analytic and simulated",
        "",
        "Regenerated by `slopewalk sweep` "
        "(the default sweep, `bench/experiments/sweeps/paper.toml`)"
        + (
            f"; the envelope's rows from `{envelope[1]}` (`slopewalk envelope`, "
            "`bench/experiments/envelopes/paper.toml`: the GA's best gait per cell)."
            if envelope is not None
            else "."
        ),
        f"Nominal gait unless stated: Hz = {nominal.params.hip_height:.2f} m, lift 0.6 × "
        f"thigh, tilt {np.rad2deg(nominal.params.tilt):g}°, `hold` profile, stiff actuators.",
        "",
        "| claim | paper | analytic here | simulated here | bears the paper out? | shown in |",
        "|---|---|---|---|---|---|",
    ]
    table += [
        f"| {c['claim']} | {c['paper']} | {c['analytic']} | {c['simulated']} | "
        f"{c['agree']} | {c['evidence']} |"
        for c in claims
    ]
    for name, text in (("claims.md", "\n".join(table) + "\n"), ("confusion.md", confusion(rows))):
        with atomic_path(out / name) as tmp:
            tmp.write_text(text)
        written.append(out / name)
    with atomic_path(out / "claims.json") as tmp:
        tmp.write_text(json.dumps(claims, indent=2))
    return [*written, out / "claims.json"]
