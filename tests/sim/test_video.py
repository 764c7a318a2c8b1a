"""Trial videos: a playable mp4 of the right length and size, a camera that follows the
pelvis, the video inside the recording, one-line refusals. Small frames, few of them:
rendering is about 0.2 s a frame at 640x480 on this machine's software OpenGL."""

import os
import subprocess
import sys

import av
import mujoco
import numpy as np
import pytest
from rerun.chunk import RrdReader

from slopewalk.bench.cli import main
from slopewalk.bench.sim.playback import SETTLE_TIME
from slopewalk.bench.sim.trial import run_trial, simulated_rows
from slopewalk.bench.sim.trial_spec import TrialSpec
from slopewalk.bench.sim.video import (
    CAMERA,
    CAMERA_OFFSET,
    PELVIS,
    VideoError,
    check_video,
    render_trial_video,
    video_model,
)
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.kinematics import rotation_slope_to_world
from slopewalk.planner.plan import plan_walk

SIZE = (96, 64)
FPS = 4.0


@pytest.fixture(scope="module")
def uphill(spec):
    """One 1 s step up a 10° slope: (plan, result); the walk lasts 1.4 s after 0.5 s settling."""
    trial = TrialSpec(GaitParams.nominal(spec, 1.0, steps=1, slope=np.deg2rad(10.0)))
    plan = plan_walk(spec, trial.gait)
    return plan, run_trial(spec, trial, plan=plan, predict=False)


def _decode(path) -> tuple[list[np.ndarray], float]:
    with av.open(str(path)) as container:
        stream = container.streams.video[0]
        frames = [frame.to_ndarray(format="rgb24") for frame in container.decode(stream)]
        return frames, float(stream.average_rate)


def test_the_video_has_a_frame_every_1_over_fps_of_the_settling_and_the_walk(uphill, tmp_path):
    plan, result = uphill
    info = render_trial_video(tmp_path / "v.mp4", plan, result, fps=FPS, size=SIZE)
    frames, rate = _decode(tmp_path / "v.mp4")
    t = simulated_rows(result.series)["t"]
    span = t[-1] - t[0]  # 0.5 s settling + 1.4 s walk, at 1 ms rows
    assert span == pytest.approx(SETTLE_TIME + 1.399)
    assert len(frames) == len(info.times) == int(span * FPS) + 1  # 0, 0.25 s, … 1.75 s
    np.testing.assert_allclose(info.times, -SETTLE_TIME + np.arange(len(frames)) / FPS)
    assert rate == FPS
    assert {f.shape for f in frames} == {(SIZE[1], SIZE[0], 3)}
    assert not any(np.array_equal(frames[0], f) for f in frames[4:])  # the walk moves
    assert [p.name for p in tmp_path.iterdir()] == ["v.mp4"]  # no temporary left


def test_the_camera_keeps_its_offset_to_the_pelvis_and_looks_at_it(uphill):
    """mjCAMLIGHT_TRACK: the camera moves with the pelvis, a constant offset in the world
    (CAMERA_OFFSET hip heights in the slope frame), the pelvis near the middle of the view."""
    plan, result = uphill
    model = video_model(plan, result, SIZE)
    data = mujoco.MjData(model)
    camera, pelvis = model.camera(CAMERA).id, model.body(PELVIS).id
    expected = rotation_slope_to_world(plan.params.slope) @ (
        plan.params.hip_height * np.asarray(CAMERA_OFFSET)
    )
    qpos = result.series["qpos"]
    travelled = np.linalg.norm(qpos[-1, :3] - qpos[0, :3])
    assert travelled > 0.05  # the pelvis goes somewhere: following it means something
    for row in (0, len(qpos) // 2, len(qpos) - 1):
        data.qpos[:] = qpos[row]
        mujoco.mj_forward(model, data)
        np.testing.assert_allclose(data.cam_xpos[camera] - data.xpos[pelvis], expected, atol=1e-6)
        to_pelvis = data.cam_xmat[camera].reshape(3, 3).T @ (
            data.xpos[pelvis] - data.cam_xpos[camera]
        )
        off_axis = np.degrees(np.arctan2(np.hypot(*to_pelvis[:2]), -to_pelvis[2]))
        assert off_axis < model.cam_fovy[camera] / 4  # well inside the view


def test_trial_writes_the_video_and_embeds_it_in_the_recording(tmp_path, capsys):
    out, record, video = tmp_path / "t.json", tmp_path / "t.rrd", tmp_path / "t.mp4"
    code = main(
        ["trial", "--step-time", "0.5", "--steps", "1", "--out", str(out), "--record", str(record),
         "--record-rate", "50", "--video", str(video), "--video-fps", "4", "--video-size", "96x64"]
    )  # fmt: skip
    assert code in (0, None), capsys.readouterr().err
    frames, _ = _decode(video)
    assert len(frames) == 5 and frames[0].shape == (64, 96, 3)  # 0.5 s settling + 0.7 s walk
    reader = RrdReader(record)
    rows: dict[tuple[str, bool], list] = {}
    for chunk in reader.store().stream():
        batch = chunk.to_record_batch()
        for name in batch.schema.names:
            if name.startswith(("AssetVideo:", "VideoFrameReference:")):
                rows.setdefault((name, chunk.is_static), []).extend(batch.column(name).to_pylist())
    (blob,) = rows[("AssetVideo:blob", True)]
    assert bytes(blob[0]) == video.read_bytes()
    assert len(rows[("VideoFrameReference:timestamp", False)]) == 5
    views = set()
    for chunk in reader.store(store=reader.blueprints()[0]).stream():
        batch = chunk.to_record_batch()
        if "ViewBlueprint:space_origin" in batch.schema.names:
            views.add(batch.column("ViewBlueprint:space_origin").to_pylist()[-1][0])
    assert "video" in views


def test_without_pyav_a_video_is_refused_in_one_line(monkeypatch):
    monkeypatch.setitem(sys.modules, "av", None)  # what `import av` meets when not installed
    with pytest.raises(VideoError, match=r"pip install 'slopewalk\[video\]'"):
        check_video()


def test_bad_rate_or_size_is_refused(uphill, tmp_path):
    plan, result = uphill
    for kwargs, message in (
        ({"fps": 0.0}, "fps 0.0: must be a finite number > 0"),
        ({"fps": float("nan")}, "fps nan"),
        ({"size": (95, 64)}, "size 95x64: each side must be an even number >= 16 px"),
        ({"size": (8, 8)}, "size 8x8"),
    ):
        with pytest.raises(VideoError, match=message):
            render_trial_video(tmp_path / "v.mp4", plan, result, **kwargs)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow  # a process of its own (the backend is picked at import): .ci/run runs it
def test_no_opengl_backend_is_refused_in_one_line_before_the_trial(tmp_path):
    env = os.environ | {"MUJOCO_GL": "disable"}  # MuJoCo without any OpenGL context
    done = subprocess.run(
        [sys.executable, "-m", "slopewalk.bench.cli", "trial", "--step-time", "1",
         "--out", str(tmp_path / "t.json"), "--video", str(tmp_path / "t.mp4")],
        capture_output=True, text=True, env=env, timeout=300,
    )  # fmt: skip
    assert done.returncode == 2, done.stderr
    assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr, done.stderr
    assert "--video: no OpenGL backend for offscreen rendering (MUJOCO_GL disable" in done.stderr
    assert "set MUJOCO_GL=egl" in done.stderr
    assert list(tmp_path.iterdir()) == []
