"""Fit a user's MJCF or URDF humanoid to the planner's legs, or refuse it in one line.

The planner's leg (``docs/robot-spec.md``): at the zero pose, legs straight down, a hip
pitch and an ankle pitch whose axes are parallel to the base body's y axis and lie on one
vertical line, a knee axis parallel to them, on that line or a measured distance ahead of
or behind it (``geometry.knee_offset``), then an ankle roll whose axis is parallel to x
and meets the ankle pitch axis (the ankle centre); both hip pitch axes are one line; the
sole is flat, ``ankle_height`` below the ankle centre. Every other joint is held at an angle.

``fit_model`` compiles the model with MuJoCo (URDF too), poses it at its zero pose with
the held joints at their angles (the *reference pose*), finds each leg's four joints
(the map file's names, or by axis and chain from the foot: the last roll joint is the
ankle roll, the three pitch joints before it ankle pitch, knee, hip pitch), and measures
every way the legs differ from the planner's. A difference above its tolerance
(``AXIS_TOLERANCE``, ``OFFSET_TOLERANCE``) is refused in one line that names the joint
and the measured misfit; one below is kept in ``Fit.misfits`` for the report.

Frames: everything is measured in the base body's frame at the reference pose (x
forward, z up: the spec's pelvis frame up to a translation, ``Fit.pelvis_origin``).
Signs: ``LegJoint.sign`` is +1 where the model's joint turns about the planner's +y
(pitch) or +x (roll) axis, so the model's angle is ``sign`` × the planner's.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from slopewalk.bench.robot_import.footprint import Footprint, sole_footprint
from slopewalk.bench.robot_import.mapfile import SIDES, RobotImportError, RobotMap
from slopewalk.planner.spec import JOINT_LIMIT_KEYS

AXIS_TOLERANCE = 1e-6  # [rad] a planned joint's axis off the planner's x or y axis
OFFSET_TOLERANCE = 1e-6  # [m] an axis off the line the planner puts it on
LOWEST_TOLERANCE = 1e-3  # [m] collision geoms this close to the lowest point are soles
_AXES = {"x": 0, "y": 1, "z": 2}
_KIND_AXIS = {"hip_pitch": "y", "knee": "y", "ankle_pitch": "y", "ankle_roll": "x"}
_WORDS = {"hip_pitch": "hip pitch", "knee": "knee", "ankle_pitch": "ankle pitch",
          "ankle_roll": "ankle roll"}  # fmt: skip


@dataclass(frozen=True)
class LegJoint:
    """One planned joint of the model: name, ids, and ``sign`` (model angle / planner angle)."""

    name: str
    joint: int
    body: int
    sign: float
    anchor: np.ndarray  # [m] a point of the axis, base frame, reference pose
    axis: np.ndarray  # unit axis, base frame, reference pose


@dataclass(frozen=True)
class Fit:
    """A model fitted to the planner (module doc); lengths [m], angles [rad].

    Attributes:
        model: The compiled, unmodified model.
        name: The robot's name (the map's, or the model's).
        base: Body id of the base (everything above the hip pitch joints).
        legs: By side ("left", "right") and joint kind (``spec.JOINT_LIMIT_KEYS``).
        held: Every other hinge or slide joint by name, at its held angle.
        feet: Foot body id by side; ``soles``: their sole geoms' ids.
        qpos: The reference pose's ``qpos``.
        pelvis_origin: The spec's pelvis frame origin (midway between the legs on the hip
            pitch axis) in the base frame.
        geometry: The spec's [geometry] values.
        sole: Per side the sole's extent (x min, x max, y min, y max) from the ankle centre.
        misfits: (what, measured size, unit) of every difference below its tolerance.
        footprints: Per side the sole's contact footprint (``footprint``), from the ankle.
    """

    model: mujoco.MjModel
    path: str
    name: str
    base: int
    legs: dict[str, dict[str, LegJoint]]
    held: dict[str, float]
    feet: dict[str, int]
    soles: dict[str, list[int]]
    qpos: np.ndarray
    pelvis_origin: np.ndarray
    geometry: dict[str, float]
    sole: dict[str, tuple[float, float, float, float]]
    misfits: list[tuple[str, float, str]] = field(default_factory=list)
    footprints: dict[str, Footprint] = field(default_factory=dict)

    def ankle_centre(self, side: str) -> np.ndarray:
        """The ankle centre in the base frame [m]: on the ankle pitch axis, at the roll axis's y."""
        pitch, roll = self.legs[side]["ankle_pitch"], self.legs[side]["ankle_roll"]
        return np.array([pitch.anchor[0], roll.anchor[1], pitch.anchor[2]])


