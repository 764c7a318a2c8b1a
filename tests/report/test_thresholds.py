"""The thresholds that decide verdicts, pinned to what MuJoCo measures (issue 22).

``TIP_ANGLE`` (planner/verdict.py) decides both the simulated ``tip`` (bench/sim/events.py)
and the predicted one. Its basis: a loaded foot of the simulated robot either rocks and
comes back (the soft floor's give, a rocking support that settles) or turns over; the
tip angle must separate the two. The committed development tables measure, for every
trial, the largest tilt of a loaded foot until the robot falls
(``simulated_max_tilt_deg``), a number the threshold does not decide. Over the trials
that do not fall, those tilts fall in two groups with a gap between them: the widest
gap on a log scale (tilts span 0.4° to 30°) lies between 4.5° and 7.4°. The tip
angle must lie in it; at half (2.5°) it would call the rocking of walks that finish
a tip, at double (10°) feet turning over would not be.
"""

import csv
import math
from pathlib import Path

import numpy as np

from slopewalk.planner.verdict import TIP_ANGLE

ROOT = Path(__file__).resolve().parents[2]
DEVELOPMENT = ("paper", "dense", "paper-noise", "dense-noise")  # results/fidelity/<name>/


def _unfallen_tilts() -> list[float]:
    """[deg] the largest loaded-foot tilt of every development trial that did not fall."""
    tilts = []
    for name in DEVELOPMENT:
        with open(ROOT / "results" / "fidelity" / name / "sweep.csv", newline="") as f:
            for row in csv.DictReader(f):
                events = row["events"].split(";")
                if row["simulated_verdict"] == "error" or {"fall", "diverged"} & set(events):
                    continue
                tilts.append(float(row["simulated_max_tilt_deg"]))
    return sorted(tilts)


def test_the_tip_angle_separates_a_rocking_foot_from_one_turning_over():
    tilts = _unfallen_tilts()
    assert len(tilts) > 100
    ratios = [(math.log(b / a), a, b) for a, b in zip(tilts, tilts[1:], strict=False) if a > 0]
    _, below, above = max(ratios)
    n_below = sum(t <= below for t in tilts)
    n_above = sum(t >= above for t in tilts)
    print(f"widest gap: {below:.2f}° .. {above:.2f}° ({n_below} trials below, {n_above} above)")
    assert n_below >= 10 and n_above >= 10  # two groups, not an outlier
    assert below < np.rad2deg(TIP_ANGLE) < above
