"""The append-only results table: one CSV line per finished row, appended whole, so a
killed run resumes where it stopped.

Two files in a run directory: ``<name>.partial.csv`` while a run is going (and
after it was killed), ``<name>.csv`` once every row is done. The partial table
is opened once with ``O_APPEND``; its header is written when it is created, and
each row is formatted completely and written with a single ``os.write``, so a
reader or a crash sees whole lines only (a kernel append is all-or-nothing for
a small write). The one exception, a crash of the machine inside that write,
can leave a last line without its newline; opening the partial table again
cuts that torn line off, and its row runs again. A row appended again for the
same id (a re-run for a missing recording) replaces the earlier one. An
exclusive ``flock`` keeps a second run from writing the same file at the same
time; it lives with this process's open file (workers start in a fresh interpreter:
forked from a fork server that holds no file of ours, or spawned; they hold no copy of it).

A file that is not such a table (binary, not UTF-8, no header, other columns,
a line of the wrong width, a verdict that is not a verdict) is refused in one
line naming the file and what is wrong; it is never truncated or overwritten.
The one exception: a finished table of an older version (``previous_layouts``),
which a fresh run replaces (``--resume`` refuses it).

A ``TableFormat`` names a kind of table's columns, their precisions and its verdict
columns with their allowed values: ``tables.sweep`` and ``tables.envelope`` hold the
bench's. Values are written so that the same rows give the same bytes (``text``).
"""

from __future__ import annotations

import contextlib
import csv
import fcntl
import io
import math
import os
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from pathlib import Path

from slopewalk.bench.files import atomic_path
from slopewalk.planner.errors import SlopewalkError

_ID_CHARS = frozenset("0123456789abcdef")


class TableError(SlopewalkError):
    """A file that is not a table of its kind, a table another run holds, or a failed write."""


@dataclass(frozen=True)
class TableFormat:
    """The columns of one kind of results table and what ``parse`` checks in them.

    Attributes:
        kind: What writes it, for messages ("sweep": "not a sweep table").
        columns: Column names; the first is the row's 12-hex-digit id.
        decimals: Outcome columns written at a fixed precision: digits after the point.
        verdicts: Column -> the values it may hold (checked on every read).
        previous_layouts: Columns of older versions, which a fresh run may replace
            (``parse(previous_ok=True)``).
        siblings: (columns, why) of layouts that are this kind's but not this table's,
            refused with ``why`` (a sweep with or without a controller column).
    """

    kind: str
    columns: tuple[str, ...]
    decimals: dict = field(default_factory=dict)
    verdicts: dict = field(default_factory=dict)
    previous_layouts: tuple[tuple[str, ...], ...] = ()
    siblings: tuple[tuple[tuple[str, ...], str], ...] = ()

    @property
    def article(self) -> str:
        """ "a sweep", "an envelope"."""
        return f"{'an' if self.kind[0] in 'aeiou' else 'a'} {self.kind}"

    @property
    def header(self) -> bytes:
        return _header(self.columns)

    def _previous_layout(self, data: bytes) -> tuple[str, ...] | None:
        first = data.split(b"\n", 1)[0] + b"\n"
        return next((c for c in self.previous_layouts if _header(c) == first), None)

    def format_row(self, row: dict) -> bytes:
        """One complete CSV line (newline included) of ``row``'s columns."""
        buffer = io.StringIO()
        csv.writer(buffer, lineterminator="\n").writerow(
            text(c, row.get(c), self.decimals) for c in self.columns
        )
        return buffer.getvalue().encode()

    def parse(
        self,
        data: bytes,
        path: Path,
        *,
        torn_ok: bool = False,
        previous_ok: bool = False,
        hint: str = "; move it away or choose another --out",
    ) -> tuple[dict[str, bytes], int]:
        """The rows of a table (by id, last one wins) and the length of its whole lines.

        Args:
            data: The file's contents.
            path: For messages.
            torn_ok: Accept a last line without its newline (left out of the rows).
            previous_ok: Accept a table of ``previous_layouts`` too (checked the
                same way), which a fresh run may replace; its rows are not returned.
            hint: Appended to a refusal of the whole file: what a run that would
                write there can do ("" for a reader).

        Raises:
            TableError: ``data`` is not such a table (module doc), naming what is wrong.
        """
        where = f"{path}: not {self.article} table"
        try:
            data.decode()
        except UnicodeDecodeError as err:
            raise TableError(f"{where} (not UTF-8 text: byte {err.start}){hint}") from None
        expected = columns = self.columns
        previous = self._previous_layout(data)
        sibling = next((why for c, why in self.siblings if data.startswith(_header(c))), None)
        if previous_ok and previous:
            columns = previous
        elif sibling:
            raise TableError(f"{where} for this {self.kind} ({sibling}){hint}")
        elif not data.startswith(self.header):
            first = data.split(b"\n", 1)[0]
            what = (
                "no header line"
                if b"\n" not in data
                else "written by an older slopewalk (its columns are another version's): run "
                "without --resume to replace it"
                if previous
                else f"its header is not that of these {len(expected)} columns (another version?)"
                if first.startswith(f"{expected[0]},".encode())
                else "its first line is not the header"
            )
            raise TableError(f"{where} ({what}){hint}")
        whole = data.rfind(b"\n") + 1
        if whole < len(data) and not torn_ok:
            raise TableError(
                f"{where} (its last line has no newline: a torn write or a cut copy?){hint}"
            )
        rows: dict[str, bytes] = {}
        lines = data[data.index(b"\n") + 1 : whole].split(b"\n")[:-1]
        id_column = expected[0]
        for number, line in enumerate(lines, start=2):
            fields = next(csv.reader([line.decode()]), [])
            if len(fields) != len(columns):
                raise TableError(
                    f"{path}: line {number} has {len(fields)} fields, not {len(columns)}"
                )
            row = dict(zip(columns, fields, strict=True))
            row_id = row[id_column]
            if len(row_id) != 12 or not set(row_id) <= _ID_CHARS:
                raise TableError(
                    f"{path}: line {number}: {id_column} {row_id!r} is not a "
                    f"{id_column.removesuffix('_id')} id"
                )
            for column, allowed in self.verdicts.items():
                if column in row and row[column] not in allowed:
                    raise TableError(
                        f"{path}: line {number}: {column} {row[column]!r} is not one of "
                        + ", ".join(allowed)
                    )
            rows[row_id] = line + b"\n"
        return (rows if columns is expected else {}), whole

    def read_rows(self, path: str | Path, *, previous_ok: bool = False) -> dict[str, bytes]:
        """The rows of a finished table (``parse``), by id."""
        path = Path(path)
        data = _read_bytes(path, f"{self.article} table")
        return self.parse(data, path, previous_ok=previous_ok)[0]

    def fields(self, line: bytes, *columns: str) -> tuple[str, ...]:
        """The values of ``columns`` in one table line."""
        values = next(csv.reader([line.decode()]))
        return tuple(values[self.columns.index(c)] for c in columns)


