"""The sweep table: one CSV line per finished trial, appended whole, so a killed sweep resumes.

Two files in a run directory: ``sweep.partial.csv`` while a run is going (and
after it was killed), ``sweep.csv`` once every trial is done. The partial table
is opened once with ``O_APPEND``; its header is written when it is created, and
each row is formatted completely and written with a single ``os.write``, so a
reader or a crash sees whole lines only (a kernel append is all-or-nothing for
a small write). The one exception, a crash of the machine inside that write,
can leave a last line without its newline; opening the partial table again
cuts that torn line off, and its trial runs again. A row appended again for the
same ``trial_id`` (a re-run for a missing recording) replaces the earlier one.
An exclusive ``flock`` keeps a second sweep from writing the same file at the
same time; it lives with this process's open file (sweep workers are spawned,
so they hold no copy of it).

A file that is not such a table (binary, not UTF-8, no header, other columns,
a line of the wrong width, a verdict that is not a verdict) is refused in one
line naming the file and what is wrong; it is never truncated or overwritten.
The one exception: a finished table of an older version (``PREVIOUS_LAYOUTS``:
its columns had a ``wall_s``, or lacked the fidelity columns or the simulated
tilt), which a fresh run replaces (``--resume`` refuses it).

Values, chosen so that regenerating a table from the same trials gives the
same bytes: the inputs (``step_time``, ``slope_deg``, ``friction``) as written
in the sweep file (Python's shortest round-trip ``repr``); each outcome at a
fixed precision well above floating-point noise (last-bit differences between
BLAS builds or summation orders cannot reach it) and below anything physical:
lengths in mm to 0.1 µm (4 decimals), times to 0.1 ms, angles to 1e-5 deg,
torques to 1 µN·m, work to 0.1 µJ, ratios and fractions to 1e-6. ``nan`` is
not-a-number, booleans are ``True``/``False``, a missing value an empty field;
pandas and polars read the file as it is.

The same machinery serves any table of this kind (the stability envelope's
``envelope.csv``): a ``TableFormat`` names its columns, their precisions and
the verdict columns with their allowed values; ``SWEEP`` and ``SWEEP_CONTROLLER``
are the sweep's, and the module-level functions below are their methods.
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
from dataclasses import dataclass, field
from pathlib import Path

from slopewalk.bench.experiments.sweep_config import SweepError
from slopewalk.bench.files import atomic_path

COLUMNS = (
    # inputs
    "trial_id",
    "step_time",  # [s]
    "slope_deg",
    "friction",
    "actuators",
    "robot",
    "mass_scale",  # "none", "legs=2", "all=10;legs=2"
    "steps",
    "seed",
    # outcome
    "analytic_verdict",  # stable / zmp_outside, or error
    "simulated_verdict",  # stable / tip / slip / fall / diverged, or error
    "slip_predicted",
    "events",  # kinds in order of first occurrence, ";"-joined
    "first_event_time_s",
    "zmp_rms_mm",
    "zmp_max_mm",
    "lipm_rms_mm",  # analytic multibody ZMP vs LIPM ZMP, RMS over the walk
    "cop_lipm_rms_mm",  # simulated CoP vs LIPM ZMP, RMS while standing
    "analytic_min_margin_mm",
    "simulated_min_margin_mm",
    "max_friction_ratio",
    "simulated_max_friction_ratio",
    "tracking_rms_deg",
    "peak_torque_planned_Nm",
    "peak_torque_simulated_Nm",
    "work_J",  # planned joint work, Plan.work.sum()
    "standing_fraction",
    "sim_steps",
    # fidelity (bench/sim/prediction.py, bench/sim/support.py)
    "compliant_verdict",  # the paper's ZMP test on the walk the servos reach
    "compliant_min_margin_mm",
    "predicted_verdict",  # the most severe predicted event, or stable
    "predicted_events",  # predicted kinds in order of first occurrence, ";"-joined
    "predicted_rotation_deg",  # largest predicted turn of the support about its edge
    "simulated_max_tilt_deg",  # largest simulated tilt of a loaded foot off the plane
    "unplanned_support_s",  # foot-time the simulated contacts differed from the plan's
    "error",  # the one-line message of a trial that raised or killed its worker, else empty
)
ANALYTIC_VERDICTS = ("stable", "zmp_outside", "error")
SIMULATED_VERDICTS = ("stable", "slip", "tip", "fall", "diverged", "error")
DECIMALS = {  # outcome columns: digits after the point (module doc)
    "first_event_time_s": 4,
    "zmp_rms_mm": 4,
    "zmp_max_mm": 4,
    "lipm_rms_mm": 4,
    "cop_lipm_rms_mm": 4,
    "analytic_min_margin_mm": 4,
    "simulated_min_margin_mm": 4,
    "max_friction_ratio": 6,
    "simulated_max_friction_ratio": 6,
    "tracking_rms_deg": 5,
    "peak_torque_planned_Nm": 6,
    "peak_torque_simulated_Nm": 6,
    "work_J": 7,
    "standing_fraction": 6,
    "compliant_min_margin_mm": 4,
    "unplanned_support_s": 4,
    "predicted_rotation_deg": 5,
    "simulated_max_tilt_deg": 5,
}
HEADER = (",".join(COLUMNS) + "\n").encode()
# A sweep that names a controller somewhere: one more input, last, so every other
# column keeps its place ("none" for a trial played open loop).
CONTROLLER_COLUMNS = (*COLUMNS, "controller")
CONTROLLER_HEADER = (",".join(CONTROLLER_COLUMNS) + "\n").encode()
# A sweep with command noise: its σ [deg], as written in the sweep file, last likewise
NOISE_COLUMNS = (*COLUMNS, "command_noise_deg")
_FIDELITY = COLUMNS.index("compliant_verdict")  # the columns before it are the older versions'
# before fixed precision: a wall time, and no fidelity columns
PREVIOUS_COLUMNS = (*COLUMNS[:_FIDELITY], "wall_s", "error")
PREVIOUS_HEADER = (",".join(PREVIOUS_COLUMNS) + "\n").encode()
_BEFORE_TILT = tuple(c for c in COLUMNS if c != "simulated_max_tilt_deg")  # before 2026-12
# every finished layout an older slopewalk wrote, which a fresh run may replace:
# the one with a wall time, then fixed precision without the fidelity columns
# (with and without the controller column)
PREVIOUS_LAYOUTS = (
    PREVIOUS_COLUMNS,
    (*COLUMNS[:_FIDELITY], "error"),
    (*COLUMNS[:_FIDELITY], "error", "controller"),
    _BEFORE_TILT,
    (*_BEFORE_TILT, "controller"),
)
_ID_CHARS = frozenset("0123456789abcdef")


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
        self, data: bytes, path: Path, *, torn_ok: bool = False, previous_ok: bool = False
    ) -> tuple[dict[str, bytes], int]:
        """The rows of a table (by id, last one wins) and the length of its whole lines.

        Args:
            data: The file's contents.
            path: For messages.
            torn_ok: Accept a last line without its newline (left out of the rows).
            previous_ok: Accept a table of ``previous_layouts`` too (checked the
                same way), which a fresh run may replace; its rows are not returned.

        Raises:
            SweepError: ``data`` is not such a table (module doc), naming what is wrong.
        """
        where = f"{path}: not {self.article} table"
        hint = "; move it away or choose another --out"
        try:
            data.decode()
        except UnicodeDecodeError as err:
            raise SweepError(f"{where} (not UTF-8 text: byte {err.start}){hint}") from None
        expected = columns = self.columns
        previous = self._previous_layout(data)
        sibling = next((why for c, why in self.siblings if data.startswith(_header(c))), None)
        if previous_ok and previous:
            columns = previous
        elif sibling:
            raise SweepError(f"{where} for this {self.kind} ({sibling}){hint}")
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
            raise SweepError(f"{where} ({what}){hint}")
        whole = data.rfind(b"\n") + 1
        if whole < len(data) and not torn_ok:
            raise SweepError(f"{where} (its last line has no newline: a torn write?){hint}")
        rows: dict[str, bytes] = {}
        lines = data[data.index(b"\n") + 1 : whole].split(b"\n")[:-1]
        id_column = expected[0]
        for number, line in enumerate(lines, start=2):
            fields = next(csv.reader([line.decode()]), [])
            if len(fields) != len(columns):
                raise SweepError(
                    f"{path}: line {number} has {len(fields)} fields, not {len(columns)}"
                )
            row = dict(zip(columns, fields, strict=True))
            row_id = row[id_column]
            if len(row_id) != 12 or not set(row_id) <= _ID_CHARS:
                raise SweepError(
                    f"{path}: line {number}: {id_column} {row_id!r} is not a "
                    f"{id_column.removesuffix('_id')} id"
                )
            for column, allowed in self.verdicts.items():
                if column in row and row[column] not in allowed:
                    raise SweepError(
                        f"{path}: line {number}: {column} {row[column]!r} is not one of "
                        + ", ".join(allowed)
                    )
            rows[row_id] = line + b"\n"
        return (rows if columns is expected else {}), whole

    def read_rows(self, path: str | Path, *, previous_ok: bool = False) -> dict[str, bytes]:
        """The rows of a finished table (``parse``), by id."""
        path = Path(path)
        try:
            data = path.read_bytes()
        except IsADirectoryError:
            raise SweepError(f"{path}: is a directory, not {self.article} table") from None
        except OSError as err:
            raise SweepError(f"{path}: cannot read ({err.strerror})") from None
        return self.parse(data, path, previous_ok=previous_ok)[0]

    def fields(self, line: bytes, *columns: str) -> tuple[str, ...]:
        """The values of ``columns`` in one table line."""
        values = next(csv.reader([line.decode()]))
        return tuple(values[self.columns.index(c)] for c in columns)


def _header(columns) -> bytes:
    return (",".join(columns) + "\n").encode()


_SWEEP_VERDICTS = {"analytic_verdict": ANALYTIC_VERDICTS, "simulated_verdict": SIMULATED_VERDICTS}
_LAYOUTS = {
    COLUMNS: "a sweep without a controller or command_noise key",
    CONTROLLER_COLUMNS: "a sweep with a controller key",
    NOISE_COLUMNS: "a sweep with a command_noise key",
}


def _sweep_layout(columns: tuple[str, ...]) -> TableFormat:
    others = tuple(
        (other, f"its columns are those of {what}")
        for other, what in _LAYOUTS.items()
        if other != columns
    )
    return TableFormat("sweep", columns, DECIMALS, _SWEEP_VERDICTS, PREVIOUS_LAYOUTS, others)


SWEEP = _sweep_layout(COLUMNS)
SWEEP_CONTROLLER = _sweep_layout(CONTROLLER_COLUMNS)
SWEEP_NOISE = _sweep_layout(NOISE_COLUMNS)


def sweep_format(columns: tuple[str, ...] = COLUMNS) -> TableFormat:
    """The sweep's ``TableFormat`` of ``columns`` (``COLUMNS``, ``CONTROLLER_COLUMNS`` or
    ``NOISE_COLUMNS``)."""
    for fmt in (SWEEP, SWEEP_CONTROLLER, SWEEP_NOISE):
        if tuple(columns) == fmt.columns:
            return fmt
    return TableFormat("sweep", tuple(columns), DECIMALS, _SWEEP_VERDICTS, PREVIOUS_LAYOUTS)


def format_row(row: dict, columns: tuple[str, ...] = COLUMNS) -> bytes:
    """One complete CSV line (newline included) of ``row``'s ``columns``."""
    return sweep_format(columns).format_row(row)


