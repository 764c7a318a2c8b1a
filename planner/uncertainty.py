"""What the robot spec only estimates: a range per estimated value, and the spec at either end.

A robot spec may carry an ``[uncertain]`` table (``docs/robot-spec.md``): for each value
the spec only estimates (the Bioloid's foot width, link masses and CoM heights, the
brackets' joint limits, the servo's constants), the interval ``[low, high]`` it is believed
to lie in, in the value's own SI unit, with its basis in a comment. The table is read
apart from the spec's numbers (``RobotSpec`` has no field for it), so a spec with it is the
same robot, with the same ids, as one without.

Keys address one number of the spec, dotted as the TOML tables are:

* ``geometry.<key>`` (e.g. ``geometry.foot_width``) [m];
* ``links.<link>.mass`` [kg] (the link's inertia scales with it: a heavier part of the
  same shape), ``links.<link>.com.x|y|z`` [m];
* ``joint_limits.<kind>.lower|upper`` [rad];
* ``servo.<key>`` (e.g. ``servo.stall_torque``) in its unit; ``servo.damping`` [N m s/rad]
  is the joint's viscous damping (the motor's back-EMF, stall_torque / no_load_speed, where
  the spec's ``[servo]`` gives none);
* ``contact.timeconst`` [s], ``contact.dampratio`` [-]: the soles' contact with the floor
  (the spec's ``[contact]``, MuJoCo's ``solref``; its defaults where the spec has none).

Each range must hold the spec's own value (``low ≤ value ≤ high``, ``low < high``) and
each end must make a valid spec; anything else is refused in one line naming the key,
the range and what is allowed.

``spec_at(spec, key, value)`` is the spec with that one value replaced: the bands of
``bench/experiments/envelope/bands.py`` move one value at a time to each end of its range.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from slopewalk.planner.config_file import load_toml
from slopewalk.planner.errors import SpecError
from slopewalk.planner.ranges import show
from slopewalk.planner.spec import (
    CONTACT,
    DAMPING,
    GEOMETRY_KEYS,
    JOINT_LIMIT_KEYS,
    LINK_NAMES,
    OPTIONAL_SERVO,
    SERVO,
    LinkInertial,
    RobotSpec,
    default_spec_path,
)

TABLE = "uncertain"
_AXES = ("x", "y", "z")
_ENDS = ("lower", "upper")


@dataclass(frozen=True)
class Uncertain:
    """One estimated value of a spec and the interval it is believed to lie in.

    Attributes:
        key: Dotted name of the value (module doc), e.g. ``geometry.foot_width``.
        low, high: The interval's ends, in ``unit``; low < high.
        nominal: The spec's own value, in [low, high].
        unit: SI unit of the value ("m", "kg", "rad", "N m", ...).
    """

    key: str
    low: float
    high: float
    nominal: float
    unit: str

    def ends(self) -> tuple[tuple[str, float], tuple[str, float]]:
        """(("low", low), ("high", high))."""
        return (("low", self.low), ("high", self.high))


def known_keys(spec: RobotSpec) -> tuple[str, ...]:
    """Every key an ``[uncertain]`` table may name for ``spec`` (module doc)."""
    keys = [f"geometry.{k}" for k in GEOMETRY_KEYS]
    for link in LINK_NAMES:
        keys += [f"links.{link}.mass", *(f"links.{link}.com.{a}" for a in _AXES)]
    keys += [f"joint_limits.{kind}.{end}" for kind in JOINT_LIMIT_KEYS for end in _ENDS]
    keys += [f"servo.{k}" for k in (*SERVO, *OPTIONAL_SERVO)]
    keys += [f"contact.{k}" for k in CONTACT]
    return tuple(keys)


def value_of(spec: RobotSpec, key: str) -> tuple[float, str]:
    """The spec's value of ``key`` and its unit."""
    part = key.split(".")
    if part[0] == "geometry":
        return float(getattr(spec, part[1])), "m"
    if part[0] == "links":
        link = spec.links[part[1]]
        if part[2] == "mass":
            return link.mass, "kg"
        return link.com[_AXES.index(part[3])], "m"
    if part[0] == "joint_limits":
        return spec.joint_limits[part[1]][_ENDS.index(part[2])], "rad"
    if part[0] == "contact":
        return float(getattr(spec, f"contact_{part[1]}")), CONTACT[part[1]].unit
    if key == "servo.damping":  # the back-EMF's where the spec gives none
        return spec.joint_damping, DAMPING.unit
    return float(getattr(spec, part[1])), SERVO[part[1]].unit


