from pathlib import Path

import pytest

from planner.spec import default_spec_path


@pytest.fixture
def short_robot(tmp_path) -> Path:
    """``tmp_path/short.toml``: the paper's biped with a 1 cm shank: no plan reaches its hips.

    The nominal hip-ankle distance, 0.757 (L1 + L2) = 0.092 m, is shorter than the
    leg folds (L1 − L2 = 0.101 m), so the hip target is out of reach.
    """
    text = default_spec_path().read_text().replace("\nshank = 0.111", "\nshank = 0.01")
    path = tmp_path / "short.toml"
    path.write_text(text)
    return path
