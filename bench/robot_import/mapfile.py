"""The map file of ``slopewalk robot import``: what detection cannot decide, named by the user.

A TOML file, every table optional::

    name = "my-robot"            # the spec's name (default: the model's name)
    base = "torso"               # the body above the legs (default: the model's root body)
    [feet]                       # the foot bodies (default: the bodies lowest at the zero pose)
    left = "l_foot"
    right = "r_foot"
    [joints.left]                # the four planned joints of a leg (default: found by axis)
    hip_pitch = "l_hip_pitch"
    knee = "l_knee"
    ankle_pitch = "l_ankle_pitch"
    ankle_roll = "l_ankle_roll"
    [joints.right]               # the same for the right leg
    [held]                       # other joints' held angles [rad] (default: the model's zero)
    l_shoulder = 0.0
    [servo]                      # the spec's [servo] keys, where the model's actuators
    stall_torque = 4.0           # do not say (motors only, e.g. a URDF)

Every joint not planned is held at its ``[held]`` angle; lengths in m, angles in rad.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from slopewalk.planner.config_file import load_toml
from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.spec import JOINT_LIMIT_KEYS, SERVO

SIDES = ("left", "right")
MAP_KEYS = ("name", "base", "feet", "joints", "held", "servo")


class RobotImportError(SlopewalkError):
    """A model or map file that does not fit the planner, refused in one line."""


@dataclass(frozen=True)
class RobotMap:
    """What the user named (``None`` / empty: detect it)."""

    name: str | None = None
    base: str | None = None
    feet: dict[str, str] = field(default_factory=dict)
    joints: dict[str, dict[str, str]] = field(default_factory=dict)
    held: dict[str, float] = field(default_factory=dict)
    servo: dict[str, float] = field(default_factory=dict)


def load_map(path: str | Path | None) -> RobotMap:
    """Read a map file (module doc); None: an empty map (detect everything)."""
    if path is None:
        return RobotMap()
    where = f"map file {str(path)!r}"
    data = load_toml(Path(path), where=where, kind="a TOML file", error=RobotImportError)
    try:
        return _parse(data)
    except RobotImportError as err:
        raise RobotImportError(f"{where}: {err}") from None


def _parse(data: dict[str, Any]) -> RobotMap:
    _known(data, MAP_KEYS, "")
    for key in ("name", "base"):
        if key in data and not isinstance(data[key], str):
            raise RobotImportError(f"{key} {data[key]!r}: must be a string")
    feet = _strings(data.get("feet", {}), SIDES, "feet.")
    joints_table = data.get("joints", {})
    _known(_table(joints_table, "joints"), SIDES, "joints.")
    joints = {
        side: _strings(joints_table.get(side, {}), JOINT_LIMIT_KEYS, f"joints.{side}.")
        for side in SIDES
        if side in joints_table
    }
    held = {}
    for name, value in _table(data.get("held", {}), "held").items():
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise RobotImportError(f"held.{name} {value!r}: must be an angle in rad")
        held[name] = float(value)
    servo_table = _table(data.get("servo", {}), "servo")
    _known(servo_table, tuple(SERVO), "servo.")
    servo = {}
    for key, value in servo_table.items():
        SERVO[key].check(f"servo.{key}", value, RobotImportError)
        servo[key] = float(value)
    return RobotMap(data.get("name"), data.get("base"), feet, joints, held, servo)


def _table(value: Any, where: str) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise RobotImportError(f"{where} {value!r}: must be a table [{where}]")
    return value


def _strings(value: Any, allowed: tuple[str, ...], prefix: str) -> dict[str, str]:
    table = _table(value, prefix.rstrip("."))
    _known(table, allowed, prefix)
    for key, name in table.items():
        if not isinstance(name, str):
            raise RobotImportError(f"{prefix}{key} {name!r}: must be a name (string)")
    return dict(table)


def _known(table: dict[str, Any], allowed: tuple[str, ...], prefix: str) -> None:
    for key in table:
        if key not in allowed:
            raise RobotImportError(f"unknown key {prefix}{key} (known: {', '.join(allowed)})")