def spec_at(spec: RobotSpec, key: str, value: float) -> RobotSpec:
    """A copy of ``spec`` with the one value ``key`` set to ``value`` (its SI unit).

    A link's mass scales its inertia by the same factor (the same part, heavier). The
    copy is checked as any spec is (``SpecError`` for a value it refuses). At the spec's
    own value it is ``spec`` itself (a damping the back-EMF implies stays implied).
    """
    if key not in known_keys(spec):
        raise SpecError(f"{TABLE}.{key}: not a value of the spec")
    if value_of(spec, key)[0] == value:  # e.g. the back-EMF's damping stays implied
        return spec
    part = key.split(".")
    if part[0] in ("geometry", "servo", "contact"):
        field = f"contact_{part[1]}" if part[0] == "contact" else part[1]
        changes: dict[str, Any] = {field: float(value)}
        return replace(spec, **changes)
    if part[0] == "links":
        link = spec.links[part[1]]
        if part[2] == "mass":
            factor = value / link.mass
            ixx, iyy, izz = link.inertia
            new = LinkInertial(
                link.name, float(value), link.com, (ixx * factor, iyy * factor, izz * factor)
            )
        else:
            com = list(link.com)
            com[_AXES.index(part[3])] = float(value)
            new = LinkInertial(link.name, link.mass, (com[0], com[1], com[2]), link.inertia)
        return replace(spec, links={**spec.links, part[1]: new})
    pair = list(spec.joint_limits[part[1]])
    pair[_ENDS.index(part[2])] = float(value)
    return replace(spec, joint_limits={**spec.joint_limits, part[1]: (pair[0], pair[1])})


def uncertain_values(spec: RobotSpec, table: Any) -> tuple[Uncertain, ...]:
    """The ``[uncertain]`` table of ``spec``'s file, checked, in file order.

    Args:
        table: The parsed table: dotted keys as nested tables or as quoted keys, each
            leaf a list ``[low, high]``.

    Raises:
        SpecError: one line naming the key and what is wrong (module doc).
    """
    if not isinstance(table, dict):
        raise SpecError(f"{TABLE} = {table!r}: must be a table [{TABLE}]")
    known = known_keys(spec)
    out = []
    for key, pair in _leaves(table, ""):
        name = f"{TABLE}.{key}"
        if key not in known:
            raise SpecError(
                f"unknown key {name}: not an estimated value of the spec (known: "
                "geometry.<key>, links.<link>.mass, links.<link>.com.x|y|z, "
                "joint_limits.<kind>.lower|upper, servo.<key>, contact.timeconst|dampratio)"
            )
        nominal, unit = value_of(spec, key)
        if not (
            isinstance(pair, list)
            and len(pair) == 2
            and all(isinstance(v, int | float) and not isinstance(v, bool) for v in pair)
        ):
            raise SpecError(
                f"{name} {show(pair)}: must be a list [low, high] of 2 numbers [{unit}]"
            )
        low, high = float(pair[0]), float(pair[1])
        if not low < high:
            raise SpecError(f"{name} [{low:g}, {high:g}] {unit}: low must be < high")
        if not low <= nominal <= high:
            raise SpecError(
                f"{name} [{low:g}, {high:g}] {unit}: must hold the spec's value "
                f"{nominal:g} {unit} (low <= value <= high)"
            )
        for end, value in (("low", low), ("high", high)):
            try:
                spec_at(spec, key, value)
            except SpecError as err:
                raise SpecError(f"{name} {end} end {value:g} {unit}: {err}") from None
        out.append(Uncertain(key, low, high, nominal, unit))
    return tuple(out)


def _leaves(table: dict, prefix: str):
    """(dotted key, value) of every non-table value under ``table``, in order."""
    for key, value in table.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            yield from _leaves(value, f"{name}.")
        else:
            yield name, value


def load_uncertainty(path: str | Path | None = None) -> tuple[Uncertain, ...]:
    """The checked ``[uncertain]`` table of a spec file (default: the paper's biped); ()
    when the file has none.

    Raises:
        SpecError: as ``load_spec``, and for a bad range (``uncertain_values``), in one
            line naming the file.
    """
    from slopewalk.planner.spec import spec_from_dict

    path = Path(path) if path is not None else default_spec_path()
    data = load_toml(path, where=f"robot spec {str(path)!r}", kind="a TOML file", error=SpecError)
    spec = spec_from_dict(data, source=str(path))
    if TABLE not in data:
        return ()
    try:
        return uncertain_values(spec, data[TABLE])
    except SpecError as err:
        raise SpecError(f"robot spec {str(path)!r}: {err}") from None
