"""RobotSpec: the robot's geometry, link inertials, joint limits and servo, read from TOML.

The spec is the only place robot numbers live; the planner's chain and the MJCF
model are both built from it. Body-frame conventions are documented at the top of
``planner/robots/bioloid.toml``.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from slopewalk.planner.config_file import load_toml
from slopewalk.planner.errors import SpecError
from slopewalk.planner.ranges import Range
from slopewalk.planner.sole import check_polygon

LINK_NAMES = ("pelvis", "thigh", "shank", "ankle", "foot")
# the keys of [joint_limits]: one per joint kind of a leg (joints.JOINT_KINDS: of each q entry)
JOINT_LIMIT_KEYS = ("hip_pitch", "knee", "ankle_pitch", "ankle_roll")
GEOMETRY_KEYS = (
    "thigh",
    "shank",
    "hip_width",
    "ankle_height",
    "ankle_to_toe",
    "foot_length",
    "foot_width",
)
# optional [geometry] keys and their defaults (a spec without them is the paper's layout)
OPTIONAL_GEOMETRY: dict[str, Any] = {"sole_offset": 0.0, "knee_offset": 0.0, "sole_polygon": None}
# the optional [contact] table: the soles' contact with the floor, MuJoCo's ``solref`` (time
# constant [s], damping ratio [-]); absent, MuJoCo's defaults, which every scene used before
CONTACT_DEFAULTS: dict[str, float] = {"timeconst": 0.02, "dampratio": 1.0}
# the optional [servo] key ``damping``: the joint's viscous damping [N m s/rad]; absent, the
# motor's back-EMF alone, stall_torque / no_load_speed (``RobotSpec.joint_damping``), which
# every scene and prediction used before the key existed
OPTIONAL_SERVO: dict[str, float | None] = {"damping": None}


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
        where = f"links.{self.name}"
        MASS.check(f"{where}.mass", self.mass, SpecError)
        _check_vector3(f"{where}.com", self.com, COM)
        _check_vector3(f"{where}.inertia", self.inertia, FINITE_INERTIA)
        ixx, iyy, izz = self.inertia
        if min(self.inertia) <= 0:
            raise SpecError(
                f"{where}.inertia {list(self.inertia)} kg m^2: "
                "every principal moment must be > 0 (positive definite)"
            )
        if ixx + iyy < izz or iyy + izz < ixx or izz + ixx < iyy:
            raise SpecError(
                f"{where}.inertia {list(self.inertia)} kg m^2: violates the triangle "
                "inequality (each moment must be <= the sum of the other two)"
            )
        _check_vector3(f"{where}.inertia", self.inertia, INERTIA)

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
        sole_offset: Lateral offset of the sole rectangle's centre from the ankle centre,
            outward (+y for the left foot, −y for the right) [m]; 0 centres it under the ankle.
        sole_polygon: The left sole's contact outline, (x, y) vertices relative to the sole
            point under the ankle [m], counter-clockwise, convex, inside the rectangle and
            symmetric about y = ``sole_offset`` (``planner.sole``); None: the rectangle.
            It refines the support polygon and the ZMP margin; the rectangle stays the
            outer bound for tipping, strike, floor give, the twin's boxes and figures.
        knee_offset: Knee axis ahead of the hip–ankle line at the zero pose (legs straight,
            ankle under the hip) [m], negative behind; ``thigh`` and ``shank`` are then the
            lengths along that line, the links themselves ``thigh_link``/``shank_link`` long.
        links: Inertials by link name (pelvis, thigh, shank, ankle, foot); legs as the left leg.
        joint_limits: (lower, upper) [rad] by joint kind, MJCF sign convention.
        stall_torque: Servo torque limit [N m].
        no_load_speed: Servo speed limit [rad/s].
        stiffness: Servo position gain kp [N m/rad].
        velocity_gain: Servo velocity gain kv [N m s/rad] (on the joint speed).
        armature: Reflected rotor inertia per joint [kg m²].
        friction_loss: Dry joint friction per joint [N m].
        contact_timeconst: Time constant τ of the soles' contact with the floor [s]
            (MuJoCo's ``solref[0]``: how fast a penetration is pushed back; the floor's
            give with the foot's mass); 0.02 is MuJoCo's default.
        contact_dampratio: Damping ratio ζ of that contact [-] (``solref[1]``; below 1 a
            landing bounces); 1 is MuJoCo's default.
        damping: The servo joint's viscous damping [N m s/rad] (MuJoCo's joint ``damping``,
            the loop's d); None: the motor's back-EMF alone, stall_torque / no_load_speed
            (``joint_damping`` is the value used either way).
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
    stiffness: float
    velocity_gain: float
    armature: float
    friction_loss: float
    sole_offset: float = 0.0
    knee_offset: float = 0.0
    sole_polygon: tuple[tuple[float, float], ...] | None = None
    contact_timeconst: float = CONTACT_DEFAULTS["timeconst"]
    contact_dampratio: float = CONTACT_DEFAULTS["dampratio"]
    damping: float | None = None

    def __post_init__(self) -> None:
        if not (isinstance(self.name, str) and self.name.strip()):
            raise SpecError(f"name {self.name!r}: must be a non-empty string")
        for key in GEOMETRY_KEYS:
            LENGTH.check(f"geometry.{key}", getattr(self, key), SpecError)
        if not self.ankle_to_toe < self.foot_length:
            raise SpecError(
                f"geometry.ankle_to_toe {self.ankle_to_toe!r} m: must lie in "
                f"(0, foot_length = {self.foot_length!r}) m (the ankle stands over the foot)"
            )
        half = self.foot_width / 2
        Range(-half, half, "m", high_open=True).check(
            "geometry.sole_offset", self.sole_offset, SpecError
        )
        if self.sole_polygon is not None:
            pts = check_polygon(self.sole_polygon, self.heel_offset, self.ankle_to_toe, half,
                                self.sole_offset)  # fmt: skip
            object.__setattr__(self, "sole_polygon", pts)
        reach = min(self.thigh, self.shank)  # the knee stays within a link length of the line
        knee = Range(-reach, reach, "m", high_open=True)
        knee.check("geometry.knee_offset", self.knee_offset, SpecError)
        for kind, pair in self.joint_limits.items():
            lower, upper = pair
            for bound in pair:
                JOINT_ANGLE.check(f"joint_limits.{kind}", bound, SpecError)
            if not lower < upper:
                raise SpecError(
                    f"joint_limits.{kind} [{lower!r}, {upper!r}] rad: lower must be < upper"
                )
        for key, allowed in SERVO.items():
            allowed.check(f"servo.{key}", getattr(self, key), SpecError)
        for key, allowed in CONTACT.items():
            allowed.check(f"contact.{key}", getattr(self, f"contact_{key}"), SpecError)
        if self.damping is not None:
            DAMPING.check("servo.damping", self.damping, SpecError)

    @property
    def joint_damping(self) -> float:
        """The servo joint's viscous damping d [N m s/rad]: ``damping`` where the spec gives
        it, else the motor's back-EMF, stall_torque / no_load_speed (a DC motor's torque
        falls linearly from stall to zero at the no-load speed)."""
        if self.damping is not None:
            return float(self.damping)
        return self.stall_torque / self.no_load_speed

    @property
    def heel_offset(self) -> float:
        """Ankle centre to heel edge along x [m] (positive number)."""
        return self.foot_length - self.ankle_to_toe

    def as_dict(self) -> dict[str, Any]:
        """The spec's fields as plain data; an optional geometry, contact or servo key at its
        default is left out, so a spec without it is written (and identified) as before the
        key existed."""
        from dataclasses import asdict

        d = asdict(self)
        optional = {
            **OPTIONAL_GEOMETRY,
            **{f"contact_{k}": v for k, v in CONTACT_DEFAULTS.items()},
            **OPTIONAL_SERVO,
        }
        for key, default in optional.items():
            if d[key] == default:
                del d[key]
        return d

    def sole_shift(self, side: int | np.ndarray) -> np.ndarray:
        """y of the sole rectangle's centre from the sole point under the ankle [m].

        Args:
            side: Leg, 0 left / 1 right (``joints.LEFT``/``RIGHT``), scalar or array.

        Returns:
            ``sole_offset`` outward: +offset for the left foot, −offset for the right.
        """
        return self.sole_offset * (1.0 - 2.0 * np.asarray(side, dtype=float))

    @property
    def shank_link(self) -> float:
        """Ankle-to-knee distance [m]: ``shank`` with the knee offset beside it."""
        return float(np.hypot(self.shank, self.knee_offset))

    @property
    def thigh_link(self) -> float:
        """Knee-to-hip distance [m]: ``thigh`` with the knee offset beside it."""
        return float(np.hypot(self.thigh, self.knee_offset))

    @property
    def shank_tilt(self) -> float:
        """Angle of the ankle→knee line ahead of the shank's own axis (ankle→hip line at the
        zero pose) [rad]: atan2(knee_offset, shank); 0 without a knee offset."""
        return float(np.arctan2(self.knee_offset, self.shank))

    @property
    def thigh_tilt(self) -> float:
        """Angle of the knee→hip line behind the thigh's own axis [rad]:
        atan2(knee_offset, thigh); 0 without a knee offset."""
        return float(np.arctan2(self.knee_offset, self.thigh))

    @property
    def leg_reach(self) -> float:
        """Longest ankle-to-hip distance [m]: ``shank_link + thigh_link`` (the two links in
        line; with a knee offset the knee is then slightly bent)."""
        return self.shank_link + self.thigh_link

    @property
    def leg_shortest(self) -> float:
        """Shortest ankle-to-hip distance the two links allow [m]: |shank_link − thigh_link|."""
        return abs(self.shank_link - self.thigh_link)

    @property
    def total_mass(self) -> float:
        """Whole-robot mass [kg]: pelvis plus two legs."""
        leg = sum(self.links[n].mass for n in LINK_NAMES if n != "pelvis")
        return self.links["pelvis"].mass + 2 * leg

    def foot_length_range(self, extend: str = "both") -> Range:
        """Foot lengths [m] ``with_foot_length(..., extend=extend)`` accepts.

        The ankle must stay over the sole: extending the toe keeps the heel
        offset, the heel keeps the ankle-to-toe offset, "both" keeps their difference.
        """
        F, a = self.foot_length, self.ankle_to_toe
        shortest = {"toe": F - a, "heel": a, "both": abs(F - 2 * a)}
        if extend not in shortest:
            raise SpecError(f"extend {extend!r}: must be one of toe, heel, both")
        return Range(shortest[extend], LENGTH.high, "m")

    def with_foot_length(self, foot_length: float, *, extend: str = "both") -> RobotSpec:
        """A copy with a longer or shorter foot.

        Args:
            foot_length: New toe-to-heel length [m], in ``foot_length_range(extend)``.
            extend: "toe", "heel" or "both" (half each) - where the change goes.
        """
        self.foot_length_range(extend).check(
            f"foot length (extending the {extend})", foot_length, SpecError
        )
        delta = foot_length - self.foot_length
        shift = {"toe": delta, "heel": 0.0, "both": delta / 2}
        toe = self.ankle_to_toe + shift[extend]
        polygon = self.sole_polygon
        if polygon is not None:  # stretched along x with the rectangle: [−heel, toe] → new
            heel, new_heel = self.heel_offset, foot_length - toe
            scale = foot_length / self.foot_length
            polygon = tuple((-new_heel + (x + heel) * scale, y) for x, y in polygon)
        return _replace(self, foot_length=foot_length, ankle_to_toe=toe, sole_polygon=polygon)

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
            MASS_SCALE.check(f"mass scale {name}", factor, SpecError)
            ixx, iyy, izz = link.inertia
            links[name] = LinkInertial(
                name, link.mass * factor, link.com, (ixx * factor, iyy * factor, izz * factor)
            )
        return _replace(self, links=links)


def _replace(spec: RobotSpec, **changes: Any) -> RobotSpec:
    from dataclasses import replace

    return replace(spec, **changes)


def default_spec_path() -> Path:
    """Path of the paper's Bioloid-scale biped spec shipped with the package."""
    return Path(str(resources.files("slopewalk.planner") / "robots" / "bioloid.toml"))


