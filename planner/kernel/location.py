"""Where the compiled kernel is cached by default (no numba here: it is read before
numba is imported, to set ``NUMBA_CACHE_DIR``)."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path


def default_dir() -> Path:
    """``$XDG_CACHE_HOME/slopewalk/numba`` (``~/.cache/…``), or a per-user temp folder
    where that cannot be written."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    path = Path(base) / "slopewalk" / "numba"
    if _writable(path):
        return path
    return Path(tempfile.gettempdir()) / f"slopewalk-numba-{os.getuid()}"


def _writable(path: Path) -> bool:
    try:
        path.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=path):
            pass
    except OSError:
        return False
    return True
