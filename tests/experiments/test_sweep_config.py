"""Sweep files: the format, the checks, trial ids, and lazy expansion of large grids."""

import hashlib
import itertools
import json
import random
import tracemalloc
from dataclasses import asdict
from pathlib import Path

import numpy as np
import pytest

from slopewalk.bench.experiments.sweep.config import (
    DEFAULT_SWEEP,
    SWEEPS_DIR,
    TIMESTEP,
    SweepError,
    load_sweep,
    sweep_from_dict,
)

SMOKE = SWEEPS_DIR / "smoke.toml"
ANKLE = "slopewalk.bench.controllers.ankle_cop:ankle_cop_feedback"


def _parse(data: dict, base_dir: Path = Path(".")):
    return sweep_from_dict(data, base_dir=base_dir, source="s.toml")


# --- the file format ---------------------------------------------------------------------------


def test_grid_is_the_product_and_defaults_fill_the_rest():
    config = _parse({"grid": {"step_time": [1.0, 0.5], "friction": [0.4, 0.6, 1.0]}})
    assert len(config.trials) == 6
    assert {(t.step_time, t.friction) for t in config.trials} == {
        (s, f) for s in (1.0, 0.5) for f in (0.4, 0.6, 1.0)
    }
    t = config.trials[0]
    assert (t.slope_deg, t.actuators, t.robot, t.mass_scale) == (0.0, "stiff", "default", ())
    assert (t.steps, t.seed, config.steps, config.seeds) == (4, 0, 4, (0,))


def test_trials_and_grids_are_a_deduplicated_union():
    config = _parse(
        {
            "steps": 2,
            "seed": 7,
            "grid": [{"slope": [0, 10]}, {"step_time": [1.0, 0.5]}],
            "trial": [{"step_time": 0.4, "friction": 0.4, "actuators": "servo"}, {"slope": 10}],
        }
    )
    # (1, 0) appears in both grids and (1, 10) in a grid and a [[trial]]: each runs once
    keys = [(t.step_time, t.slope_deg, t.friction, t.actuators) for t in config.trials]
    assert keys == [
        (1.0, 0.0, 1.0, "stiff"),
        (1.0, 10.0, 1.0, "stiff"),
        (0.5, 0.0, 1.0, "stiff"),
        (0.4, 0.0, 0.4, "servo"),
    ]
    assert len({t.trial_id for t in config.trials}) == 4
    assert all(t.steps == 2 and t.seed == 7 for t in config.trials)


def test_trial_id_is_stable_and_follows_every_input():
    a = _parse({"trial": [{"step_time": 0.5}]}).trials[0]
    assert a.trial_id == _parse({"trial": [{"step_time": 0.5}]}).trials[0].trial_id
    others = [
        {"trial": [{"step_time": 0.6}]},
        {"trial": [{"step_time": 0.5, "slope": 1}]},
        {"trial": [{"step_time": 0.5, "friction": 0.9}]},
        {"trial": [{"step_time": 0.5, "actuators": "servo"}]},
        {"trial": [{"step_time": 0.5, "mass_scale": {"pelvis": 2}}]},
        {"trial": [{"step_time": 0.5}], "steps": 3},
        {"trial": [{"step_time": 0.5}], "seed": 1},
    ]
    ids = {_parse(d).trials[0].trial_id for d in others}
    assert len(ids) == len(others) and a.trial_id not in ids


def test_mass_scale_groups_multiply(spec):
    config = _parse(
        {"grid": {"mass_scale": [{"all": 10}, {"legs": 2}, {"all": 10, "legs": 2}, {"foot": 3}]}}
    )
    masses = [
        {n: t.spec.links[n].mass / spec.links[n].mass for n in spec.links} for t in config.trials
    ]
    assert masses[0] == pytest.approx(dict.fromkeys(spec.links, 10.0))
    assert masses[1] == pytest.approx({"pelvis": 1, "thigh": 2, "shank": 2, "ankle": 2, "foot": 2})
    assert masses[2]["pelvis"] == pytest.approx(10) and masses[2]["shank"] == pytest.approx(20)
    assert masses[3] == pytest.approx({"pelvis": 1, "thigh": 1, "shank": 1, "ankle": 1, "foot": 3})
    assert [t.mass_scale_text for t in config.trials] == [
        "all=10",
        "legs=2",
        "all=10;legs=2",
        "foot=3",
    ]


