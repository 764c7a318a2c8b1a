"""Which command and which versions wrote each committed result: ``results/PROVENANCE.json``.

One entry per git-tracked file under ``results/`` (the manifest itself excepted),
keyed by its path from the repository root:

- ``command``: the command that writes it, as ``slopewalk regenerate --list`` prints
  it (``bench.regenerate``), or ``by hand`` for the READMEs and ``mutation.md``;
- ``sha256``: the content the entry speaks for (none for files written by hand);
- ``written_with``: the versions (``versions()``) of the run that wrote that content,
  or the string ``"not recorded"`` for files written before this manifest existed;
  those carry ``last_changed_in``, the commit that last changed the file;
- ``verified_with``: the versions of a later run that wrote the same bytes again;
- ``code_sha256``: for the files of a step that names the source it depends on
  (``regenerate.Step.code``), a digest of that source (``digest.code_digest``) as it was when the
  file was last written or verified; tests/test_trials.py fails when the source now
  differs (the file may be stale: regenerate it).

``record`` is the one writer: ``slopewalk regenerate`` calls it for every file a
step wrote. The manifest holds no dates, so a run that reproduces a file byte for
byte changes nothing but ``verified_with``.
"""

from __future__ import annotations

import json
import subprocess
import sys
from importlib import metadata
from pathlib import Path

from slopewalk.bench.digest import sha256

MANIFEST = Path("results") / "PROVENANCE.json"
# The distributions whose versions can change a committed number: the physics, the
# compiled kernel and the arrays it runs on, the splines, the GA's random streams.
DISTRIBUTIONS = ("slopewalk", "numpy", "scipy", "numba", "mujoco", "pymoo")
BY_HAND = "by hand"
NOT_RECORDED = "not recorded"
_ABOUT = (
    "Which command and which versions wrote each file under results/ (bench/provenance.py). "
    "written_with 'not recorded': written before this manifest existed; last_changed_in is "
    "the commit that last changed it. verified_with: a later run wrote the same bytes."
)


def versions() -> dict[str, str]:
    """The versions a result written now is written with: Python, the distributions of
    ``DISTRIBUTIONS`` (``importlib.metadata``), and slopewalk's git commit when it runs
    from a checkout (``slopewalk_commit``, with ``slopewalk_dirty`` when tracked files
    outside ``results/`` differ from it)."""
    found = {"python": ".".join(str(n) for n in sys.version_info[:3])}
    for name in DISTRIBUTIONS:
        found[name] = metadata.version(name)
    found.update(source_commit())
    return found


def source_commit() -> dict[str, str]:
    """``{"slopewalk_commit": SHA}`` (and ``"slopewalk_dirty": "yes"``) when this module
    lies in a git checkout of slopewalk; ``{}`` for an installed copy."""
    here = Path(__file__).resolve().parent
    root = here.parent
    if not (root / "pyproject.toml").is_file() or not (root / ".git").exists():
        return {}
    try:
        sha = _git(root, "rev-parse", "HEAD")
        changed = _git(
            root, "status", "--porcelain", "--untracked-files=no", "--", ".", ":(exclude)results"
        )
    except (OSError, subprocess.CalledProcessError):
        return {}
    return {"slopewalk_commit": sha} | ({"slopewalk_dirty": "yes"} if changed else {})


def last_commit(path: str | Path, root: str | Path = ".") -> str | None:
    """The commit that last changed ``path`` (``git log -1``), None if git has none."""
    try:
        return _git(Path(root), "log", "-1", "--format=%H", "--", str(path)) or None
    except (OSError, subprocess.CalledProcessError):
        return None


def load(root: str | Path = ".") -> dict[str, dict]:
    """The manifest's entries by path (empty when there is no manifest yet)."""
    path = Path(root) / MANIFEST
    if not path.exists():
        return {}
    return json.loads(path.read_text())["files"]


def save(entries: dict[str, dict], root: str | Path = ".") -> Path:
    """Write the manifest, sorted, so the same entries always give the same bytes."""
    path = Path(root) / MANIFEST
    doc = {"about": _ABOUT, "files": dict(sorted(entries.items()))}
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(doc, indent=2, sort_keys=True, ensure_ascii=False) + "\n")
    tmp.replace(path)
    return path


def entry_for(
    path: str, command: str, old: dict | None, *, root: str | Path = ".", code: str | None = None
) -> dict:
    """The manifest entry of ``path`` (from the repository root) just written by
    ``command`` with this process's ``versions()`` (and from source of digest ``code``).

    The same bytes as ``old`` speaks for keep ``old``'s writer and are marked
    ``verified_with`` these versions; other bytes start a new entry.
    """
    digest = sha256(Path(root) / path)
    now = versions()
    source = {} if code is None else {"code_sha256": code}
    if old is not None and old.get("sha256") == digest:
        kept = {k: v for k, v in old.items() if k not in ("verified_with", "code_sha256")}
        if kept.get("written_with") == now:
            return kept | source
        return kept | {"command": command, "verified_with": now} | source
    return {"command": command, "sha256": digest, "written_with": now} | source


def record(
    paths: list[str], command: str, root: str | Path = ".", *, code: str | None = None
) -> list[str]:
    """Record in the manifest that ``command`` just wrote ``paths`` (from the repository
    root ``root``) with this process's versions, from source of digest ``code`` (None: not
    recorded); returns the paths whose entry changed."""
    entries = load(root)
    changed = []
    for path in paths:
        new = entry_for(path, command, entries.get(path), root=root, code=code)
        if entries.get(path) != new:
            entries[path] = new
            changed.append(path)
    if changed:
        save(entries, root)
    return changed


def unrecorded_entry(path: str, command: str, root: str | Path = ".") -> dict:
    """The entry of a file written before the manifest: its command and content, the
    commit that last changed it, and no versions (they were not recorded)."""
    entry: dict[str, str | None] = {"command": command, "written_with": NOT_RECORDED}
    if command != BY_HAND:
        entry["sha256"] = sha256(Path(root) / path)
        entry["last_changed_in"] = last_commit(path, root)
    return entry


def tracked_results(root: str | Path = ".") -> list[str]:
    """The git-tracked files under ``results/``, the manifest excepted."""
    out = _git(Path(root), "ls-files", "--", "results")
    return [p for p in out.splitlines() if p and p != MANIFEST.as_posix()]


def _git(root: Path, *args: str) -> str:
    done = subprocess.run(
        ["git", "-C", str(root), *args], capture_output=True, text=True, check=True
    )
    return done.stdout.strip()
