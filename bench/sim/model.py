"""MJCF of the biped, built from the same ``RobotSpec`` as the planner's chain.

Built with ``mujoco.MjSpec``, MuJoCo's own model-editing API: it ships with the
``mujoco`` wheel (no second MJCF library to keep in step), compiles straight to an
``MjModel`` and writes MJCF with ``to_xml``. Its writer prints 6 significant digits
(exact for the spec's values; a test checks the text reproduces the compiled spec)
and spells a position actuator ``<general>`` with gainprm kp, biasprm (0, −kp, −kv).
The slope is no spec value: 6 digits of the floor's quaternion would turn 12° into
11.999946°, so ``scene_xml`` writes the floor's orientation itself, as an ``euler``
angle about y in radians (the file's ``<compiler angle="radian">``) with 17 digits.

``robot_xml`` is the pelvis-rooted biped: bodies named after their joints
(``l_thigh`` carries ``l_hip_pitch``), frames as in ``planner/robots/bioloid.toml``,
explicit inertials (geoms add no mass), position actuators, a ``home`` key.
``scene_xml`` stands it on a plane tilted about world y by −slope (gravity stays
vertical). ``stance_rooted_xml`` re-roots it at the stance foot for ``mj_inverse``.

Contacts: condim 3 on an elliptic cone (the exact Coulomb cone, no pyramid facets),
``impratio`` 10 so sticking feet creep less; the floor has ``priority`` 1, so its
friction and ``solref`` are the contact's: the spec's ``[contact]`` (time constant, damping
ratio), written only where it is not MuJoCo's default (0.02 s, 1), so a spec without the
table gives the scene text it gave before the table existed. Robot geoms (contype 0,
conaffinity 1) touch the floor, never each other, so a fall shows as a non-foot contact.
"""

from __future__ import annotations

import pickle
import re
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from slopewalk.bench.actuators import ACTUATOR_MODES as ACTUATOR_MODES  # for existing callers
from slopewalk.bench.actuators import DEFAULT_MODE, ActuatorMode, actuator_mode
from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.gait import MAX_SLOPE, GaitParams
from slopewalk.planner.joints import JOINT_NAMES, LEFT, SIDE_PREFIX
from slopewalk.planner.kinematics import rotation_slope_to_world
from slopewalk.planner.ranges import FRICTION
from slopewalk.planner.spec import CONTACT_DEFAULTS, JOINT_LIMIT_KEYS, RobotSpec, load_spec

_SOLE_THICKNESS = 0.005  # foot box height [m]; its bottom face is the sole
_LEG_RADIUS = 0.015  # thigh/shank capsule radius [m] (AX-12A is 32 mm wide)


class SceneError(SlopewalkError):
    """A scene option outside its allowed range (slope, friction, actuator mode, step)."""


@dataclass(frozen=True)
class Servo:
    """Joint and position-actuator settings of one actuator mode (simulation settings).

    With ``feedforward`` the plan's torque is added to the position loop's output
    (``playback.feedforward_torque``): the command becomes q_ref + τ_ff / kp, so the
    one actuator's force is kp (q_ref − q) − kv q̇ + τ_ff, clipped as a whole by its
    ``forcerange`` to ±``force_limit``. The actuator's ``ctrlrange`` is the joint
    range widened by ``force_limit`` / kp, the largest shift a clipped τ_ff makes.
    """

    kp: float  # position gain [N m/rad]
    kv: float  # velocity gain [N m s/rad]
    force_limit: float  # symmetric actuator torque limit [N m]
    damping: float = 0.0  # joint damping [N m s/rad]
    armature: float = 0.0  # reflected rotor inertia [kg m²]
    frictionloss: float = 0.0  # dry joint friction [N m]
    feedforward: bool = False  # add the plan's torque to the command

    @property
    def command_margin(self) -> float:
        """How far the command may leave the joint range [rad]: force_limit / kp with τ_ff."""
        return self.force_limit / self.kp if self.feedforward else 0.0