def compile_model(path: str | Path) -> mujoco.MjModel:
    """The MJCF or URDF file compiled by MuJoCo, or one line saying why not."""
    path = Path(path)
    if not path.is_file():
        raise RobotImportError(f"model {str(path)!r}: no such file")
    try:
        return mujoco.MjModel.from_xml_path(str(path))
    except ValueError as err:
        lines = [line.strip() for line in str(err).splitlines() if line.strip()]
        raise RobotImportError(
            f"model {str(path)!r}: MuJoCo refused it: {'; '.join(lines)}"
        ) from None


def fit_model(path: str | Path, robot_map: RobotMap | None = None) -> Fit:
    """Compile, pose and fit the model at ``path`` (module doc).

    Raises:
        RobotImportError: the model does not compile or does not fit, in one line.
    """
    robot_map = robot_map or RobotMap()
    model = compile_model(path)
    base = _body(model, robot_map.base, "base") if robot_map.base else _root_body(model)
    qpos = reference_qpos(model, robot_map.held)
    data = posed(model, qpos)
    frame = BaseFrame(data, base)
    feet = _feet(model, data, frame, robot_map.feet)
    legs, misfits = {}, []
    for side in SIDES:
        chain = _chain_joints(model, feet[side], base, side)
        legs[side] = _leg_joints(model, data, frame, chain, robot_map.joints.get(side), side)
        misfits += _leg_misfits(legs[side], side)
    planned = {j.joint for leg in legs.values() for j in leg.values()}
    held = {
        model.joint(j).name: float(qpos[model.jnt_qposadr[j]])
        for j in range(model.njnt)
        if j not in planned and model.jnt_type[j] in (_HINGE, _SLIDE)
    }
    unknown = set(robot_map.held) - set(held)
    if unknown:
        name = sorted(unknown)[0]
        raise RobotImportError(f"held joint {name!r}: not a held hinge or slide joint of the model")
    soles = {side: _sole_geoms(model, data, frame, feet[side]) for side in SIDES}
    name = robot_map.name or model.names.split(b"\0", 1)[0].decode() or Path(path).stem
    fit = Fit(model, str(path), name, base, legs, held, feet, soles, qpos, np.zeros(3), {}, {})
    return _measured(fit, data, frame, misfits)


_HINGE, _SLIDE, _FREE, _BALL = (
    int(mujoco.mjtJoint.mjJNT_HINGE),
    int(mujoco.mjtJoint.mjJNT_SLIDE),
    int(mujoco.mjtJoint.mjJNT_FREE),
    int(mujoco.mjtJoint.mjJNT_BALL),
)


def reference_qpos(model: mujoco.MjModel, held: dict[str, float]) -> np.ndarray:
    """``qpos0`` with the named joints at their held angles [rad]."""
    qpos = model.qpos0.copy()
    for name, value in held.items():
        try:
            joint = model.joint(name)
        except KeyError:
            raise RobotImportError(f"held joint {name!r}: the model has no such joint") from None
        if model.jnt_type[joint.id] not in (_HINGE, _SLIDE):
            raise RobotImportError(f"held joint {name!r}: must be a hinge or slide joint")
        qpos[model.jnt_qposadr[joint.id]] = value
    return qpos


