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

Spec ends (a sweep with ``spec_ends``, ``sweep/config.py``) replay trials on the spec with
one estimated value at an end of its range (its ``spec_end`` column). ``spec_groups``
pairs each trial's nominal row with its rows at the ends, over all of a report's tables
(by ``trial_key``, which leaves the spec end aside); ``spec_decides`` names the trials
whose simulated verdict moves within the ranges, and ``spec_end_section`` counts, per
table of nominal rows and actuator mode, the agreement on the trials the spec decides,
that of the predicted verdict where it does not move itself, and the share of the specs
at which the predicted verdict says walk as a probability of walking (Brier score and
reliability table, beside the paper's binary test).
"""

from __future__ import annotations

from collections import defaultdict

from slopewalk.bench.tables.sweep import NOMINAL  # the spec_end of a row on the spec's own values
from slopewalk.bench.tables.sweep import walks as _walks

# the inputs that make a trial, seed and noise aside (a sweep table's columns), and those
# of a drawn or given gait (``tables.sweep.GAIT_COLUMNS``), in the tables that have them
TRIAL_INPUTS = ("step_time", "slope_deg", "friction", "actuators", "robot", "mass_scale")
GAIT_INPUTS = ("gait", "hip_height_m", "swing_lift_m", "tilt_deg", "pelvis_offset_m",
               "step_length_m", "sway_share")  # fmt: skip


def seeds_of(rows: list[dict]) -> list:
    """The distinct seeds of ``rows``, in order of first appearance (0 for a row without)."""
    return list(dict.fromkeys(r.get("seed", 0) for r in rows))


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


def spec_end(r) -> str:
    """The spec end ``r`` was played at: ``"KEY:low"``, ``"KEY:high"`` or ``"nominal"``
    (a table without the column)."""
    return r.get("spec_end") or NOMINAL


def spec_groups(tables: dict[str, list[dict]]) -> dict[tuple, dict[str, dict]]:
    """Trial inputs → {spec end → row}, over all ``tables`` (errors and rows with command
    noise aside; the first row of each end kept), for each trial played both at its
    nominal spec and at one end or more."""
    by_trial: dict[tuple, dict[str, dict]] = defaultdict(dict)
    for rows in tables.values():
        for r in rows:
            if r["simulated_verdict"] == "error" or r.get("command_noise_deg", 0):
                continue
            by_trial[trial_key(r)].setdefault(spec_end(r), r)
    return {k: ends for k, ends in by_trial.items() if NOMINAL in ends and len(ends) > 1}


def _moves(ends: dict[str, dict], column: str) -> bool:
    return len({_walks(r[column]) for r in ends.values()}) > 1


def spec_decides(tables: dict[str, list[dict]]) -> dict[tuple, str]:
    """Trial inputs → "walks at …; not at …" for each trial whose simulated verdict (walks
    or not) differs between its nominal spec and a spec end (``spec_groups``): a
    disagreement on it says the spec's estimates, not the predictor, decide it."""
    out = {}
    for key, ends in spec_groups(tables).items():
        if _moves(ends, "simulated_verdict"):
            walks = [e for e, r in ends.items() if _walks(r["simulated_verdict"])]
            not_ = [e for e, r in ends.items() if not _walks(r["simulated_verdict"])]
            out[key] = (
                f"the spec's estimates decide it (walks at {', '.join(walks)}; "
                f"not at {', '.join(not_)})"
            )
    return out


def spec_end_section(tables: dict[str, list[dict]], share) -> list[str]:
    """Markdown: per table of ``tables`` whose nominal rows have spec ends in any of them
    (``spec_groups``) and per actuator mode, how many trials the spec ends move in MuJoCo,
    how many of the predicted verdict's disagreements fall on them, the agreement of each
    verdict on the trials they do not move, and the predicted verdict hedged by its own ends
    (``uncertain`` where it moves itself). ``share``: (k, n) → its text with an interval
    (``fidelity._share``). [] when no trial has ends."""
    groups = spec_groups(tables)
    out, by_end, calibration = [], [], []
    for name, rows in tables.items():
        nominal = [
            r for r in rows if spec_end(r) == NOMINAL and trial_key(r) in groups
            and r["simulated_verdict"] != "error" and not r.get("command_noise_deg", 0)
        ]  # fmt: skip
        for mode in sorted({r["actuators"] for r in nominal}):
            sub = [r for r in nominal if r["actuators"] == mode]
            trials = [groups[trial_key(r)] for r in sub]
            ends = sorted({e for g in trials for e in g} - {NOMINAL})
            moved = {id(r) for r in sub if _moves(groups[trial_key(r)], "simulated_verdict")}
            decided = [r for r in sub if id(r) not in moved]
            missed = [r for r in sub if not _agrees(r, "predicted_verdict")]
            on_moved = sum(id(r) in moved for r in missed)
            sure = [r for r in sub if not _moves(groups[trial_key(r)], "predicted_verdict")]
            cells = [
                share(sum(_agrees(r, c) for r in decided), len(decided))
                for c in ("analytic_verdict", "compliant_verdict", "predicted_verdict")
            ]
            unsure = len(sub) - len(sure)
            out.append(
                f"| {name} | {mode} | {len(sub)} | {len(ends)} | "
                f"{len(moved)}/{len(sub)} {len(moved) / len(sub):.1%} | "
                f"{on_moved}/{len(missed)} | " + " | ".join(cells) + " | "
                f"{share(sum(_agrees(r, 'predicted_verdict') for r in sure), len(sure))}; "
                f"uncertain {unsure}/{len(sub)} {unsure / len(sub):.1%} |"
            )
            by_end += _end_rows(name, mode, trials, ends, share)
            calibration.append(_calibration_row(name, mode, trials))
    if not out:
        return []
    return [
        "## Where the spec's estimates decide the simulated verdict",
        "",
        "Trials replayed with one value of the spec's `[uncertain]` table at an end of its "
        "range (a sweep's `spec_ends`; the `spec_end` column), paired with their nominal "
        "rows. *moved*: trials whose simulated verdict (walks or not) differs at an end; "
        "*misses on them*: the predicted verdict's disagreements (nominal spec) among them; "
        "*decided*: each verdict's agreement on the other trials; *spec-hedged*: the "
        "predicted verdict where it says the same at every end, `uncertain` where it moves "
        "itself (what the predictor can know without MuJoCo), its agreement on the trials "
        "it decides and its share of `uncertain`.",
        "",
        "| table | mode | trials | ends | moved | misses on them | paper, decided | "
        "compliant, decided | predicted, decided | predicted, spec-hedged |",
        "|---|---|---|---|---|---|---|---|---|---|",
        *out,
        "",
        "End by end: the trials that walk in MuJoCo, those whose verdict (walks or not) "
        "differs from the nominal spec's (*moved*), those whose predicted verdict does "
        "(*predicted moved*: the prediction's own sensitivity to that value), those both "
        "move the same way (*alike*), and the predicted verdict's agreement, made on the "
        "same moved spec.",
        "",
        "| table | mode | spec | walk | moved | predicted moved | alike | predicted agrees |",
        "|---|---|---|---|---|---|---|---|",
        *by_end,
        "",
        "As a probability of walking: *p*, the share of the specs played (nominal and ends) "
        "at which the predicted verdict says `stable`, against whether MuJoCo's robot walks "
        "on the nominal spec. Brier scores (mean squared error; 0 is perfect) of *p*, of the "
        "predicted and the paper's verdicts as 0/1, and of MuJoCo's own share of the specs at "
        "which it walks (the nominal among them: the blur the spec's spread alone makes, not "
        "a prediction), then "
        "the reliability table: of the trials with *p* in each bin, how many walk.",
        "",
        "| table | mode | Brier: p | predicted 0/1 | paper 0/1 | MuJoCo's share | p = 0 | "
        "0 < p < ½ | ½ ≤ p < 1 | p = 1 |",
        "|---|---|---|---|---|---|---|---|---|---|",
        *calibration,
        "",
    ]


def _calibration_row(name, mode, groups: list[dict[str, dict]]) -> str:
    """``spec_end_section``'s calibration row of one table and mode (module doc; ``groups``:
    each trial's rows by spec end, the nominal one included)."""

    def walk_share(g, column):
        return sum(_walks(r[column]) for r in g.values()) / len(g)

    y = [float(_walks(g[NOMINAL]["simulated_verdict"])) for g in groups]
    p = [walk_share(g, "predicted_verdict") for g in groups]

    def brier(values) -> str:
        return f"{sum((v - t) ** 2 for v, t in zip(values, y, strict=True)) / len(y):.3f}"

    bins = [lambda x: x == 0, lambda x: 0 < x < 0.5, lambda x: 0.5 <= x < 1, lambda x: x == 1]
    cells = []
    for inside in bins:
        hits = [t for v, t in zip(p, y, strict=True) if inside(v)]
        cells.append(f"{int(sum(hits))}/{len(hits)} walk" if hits else "-")
    return (
        f"| {name} | {mode} | {brier(p)} | "
        f"{brier([float(_walks(g[NOMINAL]['predicted_verdict'])) for g in groups])} | "
        f"{brier([float(_walks(g[NOMINAL]['analytic_verdict'])) for g in groups])} | "
        f"{brier([walk_share(g, 'simulated_verdict') for g in groups])} | "
        + " | ".join(cells)
        + " |"
    )


def _end_rows(name, mode, groups: list[dict[str, dict]], ends: list[str], share) -> list[str]:
    """``spec_end_section``'s end-by-end rows of one table and mode (``groups``: each
    trial's rows by spec end): MuJoCo's walks, the trials the end moves in MuJoCo and in the
    prediction (walks or not, against the same verdict on the nominal spec), those it moves
    alike in both (the same way), and the predicted verdict's agreement there."""
    rows = []
    for end in [NOMINAL, *ends]:
        pairs = [(g[NOMINAL], g[end]) for g in groups if end in g]
        walk = sum(_walks(r["simulated_verdict"]) for _, r in pairs)
        shift = [(_shift(n, r, "simulated_verdict"), _shift(n, r, "predicted_verdict"))
                 for n, r in pairs]  # fmt: skip
        moved = sum(s != 0 for s, _ in shift)
        predicted = sum(p != 0 for _, p in shift)
        alike = sum(s != 0 and s == p for s, p in shift)
        ok = sum(_agrees(r, "predicted_verdict") for _, r in pairs)
        rows.append(
            f"| {name} | {mode} | {end} | {walk}/{len(pairs)} | {moved} | {predicted} | "
            f"{alike} | {share(ok, len(pairs))} |"
        )
    return rows


def _shift(nominal: dict, at_end: dict, column: str) -> int:
    """+1 where ``column``'s verdict walks at the end and not on the nominal spec, −1 the
    other way, 0 where the end does not move it."""
    return int(_walks(at_end[column])) - int(_walks(nominal[column]))
