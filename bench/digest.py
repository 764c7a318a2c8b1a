"""Digests of files by their content: the sha256 of one file, and one digest over a set of
source files (each path and its bytes' sha256). No git needed: a rebase or a squash that
keeps the files keeps the digest. ``provenance`` records them beside each result;
``batch.cluster`` compares its workers' source with the client's by them.
"""

from __future__ import annotations

import hashlib
from pathlib import Path


def code_digest(patterns: tuple[str, ...], root: str | Path = ".") -> str:
    """sha256 over the files matching ``patterns`` (globs from ``root``, ``**`` allowed),
    sorted by path: each path and the sha256 of its bytes. Content only: no git needed,
    and a rebase or a squash of the history that keeps the files keeps the digest."""
    root = Path(root)
    files = sorted({p for pattern in patterns for p in root.glob(pattern) if p.is_file()})
    if not files:
        raise ValueError(f"code_digest: no file matches {patterns}")
    digest = hashlib.sha256()
    for path in files:
        digest.update(f"{path.relative_to(root).as_posix()}\0{sha256(path)}\n".encode())
    return digest.hexdigest()


def sha256(path: str | Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()
