"""Whole envelopes through the command line: rows, 1 ms margins, resume after kills, convergence."""

import os
import signal
import sys
from dataclasses import replace

import numpy as np
import pytest
from conftest import left_in_session

from slopewalk.bench.cli import main
from slopewalk.bench.experiments.envelope.cell import run_cell
from slopewalk.bench.experiments.envelope.config import envelope_from_dict
from slopewalk.bench.experiments.envelope.run import compare_budgets, convergence_cells
from slopewalk.bench.sim.model import ACTUATOR_MODES
from slopewalk.bench.sim.walk_check import WALK_VERDICTS
from slopewalk.bench.tables.envelope import ENVELOPE
from slopewalk.bench.tables.table import read_table
from tests.experiments.test_sweep import _rows_in, _started, _wait_rows

TINY = """\
steps = 2
[grid]
step_time = [1.0, 0.5]
slope = [0, 10]  # 10°: a 10 x 4 search finds a gait there (15° under the contact constraints not)
[search]
population = 10
generations = 4
"""
ENVELOPE_CMD = [sys.executable, "-m", "slopewalk.bench.cli", "envelope"]


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    """The tiny envelope (2 x 2 cells) run once through the CLI: (config path, out dir)."""
    root = tmp_path_factory.mktemp("envelope")
    config = root / "tiny.toml"
    config.write_text(TINY)
    out = root / "out"
    assert main(["envelope", str(config), "--out", str(out), "--workers", "2"]) == 0
    return config, out


def test_a_tiny_envelope_writes_one_row_per_cell_and_the_figure(tiny):
    _, out = tiny
    assert sorted(p.name for p in out.iterdir()) == [
        "boundaries.md",
        "envelope.csv",
        "envelope.png",
    ]
    data = (out / "envelope.csv").read_bytes()
    assert data.startswith(ENVELOPE.header)
    rows = read_table(out / "envelope.csv")
    assert [(r["step_time"], r["slope_deg"]) for r in rows] == [
        (1.0, 0.0),
        (1.0, 10.0),
        (0.5, 0.0),
        (0.5, 10.0),
    ]
    for r in rows:
        assert r["error"] == "" and r["ga_evaluations"] == 2 * 10 * 4
        for mode in ACTUATOR_MODES:  # the max-margin gait is played in every mode the bench has
            assert r[f"maxmargin_{mode}_verdict"] in ("stable", "slip", "tip", "fall", "diverged")
            strict = r[f"maxmargin_{mode}_walk"]  # the strict walk verdict beside it
            balance = r[f"maxmargin_{mode}_verdict"]
            assert strict == balance if balance != "stable" else strict in WALK_VERDICTS
    flat = rows[0]
    assert flat["feasible"] == "True" and flat["minwork_found"] == "True"  # 1 s on flat ground
    assert rows[2]["feasible"] == "False"  # 0.5 s: the paper's family has no gait inside
    assert (out / "envelope.png").stat().st_size > 20_000


def test_found_gaits_keep_their_margin_re_planned_at_1_ms(tiny):
    """The GA's margin is the continuous walk's, so a 1 ms plan never has less."""
    rows = read_table(tiny[1] / "envelope.csv")
    checked = 0
    for r in rows:
        assert r["maxmargin_margin_mm"] >= r["minwork_margin_mm"]  # the most stable of both
        if r["feasible"] == "True":
            assert r["maxmargin_margin_1ms_mm"] >= 0
            assert r["maxmargin_margin_1ms_mm"] >= r["maxmargin_margin_mm"] - 1e-3
            checked += 1
        if r["minwork_found"] == "True":
            assert r["minwork_margin_1ms_mm"] >= r["required_margin_mm"]
            checked += 1
        else:
            assert r["minwork_margin_mm"] < r["required_margin_mm"]
            assert all(r[f"minwork_{m}_verdict"] == "" for m in ACTUATOR_MODES)  # not played
    assert checked >= 3


def test_a_second_run_resumes_to_the_same_bytes(tiny, capsys):
    config, out = tiny
    before = (out / "envelope.csv").read_bytes()
    assert main(["envelope", str(config), "--out", str(out), "--resume"]) == 0
    assert "4 cells, 4 already done, 0 to run" in capsys.readouterr().err
    assert (out / "envelope.csv").read_bytes() == before


@pytest.mark.slow  # a killed run resumed (the sweep's kill test runs by default); .ci/run
def test_a_killed_envelope_resumes_where_it_stopped(tiny, tmp_path, capsys):
    config, reference = tiny
    out = tmp_path / "out"
    args = ["envelope", str(config), "--out", str(out), "--workers", "2"]
    command = [*ENVELOPE_CMD, *args[1:]]
    with _started(command, tmp_path) as (proc, err):
        _wait_rows(out / "envelope.partial.csv", 1, proc, timeout=120)
        os.kill(proc.pid, signal.SIGKILL)  # the main process only: its workers must follow it
        assert proc.wait(timeout=30) == -signal.SIGKILL
        kept = _rows_in(out / "envelope.partial.csv")
        # resumed in this process (the killed run was a process of its own): no second
        # interpreter to start, the same command line
        code = main([*args, "--resume"])
        assert left_in_session(proc.pid) == [], "workers outlived their envelope"
    resumed = capsys.readouterr().err
    assert code == 0, resumed
    assert f"4 cells, {kept} already done, {4 - kept} to run" in resumed
    assert not (out / "envelope.partial.csv").exists()
    assert (out / "envelope.csv").read_bytes() == (reference / "envelope.csv").read_bytes()


