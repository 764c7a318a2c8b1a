"""The sweep table: whole-line appends, fixed-precision values, refusal of what is not ours."""

import random

import pytest

from slopewalk.bench.tables.sweep import (
    COLUMNS,
    DECIMALS,
    HEADER,
    SWEEP,
    format_row,
    text,
)
from slopewalk.bench.tables.table import AppendTable, TableError

ID = "0123456789ab"


def _row(**values) -> dict:
    return {
        "trial_id": ID,
        "analytic_verdict": "stable",
        "simulated_verdict": "tip",
        "walk": "tip",
    } | values


def test_table_appends_whole_rows_and_survives_a_torn_line(tmp_path):
    path = tmp_path / "sweep.partial.csv"
    with AppendTable.open(path, SWEEP) as table:
        assert table.rows == {} and table.created
        table.append(_row(friction=0.1 + 0.2, error='says "no", twice\nover lines'))
    with AppendTable.open(path, SWEEP) as table:
        assert not table.created and list(table.rows) == [ID]
        line = table.rows[ID]
    assert b"0.30000000000000004" in line  # an input keeps every digit
    assert b'"says ""no"", twice over lines"' in line
    with open(path, "ab") as f:  # a crash inside a write: the last line has no newline
        f.write(b"fedcba987654,0.5,0.0")
    with AppendTable.open(path, SWEEP) as table:
        assert list(table.rows) == [ID]
    assert path.read_bytes().endswith(line)


def test_a_second_writer_is_refused(tmp_path):
    path = tmp_path / "sweep.partial.csv"
    with AppendTable.open(path, SWEEP), pytest.raises(TableError, match="another sweep"):
        with AppendTable.open(path, SWEEP):
            pass


def test_outcomes_are_written_at_a_fixed_precision():
    assert text("zmp_rms_mm", 1.39e-13) == text("zmp_rms_mm", 1.4e-13) == "0.0000"
    assert text("analytic_min_margin_mm", -1e-9) == "0.0000"  # never "-0.0000"
    assert text("work_J", 0.123456789) == "0.1234568"
    assert text("zmp_max_mm", float("nan")) == "nan"
    assert text("step_time", 0.45) == "0.45"
    rng = random.Random(0)
    for column in DECIMALS:
        for _ in range(200):
            value = rng.uniform(-1e3, 1e3) * 10 ** rng.randint(-6, 0)
            written = text(column, value)
            assert text(column, float(written)) == written  # a re-read value prints the same
            assert abs(float(written) - value) <= 0.51 * 10 ** -DECIMALS[column]


CORRUPT = {
    "binary": (bytes(range(256)) * 16, "not UTF-8 text"),
    "binary without newline": (b"\x00\x01" * 2048, "no header line"),
    "not UTF-8": (
        HEADER + b"0123456789ab,\xff\xfe\n",
        f"not UTF-8 text: byte {len(HEADER) + 13}",  # the \xff after the header and the id
    ),
    "text without newline": (b"a" * 4096, "no header line"),
    "no header": (format_row(_row()), "its first line is not the header"),
    "other columns": (b"a,b\n1,2\n", "its first line is not the header"),
    "other version": (
        b"trial_id,b\n1,2\n",
        f"its header is not that of these {len(COLUMNS)} columns",
    ),
    "short row": (HEADER + b"0123456789ab,1.0\n", "line 2 has 2 fields, not"),
    "bad id": (HEADER + format_row(_row(trial_id="abc")), "trial_id 'abc' is not a trial id"),
    "banana": (
        HEADER + format_row(_row(simulated_verdict="banana")),
        "line 2: simulated_verdict 'banana' is not one of stable, slip, tip, fall, diverged",
    ),
}


@pytest.mark.parametrize("name", CORRUPT)
def test_what_is_not_a_sweep_table_is_refused_and_left_alone(tmp_path, name):
    data, message = CORRUPT[name]
    path = tmp_path / "sweep.partial.csv"
    path.write_bytes(data)
    with pytest.raises(TableError) as err, AppendTable.open(path, SWEEP):
        pass
    assert str(path) in str(err.value) and message in str(err.value)
    assert "\n" not in str(err.value)
    assert path.read_bytes() == data


def test_columns_hold_no_wall_time():
    assert "wall_s" not in COLUMNS  # it differs run to run: the table would never be stable


def test_the_column_spec_is_the_one_list_of_columns_and_decimals():
    from slopewalk.bench.tables.sweep import OUTCOMES, SPEC

    assert COLUMNS == tuple(c.name for c in SPEC) and len(set(COLUMNS)) == len(COLUMNS)
    assert DECIMALS == {c.name: c.decimals for c in SPEC if c.decimals is not None}
    assert set(DECIMALS) <= {c.name for c in OUTCOMES}  # inputs keep every digit
    assert OUTCOMES[0].name == "analytic_verdict" and OUTCOMES[-1].name == "error"


def test_a_committed_sweep_row_is_regenerated_byte_for_byte_from_its_trial():
    """One trial of results/sweep.csv with events and predicted events (so every kind of
    column source is exercised: attributes, unit scales, functions of result and plan),
    replayed and written through the column spec: the committed line, every byte."""
    from pathlib import Path

    from slopewalk.bench.experiments.sweep.config import load_sweep
    from slopewalk.bench.experiments.sweep.run import run_one

    root = Path(__file__).resolve().parents[2]
    rows = SWEEP.read_rows(root / "results" / "sweep.csv")
    trial_id = "bad9576af640"  # 0.4 s steps, μ 0.6: slip;tip simulated, tip;slip predicted
    (trial,) = [t for t in load_sweep(root / "bench/experiments/sweeps/paper.toml").trials
                if t.trial_id == trial_id]  # fmt: skip
    assert format_row(run_one(trial)) == rows[trial_id]


def test_a_model_sweep_of_an_older_version_may_be_replaced_not_resumed(tmp_path):
    """A finished sweep on a model in an older layout (before the strict walk columns) is an
    older version's table, which a fresh run replaces; the twin's table stays refused."""
    from slopewalk.bench.tables.sweep import _BEFORE_WALK, SWEEP
    from slopewalk.bench.tables.table import MODEL_COLUMNS, TableError, model_format

    fmt = model_format(SWEEP)
    old = (",".join((*_BEFORE_WALK, *MODEL_COLUMNS)) + "\n").encode()
    rows, _ = fmt.parse(old, tmp_path / "sweep.csv", previous_ok=True)
    assert rows == {}
    with pytest.raises(TableError, match="older slopewalk"):
        fmt.parse(old, tmp_path / "sweep.csv")
    with pytest.raises(TableError, match="played on the spec's twin"):
        fmt.parse(SWEEP.header, tmp_path / "sweep.csv", previous_ok=True)
