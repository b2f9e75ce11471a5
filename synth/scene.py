"""The MuJoCo scene, built in code with ``mujoco.MjSpec``: specimen, finger, robot drives.

Bodies (x = sliding direction, z up; the specimen's plate top is z = 0):

- ``specimen`` (mocap): base plate box + the convex pieces of the raised outline. It is
  kinematic (clamped to the table); its mocap pose carries the surface texture under the
  simulated contact (see :mod:`synth.texture` and :mod:`synth.closed_loop`): its height
  by the vertical position, its slope along the path by a small turn, so the contact's
  normal tilts with the texture and the texture acts through the contact physics at the
  cost of five numbers per step instead of a fine height field.
- ``phalanx``: the rigid finger bone on the robot's tip: x, y and z slide joints held by
  stiff position servos; the robot's controller moves the x/y set points along the path
  and the z set point to hold the normal force.
- ``pad``: the soft skin pad (a sphere with soft contact) on the PDMS support, modelled as
  spring-damper joints (x, y, z shear/compression and pitch) between pad and phalanx.

The skin's contact parameters are the finger's (one contact model for every material);
the skin geom has the higher contact priority, so its friction, which the controller
updates from the friction law as the slip speed and load change, is the contact's.

Sensors: a force/torque pair at the pad mount (the load the phalanx and its strain gauges
carry), the z servo's force (the robot's wrist reading), the pad's rocking angle, an
accelerometer on the pad, the pad's position,
the position and velocity of the skin's bottom point (the skin material that rubs on
the surface: it moves over the surface only when the skin slips), and contact sensors
(net force, the deepest penetration and the centroid of the skin-specimen contacts).
"""

from __future__ import annotations

import copy
import functools
import json
import math
from dataclasses import dataclass

import mujoco
import numpy as np

import shapes
from shapes import SPECIMEN, SpecimenLike, specimen_name

from .config import Finger, Motion, SynthConfig

#: Sensor layout of the compiled model: name -> (first column, width) in ``sensordata``.
SENSORS: tuple[tuple[str, int], ...] = (
    ("mount_force", 3),
    ("mount_torque", 3),
    ("pad_acc", 3),
    ("pad_pos", 3),
    ("skin_pos", 3),
    ("slip_vel", 3),
    ("contact", 10),  # contacts found, net force (3), net torque (3), force centroid (3)
    ("contact_depth", 2),  # contacts found, the deepest contact's signed distance
    ("drive_force", 1),  # force of the z servo on the phalanx (the robot's wrist reading)
    ("pad_pitch", 1),  # rocking of the pad on its support (rad)
)

#: Actuators: x, y and z position servos.
N_CTRL = 3
#: Control vector per step (MuJoCo's order): the 3 servo set points, the specimen's
#: mocap position (its texture height) and orientation (its texture slope).
CONTROL_SPEC = (
    mujoco.mjtState.mjSTATE_CTRL
    | mujoco.mjtState.mjSTATE_MOCAP_POS
    | mujoco.mjtState.mjSTATE_MOCAP_QUAT
)


def control_layout(model: mujoco.MjModel) -> dict[str, slice]:
    """Where each input sits in a :data:`CONTROL_SPEC` vector."""
    mocap = model.nu
    return {
        "ctrl": slice(0, model.nu),
        "mocap_pos": slice(mocap, mocap + 3),
        "mocap_quat": slice(mocap + 3, mocap + 7),
        "size": slice(0, mocap + 7),
    }


def rest_control(model: mujoco.MjModel) -> np.ndarray:
    """A :data:`CONTROL_SPEC` vector with every input at rest: servo set points 0, the
    specimen at its place, unturned (the identity quaternion)."""
    lay = control_layout(model)
    control = np.zeros(lay["size"].stop)
    control[lay["mocap_quat"].start] = 1.0
    return control


STATE_SPEC = mujoco.mjtState.mjSTATE_FULLPHYSICS


def sensor_columns() -> dict[str, slice]:
    cols, start = {}, 0
    for name, width in SENSORS:
        cols[name] = slice(start, start + width)
        start += width
    return cols


@dataclass(frozen=True)
class Scene:
    """A compiled base model for one shape, and the indices the simulator needs."""

    shape: SpecimenLike
    model: mujoco.MjModel
    specimen_geoms: np.ndarray  # geom ids of plate + pieces
    skin_geom: int
    qpos_index: dict[str, int]

    def trial_model(self, friction: float) -> mujoco.MjModel:
        """A copy of the base model for one trial, its skin friction set to ``friction``
        (the controller changes it as the trial runs)."""
        m = copy.copy(self.model)
        m.geom_friction[self.skin_geom, 0] = friction
        return m


def _pad_height(finger: Finger) -> float:
    """Phalanx origin height that puts the pad's bottom on the plate."""
    return finger.pad_radius_m


