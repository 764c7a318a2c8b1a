"""A rerun recording (``.rrd``) of one trial: the robot on its slope, its balance, its joints.

``record_trial(path, plan, result)`` writes one file, headless (its own
``rr.RecordingStream`` saved to disk: no viewer, no network), atomically (a
temporary file beside ``path`` is moved into place only once complete). Open it
with ``rerun trial.rrd``.

Everything lies on the timeline ``time`` [s], walk start = 0. Entities:

* ``world``: z up. ``world/plane``: the tilted plane around the walk (static).
* ``world/robot/<body>``: each MJCF body's geoms (boxes, capsules, spheres) in
  the body frame, static, under a ``Transform3D`` of the body's world pose per
  frame, from ``mj_kinematics`` on the simulated ``qpos``.
* ``world/support_polygon``: the planned support polygon, per frame.
* ``world/zmp_analytic`` and ``world/cop_simulated``: the moving points, and
  their whole path as a static ``.../trace``.
* ``world/contact_force/left`` and ``.../right``: the ground force on each
  foot, drawn from the foot's CoP at ``FORCE_SCALE`` [m/N].
* ``joints/<joint>/planned`` and ``.../actual`` [deg] for the 8 MJCF joints;
  ``zmp/{x,y}/{analytic,simulated}`` [mm] in the slope frame S.
* ``events``: one log line per event (WARN), one INFO line with both verdicts and the
  controller (or "open loop").

3D entities are sampled at ``frame_rate`` (100 Hz by default); the plots keep
every sample of the series. Points on the plane are ``p_W = R_WS [x, y, 0]``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import rerun as rr

from slopewalk.bench.files import atomic_path
from slopewalk.bench.sim.playback import build_model
from slopewalk.bench.sim.trial import TrialResult
from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.joints import MJCF_JOINTS
from slopewalk.planner.kinematics import rotation_slope_to_world
from slopewalk.planner.plan import Plan

FRAME_RATE = 100.0  # [Hz] of the 3D entities
FORCE_SCALE = 0.01  # [m/N] arrow length per newton of ground force
LIFT = 0.0005  # [m] drawing height of lines and points above the plane
PLANE_MARGIN = 0.25  # [m] plane drawn this far beyond the soles
WARN_KINDS = ("slip", "tip", "fall", "diverged", "torque_limit")
_FEET = ("left", "right")
_COLORS = {
    "plane": (150, 160, 170, 120),
    "polygon": (40, 170, 80),
    "zmp": (40, 110, 230),
    "cop": (240, 130, 20),
    "force": (220, 40, 40),
}


class RecordingError(SlopewalkError):
    """A recording that cannot be written from the values given."""


def record_trial(
    path: str | Path, plan: Plan, result: TrialResult, *, frame_rate: float = FRAME_RATE
) -> Path:
    """Write the rerun recording of one trial to ``path`` (see module doc).

    Args:
        path: Target ``.rrd`` file; its folder is created; an existing file is replaced.
        plan: The trial's plan (its robot, slope, support polygon).
        result: The trial's ``TrialResult``; its series must hold ``qpos`` (n, 15).
        frame_rate: Sampling of the 3D entities [Hz], > 0.

    Returns:
        The path written.
    """
    if not frame_rate > 0:
        raise RecordingError(f"frame_rate {frame_rate!r} Hz: must be > 0")
    series = result.series
    if "qpos" not in series:
        raise RecordingError("result.series has no 'qpos': cannot replay the robot in 3D")
    t = np.asarray(series["t"], float)  # (n,)
    dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    frames = np.arange(0, t.size, max(1, round(1 / (frame_rate * dt))))
    frames = np.unique(np.r_[frames, t.size - 1]) if t.size else frames  # keep the last
    trial = result.trial
    model = build_model(
        plan, friction=trial.friction, actuators=trial.actuators, timestep=trial.timestep
    )
    R = rotation_slope_to_world(plan.params.slope)  # S → world
    path = Path(path)
    rec = rr.RecordingStream(application_id="slopewalk")
    with atomic_path(path) as tmp:
        rec.save(tmp)
        try:
            rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
            _log_plane(rec, series, R)
            _log_robot(rec, model, series["qpos"][frames], t[frames])
            _log_balance(rec, plan, series, R, frames)
            _log_plots(rec, series)
            _log_events(rec, result)
        finally:
            rec.disconnect()  # flushes and closes the file (with its footer)
    return path


def _on_plane(xy: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Points (..., 2) of the plane in S → world (..., 3), drawn ``LIFT`` above it."""
    xy = np.asarray(xy, float)
    lift = np.full(xy.shape[:-1] + (1,), LIFT)
    return np.concatenate([xy, lift], axis=-1) @ R.T


