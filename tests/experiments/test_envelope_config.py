"""Envelope files: every key checked, one line naming key, value and range, nothing run."""

import sys

import numpy as np
import pytest

from slopewalk.bench.cli import main
from slopewalk.bench.experiments.envelope.config import (
    DEFAULT_ENVELOPE,
    EnvelopeError,
    envelope_from_dict,
    load_envelope,
)
from slopewalk.bench.sim.model import ACTUATOR_MODES

GOOD = {"grid": {"step_time": [1.0], "slope": [0]}}


def _with(section: str, **values) -> dict:
    data = {"grid": dict(GOOD["grid"])}
    data.setdefault(section, {}).update(values)
    return data


@pytest.mark.parametrize(
    "data, message",
    [
        ({"grid": {"step_time": [1.0], "slope": [0], "frction": [1]}}, "unknown key grid.frction"),
        ({**GOOD, "search": {"populaton": 4}}, "unknown key search.populaton"),
        ({**GOOD, "sweep": 1}, "unknown key sweep"),
        ({}, "no [grid] table"),
        ({"grid": {"slope": [0]}}, "grid.step_time is missing"),
        ({"grid": {"step_time": [1.0]}}, "grid.slope is missing"),
        (_with("grid", step_time=[]), "grid.step_time = []: must be a non-empty list"),
        (_with("grid", step_time=1.0), "grid.step_time = 1.0: must be a non-empty list"),
        (_with("grid", step_time=[0]), "grid.step_time = 0 s: must lie in (0, 60] s"),
        (_with("grid", step_time=[-0.5]), "grid.step_time = -0.5 s: must lie in (0, 60] s"),
        (_with("grid", step_time=["1"]), "grid.step_time = '1': must lie in (0, 60] s"),
        (_with("grid", step_time=[True]), "grid.step_time = True: must lie in (0, 60] s"),
        (_with("grid", step_time=[0.005]), "at least 10 samples"),
        (_with("grid", slope=[60]), "grid.slope = 60 deg: must lie in (-60, 60) deg"),
        (_with("grid", slope=[-75.5]), "grid.slope = -75.5 deg: must lie in (-60, 60) deg"),
        (_with("grid", slope=[float("nan")]), "grid.slope = nan: must lie in (-60, 60) deg"),
        (_with("grid", friction=[0]), "grid.friction = 0: must lie in (0, 10]"),
        (_with("grid", friction=[11]), "grid.friction = 11: must lie in (0, 10]"),
        (_with("grid", actuators=["soft"]), "grid.actuators = 'soft': must be one of stiff"),
        (_with("grid", robot=["nope.toml"]), "no such file"),
        (_with("search", population=1), "search.population = 1: must be an integer in [2, 1000]"),
        (_with("search", population=4.5), "search.population = 4.5: must be an integer in"),
        (_with("search", generations=0), "search.generations = 0: must be an integer in [1,"),
        (_with("search", seed=-1), "search.seed = -1: must be an integer in [0, 4294967295]"),
        (_with("search", family="wide"), "search.family = 'wide': must be one of paper, extended"),
        (_with("search", family=["paper", 3]), "search.family = 3: must be one of paper, extended"),
        (_with("search", family=[]), "search.family = []: must be a family name or"),
        (_with("search", required_margin=-1), "search.required_margin = -1 mm: must lie in [0,"),
        (_with("search", required_margin=60), "search.required_margin = 60 mm: must lie in"),
        (
            _with("grid", controller=["ankle_cop_feedback"]),
            "grid.controller: controller 'ankle_cop_feedback': must read MODULE:CALLABLE",
        ),
        (_with("grid", controller=[3]), 'grid.controller = 3: must be "none" or MODULE:CALLABLE'),
        (
            _with("grid", controller=["no_such_module:f"]),
            "grid.controller: controller 'no_such_module:f': no module named 'no_such_module'",
        ),
        (
            _with("grid", controller=["slopewalk.bench.controllers.ankle_cop:nothing"]),
            "module 'slopewalk.bench.controllers.ankle_cop' has no 'nothing'",
        ),
        (
            _with("grid", controller="slopewalk.bench.controllers.ankle_cop:ankle_cop_feedback"),
            "grid.controller = 'slopewalk.bench.controllers.ankle_cop:ankle_cop_feedback': "
            "must be a "
            "non-empty list",
        ),
        (
            _with(
                "grid",
                controller=[
                    "slopewalk.bench.controllers:load_controller",
                    "slopewalk.bench.sim.closed_loop:load_controller",
                ],
            ),
            "their callables' names (load_controller, load_controller) must differ",
        ),
        (
            {"grid": [GOOD["grid"], {"step_time": [0.5], "slope": [10]}]},
            "[[grid]] is an array of 2 tables: an envelope takes one [grid] table, whose "
            "step_time x slope product is the plane its figure and boundaries draw",
        ),
        (
            _with("grid", actuators=["servo", "servo"]),
            "grid.actuators = ['servo', 'servo']: names servo more than once",
        ),
        (
            _with("search", required_margin=0.005),
            "search.required_margin = 0.005 mm: looks like metres (the key is in mm; 0.005 m "
            "would be 5 mm)",
        ),
        (
            _with("search", required_margin=30),
            "search.required_margin = 30 mm: must be below half the sole's width, 30 mm",
        ),
        ({**GOOD, "steps": 0}, "steps = 0: must be an integer in [1, 1000]"),
        ({**GOOD, "description": 3}, "description = 3: must be a string"),
    ],
)
def test_bad_values_are_refused_in_one_line(tmp_path, data, message):
    with pytest.raises(EnvelopeError) as err:
        envelope_from_dict(data, base_dir=tmp_path, source="e.toml")
    text = str(err.value)
    assert message in text and "\n" not in text and text.startswith("e.toml: ")


