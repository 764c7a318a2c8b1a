"""``slopewalk robot compare MODEL``: one plan on the twin and on the unmodified model.

The plan is made for the imported spec (``robot import``'s, or ``--robot``'s) and played
open loop, the same commands in each of ``VARIANTS``:

* ``twin``: the bench's own model of the spec (``sim.model.scene_xml``), everything the
  planner assumes (held joints rigid, the spec's lumped links, the twin's contact);
* ``model``: the user's model as it is (``robot_import.scene.ModelScene``): held joints
  held by their actuators, its own contact options;
* ``model, held welded``: the held joints welded at their angles (``ModelScene.welded``),
  so the difference to ``model`` is what the held joints' give under load contributes;
* ``model, twin's contact``: the twin's contact options (``ModelScene.twin_contact``),
  so the difference to ``model`` is what the contact model contributes;
* ``model, welded + twin's contact``: both; what is left against ``twin`` is everything
  else (the links' shapes the spec lumps, the soles' boxes, the model's own servos and
  joint friction, its integrator).

Each row (``ModelRow``) measures the walk against the plan, while the robot stands (before
a tip or fall): CoP–ZMP RMS and max (the trial's ``zmp_rms``), the CoP's least margin to
the planned support polygon, the pelvis origin's RMS distance to the planned one along
x, y, z of the slope frame S, and the footprints: each planned stance phase's sole point
against where that foot's sole is at mid-phase, in the plane (S's x, y).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from slopewalk.bench.sim.events import LOST
from slopewalk.bench.sim.playback import on_rows
from slopewalk.bench.sim.trial import TrialResult, run_trial
from slopewalk.bench.sim.trial_spec import TrialSpec
from slopewalk.planner.kinematics import Chain, rotation_slope_to_world
from slopewalk.planner.plan import Plan

VARIANTS = (  # (label, played on the model, held joints welded, the twin's contact options)
    ("twin", False, False, False),
    ("model", True, False, False),
    ("model, held welded", True, True, False),
    ("model, twin's contact", True, False, True),
    ("model, welded + twin's contact", True, True, True),
)


@dataclass(frozen=True)
class ModelRow:
    """One variant's walk against the plan (lengths [m], times [s]; module doc)."""

    variant: str
    verdict: str  # the simulated verdict
    lost: str  # the first tip, fall or divergence "kind at t s", or ""
    standing_fraction: float  # share of the walk before any loss
    cop_rms: float
    cop_max: float
    min_margin: float  # the CoP's least margin to the planned support polygon
    pelvis_rms: tuple[float, float, float]  # along x, y, z of S
    footprint_max: float  # the largest mid-phase sole distance to its planned point
    footprints: int  # stance phases compared (those before any loss)
    unplanned_support: float  # foot-time the contacts differed from the plan's
    peak_torque: float  # [N m], simulated, mapped joints
    max_tilt: float  # [rad], a loaded foot off the plane


def compare_model(scene, trial: TrialSpec, plan: Plan) -> list[ModelRow]:
    """``plan`` played in each of ``VARIANTS`` (``scene``: the model's ``ModelScene``)."""
    rows = []
    for label, on_model, welded, twin_contact in VARIANTS:
        where = replace(scene, welded=welded, twin_contact=twin_contact) if on_model else None
        result = run_trial(scene.spec, trial, plan=plan, predict=False, scene=where)
        rows.append(model_row(label, plan, result))
    return rows


def model_row(label: str, plan: Plan, result: TrialResult) -> ModelRow:
    """The measures of one played ``plan`` (module doc)."""
    series = result.series
    standing = np.asarray(series["standing"], bool)
    lost = [e for e in result.events if e.kind in LOST]
    return ModelRow(
        variant=label,
        verdict=result.simulated_verdict,
        lost=f"{lost[0].kind} at {lost[0].time:.2f} s" if lost else "",
        standing_fraction=result.standing_fraction,
        cop_rms=result.zmp_rms,
        cop_max=result.zmp_max,
        min_margin=result.simulated_min_margin,
        pelvis_rms=pelvis_rms(plan, series, standing),
        **_footprints(plan, series, standing),
        unplanned_support=result.unplanned_support_s,
        peak_torque=result.peak_torque_simulated,
        max_tilt=result.simulated_max_tilt,
    )


def planned_pelvis(plan: Plan) -> np.ndarray:
    """The planned pelvis origin (midway between the hips) in S [m], (n, 3) on ``plan.t``."""
    chain = Chain.from_spec(plan.spec)
    frames = chain.frames(plan.q, plan.stance_sole, plan.stance)
    return chain.pelvis_pose(frames, plan.stance)[0]