def load_spec(path: str | Path | None = None) -> RobotSpec:
    """Read a RobotSpec from a TOML file (default: the paper's biped).

    The file format is documented for users in ``docs/robot-spec.md``.

    Raises:
        SpecError: unreadable file, not UTF-8 TOML, a missing or unknown key, a value
            of the wrong type or out of its range, in one line naming file, key and value.
    """
    path = Path(path) if path is not None else default_spec_path()
    where = f"robot spec {str(path)!r}"
    data = load_toml(path, where=where, kind="a TOML file", error=SpecError)
    return spec_from_dict(data, source=str(path))


def spec_from_dict(data: dict[str, Any], *, source: str = "<dict>") -> RobotSpec:
    """Build a RobotSpec from the parsed TOML tables (see ``load_spec``)."""
    try:
        return _spec_from_dict(data, source)
    except SpecError as err:
        raise SpecError(f"robot spec {source!r}: {err}") from None


# "uncertain": the ranges of the estimated values, read and checked apart from the robot's
# numbers by planner/uncertainty.py (which builds on this module, so not here)
TOP_KEYS = ("name", "geometry", "links", "joint_limits", "servo", "contact", "uncertain")
LINK_KEYS = ("mass", "com", "inertia")


def _spec_from_dict(data: dict[str, Any], source: str) -> RobotSpec:
    _known(data, TOP_KEYS, "")
    geometry = _table(data, "geometry")
    links_table = _table(data, "links")
    limits = _table(data, "joint_limits")
    servo = _table(data, "servo")
    _known(geometry, GEOMETRY_KEYS + tuple(OPTIONAL_GEOMETRY), "geometry.")
    _known(links_table, LINK_NAMES, "links.")
    _known(limits, JOINT_LIMIT_KEYS, "joint_limits.")
    _known(servo, tuple(SERVO) + tuple(OPTIONAL_SERVO), "servo.")
    contact = data.get("contact", {})
    if not isinstance(contact, dict):
        raise SpecError(f"contact = {contact!r}: must be a table [contact]")
    _known(contact, tuple(CONTACT), "contact.")
    links: dict[str, LinkInertial] = {}
    for name in LINK_NAMES:
        link = _table(links_table, name, prefix="links.")
        _known(link, LINK_KEYS, f"links.{name}.")
        links[name] = LinkInertial(
            name,
            _number(link, "mass", f"links.{name}"),
            _vector(link, "com", f"links.{name}"),
            _vector(link, "inertia", f"links.{name}"),
        )
    joint_limits = {kind: _vector(limits, kind, "joint_limits", 2) for kind in JOINT_LIMIT_KEYS}
    return RobotSpec(
        name=data.get("name", Path(source).stem),
        **{key: _number(geometry, key, "geometry") for key in GEOMETRY_KEYS},
        **{key: _float(geometry.get(key, default)) for key, default in OPTIONAL_GEOMETRY.items()},
        links=links,
        joint_limits=joint_limits,
        **{key: _number(servo, key, "servo") for key in SERVO},
        **{key: _float(servo.get(key, default)) for key, default in OPTIONAL_SERVO.items()},
        **{
            f"contact_{key}": _float(contact.get(key, default))
            for key, default in CONTACT_DEFAULTS.items()
        },  # fmt: skip
    )


