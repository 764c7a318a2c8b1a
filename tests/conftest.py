import ctypes.util
import os
import time
from pathlib import Path

import numpy as np
import pytest

from slopewalk.planner.spec import default_spec_path, load_spec

# MuJoCo picks its OpenGL backend once, when first imported: offscreen through Mesa's EGL
# for the video tests (tests/sim/test_video.py), as `slopewalk trial --video` does
if ctypes.util.find_library("EGL"):
    os.environ.setdefault("MUJOCO_GL", "egl")


@pytest.fixture(scope="session")
def spec():
    """The paper's Bioloid-scale biped."""
    return load_spec()


@pytest.fixture
def short_robot(tmp_path):
    """``tmp_path/short.toml``: the paper's biped with a 1 cm shank: no plan reaches its hips.

    The nominal hip-ankle distance, 0.757 (L1 + L2) = 0.092 m, is shorter than the
    leg folds (L1 − L2 = 0.101 m), so the hip target is out of reach.
    """
    text = default_spec_path().read_text().replace("\nshank = 0.111", "\nshank = 0.01")
    path = tmp_path / "short.toml"
    path.write_text(text)
    return path


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


def session_pids(sid: int) -> list[int]:
    """Pids of the live processes of session ``sid`` (a run started in its own session).

    Tests that kill a sweep check with it that no worker outlived its parent.
    """
    out = []
    for name in filter(str.isdigit, os.listdir("/proc")):
        try:
            stat = Path(f"/proc/{name}/stat").read_text()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2 :].split()  # state ppid pgrp session ...
        if int(fields[3]) == sid and fields[0] != "Z":
            out.append(int(name))
    return out


def left_in_session(sid: int, within: float = 5.0) -> list[int]:
    """The processes of session ``sid`` still alive after ``within`` seconds (none, we hope):
    what a killed run left behind once its children had time to follow it."""
    deadline = time.monotonic() + within
    while (left := session_pids(sid)) and time.monotonic() < deadline:
        time.sleep(0.05)
    return left
