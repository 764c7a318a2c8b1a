"""The sweep's report: claims table, confusion table and figures, written whole."""

import subprocess
import sys
from importlib import resources


def test_sweep_report_writes_claims_and_figures(tmp_path):
    smoke = resources.files("bench.experiments") / "sweeps" / "smoke.toml"
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "bench.cli",
            "sweep",
            str(smoke),
            "--workers",
            "1",
            "--report",
            "--out",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    for name in (
        "claims.md",
        "confusion.md",
        "stability_map.png",
        "zmp_traces.png",
        "joint_torques.png",
        "joint_angles.png",
        "lipm_vs_step_time.png",
    ):
        assert (tmp_path / name).stat().st_size > 0, name
    claims = (tmp_path / "claims.md").read_text().splitlines()
    rows = [line for line in claims if line.startswith("| ") and "---" not in line]
    assert len(rows) >= 7  # header + one row per claim
    assert all(line.count("|") == 7 for line in rows)  # no stray '|' inside a cell
    assert not list(tmp_path.glob("*.part"))


def test_a_zero_zmp_shift_is_written_as_zero_whatever_the_rounding_noise(spec):
    from bench.report.claims import mass_claims

    heavier = mass_claims([], spec)[0]  # 10x every mass: the ZMP moves by rounding noise only
    assert heavier["analytic"].startswith("max ZMP shift 0.0000 mm;")
