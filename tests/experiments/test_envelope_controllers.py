"""Open loop vs controllers over an envelope's gaits: the table's gaits replayed, counted."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from slopewalk.bench.experiments.envelope.cell import run_cell
from slopewalk.bench.experiments.envelope.config import envelope_from_dict
from slopewalk.bench.experiments.envelope.controllers import (
    EnvelopeTableError,
    compare_envelope,
    envelope_report,
    table_jobs,
)
from slopewalk.bench.tables.envelope import ENVELOPE

PLAN_POLICY = "slopewalk.bench.sim.env:open_loop"
ANKLE = "slopewalk.bench.controllers.ankle_cop:ankle_cop_feedback"


@pytest.fixture(scope="module")
def table(tmp_path_factory) -> Path:
    """A two-cell envelope table (1 s and 0.5 s on flat ground, stiff only), from real cells,
    with a third row for a cell that failed."""
    config = envelope_from_dict(
        {
            "steps": 2,
            "grid": {"step_time": [1.0, 0.5], "slope": [0], "actuators": ["stiff"]},
            "search": {"population": 10, "generations": 4},
        },
        base_dir=Path("."),
    )
    rows = [run_cell(cell) for cell in config.cells]
    failed = replace(config.cells[0], slope_deg=5.0)
    rows.append(failed.inputs() | {"error": "planted failure", "maxmargin_margin_1ms_mm": 1.0})
    path = tmp_path_factory.mktemp("envelope") / "envelope.csv"
    path.write_bytes(ENVELOPE.header + b"".join(ENVELOPE.format_row(r) for r in rows))
    return path


def test_the_table_gives_its_played_gaits_and_leaves_out_failed_cells(table):
    jobs = table_jobs(table)
    labels = [(j.label, j.gait) for j in jobs]
    assert ("T=1 s slope=0 mu=1", "maxmargin") in labels
    assert ("T=1 s slope=0 mu=1", "minwork") in labels  # 1 s on flat ground: found
    assert ("T=0.5 s slope=0 mu=1", "minwork") not in labels  # nothing inside: not played
    assert not any("slope=5" in label for label, _ in labels)  # the failed cell
    assert {j.modes for j in jobs} == {("stiff",)}  # the modes the table played
    assert all(j.table_verdicts["stiff"] for j in jobs)
    assert all(abs(j.x[2]) < np.deg2rad(45) for j in jobs)  # tilt back in radians
    assert [j.step_time for j in table_jobs(table, min_step_time=0.75)] == [1.0, 1.0]


def test_the_plan_as_a_controller_walks_the_cells_open_loop_walks(table):
    """Replayed from the table's rounded parameters, each open-loop walk has the table's
    verdict; the plan as a policy has open loop's; the ankle controller is counted."""
    jobs = table_jobs(table)
    verdicts = compare_envelope(jobs, (PLAN_POLICY, ANKLE), workers=1)
    for job, v in zip(jobs, verdicts, strict=True):
        assert v["stiff", None] == job.table_verdicts["stiff"]
        assert v["stiff", PLAN_POLICY] == v["stiff", None]
    text = envelope_report(jobs, verdicts, (PLAN_POLICY, ANKLE), source="e.csv")
    walks = sum(v["stiff", None] == "stable" for j, v in zip(jobs, verdicts, strict=True))
    assert walks >= 1
    row = next(line for line in text.splitlines() if line.startswith("| max-margin | stiff |"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    played = sum(j.gait == "maxmargin" for j in jobs)
    assert cells[2:5] == [str(played), cells[3], f"{cells[3]} (+0 −0)"]
    assert f"have the table's balance verdict in {len(jobs)} of {len(jobs)}" in text
    tally = (
        "- open_loop walks strictly more cells than open loop in 0 of these 2 rows, as many in 2"
    )
    assert tally + ", fewer in 0." in text


def test_a_table_without_the_envelope_columns_is_refused(tmp_path):
    path = tmp_path / "sweep.csv"
    path.write_text("trial_id,step_time\n")
    with pytest.raises(EnvelopeTableError, match="not an envelope table .no column cell_id"):
        table_jobs(path)


def test_the_command_appends_the_envelope_section_and_names_itself(table, tmp_path, capsys):
    from slopewalk.bench.cli import main

    sweep = tmp_path / "s.toml"
    sweep.write_text("steps = 1\n[[trial]]\nstep_time = 1.0\n")
    out = tmp_path / "c.md"
    argv = ["controllers", str(sweep), "--controller", PLAN_POLICY, "--envelope", str(table)]
    assert main([*argv, "--min-step-time", "0.75", "--out", str(out)]) == 0
    text = out.read_text()
    command = " ".join(["slopewalk", *argv, "--min-step-time 0.75", f"--out {out}"])
    assert f"Regenerate with `{command}`" in text
    assert f"The gaits of `{table}` (1 cells of step time >= 0.75 s)" in text
    assert text.index("# Open loop vs closed-loop controllers") < text.index("## Stability")


def test_an_extended_row_is_replayed_as_its_own_family(tmp_path):
    """An extended-family row carries its pelvis offset, step length and sway share into the
    replay: the replayed walk is the cell's own (``EnvelopeCell.gait``) to the table's digits,
    and the report names the family (a row replayed as the paper's gait would not be)."""
    config = envelope_from_dict(
        {
            "steps": 2,
            "grid": {"step_time": [1.0], "slope": [0], "actuators": ["stiff"]},
            "search": {"population": 10, "generations": 4, "family": ["extended"]},
        },
        base_dir=Path("."),
    )
    (cell,) = config.cells
    row = run_cell(cell)
    path = tmp_path / "envelope.csv"
    path.write_bytes(ENVELOPE.header + ENVELOPE.format_row(row))
    jobs = table_jobs(path)
    assert jobs and all(j.family == "extended" and len(j.x) == 6 for j in jobs)
    for job in jobs:
        replayed, own = job.params(), cell.gait(job.x)
        for name in ("pelvis_offset", "step_length", "lean_share", "hip_height", "tilt"):
            assert getattr(replayed, name) == pytest.approx(getattr(own, name), abs=1e-6)
        assert replayed.step_length == pytest.approx(row[f"{job.gait}_step_length_m"], abs=1e-6)
        assert replayed.pelvis_offset == pytest.approx(row[f"{job.gait}_pelvis_offset_m"], abs=1e-6)
    verdicts = compare_envelope(jobs, (), workers=1)
    for job, v in zip(jobs, verdicts, strict=True):
        assert v["stiff", None] == job.table_verdicts["stiff"]
    text = envelope_report(jobs, verdicts, (), source="e.csv")
    assert "| max-margin (extended) | stiff |" in text
    assert "T=1 s slope=0 mu=1 extended" == jobs[0].label