def _time(t: np.ndarray) -> list:
    return [rr.TimeColumn("time", duration=np.asarray(t, float))]


def _xyzw(quat_wxyz: np.ndarray) -> np.ndarray:
    return np.roll(np.asarray(quat_wxyz, float), -1, axis=-1)


def _log_plane(rec: rr.RecordingStream, series: dict, R: np.ndarray) -> None:
    """The plane: a thin box around the soles. path (+ ``PLANE_MARGIN``), top face at z_S = 0."""
    sole = np.asarray(series["sole"], float).reshape(-1, 3)[:, :2]  # in S
    sole = np.vstack([sole[np.isfinite(sole).all(axis=1)], np.zeros((1, 2))])  # with the origin
    lo, hi = sole.min(axis=0) - PLANE_MARGIN, sole.max(axis=0) + PLANE_MARGIN
    half = np.r_[(hi - lo) / 2, 0.001]
    center = R @ np.r_[(hi + lo) / 2, -half[2]]
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, R.reshape(-1))
    box = rr.Boxes3D(
        half_sizes=[half],
        centers=[center],
        quaternions=[_xyzw(quat)],
        colors=[_COLORS["plane"]],
        fill_mode=rr.components.FillMode.Solid,
    )
    rec.log("world/plane", box, static=True)


def _log_robot(rec: rr.RecordingStream, model, qpos: np.ndarray, t: np.ndarray) -> None:
    """Each body's geoms (static, body frame) and its world pose per frame (``mj_kinematics``)."""
    data = mujoco.MjData(model)
    bodies = range(1, model.nbody)  # 0 is the world
    pos = np.empty((t.size, model.nbody, 3))
    quat = np.empty((t.size, model.nbody, 4))
    for k, q in enumerate(qpos):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        pos[k], quat[k] = data.xpos, data.xquat
    for b in bodies:
        entity = f"world/robot/{model.body(b).name}"
        for geoms in _geoms(model, b):
            rec.log(entity, geoms, static=True)
        pose = rr.Transform3D.columns(translation=pos[:, b], quaternion=_xyzw(quat[:, b]))
        rec.send_columns(entity, indexes=_time(t), columns=pose)


def _geoms(model, body: int) -> list:
    """Archetypes drawing the box, capsule and sphere geoms of ``body`` in its frame."""
    ids = np.flatnonzero(model.geom_bodyid == body)
    kinds: dict[int, list[Any]] = {}
    for geom in ids:
        kinds.setdefault(int(model.geom_type[geom]), []).append(geom)
    out: list[rr.AsComponents] = []
    solid = rr.components.FillMode.Solid
    G = mujoco.mjtGeom
    for kind, g in kinds.items():
        size, pos, quat = model.geom_size[g], model.geom_pos[g], model.geom_quat[g]
        colors = (model.geom_rgba[g] * 255).astype(np.uint8)
        if kind == G.mjGEOM_BOX:
            out.append(
                rr.Boxes3D(
                    half_sizes=size,
                    centers=pos,
                    quaternions=_xyzw(quat),
                    colors=colors,
                    fill_mode=solid,
                )
            )
        elif kind == G.mjGEOM_CAPSULE:  # MuJoCo: centred on pos; rerun: from one end along +z
            axis = np.empty((len(g), 3))
            for i, q in enumerate(quat):
                mujoco.mju_rotVecQuat(axis[i], np.array([0.0, 0.0, 1.0]), q)
            out.append(
                rr.Capsules3D(
                    lengths=2 * size[:, 1],
                    radii=size[:, 0],
                    translations=pos - axis * size[:, 1:2],
                    quaternions=_xyzw(quat),
                    colors=colors,
                    fill_mode=solid,
                )
            )
        elif kind == G.mjGEOM_SPHERE:
            out.append(rr.Points3D(pos, radii=size[:, 0], colors=colors))
    return out


