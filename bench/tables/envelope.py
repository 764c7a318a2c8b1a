"""The envelope table's columns: one row per cell, a column group per gait and mode.

``ENVELOPE`` is the ``table.TableFormat`` of ``envelope.csv``: the cell's
inputs, then per gait (``GAITS``: max-margin, min-work) whether the GA found it,
its margins (GA and 1 ms), work and parameters (``GAIT_COLUMNS``, the extended
family's ``EXTENDED_COLUMNS`` after its tilt), then one balance verdict and ZMP RMS pair
per gait and actuator mode of ``slopewalk.bench.sim.model.ACTUATOR_MODES`` (``sim_columns``),
so a mode the bench gains joins the table by itself, then, after ``ga_evaluations`` and
``error``, the strict walk verdict per gait and mode (``walk_column``,
``bench/sim/walk_check.py``; ``walks`` reads it). With controllers,
``envelope_format(controllers)`` appends their pairs, then their walk columns, after every
other column, so each open-loop column keeps its place. ``envelope/cell.py`` fills a row.
"""

from __future__ import annotations

from slopewalk.bench.sim.model import ACTUATOR_MODES
from slopewalk.bench.tables.sweep import SIMULATED_VERDICTS, WALK_COLUMN_VERDICTS
from slopewalk.bench.tables.table import TableFormat

GAITS = ("maxmargin", "minwork")
GAIT_COLUMNS = ("found", "margin_mm", "margin_1ms_mm", "work_J", "hip_height_m",
                "swing_lift_m", "tilt_deg")  # fmt: skip
# the extended family's parameters (a paper row has its walk's: 0, the nominal L, w of "hold")
EXTENDED_COLUMNS = ("pelvis_offset_m", "step_length_m", "sway_share")


def sim_columns(gait: str, mode: str, tag: str = "") -> tuple[str, str]:
    """(verdict, ZMP RMS) column names of ``gait`` played in ``mode``, open loop or with
    the controller of ``tag`` (``controller_tag``)."""
    policy = f"{mode}_{tag}" if tag else mode
    return f"{gait}_{policy}_verdict", f"{gait}_{policy}_zmp_rms_mm"


def walk_column(gait: str, mode: str, tag: str = "") -> str:
    """The strict walk verdict column (``bench/sim/walk_check.py``) of ``gait`` played in
    ``mode``, open loop or with the controller of ``tag``."""
    policy = f"{mode}_{tag}" if tag else mode
    return f"{gait}_{policy}_walk"


def walks(row: dict, gait: str, mode: str, tag: str = "") -> bool | None:
    """Whether ``gait`` walks in ``mode`` (with ``tag``'s controller) in an envelope row: its
    strict walk verdict is ``walked``; in a table written before that column, its balance
    verdict is ``stable``. None: not played."""
    strict = row.get(walk_column(gait, mode, tag))
    if strict:
        return strict == "walked"
    balance = row.get(sim_columns(gait, mode, tag)[0])
    return balance == "stable" if balance else None


def controller_tag(name: str) -> str:
    """The column tag of controller ``MODULE:CALLABLE``: its callable's name, dots as
    underscores (``ankle_cop_feedback``)."""
    return name.partition(":")[2].replace(".", "_")


def controller_columns(controllers: tuple[str, ...]) -> tuple[str, ...]:
    """The (verdict, ZMP RMS) columns the controllers add to the table, in every mode."""
    tags = [controller_tag(c) for c in controllers]
    return tuple(
        c for g in GAITS for m in ACTUATOR_MODES for t in tags for c in sim_columns(g, m, t)
    )


def controller_walk_columns(controllers: tuple[str, ...]) -> tuple[str, ...]:
    """The strict walk columns the controllers add to the table, in every mode."""
    tags = [controller_tag(c) for c in controllers]
    return tuple(walk_column(g, m, t) for g in GAITS for m in ACTUATOR_MODES for t in tags)


