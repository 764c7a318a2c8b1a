"""The robot spec and the approximation report of an imported model.

``imported_spec`` turns a ``Fit`` into the spec's tables (``planner.spec``): geometry
from the fit, links from ``lump``, joint limits from the model's ranges (the default
robot's where it has none, said so), servo constants from the actuators of the planned
joints (the map's ``[servo]``, else the default robot's, where the model has none), and
the soles' own ``solref`` as ``[contact]`` where the model sets one (the trial's floor,
whose priority makes its contact the pair's, then takes it; without the table MuJoCo's
default would replace the model's).
``spec_toml`` writes it with 17 significant digits, so it reads back as the same
doubles. ``report_lines`` lists every approximation with its size.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from slopewalk.bench.robot_import.fit import Fit
from slopewalk.bench.robot_import.footprint import SYMMETRY_TOLERANCE, spec_polygon
from slopewalk.bench.robot_import.lump import LEG_LINKS, lump_links, mirrored
from slopewalk.bench.robot_import.mapfile import SIDES, RobotMap
from slopewalk.planner.spec import (
    CONTACT_DEFAULTS,
    JOINT_LIMIT_KEYS,
    LINK_NAMES,
    SERVO,
    load_spec,
    spec_from_dict,
)


def imported_spec(fit: Fit, robot_map: RobotMap | None = None) -> tuple[dict, list[str]]:
    """(spec tables as ``spec_from_dict`` reads them, report lines)."""
    robot_map = robot_map or RobotMap()
    notes: list[str] = []
    links = lump_links(fit, "left")
    right = lump_links(fit, "right")
    tables = {
        name: {"mass": links[name].mass, "com": [float(v) for v in links[name].com],
               "inertia": [float(v) for v in np.diag(links[name].inertia)]}
        for name in LINK_NAMES
    }  # fmt: skip
    for name in LINK_NAMES:
        notes.append(f"links.{name}: products of inertia dropped, largest "
                     f"{links[name].dropped:.3g} of the largest moment")  # fmt: skip
    for name, *_ in LEG_LINKS:
        mirror = mirrored(right[name])
        asym = max(abs(mirror.mass - links[name].mass) / links[name].mass,
                   float(np.abs(mirror.com - links[name].com).max()))  # fmt: skip
        notes.append(
            f"links.{name}: the right leg's differs from the mirrored left's by "
            f"{asym:.3g} (relative mass, or m of CoM); the spec mirrors the left"
        )
    geometry: dict[str, Any] = {k: float(v) for k, v in fit.geometry.items()}
    data = {
        "name": fit.name,
        "geometry": geometry,
        "links": tables,
        "joint_limits": _limits(fit, notes),
        "servo": _servo(fit, robot_map, notes),
    }
    contact = _contact(fit, notes)
    if contact is not None:
        data["contact"] = contact
    polygon, _ = spec_polygon(fit.footprints["left"], fit.sole["left"])
    if polygon is not None:
        geometry["sole_polygon"] = polygon
    notes += _geometry_notes(fit)
    spec_from_dict(data, source=f"imported from {fit.path}")  # refuses a non-physical result
    return data, notes


def _contact(fit: Fit, notes: list[str]) -> dict[str, float] | None:
    """The soles' ``solref`` (time constant [s], damping ratio) as the spec's [contact];
    None where every sole geom keeps MuJoCo's default, or where they differ or use MuJoCo's
    direct (negative) form, which the spec cannot state (said so in ``notes``)."""
    pairs = {
        (float(fit.model.geom_solref[g][0]), float(fit.model.geom_solref[g][1]))
        for side in SIDES
        for g in fit.soles[side]
    }
    default = (CONTACT_DEFAULTS["timeconst"], CONTACT_DEFAULTS["dampratio"])
    if pairs <= {default}:
        return None
    if len(pairs) > 1 or min(min(p) for p in pairs) <= 0:
        notes.append(
            f"contact: the soles' solref {sorted(pairs)} differ or are in MuJoCo's direct "
            f"form; the spec keeps MuJoCo's default {list(default)}"
        )
        return None
    ((timeconst, dampratio),) = pairs
    notes.append(f"contact: the soles' own solref, {timeconst:g} s and {dampratio:g}")
    return {"timeconst": timeconst, "dampratio": dampratio}


def _limits(fit: Fit, notes: list[str]) -> dict[str, list[float]]:
    model, default = fit.model, load_spec()
    out = {}
    for kind in JOINT_LIMIT_KEYS:
        lows, highs = [], []
        for side in SIDES:
            joint = fit.legs[side][kind]
            if model.jnt_limited[joint.joint]:
                a, b = joint.sign * model.jnt_range[joint.joint]
                lows.append(min(a, b))
                highs.append(max(a, b))
        if len(lows) == 2:
            out[kind] = [float(max(lows)), float(min(highs))]
        else:
            out[kind] = list(default.joint_limits[kind])
            notes.append(f"joint_limits.{kind}: the model has no range; the default robot's "
                         f"{out[kind]} rad")  # fmt: skip
    return out


def _servo(fit: Fit, robot_map: RobotMap, notes: list[str]) -> dict[str, float]:
    """Servo constants: the map's, else the planned joints' actuators', else the default's."""
    model, default = fit.model, load_spec()
    joints = [fit.legs[s][k].joint for s in SIDES for k in JOINT_LIMIT_KEYS]
    dofs = [int(model.jnt_dofadr[j]) for j in joints]
    measured: dict[str, list[float]] = {k: [] for k in SERVO}
    for j in joints:
        act = position_actuator(model, j)
        if act is None:
            continue
        kp = float(model.actuator_gainprm[act, 0])
        measured["stiffness"].append(kp)
        measured["velocity_gain"].append(float(-model.actuator_biasprm[act, 2]))
        if model.actuator_forcelimited[act]:
            measured["stall_torque"].append(float(np.abs(model.actuator_forcerange[act]).min()))
    measured["armature"] = [float(model.dof_armature[d]) for d in dofs]
    measured["friction_loss"] = [float(model.dof_frictionloss[d]) for d in dofs]
    damping = [float(model.dof_damping[d]) for d in dofs]
    out = {}
    for key in SERVO:
        values = measured[key]
        if key in robot_map.servo:
            out[key] = robot_map.servo[key]
            notes.append(f"servo.{key}: {out[key]:g} from the map file")
        elif key == "no_load_speed" and min(damping) > 0 and "stall_torque" in out:
            out[key] = out["stall_torque"] / float(np.mean(damping))
            notes.append(
                f"servo.no_load_speed: stall torque / joint damping "
                f"{np.mean(damping):.4g} N m s/rad (spread {np.ptp(damping):.3g})"
            )
        elif len(values) == len(joints):
            out[key] = float(np.mean(values))
            notes.append(f"servo.{key}: mean of the 8 planned joints' {out[key]:.6g} "
                         f"(spread {np.ptp(values):.3g})")  # fmt: skip
        else:
            out[key] = float(getattr(default, key))
            notes.append(f"servo.{key}: the model does not say; the default robot's {out[key]:g}")
    return out


def position_actuator(model: mujoco.MjModel, joint: int) -> int | None:
    """The position actuator (gain kp, bias −kp q − kv q̇, gear 1) driving ``joint``, or None."""
    for a in range(model.nu):
        if (
            model.actuator_trntype[a] != mujoco.mjtTrn.mjTRN_JOINT
            or model.actuator_trnid[a, 0] != joint
        ):
            continue
        kp = model.actuator_gainprm[a, 0]
        affine = model.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_AFFINE
        if (
            affine
            and kp > 0
            and model.actuator_biasprm[a, 1] == -kp
            and model.actuator_gear[a, 0] == 1
        ):
            return a
    return None


def _geometry_notes(fit: Fit) -> list[str]:
    x0, x1, y0, y1 = fit.sole["left"]
    worst: dict[str, tuple[float, str]] = {}
    for what, size, unit in fit.misfits:
        if size >= worst.get(unit, (-1.0, ""))[0]:
            worst[unit] = (size, what)
    notes = [
        f"largest misfit kept as zero ({'offset' if unit == 'm' else 'angle'}): {what}, "
        f"{size * (1e3 if unit == 'm' else 180 / np.pi):.3g} {'mm' if unit == 'm' else 'deg'}"
        for unit, (size, what) in sorted(worst.items())
    ]
    notes.append(
        f"sole: the rectangle {(x1 - x0) * 1e3:.1f} x {(y1 - y0) * 1e3:.1f} mm around the sole "
        f"geoms, centred {(y0 + y1) / 2 * 1e3:+.1f} mm outward of the ankle (geometry.sole_offset)"
    )
    knee = fit.geometry["knee_offset"]
    notes.append(
        f"knee: the axis {abs(knee) * 1e3:.1f} mm {'ahead of' if knee >= 0 else 'behind'} the "
        "hip-ankle line at the zero pose (geometry.knee_offset; thigh and shank measured along "
        "the line)"
    )
    notes.append(_footprint_note(fit))
    kinds = {int(fit.model.geom_type[g]) for side in SIDES for g in fit.soles[side]}
    if kinds != {int(mujoco.mjtGeom.mjGEOM_BOX)}:
        notes.append(
            "sole: from the bounding boxes of non-box sole geoms (the spec's is a rectangle)"
        )
    if fit.held:
        notes.append(
            f"held joints ({len(fit.held)}: {', '.join(fit.held)}) are rigid in the spec; on the "
            "model they are held by their actuators and give under load (slopewalk robot compare)"
        )
    return notes


def _footprint_note(fit: Fit) -> str:
    """The left sole's contact footprint (``footprint``) and the rectangle the spec keeps."""
    x0, x1, y0, y1 = fit.sole["left"]
    foot = fit.footprints["left"]
    rectangle = (x1 - x0) * (y1 - y0)
    shape = (
        f"a convex {len(foot.vertices)}-gon (x, y from the ankle, mm: "
        + ", ".join(f"({x * 1e3:.1f}, {y * 1e3:.1f})" for x, y in foot.vertices)
        + f"), {foot.area * 1e6:.0f} mm^2"
        if len(foot.vertices) >= 3
        else f"{len(foot.vertices)} point(s), no area"
    )
    larger = f"{(rectangle / foot.area - 1) * 100:.1f} % larger" if foot.area > 0 else "larger"
    bound = "; some sole geoms by their bounding boxes (an outer bound)" if foot.bounded else ""
    polygon, why = spec_polygon(foot, fit.sole["left"])
    head = f"sole footprint: the contact face of the left sole geoms is {shape}{bound}; "
    if polygon is not None:
        return head + (
            f"{why} (symmetrised to its centre line, to {SYMMETRY_TOLERANCE * 1e3:g} mm), the "
            "planner's sole; tipping, strike and floor give keep the rectangle around it, "
            f"{rectangle * 1e6:.0f} mm^2, {larger}"
        )
    return head + (
        f"the planner's support polygon is the rectangle around it ({why}), "
        f"{rectangle * 1e6:.0f} mm^2, {larger}"
    )