def posed(model: mujoco.MjModel, qpos: np.ndarray) -> mujoco.MjData:
    """MjData with positions and subtree CoMs computed at ``qpos``."""
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    return data


class BaseFrame:
    """World → base body frame at a pose: ``point`` and ``vector`` map world coordinates."""

    def __init__(self, data: mujoco.MjData, base: int):
        self.R = data.xmat[base].reshape(3, 3).copy()
        self.p = data.xpos[base].copy()

    def point(self, p) -> np.ndarray:
        return (np.asarray(p) - self.p) @ self.R

    def vector(self, v) -> np.ndarray:
        return np.asarray(v) @ self.R


def _body(model, name, what) -> int:
    try:
        return model.body(name).id
    except KeyError:
        raise RobotImportError(f"{what} body {name!r}: the model has no such body") from None


def _root_body(model) -> int:
    roots = [b for b in range(1, model.nbody) if model.body_parentid[b] == 0]
    if len(roots) != 1:
        names = ", ".join(model.body(b).name for b in roots)
        raise RobotImportError(
            f"base: the world holds {len(roots)} bodies ({names}); name the robot's in the map"
        )
    return roots[0]


def _ancestors(model, body: int) -> list[int]:
    """``body`` and its ancestors up to (not including) the world, foot first."""
    out = []
    while body:
        out.append(body)
        body = int(model.body_parentid[body])
    return out


def collision_geoms(model, body: int) -> list[int]:
    """The geoms of ``body`` that take part in contacts."""
    return [g for g in range(model.ngeom) if model.geom_bodyid[g] == body
            and (model.geom_contype[g] or model.geom_conaffinity[g])]  # fmt: skip


def geom_corners(model, data, frame: BaseFrame, geom: int) -> np.ndarray:
    """The 8 corners of the geom's bounding box (exact for a box) in the base frame, (8, 3)."""
    centre, half = model.geom_aabb[geom, :3], model.geom_aabb[geom, 3:]
    signs = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
    local = centre + signs * half
    R = data.geom_xmat[geom].reshape(3, 3)
    return frame.point(data.geom_xpos[geom] + local @ R.T)


def _feet(model, data, frame, named: dict[str, str]) -> dict[str, int]:
    if set(named) == set(SIDES):
        return {side: _body(model, named[side], f"{side} foot") for side in SIDES}
    bottoms = {g: geom_corners(model, data, frame, g)[:, 2].min() for g in range(model.ngeom)
               if model.geom_contype[g] or model.geom_conaffinity[g]}  # fmt: skip
    if not bottoms:
        raise RobotImportError("feet: the model has no collision geoms; name them in [feet]")
    lowest = min(bottoms.values())
    bodies = sorted({int(model.geom_bodyid[g]) for g, z in bottoms.items()
                     if z < lowest + LOWEST_TOLERANCE})  # fmt: skip
    ys = {b: frame.point(data.xpos[b])[1] for b in bodies}
    left = [b for b in bodies if ys[b] > 0]
    right = [b for b in bodies if ys[b] < 0]
    if len(left) != 1 or len(right) != 1:
        names = ", ".join(model.body(b).name for b in bodies)
        raise RobotImportError(
            f"feet: {len(bodies)} bodies reach the lowest point ({names}), not one each side; "
            "name them in the map's [feet]"
        )
    return {"left": left[0], "right": right[0]}


def _chain_joints(model, foot: int, base: int, side: str) -> list[int]:
    """Joints between the base and the foot, base first."""
    path = _ancestors(model, foot)
    if base not in path:
        raise RobotImportError(
            f"{side} foot {model.body(foot).name!r}: not below the base body "
            f"{model.body(base).name!r}"
        )
    bodies = path[: path.index(base)][::-1]
    joints = []
    for b in bodies:
        for j in range(model.body_jntadr[b], model.body_jntadr[b] + model.body_jntnum[b]):
            if model.jnt_type[j] in (_FREE, _BALL):
                raise RobotImportError(
                    f"{side} leg joint {model.joint(j).name!r}: a free or ball joint in the leg; "
                    "the planner's leg has hinges only"
                )
            joints.append(j)
    return joints


