"""RobotSpec: the robot's geometry, link inertials, joint limits and servo, read from TOML.

The spec is the only place robot numbers live; the planner's chain and the MJCF
model are both built from it. Body-frame conventions are documented at the top of
``planner/robots/bioloid.toml``.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from planner.errors import SpecError

LINK_NAMES = ("pelvis", "thigh", "shank", "ankle", "foot")
JOINT_KINDS = ("hip_pitch", "knee", "ankle_pitch", "ankle_roll")
GEOMETRY_KEYS = (
    "thigh",
    "shank",
    "hip_width",
    "ankle_height",
    "ankle_to_toe",
    "foot_length",
    "foot_width",
)


@dataclass(frozen=True)
class LinkInertial:
    """Mass properties of one rigid link.

    Attributes:
        mass: Mass [kg], > 0.
        com: Centre of mass in the link's body frame [m], shape (3,).
        inertia: Principal moments about the CoM along the body axes [kg m²], shape (3,).
    """

    name: str
    mass: float
    com: tuple[float, float, float]
    inertia: tuple[float, float, float]

    def __post_init__(self) -> None:
        if not self.mass > 0:
            raise SpecError(f"links.{self.name}.mass = {self.mass!r}: must be > 0 kg")
        ixx, iyy, izz = self.inertia
        if min(self.inertia) <= 0:
            raise SpecError(
                f"links.{self.name}.inertia = {list(self.inertia)}: "
                "every principal moment must be > 0 (positive definite)"
            )
        if ixx + iyy < izz or iyy + izz < ixx or izz + ixx < iyy:
            raise SpecError(
                f"links.{self.name}.inertia = {list(self.inertia)}: violates the triangle "
                "inequality (each moment must be <= the sum of the other two)"
            )

    @property
    def inertia_matrix(self) -> np.ndarray:
        """Inertia tensor about the CoM in body axes [kg m²], shape (3, 3)."""
        return np.diag(self.inertia)


@dataclass(frozen=True)
class RobotSpec:
    """The biped: geometry [m], link inertials, joint limits [rad], servo limits.

    Attributes:
        thigh, shank: Hip-knee and knee-ankle lengths [m].
        hip_width: Distance between the hip joints [m].
        ankle_height: Ankle centre above the sole [m].
        ankle_to_toe: Ankle centre to toe edge along x [m].
        foot_length, foot_width: Sole rectangle [m].
        links: Inertials by link name (pelvis, thigh, shank, ankle, foot); legs as the left leg.
        joint_limits: (lower, upper) [rad] by joint kind, MJCF sign convention.
        stall_torque: Servo torque limit [N m].
        no_load_speed: Servo speed limit [rad/s].
    """

    name: str
    thigh: float
    shank: float
    hip_width: float
    ankle_height: float
    ankle_to_toe: float
    foot_length: float
    foot_width: float
    links: dict[str, LinkInertial]
    joint_limits: dict[str, tuple[float, float]]
    stall_torque: float
    no_load_speed: float

    def __post_init__(self) -> None:
        for key in GEOMETRY_KEYS:
            value = getattr(self, key)
            if not value > 0:
                raise SpecError(f"geometry.{key} = {value!r}: must be > 0 m")
        if not 0 < self.ankle_to_toe < self.foot_length:
            raise SpecError(
                f"geometry.ankle_to_toe = {self.ankle_to_toe!r}: must lie in "
                f"(0, foot_length = {self.foot_length})"
            )
        for kind, (lower, upper) in self.joint_limits.items():
            if not lower < upper:
                raise SpecError(f"joint_limits.{kind} = [{lower}, {upper}]: lower must be < upper")
        for key in ("stall_torque", "no_load_speed"):
            if not getattr(self, key) > 0:
                raise SpecError(f"servo.{key} = {getattr(self, key)!r}: must be > 0")

    @property
    def heel_offset(self) -> float:
        """Ankle centre to heel edge along x [m] (positive number)."""
        return self.foot_length - self.ankle_to_toe

    @property
    def leg_reach(self) -> float:
        """Longest ankle-to-hip distance, legs straight [m]."""
        return self.thigh + self.shank

    @property
    def total_mass(self) -> float:
        """Whole-robot mass [kg]: pelvis plus two legs."""
        leg = sum(self.links[n].mass for n in LINK_NAMES if n != "pelvis")
        return self.links["pelvis"].mass + 2 * leg

    def with_foot_length(self, foot_length: float, *, extend: str = "both") -> RobotSpec:
        """A copy with a longer or shorter foot.

        Args:
            foot_length: New toe-to-heel length [m].
            extend: "toe", "heel" or "both" (half each) - where the change goes.
        """
        delta = foot_length - self.foot_length
        shift = {"toe": delta, "heel": 0.0, "both": delta / 2}
        if extend not in shift:
            raise SpecError(f"extend = {extend!r}: must be one of toe, heel, both")
        toe = self.ankle_to_toe + shift[extend]
        return _replace(self, foot_length=foot_length, ankle_to_toe=toe)

    def with_mass_scale(self, scale: dict[str, float]) -> RobotSpec:
        """A copy with link masses and inertias multiplied by group factors.

        Args:
            scale: Factors by group: a link name (pelvis, thigh, shank, ankle, foot),
                "legs" (every link but the pelvis, both legs) or "all"; the most
                specific group wins. E.g. {"all": 10} or {"legs": 2}.
        """
        unknown = set(scale) - {"all", "legs", *LINK_NAMES}
        if unknown:
            raise SpecError(
                f"mass scale group {sorted(unknown)[0]!r}: must be one of all, legs, "
                + ", ".join(LINK_NAMES)
            )
        links = {}
        for name, link in self.links.items():
            group = (
                scale.get("all", 1.0)
                if name == "pelvis"
                else scale.get("legs", scale.get("all", 1.0))
            )
            factor = scale.get(name, group)
            if not (isinstance(factor, int | float) and factor > 0):
                raise SpecError(f"mass scale {name} = {factor!r}: must be > 0")
            links[name] = LinkInertial(
                name, link.mass * factor, link.com, tuple(i * factor for i in link.inertia)
            )
        return _replace(self, links=links)


def _replace(spec: RobotSpec, **changes) -> RobotSpec:
    from dataclasses import replace

    return replace(spec, **changes)


def default_spec_path() -> Path:
    """Path of the paper's Bioloid-scale biped spec shipped with the package."""
    return Path(str(resources.files("planner") / "robots" / "bioloid.toml"))


