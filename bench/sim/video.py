"""An mp4 video of one trial: MuJoCo's offscreen renderer, a camera following the pelvis.

``render_trial_video(path, plan, result)`` replays the simulated ``qpos`` of the
settling and the walk (``trial.simulated_rows``) at ``fps`` frames per second, each
frame the row nearest its time, seen by ``CAMERA``: a camera added to the pelvis
(``mjCAMLIGHT_TRACK``: a fixed offset in the world, a fixed orientation), beside the
robot's right side, a little behind and above, looking at the pelvis, at a distance
that scales with the hip height. It moves with the pelvis up or down the slope; the
plane is drawn tilted. Markers, pins standing on the plane along its normal: the
analytic ZMP (blue), the LIPM ZMP (purple) and the simulated CoP (orange), where they
exist. Encoded as H.264 (no B-frames, yuv420p) in an mp4 by PyAV, written atomically.
A trial on an imported model (``scene``) is rendered from the model's own ``qpos``
(``model_qpos``), the camera on its base body.

Needs PyAV (``pip install 'slopewalk[video]'``) and an OpenGL backend for offscreen
rendering: on Linux without a display, ``MUJOCO_GL=egl`` (Mesa's EGL; the ``trial``
command sets it when unset) or ``osmesa``, set before MuJoCo is first imported.
``check_video`` says in one line which is missing. Cost: about 0.2 s a frame at
640x480 on a 2-core machine with Mesa's software rasteriser (llvmpipe).
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from slopewalk.bench.files import atomic_path
from slopewalk.bench.sim.model import SceneError, mujoco_message, scene_xml
from slopewalk.bench.sim.trial import TrialResult, simulated_rows
from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.kinematics import rotation_slope_to_world
from slopewalk.planner.plan import Plan

VIDEO_FPS = 30.0  # [frames/s]
VIDEO_SIZE = (640, 480)  # [px] width, height
CAMERA = "follow"
PELVIS = "pelvis"
# The camera's offset from the pelvis in the slope frame S, in hip heights: behind (−x),
# to the robot's right (−y), above (+z); it looks at a point LOOK_DROP hip heights below
# the pelvis along the plane's normal.
CAMERA_OFFSET = (-0.9, -3.0, 0.9)
LOOK_DROP = 0.4
PIN = (0.4, 0.03)  # pin height and head radius, in hip heights
PIN_WIDTH = 0.0025  # [m] radius of a pin's stem
MARKER_COLORS = {
    "zmp_analytic": (0.16, 0.43, 0.9, 1.0),
    "zmp_lipm": (0.59, 0.24, 0.78, 1.0),
    "cop": (0.94, 0.51, 0.08, 1.0),
}


class VideoError(SlopewalkError):
    """A video that cannot be made here (no PyAV, no OpenGL backend) or from these values."""


@dataclass(frozen=True)
class VideoInfo:
    """What ``render_trial_video`` wrote.

    Attributes:
        path: The mp4 file.
        times: Trial time of each frame [s] (walk start = 0), (frames,).
        size: Frame width and height [px].
        fps: Frames per second.
    """

    path: Path
    times: np.ndarray
    size: tuple[int, int]
    fps: float


def check_video(size: tuple[int, int] = VIDEO_SIZE) -> None:
    """Raise ``VideoError`` (one line, what to install or set) unless PyAV is importable
    and MuJoCo can render offscreen here."""
    _av()
    model = mujoco.MjModel.from_xml_string(
        f'<mujoco><visual><global offwidth="{size[0]}" offheight="{size[1]}"/></visual>'
        "<worldbody/></mujoco>"
    )
    _renderer(model, size).close()


def render_trial_video(
    path: str | Path,
    plan: Plan,
    result: TrialResult,
    *,
    fps: float = VIDEO_FPS,
    size: tuple[int, int] = VIDEO_SIZE,
    scene=None,
) -> VideoInfo:
    """Render the trial to an mp4 at ``path`` (see module doc).

    Args:
        path: Target file; written as mp4 whatever its name; an existing file is replaced.
        plan: The trial's plan (its robot, slope, hip height).
        result: The trial's ``TrialResult``, whose series hold ``qpos``.
        fps: Frames per second, > 0.
        size: Frame width and height [px], even (the chroma planes are halves).
        scene: The imported model's scene the trial was played on
            (``robot_import.scene.ModelScene``): the model is rendered from its own
            ``model_qpos``, the camera on its base body; None: the twin.

    Returns:
        The ``VideoInfo`` of the file.
    """
    if not (np.isfinite(fps) and fps > 0):
        raise VideoError(f"fps {fps!r}: must be a finite number > 0")
    width, height = size
    if min(width, height) < 16 or width % 2 or height % 2:
        raise VideoError(f"size {width}x{height}: each side must be an even number >= 16 px")
    av = _av()
    sim = simulated_rows(result.series)
    t = np.asarray(sim["t"], float)
    times = t[0] + np.arange(int(np.floor((t[-1] - t[0]) * fps + 1e-9)) + 1) / fps
    rows = np.clip(np.searchsorted(t, times - 0.5 * np.median(np.diff(t))), 0, t.size - 1)
    markers = _markers(plan, result.series, sim, rows)
    model = video_model(plan, result, size, scene)
    qpos = sim["qpos"] if scene is None else sim.get("model_qpos")
    if qpos is None:
        raise VideoError("result.series has no 'model_qpos': cannot replay the model")
    data = mujoco.MjData(model)
    renderer = _renderer(model, size)
    try:
        with atomic_path(path) as tmp, av.open(str(tmp), "w", format="mp4") as out:
            stream = out.add_stream("libx264", rate=Fraction(fps).limit_denominator(1001))
            stream.width, stream.height, stream.pix_fmt = width, height, "yuv420p"
            stream.codec_context.options = {"bf": "0"}  # frames in display order
            for k, row in enumerate(rows):
                data.qpos[:] = qpos[row]
                mujoco.mj_forward(model, data)
                renderer.update_scene(data, camera=CAMERA)
                for kind, pos, normal in markers[k]:
                    _pin(renderer.scene, pos, normal, plan.params.hip_height, kind)
                frame = av.VideoFrame.from_ndarray(renderer.render(), format="rgb24")
                out.mux(stream.encode(frame))
            out.mux(stream.encode())  # flush
    finally:
        renderer.close()
    return VideoInfo(Path(path), times, (width, height), fps)


def video_model(
    plan: Plan, result: TrialResult, size: tuple[int, int], scene=None
) -> mujoco.MjModel:
    """The trial's scene with ``CAMERA`` on the pelvis (an imported model's base body, for
    its ``scene``) and an offscreen buffer of ``size``."""
    trial = result.trial
    mu, mode, dt = trial.friction, trial.actuators, trial.timestep
    if scene is None:
        slope = plan.params.slope
        xml = scene_xml(plan.spec, slope=slope, friction=mu, actuators=mode, timestep=dt)
        mjs = mujoco.MjSpec.from_string(xml)
    else:
        mjs = scene.editable(plan, friction=mu, actuators=mode, timestep=dt)
    mjs.visual.global_.offwidth = max(mjs.visual.global_.offwidth, size[0])
    mjs.visual.global_.offheight = max(mjs.visual.global_.offheight, size[1])
    R_ws = rotation_slope_to_world(plan.params.slope)
    hip = plan.params.hip_height
    offset = R_ws @ (hip * np.asarray(CAMERA_OFFSET))  # world, from the pelvis
    look = -offset - R_ws @ [0.0, 0.0, LOOK_DROP * hip]  # camera → looked-at point
    z = -look / np.linalg.norm(look)  # a camera looks along its −z
    x = np.cross(look, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    camera = np.column_stack([x, np.cross(z, x), z])  # its axes in the world
    pelvis = mjs.body(PELVIS if scene is None else scene.base_name)
    flat = np.empty(9)
    mujoco.mju_quat2Mat(flat, np.asarray(pelvis.quat, float))  # at qpos0
    body = flat.reshape(3, 3)
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, (body.T @ camera).reshape(-1))
    pelvis.add_camera(
        name=CAMERA, pos=body.T @ offset, quat=quat, mode=mujoco.mjtCamLight.mjCAMLIGHT_TRACK
    )
    try:
        return mjs.compile()
    except ValueError as err:
        raise SceneError(f"MuJoCo refused the video's model: {mujoco_message(err)}") from None


def _markers(plan: Plan, series: dict, sim: dict, rows: np.ndarray) -> list[list[tuple]]:
    """Per frame: (kind, world position, plane normal) of each marker that exists then."""
    R = rotation_slope_to_world(plan.params.slope)
    normal = R[:, 2]
    walk_t = np.asarray(series["t"], float)
    out = []
    for row in rows:
        now = sim["t"][row]
        points = {"cop": sim["cop"][row]}
        if walk_t.size and walk_t[0] <= now <= walk_t[-1]:
            k = int(np.clip(np.searchsorted(walk_t, now), 0, walk_t.size - 1))
            points |= {
                "zmp_analytic": series["zmp_analytic"][k],
                "zmp_lipm": series["zmp_lipm"][k],
            }
        out.append(
            [(kind, R @ [*xy, 0.0], normal) for kind, xy in points.items() if np.isfinite(xy).all()]
        )
    return out


def _pin(scene: Any, pos: np.ndarray, normal: np.ndarray, hip: float, kind: str) -> None:
    """Add a pin (stem and head) standing on the plane at ``pos`` [m] to ``scene``."""
    height, head = PIN[0] * hip, PIN[1] * hip
    rgba = np.asarray(MARKER_COLORS[kind], np.float32)
    top = np.asarray(pos, float) + height * np.asarray(normal, float)
    for shape in ("stem", "head"):
        if scene.ngeom >= scene.maxgeom:
            return
        geom = scene.geoms[scene.ngeom]
        if shape == "stem":
            mujoco.mjv_initGeom(
                geom,
                mujoco.mjtGeom.mjGEOM_CAPSULE,
                np.zeros(3),
                np.zeros(3),
                np.eye(3).reshape(-1),
                rgba,
            )
            mujoco.mjv_connector(geom, mujoco.mjtGeom.mjGEOM_CAPSULE, PIN_WIDTH, pos, top)
        else:
            mujoco.mjv_initGeom(
                geom,
                mujoco.mjtGeom.mjGEOM_SPHERE,
                np.full(3, head),
                top,
                np.eye(3).reshape(-1),
                rgba,
            )
        scene.ngeom += 1


def _av():
    """PyAV, or one line saying how to install it."""
    try:
        import av
    except ImportError:
        raise VideoError(
            "videos need PyAV, which is not installed: pip install 'slopewalk[video]' "
            "(or pip install av)"
        ) from None
    return av


def _renderer(model: mujoco.MjModel, size: tuple[int, int]) -> mujoco.Renderer:
    """MuJoCo's offscreen renderer, or one line saying which OpenGL backend to set."""
    backend = os.environ.get("MUJOCO_GL", "") or "unset (glfw, which needs a display)"
    try:
        with warnings.catch_warnings():  # glfw warns once per failed call
            warnings.simplefilter("ignore")
            return mujoco.Renderer(model, height=size[1], width=size[0])
    except Exception as err:  # no GL library, no display, a backend MuJoCo lacks
        text = " ".join(str(err).split())[:160] or type(err).__name__
        raise VideoError(
            f"no OpenGL backend for offscreen rendering (MUJOCO_GL {backend}: {text}); set "
            "MUJOCO_GL=egl (Mesa's EGL, e.g. apt-get install libegl1) or MUJOCO_GL=osmesa "
            "before MuJoCo is first imported"
        ) from None
