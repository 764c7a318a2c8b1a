"""Figures of results/: stability map, ZMP traces, torques, joint angles, LIPM vs multibody.

Each function takes already-computed data (sweep rows, plans, trial results)
and writes one PNG; degrees and millimetres appear only here, on the axes.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from slopewalk.bench.actuators import DEFAULT_MODE  # noqa: E402
from slopewalk.bench.files import atomic_path  # noqa: E402
from slopewalk.bench.sim.events import LOST, VERDICTS  # noqa: E402
from slopewalk.planner.joints import JOINT_NAMES, MJCF_JOINTS  # noqa: E402
from slopewalk.planner.verdict import PAPER_VERDICTS  # noqa: E402

# One colour and one marker per outcome, so no two are told apart by hue alone: the
# Okabe-Ito palette (distinct under the common colour-vision deficiencies) and shapes
# that also differ in greyscale. "stable" is the same on both sides, so agreement shows.
_VERDICT_STYLE = {  # verdict: (colour, marker)
    "stable": ("#009E73", "o"),  # bluish green, circle
    "zmp_outside": ("#D55E00", "s"),  # vermillion, square
    "slip": ("#E69F00", ">"),  # orange, right triangle
    "tip": ("#CC79A7", "^"),  # reddish purple, up triangle
    "fall": ("#000000", "v"),  # black, down triangle
    "diverged": ("#0072B2", "X"),  # blue, cross
    "error": ("#999999", "x"),  # grey, thin cross
}


def _style(verdict: str) -> tuple[str, str]:
    return _VERDICT_STYLE.get(verdict, _VERDICT_STYLE["error"])


LEGENDS_SIDE_BY_SIDE = 9.0  # [in]: a figure narrower than this stacks its two legends
MAP_PANEL_HEIGHT = 3.6  # [in], one row of panels of the stability map
STACKED_LEGENDS = 1.35  # [in] above the panels for the two legends one over the other


def stability_map(rows: list[dict], path: Path) -> Path:
    """Step time × slope, one panel per friction and one row of panels per robot (the
    table's ``robot`` column): inner filled marker = analytic verdict, outer open marker =
    simulated verdict (each outcome its own colour and shape). The two legends sit side by
    side above a wide figure, one over the other above a narrow one, never on each other."""
    rows = [r for r in rows if not r["mass_scale"] and r["actuators"] == DEFAULT_MODE]
    frictions = sorted({r["friction"] for r in rows})
    names = list(dict.fromkeys(r.get("robot", "default") for r in rows)) or ["default"]
    labelled = names != ["default"]
    width = 4.2 * max(1, len(frictions))
    stacked = width < LEGENDS_SIDE_BY_SIDE
    if stacked:
        width = max(width, 5.6)  # the simulated legend's five entries in one line
        height = MAP_PANEL_HEIGHT * len(names) + STACKED_LEGENDS
        top = 1 - STACKED_LEGENDS / height
    elif len(names) == 1:
        height, top = 4.3, 0.84
    else:
        height = MAP_PANEL_HEIGHT * len(names) + 0.7
        top = 1 - 0.7 / height
    fig, axes = plt.subplots(
        len(names), max(1, len(frictions)), figsize=(width, height), sharey=True, squeeze=False
    )
    for row_axes, name in zip(axes, names, strict=True):
        mine = [r for r in rows if r.get("robot", "default") == name]
        for ax, mu in zip(row_axes, frictions, strict=False):
            _map_panel(ax, [r for r in mine if r["friction"] == mu])
            ax.set_title(f"robot {name}, μ = {mu:g}" if labelled else f"μ = {mu:g}")
        row_axes[0].set_ylabel(f"{name}\nslope [deg]" if labelled else "slope [deg]")
    legends = (
        ("analytic (filled, inside)", PAPER_VERDICTS, True, (0.3, 1.0)),
        ("simulated (open, outside)", VERDICTS, False, (0.65, 1.0)),
    )
    for k, (side, verdicts, filled, anchor) in enumerate(legends):
        fig.legend(
            handles=[_legend_marker(v, filled=filled) for v in verdicts],
            loc="upper center",
            bbox_to_anchor=(0.5, 1.0 - k * 0.62 / height) if stacked else anchor,
            ncol=len(verdicts),
            fontsize=8,
            title=side,
            title_fontsize=8,
        )
    fig.tight_layout(rect=(0, 0, 1, top))
    return _save(fig, path)


def _map_panel(ax, rows: list[dict]) -> None:
    """One panel of the stability map: a ring (simulated) around a dot (analytic) per row."""
    for r in rows:
        colour, marker = _style(r["simulated_verdict"])
        ax.scatter(
            r["step_time"], r["slope_deg"], s=190, marker=marker, facecolors="white",
            edgecolors=colour, linewidths=2.2, zorder=2,
        )  # fmt: skip
        colour, marker = _style(r["analytic_verdict"])
        ax.scatter(
            r["step_time"], r["slope_deg"], s=38, marker=marker, c=colour,
            edgecolors="none", zorder=3,
        )  # fmt: skip
    ax.set_xlabel("step time [s]")
    ax.grid(alpha=0.3)


def _legend_marker(verdict: str, *, filled: bool):
    colour, marker = _style(verdict)
    face = colour if filled else "white"
    size = 7 if filled else 10
    return plt.Line2D(
        [], [], marker=marker, ls="", markersize=size, markerfacecolor=face,
        markeredgecolor=colour, markeredgewidth=0 if filled else 2, label=verdict,
    )  # fmt: skip


def zmp_traces(cases: list[tuple[str, object, object]], path: Path) -> Path:
    """The paper's Fig. 2-3 with the simulated CoP added: one step in the stance foot's frame.

    Args:
        cases: (title, plan, trial result) per panel; the single support of the second
            step (k = 1) is drawn. Where the simulated CoP stops short (the robot tipped,
            fell or diverged: ``bench/sim/trial.py`` compares only before that), the
            panel says when and why.
    """
    fig, axes = plt.subplots(1, len(cases), figsize=(4.5 * len(cases), 4.8), squeeze=False)
    for ax, (title, plan, result) in zip(axes[0], cases, strict=True):
        k, step = _step(plan, 1)
        step = step & ~plan.double_support  # single support, as in the paper
        origin = plan.stance_sole[step][0, :2]
        spec = plan.spec
        rect = np.array(
            [
                [spec.ankle_to_toe, -spec.foot_width / 2],
                [spec.ankle_to_toe, spec.foot_width / 2],
                [-spec.heel_offset, spec.foot_width / 2],
                [-spec.heel_offset, -spec.foot_width / 2],
                [spec.ankle_to_toe, -spec.foot_width / 2],
            ]
        )
        rect[:, 1] += spec.sole_shift(plan.stance[step][0])  # a sole beside its ankle
        ax.plot(*(rect * 1e3).T, "k-", lw=1.5, label="stance foot")
        ax.plot(*((plan.zmp[step] - origin) * 1e3).T, color="tab:orange", label="ZMP (eq. 4)")
        ax.plot(*((plan.com[step][:, :2] - origin) * 1e3).T, color="tab:green", label="CoM")
        ax.plot(
            *((plan.zmp_lipm[step] - origin) * 1e3).T, color="tab:blue", ls=":", label="LIPM ZMP"
        )
        s = result.series
        sim = (s["t"] >= plan.t[step][0]) & (s["t"] <= plan.t[step][-1]) & s["standing"]
        ax.plot(
            *((s["cop"][sim] - origin) * 1e3).T,
            color="tab:red",
            lw=0.8,
            label="simulated CoP (while standing)",
        )
        note = _lost_note(result, plan.t[step][0], plan.t[step][-1], any_cop=sim.any())
        if note:
            ax.text(
                0.02, 0.98, note, transform=ax.transAxes, fontsize=7, va="top",
                color="#D55E00", bbox={"facecolor": "white", "alpha": 0.85, "lw": 0},
            )  # fmt: skip
        ax.set_title(f"{title}\nstep {k + 1} of {plan.params.steps}, single support", fontsize=10)
        ax.set_xlabel("x along the slope [mm]")
        ax.set_ylabel("y [mm]")
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7, loc="best")
    fig.tight_layout()
    return _save(fig, path)


def joint_torques(plan, result, path: Path) -> Path:
    """Fig. 4: Newton-Euler torques over one step, with the simulated actuator torques."""
    return _joint_panels(
        plan,
        result,
        path,
        planned=plan.tau,
        simulated="actuator_force",
        labels=("Newton-Euler", "MuJoCo actuator"),
        unit="torque [N m]",
        scale=1.0,
    )


def joint_angles(plan, result, path: Path) -> Path:
    """Fig. 5: planned vs simulated joint angles θ1..θ8 over one step."""
    return _joint_panels(
        plan,
        result,
        path,
        planned=plan.q,
        simulated="q_simulated",
        labels=("planned", "simulated"),
        unit="angle [deg]",
        scale=np.rad2deg(1.0),
    )


def _joint_panels(plan, result, path, *, planned, simulated, labels, unit, scale) -> Path:
    """Eight panels (θ1..θ8) over the second step: a planned series and its simulated twin.

    The figure's title names the case (slope, step time, μ, actuators, Hz) and the step.
    """
    k, step = _step(plan, 1)
    start = plan.t[step][0]
    s = result.series
    sim = (s["t"] >= start) & (s["t"] <= plan.t[step][-1])
    order = _table_order_of_mjcf(plan.stance[step][0])
    fig, axes = plt.subplots(2, 4, figsize=(13, 5.5), sharex=True)
    for j, ax in enumerate(axes.ravel()):
        ax.plot(plan.t[step] - start, scale * planned[step, j], label=labels[0])
        ax.plot(s["t"][sim] - start, scale * s[simulated][sim, order[j]], lw=0.8, label=labels[1])
        ax.set_title(f"θ{j + 1} {JOINT_NAMES[j].replace('_', ' ')}", fontsize=9)
        ax.grid(alpha=0.3)
    for ax in axes[:, 0]:
        ax.set_ylabel(unit)
    for ax in axes[1]:
        ax.set_xlabel("time in step [s]")
    axes[0, 0].legend(fontsize=7)
    fig.suptitle(_case_title(plan, result, k, start, plan.t[step][-1]), fontsize=10)
    fig.tight_layout()
    return _save(fig, path)


def _case_title(plan, result, k: int, start: float, end: float) -> str:
    """E.g. ``flat, t_c = 1 s, μ = 1, stiff actuators, Hz 0.200 m: step 2 of 4 (...)``."""
    g, trial = plan.params, result.trial
    slope = np.rad2deg(g.slope)
    where = "flat" if slope == 0 else f"slope {slope:g}°"
    stance = "left" if plan.stance[plan.t >= start][0] == 0 else "right"
    return (
        f"{where}, t_c = {g.step_time:g} s, μ = {trial.friction:g}, {trial.actuators} actuators, "
        f"Hz {g.hip_height:.3f} m, tilt {np.rad2deg(g.tilt):g}° — step {k + 1} of {g.steps} "
        f"(t = {start:g} … {end:.3g} s, {stance} foot stance)"
    )


def _lost_note(result, start: float, end: float, *, any_cop: bool) -> str:
    """Why the simulated CoP is missing or cut short in [start, end] [s]; "" if it is not."""
    lost = next((e for e in result.events if e.kind in LOST), None)
    if lost is None or lost.time > end:
        return "" if any_cop else "no simulated CoP: no foot on the plane"
    after = next((e for e in result.events if e.kind == "fall"), None)
    fell = f"; fell at {after.time:.2f} s" if after and after is not lost else ""
    if any_cop:
        head = f"simulated CoP ends at {lost.time:.2f} s: {lost.kind}"
    else:
        head = (
            f"no simulated CoP: {lost.kind} at {lost.time:.2f} s{fell},\n"
            f"before this single support ({start:.2f} … {end:.2f} s)"
        )
        fell = ""
    return f"{head}{fell}\n{lost.cause}"


LIPM_MARKERS = ("o", "^", "D", "v", "P", "X")  # one per robot


def lipm_vs_step_time(series: dict, path: Path) -> Path:
    """RMS distance of the LIPM ZMP from the multibody ZMP and the simulated CoP.

    Args:
        series: robot name (None: the table's only robot, unnamed) → (step times [s],
            multibody ZMP to LIPM [mm], simulated CoP to LIPM [mm]); each robot its own
            pair of lines, never one line through two robots.
    """
    fig, ax = plt.subplots(figsize=(5.5, 4))
    for k, (name, (step_times, analytic_mm, simulated_mm)) in enumerate(series.items()):
        if name is None:
            styles, who = ("o-", "s--"), ""
        else:
            marker = LIPM_MARKERS[k % len(LIPM_MARKERS)]
            styles, who = (f"{marker}-", f"{marker}--"), f"{name}: "
        colour = {} if name is None else {"color": f"C{k}"}
        ax.plot(
            step_times, analytic_mm, styles[0], **colour,
            label=f"{who}multibody ZMP (eq. 4) vs LIPM (eq. 5)",
        )  # fmt: skip
        ax.plot(
            step_times, simulated_mm, styles[1], **colour,
            label=f"{who}simulated CoP vs LIPM (while standing)",
        )  # fmt: skip
    ax.set_xlabel("step time [s]")
    ax.set_ylabel("RMS distance [mm]")
    ax.set_yscale("log")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8 if len(series) == 1 else 7)
    fig.tight_layout()
    return _save(fig, path)


def _step(plan, k: int) -> tuple[int, np.ndarray]:
    """Step k (0-based, clamped to the walk) and the mask of its samples."""
    T = plan.params.step_time
    k = min(k, plan.params.steps - 1)
    return k, (plan.t >= k * T) & (plan.t < (k + 1) * T)


def _table_order_of_mjcf(stance: int) -> list[int]:
    """Index into MJCF order of each Table-I joint for a given stance leg."""
    legs = ("l_", "r_") if stance == 0 else ("r_", "l_")
    kinds = ("ankle_roll", "ankle_pitch", "knee", "hip_pitch")
    names = [legs[0] + k for k in kinds] + [legs[1] + k for k in reversed(kinds)]
    return [MJCF_JOINTS.index(n) for n in names]


def _save(fig, path: Path) -> Path:
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return path
