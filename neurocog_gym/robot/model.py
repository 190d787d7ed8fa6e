"""Loading the robot and scene, and the name-to-index map every stage uses.

Sensors, joints, sites and geoms are looked up by name (``names.py``), never by a magic index.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import mujoco
import numpy as np

from neurocog_gym import paths
from neurocog_gym.robot import names

GRAVITY = 9.81
"""m/s², the scenes' gravity (cost of transport and the per-leg weight of the touch sensors)."""
FAULT_WARNINGS = (
    mujoco.mjtWarning.mjWARN_BADQACC,
    mujoco.mjtWarning.mjWARN_BADQPOS,
    mujoco.mjtWarning.mjWARN_BADQVEL,
    mujoco.mjtWarning.mjWARN_CONTACTFULL,
    mujoco.mjtWarning.mjWARN_CNSTRFULL,
)
"""MuJoCo warnings after which the physics can no longer be trusted (a sim fault)."""


@lru_cache(maxsize=4)
def _model_xml_path(scene: str) -> str:
    return str(paths.asset(scene))


BODIES = ("v1", "v2")
"""Robot bodies an env can be built with (the ``body`` keyword): ``"v2"``, the envs' default
since the -v2 ids, is ``quadruped.xml`` with bent shanks (``robot.variants.bend_shanks``: the
lowest 10 cm of each shank stand upright above the sole; docs/body_v2.md); ``"v1"`` is
``quadruped.xml`` as it is (straight shanks: the -v1 envs' body)."""


def check_body(body: str) -> str:
    """``body`` if it is one of :data:`BODIES`, else a ``ValueError`` naming them."""
    if body not in BODIES:
        raise ValueError(f"body must be one of {BODIES}, got {body!r}")
    return body


def scene_spec(body: str = "v1", scene: str = paths.SCENE_XML) -> mujoco.MjSpec:
    """The scene (which includes the robot) as an ``MjSpec`` with the given body."""
    check_body(body)
    spec = mujoco.MjSpec.from_file(_model_xml_path(scene))
    if body == "v2":
        from neurocog_gym.robot.variants import bend_shanks

        bend_shanks(spec)
    return spec


def load_model(scene: str = paths.SCENE_XML, body: str = "v1") -> mujoco.MjModel:
    """Compile the scene (which includes the robot) with ``body`` into a fresh ``MjModel``.

    The default is the XML as written (body v1), which the training code keeps: the shipped
    AEF weights were babbled and the gait tuned on it, and the two bodies share their joints,
    kinematics and masses (v2 only bends the shanks' collision capsules). The envs default to
    body v2 (their ``body`` keyword).
    """
    if check_body(body) == "v1":
        return mujoco.MjModel.from_xml_path(_model_xml_path(scene))
    return scene_spec(body, scene).compile()


@dataclass(frozen=True)
class RobotIndex:
    """Addresses of the robot's parts in one compiled model (all arrays int, names.py order)."""

    torso_body: int
    qpos_adr: np.ndarray
    """(12,) qpos address of each actuated joint."""
    dof_adr: np.ndarray
    """(12,) qvel address of each actuated joint."""
    actuator: np.ndarray
    """(12,) actuator id of each joint's servo."""
    touch_adr: np.ndarray
    """(4,) sensordata address of each sole's touch sensor."""
    foot_site: np.ndarray
    """(4,) site id of each foot."""
    foot_geom: np.ndarray
    """(4,) geom id of each foot."""
    hip_body: np.ndarray
    """(4,) body id of each leg's first body (its hip)."""
    thigh_body: np.ndarray
    """(4,) body id of each thigh (origin: the hip flexion joint)."""
    shank_body: np.ndarray
    """(4,) body id of each shank (origin: the knee)."""
    tof_site: np.ndarray
    """(4,) site id of each time-of-flight sensor."""
    robot_geoms: np.ndarray
    """ids of every geom that belongs to the robot."""
    joint_lo: np.ndarray
    """(12,) lower joint limit, rad."""
    joint_hi: np.ndarray
    """(12,) upper joint limit, rad."""
    home_qpos: np.ndarray
    """(nq,) the ``home`` keyframe."""
    home_ctrl: np.ndarray
    """(12,) servo targets of the ``home`` keyframe, rad."""
    mass: float
    """Total robot mass, kg."""
    knee_behind: np.ndarray
    """(4,) bool, legs whose knee folds behind the foot. The MJCF convention: a positive knee
    angle folds the leg, so a knee joint about +y has its knee ahead of the foot and one about
    -y behind it (``locomotion.motor.leg_coordinates``)."""

    @classmethod
    def build(cls, model: mujoco.MjModel) -> RobotIndex:
        """Look every part up by name; a missing name raises ``KeyError`` naming it."""

        def one(kind, name):
            try:
                return getattr(model, kind)(name).id
            except KeyError:
                raise KeyError(f"the model has no {kind} named {name!r}") from None

        joints = np.array([one("joint", n) for n in names.JOINTS])
        torso = one("body", names.TORSO)
        touch = np.array([model.sensor_adr[one("sensor", n)] for n in names.TOUCH_SENSORS])
        robot_geoms = np.flatnonzero(model.geom_group == names.ROBOT_GEOM_GROUP)
        key = one("key", "home")
        return cls(
            torso_body=torso,
            qpos_adr=model.jnt_qposadr[joints].copy(),
            dof_adr=model.jnt_dofadr[joints].copy(),
            actuator=np.array([one("actuator", n) for n in names.ACTUATORS]),
            touch_adr=touch,
            foot_site=np.array([one("site", n) for n in names.FOOT_SITES]),
            foot_geom=np.array([one("geom", n) for n in names.FOOT_GEOMS]),
            hip_body=np.array([one("body", n) for n in names.HIP_BODIES]),
            thigh_body=np.array([one("body", n) for n in names.THIGH_BODIES]),
            shank_body=np.array([one("body", n) for n in names.SHANK_BODIES]),
            tof_site=np.array([one("site", n) for n in names.TOF_SITES]),
            robot_geoms=robot_geoms,
            joint_lo=model.jnt_range[joints, 0].copy(),
            joint_hi=model.jnt_range[joints, 1].copy(),
            home_qpos=model.key_qpos[key].copy(),
            home_ctrl=model.key_ctrl[key].copy(),
            mass=float(model.body_subtreemass[torso]),
            knee_behind=model.jnt_axis[joints[2::3], 1] < 0.0,
        )