def text(column: str, value, decimals: dict = DECIMALS) -> str:
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


def parse(
    data: bytes,
    path: Path,
    *,
    torn_ok: bool = False,
    previous_ok: bool = False,
    columns: tuple[str, ...] = COLUMNS,
) -> tuple[dict[str, bytes], int]:
    """The rows of a sweep table and the length of its whole lines (``TableFormat.parse``)."""
    return sweep_format(columns).parse(data, path, torn_ok=torn_ok, previous_ok=previous_ok)


def read_rows(
    path: str | Path, *, previous_ok: bool = False, columns: tuple[str, ...] = COLUMNS
) -> dict[str, bytes]:
    """The rows of a finished sweep table (``parse``), by ``trial_id``."""
    return sweep_format(columns).read_rows(path, previous_ok=previous_ok)


def verdicts(line: bytes) -> tuple[str, str]:
    """(analytic, simulated) verdict of one sweep table line."""
    return SWEEP.fields(line, "analytic_verdict", "simulated_verdict")


class SweepTable:
    """An open partial table: the rows already there (by id) and an appender.

    Use ``SweepTable.open(path)`` as a context manager; ``columns`` (the sweep's
    ``COLUMNS`` or ``CONTROLLER_COLUMNS``) or a ``TableFormat`` for another kind.

    Attributes:
        path: The file.
        fmt: Its ``TableFormat``; columns: its columns.
        created: True when this open made the file (it held no row before).
        rows: id -> the row's line (bytes, newline included).
    """

    def __init__(self, path: Path, fd: int, rows: dict[str, bytes], created: bool, fmt=SWEEP):
        self.path, self._fd, self.rows, self.created = path, fd, rows, created
        self.fmt = fmt if isinstance(fmt, TableFormat) else sweep_format(fmt)
        self.columns = self.fmt.columns

    @classmethod
    @contextlib.contextmanager
    def open(cls, path: str | Path, columns: tuple[str, ...] | TableFormat = COLUMNS):
        """Create (with its header) or reopen the table at ``path``, locked for this process.

        Raises:
            SweepError: another run holds the file, or it is not a table of this format.
        """
        fmt = columns if isinstance(columns, TableFormat) else sweep_format(columns)
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        fd = _locked(path, fmt.kind)
        try:
            size = os.fstat(fd).st_size
            if size == 0:
                os.write(fd, fmt.header)
                rows, created = {}, True
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
            raise SweepError(f"{self.path}: short write (disk full?)")
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
            raise SweepError(f"{path}: another {kind} is writing this table") from None
        try:
            if os.stat(path).st_ino == os.fstat(fd).st_ino:
                return fd
        except FileNotFoundError:
            pass
        os.close(fd)
    raise SweepError(f"{path}: removed as it was opened, three times (another {kind} finishing?)")


def read_table(path: str | Path) -> list[dict]:
    """The rows of a results table with numbers as floats and "none" scaling as "".

    For analysis (``claims.py``); the sweep itself keeps rows as text.
    """
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    out = []
    for row in rows:
        typed = {}
        for key, value in row.items():
            try:
                typed[key] = float(value)
            except ValueError:
                typed[key] = value
        if "mass_scale" in row:  # a sweep table's; other tables have none
            typed["mass_scale"] = "" if row["mass_scale"] == "none" else row["mass_scale"]
        out.append(typed)
    return out