def test_defaults_and_the_cells(tmp_path):
    config = envelope_from_dict(
        {"grid": {"step_time": [1.0, 0.5, 1.0], "slope": [0, -10]}}, base_dir=tmp_path
    )
    assert config.modes == ACTUATOR_MODES  # every mode the bench has, by default
    assert config.search.population == 40 and config.search.required_margin == 0.005
    assert [(c.step_time, c.slope_deg) for c in config.cells] == [
        (1.0, 0.0),
        (1.0, -10.0),
        (0.5, 0.0),
        (0.5, -10.0),
    ]  # duplicates dropped, file order
    assert len({c.cell_id for c in config.cells}) == 4
    other = envelope_from_dict(
        {"grid": {"step_time": [1.0], "slope": [0]}, "search": {"seed": 1}}, base_dir=tmp_path
    )
    assert other.cells[0].cell_id != config.cells[0].cell_id  # the search decides the row


def test_both_families_give_one_cell_each(tmp_path):
    data = _with("search", family=["paper", "extended"])
    config = envelope_from_dict(data, base_dir=tmp_path)
    paper = [c for c in config.cells if c.family == "paper"]
    extended = [c for c in config.cells if c.family == "extended"]
    assert len(paper) == len(extended) == len(config.cells) // 2 > 0
    assert len({c.cell_id for c in config.cells}) == len(config.cells)
    assert extended[0].problem().bounds.names[3:] == ("pelvis_offset", "step_length", "sway_share")
    x = np.array([0.2, 0.05, 0.1, 0.01, 0.08, 0.4])
    gait = extended[0].gait(x)
    assert (gait.pelvis_offset, gait.step_length, gait.lean_share) == (0.01, 0.08, 0.4)


def test_controllers_are_walked_by_every_cell_and_enter_its_id_only_when_set(tmp_path):
    ankle = "slopewalk.bench.controllers.ankle_cop:ankle_cop_feedback"
    plain = envelope_from_dict(GOOD, base_dir=tmp_path)
    none = envelope_from_dict(_with("grid", controller=["none"]), base_dir=tmp_path)
    both = envelope_from_dict(_with("grid", controller=["none", ankle, ankle]), base_dir=tmp_path)
    assert plain.controllers == none.controllers == () and both.controllers == (ankle,)
    assert none.cells[0].cell_id == plain.cells[0].cell_id  # "none" is open loop, played anyway
    assert both.cells[0].controllers == (ankle,)
    assert both.cells[0].cell_id != plain.cells[0].cell_id  # its row has more columns


def test_the_default_envelope_covers_the_papers_plane():
    config = load_envelope()
    # quoted in the reports without this checkout's absolute path
    assert config.source == "bench/experiments/envelopes/paper.toml"
    assert DEFAULT_ENVELOPE.as_posix().endswith(config.source)
    assert len(config.step_times) >= 12 and max(config.step_times) == 2.0
    assert min(config.step_times) == 0.3 and 0.5 in config.step_times
    assert len(config.slopes_deg) >= 16 and (min(config.slopes_deg), max(config.slopes_deg)) == (
        -30,
        35,
    )
    assert {15, 18, 22.5, 30} <= set(config.slopes_deg)
    assert {c.friction for c in config.cells} == {1.0}
    assert {c.family for c in config.cells} == {"paper", "extended"}  # issue 24: both


@pytest.mark.parametrize(
    "text, message",
    [
        ("[grid\n", "not valid TOML"),
        (None, "no such file"),
        (b"\x00\xff binary", "not UTF-8 text (byte 0xff at offset 1)"),
        ("[grid]\nstep_time = [1.0]\nslope = [90]\n", "grid.slope = 90 deg: must lie in"),
    ],
)
def test_the_command_refuses_a_bad_file_in_one_line_and_writes_nothing(
    tmp_path, capsys, text, message
):
    path = tmp_path / "e.toml"
    if isinstance(text, bytes):
        path.write_bytes(text)
    elif text is not None:
        path.write_text(text)
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as exited:
        sys.exit(main(["envelope", str(path), "--out", str(out)]))
    assert exited.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("slopewalk: error: ") and message in err and err.count("\n") == 1
    assert not out.exists()


def test_required_margins_in_mm_from_zero_to_half_the_sole_are_taken(tmp_path):
    for mm, metres in ((0, 0.0), (0.03, 0.03e-3), (5, 5e-3), (29.9, 29.9e-3)):
        config = envelope_from_dict(_with("search", required_margin=mm), base_dir=tmp_path)
        assert config.search.required_margin == pytest.approx(metres)
