"""What each claim row adds so that it compares like with like (issue 21).

* ``axes(plan)``: the walk's smallest lateral and sagittal ZMP margins
  (``planner.zmp.axis_margins``: along y_S and x_S alone), since the Euclidean margin of
  the paper's test does not say which edge decides; on flat ground every "no" of the
  nominal gait comes from the lateral limit.
* ``BASIS``: for each finding, what it rests on: the physics (holds for any gait of any
  biped of this build), the gait family's shape (the paper's splines, its fixed lean
  and hip path: another family can move it) or a value the spec only estimates (the
  Bioloid's foot, masses, joint limits and servo constants are estimates,
  ``planner/robots/bioloid.toml``).
* The rows the table lacked: the paper's own 22.5° GA gait replayed, the 10× mass case
  with the servo scaled as the heavier robot would have it, LIPM vs multibody judged over
  the paper's 2–0.5 s, and the paper's friction caveat.
"""

from __future__ import annotations

import numpy as np

from slopewalk.planner.gait import GaitParams
from slopewalk.planner.plan import Plan, plan_walk
from slopewalk.planner.zmp import axis_margins, signed_margin

PHYSICS = "physics"
SHAPE = "the gait family's shape"
ESTIMATE = "estimated spec values"
PAPER_RANGE = (0.5, 2.0)  # [s] the step times the paper's LIPM statement covers


def axis_minima(plan: Plan, zmp=None) -> tuple[float, float]:
    """(lateral, sagittal) smallest margin of the walk [m] (``zmp.axis_margins``); ``zmp``:
    another ZMP series on the plan's polygons (the LIPM's), default the multibody one."""
    sagittal, lateral = axis_margins(plan.zmp if zmp is None else zmp, plan.polygon)
    return float(np.nanmin(lateral)), float(np.nanmin(sagittal))


def axes(plan: Plan, zmp=None) -> str:
    """ "lateral −3.3 mm, sagittal +3.3 mm": the walk's smallest margin along each axis."""
    lateral, sagittal = axis_minima(plan, zmp)
    return f"lateral {lateral * 1e3:+.1f} mm, sagittal {sagittal * 1e3:+.1f} mm"


def labelled_axes(cases) -> str:
    """ "label: lateral …, sagittal …; …" of (label, plan) pairs."""
    return "; ".join(f"{label}: {axes(plan)}" for label, plan in cases)


def decided_by(plan: Plan) -> str:
    """Which axis's limit decides the walk's margin: "lateral", "sagittal" or "neither"
    (both inside)."""
    lateral, sagittal = axis_minima(plan)
    if min(lateral, sagittal) >= 0:
        return "neither"
    return "lateral" if lateral < sagittal else "sagittal"


def paper_gait_claim(paper_ga, ga_cite: str) -> dict:
    """The paper's published 22.5° GA gait (``claim_trials.PAPER_GA_GAIT``), planned here and
    played: is its ZMP inside, and along which axis not."""
    plan, result = paper_ga
    lateral, sagittal = axis_minima(plan)
    events = ", ".join(sorted({e.kind for e in result.events})) or "none"
    inside = plan.margin.min() >= 0
    return {
        "claim": "the paper's own 22.5° GA gait (Hz 0.151 m, Szmax 0.013 m, θ1max −9.18°, "
        "i.e. a lean of +9.18° here) replayed on this robot",
        "paper": "ZMP inside (the paper's robot)",
        "analytic": f"min margin {plan.margin.min() * 1e3:.1f} mm ({decided_by(plan)} limit "
        f"decides)",
        "simulated": f"{result.simulated_verdict} (stiff, μ 1, ZMP RMS "
        f"{result.zmp_rms * 1e3:.1f} mm, events: {events})",
        "agree": f"analytic {'yes' if inside else 'no'}, simulated "
        f"{'yes' if result.simulated_verdict == 'stable' else 'no'}"
        + ("; front to back yes" if sagittal >= 0 > lateral else ""),
        "evidence": ga_cite,
        "axes": axes(plan),
        "basis": f"{ESTIMATE} (this robot's masses and foot are not the paper's)",
    }


def mass_servo_text(mass_servo) -> str:
    """The 10× mass walks in the spec-servo modes, unscaled and scaled, beside the nominal."""
    labels = dict.fromkeys(label for label, _ in mass_servo)
    modes = dict.fromkeys(mode for _, mode in mass_servo)
    parts = []
    for label in labels:
        walks = ", ".join(
            f"{mode} {mass_servo[(label, mode)].simulated_verdict} (RMS "
            f"{mass_servo[(label, mode)].zmp_rms * 1e3:.1f} mm)"
            for mode in modes
        )
        parts.append(f"{label}: {walks}")
    return "; ".join(parts)


