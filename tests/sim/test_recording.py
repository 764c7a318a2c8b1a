"""Rerun recordings: every entity is in the file, the robot is MuJoCo's, nothing half-written."""

import dataclasses
import time

import mujoco
import numpy as np
import pyarrow as pa
import pytest
from rerun.chunk import RrdReader

import slopewalk.bench.sim.recording
from slopewalk.bench.sim.playback import build_model, play
from slopewalk.bench.sim.recording import (
    FORCE_SCALE,
    FRAME_RATE,
    LIFT,
    RecordingError,
    record_trial,
)
from slopewalk.bench.sim.trial import run_trial
from slopewalk.bench.sim.trial_spec import TrialSpec
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.joints import MJCF_JOINTS
from slopewalk.planner.kinematics import rotation_slope_to_world
from slopewalk.planner.plan import plan_walk


def simulate(spec, step_time: float, slope: float = 0.0):
    """One-step trial: (plan, result)."""
    trial = TrialSpec(GaitParams.nominal(spec, step_time, steps=1, slope=slope))
    plan = plan_walk(spec, trial.gait)
    rec = play(plan, friction=trial.friction, actuators=trial.actuators, timestep=trial.timestep)
    return plan, run_trial(spec, trial, plan=plan, recording=rec)


def chunks(path) -> dict[tuple[str, bool], dict[str, list]]:
    """{(entity, static): {column: values}} of an .rrd file; times in seconds."""
    out = {}
    for chunk in RrdReader(path).store().stream():
        batch = chunk.to_record_batch()
        columns = out.setdefault((chunk.entity_path, chunk.is_static), {})
        for name in batch.schema.names:
            col = batch.column(name)
            if name in ("time", "log_time"):  # durations / timestamps [ns]
                values = (col.cast(pa.int64()).to_numpy() / 1e9).tolist()
            else:
                values = col.to_pylist()
            columns.setdefault(name, []).extend(values)
    return out


@pytest.fixture(scope="module")
def walk(spec, tmp_path_factory):
    """A 1 s step on a 10° slope, recorded: (path, plan, result, write time [s])."""
    plan, result = simulate(spec, 1.0, slope=np.deg2rad(10.0))
    path = tmp_path_factory.mktemp("rrd") / "sub" / "trial.rrd"
    start = time.perf_counter()
    assert record_trial(path, plan, result) == path
    return path, plan, result, time.perf_counter() - start


def test_the_file_holds_every_entity(walk):
    path, _, _, wall_s = walk
    print(f"\n{path.stat().st_size / 1e6:.2f} MB in {wall_s:.3f} s")
    assert 10_000 < path.stat().st_size < 5_000_000
    # the robot at FRAME_RATE over the whole walk, the last sample kept
    t = np.asarray(walk[2].series["t"])
    times = chunks(path)[("/world/robot/pelvis", False)]["time"]
    assert len(times) == t.size // round(1 / (FRAME_RATE * np.median(np.diff(t)))) + 1
    assert times[-1] == pytest.approx(t[-1], abs=2e-9)
    assert [p.name for p in path.parent.iterdir()] == ["trial.rrd"]  # no temporary left
    found = {
        (entity, column.split(":")[0])
        for (entity, _), columns in chunks(path).items()
        for column in columns
        if ":" in column
    }
    expected = {
        ("/world/plane", "Boxes3D"),
        ("/world/robot/pelvis", "Boxes3D"),
        ("/world/robot/pelvis", "Transform3D"),
        ("/world/robot/l_thigh", "Capsules3D"),
        ("/world/robot/r_shank", "Capsules3D"),
        ("/world/robot/l_foot", "Boxes3D"),
        ("/world/robot/r_foot", "Transform3D"),
        ("/world/support_polygon", "LineStrips3D"),
        ("/world/zmp_analytic", "Points3D"),
        ("/world/zmp_analytic/trace", "LineStrips3D"),
        ("/world/cop_simulated", "Points3D"),
        ("/world/cop_simulated/trace", "LineStrips3D"),
        ("/world/contact_force/left", "Arrows3D"),
        ("/world/contact_force/right", "Arrows3D"),
        ("/events", "TextLog"),
    }
    expected |= {
        (f"/joints/{j}/{k}", "Scalars") for j in MJCF_JOINTS for k in ("planned", "actual")
    }
    expected |= {(f"/zmp/{a}/{k}", "Scalars") for a in "xy" for k in ("analytic", "simulated")}
    assert expected <= found, expected - found


