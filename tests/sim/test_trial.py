"""Trials end to end: the 2 s walk agrees with the plan, a blow-up is reported, CLI refusals."""

import json
import subprocess
import sys

import mujoco
import numpy as np
import pytest
from mujoco import rollout

from slopewalk.bench.sim.events import detect, verdict
from slopewalk.bench.sim.playback import (
    build_model,
    control_sequence,
    initial_state,
    recording_from_rollout,
)
from slopewalk.bench.sim.trial import NOT_PREDICTED, run_trial
from slopewalk.bench.sim.trial_spec import TrialSpec
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.kinematics import rotation_slope_to_world
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.spec import default_spec_path
from slopewalk.planner.verdict import TIP_ANGLE


def test_slow_walk_on_flat_ground_tracks_the_analytic_zmp(spec):
    """2 s steps, stiff actuators: no events, simulated CoP within mm of the analytic ZMP.

    The distance has two parts (measured, MuJoCo 3.x, 1 ms step). Where the contacts
    are those the plan assumes, 3.3 mm RMS: the stiff loop tracks to 6 mrad RMS
    and the soft contact lets the soles sink and roll a little. In the last ~50 ms of
    each SSP the swing foot touches down early (``tests/sim/test_simulated_forces.py``)
    and the CoP jumps towards it, up to 60 mm away, in 4 % of the samples: 5.5 mm RMS
    in all. Tolerances: 4 mm and 6 mm; 8 mm let a 40 % worse match pass.
    """
    gait = GaitParams.nominal(spec, 2.0)
    plan = plan_walk(spec, gait)
    result = run_trial(spec, TrialSpec(gait), plan=plan)
    print("\n".join(result.summary_lines()))
    assert result.analytic_verdict == "stable"
    assert result.simulated_verdict == "stable"
    assert [e.kind for e in result.events] == []
    assert result.standing_fraction == 1.0
    series = result.series
    idx = np.clip(np.searchsorted(plan.t, series["t"]), 0, plan.t.size - 1)
    fz = series["foot_force"][..., 2]
    on_swing = np.where(plan.stance[idx] == 0, fz[:, 1], fz[:, 0])
    early = ~plan.double_support[idx] & (on_swing > 0.01 * spec.total_mass * 9.81)
    distance = np.hypot(*(series["cop"] - series["zmp_analytic"]).T)
    print(f"early-contact samples {early.mean():.1%}; RMS elsewhere "
          f"{np.sqrt(np.mean(distance[~early] ** 2)) * 1e3:.2f} mm")  # fmt: skip
    assert early.mean() < 0.05
    assert np.sqrt(np.mean(distance[~early] ** 2)) < 0.004
    assert result.zmp_rms < 0.006
    # the loaded soles turn only by the floor's give (measured 0.59°), under the fifth of
    # the tip angle that the fidelity report counts as rocking
    assert 0.0 < result.simulated_max_tilt < TIP_ANGLE / 5


def test_a_played_extended_gait_lands_on_its_planned_footprints(spec):
    """A slow extended gait (short steps, pelvis ahead, a blended lean) played stiff: MuJoCo
    walks it, its joints track the plan, and both soles end where the plan puts them
    (the short step's footprints, a quarter of a thigh short of the nominal ones)."""
    gait = GaitParams.nominal(
        spec, 2.0, step_length=0.75 * spec.thigh, pelvis_offset=0.01, sway_share=0.5
    )
    plan = plan_walk(spec, gait)
    result = run_trial(spec, TrialSpec(gait), plan=plan)
    print("\n".join(result.summary_lines()))
    assert result.analytic_verdict == "stable" and result.simulated_verdict == "stable"
    series = result.series
    tracking = np.abs(series["q_simulated"] - series["q_planned"]).max()
    assert tracking < 0.05, tracking
    last = plan.stance[-1]
    planned = np.empty((2, 3))
    planned[last], planned[1 - last] = plan.stance_sole[-1], plan.swing_sole[-1]
    error = np.abs(series["sole"][-1] - planned).max()
    print(f"final soles: max |simulated - planned| {error * 1e3:.2f} mm")
    assert error < 0.003  # the nominal step would put the front foot 55 mm farther
    assert abs(planned[:, 0].max() - gait.steps * gait.step_length / 2) < 1e-9


def test_fast_walk_falls_where_the_plan_leaves_the_foot(spec):
    result = run_trial(spec, TrialSpec(GaitParams.nominal(spec, 0.4)))
    assert result.analytic_verdict == "zmp_outside"
    assert result.simulated_verdict in ("tip", "fall")
    assert "tip" in [e.kind for e in result.events]  # a foot turns over before the fall
    assert result.simulated_max_tilt > TIP_ANGLE  # and the measured tilt says so


def test_a_trial_without_predictions_simulates_the_same_and_claims_no_verdict(spec):
    """``predict=False`` (the envelope's and the controller tables' trials) skips the
    servo loop's walk: the simulated columns stay those of the full comparison, and the
    prediction columns say that nothing was predicted rather than "stable"."""
    plan = plan_walk(spec, GaitParams.nominal(spec, 1.0, slope=np.deg2rad(10.0), steps=2))
    full = run_trial(spec, TrialSpec(plan.params), plan=plan).scalars()
    bare = run_trial(spec, TrialSpec(plan.params), plan=plan, predict=False).scalars()
    predicted = {"compliant_verdict", "compliant_min_margin", "predicted_verdict",
                 "predicted_events", "predicted_rotation", "wall_s", "null_because",
                 "predicted_walk_verdict"}  # fmt: skip
    assert {k: v for k, v in bare.items() if k not in predicted} == {
        k: v for k, v in full.items() if k not in predicted
    }
    assert bare["predicted_verdict"] == bare["compliant_verdict"] == NOT_PREDICTED
    assert bare["predicted_walk_verdict"] == NOT_PREDICTED
    assert bare["predicted_events"] == [] and bare["predicted_rotation"] is None
    assert bare["null_because"]["predicted_rotation"].startswith("not predicted")


