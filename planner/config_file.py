"""Reading a user's text file (TOML or JSON) with one-line refusals.

Every file a user names (robot spec, sweep or envelope config, compare
baseline) is read here, so each failure reads the same: the file, then what is
wrong with it (missing, a directory, unreadable, not UTF-8, not valid TOML).
The callers parse what they get and raise their own error class.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

from slopewalk.planner.errors import SlopewalkError


def read_text(path: Path, *, where: str, kind: str, error: type[SlopewalkError]) -> str:
    """The UTF-8 text of ``path``, or ``error`` in one line.

    Args:
        path: The file to read.
        where: How the message names the file, e.g. ``"robot spec 'x.toml'"``.
        kind: What the file should be, for the directory case, e.g. ``"a TOML file"``.
        error: The caller's error class (a ``SlopewalkError``).
    """
    try:
        data = Path(path).read_bytes()
    except FileNotFoundError:
        raise error(f"{where}: no such file") from None
    except IsADirectoryError:
        raise error(f"{where}: is a directory, not {kind}") from None
    except OSError as err:
        raise error(f"{where}: cannot read ({err.strerror or err})") from None
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise error(
            f"{where}: not UTF-8 text (byte {err.object[err.start]:#04x} at offset {err.start})"
        ) from None


def load_toml(path: Path, *, where: str, kind: str, error: type[SlopewalkError]) -> dict[str, Any]:
    """The TOML table in ``path``, or ``error`` in one line (see ``read_text``)."""
    text = read_text(path, where=where, kind=kind, error=error)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise error(f"{where}: not valid TOML ({err})") from None
