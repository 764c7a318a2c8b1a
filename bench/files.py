"""Output files: checked before any work, and written whole or not at all.

``check_output`` refuses, in one line, a path that cannot become a file: empty,
a directory, under a regular file, in a folder that refuses new files, or a
special file other than a character device. The CLI calls it for every output
before it computes anything.

``atomic_paths`` writes regular files beside their targets and moves them into
place only when every one was written, so a failure leaves nothing behind (not
even the folders it made). A character device (``/dev/null``, ``/dev/full``, a
terminal) is written through directly and never replaced: its own error, e.g.
"No space left on device", is the refusal.
"""

from __future__ import annotations

import contextlib
import os
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path

from slopewalk.planner.errors import SlopewalkError


class OutputError(SlopewalkError):
    """An output path that cannot be written, or a write that failed."""


def check_output(path: str | Path, *, name: str = "--out") -> Path:
    """Refuse an output file path that cannot be written (see module doc); return it.

    Args:
        path: The file to be written.
        name: How the user gave it (a flag), for the message.
    """
    text = str(path)
    where = f"{name} {text!r}"
    if not text.strip():
        raise OutputError(f"{name} {text!r}: must be a file path, not empty")
    path = Path(path)
    mode = _mode(path)
    if mode is not None:
        if stat.S_ISDIR(mode):
            raise OutputError(f"{where}: is a directory; give a file path (e.g. inside it)")
        if stat.S_ISCHR(mode):
            if not os.access(path, os.W_OK):
                raise OutputError(f"{where}: the device is not writable")
            return path
        if not stat.S_ISREG(mode):
            raise OutputError(f"{where}: is a {_kind(mode)}, not a regular file or a device")
    _check_folder(path.parent, where)
    return path


def check_output_dir(path: str | Path, *, name: str = "--out") -> Path:
    """Refuse an output folder path that is a file or cannot be created or written into."""
    text = str(path)
    where = f"{name} {text!r}"
    if not text.strip():
        raise OutputError(f"{name} {text!r}: must be a folder path, not empty")
    path = Path(path)
    mode = _mode(path)
    if mode is not None and not stat.S_ISDIR(mode):
        raise OutputError(f"{where}: is a {_kind(mode)}, not a folder")
    _check_folder(path, where)
    return path


def _mode(path: Path) -> int | None:
    try:
        return os.stat(path).st_mode
    except FileNotFoundError:
        return None
    except NotADirectoryError:
        return None  # an ancestor is a file: _check_folder says which
    except OSError as err:
        raise OutputError(f"{str(path)!r}: {err.strerror}") from None


def _kind(mode: int) -> str:
    kinds = {
        stat.S_ISREG: "regular file",
        stat.S_ISDIR: "folder",
        stat.S_ISFIFO: "named pipe",
        stat.S_ISSOCK: "socket",
        stat.S_ISBLK: "block device",
        stat.S_ISCHR: "character device",
    }
    return next((kind for test, kind in kinds.items() if test(mode)), "special file")


def _check_folder(folder: Path, where: str) -> None:
    """The nearest existing ancestor of ``folder`` must be a folder that takes new files."""
    existing = folder
    while _mode(existing) is None and existing != existing.parent:
        existing = existing.parent
    mode = _mode(existing)
    if mode is None or not stat.S_ISDIR(mode):
        raise OutputError(f"{where}: {str(existing)!r} is a {_kind(mode or 0)}, not a folder")
    try:  # the only test that holds for root, read-only mounts and /proc alike
        fd, probe = tempfile.mkstemp(prefix=".slopewalk-probe.", dir=existing)
    except OSError as err:
        raise OutputError(
            f"{where}: cannot create files in {str(existing)!r} ({err.strerror})"
        ) from None
    os.close(fd)
    os.remove(probe)


@contextlib.contextmanager
def atomic_paths(*paths: str | Path) -> Iterator[list[Path]]:
    """Yield one path to write per target; move them all into place only on success.

    A regular target gets a temporary file beside it; a character device is
    yielded as it is and written through. On any error nothing is moved, the
    temporary files and the folders made for them are removed, and an ``OSError``
    of the writes comes out as one ``OutputError`` line naming the target.
    """
    targets = [Path(p) for p in paths]
    made: list[Path] = []  # folders created here, deepest last
    staged: list[Path | None] = []  # temporary file per target, None: written through
    try:
        for target in targets:
            staged.append(_stage(target, made))
        try:
            yield [tmp or target for tmp, target in zip(staged, targets, strict=True)]
        except OSError as err:
            raise OutputError(_write_error(err, targets, staged)) from None
        for tmp, target in zip(staged, targets, strict=True):
            if tmp is not None:
                os.replace(tmp, target)
        made.clear()
    finally:
        for tmp in staged:
            if tmp is not None:
                with contextlib.suppress(FileNotFoundError):
                    os.remove(tmp)
        for folder in reversed(made):
            with contextlib.suppress(OSError):
                folder.rmdir()


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """``atomic_paths`` for one target: yield the path to write."""
    with atomic_paths(path) as (tmp,):
        yield tmp


def _stage(target: Path, made: list[Path]) -> Path | None:
    mode = _mode(target)
    if mode is not None and stat.S_ISCHR(mode):
        return None
    if mode is not None and not stat.S_ISREG(mode):
        raise OutputError(f"{str(target)!r}: is a {_kind(mode)}, not a regular file or a device")
    missing = []
    folder = target.parent
    while not folder.exists() and folder != folder.parent:
        missing.append(folder)
        folder = folder.parent
    try:
        for folder in reversed(missing):
            folder.mkdir()
            made.append(folder)
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".part", dir=target.parent)
    except OSError as err:
        raise OutputError(f"cannot write {str(target)!r}: {err.strerror}") from None
    os.close(fd)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; results are ordinary files
    return Path(tmp)


def _write_error(err: OSError, targets: list[Path], staged: list[Path | None]) -> str:
    """One line naming the target whose write failed (not its temporary name)."""
    name = err.filename
    for target, tmp in zip(targets, staged, strict=True):
        if name is not None and str(name) in (str(target), str(tmp)):
            return f"cannot write {str(target)!r}: {err.strerror}"
    if len(targets) == 1:
        return f"cannot write {str(targets[0])!r}: {err.strerror or err}"
    return f"cannot write {', '.join(repr(str(t)) for t in targets)}: {err.strerror or err}"


def in_package(path: str | Path) -> str:
    """A file shipped with slopewalk, as reports quote it: relative to the checkout's root.

    POSIX style (``bench/experiments/sweeps/paper.toml``), never this machine's
    absolute path, which differs in every checkout.
    """
    return Path(path).resolve().relative_to(Path(__file__).resolve().parents[1]).as_posix()
