"""Sweeps of other gaits than the nominal one: drawn at random ([draw]) or an envelope's
GA gaits (``envelope``), the held-out fidelity sets of issue 22."""

import csv
import io

import numpy as np
import pytest

from slopewalk.bench.experiments.sweep.config import SweepError, load_sweep, sweep_from_dict
from slopewalk.bench.experiments.sweep.run import run_one
from slopewalk.bench.tables.sweep import GAIT_COLUMNS, GAIT_TABLE_COLUMNS, SWEEP_GAIT
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.gait_search import GaitProblem, ga_params
from slopewalk.planner.spec import load_spec

ROOT = __import__("pathlib").Path(__file__).resolve().parents[2]
DRAW = {
    "steps": 1,
    "draw": {"family": ["paper", "extended"], "gaits": 1, "seed": 5},
    "grid": {"step_time": [1.0], "slope": [10], "actuators": ["stiff", "servo"]},
}


def _sweep(data):
    return sweep_from_dict(data, base_dir=ROOT)


@pytest.fixture(scope="module")
def drawn():
    """The trials of ``DRAW`` and their gaits (a draw costs a box and a measured batch)."""
    trials = list(_sweep(DRAW).trials)
    return trials, [t.gait() for t in trials]


def test_drawn_gaits_are_admissible_inside_their_box_and_the_same_in_every_mode(drawn):
    trials, _ = drawn
    assert len(trials) == 2 * 2  # families x modes
    spec = load_spec()
    gaits = {}
    for t in trials:
        params = t.gait()
        key = t.gait_choice.key
        family = t.gait_choice.family
        problem = GaitProblem(spec, ga_params(spec, 1.0, np.deg2rad(10.0)), family=family)
        x = [getattr(params, n) for n in problem.bounds.names]
        if family == "extended":  # sway_share is the resolved w
            x[-1] = params.lean_share
        assert np.all(problem.bounds.xl <= x) and np.all(x <= problem.bounds.xu)
        assert problem.measure(np.array([x])).admissible[0]  # reachable, within the limits
        gaits.setdefault(key, params)
        assert gaits[key] == params  # the same gait in both modes: paired trials
    assert len(gaits) == 2 and len(set(gaits.values())) == 2  # every draw its own gait
    nominal = GaitParams.nominal(spec, 1.0, slope=np.deg2rad(10.0), steps=1)
    assert nominal not in gaits.values()


def test_a_draw_is_fixed_by_its_seed_and_its_cell(drawn):
    trials, gaits = drawn
    paper = DRAW | {"draw": {"family": ["paper"], "seed": 5}}
    assert [t.gait() for t in _sweep(paper).trials] == gaits[::2]  # drawn again: the same
    other = list(_sweep(paper | {"draw": {"family": ["paper"], "seed": 6}}).trials)
    assert not {t.gait() for t in other} & set(gaits)
    assert not {t.trial_id for t in other} & {t.trial_id for t in trials}
    steeper = list(_sweep(paper | {"grid": DRAW["grid"] | {"slope": [12]}}).trials)
    assert steeper[0].gait().hip_height != gaits[0].hip_height  # another cell, another draw


def test_a_drawn_trial_row_records_the_gait_it_walked(drawn):
    trial = drawn[0][0]
    row = run_one(trial)
    params = trial.gait()
    assert row["gait"] == "paper draw 0"
    assert row["hip_height_m"] == params.hip_height
    assert row["tilt_deg"] == pytest.approx(np.rad2deg(params.tilt))
    assert row["predicted_verdict"] and row["simulated_verdict"] != "error"
    line = SWEEP_GAIT.format_row(row)
    assert next(csv.reader(io.StringIO(line.decode())))[-len(GAIT_COLUMNS)] == "paper draw 0"


@pytest.mark.parametrize(
    "draw, message",
    [
        ({"family": ["banana"]}, "draw.family = ['banana']: must be a non-empty list of paper"),
        ({"gaits": 0}, "draw.gaits = 0: must be an integer >= 1"),
        ({"seed": -1}, "draw.seed = -1: must be an integer >= 0"),
        ({"count": 3}, "unknown key draw.count"),
    ],
)
def test_a_bad_draw_is_refused_in_one_line(draw, message):
    with pytest.raises(SweepError, match=message.replace("[", r"\[").replace("]", r"\]")):
        _sweep(DRAW | {"draw": draw})


