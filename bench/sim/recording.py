"""A rerun recording (``.rrd``) of one trial: the robot on its slope, its balance, its joints.

``record_trial(path, plan, result)`` writes one file, headless (its own
``rr.RecordingStream`` saved to disk: no viewer, no network), atomically (a
temporary file beside ``path`` is moved into place only once complete). Open it
with ``rerun trial.rrd``: the file carries its own default layout (``blueprint``), a 3D
view beside grouped plots, so the viewer opens on the same screen for every trial.

Everything lies on the timeline ``time`` [s], walk start = 0; the settling before it
(the robot held at the plan's first pose, t < 0) is recorded for everything simulated.
Entities:

* ``world``: z up. ``world/plane``: the tilted plane around the walk (static).
* ``world/robot/<body>``: each MJCF body's geoms (boxes, capsules, spheres) in
  the body frame, static, under a ``Transform3D`` of the body's world pose per
  frame, from ``mj_kinematics`` on the simulated ``qpos``; for a trial on an imported
  model (``scene``), the model's own bodies from its own ``qpos`` (``model_qpos``:
  held joints as they gave under load), a body without a name as ``body<id>``.
* ``world/support_polygon``: the planned support polygon, per frame.
* ``world/zmp_analytic``, ``world/zmp_lipm`` and ``world/cop_simulated``: the moving
  points, and their whole path as a static ``.../trace``.
* ``world/contact_force/left`` and ``.../right``: the ground force on each
  foot, drawn from the foot's CoP at ``FORCE_SCALE`` [m/N].
* ``joints/<joint>/planned`` and ``.../actual`` [deg] for the 8 MJCF joints;
  ``torques/<joint>/planned`` (Newton-Euler) and ``.../simulated`` (MuJoCo's
  ``actuator_force``) [N m]; ``zmp/{x,y}/{analytic,lipm,simulated}`` [mm] in the slope
  frame S; ``margin/{analytic,simulated}`` [mm]: the signed distance of the planned ZMP
  and of the simulated CoP to the planned support polygon, positive inside (and
  ``margin/compliant`` where the trial predicted the compliant walk).
* ``events``: an INFO line at the start of the settling, one INFO line at the walk's start
  with both verdicts and the controller (or "open loop"), then one line per event (WARN).
* ``video`` (when a video is given): the trial's mp4 (``video.py``), frame by frame.

3D entities are sampled at ``frame_rate`` (100 Hz by default); the plots at
``plot_rate``, by default every sample of the series (the simulation's 1 kHz). Points
on the plane are ``p_W = R_WS [x, y, 0]``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from slopewalk.bench.files import atomic_path
from slopewalk.bench.sim.playback import build_model, on_rows
from slopewalk.bench.sim.trial import TrialResult, simulated_rows
from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.joints import MJCF_JOINTS, stance_swing_to_left_right
from slopewalk.planner.kinematics import rotation_slope_to_world
from slopewalk.planner.plan import Plan
from slopewalk.planner.zmp import signed_margin

FRAME_RATE = 100.0  # [Hz] of the 3D entities
SWEEP_PLOT_RATE = 100.0  # [Hz] of the plots in a sweep's or an envelope's recordings
FORCE_SCALE = 0.01  # [m/N] arrow length per newton of ground force
LIFT = 0.0005  # [m] drawing height of lines and points above the plane
PLANE_MARGIN = 0.25  # [m] plane drawn this far beyond the soles
WARN_KINDS = ("slip", "tip", "fall", "diverged", "torque_limit")
_FEET = ("left", "right")
_COLORS = {
    "plane": (150, 160, 170, 120),
    "polygon": (40, 170, 80),
    "zmp": (40, 110, 230),
    "lipm": (150, 60, 200),
    "cop": (240, 130, 20),
    "force": (220, 40, 40),
}
# The plots' series: (group, name) -> colour; the planned side blue, the simulated orange
_LINES = {
    "planned": _COLORS["zmp"],
    "actual": _COLORS["cop"],
    "simulated": _COLORS["cop"],
    "analytic": _COLORS["zmp"],
    "lipm": _COLORS["lipm"],
    "compliant": (40, 170, 80),
}


class RecordingError(SlopewalkError):
    """A recording that cannot be written from the values given."""


def record_trial(
    path: str | Path,
    plan: Plan,
    result: TrialResult,
    *,
    frame_rate: float = FRAME_RATE,
    plot_rate: float | None = None,
    video: str | Path | None = None,
    scene=None,
) -> Path:
    """Write the rerun recording of one trial to ``path`` (see module doc).

    Args:
        path: Target ``.rrd`` file; its folder is created; an existing file is replaced.
        plan: The trial's plan (its robot, slope, support polygon).
        result: The trial's ``TrialResult``; its series must hold ``qpos`` (n, 15).
        frame_rate: Sampling of the 3D entities [Hz], > 0.
        plot_rate: Sampling of the plots [Hz], > 0; None: every sample of the series.
        video: An mp4 of the trial (``video.render_trial_video``) to embed, its first
            frame at the first recorded time; None: no video.
        scene: The imported model's scene the trial was played on
            (``robot_import.scene.ModelScene``), whose bodies are drawn; None: the twin.

    Returns:
        The path written.
    """
    for name, rate in (("frame_rate", frame_rate), ("plot_rate", plot_rate)):
        if rate is not None and not (np.isfinite(rate) and rate > 0):
            raise RecordingError(f"{name} {rate!r} Hz: must be a finite number > 0")
    series = result.series
    if "qpos" not in series:
        raise RecordingError("result.series has no 'qpos': cannot replay the robot in 3D")
    sim = simulated_rows(series)
    trial = result.trial
    build = build_model if scene is None else scene.build
    model = build(plan, friction=trial.friction, actuators=trial.actuators, timestep=trial.timestep)
    qpos = sim["qpos"] if scene is None else sim.get("model_qpos")
    if qpos is None:
        raise RecordingError("result.series has no 'model_qpos': cannot replay the model in 3D")
    R = rotation_slope_to_world(plan.params.slope)  # S → world
    path = Path(path)
    rec = rr.RecordingStream(application_id="slopewalk")
    with atomic_path(path) as tmp:
        rec.save(tmp, default_blueprint=blueprint(video=video is not None))
        try:
            rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
            _log_plane(rec, series, R)
            frames = every(sim["t"], frame_rate)
            _log_robot(rec, model, qpos[frames], sim["t"][frames])
            _log_balance(rec, plan, series, sim, R, frame_rate)
            _log_plots(rec, plan, series, sim, plot_rate)
            _log_events(rec, result, float(sim["t"][0]) if sim["t"].size else 0.0)
            if video is not None:
                _log_video(rec, Path(video), float(sim["t"][0]) if sim["t"].size else 0.0)
        finally:
            rec.disconnect()  # flushes and closes the file (with its footer)
    return path


def every(t: np.ndarray, rate: float | None) -> np.ndarray:
    """Indices of the samples ``t`` [s] (evenly spaced) kept at ``rate`` [Hz]: every k-th,
    k = round(1 / (rate dt)) ≥ 1, and the last; all of them for ``rate`` None."""
    t = np.asarray(t, float)
    if rate is None or t.size < 2:
        return np.arange(t.size)
    dt = float(np.median(np.diff(t)))
    return np.unique(np.r_[np.arange(0, t.size, max(1, round(1 / (rate * dt)))), t.size - 1])


def blueprint(*, video: bool = False) -> rrb.Blueprint:
    """The recording's default layout: the 3D scene and the event log (and the video) on
    the left; on the right, tabs of plots: balance (ZMP vs CoP per axis, the margins), each
    joint's planned vs actual angle, each joint's planned vs simulated torque."""
    left: list[Any] = [rrb.Spatial3DView(origin="world", name="robot on the slope")]
    if video:
        left.append(rrb.Spatial2DView(origin="video", name="video"))
    left.append(rrb.TextLogView(origin="events", name="events"))
    balance = rrb.Vertical(
        rrb.TimeSeriesView(origin="zmp/x", name="ZMP x (up the slope) [mm]"),
        rrb.TimeSeriesView(origin="zmp/y", name="ZMP y (left) [mm]"),
        rrb.TimeSeriesView(origin="margin", name="margin to the support polygon [mm]"),
        name="balance",
    )
    angles = rrb.Grid(
        *[rrb.TimeSeriesView(origin=f"joints/{j}", name=f"{j} [deg]") for j in MJCF_JOINTS],
        grid_columns=2,
        name="joint angles",
    )
    torques = rrb.Grid(
        *[rrb.TimeSeriesView(origin=f"torques/{j}", name=f"{j} [N m]") for j in MJCF_JOINTS],
        grid_columns=2,
        name="joint torques",
    )
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(*left, row_shares=[3, 2, 1] if video else [3, 1]),
            rrb.Tabs(balance, angles, torques, name="plots"),
            column_shares=[3, 2],
        )
    )


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
        entity = f"world/robot/{model.body(b).name or f'body{b}'}"
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


def _log_balance(rec, plan: Plan, series: dict, sim: dict, R: np.ndarray, rate: float) -> None:
    """Support polygon, analytic and LIPM ZMP (the walk), simulated CoP and foot forces (the
    settling and the walk): points and traces, sampled at ``rate`` [Hz]."""
    walk = every(series["t"], rate)
    t = np.asarray(series["t"], float)[walk]
    idx = np.clip(np.searchsorted(plan.t, t), 0, plan.t.size - 1)
    polygon = plan.polygon[idx]  # (k, 2M, 2) in S (M: the sole's vertices)
    strips = _on_plane(np.concatenate([polygon, polygon[:, :1]], axis=1), R)  # closed
    rec.send_columns(
        "world/support_polygon",
        indexes=_time(t),
        columns=rr.LineStrips3D.columns(strips=list(strips), colors=[_COLORS["polygon"]] * len(t)),
    )
    frames = every(sim["t"], rate)
    for name, times, xy, color in (
        ("zmp_analytic", series["t"], series["zmp_analytic"], _COLORS["zmp"]),
        ("zmp_lipm", series["t"], series["zmp_lipm"], _COLORS["lipm"]),
        ("cop_simulated", sim["t"], sim["cop"], _COLORS["cop"]),
    ):
        xy = np.asarray(xy, float)
        k = frames if name == "cop_simulated" else walk
        ok = np.isfinite(xy[k]).all(axis=1)  # the CoP is NaN while no foot is loaded
        points = rr.Points3D.columns(
            positions=_on_plane(xy[k][ok], R),
            radii=[0.004] * ok.sum(),
            colors=[color] * ok.sum(),
        ).partition(ok.astype(int))
        rec.send_columns(f"world/{name}", indexes=_time(np.asarray(times)[k]), columns=points)
        trace = [_on_plane(s, R) for s in _finite_runs(xy)]
        rec.log(f"world/{name}/trace", rr.LineStrips3D(trace, colors=[color]), static=True)
    cop = np.asarray(sim["foot_cop"], float)[frames]  # (k, 2, 2)
    force = np.asarray(sim["foot_force"], float)[frames] @ R.T * FORCE_SCALE  # (k, 2, 3)
    for f, foot in enumerate(_FEET):
        ok = np.isfinite(cop[:, f]).all(axis=1) & np.isfinite(force[:, f]).all(axis=1)
        vectors = force[ok, f]
        origins = _on_plane(cop[ok, f], R)
        cols = rr.Arrows3D.columns(
            vectors=vectors, origins=origins, colors=[_COLORS["force"]] * len(vectors)
        ).partition(ok.astype(int))
        rec.send_columns(
            f"world/contact_force/{foot}", indexes=_time(sim["t"][frames]), columns=cols
        )


def _finite_runs(xy: np.ndarray) -> list[np.ndarray]:
    """Runs (each (m ≥ 2, 2)) of consecutive finite rows of ``xy`` (n, 2)."""
    ok = np.isfinite(xy).all(axis=1)
    edges = np.flatnonzero(np.diff(np.r_[0, ok.astype(int), 0]))
    return [xy[a:b] for a, b in zip(edges[::2], edges[1::2], strict=True) if b - a >= 2]


def plotted(plan: Plan, series: dict, sim: dict) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Every plot's series: entity -> (times [s], values), in the plots' units (degrees,
    newton-metres, millimetres); planned values over the walk, simulated ones over the
    settling and the walk. Values may be NaN (left out when logged)."""
    t = np.asarray(series["t"], float)
    idx = np.clip(np.searchsorted(plan.t, t), 0, plan.t.size - 1)
    tau = stance_swing_to_left_right(on_rows(t, plan, plan.tau), plan.stance[idx])
    cop = np.asarray(series["cop"], float)
    margin = signed_margin(cop, plan.polygon[idx])  # NaN where no foot is loaded
    out = {}
    for j, joint in enumerate(MJCF_JOINTS):
        out[f"joints/{joint}/planned"] = t, np.rad2deg(series["q_planned"][:, j])
        out[f"joints/{joint}/actual"] = sim["t"], np.rad2deg(sim["q_simulated"][:, j])
        out[f"torques/{joint}/planned"] = t, tau[:, j]
        out[f"torques/{joint}/simulated"] = sim["t"], sim["actuator_force"][:, j]
    for a, axis in enumerate("xy"):
        out[f"zmp/{axis}/analytic"] = t, 1e3 * series["zmp_analytic"][:, a]
        out[f"zmp/{axis}/lipm"] = t, 1e3 * series["zmp_lipm"][:, a]
        out[f"zmp/{axis}/simulated"] = sim["t"], 1e3 * sim["cop"][:, a]
    out["margin/analytic"] = t, 1e3 * series["margin_analytic"]
    out["margin/simulated"] = t, 1e3 * margin
    if "margin_compliant" in series:
        out["margin/compliant"] = t, 1e3 * series["margin_compliant"]
    return {k: (np.asarray(ts, float), np.asarray(v, float)) for k, (ts, v) in out.items()}


