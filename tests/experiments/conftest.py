from pathlib import Path

import pytest

from planner.spec import default_spec_path


@pytest.fixture
def short_robot(tmp_path) -> Path:
    """``tmp_path/short.toml``: the paper's biped with 5 cm thigh and shank (the nominal hip
    height is out of reach)."""
    text = default_spec_path().read_text()
    text = text.replace("\nthigh = 0.111", "\nthigh = 0.05").replace(
        "\nshank = 0.111", "\nshank = 0.05"
    )
    path = tmp_path / "short.toml"
    path.write_text(text)
    return path