def _dominant(axis: np.ndarray) -> str:
    return "xyz"[int(np.argmax(np.abs(axis)))]


def _leg_joints(model, data, frame, chain, named, side) -> dict[str, LegJoint]:
    """The four planned joints of one leg: the map's names, or found by axis and chain."""
    axes = {j: frame.vector(data.xaxis[j]) for j in chain}
    if named:
        missing = [k for k in JOINT_LIMIT_KEYS if k not in named]
        if missing:
            raise RobotImportError(f"map joints.{side}: names no {missing[0]} (name all four)")
        order = {}
        for kind in JOINT_LIMIT_KEYS:
            j = _joint_id(model, named[kind], f"joints.{side}.{kind}")
            if j not in chain:
                raise RobotImportError(
                    f"{side} {_WORDS[kind]} {named[kind]!r}: not between the base and the foot"
                )
            order[kind] = j
        found = order
    else:
        found = _detect(model, chain, axes, side)
    positions = [chain.index(found[k]) for k in JOINT_LIMIT_KEYS]
    for i in range(3):
        (k1, p1), (k2, p2) = (
            (JOINT_LIMIT_KEYS[i], positions[i]),
            (JOINT_LIMIT_KEYS[i + 1], positions[i + 1]),
        )
        if p2 <= p1:
            raise RobotImportError(
                f"{side} {_WORDS[k2]} {model.joint(found[k2]).name!r} comes before the "
                f"{_WORDS[k1]} {model.joint(found[k1]).name!r} (from the hip down); the "
                "planner's leg is hip pitch, knee, ankle pitch, ankle roll"
            )
    bodies = [int(model.jnt_bodyid[found[k]]) for k in JOINT_LIMIT_KEYS]
    if len(set(bodies)) < 4:
        kind = JOINT_LIMIT_KEYS[[bodies.count(b) > 1 for b in bodies].index(True)]
        raise RobotImportError(
            f"{side} {_WORDS[kind]} {model.joint(found[kind]).name!r} shares its body with "
            "another planned joint: the spec needs a link between each (e.g. the ankle cross)"
        )
    legs = {}
    for kind in JOINT_LIMIT_KEYS:
        j = found[kind]
        axis = axes[j]
        want = _AXES[_KIND_AXIS[kind]]
        sign = float(np.sign(axis[want]))
        anchor = frame.point(data.xanchor[j])
        legs[kind] = LegJoint(model.joint(j).name, j, int(model.jnt_bodyid[j]), sign, anchor, axis)
    return legs


def _joint_id(model, name, where) -> int:
    try:
        return model.joint(name).id
    except KeyError:
        raise RobotImportError(f"map {where} {name!r}: the model has no such joint") from None


