"""The user docs of the file formats name every key the code reads, with the code's defaults."""

import re
import tomllib
from pathlib import Path

import pytest

from slopewalk.bench.experiments.sweep.config import (
    DEFAULTS,
    MASS_GROUPS,
    TOP_KEYS,
    TRIAL_KEYS,
    sweep_from_dict,
)
from slopewalk.planner.spec import default_spec_path

ROOT = Path(__file__).resolve().parents[1]
ROBOT_DOC = ROOT / "docs" / "robot-spec.md"
SWEEP_DOC = ROOT / "docs" / "sweep-format.md"


def _rows(doc: Path) -> dict[str, list[str]]:
    """Markdown table rows by the backticked key(s) of their first cell: the other cells."""
    rows = {}
    for line in doc.read_text().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("|") and re.fullmatch(r"`[^`]+`(, `[^`]+`)*", cells[0]):
            for key in re.findall(r"`([^`]+)`", cells[0]):
                rows.setdefault(key, cells[1:])
    return rows


def _toml_value(text: str):
    """A cell like ``[−1.60, 1.60]``, ``0.111`` or ```"stiff"``` read as TOML."""
    text = text.strip("`").replace("−", "-")
    return tomllib.loads(f"v = {text}")["v"]


def test_robot_doc_has_every_key_of_the_spec_with_its_value():
    with open(default_spec_path(), "rb") as f:
        spec = tomllib.load(f)
    text, rows = ROBOT_DOC.read_text(), _rows(ROBOT_DOC)
    assert "`name`" in text
    for table in ("geometry", "joint_limits", "servo"):
        assert f"`[{table}]`" in text, table
        for key, value in spec[table].items():
            assert key in rows, f"{table}.{key} is not documented"
            assert _toml_value(rows[key][1]) == value, f"{table}.{key}: doc {rows[key][1]}"
    for link, keys in spec["links"].items():
        assert f"`[links.{link}]`" in text, link
        for key in keys:
            assert key in rows, f"links.{link}.{key} is not documented"


def test_sweep_doc_has_every_key_with_the_codes_default(tmp_path):
    rows = _rows(SWEEP_DOC)
    for key in (*TOP_KEYS, *TRIAL_KEYS, *MASS_GROUPS):
        assert key in rows, f"{key} is not documented"
    for key in TRIAL_KEYS:
        assert _toml_value(rows[key][1]) == DEFAULTS[key], key
    config = sweep_from_dict({"trial": [{}]}, base_dir=tmp_path)
    for key in ("steps", "description"):
        assert _toml_value(rows[key][1]) == getattr(config, key), key
    assert (_toml_value(rows["seed"][1]),) == config.seeds
    assert _toml_value(rows["command_noise"][1]) == config.command_noise_deg


def test_sweep_doc_example_is_a_valid_sweep(tmp_path):
    """The example parses, robot path included, into the trials its comments promise."""
    example, replicas, ends, draw, envelope = re.findall(
        r"```toml\n(.*?)```", SWEEP_DOC.read_text(), re.S
    )
    (robot,) = re.findall(r'robot = "([^"]+)"', example)
    (tmp_path / robot).parent.mkdir(parents=True)
    long_legs = default_spec_path().read_text().replace("\nthigh = 0.111", "\nthigh = 0.15")
    (tmp_path / robot).write_text(long_legs)  # a copy of the paper's would be a duplicate
    config = sweep_from_dict(tomllib.loads(example), base_dir=tmp_path)
    assert len(config.trials) == 12 + 2 + 2
    noisy = sweep_from_dict(tomllib.loads(replicas) | {"trial": [{}]}, base_dir=tmp_path)
    assert len(noisy.trials) == 8 and noisy.noisy  # the replicas snippet: 8 seeds
    moved = sweep_from_dict(tomllib.loads(ends) | {"trial": [{}]}, base_dir=tmp_path)
    assert [t.spec_end for t in moved.trials] == list(tomllib.loads(ends)["spec_ends"])
    drawn = sweep_from_dict(tomllib.loads(draw) | {"grid": {"step_time": [1.0]}}, base_dir=tmp_path)
    assert len(drawn.trials) == 2 and drawn.other_gaits  # a gait of each family
    assert tomllib.loads(envelope)["grid"] == {
        "actuators": ["stiff", "servo", "stiff_ff", "servo_ff"]
    }


@pytest.mark.parametrize("doc", [ROBOT_DOC, SWEEP_DOC])
def test_readme_links_the_docs(doc):
    assert f"]({doc.relative_to(ROOT)})" in (ROOT / "README.md").read_text()


ENVELOPE_DOC = ROOT / "docs" / "envelope-format.md"


def test_envelope_doc_has_every_key_with_the_codes_default(tmp_path):
    from slopewalk.bench.experiments.envelope.config import (
        GRID_KEYS,
        SEARCH_DEFAULTS,
        SEARCH_KEYS,
        TOP_KEYS,
        envelope_from_dict,
    )
    from slopewalk.bench.sim.model import ACTUATOR_MODES

    rows = _rows(ENVELOPE_DOC)
    for key in (*TOP_KEYS[:4], *GRID_KEYS, *SEARCH_KEYS):
        assert key in rows, f"{key} is not documented"
    for key in SEARCH_KEYS:
        assert _toml_value(rows[key][-1]) == SEARCH_DEFAULTS[key], key
    config = envelope_from_dict({"grid": {"step_time": [1.0], "slope": [0]}}, base_dir=tmp_path)
    assert config.modes == ACTUATOR_MODES and rows["actuators"][-1] == "every mode the bench has"
    assert config.controllers == () and _toml_value(rows["controller"][-1]) == []
    (example,) = re.findall(r"```toml\n(.*?)```", ENVELOPE_DOC.read_text(), re.S)
    assert len(envelope_from_dict(tomllib.loads(example), base_dir=tmp_path).cells) == 15


def test_envelope_doc_names_every_family_and_its_columns():
    from slopewalk.bench.experiments.envelope.cell import FAMILIES
    from slopewalk.bench.tables.envelope import EXTENDED_COLUMNS

    rows, text = _rows(ENVELOPE_DOC), ENVELOPE_DOC.read_text()
    for family in FAMILIES:
        assert f'`"{family}"`' in rows["family"][-2], family
        assert f"- `{family}`:" in text, family
    for column in EXTENDED_COLUMNS:
        assert f"`{column}`" in text, column


def test_readme_links_the_envelope_doc():
    assert f"]({ENVELOPE_DOC.relative_to(ROOT)})" in (ROOT / "README.md").read_text()


def test_readme_flag_table_lists_the_registrys_actuator_modes():
    from slopewalk.bench.actuators import ACTUATOR_MODES, DEFAULT_MODE

    (row,) = [r for r in (ROOT / "README.md").read_text().splitlines() if r.startswith("| `--act")]
    values, default = [cell.strip() for cell in row.split("|")[-3:-1]]
    assert values == ", ".join(f"`{m}`" for m in ACTUATOR_MODES) and default == f"`{DEFAULT_MODE}`"
