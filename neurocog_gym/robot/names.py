"""Names and orderings of the quadruped, fixed once and used everywhere.

Leg order is ``FL, FR, HL, HR`` (front-left, front-right, hind-left, hind-right). Each leg has three
joints in the order hip abduction, hip flexion, knee, so joint ``3 * leg + k`` is joint ``k`` of
``leg``. Frames follow MuJoCo's convention: world z up, the robot walks along body +x, body +y is
its left.

The robot's own geoms live in geom group ``ROBOT_GEOM_GROUP``; the world (floor, walls, obstacles)
uses groups 0 and 1, so ray casts pass ``RAY_GEOM_GROUPS`` to skip the robot.
"""

from __future__ import annotations

import numpy as np

LEGS: tuple[str, ...] = ("FL", "FR", "HL", "HR")
JOINT_KINDS: tuple[str, ...] = ("abduct", "hip", "knee")
JOINTS: tuple[str, ...] = tuple(f"{leg}_{kind}" for leg in LEGS for kind in JOINT_KINDS)
ACTUATORS: tuple[str, ...] = JOINTS
TOUCH_SENSORS: tuple[str, ...] = tuple(f"{leg}_touch" for leg in LEGS)
FOOT_SITES: tuple[str, ...] = tuple(f"{leg}_foot" for leg in LEGS)
FOOT_GEOMS: tuple[str, ...] = tuple(f"{leg}_foot" for leg in LEGS)
HIP_BODIES: tuple[str, ...] = tuple(f"{leg}_hip" for leg in LEGS)
THIGH_BODIES: tuple[str, ...] = tuple(f"{leg}_thigh" for leg in LEGS)
"""Each thigh body's origin is its hip flexion joint."""
SHANK_BODIES: tuple[str, ...] = tuple(f"{leg}_shank" for leg in LEGS)
"""Each shank body's origin is its knee joint."""
TORSO: str = "torso"
TOF_SITES: tuple[str, ...] = ("tof_0", "tof_1", "tof_2", "tof_3")
"""Time-of-flight sensor sites, left to right. Site frame: +x optical axis, +y left, +z up."""

ROBOT_GEOM_GROUP: int = 2
WORLD_GEOM_GROUPS: tuple[int, ...] = (0, 1)
RAY_GEOM_GROUPS = np.array([1, 1, 0, 0, 0, 0], dtype=np.uint8)
"""Geom-group mask for ``mujoco.mj_multiRay``: world groups on, robot group off."""

N_LEGS: int = 4
N_JOINTS: int = 12
FRONT_LEGS: tuple[int, ...] = (0, 1)