def _scalars(column) -> np.ndarray:
    return np.array([v[0] for v in column["Scalars:scalars"]])


def test_plots_polygon_and_forces_hold_the_trials_values(walk):
    """Every plotted value is the trial's, in the units and frame the recording promises."""
    path, plan, result, _ = walk
    data, series = chunks(path), result.series
    t = np.asarray(series["t"])
    R = rotation_slope_to_world(plan.params.slope)
    for j, joint in enumerate(MJCF_JOINTS):  # degrees, every sample
        for name, key in (("planned", "q_planned"), ("actual", "q_simulated")):
            column = data[(f"/joints/{joint}/{name}", False)]
            np.testing.assert_allclose(column["time"], t, rtol=0, atol=2e-9)
            np.testing.assert_allclose(_scalars(column), np.rad2deg(series[key][:, j]), rtol=1e-12)
    for a, axis in enumerate("xy"):  # millimetres in S, NaN samples left out
        for name, key in (("analytic", "zmp_analytic"), ("simulated", "cop")):
            values = 1e3 * np.asarray(series[key])[:, a]
            ok = np.isfinite(values)
            column = data[(f"/zmp/{axis}/{name}", False)]
            np.testing.assert_allclose(column["time"], t[ok], rtol=0, atol=2e-9)
            np.testing.assert_allclose(_scalars(column), values[ok], rtol=1e-12)
    polygon = data[("/world/support_polygon", False)]
    for time_s, (strip,) in zip(polygon["time"], polygon["LineStrips3D:strips"], strict=True):
        sample = t[np.argmin(abs(t - time_s))]  # the trial's time, then the plan's sample
        k = min(np.searchsorted(plan.t, sample), plan.t.size - 1)
        closed = np.concatenate([plan.polygon[k], plan.polygon[k][:1]])
        expected = np.column_stack([closed, np.full(len(closed), LIFT)]) @ R.T
        np.testing.assert_allclose(strip, expected, rtol=0, atol=1e-6)
    for f, foot in enumerate(("left", "right")):  # arrows: world force × scale, from the CoP
        column = data[(f"/world/contact_force/{foot}", False)]
        rows = zip(
            column["time"], column["Arrows3D:vectors"], column["Arrows3D:origins"], strict=True
        )
        drawn = 0
        for time_s, vectors, origins in rows:
            k = int(np.argmin(abs(t - time_s)))
            cop, force = series["foot_cop"][k, f], series["foot_force"][k, f]
            if not vectors:
                assert not np.isfinite(cop).all()
                continue
            drawn += 1
            np.testing.assert_allclose(vectors[0], R @ force * FORCE_SCALE, rtol=0, atol=1e-6)
            np.testing.assert_allclose(origins[0], R @ [*cop, LIFT], rtol=0, atol=1e-6)
        assert drawn > 10


