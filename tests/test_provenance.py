"""results/PROVENANCE.json speaks for every committed result, with the command of
`slopewalk regenerate` that writes it and the versions that did (bench/provenance.py)."""

import json
import re
import subprocess
from importlib import metadata
from pathlib import Path

import pytest

from slopewalk.bench import provenance, regenerate
from slopewalk.bench.cli import main

ROOT = Path(__file__).resolve().parents[1]
COMMIT = re.compile(r"^[0-9a-f]{40}$")


@pytest.fixture(scope="module")
def manifest():
    return provenance.load(ROOT)


def test_every_tracked_result_has_an_entry_and_every_entry_a_file(manifest):
    tracked = set(provenance.tracked_results(ROOT))
    assert tracked, "no tracked files under results/"
    assert sorted(tracked - set(manifest)) == [], (
        "results without provenance: add their command to bench/regenerate.py's STEPS and run "
        "'slopewalk regenerate --only PATH'"
    )
    assert sorted(set(manifest) - tracked) == [], "entries for files git does not track"


def test_each_entry_names_the_regeneration_step_that_writes_its_file(manifest):
    listed = {s.command for s in regenerate.STEPS}
    for path, entry in manifest.items():
        assert entry["command"] == regenerate.command_of(path), path
        command = entry["command"].removeprefix(f"{provenance.BY_HAND}: ")
        assert command in listed or command == provenance.BY_HAND, path


def test_each_entry_speaks_for_the_committed_bytes(manifest):
    for path, entry in manifest.items():
        if entry["command"] == provenance.BY_HAND:
            assert "sha256" not in entry and entry["written_with"] == provenance.NOT_RECORDED
            continue
        assert entry["sha256"] == provenance.sha256(ROOT / path), (
            f"{path} changed since its entry: write it with 'slopewalk regenerate --only {path}'"
        )
        if entry["written_with"] == provenance.NOT_RECORDED:
            assert COMMIT.match(entry["last_changed_in"]), path
        else:
            assert {"slopewalk", "numpy", "numba", "mujoco"} <= set(entry["written_with"]), path


def test_manifest_is_written_sorted_and_whole():
    text = (ROOT / provenance.MANIFEST).read_text()
    doc = json.loads(text)
    assert text == json.dumps(doc, indent=2, sort_keys=True, ensure_ascii=False) + "\n"


def test_versions_are_those_installed_and_the_checkout_commit():
    found = provenance.versions()
    for name in ("slopewalk", "numpy", "scipy", "numba", "mujoco", "pymoo"):
        assert found[name] == metadata.version(name)
    if not (ROOT / ".git").exists():
        assert "slopewalk_commit" not in found  # an export without git: no commit to name
        return
    head = subprocess.run(
        ["git", "-C", str(ROOT), "rev-parse", "HEAD"], capture_output=True, text=True, check=True
    ).stdout.strip()
    assert found["slopewalk_commit"] == head


def test_record_writes_the_versions_it_claims_and_nothing_more_when_bytes_repeat(tmp_path):
    (tmp_path / "results").mkdir()
    out = tmp_path / "results" / "a.txt"
    out.write_text("one\n")
    assert provenance.record(["results/a.txt"], "slopewalk x", tmp_path) == ["results/a.txt"]
    entry = provenance.load(tmp_path)["results/a.txt"]
    assert entry["command"] == "slopewalk x"
    assert entry["sha256"] == provenance.sha256(out)
    for name in ("slopewalk", "numpy", "numba", "mujoco"):
        assert entry["written_with"][name] == metadata.version(name)
    before = (tmp_path / provenance.MANIFEST).read_bytes()
    assert provenance.record(["results/a.txt"], "slopewalk x", tmp_path) == []
    assert (tmp_path / provenance.MANIFEST).read_bytes() == before  # no dates: no churn
    out.write_text("two\n")
    provenance.record(["results/a.txt"], "slopewalk x", tmp_path)
    assert provenance.load(tmp_path)["results/a.txt"]["sha256"] == provenance.sha256(out)


def test_reproducing_an_unrecorded_file_marks_it_verified_and_keeps_its_history(tmp_path):
    (tmp_path / "results").mkdir()
    (tmp_path / "results" / "a.txt").write_text("old\n")
    old = {
        "command": "slopewalk x",
        "sha256": provenance.sha256(tmp_path / "results" / "a.txt"),
        "written_with": provenance.NOT_RECORDED,
        "last_changed_in": "0" * 40,
    }
    provenance.save({"results/a.txt": old}, tmp_path)
    provenance.record(["results/a.txt"], "slopewalk x", tmp_path)
    entry = provenance.load(tmp_path)["results/a.txt"]
    assert entry["verified_with"] == provenance.versions()
    assert {k: v for k, v in entry.items() if k != "verified_with"} == old


def test_a_regeneration_step_records_what_it_wrote(tmp_path):
    step = regenerate.Step(("mjcf", "--slope", "5", "--out", "results/scene.xml"),
                           ("results/scene.xml",), 0.1)  # fmt: skip
    (tmp_path / "results").mkdir()
    assert regenerate.run_step(step, tmp_path) == ["results/scene.xml"]
    entry = provenance.load(tmp_path)["results/scene.xml"]
    assert entry["command"] == "slopewalk mjcf --slope 5 --out results/scene.xml"
    assert entry["sha256"] == provenance.sha256(tmp_path / "results" / "scene.xml")
    assert entry["written_with"]["mujoco"] == metadata.version("mujoco")


def test_regeneration_order_puts_inputs_before_readers():
    commands = [s.command for s in regenerate.STEPS]

    def first(text):
        return next(i for i, c in enumerate(commands) if text in c)

    sweep = commands.index("slopewalk sweep")  # the claims table: reads optimize/ and envelope/
    assert max(i for i, c in enumerate(commands) if "slopewalk optimize" in c) < sweep
    assert first("slopewalk envelope --convergence") < sweep < first("slopewalk controllers")
    assert first("dense-noise.toml") < first("slopewalk fidelity")


def test_list_prints_every_command_and_its_time(capsys):
    assert main(["regenerate", "--list"]) == 0
    text = capsys.readouterr().out
    for step in regenerate.STEPS:
        assert step.command in text
    assert re.search(r"\d+ commands, about \d+ min", text)
    assert main(["regenerate", "--list", "--only", "results/trials/*"]) == 0
    assert capsys.readouterr().out.count("slopewalk trial") == 7
    assert main(["regenerate", "--list", "--only", "results/nothing*"]) == 2