def _detect(model, chain, axes, side) -> dict[str, int]:
    """Last roll joint = ankle roll; the three pitch joints before it: ankle pitch, knee, hip."""
    kinds = [_dominant(axes[j]) for j in chain]
    names = [model.joint(j).name for j in chain]
    rolls = [i for i, k in enumerate(kinds) if k == "x"]
    pitches = [i for i, k in enumerate(kinds) if k == "y"]
    after = [i for i in rolls if pitches and i > pitches[-1]]
    if not after:
        above = pitches[-2] if len(pitches) > 1 else -1
        between = [i for i in rolls if pitches and above < i < pitches[-1]]
        if between:
            raise RobotImportError(
                f"{side} ankle roll {names[between[-1]]!r} comes before the ankle pitch "
                f"{names[pitches[-1]]!r} (from the hip down); the planner's ankle is pitch, "
                "then roll"
            )
        raise RobotImportError(
            f"{side} leg: no ankle roll joint below its last pitch joint "
            f"(joints {', '.join(names)})"
        )
    roll = after[0]
    before = [i for i in pitches if i < roll]
    if len(before) < 3:
        raise RobotImportError(
            f"{side} leg: {len(before)} pitch joints above the ankle roll {names[roll]!r}, "
            f"the planner needs 3 (hip pitch, knee, ankle pitch); joints: {', '.join(names)}"
        )
    if len(before) > 3:
        raise RobotImportError(
            f"{side} leg: {len(before)} pitch joints above the ankle roll, which 3 are planned "
            f"is ambiguous ({', '.join(names[i] for i in before)}); name them in [joints.{side}]"
        )
    hip, knee, ankle = before
    return dict(zip(JOINT_LIMIT_KEYS, (chain[hip], chain[knee], chain[ankle], chain[roll]),
                    strict=True))  # fmt: skip


def _refuse_or_keep(misfits, what: str, size: float, tolerance: float, unit: str, scale: float):
    """Keep a misfit below ``tolerance``; refuse one above, in one line."""
    if abs(size) > tolerance:
        raise RobotImportError(
            f"{what}: {abs(size) * scale:.4g} {unit} (tolerance {tolerance * scale:.3g} {unit}); "
            "the planner cannot model it"
        )
    misfits.append((what, abs(size), "rad" if unit == "deg" else "m"))


def _leg_misfits(leg: dict[str, LegJoint], side: str) -> list[tuple[str, float, str]]:
    """Axis directions and axis lines of one leg against the planner's (module doc)."""
    out: list[tuple[str, float, str]] = []
    for kind, joint in leg.items():
        want = _AXES[_KIND_AXIS[kind]]
        off = float(np.arccos(np.clip(abs(joint.axis[want]), -1.0, 1.0)))
        what = f"{side} {_WORDS[kind]} {joint.name!r} axis angle off the {_KIND_AXIS[kind]} axis"
        _refuse_or_keep(out, what, off, AXIS_TOLERANCE, "deg", 180 / np.pi)
    hip = leg["hip_pitch"].anchor
    joint = leg["ankle_pitch"]  # the knee may sit off the line: geometry.knee_offset
    what = f"{side} ankle pitch {joint.name!r} axis ahead of the hip pitch axis (x offset)"
    _refuse_or_keep(out, what, joint.anchor[0] - hip[0], OFFSET_TOLERANCE, "mm", 1e3)
    pitch, roll = leg["ankle_pitch"], leg["ankle_roll"]
    what = f"{side} ankle roll {roll.name!r} axis above the ankle pitch axis (does not meet it)"
    _refuse_or_keep(out, what, roll.anchor[2] - pitch.anchor[2], OFFSET_TOLERANCE, "mm", 1e3)
    for upper, lower in (("hip_pitch", "knee"), ("knee", "ankle_pitch")):
        if not leg[upper].anchor[2] > leg[lower].anchor[2] + OFFSET_TOLERANCE:
            raise RobotImportError(
                f"{side} {_WORDS[lower]} {leg[lower].name!r} is not below the {_WORDS[upper]} "
                "at the zero pose: the planner's zero pose has the legs straight down"
            )
    return out


def _sole_geoms(model, data, frame, foot: int) -> list[int]:
    geoms = collision_geoms(model, foot)
    if not geoms:
        raise RobotImportError(f"foot {model.body(foot).name!r}: has no collision geoms (no sole)")
    bottoms = {g: geom_corners(model, data, frame, g)[:, 2].min() for g in geoms}
    lowest = min(bottoms.values())
    return [g for g in geoms if bottoms[g] < lowest + OFFSET_TOLERANCE]


