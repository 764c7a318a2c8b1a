"""The sweep's report: claims table, confusion table and figures, written whole and right.

Each claim's numbers are recomputed here from the primitives, outside
``bench/report/claims.py``: MuJoCo's ``mj_inverse`` for the ZMP on slopes, the planner
and a trial for margins and torques, the sweep table for the simulated cells. The
claims that need the paper's cases are checked on the committed paper sweep's table
(``results/sweep.csv``); the smoke sweep's report holds only what its four trials hold.
"""

import csv
import re
import subprocess
import sys
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
from mj_reference import StanceRootedInverse

from slopewalk.bench.report.claims import lipm_claim, mass_claims, slope_claim, torque_claim
from slopewalk.bench.sim.trial import run_trial
from slopewalk.bench.sim.trial_spec import TrialSpec
from slopewalk.bench.tables.table import read_table
from slopewalk.planner.gait import GaitParams
from slopewalk.planner.kinematics import gravity_in_slope
from slopewalk.planner.plan import plan_walk
from slopewalk.planner.zmp import cop_of_wrench, signed_margin


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    """The smoke sweep with --report: (output dir, {claim: cells}, sweep rows)."""
    out = tmp_path_factory.mktemp("report")
    smoke = resources.files("slopewalk.bench.experiments") / "sweeps" / "smoke.toml"
    result = subprocess.run(
        [sys.executable, "-m", "slopewalk", "sweep", str(smoke), "--workers", "1", "--report",
         "--out", str(out)],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    lines = (out / "claims.md").read_text().splitlines()
    rows = [line for line in lines if line.startswith("| ") and "---" not in line]
    cells = [[c.strip() for c in line.strip("|").split("|")] for line in rows[1:]]
    with open(out / "sweep.csv", newline="") as f:
        table = list(csv.DictReader(f))
    return out, {c[0]: c[1:] for c in cells}, rows, table


@pytest.fixture(scope="module")
def paper_rows():
    """The committed paper sweep's rows: every case the paper's claims need."""
    return read_table(Path(__file__).parents[2] / "results" / "sweep.csv")


def _numbers(text: str) -> list[float]:
    return [float(x) for x in re.findall(r"[-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?", text)]


def _claim(claims, start: str) -> list[str]:
    (key,) = [k for k in claims if k.startswith(start)]
    return claims[key]


def test_sweep_report_writes_claims_and_figures(report):
    """The smoke sweep holds none of the walks the ZMP-trace and joint figures show (all
    at μ = 1, stiff, no mass scaling) nor two flat step times at μ = 1: no such figure."""
    out, claims, rows, _ = report
    for name in ("claims.md", "confusion.md", "stability_map.png"):
        assert (out / name).stat().st_size > 0, name
    assert sorted(p.name for p in out.glob("*.png")) == ["stability_map.png"]
    assert len(rows) >= 7  # header + one row per claim
    assert all(line.count("|") == 9 for line in rows)  # no stray '|' inside a cell
    assert not list(out.glob("*.part"))
    absent = [c for c, cells in claims.items() if cells[4] == "not in this sweep"]
    assert len(absent) == 6, absent  # step time, slopes, friction, 10x mass, LIPM, torques
    assert _claim(claims, "doubling")[4] != "not in this sweep"  # its {legs = 2} trial is there


def test_slope_claim_zmp_positions_are_mujocos(spec, paper_rows):
    """Mean SSP ZMP x from the stance ankle, per slope: the CoP of mj_inverse's ground wrench."""
    analytic = slope_claim(paper_rows, spec)["analytic"]
    stated = dict(re.findall(r"([\d.]+)°: ([-+]\d+\.\d)", analytic))
    assert set(stated) == {"0", "15", "18", "22.5"}
    for slope_deg, value in stated.items():
        slope = np.deg2rad(float(slope_deg))
        plan = plan_walk(spec, GaitParams.nominal(spec, 1.0, slope=slope))
        mj = StanceRootedInverse(spec, gravity_in_slope(slope))
        ssp = np.flatnonzero(~plan.double_support)
        x = []
        for k in ssp:
            ref = mj(plan.q[k], plan.qd[k], plan.qdd[k], plan.stance[k], plan.stance_sole[k])
            cop = cop_of_wrench(ref.force[None], ref.moment[None], plan.stance_sole[k][None])
            x.append(cop[0, 0] - plan.stance_sole[k, 0])
        assert float(value) == pytest.approx(np.mean(x) * 1e3, abs=0.051), slope_deg


def test_mass_claims(spec, report, paper_rows):
    _, smoke, _, table = report
    claims = {
        c["claim"]: [c["paper"], c["analytic"], c["simulated"]]
        for c in mass_claims(paper_rows, spec)
    }
    nominal = plan_walk(spec, GaitParams.nominal(spec, 1.0))
    # 10x every mass and inertia: the ZMP is invariant (every term of eq. 4 scales alike)
    shift, margin, base = _numbers(_claim(claims, "10×")[1])[-3:]
    assert shift < 1e-6
    assert base == pytest.approx(nominal.margin.min() * 1e3, abs=0.051)
    assert margin == pytest.approx(base, abs=1e-9)
    # doubled legs: recomputed from the scaled spec
    cells = _claim(claims, "doubling")
    heavy = plan_walk(spec.with_mass_scale({"legs": 2.0}), nominal.params)
    shift, margin, base = _numbers(cells[1])[-3:]
    assert shift == pytest.approx(np.hypot(*(heavy.zmp - nominal.zmp).T).max() * 1e3, abs=0.051)
    assert margin == pytest.approx(heavy.margin.min() * 1e3, abs=0.051)
    assert margin < 0 < base
    (row,) = [r for r in paper_rows if r["mass_scale"] == "legs=2"]
    assert cells[2].startswith(f"{row['simulated_verdict']} (μ 1, RMS ")
    assert _numbers(cells[2])[1] == pytest.approx(float(row["zmp_rms_mm"]), abs=0.051)
    # the smoke sweep's report: the same claim from its own {legs = 2} row
    (row,) = [r for r in table if r["mass_scale"] == "legs=2"]
    assert _claim(smoke, "doubling")[2].startswith(f"{row['simulated_verdict']} (μ 1, RMS ")


def test_lipm_claim_is_judged_over_the_papers_range(spec, paper_rows):
    """Over 2–0.5 s each step time's multibody and LIPM margins are the plans' (recomputed
    here); at 0.75 s the multibody ZMP leaves the polygon while the LIPM's stays inside,
    which is the paper's statement; 0.4 s lies outside the range and is not judged."""
    claim = lipm_claim(paper_rows, spec)
    text = claim["analytic"].split("over the paper's 2–0.5 s: ")[1]
    multibody, lipm = _numbers(text.split("0.75 s: ")[1])[:2]
    plan = plan_walk(spec, GaitParams.nominal(spec, 0.75))
    assert multibody == pytest.approx(plan.margin.min() * 1e3, abs=0.051)
    assert lipm == pytest.approx(signed_margin(plan.zmp_lipm, plan.polygon).min() * 1e3, abs=0.051)
    assert multibody < 0 < lipm
    assert "multibody outside while the LIPM is inside at 0.75 s" in claim["analytic"]
    assert claim["agree"].startswith("analytic yes (judged over the paper's 2–0.5 s)")
    assert "0.4 s:" not in text.split(";")[0]


def test_torque_claim_stance_and_swing(spec):
    """Peaks and RMS of stance vs swing joints, planned and simulated (MJCF order remapped)."""
    plan = plan_walk(spec, GaitParams.nominal(spec, 1.0))
    result = run_trial(spec, TrialSpec(plan.params), plan=plan)
    claim = torque_claim(plan, result)
    cells = [claim["paper"], claim["analytic"], claim["simulated"]]

    def figures(stance, swing):
        rms = [float(np.sqrt(np.mean(x**2, axis=0)).mean()) for x in (stance, swing)]
        return [stance.max(axis=0).mean(), swing.max(axis=0).mean(), *rms]

    tau = np.abs(plan.tau)
    np.testing.assert_allclose(
        _numbers(cells[1])[:4], figures(tau[:, :4], tau[:, 4:]), rtol=0, atol=6e-4
    )
    sim = np.abs(result.series["actuator_force"])  # left hip..roll, right hip..roll
    idx = np.clip(np.searchsorted(plan.t, result.series["t"]), 0, plan.t.size - 1)
    right = plan.stance[idx] == 1
    stance = np.where(right[:, None], sim[:, 4:], sim[:, :4])
    swing = np.where(right[:, None], sim[:, :4], sim[:, 4:])
    np.testing.assert_allclose(_numbers(cells[2])[:4], figures(stance, swing), rtol=0, atol=6e-4)


def test_a_zero_zmp_shift_is_written_as_zero_whatever_the_rounding_noise(spec):
    from slopewalk.bench.report.claims import mass_claims

    row = {"step_time": 1.0, "slope_deg": 0.0, "friction": 1.0, "actuators": "stiff",
           "mass_scale": "all=10", "simulated_verdict": "stable", "zmp_rms_mm": 1.0}  # fmt: skip
    heavier = mass_claims([row], spec)[0]  # 10x every mass: the ZMP moves by rounding noise only
    assert heavier["analytic"].startswith("max ZMP shift 0.0000 mm;")
