"""One optimisation case as ``slopewalk optimize`` runs it: search, check, report.

``optimize_case`` builds the ``GaitProblem`` of a slope and step time, runs the GA
(and NSGA-II with ``pareto=True``), re-plans the best gait at 1 ms with
``plan_walk`` to check it (margin, joint limits, required friction), and returns
a JSON-ready report; ``summary_lines`` says the same in a few lines. Files are
written by the CLI only.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from slopewalk.bench.experiments.ga.search import (
    GaSettings,
    ParetoFront,
    RunResult,
    run_ga,
    run_nsga2,
)
from slopewalk.planner.errors import SlopewalkError, UnreachableError
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.gait_search import (
    PENALTY,
    SAMPLES_PER_STEP,
    GaitProblem,
    ga_params,
    joint_limit_excess,
    min_knee_flexion,
    swing_clearance,
)
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.spec import RobotSpec

CHECK_DT = 1e-3  # [s] resolution at which the best gait is re-planned and checked


@dataclass(frozen=True)
class Case:
    """Outcome of ``optimize_case``: the JSON report, the GA run and the front (if asked)."""

    report: dict
    run: RunResult
    front: ParetoFront | None


def optimize_case(
    spec: RobotSpec,
    *,
    slope: float,
    step_time: float = 1.0,
    settings: GaSettings | None = None,
    friction: float | None = None,
    pareto: bool = False,
    progress: bool = False,
) -> Case:
    """Optimise (Hz, Szmax, tilt) of a walk on a slope and check the best gait.

    Args:
        spec: The robot (foot already lengthened if asked).
        slope: Plane inclination [rad], in (−60°, 60°).
        step_time: Step completion time [s], > 0.
        settings: GA settings (default: the paper's 130 x 500, penalty, seed 0).
        friction: Coefficient μ of the plane, > 0, or None (1.0); the GA admits no gait
            whose largest required |F_t|/F_n exceeds it (``GaitProblem.friction``), and
            the report says whether the best gait's 1 ms re-plan does.
        pareto: Also run NSGA-II over (work, −min margin) with the same settings.
        progress: tqdm bars on stderr.
    """
    settings = settings if settings is not None else GaSettings()
    if friction is not None and not friction > 0:
        raise SlopewalkError(f"friction {friction!r}: must be > 0")
    mu = 1.0 if friction is None else friction
    problem = GaitProblem(spec, ga_params(spec, step_time, slope), friction=mu)
    run = run_ga(problem, settings, progress=progress)
    front = run_nsga2(problem, settings, progress=progress) if pareto else None
    report = _report(spec, problem.params, problem, settings, run, friction)
    if front is not None:
        report["pareto"] = {
            "points": int(front.work.size),
            "evaluations": front.evaluations,
            "wall_s": front.wall_s,
        }
    return Case(report, run, front)


def _report(spec, params: GaitParams, problem, settings, run: RunResult, friction) -> dict:
    best = run.best
    hz, lift, tilt = (float(v) for v in best.x)
    b = problem.bounds
    found = np.flatnonzero(run.feasible_history)
    report = {
        "robot": spec.name,
        "foot_length_m": spec.foot_length,
        "ankle_to_toe_m": spec.ankle_to_toe,
        "slope_deg": float(np.rad2deg(params.slope)),
        "step_time_s": params.step_time,
        "steps": params.steps,
        "samples_per_step": SAMPLES_PER_STEP,
        "settings": {
            "population": settings.population,
            "generations": settings.generations,
            "seed": settings.seed,
            "constraint": settings.constraint,
            "crossover": f"SBX(prob={settings.crossover}, eta=15, prob_var=0.5)",
            "mutation": f"PM(prob=1.0, prob_var={settings.mutation}, eta=20)",
            "survival": "(mu + lambda) truncation, duplicates eliminated",
            "penalty": PENALTY,
        },
        "bounds": {
            "hip_height_m": [b.lower[0], b.upper[0]],
            "swing_lift_m": [b.lower[1], b.upper[1]],
            "tilt_deg": [float(np.rad2deg(b.lower[2])), float(np.rad2deg(b.upper[2]))],
            "min_clearance_m": swing_clearance(spec),
            "min_knee_flexion_rad": min_knee_flexion(spec),
            "friction": problem.friction,
        },
        "feasible": best.feasible,
        "best": {
            "hip_height_m": hz,
            "swing_lift_m": lift,
            "tilt_deg": float(np.rad2deg(tilt)),
            "tilt_rad": tilt,
            "work_J": best.work,
            "min_margin_m": best.margin,
            "joint_gap_rad": best.joint_gap,
            "objective": best.objective,
        },
        "first_feasible_generation": int(found[0]) + 1 if found.size else None,
        "evaluations": run.evaluations,
        "wall_s": run.wall_s,
        "evals_per_s": run.evals_per_s,
        "history_best_objective": [float(v) for v in run.history],
    }
    report["check"] = _check(spec, params, best.x, friction)
    return report


def _check(spec, params: GaitParams, x, friction) -> dict:
    """Re-plan the best gait at ``CHECK_DT`` and read its margin, limits and friction."""
    fine = GaitParams.nominal(
        spec,
        params.step_time,
        slope=params.slope,
        steps=params.steps,
        dt=CHECK_DT,
        hip_height=float(x[0]),
        swing_lift=float(x[1]),
        tilt=float(x[2]),
    )
    try:
        plan = plan_walk(spec, fine)
    except UnreachableError as err:
        return {"dt_s": CHECK_DT, "error": str(err)}
    summary = plan.summary()
    excess = joint_limit_excess(spec, plan.q)
    check = {
        "dt_s": CHECK_DT,
        "verdict": summary["verdict"],
        "min_margin_m": summary["min_margin_m"],
        "work_J": summary["work_J"],
        "peak_torque_over_stall": summary["peak_torque_over_stall"],
        "max_friction_ratio": summary["max_friction_ratio"],
        "joint_limit_excess_rad": excess,
        "within_joint_limits": all(v == 0 for v in excess.values()),
    }
    if friction is not None:
        check["friction"] = friction
        check["slip_predicted"] = bool(summary["max_friction_ratio"] > friction)
    return check


def summary_lines(report: dict) -> list[str]:
    """What a user reads first: best gait, verdict, friction, speed."""
    s, b, best, check = report["settings"], report["bounds"], report["best"], report["check"]
    lines = [
        f"optimize: {report['robot']} (foot {report['foot_length_m']:.3f} m, toe "
        f"{report['ankle_to_toe_m']:.3f} m), {report['slope_deg']:g} deg, step time "
        f"{report['step_time_s']:g} s, GA {s['population']} x {s['generations']} "
        f"({s['constraint']}), seed {s['seed']}",
        f"bounds: Hz [{b['hip_height_m'][0]:.4f}, {b['hip_height_m'][1]:.4f}] m, Szmax "
        f"[{b['swing_lift_m'][0]:.4f}, {b['swing_lift_m'][1]:.4f}] m, tilt "
        f"[{b['tilt_deg'][0]:.2f}, {b['tilt_deg'][1]:.2f}] deg",
        f"best: Hz {best['hip_height_m']:.4f} m, Szmax {best['swing_lift_m']:.4f} m, "
        f"theta1max {best['tilt_deg']:.2f} deg",
        f"work {best['work_J']:.4f} J, min ZMP margin {best['min_margin_m'] * 1e3:.2f} mm "
        f"(re-planned at 1 ms: {_mm(check.get('min_margin_m'))}), objective "
        f"{best['objective']:.6g}",
    ]
    if report["feasible"]:
        lines.append(f"feasible: yes (first at generation {report['first_feasible_generation']})")
    elif s["constraint"] == "penalty":
        lines.append(
            f"feasible: NO - none of the {report['evaluations']} gaits evaluated keeps the ZMP "
            "inside the support polygon with the joints within their limits; the best fitness "
            f"stays at the penalty (objective {best['objective']:.6g} >= {s['penalty']:g})"
        )
    else:
        lines.append(
            f"feasible: NO - none of the {report['evaluations']} gaits evaluated keeps the ZMP "
            "inside the support polygon; the closest misses by "
            f"{-best['min_margin_m'] * 1e3:.2f} mm"
        )
    if report["feasible"] and check.get("verdict") == "zmp_outside":
        lines.append(
            f"note: re-planned at {check['dt_s'] * 1e3:g} ms the ZMP leaves the polygon by "
            f"{-check['min_margin_m'] * 1e3:.2f} mm (the GA plans {SAMPLES_PER_STEP} samples "
            "per step)"
        )
    if "within_joint_limits" in check and not check["within_joint_limits"]:
        lines.append(f"joint limits exceeded [rad]: {check['joint_limit_excess_rad']}")
    if "friction" in check:
        verdict = "slip predicted" if check["slip_predicted"] else "no slip predicted"
        lines.append(
            f"friction: max required |Ft|/Fn {check['max_friction_ratio']:.3f} vs mu "
            f"{check['friction']:g}: {verdict}"
        )
    lines.append(
        f"{report['evaluations']} evaluations in {report['wall_s']:.1f} s "
        f"({report['evals_per_s']:.0f} evals/s)"
    )
    if "pareto" in report:
        p = report["pareto"]
        lines.append(
            f"pareto: {p['points']} non-dominated gaits from {p['evaluations']} evaluations"
        )
    return lines


def _mm(value) -> str:
    return "n/a" if value is None else f"{value * 1e3:.2f} mm"


def pareto_paths(out) -> tuple[Path, Path]:
    """Where the front goes beside the best-gait JSON: ``<stem>_pareto.csv`` and ``.png``."""
    out = Path(out)
    return out.with_name(f"{out.stem}_pareto.csv"), out.with_name(f"{out.stem}_pareto.png")


def pareto_csv(front: ParetoFront) -> str:
    """The front as CSV text, one gait a row, sorted by work (header included)."""
    rows = front.rows()
    header = list(rows[0]) if rows else list(ParetoFront.COLUMNS)
    lines = [",".join(header)]
    lines += [",".join(f"{row[k]:.9g}" for k in header) for row in rows]
    return "\n".join(lines) + "\n"


def pareto_title(report: dict) -> str:
    return (
        f"NSGA-II front: {report['robot']}, {report['slope_deg']:g} deg, "
        f"t_c = {report['step_time_s']:g} s, foot {report['foot_length_m']:.3f} m"
    )
