import numpy as np
import pytest

from planner.spec import load_spec


@pytest.fixture(scope="session")
def spec():
    """The paper's Bioloid-scale biped."""
    return load_spec()


def away_from_phase_changes(plan, margin: int = 3) -> np.ndarray:
    """Mask of samples at least ``margin`` samples away from a DSP/SSP or stance change.

    Accelerations jump at those instants, so finite differences straddling one
    are not derivatives; tests that use differences as a reference skip them.
    """
    change = np.flatnonzero(
        np.diff(plan.double_support.astype(int)) | np.diff(plan.stance.astype(int))
    )
    keep = np.ones(plan.t.size, bool)
    keep[:margin] = keep[-margin:] = False
    for offset in range(-margin + 1, margin + 1):
        keep[np.clip(change + offset, 0, plan.t.size - 1)] = False
    return keep