# ---- Simulation settings: the one place they live (robot numbers live in the spec). ----
# The servo's constants (kp, kv, armature, friction loss, torque limit) are the spec's
# [servo] table; for the default spec the AX-12A's, with their sources in bioloid.toml.
# Servo joint damping = the spec's [servo] damping, or where it has none stall torque /
# no-load speed: the slope of a DC motor's torque-speed line (back-EMF), present with or
# without a command (for the XM430 this rule gives 0.85 N m s/rad; the OP3's identified
# value is 1.08: the gear train adds; RobotSpec.joint_damping).
#
# stiff: a stiff, unsaturated position loop that tracks the plan closely, for validating
# the analytic model. It keeps the servo's armature: with a 1 ms step and no rotor
# inertia, kp = 200 on the 0.1 kg foot chatters on the floor (the stance foot creeps).
# Armature only adds A q̈ to each hinge's own equation, so for a tracked motion it changes
# actuator torques, not the ground reaction the ZMP comes from. The loop lags the
# command by about kv / kp = 10 ms (kv acts on the absolute joint speed).
STIFF_KP, STIFF_KV, STIFF_FORCE_LIMIT = 200.0, 2.0, 50.0
# Options: implicitfast integrates kv and joint damping implicitly; 1 ms resolves the stiff loop.
TIMESTEP = 0.001  # [s], default of scene_xml
INTEGRATOR = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
IMPRATIO = 10.0


def mode(actuators: str) -> ActuatorMode:
    """The registered mode ``actuators`` (``bench.actuators.MODES``).

    Raises:
        SceneError: no such mode, in one line.
    """
    return actuator_mode(actuators, SceneError)


def servo_settings(spec: RobotSpec, actuators: str) -> Servo:
    """Joint and actuator settings of ``actuators`` mode for ``spec``.

    Gains "stiff" (``ActuatorMode.gains``): kp 200, kv 2, 50 N m, the spec's armature;
    "spec": every constant from the spec's [servo] table. A ``feedforward`` mode adds
    the torque feedforward.
    """
    settings = mode(actuators)
    feedforward = settings.feedforward
    if settings.gains == "stiff":
        return Servo(
            kp=STIFF_KP,
            kv=STIFF_KV,
            force_limit=STIFF_FORCE_LIMIT,
            armature=spec.armature,
            feedforward=feedforward,
        )
    return Servo(
        kp=spec.stiffness,
        kv=spec.velocity_gain,
        force_limit=spec.stall_torque,
        damping=spec.joint_damping,
        armature=spec.armature,
        frictionloss=spec.friction_loss,
        feedforward=feedforward,
    )


def check_scene_options(*, slope: float, friction: float, actuators: str, timestep: float):
    """Raise one SceneError line for a slope, μ, actuator mode or timestep out of range."""
    if not abs(slope) < MAX_SLOPE:
        raise SceneError(f"slope {np.rad2deg(slope):.4g} deg: must lie in (-60, 60) deg")
    FRICTION.check("friction", friction, SceneError)
    mode(actuators)
    if not timestep > 0:
        raise SceneError(f"timestep {timestep!r} s: must be > 0")


def check_contact_step(spec: RobotSpec, timestep: float) -> None:
    """Raise one SceneError line where the spec's contact time constant is below 2 steps
    (MuJoCo would silently stiffen the contact to 2 steps, not the spec's floor)."""
    if not spec.contact_timeconst >= 2 * timestep:
        raise SceneError(
            f"contact.timeconst {spec.contact_timeconst!r} s of robot {spec.name!r}: must be "
            f">= 2 time steps ({2 * timestep:g} s) at timestep {timestep:g} s"
        )


def contact_solref(spec: RobotSpec) -> list[float] | None:
    """The floor's ``solref`` [τ s, ζ] for the spec's ``[contact]``; None where it is
    MuJoCo's default (the scene then leaves the attribute out)."""
    pair = [spec.contact_timeconst, spec.contact_dampratio]
    return None if pair == list(CONTACT_DEFAULTS.values()) else pair


def robot_xml(spec: RobotSpec, *, actuators: str = DEFAULT_MODE) -> str:
    """MJCF text of the pelvis-rooted biped (see module doc)."""
    return compiled_xml(build_robot(spec, actuators=actuators))


def compiled_xml(mjs: mujoco.MjSpec) -> str:
    """``mjs.to_xml()`` (which compiles), with MuJoCo's refusal turned into one SceneError line."""
    try:
        return mjs.to_xml()
    except ValueError as err:
        raise SceneError(f"MuJoCo refused the model: {mujoco_message(err)}") from None