def _log_plots(rec, plan: Plan, series: dict, sim: dict, rate: float | None) -> None:
    """Each of ``plotted`` at ``rate`` [Hz] (None: every sample), its line named and coloured."""
    for entity, (t, values) in plotted(plan, series, sim).items():
        name = entity.rsplit("/", 1)[1]
        rec.log(entity, rr.SeriesLines(colors=[_LINES[name]], names=[name]), static=True)
        keep = every(t, rate)
        _send_scalars(rec, entity, t[keep], values[keep])


def _send_scalars(rec, entity: str, t: np.ndarray, values: np.ndarray) -> None:
    ok = np.isfinite(values)  # the CoP is NaN while no foot is loaded
    rec.send_columns(entity, indexes=_time(t[ok]), columns=rr.Scalars.columns(scalars=values[ok]))


def _log_events(rec: rr.RecordingStream, result: TrialResult, start: float) -> None:
    """An INFO line at the settling's ``start`` [s], one with both verdicts at time 0, then
    each event at its time (WARN for ``WARN_KINDS``)."""
    if start < 0:
        rec.set_time("time", duration=start)
        rec.log(
            "events",
            rr.TextLog(
                f"settling: the robot held at the plan's first pose for {-start:.3f} s "
                "before the walk",
                level=rr.TextLogLevel.INFO,
            ),
        )
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


def _log_video(rec: rr.RecordingStream, path: Path, start: float) -> None:
    """The mp4 at ``path`` as an asset, each frame shown from its time: ``start`` [s] plus
    its presentation time in the video."""
    asset = rr.AssetVideo(path=path)
    rec.log("video", asset, static=True)
    nanos = asset.read_frame_timestamps_nanos()
    rec.send_columns(
        "video",
        indexes=_time(start + nanos / 1e9),
        columns=rr.VideoFrameReference.columns_nanos(nanos),
    )