def mass_servo_same(mass_servo) -> bool:
    """Whether the 10× robot with its servo scaled walks as the nominal one in every mode."""
    modes = {mode for _, mode in mass_servo}
    return all(
        mass_servo[("10× mass, servo × 10", m)].simulated_verdict
        == mass_servo[("nominal", m)].simulated_verdict
        for m in modes
    )


def lipm_in_range(spec, rows_times: list[float]) -> tuple[str, str, bool | None]:
    """LIPM vs multibody over the paper's 2–0.5 s: (analytic text, axes text, whether some
    step time there has the multibody ZMP outside while the LIPM's is inside)."""
    times = sorted(t for t in rows_times if PAPER_RANGE[0] <= t <= PAPER_RANGE[1])
    if not times:
        return "no step time of this sweep in 0.5–2 s", "-", None
    parts, split, shown = [], [], []
    for t in times:
        plan = plan_walk(spec, GaitParams.nominal(spec, t))
        multi = plan.margin.min()
        lipm = signed_margin(plan.zmp_lipm, plan.polygon).min()
        parts.append(f"{t:g} s: {multi * 1e3:+.1f} / {lipm * 1e3:+.1f}")
        if multi < 0 <= lipm:
            split.append(t)
            shown.append((t, plan))
    text = "min margin multibody / LIPM [mm] over the paper's 2–0.5 s: " + ", ".join(parts)
    if split:
        text += (
            f"; multibody outside while the LIPM is inside at {', '.join(f'{t:g}' for t in split)}"
            " s"
        )
    axis = (
        "; ".join(
            f"{t:g} s multibody {axes(plan)}, LIPM {axes(plan, plan.zmp_lipm)}"
            for t, plan in shown[-1:]
        )
        or "-"
    )
    return text, axis, bool(split)


def _walked(line, mu: float) -> list[float]:
    """Slopes [deg] of ``line`` MuJoCo walks (verdict stable) at friction ``mu``."""
    return [
        r["slope_deg"] for r in line if r["friction"] == mu and r["simulated_verdict"] == "stable"
    ]


def friction_claim(rows, spec, line) -> dict:
    """The paper's caveat that μ 0.4–0.6 may not hold its walk on the incline, from the sweep's
    slope line (t_c = 1 s, nominal gait, stiff) at each μ it holds: the largest required
    |F_t|/F_n per slope and the slopes MuJoCo walks at each μ. Borne out where a slope the
    robot walks at μ 1 is lost at a lower μ that its required ratio exceeds."""
    ratios = {r["slope_deg"]: r["max_friction_ratio"] for r in line if r["friction"] == 1.0}
    mus = sorted({r["friction"] for r in line})
    walked = {mu: _walked(line, mu) for mu in mus}
    lost = sorted(
        (s, mu)
        for mu in mus
        if mu < 1.0
        for s in set(walked.get(1.0, [])) - set(walked[mu])
        if ratios.get(s, 0.0) > mu
    )
    analytic = "largest friction ratio F_t/F_n of the nominal gait: " + ", ".join(
        f"{s:g}°: {v:.2f}" for s, v in sorted(ratios.items())
    )
    simulated = "; ".join(
        f"μ {mu:g}: walks {', '.join(f'{s:g}°' for s in sorted(ws)) or 'no slope'}"
        for mu, ws in walked.items()
    ) + "".join(f"; at {s:g}° μ {mu:g} loses the walk μ 1 keeps" for s, mu in lost)
    at = ratios.get(22.5)
    plan = plan_walk(spec, GaitParams.nominal(spec, 1.0, slope=np.deg2rad(22.5)))
    return {
        "claim": "friction: μ 0.4–0.6 may be insufficient on the incline (22.5°)",
        "paper": "0.4–0.6 may be insufficient",
        "analytic": analytic + f"; tan 22.5° = {np.tan(np.deg2rad(22.5)):.2f} is the least any "
        "walk from rest to rest needs there",
        "simulated": simulated or "no trial in this sweep",
        "agree": "analytic "
        + ("-" if at is None else "yes" if at > min(mus) else "no")
        + ", simulated "
        + ("yes" if lost else "no"),
        "evidence": "sweep.csv (t_c = 1 s, μ " + ", ".join(f"{m:g}" for m in mus) + ")",
        "axes": f"22.5°: {axes(plan)}",
        "basis": f"{PHYSICS} (the static part is tan θs whatever the robot)",
    }