def mujoco_message(err: Exception) -> str:
    """MuJoCo's compiler error on one line ("Error: ... / Element name ...")."""
    lines = [line.strip() for line in str(err).splitlines() if line.strip()]
    return "; ".join(lines).removeprefix("Error: ") or "unknown error"


def build_robot(spec: RobotSpec, *, actuators: str = DEFAULT_MODE) -> mujoco.MjSpec:
    """The pelvis-rooted biped as an ``MjSpec`` (``compile()`` it for full precision)."""
    mjs = _new_spec(spec.name)
    mjs.option.timestep, mjs.option.integrator = TIMESTEP, INTEGRATOR  # the stiff loop needs them
    _add_robot(mjs, spec, servo_settings(spec, actuators))
    return mjs


def scene_xml(
    spec: RobotSpec,
    *,
    slope: float = 0.0,
    friction: float = 1.0,
    actuators: str = DEFAULT_MODE,
    timestep: float = TIMESTEP,
) -> str:
    """Self-contained MJCF text of the biped standing (``home`` key) on a tilted plane.

    Args:
        spec: The robot.
        slope: Plane inclination θs [rad] in (−60°, 60°); the plane turns about world y
            by −θs, so slope-frame x goes uphill. Gravity stays (0, 0, −9.81).
        friction: Coulomb friction coefficient μ of the foot-plane contact, > 0.
        actuators: A mode of ``ACTUATOR_MODES`` (``servo_settings``).
        timestep: Simulation step [s], > 0.

    Raises:
        SceneError: a value outside its range, named in one line.

    The text of the last ``SCENES_KEPT`` scenes is kept, by the spec's pickle and the
    options (a trial builds its scene twice, for the rollout and for the predictors'
    floor, and a sweep's trials share scenes): 1.3 ms a scene.
    """
    check_scene_options(slope=slope, friction=friction, actuators=actuators, timestep=timestep)
    check_contact_step(spec, timestep)
    # repr of each float: -0.0 names its scene "-0 deg", a scene of its own
    key = (pickle.dumps(spec), *map(repr, map(float, (slope, friction, timestep))), actuators)
    if key in _SCENES:
        _SCENES.move_to_end(key)
        return _SCENES[key]
    text = _scene_xml(spec, slope, friction, actuators, timestep)
    _SCENES[key] = text
    if len(_SCENES) > SCENES_KEPT:
        _SCENES.popitem(last=False)
    return text


SCENES_KEPT = 32
_SCENES: OrderedDict[tuple, str] = OrderedDict()


def _scene_xml(spec: RobotSpec, slope: float, friction: float, actuators: str, timestep: float):
    """``scene_xml``, built."""
    servo = servo_settings(spec, actuators)
    mjs = _new_spec(f"{spec.name} on {np.rad2deg(slope):.4g} deg")
    _add_world(mjs, slope=slope, friction=friction, timestep=timestep,
               solref=contact_solref(spec))  # fmt: skip
    pelvis = _add_robot(mjs, spec, servo)
    # Stand the home pose on the tilted plane: its pelvis pose is in S; turn it into W.
    R = rotation_slope_to_world(slope)
    pelvis.pos, pelvis.quat = R @ pelvis.pos, _quat(R)
    key = mjs.key("home")
    key.qpos = np.concatenate([pelvis.pos, pelvis.quat, list(key.qpos)[7:]])
    return _exact_floor(compiled_xml(mjs), slope)


_FLOOR_QUAT = re.compile(r'(<geom name="floor"[^>]*?) quat="[^"]*"')
_FLOOR = re.compile(r'(<geom name="floor")')


def _exact_floor(xml: str, slope: float) -> str:
    """``xml`` with the floor's 6-digit ``quat`` replaced by ``euler="0 −θs 0"`` [rad].

    17 significant digits read back as the same double, so the compiled plane is
    tilted by exactly ``slope`` (MuJoCo turns a one-axis euler into cos, sin of θs/2).
    A level floor has no ``quat`` attribute and is left as it is.
    """
    if slope == 0.0:
        return xml
    euler = f'euler="0 {-slope:.17g} 0"'
    exact, found = _FLOOR_QUAT.subn(rf"\1 {euler}", xml, count=1)
    if found != 1:  # below ~1e-16 rad MuJoCo's writer takes the quaternion for the identity
        exact, found = _FLOOR.subn(rf"\1 {euler}", xml, count=1)
    if found != 1:
        raise SceneError("MuJoCo's writer changed: no floor geom to write the slope on")
    return exact