def test_robot_paths_are_relative_to_the_sweep_file(tmp_path, short_robot):
    (tmp_path / "s.toml").write_text('[grid]\nrobot = ["short.toml", "default"]\n')
    config = load_sweep(tmp_path / "s.toml")
    assert [t.robot for t in config.trials] == ["short.toml", "default"]
    assert config.trials[0].spec.shank == 0.01 and config.trials[1].spec.shank == 0.111


def test_shipped_sweeps_parse():
    paper = load_sweep()
    assert Path(paper.source) == DEFAULT_SWEEP
    # 8 step times + 9 slopes at 3 frictions, flat 1 s counted once, + 2 mass cases
    assert len(paper.trials) == (8 + 9 - 1) * 3 + 2
    assert {t.mass_scale_text for t in paper.trials} == {"none", "all=10", "legs=2"}
    smoke = load_sweep(SMOKE)
    assert 3 <= len(smoke.trials) <= 4 and smoke.steps == 1


@pytest.mark.parametrize(
    "data, message",
    [
        ({"grid": {"step_time": [1.0]}, "stepz": 3}, "unknown key stepz"),
        ({"grid": {"sloap": [0]}}, "unknown key grid.sloap"),
        ({"trial": [{}, {"mu": 0.5}]}, "unknown key trial[1].mu"),
        ({"grid": {"mass_scale": [{"arms": 2}]}}, "mass_scale: unknown group 'arms'"),
        ({"grid": {"step_time": [1.0, 0]}}, "grid.step_time = 0 s: must be > 0"),
        ({"grid": {"step_time": [-1]}}, "step_time = -1 s: must be > 0"),
        ({"grid": {"slope": [60]}}, "grid.slope = 60 deg: must lie in (-60, 60) deg"),
        ({"trial": [{"slope": -75}]}, "trial[0].slope = -75 deg: must lie in (-60, 60)"),
        ({"grid": {"friction": [0.5, 0]}}, "grid.friction = 0: must be > 0"),
        ({"grid": {"actuators": ["soft"]}}, "actuators = 'soft': must be one of stiff, servo"),
        ({"grid": {"mass_scale": [{"legs": 0}]}}, "mass_scale.legs = 0: must be > 0"),
        ({"grid": {"robot": ["missing.toml"]}}, "grid.robot: robot spec"),
        ({"grid": {"slope": 5}}, "grid.slope = 5: must be a non-empty list"),
        ({"grid": {"friction": ["high"]}}, "grid.friction = 'high': must be a finite number"),
        ({"grid": {}, "steps": 0}, "steps = 0: must be an integer >= 1"),
        ({"steps": 2}, "no trials"),
        ({"grid": {}}, "s.toml: grid is empty: give at least one list, e.g. step_time = [1.0]"),
        ({"grid": [{"slope": [0]}, {}]}, "grid[1] is empty"),
        ({"grid": {"step_time": [0.005]}}, "step time 0.005 s: must lie in [0.01, 60] s"),
        ({"grid": {"controller": ["ankle"]}}, "grid.controller: controller 'ankle': must read"),
        ({"trial": [{"controller": "no_such:f"}]}, "no module named 'no_such'"),
        ({"grid": {"controller": [None, 3]}}, "grid.controller = None: must be"),
        ({"grid": {}, "seed": []}, "seed = []: must be an integer >= 0 or a non-empty list"),
        ({"grid": {"slope": [0]}, "seed": [1, 1]}, "seed = [1, 1]: must be an integer >= 0 or"),
        ({"grid": {"slope": [0]}, "seed": [0, -1]}, "seed = [0, -1]: must be"),
        ({"grid": {"slope": [0]}, "seed": [1.5]}, "seed = [1.5]: must be"),
        ({"grid": {"slope": [0]}, "seed": "x"}, "seed = 'x': must be"),
        ({"grid": {"slope": [0]}, "command_noise": -1e-4}, "command_noise = -0.0001 deg: must lie"),
        (
            {"grid": {"slope": [0]}, "command_noise": 1},
            "command_noise = 1 deg: must lie in [0, 0.5]",
        ),
        ({"grid": {"slope": [0]}, "command_noise": float("nan")}, "command_noise = nan: must be"),
        ({"grid": {"slope": [0]}, "command_noise": float("inf")}, "command_noise = inf: must be"),
        ({"grid": {"slope": [0]}, "command_noise": "1e-4"}, "command_noise = '1e-4': must be a"),
        ({"grid": {"slope": [0]}, "command_noise": True}, "command_noise = True: must be a"),
        (
            {"grid": {"controller": [ANKLE]}, "command_noise": 1e-4},
            "command_noise = 0.0001 deg with a controller",
        ),
    ],
)
def test_bad_sweep_files_are_refused_naming_the_key(data, message):
    with pytest.raises(SweepError) as err:
        _parse(data)
    assert message in str(err.value)
    assert "\n" not in str(err.value)


