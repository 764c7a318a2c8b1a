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

``SPEC`` is the one list of the columns, each a ``Column``: where its value comes from
(an input of the trial, an attribute of its ``TrialResult``, or a function of the result
and its plan), its unit scale and its decimals; ``COLUMNS``, ``DECIMALS`` and
``outcome_columns`` (a trial's row) derive from it. A new column is one ``Column`` here
(and, as ever, the previous layout added to ``PREVIOUS_LAYOUTS``).

``SWEEP``, ``SWEEP_CONTROLLER``, ``SWEEP_NOISE`` and ``SWEEP_GAIT`` are the sweep's
``TableFormat``s (without, with a controller column, with a command-noise column, with
the gait's columns of a sweep of drawn or given gaits); the module-level
functions below are their methods. A finished table of an older version
(``PREVIOUS_LAYOUTS``: its columns had a ``wall_s``, or lacked the fidelity columns, the
simulated tilt or the strict walk columns) is replaced by a fresh run (``--resume`` refuses it).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from slopewalk.bench.sim.events import VERDICTS
from slopewalk.bench.sim.walk_check import WALK_VERDICTS
from slopewalk.bench.tables.table import TableFormat
from slopewalk.bench.tables.table import text as _text
from slopewalk.planner.verdict import PAPER_VERDICTS

DEG = 180 / math.pi  # rad → deg: ``np.rad2deg``'s factor, bit for bit
MM = 1e3  # m → mm


def walks(verdict: str) -> bool:
    """Whether a verdict column's value (``analytic_verdict``, ``compliant_verdict``,
    ``predicted_verdict`` or ``simulated_verdict``) says the robot walked: ``stable``."""
    return verdict == "stable"


@dataclass(frozen=True)
class Column:
    """One column of the sweep table: where its value comes from and how it is written.

    Attributes:
        name: The header's name.
        source: None for an input (``SweepTrial.inputs``); an attribute of the trial's
            ``TrialResult``; or a function (result, plan) → value.
        scale: Unit factor applied to the source's value (e.g. ``MM``: m → mm), the
            scaled value a float.
        decimals: Digits after the point, for an outcome written at a fixed precision
            (module doc); None: as ``table.text`` writes it.
    """

    name: str
    source: str | Callable[[Any, Any], Any] | None = None
    scale: float | None = None
    decimals: int | None = None

    def value(self, result, plan):
        """This outcome column's value for a ``TrialResult`` and its ``Plan``."""
        if self.source is None:
            raise ValueError(f"{self.name}: an input, not an outcome")
        if isinstance(self.source, str):
            value = getattr(result, self.source)
        else:
            value = self.source(result, plan)
        return value if self.scale is None else float(value * self.scale)


def _kinds(events) -> str:
    """Event kinds in order of first occurrence, ";"-joined."""
    return ";".join(dict.fromkeys(e.kind for e in events))


def _in_time(result) -> list:
    return sorted(result.events, key=lambda e: e.time)


def _first_time(result, _plan):
    events = _in_time(result)
    return float(events[0].time) if events else None


SPEC = (
    # inputs
    Column("trial_id"),
    Column("step_time"),  # [s]
    Column("slope_deg"),
    Column("friction"),
    Column("actuators"),
    Column("robot"),
    Column("mass_scale"),  # "none", "legs=2", "all=10;legs=2"
    Column("steps"),
    Column("seed"),
    # outcome
    Column("analytic_verdict", "analytic_verdict"),  # ANALYTIC_VERDICTS
    Column("simulated_verdict", "simulated_verdict"),  # SIMULATED_VERDICTS
    Column("slip_predicted", lambda r, _: bool(r.slip_predicted)),
    Column("events", lambda r, _: _kinds(_in_time(r))),  # kinds in order of first occurrence
    Column("first_event_time_s", _first_time, decimals=4),
    Column("zmp_rms_mm", "zmp_rms", MM, 4),
    Column("zmp_max_mm", "zmp_max", MM, 4),
    Column("lipm_rms_mm", "lipm_rms", MM, 4),  # analytic multibody ZMP vs LIPM ZMP, RMS
    Column("cop_lipm_rms_mm", "cop_lipm_rms", MM, 4),  # simulated CoP vs LIPM ZMP, standing
    Column("analytic_min_margin_mm", "analytic_min_margin", MM, 4),
    Column("simulated_min_margin_mm", "simulated_min_margin", MM, 4),
    Column("max_friction_ratio", "max_friction_ratio", decimals=6),
    Column("simulated_max_friction_ratio", "simulated_max_friction_ratio", decimals=6),
    Column("tracking_rms_deg", "tracking_rms", DEG, 5),
    Column("peak_torque_planned_Nm", "peak_torque_planned", decimals=6),
    Column("peak_torque_simulated_Nm", "peak_torque_simulated", decimals=6),
    Column("work_J", lambda _, plan: float(plan.work.sum()), decimals=7),  # planned joint work
    Column("standing_fraction", "standing_fraction", decimals=6),
    Column("sim_steps", lambda r, _: int(r.sim_steps)),
    # fidelity (bench/sim/prediction.py, bench/sim/support.py)
    Column("compliant_verdict", "compliant_verdict"),  # the paper's test on the servos' walk
    Column("compliant_min_margin_mm", "compliant_min_margin", MM, 4),
    Column("predicted_verdict", "predicted_verdict"),  # the most severe predicted event
    Column("predicted_events", lambda r, _: _kinds(r.predicted_events)),
    Column("predicted_rotation_deg", "predicted_rotation", DEG, 5),  # of the support, largest
    Column("simulated_max_tilt_deg", "simulated_max_tilt", DEG, 5),  # of a loaded foot, largest
    Column("unplanned_support_s", "unplanned_support_s", decimals=4),  # foot-time off the plan
    # the strict walk verdict (bench/sim/walk_check.py) and its measures, then the plan's
    # prediction of it (planner/walk_prediction.py)
    Column("walk", "walk_verdict"),  # WALK_VERDICTS, or the balance verdict when not stable
    Column("landing_error_mm", "landing_error", MM, 4),  # largest, off the planned footprint
    Column("landing_heading_error_deg", "landing_heading_error", DEG, 5),  # largest
    Column("swing_touch_s", "swing_touch", decimals=4),  # longest in one single support
    Column("pelvis_end_error_mm", "pelvis_end_error", MM, 4),  # vs the plan's end pose
    Column("torque_ratio", "torque_ratio", decimals=6),  # peak |actuator torque| / stall
    Column("predicted_walk", "predicted_walk_verdict"),  # overload / shuffle from the plan
    Column("predicted_torque_ratio", "predicted_torque_ratio", decimals=6),  # planned |τ|
    Column("predicted_swing_touch_s", "predicted_swing_touch", decimals=4),
    # the one-line message of a trial that raised or killed its worker, else empty
    Column("error", lambda _r, _p: ""),
)
COLUMNS = tuple(c.name for c in SPEC)
OUTCOMES = tuple(c for c in SPEC if c.source is not None)
# a trial that raised has the verdicts "error"
ANALYTIC_VERDICTS = (*PAPER_VERDICTS, "error")
SIMULATED_VERDICTS = (*VERDICTS, "error")
# the strict walk verdict: walked, a failed check, or the balance verdict when not stable
WALK_COLUMN_VERDICTS = (*WALK_VERDICTS, *SIMULATED_VERDICTS[1:])
DECIMALS = {c.name: c.decimals for c in SPEC if c.decimals is not None}  # (module doc)
HEADER = (",".join(COLUMNS) + "\n").encode()
# A sweep that names a controller somewhere: one more input, last, so every other
# column keeps its place ("none" for a trial played open loop).
CONTROLLER_COLUMNS = (*COLUMNS, "controller")
CONTROLLER_HEADER = (",".join(CONTROLLER_COLUMNS) + "\n").encode()
# A sweep with command noise: its σ [deg], as written in the sweep file, last likewise
NOISE_COLUMNS = (*COLUMNS, "command_noise_deg")
# A sweep of drawn or given gaits ([draw], envelope): the gait's source and parameters
# (``SweepTrial.gait_inputs``), last likewise
GAIT_COLUMNS = ("gait", "hip_height_m", "swing_lift_m", "tilt_deg", "pelvis_offset_m",
                "step_length_m", "sway_share")  # fmt: skip
GAIT_TABLE_COLUMNS = (*COLUMNS, *GAIT_COLUMNS)
# A sweep of given gaits with command noise (envelope and command_noise): both, noise last
GAIT_NOISE_COLUMNS = (*GAIT_TABLE_COLUMNS, "command_noise_deg")
GAIT_DECIMALS = {"hip_height_m": 7, "swing_lift_m": 7, "tilt_deg": 5, "pelvis_offset_m": 7,
                 "step_length_m": 7, "sway_share": 7}  # fmt: skip
_FIDELITY = COLUMNS.index("compliant_verdict")  # the columns before it are the older versions'
# before fixed precision: a wall time, and no fidelity columns
PREVIOUS_COLUMNS = (*COLUMNS[:_FIDELITY], "wall_s", "error")
PREVIOUS_HEADER = (",".join(PREVIOUS_COLUMNS) + "\n").encode()
_STRICT = COLUMNS.index("walk")  # the columns before it are the older versions'
_BEFORE_WALK = (*COLUMNS[:_STRICT], "error")  # before the strict walk verdict (issue 21)
_BEFORE_TILT = tuple(c for c in _BEFORE_WALK if c != "simulated_max_tilt_deg")  # before 2026-12
# every finished layout an older slopewalk wrote, which a fresh run may replace:
# the one with a wall time, then fixed precision without the fidelity columns
# (with and without the controller column)
PREVIOUS_LAYOUTS = (
    PREVIOUS_COLUMNS,
    (*COLUMNS[:_FIDELITY], "error"),
    (*COLUMNS[:_FIDELITY], "error", "controller"),
    _BEFORE_TILT,
    (*_BEFORE_TILT, "controller"),
    _BEFORE_WALK,
    (*_BEFORE_WALK, "controller"),
    (*_BEFORE_WALK, "command_noise_deg"),
    (*_BEFORE_WALK, *GAIT_COLUMNS),
)


_SWEEP_VERDICTS = {
    "analytic_verdict": ANALYTIC_VERDICTS,
    "simulated_verdict": SIMULATED_VERDICTS,
    "walk": WALK_COLUMN_VERDICTS,
}
_LAYOUTS = {
    COLUMNS: "a sweep without a controller or command_noise key",
    CONTROLLER_COLUMNS: "a sweep with a controller key",
    NOISE_COLUMNS: "a sweep with a command_noise key",
    GAIT_TABLE_COLUMNS: "a sweep with a draw or envelope key",
    GAIT_NOISE_COLUMNS: "a sweep with an envelope and a command_noise key",
}


def _sweep_layout(columns: tuple[str, ...]) -> TableFormat:
    others = tuple(
        (other, f"its columns are those of {what}")
        for other, what in _LAYOUTS.items()
        if other != columns
    )
    decimals = DECIMALS | GAIT_DECIMALS if set(GAIT_COLUMNS) <= set(columns) else DECIMALS
    return TableFormat("sweep", columns, decimals, _SWEEP_VERDICTS, PREVIOUS_LAYOUTS, others)


SWEEP = _sweep_layout(COLUMNS)
SWEEP_CONTROLLER = _sweep_layout(CONTROLLER_COLUMNS)
SWEEP_NOISE = _sweep_layout(NOISE_COLUMNS)
SWEEP_GAIT = _sweep_layout(GAIT_TABLE_COLUMNS)
SWEEP_GAIT_NOISE = _sweep_layout(GAIT_NOISE_COLUMNS)


def sweep_format(columns: tuple[str, ...] = COLUMNS) -> TableFormat:
    """The sweep's ``TableFormat`` of ``columns`` (``COLUMNS``, ``CONTROLLER_COLUMNS`` or
    ``NOISE_COLUMNS``)."""
    for fmt in (SWEEP, SWEEP_CONTROLLER, SWEEP_NOISE, SWEEP_GAIT, SWEEP_GAIT_NOISE):
        if tuple(columns) == fmt.columns:
            return fmt
    return TableFormat("sweep", tuple(columns), DECIMALS, _SWEEP_VERDICTS, PREVIOUS_LAYOUTS)


SPEC_END_COLUMNS = ("spec_end",)  # a sweep with spec_ends: the spec end each row was played at
NOMINAL = "nominal"  # its value for a row played on the spec's own values


def spec_end_format(fmt: TableFormat) -> TableFormat:
    """``fmt`` of a sweep with ``spec_ends`` (``sweep/config.py``): the ``spec_end`` column
    after every other (``"nominal"``, ``"KEY:low"``, ``"KEY:high"``), so each column of
    ``fmt`` keeps its place; the same sweep's table without it is refused as such."""
    return replace(
        fmt,
        columns=(*fmt.columns, *SPEC_END_COLUMNS),
        siblings=((fmt.columns, "its rows were played on the nominal spec alone"), *fmt.siblings),
        previous_layouts=(),
    )


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


def outcome_columns(result, plan) -> dict:
    """The outcome columns of a row (``OUTCOMES``) from a ``TrialResult`` and its ``Plan``."""
    return {c.name: c.value(result, plan) for c in OUTCOMES}


def verdicts(line: bytes) -> tuple[str, str]:
    """(analytic, simulated) verdict of one sweep table line."""
    analytic, simulated = SWEEP.fields(line, "analytic_verdict", "simulated_verdict")
    return analytic, simulated
