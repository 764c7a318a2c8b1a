import pytest

from planner.spec import load_spec


@pytest.fixture(scope="session")
def spec():
    """The paper's Bioloid-scale biped."""
    return load_spec()
