"""Fidelity report: how often each analytic verdict agrees with MuJoCo, and why not.

``fidelity_report(tables)`` turns sweep tables (``tables.table.read_table`` rows)
into markdown: per table, the agreement of the paper's verdict (planned ZMP
inside the polygon), the compliance-aware verdict and the predicted verdict
(the most severe predicted event) with the simulated one, counting "walks"
(``stable``) against "does not" (the balance comparison: the strict walk verdict of
``bench/sim/walk_check.py`` is not what these count), both confusion tables, and, for a
table with the strict walk columns, one line of how often the plan's predicted walk
verdict (``predicted_walk``) says what the simulated one (``walk``) says; each disagreement of
the predicted verdict with the measured quantities that explain it; and the
issue's goals where the table holds their cells (flat 2 s stiff CoP RMS,
``servo_ff`` on every cell with ≥ 5 mm planned margin within the joint limits); for
a table of several seeds of command noise, the verdicts seed by seed, and for trials
replayed at the spec's estimated ends, where those ends decide the simulated verdict
(``replicas``).
"""

from __future__ import annotations

import csv
from collections import Counter
from pathlib import Path

import numpy as np

from slopewalk.bench.actuators import modes_where
from slopewalk.bench.report.replicas import (
    NOMINAL,
    replica_section,
    spec_decides,
    spec_end,
    spec_end_section,
    trial_key,
    undecided,
)
from slopewalk.bench.tables.sweep import SIMULATED_VERDICTS
from slopewalk.bench.tables.sweep import walks as _walks
from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.verdict import (
    LOADED_FRACTION,
    PAPER_VERDICTS,
    SLIP_DISTANCE,
    TIP_ANGLE,
    VERDICT_KINDS,
)
from slopewalk.planner.walk_prediction import TOUCH_ALLOWANCE

VERDICTS = ("paper", "compliant", "predicted")
_COLUMN = {
    "paper": "analytic_verdict",
    "compliant": "compliant_verdict",
    "predicted": "predicted_verdict",
}
REQUIRED = (
    *_COLUMN.values(),
    "predicted_events",
    "predicted_rotation_deg",
    "simulated_max_tilt_deg",
    "compliant_min_margin_mm",
    "unplanned_support_s",
)
SIM_VERDICTS = SIMULATED_VERDICTS  # the sweep table's, "error" included
MARGIN_GOAL_MM = 5.0  # servo_ff goal: cells whose plan keeps this margin
REPLICAS_UNLISTED = (
    "Not listed one by one in a table of spec ends (its rows are replicas of trials "
    "listed with their nominal table, `slopewalk fidelity`'s spec-end section pairs them; "
    "each row's measured quantities are in the table itself)."
)


class FidelityError(SlopewalkError):
    """A table that is missing, unreadable or not a sweep table of this version."""


def fidelity_report(
    tables: dict[str, list[dict]],
    *,
    command: str = "",
    held_out: dict[str, list[dict]] | None = None,
) -> str:
    """Markdown report of ``tables`` (name → rows), see module doc.

    Args:
        tables: Rows of each development sweep table (the grids the predictor was
            designed on), by its path.
        command: The command line that writes this report, quoted in it.
        held_out: Rows of each held-out table (gaits, robots never used to design the
            predictor), by its path; reported after the development tables, apart.
    """
    held_out = held_out or {}
    lines = ["# Fidelity: the analytic predictions against MuJoCo", ""]
    if command:
        lines += [
            f"Written by `{command}`; each table by `slopewalk sweep CONFIG --out DIR` "
            "(DIR/sweep.csv; the configs are in `bench/experiments/sweeps/`).",
            "",
        ]
    lines += _thresholds()
    for name, rows in (tables | held_out).items():
        missing = [c for c in REQUIRED if rows and c not in rows[0]]
        if missing:
            raise FidelityError(
                f"{name}: no column {missing[0]} (a sweep table of an older version; re-run it)"
            )
    lines += summary_table(tables, held_out)
    everything = tables | held_out
    short = Counter(set_name(k) for k in everything)  # a set's name, its path where two share one
    named = {(set_name(k) if short[set_name(k)] == 1 else k): v for k, v in everything.items()}
    lines += spec_end_section(named, _share)
    noisy = undecided(everything)
    spec = spec_decides(everything)
    if held_out:
        lines += ["# Development: the grids the predictor was designed on", ""]
    for name, rows in tables.items():
        lines += _table_section(name, rows, noisy, spec)
    if held_out:
        lines += [
            "# Held out: gaits and robots never used to design the predictor",
            "",
            "Each set is evaluated only: a change to the predictor is designed on the "
            "development grids and on a fresh draw of another seed, never on these.",
            "",
        ]
    for name, rows in held_out.items():
        lines += _table_section(name, rows, noisy, spec)
    return "\n".join(lines) + "\n"