def _log_balance(rec, plan: Plan, series: dict, R: np.ndarray, frames: np.ndarray) -> None:
    """Support polygon, analytic ZMP, simulated CoP (points and traces), foot forces."""
    t = series["t"][frames]
    idx = np.clip(np.searchsorted(plan.t, t), 0, plan.t.size - 1)
    polygon = plan.polygon[idx]  # (k, 8, 2) in S
    strips = _on_plane(np.concatenate([polygon, polygon[:, :1]], axis=1), R)  # closed
    rec.send_columns(
        "world/support_polygon",
        indexes=_time(t),
        columns=rr.LineStrips3D.columns(strips=list(strips), colors=[_COLORS["polygon"]] * len(t)),
    )
    for name, xy, color in (
        ("zmp_analytic", series["zmp_analytic"], _COLORS["zmp"]),
        ("cop_simulated", series["cop"], _COLORS["cop"]),
    ):
        xy = np.asarray(xy, float)
        ok = np.isfinite(xy[frames]).all(axis=1)  # the CoP is NaN while no foot is loaded
        points = rr.Points3D.columns(
            positions=_on_plane(xy[frames][ok], R),
            radii=[0.004] * ok.sum(),
            colors=[color] * ok.sum(),
        ).partition(ok.astype(int))
        rec.send_columns(f"world/{name}", indexes=_time(t), columns=points)
        trace = [_on_plane(s, R) for s in _finite_runs(xy)]
        rec.log(f"world/{name}/trace", rr.LineStrips3D(trace, colors=[color]), static=True)
    cop = np.asarray(series["foot_cop"], float)[frames]  # (k, 2, 2)
    force = np.asarray(series["foot_force"], float)[frames] @ R.T * FORCE_SCALE  # (k, 2, 3)
    for f, foot in enumerate(_FEET):
        ok = np.isfinite(cop[:, f]).all(axis=1) & np.isfinite(force[:, f]).all(axis=1)
        vectors = force[ok, f]
        origins = _on_plane(cop[ok, f], R)
        cols = rr.Arrows3D.columns(
            vectors=vectors, origins=origins, colors=[_COLORS["force"]] * len(vectors)
        ).partition(ok.astype(int))
        rec.send_columns(f"world/contact_force/{foot}", indexes=_time(t), columns=cols)


def _finite_runs(xy: np.ndarray) -> list[np.ndarray]:
    """Runs (each (m ≥ 2, 2)) of consecutive finite rows of ``xy`` (n, 2)."""
    ok = np.isfinite(xy).all(axis=1)
    edges = np.flatnonzero(np.diff(np.r_[0, ok.astype(int), 0]))
    return [xy[a:b] for a, b in zip(edges[::2], edges[1::2], strict=True) if b - a >= 2]


def _log_plots(rec: rr.RecordingStream, series: dict) -> None:
    """Planned and actual joint angles [deg]; analytic and simulated ZMP in S [mm]."""
    t = np.asarray(series["t"], float)
    for j, joint in enumerate(MJCF_JOINTS):
        for name, key in (("planned", "q_planned"), ("actual", "q_simulated")):
            _send_scalars(rec, f"joints/{joint}/{name}", t, np.rad2deg(series[key][:, j]))
    for a, axis in enumerate("xy"):
        for name, key in (("analytic", "zmp_analytic"), ("simulated", "cop")):
            _send_scalars(rec, f"zmp/{axis}/{name}", t, 1e3 * np.asarray(series[key])[:, a])


def _send_scalars(rec, entity: str, t: np.ndarray, values: np.ndarray) -> None:
    ok = np.isfinite(values)  # the CoP is NaN while no foot is loaded
    rec.send_columns(entity, indexes=_time(t[ok]), columns=rr.Scalars.columns(scalars=values[ok]))


def _log_events(rec: rr.RecordingStream, result: TrialResult) -> None:
    """One INFO line with both verdicts at time 0, then each event (WARN) at its time."""
    rec.set_time("time", duration=0.0)
    rec.log(
        "events",
        rr.TextLog(
            f"analytic {result.analytic_verdict}, simulated {result.simulated_verdict}; "
            f"ZMP RMS {result.zmp_rms * 1e3:.2f} mm, max {result.zmp_max * 1e3:.2f} mm; "
            + (f"controller {result.trial.controller}" if result.trial.controller else "open loop"),
            level=rr.TextLogLevel.INFO,
        ),
    )
    for event in result.events:
        level = rr.TextLogLevel.WARN if event.kind in WARN_KINDS else rr.TextLogLevel.INFO
        rec.set_time("time", duration=float(event.time))
        rec.log("events", rr.TextLog(f"{event.kind}: {event.cause}", level=level))
