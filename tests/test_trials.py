"""The committed single trials (results/trials/) are what their commands write now.

Two checks, because a trial costs seconds to minutes:

- the cheap one, 4 steps of 2 s on flat ground, is run again here into a temporary
  folder and compared with the committed files (the summary byte for byte; the JSON but
  for ``wall_s``, the time the run took);
- every committed trial's manifest entry records ``code_sha256``, the digest of the source
  its command runs (``regenerate.TRIAL_CODE``: the planner, the robot spec, the
  simulation, the command) when it was last written; a change of that source fails here
  until the trials are regenerated. The digest is of content, not of a commit: it needs
  no git history, survives a rebase or a squash, and is false only the other way (an
  edit that leaves the numbers alone, e.g. a docstring, also asks for a regeneration,
  which takes about a minute and changes nothing then but the manifest).
"""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from slopewalk.bench import digest, provenance, regenerate

ROOT = Path(__file__).resolve().parents[1]
CHEAP = "results/trials/T2_slope0_mu1.0"
REGENERATE = "slopewalk regenerate --only 'results/trials/*'"


def _trial_steps():
    return [s for s in regenerate.STEPS if any(o.startswith("results/trials/") for o in s.outputs)]


def _scalars(text: str) -> dict:
    data = json.loads(text)
    data.pop("wall_s")  # how long the run took: the one number that is not a result
    return data


def test_the_cheap_trial_is_what_its_command_writes_now(tmp_path):
    (step,) = [s for s in _trial_steps() if f"{CHEAP}.json" in s.outputs]
    (tmp_path / "results" / "trials").mkdir(parents=True)
    done = subprocess.run(
        [sys.executable, "-m", "slopewalk.bench.cli", *step.args],
        cwd=tmp_path,
        capture_output=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr.decode()
    stale = f"{CHEAP}: stale, rewrite it with {REGENERATE}"
    assert done.stdout == (ROOT / f"{CHEAP}.txt").read_bytes(), stale
    written = (tmp_path / f"{CHEAP}.json").read_text()
    assert _scalars(written) == _scalars((ROOT / f"{CHEAP}.json").read_text()), stale


def test_every_committed_trial_was_written_by_the_source_there_now():
    manifest = provenance.load(ROOT)
    steps = _trial_steps()
    assert len(steps) == 7 and all(s.code == regenerate.TRIAL_CODE for s in steps)
    now = digest.code_digest(regenerate.TRIAL_CODE, ROOT)
    for step in steps:
        for path in step.outputs:
            recorded = manifest[path].get("code_sha256")
            assert recorded == now, (
                f"{path}: written by other source than planner/, bench/sim/ and the trial "
                f"command hold now (code_sha256 {recorded} != {now}): rewrite it with "
                f"{REGENERATE}"
            )


def test_the_code_digest_sees_every_file_it_covers_and_only_those(tmp_path):
    (tmp_path / "planner" / "robots").mkdir(parents=True)
    (tmp_path / "bench" / "report").mkdir(parents=True)
    (tmp_path / "planner" / "a.py").write_text("x = 1\n")
    (tmp_path / "planner" / "robots" / "r.toml").write_text("m = 1\n")
    (tmp_path / "bench" / "report" / "c.py").write_text("y = 1\n")
    patterns = ("planner/**/*.py", "planner/**/*.toml")
    before = digest.code_digest(patterns, tmp_path)
    (tmp_path / "bench" / "report" / "c.py").write_text("y = 2\n")  # not a trial's source
    assert digest.code_digest(patterns, tmp_path) == before
    (tmp_path / "planner" / "robots" / "r.toml").write_text("m = 2\n")  # the robot changed
    changed = digest.code_digest(patterns, tmp_path)
    assert changed != before
    (tmp_path / "planner" / "robots" / "r.toml").rename(tmp_path / "planner" / "r.toml")
    assert digest.code_digest(patterns, tmp_path) != changed  # a move is a change
    with pytest.raises(ValueError, match="no file matches"):
        digest.code_digest(("nothing/*.py",), tmp_path)


def test_regenerating_records_the_digest_and_keeps_it_current(tmp_path):
    (tmp_path / "results").mkdir()
    (tmp_path / "planner").mkdir()
    (tmp_path / "planner" / "a.py").write_text("x = 1\n")
    step = regenerate.Step(("mjcf", "--out", "results/scene.xml"), ("results/scene.xml",), 0.1,
                           code=("planner/*.py",))  # fmt: skip
    regenerate.run_step(step, tmp_path)
    entry = provenance.load(tmp_path)["results/scene.xml"]
    assert entry["code_sha256"] == digest.code_digest(("planner/*.py",), tmp_path)
    (tmp_path / "planner" / "a.py").write_text("x = 2\n")  # same output, new source
    regenerate.run_step(step, tmp_path)
    again = provenance.load(tmp_path)["results/scene.xml"]
    assert again["sha256"] == entry["sha256"]
    assert again["code_sha256"] == digest.code_digest(("planner/*.py",), tmp_path)
    assert again["code_sha256"] != entry["code_sha256"]