def test_the_robot_in_the_file_is_mujocos(walk):
    """Body pose ∘ geom offset read back from the file = MuJoCo's geom positions at that qpos."""
    path, plan, result, _ = walk
    data = chunks(path)
    model = build_model(plan, friction=1.0, actuators="stiff", timestep=0.001)
    mj = mujoco.MjData(model)
    t = np.asarray(result.series["t"])
    for body, kind, key in (("l_foot", "Boxes3D", "centers"), ("r_shank", "Capsules3D", None)):
        pose = data[(f"/world/robot/{body}", False)]
        geom = data[(f"/world/robot/{body}", True)]
        for k in (0, len(pose["time"]) // 2, len(pose["time"]) - 1):
            mj.qpos[:] = result.series["qpos"][np.argmin(abs(t - pose["time"][k]))]
            mujoco.mj_kinematics(model, mj)
            R = np.empty(9)
            mujoco.mju_quat2Mat(R, np.roll(pose["Transform3D:quaternion"][k][0], 1))
            R = R.reshape(3, 3)
            if key:  # box centre
                local = np.asarray(geom[f"{kind}:{key}"][0][0])
            else:  # capsule: from one end along +z, half its length to the centre
                q = np.roll(geom[f"{kind}:quaternions"][0][0], 1)
                axis = np.empty(3)
                mujoco.mju_rotVecQuat(axis, np.array([0.0, 0.0, 1.0]), q)
                local = (
                    geom[f"{kind}:translations"][0][0] + axis * geom[f"{kind}:lengths"][0][0] / 2
                )
            center = np.asarray(pose["Transform3D:translation"][k][0]) + R @ local
            np.testing.assert_allclose(center, mj.geom_xpos[model.geom(body).id], atol=1e-5)


def test_zmp_and_cop_lie_on_the_tilted_plane(walk):
    path, plan, result, _ = walk
    data = chunks(path)
    R = rotation_slope_to_world(plan.params.slope)
    t = np.asarray(result.series["t"])
    for entity, key in (("zmp_analytic", "zmp_analytic"), ("cop_simulated", "cop")):
        points = data[(f"/world/{entity}", False)]
        for time_s, p in zip(points["time"], points["Points3D:positions"], strict=True):
            xy = result.series[key][np.argmin(abs(t - time_s))]
            if np.isfinite(xy).all():
                np.testing.assert_allclose(p[0], R @ [*xy, LIFT], atol=1e-6)
            else:
                assert p == []
    polygon = np.asarray(data[("/world/support_polygon", False)]["LineStrips3D:strips"][0][0])
    assert polygon.shape == (9, 3)
    np.testing.assert_allclose((polygon @ R)[:, 2], LIFT, atol=1e-6)  # z in S


def test_events_and_verdicts_are_log_lines(spec, tmp_path):
    """A fast step slips: a WARN line at the event's time, and the INFO line with the verdicts."""
    plan, result = simulate(spec, 0.4)
    assert result.events, "this trial is expected to report events"
    path = record_trial(tmp_path / "fast.rrd", plan, result)
    log = chunks(path)[("/events", False)]
    levels = [level for (level,) in log["TextLog:level"]]  # one line per row
    texts = [text for (text,) in log["TextLog:text"]]
    lines = list(zip(log["time"], levels, texts, strict=True))
    assert lines[0][:2] == (0.0, "INFO")
    assert f"simulated {result.simulated_verdict}" in lines[0][2]
    assert f"analytic {result.analytic_verdict}" in lines[0][2]
    assert lines[0][2].endswith("; open loop")
    for event, (when, level, text) in zip(result.events, lines[1:], strict=True):
        assert when == pytest.approx(event.time, abs=1e-6)
        assert level == "WARN"
        assert text == f"{event.kind}: {event.cause}"


def test_a_closed_loop_recording_names_its_controller(spec, tmp_path):
    name = "slopewalk.bench.controllers.capture_point:capture_point_pelvis"
    trial = TrialSpec(GaitParams.nominal(spec, 1.0, steps=1), controller=name)
    plan = plan_walk(spec, trial.gait)
    result = run_trial(spec, trial, plan=plan)
    log = chunks(record_trial(tmp_path / "closed.rrd", plan, result))[("/events", False)]
    (first, *_) = [text for (text,) in log["TextLog:text"]]
    assert first.endswith(f"; controller {name}")


def test_a_failure_mid_write_leaves_no_file(walk, tmp_path, monkeypatch):
    _, plan, result, _ = walk

    def boom(*args):
        raise RuntimeError("disk full")

    monkeypatch.setattr(slopewalk.bench.sim.recording, "_log_plots", boom)
    with pytest.raises(RuntimeError, match="disk full"):
        record_trial(tmp_path / "new.rrd", plan, result)
    (tmp_path / "old.rrd").write_bytes(b"previous recording")
    with pytest.raises(RuntimeError, match="disk full"):
        record_trial(tmp_path / "old.rrd", plan, result)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.rrd"]
    assert (tmp_path / "old.rrd").read_bytes() == b"previous recording"


def test_bad_input_is_refused_in_one_line(walk, tmp_path):
    _, plan, result, _ = walk
    with pytest.raises(RecordingError, match="frame_rate 0 Hz"):
        record_trial(tmp_path / "a.rrd", plan, result, frame_rate=0)
    no_qpos = {k: v for k, v in result.series.items() if k != "qpos"}
    with pytest.raises(RecordingError, match="qpos"):
        record_trial(tmp_path / "a.rrd", plan, dataclasses.replace(result, series=no_qpos))
    assert list(tmp_path.iterdir()) == []
