"""The report of a user's own sweep describes exactly the table it was given.

A two-robot sweep (the paper's biped and one 1.5 times larger in every length), two step
times and two slopes, one step each, run through the CLI with ``--report``: one section
per robot with that robot's nominal gait, a claim only where its rows hold the cases it
needs (else ``not in this sweep``), the walks of the figures only for cases that ran, and
nothing read from outside the output folder (no GA results or envelope there: said so).
"""

import json
import re
import struct
import subprocess
import sys

import pytest

from slopewalk.planner.spec import default_spec_path

# a two-robot sweep with its report (the claims' replays of both robots, their figures):
# 10-20 s with the VM's speed, a sweep of its own; .ci/run runs it on its own
pytestmark = pytest.mark.slow

SWEEP = (
    'steps = 1\n[grid]\nrobot = ["big.toml", "default"]\nstep_time = [1.0, 0.5]\nslope = [0, 10]\n'
)


def _scaled_spec_text(factor: float) -> str:
    """The paper's spec file with every length (geometry and link CoMs) times ``factor``."""
    out, section = [], None
    for line in default_spec_path().read_text().splitlines():
        if line.startswith("["):
            section = line
        if section == "[geometry]" and (m := re.match(r"^(\w+) = ([\d.]+)(.*)$", line)):
            line = f"{m[1]} = {float(m[2]) * factor!r}{m[3]}"
        if m := re.match(r"^com = \[([^\]]*)\](.*)$", line):
            com = ", ".join(repr(float(v) * factor) for v in m[1].split(","))
            line = f"com = [{com}]{m[2]}"
        out.append(line.replace('name = "bioloid-8dof"', 'name = "bioloid-x1.5"'))
    return "\n".join(out) + "\n"


@pytest.fixture(scope="module")
def own(tmp_path_factory):
    """(output folder, claims.md text, {robot: {claim: cells}}, the sweep file's path)."""
    where = tmp_path_factory.mktemp("own")
    (where / "big.toml").write_text(_scaled_spec_text(1.5))
    (where / "big_sweep.toml").write_text(SWEEP)
    out = where / "runs_big"
    result = subprocess.run(
        [sys.executable, "-m", "slopewalk", "sweep", str(where / "big_sweep.toml"), "--out",
         str(out), "--report", "--workers", "1"],
        capture_output=True, text=True, timeout=300, cwd=where,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    text = (out / "claims.md").read_text()
    sections = {}
    for part in text.split("\n## Robot `")[1:]:
        name = part.split("`")[0]
        lines = [ln for ln in part.splitlines() if ln.startswith("| ") and "---" not in ln]
        cells = [[c.strip() for c in ln.strip("|").split("|")] for ln in lines[1:]]
        sections[name] = {c[0]: c[1:] for c in cells}
    return out, text, sections, where / "big_sweep.toml"


def _claim(claims: dict, start: str) -> list[str]:
    (key,) = [k for k in claims if k.startswith(start)]
    return claims[key]


def test_the_header_names_the_sweep_file_and_each_robot_has_its_section(own):
    _, text, sections, sweep = own
    assert f"from the sweep file `{sweep}`" in text
    assert "the default sweep" not in text
    assert list(sections) == ["big.toml", "default"]
    big = text.split("## Robot `big.toml`")[1].split("## Robot `default`")[0]
    default = text.split("## Robot `default`")[1]
    assert "Hz = 0.30 m" in big and "Hz = 0.20 m" not in big  # 1.5 x 0.20 m: its own gait
    assert "Hz = 0.20 m" in default
    claims = json.loads((own[0] / "claims.json").read_text())
    assert {c["robot"] for c in claims} == {"big.toml", "default"}


def test_claims_without_their_cases_say_not_in_this_sweep(own):
    """No 0.4 s, no 15°-30°, no mass scaling: those claims quote no number at all."""
    _, text, sections, _ = own
    for name, claims in sections.items():
        for start in ("flat ground:", "slopes:", "10×", "doubling", "friction:"):
            cells = _claim(claims, start)
            assert cells[1].startswith("not in this sweep: needs"), (name, start)
            assert cells[4] == "not in this sweep", (name, start)
        # LIPM and torques: both step times on flat ground at μ = 1 ran, so they are claimed
        assert _claim(claims, "LIPM")[1].startswith("RMS distance ZMP to LIPM [mm]: 0.5 s: ")
        assert "over the paper's 2–0.5 s: 0.5 s: " in _claim(claims, "LIPM")[1]  # its fastest
        assert _claim(claims, "stance joints")[1].startswith("peak ")
    assert "mean SSP ZMP x" not in text  # the slope claim's numbers at 15°, 18°, 22.5°
    assert "0.4 s:" not in text and "nan" not in text
    assert not re.search(r"(?<![\d.])(15|18|22\.5)°: ", text)  # no value at an absent slope


def test_absent_ga_results_and_envelope_are_said_not_sought_elsewhere(own):
    _, text, sections, _ = own
    assert "No envelope table at `envelope/envelope.csv` beside this report" in text
    ga = _claim(sections["default"], "GA cases")
    assert ga[1].startswith("not checked: no `slopewalk optimize` reports in `optimize/`")
    assert "GA cases" not in "".join(sections["big.toml"])  # the GA's robot is the paper's


def _png_size(path) -> tuple[int, int]:
    return struct.unpack(">II", path.read_bytes()[16:24])


def test_figures_show_only_walks_the_sweep_ran_one_file_per_robot(own):
    out = own[0]
    names = sorted(p.name for p in out.glob("*.png"))
    assert names == sorted(
        ["stability_map.png", "lipm_vs_step_time.png"]
        + [f"{kind}_{robot}.png" for kind in ("zmp_traces", "joint_torques", "joint_angles")
           for robot in ("big", "default")]
    )  # fmt: skip
    # one ZMP-trace panel per robot: of the paper's three cases only flat, 0.5 s, μ = 1 ran
    for robot in ("big", "default"):
        assert _png_size(out / f"zmp_traces_{robot}.png") == (round(4.5 * 110), round(4.8 * 110))
    text = own[1]
    assert "| joint_torques_big.png |" in text and "| joint_torques_default.png |" in text
