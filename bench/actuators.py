"""The actuator modes a trial may name: each defined once, here, as data.

A mode says where its position loop's gains come from and whether the plan's torque
is fed forward; ``sim.model.servo_settings`` turns that into joint and actuator
settings for a robot. Everything else that needs the modes (the scene's check, the
``--actuators`` flag, the sweep and envelope files, the envelope's columns, the reports)
reads ``MODES``, ``ACTUATOR_MODES`` or ``actuator_mode``; adding a mode is one line in
``MODES`` (plus its test and the README's flag table).

A leaf of the bench (pure data, no MuJoCo): ``flags`` sits below the simulation and
builds ``--actuators``' choices from it.
"""

from __future__ import annotations

from dataclasses import dataclass

GAIN_SOURCES = {
    "stiff": "the bench's stiff position loop (sim.model.STIFF_KP, STIFF_KV, STIFF_FORCE_LIMIT)",
    "spec": "the robot spec's [servo] table",
}


@dataclass(frozen=True)
class ActuatorMode:
    """One actuator mode.

    Attributes:
        name: What a trial, a flag or a table calls it.
        gains: Where kp, kv and the torque limit come from, a key of ``GAIN_SOURCES``.
        feedforward: The plan's torque (and the soft floor's deflection) fed forward.
        description: One line for the ``--actuators`` help.
    """

    name: str
    gains: str
    feedforward: bool
    description: str

    def __post_init__(self):
        if self.gains not in GAIN_SOURCES:
            raise ValueError(f"gains {self.gains!r}: must be one of {', '.join(GAIN_SOURCES)}")


# The one place the modes are listed (their order is the tables' column order).
MODES = {
    m.name: m
    for m in (
        ActuatorMode("stiff", "stiff", False, "tracks the plan closely"),
        ActuatorMode("servo", "spec", False, "the spec's servo gains and limit"),
        ActuatorMode("stiff_ff", "stiff", True, "stiff, the plan's torque fed forward"),
        ActuatorMode("servo_ff", "spec", True, "servo, the plan's torque fed forward"),
    )
}
ACTUATOR_MODES = tuple(MODES)  # the names, for callers that list them
DEFAULT_MODE = "stiff"  # a trial's mode unless it names one


def actuator_mode(name, error: type[Exception] = ValueError, label: str = "actuators"):
    """The registered mode called ``name``.

    Raises:
        error: ``name`` is no mode, in one line: ``{label} {name!r}: must be one of ...``.
    """
    mode = MODES.get(name) if isinstance(name, str) else None
    if mode is None:
        raise error(f"{label} {name!r}: must be one of {', '.join(MODES)}")
    return mode


def modes_where(*, gains: str | None = None, feedforward: bool | None = None) -> tuple[str, ...]:
    """Names of the modes with these ``gains`` and ``feedforward`` (None: any), in order."""
    return tuple(
        m.name
        for m in MODES.values()
        if gains in (None, m.gains) and feedforward in (None, m.feedforward)
    )