def _header(columns) -> bytes:
    return (",".join(columns) + "\n").encode()


def text(column: str, value, decimals: dict) -> str:
    """``value`` of ``column`` as written in the table (module doc); ``decimals`` by column."""
    if value is None:
        return ""
    if isinstance(value, float):  # np.float64 too: its repr is not a plain number
        value = float(value)
        if column not in decimals or not math.isfinite(value):
            return repr(value)
        out = f"{value:.{decimals[column]}f}"
        return out[1:] if out.startswith("-") and not out.strip("-0.") else out  # no "-0.0000"
    return " ".join(str(value).split()) if isinstance(value, str) else str(value)


class AppendTable:
    """An open partial table: the rows already there (by id) and an appender.

    Use ``AppendTable.open(path, fmt)`` as a context manager.

    Attributes:
        path: The file.
        fmt: Its ``TableFormat``; columns: its columns.
        created: True when this open made the file (it held no row before).
        rows: id -> the row's line (bytes, newline included).
    """

    def __init__(
        self, path: Path, fd: int, rows: dict[str, bytes], created: bool, fmt: TableFormat
    ):
        self.path, self._fd, self.rows, self.created = path, fd, rows, created
        self.fmt = fmt
        self.columns = self.fmt.columns

    @classmethod
    @contextlib.contextmanager
    def open(cls, path: str | Path, fmt: TableFormat):
        """Create (with its header) or reopen the table at ``path``, locked for this process.

        Raises:
            TableError: another run holds the file, or it is not a table of this format.
        """
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        fd = _locked(path, fmt.kind)
        try:
            size = os.fstat(fd).st_size
            rows: dict[str, bytes] = {}
            if size == 0:
                os.write(fd, fmt.header)
                created = True
            else:
                rows, whole = fmt.parse(os.pread(fd, size, 0), path, torn_ok=True)
                if whole < size:  # our own torn last line (module doc): its row runs again
                    os.truncate(fd, whole)
                created = False
            yield cls(path, fd, rows, created, fmt)
        finally:
            os.close(fd)

    def append(self, row: dict) -> None:
        """Append one finished row: a single write of the whole line."""
        self.append_line(self.fmt.format_row(row))

    def append_line(self, line: bytes) -> None:
        """Append one formatted line (``format_row``) whole."""
        if os.write(self._fd, line) != len(line):  # only on a full disk
            raise TableError(f"{self.path}: short write (disk full?)")
        self.rows[line.split(b",", 1)[0].decode()] = line

    def counts(self) -> Counter:
        """Verdicts (the values of the format's verdict columns, in order) -> rows."""
        return Counter(self.fmt.fields(line, *self.fmt.verdicts) for line in self.rows.values())

    def write_finished(self, path: str | Path, order: Iterable[str]) -> None:
        """Write the rows, ids of ``order`` first, to ``path`` whole (atomically)."""
        seen = {}
        for trial_id in order:
            if trial_id in self.rows:
                seen[trial_id] = self.rows[trial_id]
        lines = list(seen.values()) + [v for k, v in self.rows.items() if k not in seen]
        with atomic_path(path) as tmp:
            with open(tmp, "wb") as f:
                f.write(self.fmt.header)
                f.writelines(lines)
            os.chmod(tmp, 0o644)