def _known(table: dict[str, Any], allowed: tuple[str, ...], prefix: str) -> None:
    """Refuse a key the format does not have, suggesting the nearest known one."""
    for key in table:
        if key not in allowed:
            near = difflib.get_close_matches(str(key), allowed, n=1)
            hint = f"did you mean {prefix}{near[0]}? " if near else ""
            raise SpecError(f"unknown key {prefix}{key} ({hint}known: {', '.join(allowed)})")


def _table(data: dict[str, Any], key: str, prefix: str = "") -> dict[str, Any]:
    value = data.get(key)
    if value is None:
        raise SpecError(f"missing table [{prefix}{key}]")
    if not isinstance(value, dict):
        raise SpecError(f"{prefix}{key} = {value!r}: must be a table [{prefix}{key}]")
    return value


# A TOML value is Any until the dataclass it fills checks it: a number becomes a float, any
# other value stays as it is, for the range check to refuse with its own words.


def _number(table: dict[str, Any], key: str, where: str) -> Any:
    """The value of a number key as a float; a non-number stays as it is for the range check."""
    if key not in table:
        raise SpecError(f"missing key {where}.{key}")
    return _float(table[key])


def _float(value: Any) -> Any:
    return float(value) if isinstance(value, int | float) and not isinstance(value, bool) else value