def stance_rooted_xml(spec: RobotSpec, stance: int) -> str:
    """MJCF text of the chain rooted at the stance foot, for ``mj_inverse``.

    The world frame of this model is the slope frame S (set ``opt.gravity`` to
    ``gravity_in_slope(slope)``). Root: the stance foot (free joint at its ankle
    centre, so the sole point is the world origin at zero pose), then ankle cross,
    shank, thigh, pelvis, swing thigh, shank, ankle cross, foot; every body frame as
    in the pelvis-rooted model. Hinges are named and ordered as ``joints.JOINT_NAMES``
    and each angle equals the planner's q: the stance leg is walked from foot to hip,
    so its axes are negated (−x roll, −y pitch) and its joints sit at the far end of
    each child body. Generalized forces are then the planner's torques. No geoms, no
    limits, no damping or armature; constraints disabled.

    Args:
        stance: 0 left / 1 right.
    """
    if stance not in (0, 1):
        raise SceneError(f"stance {stance!r}: must be 0 (left) or 1 (right)")
    mjs = _new_spec(f"{spec.name} stance {SIDE_PREFIX[stance]}foot")
    mjs.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    st, sw = SIDE_PREFIX[stance], SIDE_PREFIX[1 - stance]
    y_hip = (spec.hip_width if stance == LEFT else -spec.hip_width) / 2  # in pelvis frame
    L1, L2, k = spec.thigh, spec.shank, spec.knee_offset  # the knee k ahead of the line
    # (body, link, is right leg, body pos in parent, joint pos in body, axis), q = 0 pose
    chain = [
        (f"{st}ankle", "ankle", stance, (0, 0, 0), (0, 0, 0), (-1, 0, 0)),
        (f"{st}shank", "shank", stance, (k, 0, L2), (-k, 0, -L2), (0, -1, 0)),
        (f"{st}thigh", "thigh", stance, (-k, 0, L1), (k, 0, -L1), (0, -1, 0)),
        ("pelvis", "pelvis", 0, (0, -y_hip, 0), (0, y_hip, 0), (0, -1, 0)),
        (f"{sw}thigh", "thigh", 1 - stance, (0, -y_hip, 0), (0, 0, 0), (0, 1, 0)),
        (f"{sw}shank", "shank", 1 - stance, (k, 0, -L1), (0, 0, 0), (0, 1, 0)),
        (f"{sw}ankle", "ankle", 1 - stance, (-k, 0, -L2), (0, 0, 0), (0, 1, 0)),
        (f"{sw}foot", "foot", 1 - stance, (0, 0, 0), (0, 0, 0), (1, 0, 0)),
    ]
    body = mjs.worldbody.add_body(name=f"{st}foot", pos=[0, 0, spec.ankle_height])
    body.add_freejoint(name="root")
    _set_inertial(body, spec, "foot", stance == 1)
    for (name, link, right, pos, joint_pos, axis), joint in zip(chain, JOINT_NAMES, strict=True):
        body = body.add_body(name=name, pos=list(pos))
        _set_inertial(body, spec, link, right == 1)
        body.add_joint(name=joint, pos=list(joint_pos), axis=list(axis))
    return mjs.to_xml()


