"""Replicas: the same trials over several seeds of command noise, verdict by verdict.

A sweep with ``command_noise`` and a list of seeds (``sweep/config.py``) plays every
trial once per seed, each with its own white noise on the commands
(``playback.noisy``), far below anything physical (1e-4° is 1.7 µrad, a thousandth
of the loops' own lag). A trial whose simulated verdict differs between seeds was
decided by the integration's last bits, not by the physics the analytic side
models. ``replica_section(rows)`` writes, for a table of more than one seed:

* each seed's agreement of the paper's and the predicted verdict with the
  simulated one (walks or not, as ``fidelity`` counts it), and their range;
* the trials whose simulated verdict differs between seeds, with the share of
  seeds in which they walk, and how many of the predicted verdict's disagreements
  fall on them.

``undecided(tables)`` collects those trials over a report's tables, so that a
disagreement on one of them in a table of one seed says MuJoCo does not decide it.
"""

from __future__ import annotations

from collections import defaultdict

# the inputs that make a trial, seed and noise aside (a sweep table's columns), and those
# of a drawn or given gait (``tables.sweep.GAIT_COLUMNS``), in the tables that have them
TRIAL_INPUTS = ("step_time", "slope_deg", "friction", "actuators", "robot", "mass_scale")
GAIT_INPUTS = ("gait", "hip_height_m", "swing_lift_m", "tilt_deg", "pelvis_offset_m",
               "step_length_m", "sway_share")  # fmt: skip


def seeds_of(rows: list[dict]) -> list:
    """The distinct seeds of ``rows``, in order of first appearance (0 for a row without)."""
    return list(dict.fromkeys(r.get("seed", 0) for r in rows))


def _walks(verdict) -> bool:
    return verdict == "stable"


def _agrees(r, column: str) -> bool:
    return _walks(r[column]) == _walks(r["simulated_verdict"])


def trial_key(r) -> tuple:
    """The inputs that make ``r``'s trial, seed and noise aside (``TRIAL_INPUTS``, and
    ``GAIT_INPUTS`` where the row has them)."""
    return tuple(r.get(c) for c in TRIAL_INPUTS) + tuple(r[c] for c in GAIT_INPUTS if c in r)


def flipping(rows: list[dict]) -> dict[tuple, list[dict]]:
    """Trial inputs → its rows, for each trial that walks under some seeds and not others."""
    by_trial: dict[tuple, list[dict]] = defaultdict(list)
    for r in rows:
        by_trial[trial_key(r)].append(r)
    return {
        key: group
        for key, group in by_trial.items()
        if len({_walks(r["simulated_verdict"]) for r in group}) > 1
    }


def replica_section(rows: list[dict], label) -> list[str]:
    """Markdown lines for a table of several seeds (module doc); [] for one seed.

    Args:
        rows: The table's rows (errors left out).
        label: Row → its short description (``fidelity``'s).
    """
    seeds = seeds_of(rows)
    if len(seeds) < 2:
        return []
    noise = {r.get("command_noise_deg", 0.0) for r in rows}
    lines = [
        "",
        f"### Replicas: {len(seeds)} seeds of command noise "
        + ", ".join(f"{x:g}°" for x in sorted(noise)),
        "",
        "| seed | trials | paper agrees | predicted agrees |",
        "|---|---|---|---|",
    ]
    shares = []
    for seed in seeds:
        sub = [r for r in rows if r.get("seed", 0) == seed]
        paper = sum(_agrees(r, "analytic_verdict") for r in sub)
        predicted = sum(_agrees(r, "predicted_verdict") for r in sub)
        shares.append((predicted / len(sub), predicted, len(sub)))
        lines.append(
            f"| {seed:g} | {len(sub)} | {paper}/{len(sub)} ({paper / len(sub):.1%}) | "
            f"{predicted}/{len(sub)} ({predicted / len(sub):.1%}) |"
        )
    low, high = min(shares), max(shares)
    flips = flipping(rows)
    trials = len({trial_key(r) for r in rows})
    wrong = [r for r in rows if not _agrees(r, "predicted_verdict")]
    on_flips = sum(trial_key(r) in flips for r in wrong)
    lines += [
        "",
        f"The predicted verdict agrees in {low[1]}/{low[2]} ({low[0]:.1%}) to "
        f"{high[1]}/{high[2]} ({high[0]:.1%}) of the trials, seed by seed. "
        f"{len(flips)} of {trials} trials walk under some seeds and not under others; "
        f"{on_flips} of the predicted verdict's {len(wrong)} disagreements over all seeds "
        "fall on them:",
        "",
    ]
    for group in flips.values():
        walked = sum(_walks(r["simulated_verdict"]) for r in group)
        others = sorted({r["simulated_verdict"] for r in group} - {"stable"})
        lines.append(
            f"- {label(group[0])}: walks under {walked}/{len(group)} seeds "
            f"(else {', '.join(others)}); predicted {group[0]['predicted_verdict']}"
        )
    return lines if flips else [*lines, "none"]


def undecided(tables: dict[str, list[dict]]) -> dict[tuple, str]:
    """Trial inputs → "walks under k/K seeds of command noise (table)", for each trial that
    flips in a table of several seeds among ``tables`` (name → rows): a disagreement on
    such a trial in any table is one MuJoCo itself does not decide."""
    out: dict[tuple, str] = {}
    for name, rows in tables.items():
        rows = [r for r in rows if r["simulated_verdict"] != "error"]
        if len(seeds_of(rows)) < 2:
            continue
        for key, group in flipping(rows).items():
            walked = sum(_walks(r["simulated_verdict"]) for r in group)
            out.setdefault(
                key, f"walks under {walked}/{len(group)} seeds of command noise ({name})"
            )
    return out