def _envelope(tmp_path, rows=3):
    """The first ``rows`` cells of the committed envelope, as a table of their own."""
    lines = (ROOT / "results/envelope/envelope.csv").read_text().splitlines(keepends=True)
    path = tmp_path / "envelope.csv"
    path.write_text("".join(lines[: rows + 1]))
    return path, list(csv.DictReader(io.StringIO("".join(lines[: rows + 1]))))


def test_an_envelope_sweep_plays_every_gait_the_envelope_played_in_every_mode(tmp_path):
    path, rows = _envelope(tmp_path)
    played = [
        (r, g)
        for r in rows
        for g in ("maxmargin", "minwork")
        if any(r[f"{g}_{m}_verdict"] for m in ("stiff", "servo", "stiff_ff", "servo_ff"))
    ]
    config = sweep_from_dict(
        {"steps": 4, "envelope": [path.name], "grid": {"actuators": ["stiff", "servo_ff"]}},
        base_dir=tmp_path,
    )
    trials = list(config.trials)
    assert config.other_gaits and len(trials) == 2 * len(played)
    for t, (row, gait) in zip(trials[::2], played, strict=True):
        params = t.gait()
        assert t.step_time == float(row["step_time"]) and t.slope_deg == float(row["slope_deg"])
        assert params.hip_height == float(row[f"{gait}_hip_height_m"])
        assert params.swing_lift == float(row[f"{gait}_swing_lift_m"])
        # the table's tilt, to its 1e-5 deg, within the ankle roll's limits (0.6 rad)
        assert abs(params.tilt - np.deg2rad(float(row[f"{gait}_tilt_deg"]))) < 1e-6
        assert abs(params.tilt) <= 0.6


def test_an_envelope_sweep_takes_only_actuators_in_its_grid(tmp_path):
    path, _ = _envelope(tmp_path, 1)
    with pytest.raises(SweepError, match="envelope goes with one \\[grid\\] of actuators alone"):
        sweep_from_dict(
            {"envelope": [path.name], "grid": {"actuators": ["stiff"], "slope": [0]}},
            base_dir=tmp_path,
        )
    with pytest.raises(SweepError, match="no such file"):
        sweep_from_dict({"envelope": ["nope.csv"], "grid": {}}, base_dir=tmp_path)


@pytest.mark.slow
def test_the_committed_held_out_sets_hold_their_size():
    """Issue 22: at least 400 trials per held-out set, at least 40 gaits in CI's."""
    sweeps = ROOT / "bench/experiments/sweeps"
    assert len(load_sweep(sweeps / "random.toml").trials) >= 400
    assert len(load_sweep(sweeps / "robots.toml").trials) >= 400
    assert len(load_sweep(sweeps / "ga.toml").trials) >= 400
    ci = load_sweep(sweeps / "ci.toml")
    assert len({t.gait() for t in ci.trials}) >= 40
    assert GAIT_TABLE_COLUMNS[-len(GAIT_COLUMNS) :] == GAIT_COLUMNS


def test_an_envelope_sweep_with_command_noise_replays_each_gait_once_per_seed(tmp_path):
    """``ga-noise.toml``: the envelope's gaits, each seed a replica with noise of its own,
    in a table with the gait's columns and then the noise's."""
    from slopewalk.bench.experiments.sweep.run import _open_loop_format

    path, _ = _envelope(tmp_path, 1)
    base = {"envelope": [path.name], "grid": {"actuators": ["servo"]}}
    once = list(sweep_from_dict(base, base_dir=tmp_path).trials)
    noisy = base | {"seed": [0, 1], "command_noise": 1e-4}
    config = sweep_from_dict(noisy, base_dir=tmp_path)
    trials = list(config.trials)
    assert config.noisy and config.other_gaits and len(trials) == 2 * len(once) > 0
    for plain in once:
        replicas = [t for t in trials if t.gait() == plain.gait()]
        assert sorted(t.seed for t in replicas) == [0, 1]
        assert len({t.trial_id for t in replicas} | {plain.trial_id}) == 3
        for t in replicas:
            assert t.trial_spec().command_noise == pytest.approx(np.deg2rad(1e-4))
    columns = _open_loop_format(config).columns
    assert columns[-len(GAIT_COLUMNS) - 1 :] == (*GAIT_COLUMNS, "command_noise_deg")
    row = run_one(trials[0])
    assert not row["error"] and set(columns) <= set(row)
    assert row["command_noise_deg"] == 1e-4 and row["gait"] == trials[0].gait_inputs()["gait"]