def load_spec(path: str | Path | None = None) -> RobotSpec:
    """Read a RobotSpec from a TOML file (default: the paper's biped).

    Raises:
        SpecError: unreadable file, missing key or non-physical value, in one line.
    """
    path = Path(path) if path is not None else default_spec_path()
    try:
        with open(path, "rb") as f:
            data = tomllib.load(f)
    except FileNotFoundError:
        raise SpecError(f"robot spec {str(path)!r}: no such file") from None
    except tomllib.TOMLDecodeError as err:
        raise SpecError(f"robot spec {str(path)!r}: not valid TOML ({err})") from None
    return spec_from_dict(data, source=str(path))


def spec_from_dict(data: dict, *, source: str = "<dict>") -> RobotSpec:
    """Build a RobotSpec from the parsed TOML tables (see ``load_spec``)."""
    geometry = _table(data, "geometry", source)
    links_table = _table(data, "links", source)
    limits = _table(data, "joint_limits", source)
    servo = _table(data, "servo", source)
    links = {}
    for name in LINK_NAMES:
        link = _table(links_table, name, source, prefix="links.")
        links[name] = LinkInertial(
            name,
            _number(link, "mass", f"links.{name}", source),
            _vector3(link, "com", f"links.{name}", source),
            _vector3(link, "inertia", f"links.{name}", source),
        )
    joint_limits = {}
    for kind in JOINT_KINDS:
        pair = limits.get(kind)
        if not (isinstance(pair, list) and len(pair) == 2):
            raise SpecError(f"{source}: joint_limits.{kind} must be [lower, upper] in rad")
        joint_limits[kind] = (float(pair[0]), float(pair[1]))
    return RobotSpec(
        name=str(data.get("name", Path(source).stem)),
        **{key: _number(geometry, key, "geometry", source) for key in GEOMETRY_KEYS},
        links=links,
        joint_limits=joint_limits,
        stall_torque=_number(servo, "stall_torque", "servo", source),
        no_load_speed=_number(servo, "no_load_speed", "servo", source),
    )


def _table(data: dict, key: str, source: str, prefix: str = "") -> dict:
    value = data.get(key)
    if not isinstance(value, dict):
        raise SpecError(f"{source}: missing table [{prefix}{key}]")
    return value


def _number(table: dict, key: str, where: str, source: str) -> float:
    if key not in table:
        raise SpecError(f"{source}: missing key {where}.{key}")
    value = table[key]
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise SpecError(f"{source}: {where}.{key} = {value!r} must be a number")
    return float(value)


def _vector3(table: dict, key: str, where: str, source: str) -> tuple[float, float, float]:
    if key not in table:
        raise SpecError(f"{source}: missing key {where}.{key}")
    value = table[key]
    if not (isinstance(value, list) and len(value) == 3):
        raise SpecError(f"{source}: {where}.{key} = {value!r} must be a list of 3 numbers")
    return tuple(float(v) for v in value)