def wilson(k: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """The Wilson score interval of a share of ``k`` in ``n`` (scipy's ``binomtest``):
    it stays inside [0, 1] and keeps its width at shares near 0 or 1, where the normal
    interval collapses; (0, 1) for n = 0.
    """
    if n == 0:
        return 0.0, 1.0
    from scipy.stats import binomtest

    ci = binomtest(k, n).proportion_ci(confidence, method="wilson")
    return float(ci.low), float(ci.high)


def agreement(rows: list[dict], verdict: str = "predicted") -> tuple[int, int]:
    """(agreeing, trials) of ``verdict`` (``VERDICTS``) with the simulated one, errors aside."""
    rows = [r for r in rows if r["simulated_verdict"] != "error"]
    return sum(_walks(r[_COLUMN[verdict]]) == _walks(r["simulated_verdict"]) for r in rows), len(
        rows
    )


def hedged(r) -> str:
    """The predicted verdict, or ``uncertain`` where the predictor's own two models of the
    walk the servos make disagree on whether it walks: the compliance-aware ZMP test
    (the static fixed point's ZMP inside the polygon) and the events of the servo loop's
    walk (``predicted_verdict``). No threshold: it says where the models part."""
    if _walks(r["compliant_verdict"]) != _walks(r["predicted_verdict"]):
        return "uncertain"
    return r["predicted_verdict"]


def hedged_agreement(rows: list[dict]) -> tuple[int, int, int]:
    """(agreeing, decided, uncertain) of ``hedged`` over ``rows``, errors aside."""
    rows = [r for r in rows if r["simulated_verdict"] != "error"]
    sure = [r for r in rows if hedged(r) != "uncertain"]
    ok = sum(_walks(r["predicted_verdict"]) == _walks(r["simulated_verdict"]) for r in sure)
    return ok, len(sure), len(rows) - len(sure)


def _hedged_cell(rows) -> str:
    ok, sure, unsure = hedged_agreement(rows)
    total = sure + unsure
    if not total:
        return "-"
    return _share(ok, sure) + f"; uncertain {unsure}/{total} {unsure / total:.1%}"


def _share(k: int, n: int) -> str:
    """``k/n share [low, high]`` with the Wilson interval, in percent."""
    if not n:
        return "-"
    low, high = wilson(k, n)
    return f"{k}/{n} {k / n:.1%} [{low:.1%}, {high:.1%}]"


def set_name(path: str) -> str:
    """A table's set name: its directory's (``results/fidelity/random/sweep.csv`` → random)."""
    return Path(path).parent.name or str(path)


def summary_table(tables: dict, held_out: dict) -> list[str]:
    """Set × actuator mode × verdict: agreement with its 95 % Wilson interval."""
    lines = [
        "## Agreement by set and actuator mode",
        "",
        "Agreement with the simulated verdict (walks or not), with its 95 % Wilson "
        "interval; every mode, then all modes together. *hedged*: the predicted verdict "
        "where the compliance-aware test agrees with it on walking, `uncertain` where the "
        "two disagree; its agreement counts the trials it decides, and its share of "
        "`uncertain` follows.",
        "",
        "| set | role | mode | paper | compliant | predicted | hedged |",
        "|---|---|---|---|---|---|---|",
    ]
    for role, group in (("development", tables), ("held out", held_out)):
        for name, rows in group.items():
            modes = sorted({r["actuators"] for r in rows})
            for mode in [*modes, "all"] if len(modes) > 1 else modes:
                sub = rows if mode == "all" else [r for r in rows if r["actuators"] == mode]
                cells = [_share(*agreement(sub, v)) for v in VERDICTS] + [_hedged_cell(sub)]
                lines.append(f"| {set_name(name)} | {role} | {mode} | " + " | ".join(cells) + " |")
    return lines + [""]


def _thresholds() -> list[str]:
    return [
        "Thresholds (one definition, `planner/verdict.py`, shared with the simulator's "
        "events in `bench/sim/events.py`, where their physical basis is stated): "
        f"tip angle {np.rad2deg(TIP_ANGLE):g}°, slip distance {SLIP_DISTANCE * 1e3:g} mm, "
        f"loaded foot > {LOADED_FRACTION:.0%} of the weight. Agreement counts a verdict "
        "as right when it says `stable` exactly where the simulated robot walks (no slip, "
        "tip, fall or divergence).",
        "",
    ]


def _table_section(
    name: str, rows: list[dict], noisy: dict | None = None, spec: dict | None = None
) -> list[str]:
    """Markdown of one table; ``noisy``: ``replicas.undecided`` of the report's tables,
    ``spec``: their ``replicas.spec_decides``."""
    noisy, spec = noisy or {}, spec or {}
    all_rows = rows
    rows = [r for r in rows if r["simulated_verdict"] != "error"]
    n = len(rows)
    lines = [f"## {name}: {n} trials", "", "| verdict | agrees | share |", "|---|---|---|"]
    for v in VERDICTS:
        ok = sum(_walks(r[_COLUMN[v]]) == _walks(r["simulated_verdict"]) for r in rows)
        lines.append(f"| {v} | {ok}/{n} | {ok / n:.1%} |" if n else f"| {v} | 0/0 | - |")
    modes = sorted({r["actuators"] for r in rows})
    if len(modes) > 1:
        lines += ["", "By actuator mode (predicted verdict): " + ", ".join(_by_mode(rows, modes))]
    errors = [r for r in all_rows if r["simulated_verdict"] == "error"]
    if errors:
        lines += ["", f"{len(errors)} trials raised and are not counted: " + "; ".join(
            sorted({str(r.get("error", "")) for r in errors})[:3])]  # fmt: skip
    lines += ["", "### Paper's verdict × simulated", ""]
    lines += confusion_table(rows, "analytic_verdict", PAPER_VERDICTS)
    lines += ["", "### Predicted verdict × simulated", ""]
    lines += confusion_table(rows, "predicted_verdict", ("stable", *VERDICT_KINDS))
    if rows and "predicted_walk" in rows[0]:  # a table with the strict walk columns
        lines += ["", walk_agreement(rows)]
    if not any(r.get("gait", "nominal") != "nominal" for r in rows):
        lines += _goals(rows)  # the issue-11 goals are the nominal gait's
    wrong = [r for r in rows if _walks(r["predicted_verdict"]) != _walks(r["simulated_verdict"])]
    lines += ["", f"### Disagreements of the predicted verdict ({len(wrong)})", ""]
    if wrong:
        classes = Counter(cause_class(r) for r in wrong)
        on_noise = sum(trial_key(r) in noisy for r in wrong)
        on_spec = sum(trial_key(r) in spec for r in wrong)
        lines += [
            "By measured cause: "
            + ", ".join(f"{k} {v}" for k, v in classes.most_common())
            + (
                f"; {on_noise} of them on trials whose simulated verdict command noise "
                "decides (MuJoCo does not decide them)"
                if on_noise
                else ""
            )
            + (
                f"; {on_spec} of them on trials whose simulated verdict moves within the "
                "spec's estimated ranges"
                if on_spec
                else ""
            ),
            "",
        ]
    if wrong and any(spec_end(r) != NOMINAL for r in rows):  # thousands of replicas
        return [*lines, REPLICAS_UNLISTED, ""]
    lines += [
        f"- {_label(r)}: {disagreement_cause(r)}"
        + (f"; MuJoCo does not decide it: {noisy[trial_key(r)]}" if trial_key(r) in noisy else "")
        + (f"; {spec[trial_key(r)]}" if trial_key(r) in spec else "")
        for r in wrong
    ] or ["none"]
    lines += replica_section(rows, _label)
    return lines + [""]


def walk_agreement(rows) -> str:
    """One line: how often the plan's strict verdict (``predicted_walk``) says what the
    simulation's (``walk``) says, and per check the trials each side names."""
    sure = [r for r in rows if r["predicted_walk"] != "not_predicted"]
    same = sum((r["predicted_walk"] == "walked") == (r["walk"] == "walked") for r in sure)
    parts = []
    for kind in ("overload", "shuffle"):
        pred = {id(r) for r in sure if r["predicted_walk"] == kind}
        sim = {id(r) for r in sure if r["walk"] == kind}
        parts.append(f"{kind} predicted {len(pred)}, simulated {len(sim)}, both {len(pred & sim)}")
    return (
        f"Predicted vs simulated strict walk: walked or not agree on {same} of {len(sure)} "
        f"trials; {'; '.join(parts)} (the plan predicts overload from its Newton–Euler "
        "torques plus the servo rotor's inertia × q̈, and shuffle from its swing clearance; "
        "off_footprint and pelvis_off only the simulation can see)."
    )


def _by_mode(rows, modes) -> list[str]:
    out = []
    for mode in modes:
        sub = [r for r in rows if r["actuators"] == mode]
        ok = sum(_walks(r["predicted_verdict"]) == _walks(r["simulated_verdict"]) for r in sub)
        out.append(f"{mode} {ok}/{len(sub)}")
    return out


def confusion_table(rows, column, kinds) -> list[str]:
    counts = Counter((r[column], r["simulated_verdict"]) for r in rows)
    sims = [s for s in SIM_VERDICTS if any(k[1] == s for k in counts)]
    lines = [
        "| analytic \\ simulated | " + " | ".join(sims) + " |",
        "|---|" + "---|" * len(sims),
    ]
    for kind in kinds:
        if any(k[0] == kind for k in counts):
            lines.append(f"| {kind} | " + " | ".join(str(counts[(kind, s)]) for s in sims) + " |")
    return lines


def _goals(rows) -> list[str]:
    lines = []
    stiff = modes_where(gains="stiff")
    flat = [
        r for r in rows if r["step_time"] == 2.0 and r["slope_deg"] == 0 and r["actuators"] in stiff
    ]
    if flat:
        lines += ["", "Flat ground, 2 s steps: simulated CoP vs analytic ZMP (RMS, max), "
                  "unplanned support (foot-time touching where the plan has the foot lifted, "
                  "or the reverse):", ""]  # fmt: skip
        lines += [
            f"- {r['actuators']}, μ {r['friction']:g}: RMS {r['zmp_rms_mm']:.2f} mm, max "
            f"{r['zmp_max_mm']:.1f} mm, unplanned support {r['unplanned_support_s']:.3f} s"
            for r in flat
        ]
        lines += [
            "",
            "Taken apart by phase and cause (touch-down, the floor's give, the double "
            "support's foot slide): `slopewalk cop-error`, results/cop_error.md.",
        ]
    servo_ff = modes_where(gains="spec", feedforward=True)  # the goal's modes
    ff = [
        r
        for r in rows
        if r["actuators"] in servo_ff
        and r["analytic_min_margin_mm"] >= MARGIN_GOAL_MM
        and "joint_limit" not in str(r["predicted_events"])
    ]
    if ff:
        walked = sum(_walks(r["simulated_verdict"]) for r in ff)
        lines += [
            "",
            f"{', '.join(servo_ff)} on the cells whose plan keeps ≥ {MARGIN_GOAL_MM:g} mm "
            f"margin within the joint limits: {walked}/{len(ff)} walk"
            + (
                " ("
                + "; ".join(
                    f"{_label(r)} {r['simulated_verdict']}"
                    for r in ff
                    if not _walks(r["simulated_verdict"])
                )
                + ")"  # fmt: skip
                if walked < len(ff)
                else ""
            ),
        ]
    return lines


def _label(r) -> str:
    scale = r["mass_scale"] or ""
    robot = r.get("robot", "default")
    return (
        f"t_c {r['step_time']:g} s, {r['slope_deg']:g}°, μ {r['friction']:g}, "
        f"{r['actuators']}"
        + (f", {scale}" if scale else "")
        + (f", robot {robot}" if robot and robot != "default" else "")
        + _gait_label(r)
    )


def _gait_label(r) -> str:
    """The gait of a row of a sweep of drawn or given gaits, else ""."""
    if r.get("gait", "nominal") == "nominal":
        return ""
    if not _finite(r.get("hip_height_m")):
        return f", {r['gait']}"
    return (
        f", {r['gait']} (Hz {r['hip_height_m'] * 1e3:.0f} mm, lift "
        f"{r['swing_lift_m'] * 1e3:.0f} mm, tilt {r['tilt_deg']:.1f}°, δ "
        f"{r['pelvis_offset_m'] * 1e3:.0f} mm, L {r['step_length_m'] * 1e3:.0f} mm, w "
        f"{r['sway_share']:.2f})"
    )


def disagreement_cause(r) -> str:
    """The measured quantities behind one disagreement, in one line."""
    sim = f"simulated {r['simulated_verdict']} ({_events(r['events'])}, first at " + (
        f"{r['first_event_time_s']:.2f} s)" if _finite(r["first_event_time_s"]) else "-)"
    )
    plan = (
        f"planned ZMP margin {r['analytic_min_margin_mm']:.1f} mm, on the reached walk "
        f"{r['compliant_min_margin_mm']:.1f} mm"
    )
    tracking = (
        f"joint tracking {r['tracking_rms_deg']:.2f}° RMS"
        if _finite(r["tracking_rms_deg"])
        else "no tracking sample"
    )
    support = f"unplanned support {r['unplanned_support_s']:.3f} s"
    rotation = (
        f"predicted support tilt {r['predicted_rotation_deg']:.2f}°, simulated "
        f"{r['simulated_max_tilt_deg']:.2f}°"
    )
    cause = f"**{cause_class(r)}**: "
    if _walks(r["predicted_verdict"]):
        return cause + f"predicted stable, {sim}; {plan}; {rotation}; {tracking}; {support}"
    return cause + (
        f"predicted {r['predicted_verdict']} ({_events(r['predicted_events'])}; {rotation}), "
        f"yet the robot walked ({_events(r['events'])}); {plan}; {tracking}; {support}"
    )


def cause_class(r) -> str:
    """Which measured mechanism a disagreement belongs to (results/README.md measures each).

    * servo sway: plain ``servo``, predicted stable, the quasi-static compliance pass
      keeping a positive margin: the servo loop's sway (``planner/servo_loop.py``)
      left too small by the model, while the simulated servo sways and tips;
    * slip of a rocking sole: predicted stable, simulated slip (no tip, no fall), the
      loaded sole tilting by more than a fifth of the tip angle (measured): a sole
      rocking on its edge holds by that edge alone, and slides (the predicted slip
      compares the planned friction ratio with μ on a flat sole);
    * rocking short of the tip angle: predicted stable, yet the predicted rocking
      turns the support by more than a fifth of the tip angle (it is there, only
      smaller than the simulator's): a landing's impact turning pitch into roll, which
      the two-axis rocking keeps apart (results/README.md);
    * a sole on its edge in the prediction only: predicted tip with the support's
      rocking short of the tip angle, so the tip is a sole the servos stand on its edge:
      their walk landing the swing sole tilted past the tip angle
      (``planner.verdict.landing_events``), or their open chain turning the two soles
      past it in double support (``double_support_events``), yet the robot walked;
    * rocking past the tip angle in the prediction only: predicted tip, yet the robot
      walked, its loaded foot tilting by more than a fifth of the tip angle (measured,
      ``simulated_max_tilt_deg``): the support rocked in MuJoCo as predicted, less far;
    * foot slide in the plan only: predicted ``foot_slide`` (the plan drags a loaded
      rear foot in double support past the slip distance: a large lean's
      hip width × (1/cos λ − 1), faster than the soft floor's contacts let a hopping
      sole stay loaded: ``planner.verdict.stretch_slide``), yet the robot walked: no
      loaded foot of MuJoCo's slid that far (its slip detection measures it);
    * ring the robot rode out: predicted ``ring`` (the walk lands again with the
      servos' ring from the last load transfer not yet settled, ``planner/servo_ring.py``), yet
      the robot walked: the ring it found was not enough to throw it;
    * a dragged swing sole the robot walked over: predicted ``swing_drag`` (the swing
      sole props the robot and the walk carries it along the plane,
      ``planner.verdict.swing_drag_events``), yet the robot walked, its swing foot on the
      plane for longer than ``TOUCH_ALLOWANCE`` in one single support (measured,
      ``swing_touch_s``): the sole dragged in MuJoCo too, and nothing tripped on it;
    * unexplained: none of these.
    """
    walks = _walks(r["predicted_verdict"])
    rocked = np.rad2deg(TIP_ANGLE) / 5  # [deg] a turn that is there, not the floor's give
    servo = modes_where(gains="spec", feedforward=False)
    if walks and r["actuators"] in servo and r["compliant_min_margin_mm"] > 0:
        return "servo sway"
    if walks and r["simulated_verdict"] == "slip" and r["simulated_max_tilt_deg"] > rocked:
        return "slip of a rocking sole"
    if walks and r["predicted_rotation_deg"] > rocked:
        return "rocking short of the tip angle"
    tipped = r["predicted_verdict"] == "tip" and _walks(r["simulated_verdict"])
    if tipped and not r["predicted_rotation_deg"] > np.rad2deg(TIP_ANGLE):
        return "a sole on its edge in the prediction only"
    if tipped and r["simulated_max_tilt_deg"] > rocked:
        return "rocking past the tip angle in the prediction only"
    if r["predicted_verdict"] == "foot_slide" and _walks(r["simulated_verdict"]):
        return "foot slide in the plan only"
    if r["predicted_verdict"] == "ring" and _walks(r["simulated_verdict"]):
        return "ring the robot rode out"
    dragged = r["predicted_verdict"] == "swing_drag" and _walks(r["simulated_verdict"])
    if dragged and r["swing_touch_s"] > TOUCH_ALLOWANCE:
        return "a dragged swing sole the robot walked over"
    return "unexplained"


def _events(text) -> str:
    return str(text).replace(";", ", ") if text else "no event"


def _finite(x) -> bool:
    return isinstance(x, float) and np.isfinite(x)


def read_tables(paths: list[str | Path]) -> dict[str, list[dict]]:
    """Rows of each sweep table, by its path.

    Raises:
        FidelityError: a missing or unreadable file, or one that is not a sweep table.
    """
    from slopewalk.bench.tables.table import read_table

    tables = {}
    for path in paths:
        if not Path(path).is_file():
            raise FidelityError(f"sweep table {str(path)!r}: no such file")
        try:
            tables[str(path)] = read_table(path)
        except (OSError, UnicodeDecodeError, KeyError, csv.Error) as err:
            raise FidelityError(f"sweep table {str(path)!r}: not a sweep table ({err})") from None
    return tables