def sole_extent(model, data, frame, geoms, ankle: np.ndarray) -> tuple[float, float, float, float]:
    """(x min, x max, y min, y max) [m] of the sole geoms' lowest faces, from the ankle centre."""
    points = []
    for g in geoms:
        corners = geom_corners(model, data, frame, g)
        bottom = corners[:, 2].min()
        points.append(corners[corners[:, 2] < bottom + OFFSET_TOLERANCE])
    p = np.concatenate(points)[:, :2] - ankle[:2]
    return (float(p[:, 0].min()), float(p[:, 0].max()), float(p[:, 1].min()), float(p[:, 1].max()))


def _measured(fit: Fit, data, frame, misfits) -> Fit:
    """``fit`` with its pelvis origin, geometry, sole extents and both-leg misfits."""
    from dataclasses import replace

    model, left, right = fit.model, fit.legs["left"], fit.legs["right"]
    hips = left["hip_pitch"].anchor, right["hip_pitch"].anchor
    what = "the two hip pitch axes apart (not one line)"
    _refuse_or_keep(misfits, what, float(np.hypot(*(hips[0] - hips[1])[[0, 2]])),
                    OFFSET_TOLERANCE, "mm", 1e3)  # fmt: skip
    ankles = {side: fit.ankle_centre(side) for side in SIDES}
    y_left, y_right = ankles["left"][1], ankles["right"][1]
    if not y_left > y_right:
        raise RobotImportError("left leg: not on the +y side of the right leg (x forward, z up?)")
    origin = np.array([hips[0][0], (y_left + y_right) / 2, hips[0][2]])
    lengths: dict[str, tuple[float, ...]] = {}
    for side in SIDES:
        leg = fit.legs[side]
        lengths[side] = (leg["hip_pitch"].anchor[2] - leg["knee"].anchor[2],
                         leg["knee"].anchor[2] - leg["ankle_pitch"].anchor[2],
                         leg["knee"].anchor[0] - leg["hip_pitch"].anchor[0])  # fmt: skip
    sole, footprints = {}, {}
    for side in SIDES:
        footprints[side] = sole_footprint(model, data, frame, fit.soles[side], ankles[side])
        bottom = min(geom_corners(model, data, frame, g)[:, 2].min() for g in fit.soles[side])
        sole[side] = sole_extent(model, data, frame, fit.soles[side], ankles[side])
        lengths[side] += (ankles[side][2] - bottom,)
    for i, key in enumerate(("thigh", "shank", "knee_offset", "ankle_height")):
        what = f"{key} left vs right"
        _refuse_or_keep(misfits, what, lengths["left"][i] - lengths["right"][i],
                        OFFSET_TOLERANCE, "mm", 1e3)  # fmt: skip
    thigh, shank, knee_offset, ankle_height = lengths["left"]
    x0, x1, y0, y1 = sole["left"]
    mirrored = np.subtract(sole["right"], (x0, x1, -y1, -y0))  # the right sole mirrors y
    _refuse_or_keep(misfits, "sole extent left vs right (mirrored)",
                    float(np.abs(mirrored).max()), OFFSET_TOLERANCE, "mm", 1e3)  # fmt: skip
    if not (x0 < 0 < x1 and y0 < 0 < y1):
        raise RobotImportError(
            f"left foot {model.body(fit.feet['left']).name!r}: the ankle centre is not above "
            f"its sole (sole x {x0 * 1e3:.1f}..{x1 * 1e3:.1f} mm, "
            f"y {y0 * 1e3:.1f}..{y1 * 1e3:.1f} mm)"
        )
    geometry = {
        "thigh": thigh, "shank": shank, "hip_width": y_left - y_right,
        "ankle_height": ankle_height, "ankle_to_toe": x1, "foot_length": x1 - x0,
        "foot_width": y1 - y0, "sole_offset": (y0 + y1) / 2, "knee_offset": knee_offset,
    }  # fmt: skip
    return replace(fit, pelvis_origin=origin, geometry=geometry, sole=sole, misfits=misfits,
                   footprints=footprints)  # fmt: skip