def test_a_directory_is_not_a_sweep_file(tmp_path):
    with pytest.raises(SweepError, match="is a directory, not a sweep TOML"):
        load_sweep(tmp_path)


def test_trial_id_is_the_hash_of_the_inputs_and_the_spec(tmp_path, short_robot):
    data = {"grid": {"step_time": [0.5, 1.0], "robot": ["short.toml", "default"]}}
    for trial in _parse(data | {"trial": [{"mass_scale": {"legs": 2}}]}, tmp_path).trials:
        key = {  # the definition of the id, written out the slow way
            "step_time": trial.step_time,
            "slope_deg": trial.slope_deg,
            "friction": trial.friction,
            "actuators": trial.actuators,
            "steps": trial.steps,
            "seed": trial.seed,
            "timestep": TIMESTEP,
            # every field, but the optional geometry, contact and servo keys at their
            # default (sole_offset, knee_offset 0, no sole_polygon, contact 0.02 s and 1, no
            # damping: the back-EMF's) left out, so the ids of robots written before them
            # do not move
            "spec": {
                k: v
                for k, v in asdict(trial.spec).items()
                if k
                not in (
                    "sole_offset",
                    "knee_offset",
                    "sole_polygon",
                    "contact_timeconst",
                    "contact_dampratio",
                    "damping",
                )  # fmt: skip
            },
        }
        assert trial.spec.sole_offset == 0.0 and trial.spec.knee_offset == 0.0
        assert trial.spec.sole_polygon is None
        assert (trial.spec.contact_timeconst, trial.spec.contact_dampratio) == (0.02, 1.0)
        assert trial.spec.damping is None
        text = json.dumps(key, sort_keys=True, default=float)
        assert trial.trial_id == hashlib.sha256(text.encode()).hexdigest()[:12]


def _random_sweep(rng: random.Random) -> dict:
    def axis(values):
        chosen = rng.sample(values, rng.randint(1, len(values)))
        return chosen + rng.sample(values, rng.randint(0, 1))  # sometimes a value twice

    def table():
        keys = rng.sample(["step_time", "slope", "friction", "actuators", "mass_scale"], 3)
        pool = {
            "step_time": [0.5, 1.0, 2.0],
            "slope": [0, 0.0, 5, 10],
            "friction": [0.6, 1.0],
            "actuators": ["stiff", "servo"],
            "mass_scale": [{}, {"legs": 2}, {"thigh": 2, "shank": 2, "ankle": 2, "foot": 2}],
        }
        return {k: axis(pool[k]) for k in keys}

    trials = [{k: v[0] for k, v in table().items()} for _ in range(rng.randint(0, 3))]
    return {"grid": [table() for _ in range(rng.randint(1, 3))], "trial": trials}


def test_the_count_is_that_of_the_distinct_trials_listed():
    rng = random.Random(3)
    for _ in range(40):
        data = _random_sweep(rng)
        if not data["trial"]:
            del data["trial"]
        trials = _parse(data).trials
        listed = list(trials)
        ids = [t.trial_id for t in listed]
        assert len(trials) == len(listed) == len(set(ids)), data
        # the same trials as the product of every grid, de-duplicated by id in file order
        everything = []
        for grid in data["grid"] + data.get("trial", []):
            one = _parse({"grid": {k: v if isinstance(v, list) else [v] for k, v in grid.items()}})
            everything += [t.trial_id for t in one.trials]
        assert ids == list(dict.fromkeys(everything))


def test_a_million_trial_grid_is_counted_without_expanding_it(tmp_path):
    path = tmp_path / "big.toml"
    values = ", ".join(f"{x / 100:.2f}" for x in range(1, 101))
    path.write_text(f"[grid]\nstep_time = [{values}]\nslope = [{values}]\nfriction = [{values}]\n")
    tracemalloc.start()
    try:
        trials = load_sweep(path).trials
        assert len(trials) == 10**6
        first = list(itertools.islice(trials, 3))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 20e6, f"{peak / 1e6:.0f} MB: the grid was expanded"  # a list would take GBs
    assert [(t.step_time, t.slope_deg, t.friction) for t in first] == [
        (0.01, 0.01, 0.01),
        (0.01, 0.01, 0.02),
        (0.01, 0.01, 0.03),
    ]
    assert trials.simulated_steps() == pytest.approx(
        sum((1.0 + t / 100 * 4.4) / TIMESTEP for t in range(1, 101)) * 10**4
    )