def spec_toml(data: dict, header: list[str]) -> str:
    """The spec tables as TOML, numbers with 17 significant digits, ``header`` as comments."""
    lines = [f"# {h}" for h in header] + [f'name = "{data["name"]}"', "", "[geometry]"]
    lines += [f"{k} = {_num(v)}" for k, v in data["geometry"].items()]
    for name in LINK_NAMES:
        lines += ["", f"[links.{name}]"]
        lines += [f"{k} = {_num(v)}" for k, v in data["links"][name].items()]
    for table in ("joint_limits", "servo", "contact"):
        if table in data:
            lines += ["", f"[{table}]"] + [f"{k} = {_num(v)}" for k, v in data[table].items()]
    return "\n".join(lines) + "\n"


def _num(value) -> str:
    if isinstance(value, list):
        return "[" + ", ".join(_num(v) for v in value) + "]"
    return repr(float(value))


def import_robot(model_path, map_path=None) -> tuple[str, list[str]]:
    """(spec TOML text, report lines) of the model at ``model_path`` (``robot import``)."""
    from slopewalk.bench.robot_import.fit import fit_model
    from slopewalk.bench.robot_import.mapfile import load_map

    robot_map = load_map(map_path)
    fit = fit_model(model_path, robot_map)
    data, notes = imported_spec(fit, robot_map)
    header = [
        f"Imported by `slopewalk robot import` from {fit.path}"
        + (f" with the map {map_path}" if map_path else "")
        + ".",
        "Every approximation and its size: the report below (also printed by the import).",
        *(f"  {n}" for n in notes),
    ]
    return spec_toml(data, header), notes