def build_spec(shape: SpecimenLike, finger: Finger, motion: Motion) -> mujoco.MjSpec:
    """The scene as an ``MjSpec`` (before per-trial contact parameters); ``shape`` is a
    built-in shape's name or a ``shapes.Specimen``."""
    pieces = shapes.convex_pieces(shape) if motion.raised_shape else []
    spec = mujoco.MjSpec()
    spec.modelname = f"tactile_{specimen_name(shape)}"
    opt = spec.option
    opt.timestep = motion.timestep_s
    # Stiff drives need the implicit-in-velocity integrator; with the elliptic friction
    # cone a sliding contact's tangential/normal force ratio is the friction coefficient
    # (MuJoCo's pyramidal default only approximates the cone by its edges).
    opt.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    opt.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    opt.impratio = motion.impratio
    # The skin's parameters rule every skin-specimen contact (priority): the specimen's
    # own friction is never used.
    skin_contact = {
        "condim": 3,
        "solref": list(finger.skin_solref),
        "solimp": list(finger.skin_solimp),
        "priority": 1,
    }
    contact = {"condim": 3}

    world = spec.worldbody
    specimen = world.add_body(name="specimen", mocap=True)
    half = [SPECIMEN.base_length_m / 2, SPECIMEN.base_width_m / 2, SPECIMEN.base_thickness_m / 2]
    specimen.add_geom(
        name="plate",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=half,
        pos=[0, 0, -SPECIMEN.base_thickness_m / 2],
        rgba=[0.6, 0.6, 0.65, 1],
        **contact,
    )
    for i, piece in enumerate(pieces):
        spec.add_mesh(
            name=f"piece{i}",
            uservert=piece.vertices.ravel().tolist(),
            userface=piece.faces.ravel().tolist(),
        )
        specimen.add_geom(
            name=f"piece{i}",
            type=mujoco.mjtGeom.mjGEOM_MESH,
            meshname=f"piece{i}",
            rgba=[0.8, 0.5, 0.3, 1],
            **contact,
        )

    phalanx = world.add_body(name="phalanx", pos=[0, 0, _pad_height(finger)], gravcomp=1)
    slide = mujoco.mjtJoint.mjJNT_SLIDE
    phalanx.add_joint(name="robot_x", type=slide, axis=[1, 0, 0])
    phalanx.add_joint(name="robot_y", type=slide, axis=[0, 1, 0])
    phalanx.add_joint(name="robot_z", type=slide, axis=[0, 0, 1])
    side = finger.pad_radius_m * 0.8
    phalanx.add_geom(
        name="bone",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[side / 2, side / 2, 0.012],
        pos=[0, 0, finger.pad_radius_m + 0.012],
        mass=finger.phalanx_mass_kg,
        contype=0,
        conaffinity=0,
        rgba=[0.3, 0.3, 0.35, 1],
    )

    pad = phalanx.add_body(name="pad", gravcomp=1)
    m_pad = finger.pad_mass_kg
    zeta = finger.pdms_damping_ratio
    for name, axis, k in (
        ("pdms_x", [1, 0, 0], finger.pdms_shear_stiffness_n_m),
        ("pdms_y", [0, 1, 0], finger.pdms_shear_stiffness_n_m),
        ("pdms_z", [0, 0, 1], finger.pdms_normal_stiffness_n_m),
    ):
        pad.add_joint(
            name=name, type=slide, axis=axis, stiffness=k, damping=2 * zeta * math.sqrt(k * m_pad)
        )
    inertia_pitch = 0.4 * m_pad * finger.pad_radius_m**2 + m_pad * finger.pad_radius_m**2
    k_pitch = finger.pdms_pitch_stiffness_nm_rad
    pad.add_joint(
        name="pdms_pitch",
        type=mujoco.mjtJoint.mjJNT_HINGE,
        axis=[0, 1, 0],
        pos=[0, 0, finger.pad_radius_m],  # the pad rocks about its mount, above the skin
        stiffness=k_pitch,
        damping=2 * zeta * math.sqrt(k_pitch * inertia_pitch),
    )
    pad.add_geom(
        name="skin",
        type=mujoco.mjtGeom.mjGEOM_SPHERE,
        size=[finger.pad_radius_m, 0, 0],
        mass=m_pad,
        rgba=[0.9, 0.75, 0.65, 1],
        **skin_contact,
    )
    pad.add_site(name="mount", pos=[0, 0, finger.pad_radius_m])
    pad.add_site(name="pad_center", pos=[0, 0, 0])
    pad.add_site(name="skin_bottom", pos=[0, 0, -finger.pad_radius_m])

    def servo(name: str, joint: str) -> None:
        act = spec.add_actuator(name=name, target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.set_to_position(kp=motion.servo_stiffness_n_m, kv=motion.servo_damping_n_s_m)

    servo("drive_x", "robot_x")
    servo("drive_y", "robot_y")
    servo("drive_z", "robot_z")

    sens = mujoco.mjtSensor
    site = mujoco.mjtObj.mjOBJ_SITE
    spec.add_sensor(name="mount_force", type=sens.mjSENS_FORCE, objtype=site, objname="mount")
    spec.add_sensor(name="mount_torque", type=sens.mjSENS_TORQUE, objtype=site, objname="mount")
    spec.add_sensor(
        name="pad_acc", type=sens.mjSENS_ACCELEROMETER, objtype=site, objname="pad_center"
    )
    spec.add_sensor(name="pad_pos", type=sens.mjSENS_FRAMEPOS, objtype=site, objname="pad_center")
    spec.add_sensor(name="skin_pos", type=sens.mjSENS_FRAMEPOS, objtype=site, objname="skin_bottom")
    spec.add_sensor(
        name="slip_vel", type=sens.mjSENS_FRAMELINVEL, objtype=site, objname="skin_bottom"
    )
    # Skin-specimen contacts reduced to their net force and torque (global frame) and the
    # force-weighted centroid: intprm = (data flags found|force|torque|pos, reduce=netforce, num).
    spec.add_sensor(
        name="contact",
        type=sens.mjSENS_CONTACT,
        objtype=mujoco.mjtObj.mjOBJ_GEOM,
        objname="skin",
        reftype=mujoco.mjtObj.mjOBJ_BODY,
        refname="specimen",
        intprm=[_CONTACT_DATA, _REDUCE_NETFORCE, 1],
    )
    spec.add_sensor(
        name="contact_depth",
        type=sens.mjSENS_CONTACT,
        objtype=mujoco.mjtObj.mjOBJ_GEOM,
        objname="skin",
        reftype=mujoco.mjtObj.mjOBJ_BODY,
        refname="specimen",
        intprm=[_FOUND | _DIST, _REDUCE_MINDIST, 1],
    )
    spec.add_sensor(
        name="drive_force",
        type=sens.mjSENS_ACTUATORFRC,
        objtype=mujoco.mjtObj.mjOBJ_ACTUATOR,
        objname="drive_z",
    )
    spec.add_sensor(
        name="pad_pitch",
        type=sens.mjSENS_JOINTPOS,
        objtype=mujoco.mjtObj.mjOBJ_JOINT,
        objname="pdms_pitch",
    )
    return spec


# mjtConDataField bits: found 1, force 2, torque 4, dist 8, pos 16; reduce 1 = mindist,
# 3 = netforce.
_FOUND, _DIST = 1, 8
_CONTACT_DATA = 1 | 2 | 4 | 16
_REDUCE_MINDIST = 1
_REDUCE_NETFORCE = 3


@functools.lru_cache(maxsize=64)
def _scene_cached(shape: SpecimenLike, finger_json: str, motion_json: str) -> Scene:
    from .params import from_dict

    finger = from_dict(Finger, json.loads(finger_json))
    motion = from_dict(Motion, json.loads(motion_json))
    model = build_spec(shape, finger, motion).compile()
    expected = sum(w for _, w in SENSORS)
    if model.nsensordata != expected:
        raise RuntimeError(f"scene sensors: {model.nsensordata} values, expected {expected}")
    geoms = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "plate")]
    geoms += [
        mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, f"piece{i}") for i in range(model.nmesh)
    ]
    qpos_index = {model.joint(j).name: int(model.jnt_qposadr[j]) for j in range(model.njnt)}
    return Scene(
        shape=shape,
        model=model,
        specimen_geoms=np.asarray(geoms, dtype=np.intp),
        skin_geom=mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "skin"),
        qpos_index=qpos_index,
    )