def write_default_mjcf(directory: str | Path) -> tuple[Path, Path]:
    """(Re)write ``biped.xml`` and ``scene.xml`` (flat, includes the biped) for the default spec.

    Returns:
        Paths of the two files.
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    robot, scene = directory / "biped.xml", directory / "scene.xml"
    robot.write_text(robot_xml(load_spec()))
    world = _new_spec("biped scene")
    _add_world(world, slope=0.0, friction=1.0, timestep=TIMESTEP)
    lines = world.to_xml().splitlines(keepends=True)
    scene.write_text(lines[0] + '  <include file="biped.xml"/>\n\n' + "".join(lines[1:]))
    return robot, scene


def home_pose(spec: RobotSpec) -> tuple[float, np.ndarray]:
    """Standing pose at the planner's nominal hip height, feet flat under the hips.

    Returns:
        (pelvis height above the sole [m], (hip pitch, knee, ankle pitch, ankle roll) [rad]).
    """
    reach = spec.ankle_height + spec.thigh_link + spec.shank_link
    height = min(GaitParams.nominal(spec, 1.0).hip_height, reach)
    D, L1, L2 = height - spec.ankle_height, spec.thigh_link, spec.shank_link
    knee = np.pi - np.arccos(np.clip((L1**2 + L2**2 - D**2) / (2 * L1 * L2), -1, 1))
    lean = np.arccos(np.clip((L1**2 + D**2 - L2**2) / (2 * L1 * D), -1, 1))
    if spec.knee_offset:  # the effective links' angles back to the links' own axes (ik.leg_ik)
        gs, gt = spec.shank_tilt, spec.thigh_tilt
        return height, np.array([gt - lean, knee - gs - gt, lean - knee + gs, 0.0])
    return height, np.array([-lean, knee, lean - knee, 0.0])


def _new_spec(name: str) -> mujoco.MjSpec:
    mjs = mujoco.MjSpec()
    mjs.modelname = name
    mjs.comment = " Generated by slopewalk bench/sim/model.py; do not edit by hand. "
    mjs.compiler.degree = False
    mjs.compiler.autolimits = True
    mjs.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    return mjs


def _add_world(
    mjs: mujoco.MjSpec,
    *,
    slope: float,
    friction: float,
    timestep: float,
    solref: list[float] | None = None,
) -> None:
    """Options, floor texture, light and the tilted floor plane (its pose is S in the world),
    with ``solref`` (``contact_solref``; None: MuJoCo's default, left out of the text)."""
    mjs.option.timestep = timestep
    mjs.option.integrator = INTEGRATOR
    mjs.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    mjs.option.impratio = IMPRATIO
    mjs.add_texture(
        name="grid", type=mujoco.mjtTexture.mjTEXTURE_2D, width=300, height=300,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER, rgb1=[0.2, 0.3, 0.4], rgb2=[0.1, 0.2, 0.3],
    )  # fmt: skip
    mjs.add_material(name="grid", texrepeat=[10, 10], reflectance=0.1).textures[1] = "grid"
    mjs.worldbody.add_light(
        name="sun", pos=[0, 0, 2], dir=[0, 0, -1], type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL
    )
    floor = mjs.worldbody.add_geom(
        name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05], material="grid",
        quat=_quat(rotation_slope_to_world(slope)), friction=[friction, 0.005, 0.0001],
        condim=3, priority=1,
    )  # fmt: skip
    if solref is not None:
        floor.solref = solref


