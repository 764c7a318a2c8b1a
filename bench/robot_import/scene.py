"""A trial scene on the user's unmodified model: ``trial --model MODEL``.

The model file is compiled as it is (its own bodies, actuators, contacts and options);
MuJoCo's model-editing API (``mujoco.MjSpec``) only *adds* to it what a trial needs,
never changes what is there:

* the tilted floor plane (``model._add_world``'s: friction μ, condim 3, priority 1, and
  the spec's ``[contact]`` as its ``solref`` where the spec has one that is not MuJoCo's
  default), and a free joint on the base where the model fixes it to the world (a URDF);
* the trial's sensors under the twin's names (``contact.add_trial_sensors``), pointing
  at the model's own bodies and joints: each foot's contacts with the floor (all its
  geoms), the mapped joints' angles and the actuator force on them (``JOINTACTFRC``),
  the base's pose, and sites for the sole point under each ankle and each foot's axes
  as the spec has them; ``contact.decode`` multiplies angles and torques by each mapped
  joint's sign (the numeric ``slopewalk_joint_sign``), so the recording is in the
  planner's convention;
* for a joint (mapped or held) that no position actuator of the model drives (a model
  with motors only), a position servo from the spec's [servo] table, as the twin's
  (``model.servo_settings``): kp, kv and the torque limit on the actuator, and the
  motor's rotor added to its joint's own (armature, back-EMF damping = stall torque / no-load speed,
  friction loss). Without the rotor, kv acts explicitly under a model's own Euler
  integrator and chatters on light links (a URDF's 0.04 kg ankle cross).

The playback's 8 commands (MJCF order, planner signs) become the model's controls
through ``controls``: a mapped joint's position actuator gets sign × its command, a
held joint's the map's angle, every other actuator (a motor) 0. The trial's timestep
replaces the model's; nothing else of its options changes (a model's own contact cone
and impratio stay: MuJoCo's defaults, pyramidal and 1, where it sets none, against the
twin's elliptic and 10). The floor's give is fed forward as on the twin (``floor``): the
contact's constants from the floor (its priority makes them the contact's), the foot's
inverse mass, and the corners of every box of the sole.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from slopewalk.bench.actuators import ACTUATOR_MODES
from slopewalk.bench.robot_import.fit import BaseFrame, Fit, fit_model, posed
from slopewalk.bench.robot_import.mapfile import SIDES, load_map
from slopewalk.bench.sim.contact import FOOT_GEOMS, JOINT_SIGN, MAX_CONTACTS, NON_FOOT_BODIES
from slopewalk.bench.sim.floor import SoftFloor
from slopewalk.bench.sim.model import (
    IMPRATIO,
    SceneError,
    check_contact_step,
    contact_solref,
    mujoco_message,
    servo_settings,
)
from slopewalk.planner.errors import SlopewalkError
from slopewalk.planner.joints import MJCF_JOINTS, SIDE_PREFIX
from slopewalk.planner.kinematics import Chain, rotation_slope_to_world
from slopewalk.planner.spec import JOINT_LIMIT_KEYS, RobotSpec

FLOOR = "slopewalk_floor"
_STATE = mujoco.mjtState.mjSTATE_FULLPHYSICS  # playback.py's
_SENSOR, _OBJ = mujoco.mjtSensor, mujoco.mjtObj
_FOUND, _FORCE, _POS = 1, 2, 16  # mjtConDataField bits (contact.py's)
_MINDIST, _NETFORCE = 1, 3


@dataclass
class ModelScene:
    """The trial scene of an imported model (module doc).

    Attributes:
        fit: The model fitted to the planner (``fit.fit_model``).
        spec: The imported spec (the plan's robot).
        welded: Weld each held joint at its angle (a joint equality constraint as stiff as
            the step allows, solref 2 steps, critically damped): the held joints as rigid
            as the planner takes them, for ``robot compare``; False: held by actuators.
        twin_contact: Play on the twin's contact options (elliptic cone, impratio 10)
            instead of the model's own, for ``robot compare``.
    """

    fit: Fit
    spec: RobotSpec
    welded: bool = False
    twin_contact: bool = False

    @property
    def name(self) -> str:
        """The model's name, marking the trial's outputs."""
        return self.fit.name

    def joints(self) -> list[tuple[str, float]]:
        """(model joint name, sign) of each MJCF joint (``joints.MJCF_JOINTS`` order)."""
        return [
            (self.fit.legs[side][kind].name, float(self.fit.legs[side][kind].sign))
            for side in SIDES
            for kind in JOINT_LIMIT_KEYS
        ]

    @property
    def base_name(self) -> str:
        """The name of the model's base body (the spec's pelvis)."""
        return self.fit.model.body(self.fit.base).name

    def build(self, plan, *, friction: float, actuators: str, timestep: float) -> mujoco.MjModel:
        """The model on the plan's tilted plane with the trial's sensors (module doc)."""
        mjs = self.editable(plan, friction=friction, actuators=actuators, timestep=timestep)
        try:
            return mjs.compile()
        except ValueError as err:
            raise SceneError(f"MuJoCo refused the model: {mujoco_message(err)}") from None

    def editable(self, plan, *, friction: float, actuators: str, timestep: float) -> mujoco.MjSpec:
        """``build``'s scene before it is compiled, for a caller that adds to it (a video's
        camera)."""
        if actuators not in model_modes(self.spec):
            raise SceneError(
                f"--actuators {actuators}: a model plays on its own actuators (gains "
                f"the spec's [servo]); use {' or '.join(model_modes(self.spec))}"
            )
        mjs = mujoco.MjSpec.from_file(self.fit.path)
        mjs.option.timestep = timestep
        floor = mjs.worldbody.add_geom(
            name=FLOOR, type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05],
            quat=_quat(rotation_slope_to_world(plan.params.slope)),
            friction=[friction, 0.005, 0.0001], condim=3, priority=1, contype=1, conaffinity=1,
        )  # fmt: skip
        check_contact_step(self.spec, timestep)
        solref = contact_solref(self.spec)
        if solref is not None:
            floor.solref = solref
        base = mjs.body(self.fit.model.body(self.fit.base).name)
        if not any(j.type == mujoco.mjtJoint.mjJNT_FREE for j in base.joints):
            base.add_freejoint()
        self._add_servos(mjs)
        if self.welded:
            self._weld_held(mjs, timestep)
        if self.twin_contact:
            mjs.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
            mjs.option.impratio = IMPRATIO
        self._add_sites(mjs)
        self._add_sensors(mjs)
        mjs.add_numeric(name=JOINT_SIGN, data=[sign for _, sign in self.joints()])
        return mjs

    def _position_actuated(self, mjs: mujoco.MjSpec) -> set[str]:
        """Joints a position actuator of the model drives (gear 1, kp = the spec's)."""
        out = set()
        for act in mjs.actuators:
            kp, bias = act.gainprm[0], act.biasprm
            if act.trntype != mujoco.mjtTrn.mjTRN_JOINT or bias[1] != -kp or kp <= 0:
                continue
            if act.gear[0] != 1:
                raise SceneError(f"actuator {act.name!r}: gear {act.gear[0]:g}; must be 1")
            out.add(act.target)
        return out

    def _add_servos(self, mjs: mujoco.MjSpec) -> None:
        have = self._position_actuated(mjs)
        spec = self.spec
        for joint in [name for name, _ in self.joints()] + list(self.fit.held):
            if joint in have:
                continue
            act = mjs.add_actuator(name=f"slopewalk_{joint}", target=joint)
            act.trntype = mujoco.mjtTrn.mjTRN_JOINT
            act.set_to_position(kp=spec.stiffness, kv=spec.velocity_gain)
            act.forcelimited = True
            act.forcerange = [-spec.stall_torque, spec.stall_torque]
            motor = mjs.joint(joint)  # the rotor adds to the joint's own (URDF <dynamics>)
            motor.armature += spec.armature
            damping = spec.joint_damping  # the spec's, or its back-EMF (``servo_settings``)
            if np.ndim(motor.damping):  # MuJoCo 4: polynomial coefficients; 3.x: a number
                motor.damping = np.asarray(motor.damping) + [damping, 0.0, 0.0]
            else:
                motor.damping += damping
            motor.frictionloss += spec.friction_loss

    def _weld_held(self, mjs: mujoco.MjSpec, timestep: float) -> None:
        """A joint equality per held joint: q = its held angle (``welded``)."""
        qpos0 = self.fit.model.qpos0
        for name, angle in self.fit.held.items():
            weld = mjs.add_equality(
                name=f"slopewalk_weld_{name}", type=mujoco.mjtEq.mjEQ_JOINT, name1=name,
                objtype=_OBJ.mjOBJ_JOINT,
            )  # fmt: skip
            data = np.zeros(len(weld.data))  # joint1 alone: q − q0 = data[0]
            data[0] = angle - qpos0[self.fit.model.joint(name).qposadr[0]]
            weld.data = data
            weld.solref = [2 * timestep, 1.0]

    def _add_sites(self, mjs: mujoco.MjSpec) -> None:
        """Sole point and spec-aligned axes on each foot; the spec's pelvis frame on the base."""
        model, fit = self.fit.model, self.fit
        ref = posed(model, fit.qpos)
        frame = BaseFrame(ref, fit.base)
        for side, prefix in zip(SIDES, SIDE_PREFIX, strict=True):
            foot = fit.feet[side]
            sole = fit.ankle_centre(side) - [0, 0, fit.geometry["ankle_height"]]
            world = frame.R @ sole + frame.p
            R_foot = ref.xmat[foot].reshape(3, 3)
            mjs.body(model.body(foot).name).add_site(
                name=f"{prefix}sole",
                pos=R_foot.T @ (world - ref.xpos[foot]),
                quat=_quat(R_foot.T @ frame.R),
            )
        mjs.body(model.body(fit.base).name).add_site(name="slopewalk_pelvis", pos=fit.pelvis_origin)

    def _add_sensors(self, mjs: mujoco.MjSpec) -> None:
        """``contact.add_trial_sensors``'s sensors, by name, on the model's parts."""
        fit, model = self.fit, self.fit.model
        feet = [model.body(fit.feet[side]).name for side in SIDES]
        for geom, foot in zip(FOOT_GEOMS, feet, strict=True):
            for suffix, prm in (
                ("contacts", [_FOUND | _FORCE | _POS, _MINDIST, MAX_CONTACTS]),
                ("net", [_FORCE, _NETFORCE, 1]),
            ):
                mjs.add_sensor(
                    name=f"{geom}_{suffix}", type=_SENSOR.mjSENS_CONTACT, objtype=_OBJ.mjOBJ_BODY,
                    objname=foot, reftype=_OBJ.mjOBJ_GEOM, refname=FLOOR, intprm=prm,
                )  # fmt: skip
        links = {"thigh": "hip_pitch", "shank": "knee", "ankle": "ankle_pitch"}
        for body in NON_FOOT_BODIES:
            if body == "pelvis":
                carrier = model.body(fit.base).name
            else:
                side = SIDES[SIDE_PREFIX.index(body[:2])]
                carrier = model.body(fit.legs[side][links[body[2:]]].body).name
            mjs.add_sensor(
                name=f"{body}_touch", type=_SENSOR.mjSENS_CONTACT, objtype=_OBJ.mjOBJ_BODY,
                objname=carrier, reftype=_OBJ.mjOBJ_GEOM, refname=FLOOR,
                intprm=[_FOUND, _NETFORCE, 1],
            )  # fmt: skip
        for p in SIDE_PREFIX:
            for name, kind in (
                ("sole_pos", "FRAMEPOS"),
                ("foot_zaxis", "FRAMEZAXIS"),
                ("foot_xaxis", "FRAMEXAXIS"),  # the heading (walk_check), rigid with the foot
            ):
                mjs.add_sensor(
                    name=f"{p}{name}", type=getattr(_SENSOR, f"mjSENS_{kind}"),
                    objtype=_OBJ.mjOBJ_SITE, objname=f"{p}sole",
                )  # fmt: skip
        for name, kind in (("pelvis_pos", "FRAMEPOS"), ("pelvis_quat", "FRAMEQUAT")):
            mjs.add_sensor(
                name=name, type=getattr(_SENSOR, f"mjSENS_{kind}"),
                objtype=_OBJ.mjOBJ_SITE, objname="slopewalk_pelvis",
            )  # fmt: skip
        for twin, (joint, _) in zip(MJCF_JOINTS, self.joints(), strict=True):
            for suffix, kind in (("pos", "JOINTPOS"), ("torque", "JOINTACTFRC")):
                mjs.add_sensor(
                    name=f"{twin}_{suffix}", type=getattr(_SENSOR, f"mjSENS_{kind}"),
                    objtype=_OBJ.mjOBJ_JOINT, objname=joint,
                )  # fmt: skip

    def floor(self, model: mujoco.MjModel) -> SoftFloor:
        """The soft floor under this model's feet (``floor.SoftFloor``, module doc).

        The corners are the bottom corners of each foot's box collision geoms at the
        reference pose, in the spec's sole axes from its sole rectangle's centre; a foot
        with any other collision shape keeps the rectangle's 4 corners.
        """
        g = model.geom(FLOOR).id
        timeconst, dampratio = (float(v) for v in model.geom_solref[g])
        d0, d_max, width, midpoint, power = (float(v) for v in model.geom_solimp[g][:5])
        fit = self.fit
        foot = model.body(fit.model.body(fit.feet[SIDES[0]]).name).id
        corners = [self._sole_corners(side) for side in SIDES]
        return SoftFloor(
            timeconst, dampratio, (d0, d_max, width, midpoint, power),
            float(model.body_invweight0[foot, 0]),
            None if any(c is None for c in corners) else tuple(corners),
        )  # fmt: skip

    def _sole_corners(self, side: str) -> np.ndarray | None:
        fit, model, spec = self.fit, self.fit.model, self.spec
        ref = posed(model, fit.qpos)
        frame = BaseFrame(ref, fit.base)
        centre = fit.ankle_centre(side) - [0, 0, fit.geometry["ankle_height"]]
        centre = centre + [(spec.ankle_to_toe - spec.heel_offset) / 2, 0.0, 0.0]
        centre[1] += spec.sole_shift(SIDES.index(side))
        points = []
        for g in np.flatnonzero(model.geom_bodyid == fit.feet[side]):
            if not (model.geom_contype[g] or model.geom_conaffinity[g]):
                continue
            if model.geom_type[g] != mujoco.mjtGeom.mjGEOM_BOX:
                return None
            signs = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
            local = signs * model.geom_size[g]
            world = ref.geom_xpos[g] + local @ ref.geom_xmat[g].reshape(3, 3).T
            points.append(frame.point(world) - centre)
        if not points:
            return None
        every = np.concatenate(points)
        bottom = every[np.abs(every[:, 2] - every[:, 2].min()) < 1e-6]
        return bottom[:, :2]

    def controls(self, model: mujoco.MjModel, q_ref: np.ndarray) -> np.ndarray:
        """The model's controls (m, nu) from the playback's commands (m, 8) (module doc)."""
        q_ref = np.atleast_2d(q_ref)
        mapped = {name: (k, sign) for k, (name, sign) in enumerate(self.joints())}
        A, b = np.zeros((model.nu, 8)), np.zeros(model.nu)
        for a in range(model.nu):
            kp = model.actuator_gainprm[a, 0]
            position = kp > 0 and model.actuator_biasprm[a, 1] == -kp
            if model.actuator_trntype[a] != mujoco.mjtTrn.mjTRN_JOINT or not position:
                continue  # a motor (or another transmission): no command
            joint = model.joint(model.actuator_trnid[a, 0]).name
            if joint in mapped:
                k, sign = mapped[joint]
                A[a, k] = sign
            elif joint in self.fit.held:
                b[a] = self.fit.held[joint]
        return q_ref @ A.T + b

    def initial_state(self, model: mujoco.MjModel, plan) -> np.ndarray:
        """Full physics state at the plan's first pose, soles on the plane, held joints held."""
        fit = self.fit
        chain = Chain.from_spec(plan.spec)
        frames = chain.frames(plan.q[:1], plan.stance_sole[:1], plan.stance[:1])
        (pelvis, ), (rotation, ) = chain.pelvis_pose(frames, plan.stance[:1])  # fmt: skip
        R_ws = rotation_slope_to_world(plan.params.slope)
        data = mujoco.MjData(model)
        for j in range(fit.model.njnt):  # the reference pose, joint by joint (a free joint
            if fit.model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE:  # added to a URDF's base
                continue  # moves the addresses)
            src, dst = fit.model.jnt_qposadr[j], model.joint(fit.model.joint(j).name).qposadr[0]
            data.qpos[dst] = fit.qpos[src]
        base = model.body(fit.model.body(fit.base).name).id
        free = [j for j in range(model.njnt) if model.jnt_bodyid[j] == base
                and model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE]  # fmt: skip
        adr = model.jnt_qposadr[free[0]]
        R_base = R_ws @ rotation
        data.qpos[adr : adr + 3] = R_ws @ pelvis - R_base @ fit.pelvis_origin
        mujoco.mju_mat2Quat(data.qpos[adr + 3 : adr + 7], R_base.reshape(-1))
        for (name, sign), value in zip(self.joints(), plan.q_left_right[0], strict=True):
            data.qpos[model.joint(name).qposadr[0]] = sign * value
        for name, value in fit.held.items():
            data.qpos[model.joint(name).qposadr[0]] = value
        data.ctrl[:] = self.controls(model, plan.q_left_right[0])[0]
        mujoco.mj_forward(model, data)
        state = np.empty(mujoco.mj_stateSize(model, _STATE))
        mujoco.mj_getState(model, data, state, _STATE)
        return state


def model_modes(spec: RobotSpec) -> tuple[str, ...]:
    """The actuator modes (``actuators.ACTUATOR_MODES``) a model plays in: those whose
    gains are the spec's [servo] table (the model's own actuators), e.g. servo, servo_ff."""
    return tuple(m for m in ACTUATOR_MODES if servo_settings(spec, m).kp == spec.stiffness)


def model_scene(model_path, map_path=None, spec: RobotSpec | None = None) -> ModelScene:
    """The trial scene of the model at ``model_path`` (``trial --model``): fitted with the
    map at ``map_path`` (None: detect everything); ``spec`` the plan's robot (``--robot``),
    None: the spec ``robot import`` writes for it.

    Raises:
        RobotImportError: the model or map cannot be read or does not fit, in one line.
    """
    from slopewalk.bench.robot_import.write import imported_spec
    from slopewalk.planner.spec import spec_from_dict

    robot_map = load_map(map_path)
    fit = fit_model(model_path, robot_map)
    if spec is None:
        spec = spec_from_dict(imported_spec(fit, robot_map)[0])
    return ModelScene(fit, spec)


def _quat(R: np.ndarray) -> np.ndarray:
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(R).reshape(-1))
    return quat


class ModelSceneError(SlopewalkError):
    """A model that cannot be played as a trial scene."""
