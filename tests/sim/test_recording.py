"""Rerun recordings: every entity is in the file, the robot is MuJoCo's, nothing half-written."""

import dataclasses
import functools
import time

import mujoco
import numpy as np
import pyarrow as pa
import pytest
from rerun.chunk import RrdReader

import slopewalk.bench.sim.recording
from slopewalk.bench.sim.playback import SETTLE_TIME, build_model, play
from slopewalk.bench.sim.recording import (
    FORCE_SCALE,
    FRAME_RATE,
    LIFT,
    RecordingError,
    record_trial,
)
from slopewalk.bench.sim.trial import run_trial, simulated_rows
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


@functools.cache  # read once per file: the tests share the module's recording
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
    # the robot at FRAME_RATE over the settling and the walk, the last sample kept
    t = np.asarray(walk[2].series["t"])
    rows = round((SETTLE_TIME + t[-1]) / walk[2].trial.timestep) + 1  # -0.5 s … the walk's end
    times = chunks(path)[("/world/robot/pelvis", False)]["time"]
    k = round(1 / (FRAME_RATE * np.median(np.diff(t))))  # every k-th row, and the last
    assert len(times) == len(range(0, rows, k)) + ((rows - 1) % k != 0)
    assert times[0] == pytest.approx(-SETTLE_TIME, abs=2e-9)
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
        ("/world/zmp_lipm", "Points3D"),
        ("/world/zmp_lipm/trace", "LineStrips3D"),
        ("/world/cop_simulated", "Points3D"),
        ("/world/cop_simulated/trace", "LineStrips3D"),
        ("/world/contact_force/left", "Arrows3D"),
        ("/world/contact_force/right", "Arrows3D"),
        ("/events", "TextLog"),
    }
    expected |= {
        (f"/joints/{j}/{k}", "Scalars") for j in MJCF_JOINTS for k in ("planned", "actual")
    }
    expected |= {
        (f"/torques/{j}/{k}", "Scalars") for j in MJCF_JOINTS for k in ("planned", "simulated")
    }
    expected |= {
        (f"/zmp/{a}/{k}", "Scalars") for a in "xy" for k in ("analytic", "lipm", "simulated")
    }
    expected |= {(f"/margin/{k}", "Scalars") for k in ("analytic", "simulated", "compliant")}
    assert expected <= found, expected - found


def _scalars(column) -> np.ndarray:
    return np.array([v[0] for v in column["Scalars:scalars"]])


def test_plots_polygon_and_forces_hold_the_trials_values(walk):
    """Every plotted value is the trial's, in the units and frame the recording promises."""
    path, plan, result, _ = walk
    data, series = chunks(path), result.series
    t = np.asarray(series["t"])
    sim = simulated_rows(series)  # the settling (t < 0), then the walk
    assert sim["t"][0] == pytest.approx(-SETTLE_TIME) and np.all(np.diff(sim["t"]) > 0)
    R = rotation_slope_to_world(plan.params.slope)
    for j, joint in enumerate(MJCF_JOINTS):  # degrees, every sample
        for name, times, values in (
            ("planned", t, series["q_planned"]),
            ("actual", sim["t"], sim["q_simulated"]),
        ):
            column = data[(f"/joints/{joint}/{name}", False)]
            np.testing.assert_allclose(column["time"], times, rtol=0, atol=2e-9)
            np.testing.assert_allclose(_scalars(column), np.rad2deg(values[:, j]), rtol=1e-12)
        column = data[(f"/torques/{joint}/simulated", False)]  # N m, MuJoCo's actuator force
        np.testing.assert_allclose(column["time"], sim["t"], rtol=0, atol=2e-9)
        np.testing.assert_allclose(_scalars(column), sim["actuator_force"][:, j], rtol=1e-12)
    for a, axis in enumerate("xy"):  # millimetres in S, NaN samples left out
        for name, times, xy in (
            ("analytic", t, series["zmp_analytic"]),
            ("lipm", t, series["zmp_lipm"]),
            ("simulated", sim["t"], sim["cop"]),
        ):
            values = 1e3 * np.asarray(xy)[:, a]
            ok = np.isfinite(values)
            column = data[(f"/zmp/{axis}/{name}", False)]
            np.testing.assert_allclose(column["time"], times[ok], rtol=0, atol=2e-9)
            np.testing.assert_allclose(_scalars(column), values[ok], rtol=1e-12)
    column = data[("/margin/analytic", False)]
    np.testing.assert_allclose(_scalars(column), 1e3 * series["margin_analytic"], rtol=1e-12)
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
            k = int(np.argmin(abs(sim["t"] - time_s)))  # the settling's rows too
            cop, force = sim["foot_cop"][k, f], sim["foot_force"][k, f]
            if not vectors:
                assert not np.isfinite(cop).all()
                continue
            drawn += 1
            np.testing.assert_allclose(vectors[0], R @ force * FORCE_SCALE, rtol=0, atol=1e-6)
            np.testing.assert_allclose(origins[0], R @ [*cop, LIFT], rtol=0, atol=1e-6)
        assert drawn > 10