def _add_robot(mjs: mujoco.MjSpec, spec: RobotSpec, servo: Servo) -> mujoco.MjsBody:
    """Defaults, bodies, sites, actuators and the home key of the pelvis-rooted biped."""
    main = mjs.add_default("bioloid", mjs.default)
    main.geom.contype, main.geom.conaffinity, main.geom.group = 0, 1, 2
    main.geom.rgba = [0.25, 0.25, 0.28, 1]
    main.site.group, main.site.size, main.site.rgba = 5, [0.004, 0, 0], [1, 0.4, 0, 1]
    foot = mjs.add_default("foot", main)
    foot.geom.type, foot.geom.rgba = mujoco.mjtGeom.mjGEOM_BOX, [0.6, 0.6, 0.65, 1]
    ax12 = mjs.add_default("ax12", main)
    ax12.joint.damping = [servo.damping, 0, 0]
    ax12.joint.armature, ax12.joint.frictionloss = servo.armature, servo.frictionloss
    ax12.actuator.set_to_position(kp=servo.kp, kv=servo.kv)
    ax12.actuator.forcerange = [-servo.force_limit, servo.force_limit]
    for kind in JOINT_LIMIT_KEYS:
        cls = mjs.add_default(kind, ax12)
        lower, upper = spec.joint_limits[kind]
        cls.joint.range = [lower, upper]
        widen = servo.command_margin
        cls.actuator.ctrlrange = [lower - widen, upper + widen]

    height, home = home_pose(spec)
    pelvis = mjs.worldbody.add_body(name="pelvis", pos=[0, 0, height], childclass="bioloid")
    pelvis.add_freejoint(name="root")
    _set_inertial(pelvis, spec, "pelvis", False)
    hw = spec.hip_width / 2
    pelvis.add_geom(
        type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.025, hw + 0.015, 0.02], pos=[0, 0, 0.02]
    )
    heel, toe, sole = spec.heel_offset, spec.ankle_to_toe, -spec.ankle_height
    half_sole = [spec.foot_length / 2, spec.foot_width / 2, _SOLE_THICKNESS / 2]
    for side, pre in enumerate(SIDE_PREFIX):
        right = side == 1
        thigh = pelvis.add_body(name=f"{pre}thigh", pos=[0, -hw if right else hw, 0])
        k = spec.knee_offset  # the knee ahead of the hip–ankle line
        shank = thigh.add_body(name=f"{pre}shank", pos=[k, 0, -spec.thigh])
        ankle = shank.add_body(name=f"{pre}ankle", pos=[-k, 0, -spec.shank])
        foot_body = ankle.add_body(name=f"{pre}foot")
        for body, link, kind in zip(
            (thigh, shank, ankle, foot_body), ("thigh", "shank", "ankle", "foot"), JOINT_LIMIT_KEYS,
            strict=True,
        ):  # fmt: skip
            _set_inertial(body, spec, link, right)
            axis = [1, 0, 0] if kind == "ankle_roll" else [0, 1, 0]
            body.add_joint(mjs.find_default(kind), name=f"{pre}{kind}", axis=axis)
            mjs.add_actuator(
                mjs.find_default(kind), name=f"{pre}{kind}", target=f"{pre}{kind}",
                trntype=mujoco.mjtTrn.mjTRN_JOINT,
            )  # fmt: skip
            if kind in _SITE:
                body.add_site(name=f"{pre}{_SITE[kind]}")
        for body, x, length in ((thigh, k, spec.thigh), (shank, -k, spec.shank)):
            body.add_geom(
                name=body.name, type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                fromto=[0, 0, 0, x, 0, -length], size=[_LEG_RADIUS, 0, 0],
            )  # fmt: skip
        if spec.sole_polygon is None:
            foot_body.add_geom(
                mjs.find_default("foot"), name=f"{pre}foot", size=half_sole,
                pos=[(toe - heel) / 2, spec.sole_shift(side), sole + _SOLE_THICKNESS / 2],
            )  # fmt: skip
        else:
            _add_sole_prism(mjs, foot_body, spec, side, pre)
        for name, x in (("sole", 0.0), ("toe", toe), ("heel", -heel)):
            foot_body.add_site(name=f"{pre}{name}", pos=[x, 0, sole])
    legs = np.tile(home, 2)
    mjs.add_key(name="home", qpos=[0, 0, height, 1, 0, 0, 0, *legs], ctrl=legs)
    return pelvis


def _add_sole_prism(mjs: mujoco.MjSpec, foot: mujoco.MjsBody, spec: RobotSpec, side: int, pre: str):
    """The foot's collision geometry for a ``sole_polygon``: a convex mesh, the polygon
    (the right foot's mirrored in y) extruded ``_SOLE_THICKNESS`` up from the sole.

    MuJoCo's plane–convex collision keeps at most 4 contact points per geom, at vertices
    of the mesh's bottom face: a sole of more than 4 vertices stands on 4 of them (inside
    the polygon, not necessarily spanning it).
    """
    sole = np.array(spec.sole_polygon) * [1.0, 1.0 - 2.0 * side]
    bottom = -spec.ankle_height
    rings = [np.c_[sole, np.full(len(sole), z)] for z in (bottom, bottom + _SOLE_THICKNESS)]
    mjs.add_mesh(name=f"{pre}sole", uservert=np.vstack(rings).ravel().tolist())
    foot.add_geom(
        mjs.find_default("foot"), name=f"{pre}foot", type=mujoco.mjtGeom.mjGEOM_MESH,
        meshname=f"{pre}sole",
    )  # fmt: skip


# Sites at body origins, named after the physical joint there (the foot's is the ankle's).
_SITE = {"hip_pitch": "hip", "knee": "knee", "ankle_pitch": "ankle"}


def _set_inertial(body: mujoco.MjsBody, spec: RobotSpec, link: str, right: bool) -> None:
    """Explicit inertial of ``link`` (the spec gives the left leg; the right mirrors y)."""
    inertial = spec.links[link]
    com = np.array(inertial.com)
    if right:
        com[1] = -com[1]
    body.mass, body.ipos, body.inertia = inertial.mass, com, list(inertial.inertia)
    body.explicitinertial = True


def _quat(R: np.ndarray) -> np.ndarray:
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(R).reshape(-1))
    return quat
