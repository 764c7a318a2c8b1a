"""The sweep table's columns: one CSV line per finished trial (``tables.table``).

Values, chosen so that regenerating a table from the same trials gives the
same bytes: the inputs (``step_time``, ``slope_deg``, ``friction``) as written
in the sweep file (Python's shortest round-trip ``repr``); each outcome at a
fixed precision well above floating-point noise (last-bit differences between
BLAS builds or summation orders cannot reach it) and below anything physical:
lengths in mm to 0.1 µm (4 decimals), times to 0.1 ms, angles to 1e-5 deg,
torques to 1 µN·m, work to 0.1 µJ, ratios and fractions to 1e-6. ``nan`` is
not-a-number, booleans are ``True``/``False``, a missing value an empty field;
pandas and polars read the file as it is.

``SWEEP``, ``SWEEP_CONTROLLER`` and ``SWEEP_NOISE`` are the sweep's ``TableFormat``s
(without, with a controller column, with a command-noise column); the module-level
functions below are their methods. A finished table of an older version
(``PREVIOUS_LAYOUTS``: its columns had a ``wall_s``, or lacked the fidelity columns or
the simulated tilt) is replaced by a fresh run (``--resume`` refuses it).
"""

from __future__ import annotations

from pathlib import Path

from slopewalk.bench.sim.events import VERDICTS
from slopewalk.bench.tables.table import TableFormat
from slopewalk.bench.tables.table import text as _text
from slopewalk.planner.verdict import PAPER_VERDICTS

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
# a trial that raised has the verdicts "error"
ANALYTIC_VERDICTS = (*PAPER_VERDICTS, "error")
SIMULATED_VERDICTS = (*VERDICTS, "error")
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
    """``value`` of a sweep ``column`` as written in the table (``table.text``)."""
    return _text(column, value, decimals)


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
    analytic, simulated = SWEEP.fields(line, "analytic_verdict", "simulated_verdict")
    return analytic, simulated