def test_planned_torques_are_the_plans_newton_euler_torques_per_leg(walk):
    """``torques/<joint>/planned``: the plan's torque of that joint's leg, stance or swing by
    the plan's stance at that time (the walk's samples are the plan's)."""
    path, plan, result, _ = walk
    data = chunks(path)
    t = np.asarray(result.series["t"])
    np.testing.assert_allclose(t, plan.t[: t.size], rtol=0, atol=1e-9)
    stance_left = plan.stance[: t.size] == 0  # Table-I order: 4 stance joints, then the swing leg's
    for j, joint in enumerate(MJCF_JOINTS):
        leg, side = divmod(j, 4)  # MJCF order: left hip…roll, right hip…roll
        ankle_roll_first = {0: 3, 1: 2, 2: 1, 3: 0}  # left/right order vs Table I's stance
        stance_col = ankle_roll_first[side]  # stance: ankle roll, ankle pitch, knee, hip
        swing_col = 4 + side  # swing: hip, knee, ankle pitch, ankle roll
        own_leg_is_stance = stance_left if leg == 0 else ~stance_left
        tau = plan.tau[: t.size]
        expected = np.where(own_leg_is_stance, tau[:, stance_col], tau[:, swing_col])
        column = data[(f"/torques/{joint}/planned", False)]
        np.testing.assert_allclose(column["time"], t, rtol=0, atol=2e-9)
        np.testing.assert_allclose(_scalars(column), expected, rtol=1e-12, atol=1e-12)


def test_the_simulated_margin_is_the_cops_distance_to_the_polygon_edge(walk):
    """``margin/simulated`` [mm]: the CoP's distance to the nearest edge of the planned
    support polygon, positive inside; checked point by point against edges and a winding."""
    path, plan, result, _ = walk
    column = chunks(path)[("/margin/simulated", False)]
    t = np.asarray(result.series["t"])
    for when, margin in list(zip(column["time"], _scalars(column), strict=True))[::97]:
        k = int(np.argmin(abs(t - when)))  # the trial's sample, then the plan's (as trial.py)
        p, polygon = (
            result.series["cop"][k],
            plan.polygon[min(np.searchsorted(plan.t, t[k]), k + 1)],
        )
        a, b = polygon, np.roll(polygon, -1, axis=0)
        edge = b - a
        along = np.clip(
            np.einsum("ij,ij->i", p - a, edge) / np.maximum((edge**2).sum(1), 1e-30), 0, 1
        )
        distance = np.hypot(*(a + along[:, None] * edge - p).T).min()
        inside = np.all(edge[:, 0] * (p - a)[:, 1] - edge[:, 1] * (p - a)[:, 0] >= -1e-12)
        assert margin == pytest.approx(1e3 * distance * (1 if inside else -1), abs=1e-6)


def _blueprint_views(path) -> dict[str, tuple[str, str]]:
    """{view name: (kind, origin)} of the file's blueprint; asserts each shows its origin's
    whole subtree."""
    reader = RrdReader(path)
    (entry,) = reader.blueprints()
    assert entry.application_id == "slopewalk"  # the recording's: the viewer applies it
    rows: dict[str, dict] = {}
    for chunk in reader.store(store=entry).stream():
        batch = chunk.to_record_batch()
        fields = rows.setdefault(chunk.entity_path, {})
        for name in batch.schema.names:
            if name.split(":")[0] in ("ViewBlueprint", "ViewContents"):
                fields[name] = batch.column(name).to_pylist()[-1][0]
    views = {}
    for entity, fields in rows.items():
        if "ViewBlueprint:class_identifier" in fields:
            assert rows[f"{entity}/ViewContents"]["ViewContents:query"] == "$origin/**"
            views[fields["ViewBlueprint:display_name"]] = (
                fields["ViewBlueprint:class_identifier"],
                fields["ViewBlueprint:space_origin"],
            )
    return views