def scene(shape: SpecimenLike, config: SynthConfig) -> Scene:
    """The compiled scene for ``shape``, a built-in shape's name or a ``shapes.Specimen``
    (cached per shape and finger/motion parameters)."""
    # Every trial's plan asks, mostly with the same configuration objects: they are
    # answered by identity first (hashing the two sections takes longer than the rest of
    # the look-up). The entry keeps the sections alive, so their ids stay theirs.
    key = (shape, id(config.finger), id(config.motion))
    hit = _by_identity.get(key)
    if hit is not None and hit[0] is config.finger and hit[1] is config.motion:
        return hit[2]
    try:
        found = _scene_for(shape, config.finger, config.motion)
    except TypeError:  # a section holding an unhashable value (e.g. a list for a tuple)
        return _scene_for.__wrapped__(shape, config.finger, config.motion)
    if len(_by_identity) >= 64:
        _by_identity.clear()
    _by_identity[key] = (config.finger, config.motion, found)
    return found


_by_identity: dict[tuple[SpecimenLike, int, int], tuple[Finger, Motion, Scene]] = {}


@functools.lru_cache(maxsize=64)
def _scene_for(shape: SpecimenLike, finger: Finger, motion: Motion) -> Scene:
    # Every trial's plan asks for its scene: this cache answers from the (frozen, hashable)
    # parameter sections, the one below from their serialised values, so that equal
    # parameters share one compiled model.
    return _scene_cached(
        shape,
        json.dumps(_plain(finger), sort_keys=True),
        json.dumps(_plain(motion), sort_keys=True),
    )


def _plain(obj) -> dict:
    from .params import to_dict

    return to_dict(obj)