def _vector(table: dict[str, Any], key: str, where: str, size: int = 3) -> tuple[Any, ...]:
    if key not in table:
        raise SpecError(f"missing key {where}.{key}")
    value = table[key]
    if not (isinstance(value, list) and len(value) == size):
        raise SpecError(f"{where}.{key} {value!r}: must be a list of {size} numbers")
    return tuple(_float(v) for v in value)


def _check_vector3(name: str, value: object, allowed: Range) -> None:
    if not (isinstance(value, tuple | list) and len(value) == 3):
        raise SpecError(f"{name} {value!r}: must be 3 numbers")
    for v in value:
        allowed.check(name, v, SpecError)


# Allowed ranges: from a toy robot to beyond human scale; values past them are typos
# or stand-ins for infinity, and would overflow the dynamics long before a walk.
LENGTH = Range(0.0, 5.0, "m")  # every geometry length
MASS = Range(0.0, 1000.0, "kg")  # per link
INERTIA = Range(0.0, 1000.0, "kg m^2")  # principal moments about the CoM
COM = Range(-5.0, 5.0, "m", low_open=False)  # each component, in the link frame
JOINT_ANGLE = Range(-2 * np.pi, 2 * np.pi, "rad", low_open=False)
SERVO = {
    "stall_torque": Range(0.0, 1e4, "N m"),
    "no_load_speed": Range(0.0, 1e3, "rad/s"),
    "stiffness": Range(0.0, 1e6, "N m/rad"),
    "velocity_gain": Range(0.0, 1e4, "N m s/rad", low_open=False),
    "armature": Range(0.0, 1e3, "kg m^2", low_open=False),
    "friction_loss": Range(0.0, 1e4, "N m", low_open=False),
}
DAMPING = Range(0.0, 1e4, "N m s/rad", low_open=False)  # [servo] damping, where given
# [contact]: a time constant up to a mattress's 1 s (MuJoCo keeps it at 2 steps at least:
# the scene refuses one shorter than that); a damping ratio from a bouncing to a dead landing
CONTACT = {"timeconst": Range(0.0, 1.0, "s"), "dampratio": Range(0.0, 100.0, "")}
MASS_SCALE = Range(0.0, 1e3)
FINITE_INERTIA = Range(-math.inf, math.inf, "kg m^2")