def test_the_file_carries_its_layout_plots_grouped_by_what_they_compare(walk):
    path = walk[0]
    views = _blueprint_views(path)
    kinds = sorted(kind for kind, _ in views.values())
    assert kinds == ["3D", "TextLog"] + ["TimeSeries"] * 19, views
    assert views["robot on the slope"] == ("3D", "world")
    assert views["events"] == ("TextLog", "events")
    entities = {entity for entity, _ in chunks(path)}
    plotted = {"/" + origin: [] for kind, origin in views.values() if kind == "TimeSeries"}
    for entity in entities:
        parent = entity.rsplit("/", 1)[0]
        if parent in plotted:
            plotted[parent].append(entity.rsplit("/", 1)[1])
    assert (
        sorted(plotted["/zmp/x"]) == sorted(plotted["/zmp/y"]) == ["analytic", "lipm", "simulated"]
    )
    assert sorted(plotted["/margin"]) == ["analytic", "compliant", "simulated"]
    for joint in MJCF_JOINTS:  # each joint: planned vs actual in one plot, torques in another
        assert sorted(plotted[f"/joints/{joint}"]) == ["actual", "planned"]
        assert sorted(plotted[f"/torques/{joint}"]) == ["planned", "simulated"]


def test_a_lower_plot_rate_keeps_every_kth_sample_and_the_3d_rate(walk, tmp_path):
    path, plan, result, _ = walk
    low = record_trial(tmp_path / "low.rrd", plan, result, plot_rate=100.0)
    full, lean = chunks(path), chunks(low)
    sim_t = simulated_rows(result.series)["t"]
    expected = np.unique(np.r_[sim_t[::10], sim_t[-1]])
    np.testing.assert_allclose(lean[("/joints/l_knee/actual", False)]["time"], expected, atol=2e-9)
    key = ("/world/robot/pelvis", False)
    assert lean[key]["time"] == full[key]["time"]
    print(
        f"\nfull rate {path.stat().st_size / 1e6:.2f} MB, 100 Hz {low.stat().st_size / 1e6:.2f} MB"
    )
    assert low.stat().st_size < 0.6 * path.stat().st_size


def test_the_robot_in_the_file_is_mujocos(walk):
    """Body pose ∘ geom offset read back from the file = MuJoCo's geom positions at that qpos."""
    path, plan, result, _ = walk
    data = chunks(path)
    model = build_model(plan, friction=1.0, actuators="stiff", timestep=0.001)
    mj = mujoco.MjData(model)
    sim = simulated_rows(result.series)  # the settling, then the walk
    for body, kind, key in (("l_foot", "Boxes3D", "centers"), ("r_shank", "Capsules3D", None)):
        pose = data[(f"/world/robot/{body}", False)]
        geom = data[(f"/world/robot/{body}", True)]
        for k in (0, len(pose["time"]) // 2, len(pose["time"]) - 1):
            mj.qpos[:] = sim["qpos"][np.argmin(abs(sim["t"] - pose["time"][k]))]
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
    sim = simulated_rows(result.series)
    for entity, times, xys in (
        ("zmp_analytic", t, result.series["zmp_analytic"]),
        ("zmp_lipm", t, result.series["zmp_lipm"]),
        ("cop_simulated", sim["t"], sim["cop"]),
    ):
        points = data[(f"/world/{entity}", False)]
        for time_s, p in zip(points["time"], points["Points3D:positions"], strict=True):
            xy = xys[np.argmin(abs(times - time_s))]
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
    assert lines[0][:2] == (-SETTLE_TIME, "INFO") and lines[0][2].startswith("settling")
    assert lines[1][:2] == (0.0, "INFO")
    assert f"simulated {result.simulated_verdict}" in lines[1][2]
    assert f"analytic {result.analytic_verdict}" in lines[1][2]
    assert lines[1][2].endswith("; open loop")
    for event, (when, level, text) in zip(result.events, lines[2:], strict=True):
        assert when == pytest.approx(event.time, abs=1e-6)
        assert level == "WARN"
        assert text == f"{event.kind}: {event.cause}"


def test_a_closed_loop_recording_names_its_controller(spec, tmp_path):
    name = "slopewalk.bench.controllers.capture_point:capture_point_pelvis"
    trial = TrialSpec(GaitParams.nominal(spec, 1.0, steps=1), controller=name)
    plan = plan_walk(spec, trial.gait)
    result = run_trial(spec, trial, plan=plan)
    log = chunks(record_trial(tmp_path / "closed.rrd", plan, result))[("/events", False)]
    (_, verdicts, *_) = [text for (text,) in log["TextLog:text"]]
    assert verdicts.endswith(f"; controller {name}")


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
    for rate in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(RecordingError, match=f"plot_rate {rate} Hz: must be a finite number"):
            record_trial(tmp_path / "a.rrd", plan, result, plot_rate=rate)
    no_qpos = {k: v for k, v in result.series.items() if k != "qpos"}
    with pytest.raises(RecordingError, match="qpos"):
        record_trial(tmp_path / "a.rrd", plan, dataclasses.replace(result, series=no_qpos))
    assert list(tmp_path.iterdir()) == []