@pytest.mark.slow  # three envelope runs; .ci/run runs it
def test_an_unfinished_run_is_resumed_or_refused(tiny, tmp_path, capsys):
    config, reference = tiny
    out = tmp_path / "out"
    out.mkdir()
    lines = (reference / "envelope.csv").read_bytes().splitlines(keepends=True)
    # three of the four cells done, as a killed run leaves them: each resume plays one cell
    (out / "envelope.partial.csv").write_bytes(b"".join(lines[:4]))
    assert main(["envelope", str(config), "--out", str(out), "--resume"]) == 0
    assert "4 cells, 3 already done, 1 to run" in capsys.readouterr().err
    assert (out / "envelope.csv").read_bytes() == (reference / "envelope.csv").read_bytes()
    (out / "envelope.partial.csv").write_bytes(b"".join(lines[:4]))
    assert main(["envelope", str(config), "--out", str(out)]) == 0  # --out: resumes it
    assert "4 cells, 3 already done, 1 to run" in capsys.readouterr().err
    (out / "envelope.partial.csv").write_bytes(b"".join(lines[:2]))
    cwd = os.getcwd()
    os.chdir(tmp_path)  # the default --out is ./results/envelope
    try:
        (tmp_path / "results").mkdir()
        os.replace(out, tmp_path / "results" / "envelope")
        assert main(["envelope", str(config)]) == 2  # a plain run does not resume
    finally:
        os.chdir(cwd)
    err = capsys.readouterr().err
    assert "holds an unfinished envelope (1 cells in envelope.partial.csv)" in err