def pelvis_rms(plan: Plan, series: dict, standing: np.ndarray) -> tuple[float, float, float]:
    """RMS of the simulated minus the planned pelvis origin along S's x, y, z [m]."""
    R = rotation_slope_to_world(plan.params.slope)
    simulated = np.asarray(series["qpos"])[:, :3] @ R  # world → S (row vectors)
    error = (simulated - on_rows(series["t"], plan, planned_pelvis(plan)))[standing]
    if not error.size:
        return (float("nan"),) * 3
    return tuple(float(v) for v in np.sqrt(np.mean(error**2, axis=0)))


def _footprints(plan: Plan, series: dict, standing: np.ndarray) -> dict:
    """``footprint_max`` and ``footprints`` of ``ModelRow`` (module doc)."""
    t, sole = np.asarray(series["t"]), np.asarray(series["sole"])
    change = np.flatnonzero(np.diff(plan.stance)) + 1
    starts, ends = np.r_[0, change], np.r_[change, plan.t.size]
    errors = []
    for i0, i1 in zip(starts, ends, strict=True):
        row = int(np.clip(np.searchsorted(t, (plan.t[i0] + plan.t[i1 - 1]) / 2), 0, t.size - 1))
        if not standing[row]:
            break
        foot = int(plan.stance[i0])
        errors.append(np.hypot(*(sole[row, foot, :2] - plan.stance_sole[i0, :2])))
    return {"footprint_max": max(errors, default=float("nan")), "footprints": len(errors)}


def report(rows: list[ModelRow], *, scene, trial: TrialSpec, plan: Plan, command: str) -> str:
    """The markdown report of ``compare_model``'s rows (lengths in mm, angles in degrees)."""
    spec, gait = scene.spec, trial.gait
    head = [
        f"# {scene.name}: the twin against the unmodified model",
        "",
        f"`{command}`",
        "",
        f"Plan: {gait.steps} steps of {gait.step_time:g} s on {np.rad2deg(gait.slope):g} deg, "
        f"lean {np.rad2deg(gait.tilt):g} deg, hip height {gait.hip_height:g} m, "
        f"mu {trial.friction:g}, {trial.actuators}; analytic verdict "
        f"{'stable' if plan.stable else 'zmp_outside'}, least ZMP margin "
        f"{plan.margin.min() * 1e3:.1f} mm; planned peak torque "
        f"{np.abs(plan.tau).max():.2f} N m (the spec's limit {spec.stall_torque:g} N m).",
        "",
        "| variant | verdict | lost | CoP-ZMP RMS / max [mm] | CoP margin [mm] "
        "| pelvis RMS x / y / z [mm] | footprint error max [mm] (phases) "
        "| unplanned support [s] | peak torque [N m] | foot tilt [deg] |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    lines = [
        f"| {r.variant} | {r.verdict} | {r.lost or '-'} | {_mm(r.cop_rms)} / {_mm(r.cop_max)} "
        f"| {_mm(r.min_margin)} | {' / '.join(_mm(v) for v in r.pelvis_rms)} "
        f"| {_mm(r.footprint_max)} ({r.footprints}) | {r.unplanned_support:.3f} "
        f"| {r.peak_torque:.2f} | {np.rad2deg(r.max_tilt):.2f} |"
        for r in rows
    ]
    return "\n".join(head + lines + ["", *_reading(rows), ""])


def _reading(rows: list[ModelRow]) -> list[str]:
    """What each unmodelled effect contributes: the CoP RMS differences between rows."""
    by = {r.variant: r for r in rows}

    def delta(a: str, b: str) -> str:
        return _mm(by[a].cop_rms - by[b].cop_rms)

    model, welded, contact, both = (v for v, *_ in VARIANTS[1:])
    return [
        "Reading (CoP-ZMP RMS differences [mm], each row over its own standing time): "
        f"model - twin {delta(model, 'twin')}; held joints as actuated - welded "
        f"{delta(model, welded)}; the model's contact options - the twin's "
        f"{delta(model, contact)}; what is left with both, against the twin (links, soles, "
        f"servos, joint friction, integrator) {delta(both, 'twin')}.",
        "A row that falls is measured only up to its loss (see 'lost').",
    ]


def _mm(value: float) -> str:
    return "-" if not np.isfinite(value) else f"{value * 1e3:.1f}"