def test_a_blow_up_is_reported_not_raised(spec, tmp_path, monkeypatch):
    """Explicit Euler with absurd gains diverges; the recording is cut and says so."""
    monkeypatch.chdir(tmp_path)  # where MuJoCo's own handler would write MUJOCO_LOG.TXT
    plan = plan_walk(spec, GaitParams.nominal(spec, 1.0, steps=1))
    model = build_model(plan, friction=1.0, actuators="stiff", timestep=0.004)
    model.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    model.actuator_gainprm[:, 0] *= 1e6
    model.actuator_biasprm[:, 1] *= 1e6
    model.actuator_forcelimited[:] = 0
    t, q_ref = control_sequence(plan, model.opt.timestep, 0.1, 0.0)
    state, sensordata = rollout.rollout(
        model, mujoco.MjData(model), initial_state(model, plan), q_ref[None]
    )
    rec = recording_from_rollout(
        model, state[0], sensordata[0], t, q_ref, rotation_slope_to_world(0.0), 50.0
    )
    assert rec.diverged_at is not None
    assert rec.t.size < t.size
    events = detect(rec, weight=spec.total_mass * 9.81, hip_height=plan.params.hip_height)
    assert verdict(events) == "diverged"
    assert list(tmp_path.iterdir()) == []  # the warning went to our logger, not to a file


def _cli(*args):
    return subprocess.run(
        [sys.executable, "-m", "slopewalk.bench.cli", *args],
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_trial_cli_writes_json_and_series(spec, tmp_path):
    """The CLI's numbers are those of ``run_trial`` on the trial its flags describe.

    1 s steps on 10°, μ 0.6: the plan needs friction 0.26 and the simulation stays on
    its feet, so both verdicts are stable; a CLI that dropped or mis-scaled a flag
    (degrees as radians, the default μ) changes these values.
    """
    out, series = tmp_path / "trial.json", tmp_path / "trial.npz"
    result = _cli(
        "trial",
        "--step-time",
        "1",
        "--slope",
        "10",
        "--friction",
        "0.6",
        "--steps",
        "2",
        "--out",
        str(out),
        "--series",
        str(series),
    )
    assert result.returncode == 0, result.stderr
    data = json.loads(out.read_text())
    assert data["trial"]["gait"]["slope_deg"] == pytest.approx(10)
    gait = GaitParams.nominal(spec, 1.0, slope=np.deg2rad(10.0), steps=2)
    expected = run_trial(spec, TrialSpec(gait, friction=0.6))
    assert (expected.analytic_verdict, expected.simulated_verdict) == ("stable", "stable")
    assert not expected.slip_predicted
    for key in ("analytic_verdict", "simulated_verdict", "slip_predicted"):
        assert data[key] == getattr(expected, key), key
    for key in ("zmp_rms", "zmp_max", "analytic_min_margin", "max_friction_ratio",
                "simulated_max_friction_ratio", "tracking_rms"):  # fmt: skip
        assert data[key] == pytest.approx(getattr(expected, key), rel=1e-6, abs=1e-9), key
    cop = np.load(series)["cop"]
    np.testing.assert_allclose(cop, expected.series["cop"], rtol=0, atol=1e-9)


def test_spec_mujoco_refuses_is_one_line(tmp_path, spec):
    """A spec the planner accepts but MuJoCo cannot compile is refused in one line."""
    text = default_spec_path().read_text()
    bad = tmp_path / "bad.toml"
    # positive (the planner accepts it) but below MuJoCo's minimum for a moving body
    bad.write_text(
        text.replace("mass = 0.008", "mass = 1e-20").replace(
            "inertia = [8.330e-7, 8.330e-7, 8.330e-7]", "inertia = [1e-22, 1e-22, 1e-22]"
        )
    )
    result = _cli("mjcf", "--robot", str(bad), "--out", str(tmp_path / "scene.xml"))
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.stderr
    assert not (tmp_path / "scene.xml").exists()


def test_trial_json_is_strict_and_says_why_a_value_is_missing(spec):
    """A trial lost during settling has no ZMP comparison: null in the JSON, and why."""
    import dataclasses

    from slopewalk.bench.sim.events import Event

    result = run_trial(spec, TrialSpec(GaitParams.nominal(spec, 1.0, steps=1)))
    lost = dataclasses.replace(
        result,
        zmp_rms=float("nan"),
        zmp_max=float("nan"),
        events=[Event(-0.05, "tip", "left foot 6 deg off"), Event(0.5, "slip", "6 mm")],
    )
    data = lost.scalars()
    json.dumps(data, allow_nan=False)  # raises on a bare NaN
    assert data["zmp_rms"] is None and data["zmp_max"] is None
    assert (
        "before the walk began (tip at t = -0.050 s, settling)" in data["null_because"]["zmp_rms"]
    )
    assert [e["phase"] for e in data["events"]] == ["settling", "walk"]
    lines = lost.summary_lines()
    assert any(line.startswith("n/a: the robot was lost before the walk") for line in lines)
    assert any("(settling)" in line and "tip" in line for line in lines)
    assert "null_because" not in result.scalars()  # a whole trial has every value