def test_a_sweep_table_is_not_an_envelope_table(tiny, tmp_path, capsys):
    config, _ = tiny
    out = tmp_path / "out"
    out.mkdir()
    (out / "envelope.csv").write_text("trial_id,step_time\n")
    assert main(["envelope", str(config), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "not an envelope table (its first line is not the header)" in err
    assert err.count("\n") == 1 and (out / "envelope.csv").read_text() == "trial_id,step_time\n"


def test_a_cell_that_raises_is_an_error_row(tmp_path):
    """A cell whose walk cannot be planned (built past the file's checks) is a row, not a crash."""
    config = envelope_from_dict({"grid": {"step_time": [0.3], "slope": [0]}}, base_dir=tmp_path)
    cell = replace(config.cells[0], step_time=0.009)  # under 10 samples of 1 ms
    row = run_cell(cell)
    assert row["error"].startswith("step time 0.009 s: must lie in") and "\n" not in row["error"]
    assert all(row[f"maxmargin_{m}_verdict"] == "error" for m in ACTUATOR_MODES)
    assert all(row[f"maxmargin_{m}_walk"] == "error" for m in ACTUATOR_MODES)
    assert ENVELOPE.parse(ENVELOPE.header + ENVELOPE.format_row(row), tmp_path)[0]


@pytest.mark.slow  # a convergence run: the tiny envelope's cells searched again; .ci/run runs it
def test_convergence_reports_its_figures(tiny, capsys):
    config, out = tiny
    assert main(["envelope", str(config), "--out", str(out), "--convergence"]) == 0
    printed = capsys.readouterr().out
    assert "convergence: 1 cells re-searched with 4x the generations" in printed
    text = (out / "convergence.md").read_text()
    assert "feasibility verdicts that change: " in text and "16 instead of 4 generations" in text
    rows = read_table(out / "convergence.csv")
    assert len(rows) == 1 and rows[0]["generations"] == 16
    assert all(rows[0][f"maxmargin_{m}_verdict"] == "" for m in ACTUATOR_MODES)  # GA only


def test_convergence_counts_flips_and_the_largest_margin_change(tmp_path):
    grid = {"step_time": [2.0, 1.0, 0.5, 0.4, 0.3], "slope": [0, 10, 20, 30]}
    config = envelope_from_dict({"grid": grid}, base_dir=tmp_path)
    base, bigger = convergence_cells(config)
    assert len(base) == 2 and [c.search.generations for c in bigger] == [120, 120]
    assert [b.step_time for b in base] == [b.step_time for b in bigger]
    assert base == convergence_cells(config)[0]  # seeded: the same cells every time

    def table(name, cells, margins, feasible, found):
        lines = [
            ENVELOPE.format_row(
                c.inputs()
                | {
                    "maxmargin_margin_mm": m,
                    "feasible": f,
                    "minwork_found": w,
                    "minwork_work_J": 1.0,
                }
            )
            for c, m, f, w in zip(cells, margins, feasible, found, strict=True)
        ]
        path = tmp_path / name
        path.write_bytes(ENVELOPE.header + b"".join(lines))
        return path

    small = table("a.csv", base, [2.0, -30.0], [True, False], [False, False])
    large = table("b.csv", bigger, [2.4, -20.0], [True, False], [False, False])
    check = compare_budgets(small, large, base, bigger)
    assert (check.flips, check.found_flips) == (0, 0)
    assert check.max_change_mm == pytest.approx(0.4) and check.max_change_all_mm == 10.0
    flipped = table("c.csv", bigger, [2.4, 0.5], [True, True], [False, True])
    check = compare_budgets(small, flipped, base, bigger)
    assert (check.flips, check.found_flips) == (1, 1) and check.max_change_mm == 30.5


def test_a_gait_that_overreaches_at_1_ms_is_passed_over(tmp_path):
    """The GA's best may be reachable at its samples only; the next best that plans is taken."""
    from slopewalk.bench.experiments.envelope.cell import _choose, _Pool
    from slopewalk.planner.errors import UnreachableError
    from slopewalk.planner.plan import plan_walk

    config = envelope_from_dict({"grid": {"step_time": [1.0], "slope": [0]}}, base_dir=tmp_path)
    cell = config.cells[0]
    straight = [0.2491, 0.005, 0.0]  # the legs straight: out of reach during the walk
    nominal = [0.20, 0.0666, 0.2094]
    with pytest.raises(UnreachableError):
        plan_walk(cell.spec, cell.gait(straight))
    pool = _Pool(
        X=np.array([straight, nominal]),
        work=np.array([0.5, 0.8]),
        margin=np.array([0.009, 0.0005]),  # the nominal gait's 1 ms margin is 0.85 mm
        gap=np.array([-0.1, -0.1]),
        friction_gap=np.array([-0.5, -0.5]),
        slide_gap=np.array([-0.001, -0.001]),
    )
    columns = _choose(cell, "maxmargin", pool, pool.most_stable(), None, 0.005, None, False)
    assert columns["maxmargin_hip_height_m"] == 0.20 and columns["maxmargin_found"]
    assert columns["maxmargin_margin_mm"] == pytest.approx(0.5)
    assert "maxmargin_margin_1ms_mm" in columns and "error" not in columns


def test_rows_are_found_by_their_id_as_written(tmp_path):
    from slopewalk.bench.experiments.envelope.run import _by_id

    path = tmp_path / "e.csv"
    path.write_bytes(ENVELOPE.header + ENVELOPE.format_row({"cell_id": "123456789012"}))
    assert list(_by_id(path, ENVELOPE)) == ["123456789012"]  # not the number 123456789012.0


@pytest.mark.slow  # an envelope with a controller and recordings; .ci/run runs it
def test_a_controller_walks_every_played_gait_in_columns_and_recordings_of_its_own(tmp_path):
    """The plan as a controller (``slopewalk.bench.sim.env:open_loop``) walks as open loop does; the
    ankle controller walks the same gaits with its own CoP trace; each is recorded by name."""
    from slopewalk.bench.tables.envelope import envelope_format, sim_columns, walk_column

    plan_policy = "slopewalk.bench.sim.env:open_loop"
    ankle = "slopewalk.bench.controllers.ankle_cop:ankle_cop_feedback"
    config = tmp_path / "c.toml"
    config.write_text(
        'steps = 2\n[grid]\nstep_time = [1.0]\nslope = [0]\nactuators = ["stiff"]\n'
        f'controller = ["{plan_policy}", "{ankle}"]\n'
        "[search]\npopulation = 10\ngenerations = 4\n"
    )
    out = tmp_path / "out"
    assert main(["envelope", str(config), "--out", str(out), "--workers", "1", "--record"]) == 0
    data = (out / "envelope.csv").read_bytes()
    assert data.startswith(envelope_format((plan_policy, ankle)).header)
    (row,) = read_table(out / "envelope.csv")
    assert row["error"] == "" and row["minwork_found"] == "True"
    for gait in ("maxmargin", "minwork"):
        verdict, rms = sim_columns(gait, "stiff")
        same, same_rms = sim_columns(gait, "stiff", "open_loop")
        ankle_verdict, ankle_rms = sim_columns(gait, "stiff", "ankle_cop_feedback")
        assert row[verdict] == "stable" == row[same] == row[ankle_verdict]
        assert row[walk_column(gait, "stiff")] == row[walk_column(gait, "stiff", "open_loop")]
        assert row[walk_column(gait, "stiff", "ankle_cop_feedback")] in WALK_VERDICTS
        assert abs(row[same_rms] - row[rms]) < 1e-3  # [mm]: the same trial, stepped
        assert abs(row[ankle_rms] - row[rms]) > 1e-3  # the controller moved the CoP
        assert row[sim_columns(gait, "servo", "ankle_cop_feedback")[0]] == ""  # not asked
    cell = row["cell_id"]
    names = sorted(p.name for p in (out / "recordings").iterdir())
    assert names == [f"{cell}.rrd", f"{cell}_ankle_cop_feedback.rrd", f"{cell}_open_loop.rrd"]
