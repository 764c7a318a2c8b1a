"""Open loop vs closed-loop controllers over a sweep file's trials: which walk.

``compare_controllers`` plays every trial of a sweep (default: the paper's) open
loop (one ``mujoco.rollout``) and with each controller (``slopewalk.bench.sim.env``), on
local spawned worker processes (``map_local``), and ``report`` writes the markdown table of
``results/controllers.md``: per controller, how many trials walk (strict walk
verdict ``walked``, ``bench/sim/walk_check.py``), which ones it gains and loses against
open loop, and the verdict of every trial.
"""

from __future__ import annotations

import dataclasses
import multiprocessing
from concurrent.futures import ProcessPoolExecutor

from slopewalk.bench.controllers import SHIPPED
from slopewalk.bench.sim.trial import run_trial

OPEN_LOOP = "open loop"


def play(job) -> dict:
    """Verdict, first event and ZMP RMS of one (sweep trial, controller or None).

    No timing: the table is the same bytes every time it is regenerated.
    """
    trial, controller = job
    trial_spec = dataclasses.replace(trial.trial_spec(), controller=controller)
    result = run_trial(trial.spec, trial_spec, predict=False)  # simulated columns only
    lost = [e for e in result.events if e.kind != "torque_limit"]
    return {
        "verdict": result.simulated_verdict,
        "walk": result.walk_verdict,
        "first": f"{lost[0].kind} {lost[0].time:.2f} s" if lost else "",
        "zmp_rms_mm": result.zmp_rms * 1e3,
    }


def compare_controllers(config, controllers=SHIPPED, *, workers: int = 1) -> dict:
    """{"trials": labels, OPEN_LOOP: [row per trial], controller: [...], ...}."""
    trials = list(config.trials)
    names = [None, *controllers]
    jobs = [(trial, name) for name in names for trial in trials]
    rows = map_local(play, jobs, workers)
    out = {"trials": [t.label for t in trials]}
    for k, name in enumerate(names):
        out[name or OPEN_LOOP] = rows[k * len(trials) : (k + 1) * len(trials)]
    return out


def map_local(fn, items: list, workers: int) -> list:
    """``fn`` over ``items``: here with one worker, else on spawned processes (a fork of a
    process whose numba kernel has started its OpenMP threads is refused)."""
    if workers <= 1:
        return [fn(item) for item in items]
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
        return list(pool.map(fn, items, chunksize=4))


def report(table: dict, *, source: str, command: str) -> str:
    """The markdown comparison (module doc)."""
    labels = table["trials"]
    names = [k for k in table if k != "trials"]
    base = [r["walk"] == "walked" for r in table[OPEN_LOOP]]
    lines = [
        "# Open loop vs closed-loop controllers",
        "",
        f"Trials of `{source}` ({len(labels)}), each played open loop (the plan's joint "
        "angles through one `mujoco.rollout`) and with each controller "
        "(`bench/controllers/`, stepped through the `dm_env` environment `bench/sim/env.py`). "
        "A trial *walks* when its strict walk verdict is `walked`: no slip, tip or fall, "
        "and it walked the plan (each landing on its footprint, the swing foot off the plane, "
        "the pelvis at the end pose, every actuator within the servo's stall torque; "
        "`docs/verdicts.md`).",
        "",
        f"Regenerate with `{command}`.",
        "",
        "| policy | walks | gained vs open loop | lost vs open loop |",
        "|---|---|---|---|",
    ]
    for name in names:
        rows = table[name]
        walks = [r["walk"] == "walked" for r in rows]
        gained = [labels[i] for i, (w, b) in enumerate(zip(walks, base, strict=True)) if w > b]
        lost = [labels[i] for i, (w, b) in enumerate(zip(walks, base, strict=True)) if w < b]
        lines.append(
            f"| {name} | {sum(walks)} / {len(rows)} | {len(gained)}: {'; '.join(gained) or '-'} "
            f"| {len(lost)}: {'; '.join(lost) or '-'} |"
        )
    lines += ["", "| trial | " + " | ".join(names) + " |", "|---" * (len(names) + 1) + "|"]
    for i, label in enumerate(labels):
        cells = []
        for name in names:
            r = table[name][i]
            first = f" ({r['first']})" if r["first"] else ""
            walk = f" / {r['walk']}" if r["walk"] not in ("walked", r["verdict"]) else ""
            cells.append(f"{r['verdict']}{walk}{first}")
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    lines += [
        "",
        "Cells: balance verdict, / the strict walk verdict where the robot kept its balance "
        "but did not walk the plan (first slip/tip/fall and its time after the walk starts). "
        "Speed: `slopewalk benchmark controller` (closed-loop vs rollout steps/s).",
    ]
    return "\n".join(lines) + "\n"