_V1_COLUMNS = (
    "cell_id",
    "step_time",  # [s], as written in the envelope file
    "slope_deg",
    "friction",
    "robot",
    "family",
    "steps",
    "population",
    "generations",
    "seed",
    "required_margin_mm",
    "feasible",  # the max-margin gait has its ZMP inside and every joint within limits
    *(f"{g}_{c}" for g in GAITS for c in GAIT_COLUMNS),
    *(c for g in GAITS for m in ACTUATOR_MODES for c in sim_columns(g, m)),
    "ga_evaluations",
    "error",
)
# The second version's columns: the first (paper family only) with each gait's (δ, L, w)
# after its tilt.
_V2_COLUMNS = tuple(
    c
    for col in _V1_COLUMNS
    for c in (
        (col, *(f"{col.removesuffix('_tilt_deg')}_{e}" for e in EXTENDED_COLUMNS))
        if col.endswith("_tilt_deg")
        else (col,)
    )
)
# Columns: the second version's, then the strict walk verdict per gait and mode (issue 21)
WALK_COLUMNS = tuple(walk_column(g, m) for g in GAITS for m in ACTUATOR_MODES)
COLUMNS = (*_V2_COLUMNS, *WALK_COLUMNS)
DECIMALS = {
    **{f"{g}_{c}": 4 for g in GAITS for c in ("margin_mm", "margin_1ms_mm")},
    **{f"{g}_work_J": 7 for g in GAITS},
    **{f"{g}_{c}": 7 for g in GAITS for c in ("hip_height_m", "swing_lift_m")},
    **{f"{g}_tilt_deg": 5 for g in GAITS},
    **{f"{g}_{c}": 7 for g in GAITS for c in EXTENDED_COLUMNS},
    **{sim_columns(g, m)[1]: 4 for g in GAITS for m in ACTUATOR_MODES},
}
VERDICTS = ("", *SIMULATED_VERDICTS)  # "": not played (nothing found, or mode not asked)
WALK_VERDICTS = ("", *WALK_COLUMN_VERDICTS)  # likewise
ENVELOPE = TableFormat(
    "envelope",
    COLUMNS,
    DECIMALS,
    {"feasible": ("True", "False", "")}
    | {sim_columns(g, m)[0]: VERDICTS for g in GAITS for m in ACTUATOR_MODES}
    | dict.fromkeys(WALK_COLUMNS, WALK_VERDICTS),
    previous_layouts=(_V1_COLUMNS, _V2_COLUMNS),
)


def envelope_format(controllers: tuple[str, ...] = ()) -> TableFormat:
    """The table of an envelope whose gaits are also walked by ``controllers``: ``ENVELOPE``
    and, after its columns, a verdict and ZMP RMS column pair per gait, mode and controller.

    Raises:
        ValueError: two controllers whose columns would share a name.
    """
    if not controllers:
        return ENVELOPE
    extra = controller_columns(controllers)
    strict = controller_walk_columns(controllers)
    if len(set(extra) | set(COLUMNS) | set(strict)) != len(extra) + len(COLUMNS) + len(strict):
        raise ValueError(
            f"controllers {', '.join(controllers)}: their callables' names "
            f"({', '.join(controller_tag(c) for c in controllers)}) must differ (they name the "
            "table's columns)"
        )
    verdicts, rms = extra[0::2], extra[1::2]
    return TableFormat(
        "envelope",
        (*COLUMNS, *extra, *strict),
        DECIMALS | dict.fromkeys(rms, 4),
        ENVELOPE.verdicts
        | dict.fromkeys(verdicts, VERDICTS)
        | dict.fromkeys(strict, WALK_VERDICTS),
        siblings=((COLUMNS, "its columns are those of an envelope without a controller key"),),
    )


REPLAN_NOTE = "not re-plannable:"  # the error of a gait passed over, not of a failed cell


def is_failure(error) -> bool:
    """Whether a row's ``error`` is a failed cell (not a recording or re-plan note)."""
    text = str(error or "")
    return bool(text) and not text.startswith(("recording failed", REPLAN_NOTE))
