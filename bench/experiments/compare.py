"""CI comparison of analytic and simulated ZMP on a small fixed set of trials.

``run_comparison()`` plays ``CASES`` (flat ground at 2, 0.5 and 0.4 s steps; 15°
and 22.5° at the nominal 1 s step), and ``check(rows, baseline)`` compares them
with a committed baseline: the check fails when a verdict (analytic or
simulated) flips, or when an RMS analytic–simulated ZMP distance grows by more
than ``TOLERANCE_MM + TOLERANCE_FRACTION × baseline``. MuJoCo is deterministic
for a given build, so on one machine the numbers repeat exactly; the tolerance
absorbs the small differences between MuJoCo builds and CPUs.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from slopewalk.bench.sim.trial import run_trial
from slopewalk.bench.sim.trial_spec import TrialSpec
from slopewalk.planner.config_file import read_text
from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.spec import RobotSpec

NOMINAL_STEP_TIME = 1.0  # [s]
CASES = (  # (name, step time [s], slope [deg])
    ("flat 2 s", 2.0, 0.0),
    ("flat 0.5 s", 0.5, 0.0),
    ("flat 0.4 s", 0.4, 0.0),
    ("15 deg", NOMINAL_STEP_TIME, 15.0),
    ("22.5 deg", NOMINAL_STEP_TIME, 22.5),
)
TOLERANCE_MM = 1.0
TOLERANCE_FRACTION = 0.10


def run_comparison(spec: RobotSpec) -> list[dict]:
    """Play every case with the nominal gait, stiff actuators, μ = 1."""
    rows = []
    for name, step_time, slope_deg in CASES:
        gait = GaitParams.nominal(spec, step_time, slope=np.deg2rad(slope_deg))
        result = run_trial(spec, TrialSpec(gait), predict=False)  # simulated columns only
        rows.append(
            {
                "case": name,
                "analytic_verdict": result.analytic_verdict,
                "simulated_verdict": result.simulated_verdict,
                "zmp_rms_mm": round(result.zmp_rms * 1e3, 3),
                "zmp_max_mm": round(result.zmp_max * 1e3, 3),
                "standing_fraction": round(result.standing_fraction, 3),
                "events": sorted({e.kind for e in result.events}),
            }
        )
    return rows


def check(rows: list[dict], baseline: list[dict] | None) -> list[str]:
    """Problems of ``rows`` against ``baseline`` (empty when none or no baseline)."""
    if baseline is None:
        return []
    old = {row["case"]: row for row in baseline}
    problems = []
    for row in rows:
        before = old.get(row["case"])
        if before is None:
            problems.append(f"{row['case']}: not in the baseline (refresh it: --write-baseline)")
            continue
        for key in ("analytic_verdict", "simulated_verdict"):
            if row[key] != before[key]:
                problems.append(f"{row['case']}: {key} flipped {before[key]} -> {row[key]}")
        limit = before["zmp_rms_mm"] * (1 + TOLERANCE_FRACTION) + TOLERANCE_MM
        if row["zmp_rms_mm"] > limit:
            problems.append(
                f"{row['case']}: ZMP RMS {row['zmp_rms_mm']:.2f} mm exceeds "
                f"{limit:.2f} mm (baseline {before['zmp_rms_mm']:.2f} mm)"
            )
    return problems


def report(rows: list[dict], baseline: list[dict] | None, problems: list[str]) -> str:
    """Markdown report: per case both verdicts, the RMS distance and its change."""
    old = {row["case"]: row for row in baseline or []}
    lines = [
        "# Analytic vs simulated ZMP (slopewalk compare)",
        "",
        f"Tolerance: a verdict may not flip; the RMS distance may grow by at most "
        f"{TOLERANCE_MM:g} mm + {TOLERANCE_FRACTION:.0%} of the baseline.",
        "",
        "| case | analytic | simulated | ZMP RMS [mm] | baseline [mm] | change [mm] | "
        "compared | events |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        before = old.get(row["case"])
        base = f"{before['zmp_rms_mm']:.2f}" if before else "-"
        change = f"{row['zmp_rms_mm'] - before['zmp_rms_mm']:+.2f}" if before else "-"
        lines.append(
            f"| {row['case']} | {row['analytic_verdict']} | "
            f"{row['simulated_verdict']} | {row['zmp_rms_mm']:.2f} | {base} | {change} | "
            f"{row['standing_fraction']:.0%} | {', '.join(row['events']) or '-'} |"
        )
    lines += ["", "**Result: " + ("FAIL**" if problems else "pass**")]
    lines += [f"- {p}" for p in problems]
    return "\n".join(lines) + "\n"


class CompareError(SlopewalkError):
    """A baseline that is missing, empty or not a list of case rows."""


BASELINE_KEYS = ("case", "analytic_verdict", "simulated_verdict", "zmp_rms_mm")


def load_baseline(path: str | Path) -> list[dict]:
    """The baseline rows of ``path`` (written by ``slopewalk compare --write-baseline``).

    Raises:
        CompareError: a missing, unreadable, empty or malformed file, or one that covers
            none of ``CASES``: a check against nothing must not pass.
    """
    path = Path(path)
    where = f"baseline {str(path)!r}"
    hint = "; write one with `slopewalk compare --write-baseline`"
    try:
        text = read_text(path, where=where, kind="a JSON file", error=CompareError)
    except CompareError as err:
        if str(err).endswith("no such file"):
            raise CompareError(f"{err}{hint}") from None
        raise
    if not text.strip():
        raise CompareError(f"{where}: is empty{hint}")
    try:
        rows = json.loads(text)
    except json.JSONDecodeError as err:
        raise CompareError(f"{where}: not valid JSON ({err})") from None
    if not isinstance(rows, list) or not rows:
        raise CompareError(f"{where}: must be a non-empty list of case rows{hint}")
    for i, row in enumerate(rows):
        missing = [k for k in BASELINE_KEYS if not isinstance(row, dict) or k not in row]
        if missing:
            raise CompareError(f"{where}: row {i} lacks {', '.join(missing)}")
        if not isinstance(row["zmp_rms_mm"], int | float) or isinstance(row["zmp_rms_mm"], bool):
            raise CompareError(f"{where}: row {i} zmp_rms_mm {row['zmp_rms_mm']!r}: not a number")
    known = {name for name, _, _ in CASES}
    if not known & {row["case"] for row in rows}:
        raise CompareError(f"{where}: covers none of the cases {', '.join(sorted(known))}")
    return rows
