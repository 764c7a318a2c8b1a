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

from bench.files import atomic_path  # noqa: E402
from planner.joints import JOINT_NAMES, MJCF_JOINTS  # noqa: E402

_VERDICT_COLOR = {
    "stable": "tab:green",
    "zmp_outside": "tab:red",
    "slip": "tab:orange",
    "tip": "tab:purple",
    "fall": "tab:red",
    "diverged": "black",
    "error": "grey",
}


def stability_map(rows: list[dict], path: Path) -> Path:
    """Step time × slope, one panel per friction: face = analytic, ring = simulated verdict."""
    rows = [r for r in rows if not r["mass_scale"] and r["actuators"] == "stiff"]
    frictions = sorted({r["friction"] for r in rows})
    fig, axes = plt.subplots(
        1,
        max(1, len(frictions)),
        figsize=(4.2 * max(1, len(frictions)), 4),
        sharey=True,
        squeeze=False,
    )
    for ax, mu in zip(axes[0], frictions, strict=False):
        for r in (r for r in rows if r["friction"] == mu):
            ax.scatter(
                r["step_time"],
                r["slope_deg"],
                s=110,
                c="white",
                edgecolors=_VERDICT_COLOR.get(r["simulated_verdict"], "grey"),
                linewidths=2.5,
            )
            ax.scatter(
                r["step_time"],
                r["slope_deg"],
                s=35,
                c=_VERDICT_COLOR.get(r["analytic_verdict"], "grey"),
            )
        ax.set_title(f"μ = {mu:g}")
        ax.set_xlabel("step time [s]")
        ax.grid(alpha=0.3)
    axes[0, 0].set_ylabel("slope [deg]")
    handles = [
        plt.Line2D([], [], marker="o", ls="", color=c, label=v)
        for v, c in _VERDICT_COLOR.items()
        if v not in ("error",)
    ]
    fig.legend(
        handles=handles,
        loc="upper center",
        ncol=6,
        fontsize=8,
        title="dot = analytic, ring = simulated",
    )
    fig.tight_layout(rect=(0, 0, 1, 0.84))
    return _save(fig, path)


def zmp_traces(cases: list[tuple[str, object, object]], path: Path) -> Path:
    """The paper's Fig. 2-3 with the simulated CoP added: one step in the stance foot's frame.

    Args:
        cases: (title, plan, trial result) per panel; the second step (k = 1) is drawn.
    """
    fig, axes = plt.subplots(1, len(cases), figsize=(4.5 * len(cases), 4.5), squeeze=False)
    for ax, (title, plan, result) in zip(axes[0], cases, strict=True):
        step = _step_mask(plan, 1) & ~plan.double_support  # single support, as in the paper
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
        ax.set_title(title)
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
    """Eight panels (θ1..θ8) over the second step: a planned series and its simulated twin."""
    step = _step_mask(plan, 1)
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
    fig.tight_layout()
    return _save(fig, path)


def lipm_vs_step_time(step_times, analytic_mm, simulated_mm, path: Path) -> Path:
    """RMS distance of the LIPM ZMP from the multibody ZMP and the simulated CoP."""
    fig, ax = plt.subplots(figsize=(5.5, 4))
    ax.plot(step_times, analytic_mm, "o-", label="multibody ZMP (eq. 4) vs LIPM (eq. 5)")
    ax.plot(step_times, simulated_mm, "s--", label="simulated CoP vs LIPM (while standing)")
    ax.set_xlabel("step time [s]")
    ax.set_ylabel("RMS distance [mm]")
    ax.set_yscale("log")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return _save(fig, path)


def _step_mask(plan, k: int) -> np.ndarray:
    T = plan.params.step_time
    k = min(k, plan.params.steps - 1)
    return (plan.t >= k * T) & (plan.t < (k + 1) * T)


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