def test_open_loop_ids_do_not_change_with_the_controller_key():
    """The paper's ids are those of the committed table, with or without controller = "none"."""
    committed = Path(__file__).parents[2] / "results" / "sweep.csv"
    ids = [line.split(",", 1)[0] for line in committed.read_text().splitlines()[1:]]
    paper = load_sweep()
    assert [t.trial_id for t in paper.trials] == ids
    assert not paper.closed_loop
    flat = {"grid": {"step_time": [1.0, 0.5]}}
    keyed = {"grid": {"step_time": [1.0, 0.5], "controller": ["none"]}}
    assert [t.trial_id for t in _parse(flat).trials] == [t.trial_id for t in _parse(keyed).trials]


def test_a_controller_axis_multiplies_the_trials_and_reaches_the_trial_spec():
    config = _parse({"grid": {"step_time": [1.0, 0.5], "controller": ["none", ANKLE]}})
    trials = list(config.trials)
    assert config.closed_loop and len(trials) == 4
    assert [t.controller for t in trials] == [None, ANKLE, None, ANKLE]
    assert len({t.trial_id for t in trials}) == 4
    assert trials[1].trial_spec().controller == ANKLE
    assert trials[1].label.endswith("controller ankle_cop_feedback")
    assert trials[1].inputs()["controller"] == ANKLE and trials[0].inputs()["controller"] == "none"


# --- seeds and command noise -------------------------------------------------------------------


def test_a_seed_list_plays_every_trial_once_per_seed():
    one = _parse({"seed": 3, "grid": {"step_time": [1.0, 0.5]}})
    both = _parse({"seed": [3, 5], "grid": {"step_time": [1.0, 0.5]}})
    trials = list(both.trials)
    assert len(both.trials) == len(trials) == 4 and both.seeds == (3, 5)
    assert [(t.step_time, t.seed) for t in trials] == [(1.0, 3), (1.0, 5), (0.5, 3), (0.5, 5)]
    assert [t.trial_id for t in trials if t.seed == 3] == [t.trial_id for t in one.trials]
    assert len({t.trial_id for t in trials}) == 4


def test_command_noise_enters_the_id_the_table_and_the_trial_only_when_set():
    grid = {"grid": {"step_time": [1.0]}}
    plain, zero = _parse(grid), _parse(grid | {"command_noise": 0})
    noisy = _parse(grid | {"command_noise": 1e-4, "seed": [0, 1]})
    assert [t.trial_id for t in plain.trials] == [t.trial_id for t in zero.trials]
    assert not zero.noisy and noisy.noisy
    a, b = noisy.trials
    assert a.trial_id not in {t.trial_id for t in plain.trials} and a.trial_id != b.trial_id
    spec_a, spec_b = a.trial_spec(), b.trial_spec()
    assert spec_a.command_noise == pytest.approx(np.deg2rad(1e-4), rel=1e-15)
    assert (spec_a.noise_seed, spec_b.noise_seed) == (int(a.trial_id, 16), int(b.trial_id, 16))
    assert a.inputs()["command_noise_deg"] == 1e-4 and "noise 0.0001 deg seed 1" in b.label
    assert plain.trials[0].trial_spec().command_noise == 0.0


def test_the_checks_do_not_walk_the_seeds(monkeypatch):
    """The per-value checks build one trial per value of each other axis, however many seeds
    (a check per seed would cost ~1 ms each: minutes for a long replica list)."""
    from slopewalk.bench.experiments.sweep.trials import SweepTrial

    calls = []
    original = SweepTrial.trial_spec
    monkeypatch.setattr(SweepTrial, "trial_spec", lambda self: calls.append(1) or original(self))
    grid = {"grid": {"step_time": [1.0, 0.5], "slope": [0, 5]}}
    for seeds in (0, list(range(1000))):
        calls.clear()
        config = _parse(grid | {"seed": seeds})
        assert len(calls) == 3  # both step times, then the second slope
    assert len(config.trials) == 4000 and config.trials[1001].seed == 1