def _locked(path: Path, kind: str = "sweep") -> int:
    """An ``O_APPEND`` descriptor of ``path`` (created if missing) holding its exclusive flock.

    If a finishing sweep removed the file between our open and our lock, the
    lock is on a file no one will read: open the new one instead.
    """
    for _ in range(3):
        fd = os.open(path, os.O_RDWR | os.O_APPEND | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise TableError(f"{path}: another {kind} is writing this table") from None
        try:
            if os.stat(path).st_ino == os.fstat(fd).st_ino:
                return fd
        except FileNotFoundError:
            pass
        os.close(fd)
    raise TableError(f"{path}: removed as it was opened, three times (another {kind} finishing?)")


def _read_bytes(path: Path, what: str) -> bytes:
    """The bytes of the table file ``path``; a directory or an unreadable file is one
    TableError line (``what``: what it should be, e.g. "a sweep table")."""
    try:
        return path.read_bytes()
    except IsADirectoryError:
        raise TableError(f"{path}: is a directory, not {what}") from None
    except OSError as err:
        raise TableError(f"{path}: cannot read ({err.strerror})") from None


def read_table(path: str | Path) -> list[dict]:
    """The rows of a finished results table, in file order, with numbers as floats and
    "none" scaling as "".

    For analysis (``claims.py``, ``fidelity.py``); the runs themselves keep rows as
    text. The file is checked whole first (``TableFormat.parse`` with the columns its
    header names, the first an id column): a truncated copy (``head -c``), an empty
    file, a cut header, a line of another width or a table without rows is refused
    in one line naming the file, never read as fewer or emptier rows.

    Raises:
        TableError: the file cannot be read or is not a whole table (above).
    """
    path = Path(path)
    data = _read_bytes(path, "a results table")
    rows = _own_format(data, path).parse(data, path, hint="")[0]
    if not rows:
        raise TableError(f"{path}: a header and no row (an unfinished or emptied table?)")
    out = []
    for row in csv.DictReader(io.StringIO(data.decode(), newline="")):
        typed: dict[str, float | str] = {}
        for key, value in row.items():
            try:
                typed[key] = float(value)
            except ValueError:
                typed[key] = value
        if "mass_scale" in row:  # a sweep table's; other tables have none
            typed["mass_scale"] = "" if row["mass_scale"] == "none" else row["mass_scale"]
        out.append(typed)
    return out


MODEL_COLUMNS = ("model", "model_digest")  # a run on an imported model: its name, its files'


def model_format(fmt: TableFormat) -> TableFormat:
    """``fmt`` of a run on an imported model (``sweep``/``envelope --model``): the model's
    columns after every other (``MODEL_COLUMNS``: its name and ``sha256:`` with the first
    digits of its files' digest), so each column of ``fmt`` keeps its place; the table of
    the same run on the twin is refused as such, and a finished table of an older version
    on a model (``fmt``'s previous layouts with the model's columns) may be replaced."""
    why = "its rows were played on the spec's twin, not on a model"
    return replace(
        fmt,
        columns=(*fmt.columns, *MODEL_COLUMNS),
        siblings=((fmt.columns, why), *fmt.siblings),
        previous_layouts=tuple((*old, *MODEL_COLUMNS) for old in fmt.previous_layouts),
    )


_KINDS = {"trial_id": "sweep", "cell_id": "envelope"}  # a table's id column -> what wrote it


def _own_format(data: bytes, path: Path) -> TableFormat:
    """The ``TableFormat`` of the columns ``data``'s header names (``read_table``)."""
    if not data:
        raise TableError(f"{path}: is empty, not a results table")
    if b"\n" not in data:
        raise TableError(f"{path}: not a results table (no whole header line: cut short?)")
    try:
        first = data.split(b"\n", 1)[0].decode()
    except UnicodeDecodeError as err:
        raise TableError(
            f"{path}: not a results table (not UTF-8 text: byte {err.start})"
        ) from None
    columns = tuple(next(csv.reader([first]), []))
    if not columns or not columns[0].endswith("_id") or len(set(columns)) != len(columns):
        raise TableError(
            f"{path}: not a results table (its first line is not a header of distinct column "
            "names, the first an id column such as trial_id)"
        )
    return TableFormat(_KINDS.get(columns[0], "results"), columns)
