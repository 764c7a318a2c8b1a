"""The sweep table: one CSV row per finished trial, appended whole, so a killed sweep resumes.

Atomicity: the file is opened once with ``O_APPEND``; the header is written when
the file is created (or found empty), and each row is formatted completely and
written with a single ``os.write``, so a reader or a crash sees whole rows only
(a kernel append is all-or-nothing for a small write). The one exception, a
crash of the machine inside that write, can leave a last line without its
newline; opening the table again cuts that torn line off, and its trial runs
again. An exclusive ``flock`` keeps a second sweep from writing the same file
at the same time.

Values: floats are written with ``repr`` (exact round trip, ``nan`` for
not-a-number), booleans as ``True``/``False``, a missing value as an empty
field; pandas and polars read the file as it is.
"""

from __future__ import annotations

import contextlib
import csv
import fcntl
import io
import os
from collections.abc import Iterable
from pathlib import Path

from bench.experiments.sweep_config import SweepError
from bench.files import atomic_path

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
    "wall_s",  # plan + simulation + comparison, in the worker
    "error",  # the one-line message of a trial that raised, else empty
)


def format_row(row: dict) -> bytes:
    """One complete CSV line (newline included) of ``row``'s ``COLUMNS``."""
    buffer = io.StringIO()
    csv.writer(buffer, lineterminator="\n").writerow(_text(row.get(c)) for c in COLUMNS)
    return buffer.getvalue().encode()


def _text(value) -> str:
    if value is None:
        return ""
    if isinstance(value, float):  # np.float64 too: its repr is not a plain number
        return repr(float(value))
    return " ".join(str(value).split()) if isinstance(value, str) else str(value)


class SweepTable:
    """An open ``sweep.csv``: the rows already there (by ``trial_id``) and an appender.

    Use ``SweepTable.open(path)`` as a context manager.
    """

    def __init__(self, path: Path, fd: int, rows: dict[str, dict[str, str]]):
        self.path = path
        self._fd = fd
        self.rows = rows  # trial_id -> row (strings as read, or as appended)

    @classmethod
    @contextlib.contextmanager
    def open(cls, path: str | Path):
        """Create (with its header) or reopen the table at ``path``, locked for this process.

        Raises:
            SweepError: another sweep holds the file, or it is not a sweep table
                of these columns.
        """
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(path, os.O_RDWR | os.O_APPEND | os.O_CREAT, 0o644)
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                raise SweepError(f"{path}: another sweep is writing this table") from None
            rows = _read_rows(fd, path)
            yield cls(path, fd, rows)
        finally:
            os.close(fd)

    def append(self, row: dict) -> None:
        """Append one finished trial's row: a single write of the whole line."""
        line = format_row(row)
        if os.write(self._fd, line) != len(line):  # only on a full disk
            raise SweepError(f"{self.path}: short write (disk full?)")
        self.rows[row["trial_id"]] = {c: _text(row.get(c)) for c in COLUMNS}

    def replace(self, row: dict) -> None:
        """Take ``row`` in place of the one with its ``trial_id``, on the next ``rewrite``."""
        self.rows[row["trial_id"]] = {c: _text(row.get(c)) for c in COLUMNS}

    def rewrite(self, order: Iterable[str]) -> None:
        """Replace the file by its rows in ``order`` (ids first, the rest after), atomically."""
        ids = list(dict.fromkeys([i for i in order if i in self.rows] + list(self.rows)))
        with atomic_path(self.path) as tmp:
            with open(tmp, "w", newline="") as f:
                writer = csv.writer(f, lineterminator="\n")
                writer.writerow(COLUMNS)
                writer.writerows([self.rows[i][c] for c in COLUMNS] for i in ids)
            os.chmod(tmp, 0o644)


def _read_rows(fd: int, path: Path) -> dict[str, dict[str, str]]:
    """Rows of an existing table; writes the header into a new (empty) one."""
    size = os.fstat(fd).st_size
    header = format_row(dict(zip(COLUMNS, COLUMNS, strict=True)))
    if size == 0:
        os.write(fd, header)
        return {}
    data = os.pread(fd, size, 0)
    if not data.endswith(b"\n"):  # a torn last line (crash inside a write): drop it
        os.truncate(fd, data.rfind(b"\n") + 1)
        data = data[: data.rfind(b"\n") + 1]
        if not data:
            os.write(fd, header)
            return {}
    lines = list(csv.reader(io.StringIO(data.decode())))
    if tuple(lines[0]) != COLUMNS:
        raise SweepError(
            f"{path}: not a sweep table of this version (its columns differ); choose another --out"
        )
    rows = {}
    for number, fields in enumerate(lines[1:], start=2):
        if len(fields) != len(COLUMNS):
            raise SweepError(f"{path}: line {number} has {len(fields)} fields, not {len(COLUMNS)}")
        row = dict(zip(COLUMNS, fields, strict=True))
        rows[row["trial_id"]] = row
    return rows


def read_table(path: str | Path) -> list[dict]:
    """The rows of a results table with numbers as floats and "none" scaling as "".

    For analysis (``claims.py``); the sweep itself keeps rows as text.
    """
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    out = []
    for row in rows:
        typed = {}
        for key, text in row.items():
            try:
                typed[key] = float(text)
            except ValueError:
                typed[key] = text
        typed["mass_scale"] = "" if row["mass_scale"] == "none" else row["mass_scale"]
        out.append(typed)
    return out
