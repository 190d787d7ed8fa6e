"""Body variants built from the shipped model with ``mujoco.MjSpec`` (design studies, not envs).

``knee_behind`` is the candidate for body v2 (issue 21): every knee folds behind its foot, as
MuJoCo Menagerie's A1 and Go1 do, so that a front foot, not the shank, leads the leg over a
block. It reverses each knee's axis (a positive knee angle still folds the leg), moves the hip
range to the thigh pointing backwards, and mirrors the home pose's hip angle so each foot stays
under its hip. The motor-neuron pools drive such a leg in leg coordinates
(``locomotion.motor.leg_coordinates``), so the shipped gait and interrupts move its feet as they
move body v1's. ``scripts/stepover_geometry.py`` gives the reason in numbers; the envs still use
body v1 until v2 is tuned and benchmarked (docs/oracle_notes.md).

``kinked_shank`` keeps body v1's joints, gait and kinematics (knee to foot stays 0.20 m) and
bends each shank's collision capsule so that its lowest ``low`` metres stand upright when the
shank pitches ``pitch`` rad (the gait's shank pitch at the moments a sole meets a block's
face): the part of the leg at a block's height is then the segment above the sole, not a
shank that leads it by 10-17 cm. A rigid bent tube, no new joint; the same idea as the
pantograph legs whose lowest segment stays upright. Measured in docs/oracle_notes.md.

``servo_speed`` keeps everything but the servos' no-load speed: each position servo's velocity
gain becomes its stall torque over the new speed (the slope of a DC motor's torque-speed line,
as body v1 models its MX-64s), so the joints can move faster at the same torque. The pools'
theta_dot_MAX is the gait's (``Gait.vel_max``): a gait for such a body says the same speed.
A design study of the time a step over takes (docs/oracle_notes.md, "The servo's speed").
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from neurocog_gym import io as nio
from neurocog_gym import paths
from neurocog_gym.robot import names

KNEE_BEHIND_HIP_RANGE = (-1.0, 3.0)
"""Hip range of a knee-behind leg, rad: the thigh from 57 degrees forward to 172 degrees back
(shank pitches hip - knee from -3.8 to 2.9 rad; the gait uses about -1.5 to 0)."""


def knee_behind(scene: str | Path | None = None) -> mujoco.MjSpec:
    """The scene's spec with every leg folded knee-behind (module docstring).

    Args:
        scene: the scene XML (default: the shipped ``scene.xml``).
    """
    spec = mujoco.MjSpec.from_file(str(scene or paths.asset(paths.SCENE_XML)))
    lo, hi = KNEE_BEHIND_HIP_RANGE
    key = spec.key("home")
    if key is None:
        raise KeyError("the scene has no keyframe named 'home'")
    qpos, ctrl = np.array(key.qpos), np.array(key.ctrl)
    for leg, prefix in enumerate(names.LEGS):
        knee = spec.joint(f"{prefix}_knee")
        hip = spec.joint(f"{prefix}_hip")
        if knee is None or hip is None:
            raise KeyError(f"the scene has no joints {prefix}_hip / {prefix}_knee")
        knee.axis = -np.asarray(knee.axis)
        hip.range = [lo, hi]
        spec.actuator(f"{prefix}_hip").ctrlrange = [lo, hi]
        # The foot stays under the hip: the thigh mirrors, hip -> hip + knee.
        q_hip, c_hip = 7 + 3 * leg + 1, 3 * leg + 1
        qpos[q_hip] = qpos[q_hip] + qpos[q_hip + 1]
        ctrl[c_hip] = ctrl[c_hip] + ctrl[c_hip + 1]
    key.qpos, key.ctrl = qpos.tolist(), ctrl.tolist()
    return spec


KINKED_LOW = 0.10
"""Length of a kinked shank's lower, upright segment, m (above the 6-8 cm blocks' tops)."""
KINKED_PITCH = 0.8
"""Shank pitch (hip + knee angle, rad) at which the lower segment is vertical: body v1's home
pose (hip -0.8, knee 1.6) and its shank at the end of a stance and the start of a swing."""


def kinked_shank(
    scene: str | Path | None = None, low: float = KINKED_LOW, pitch: float = KINKED_PITCH
) -> mujoco.MjSpec:
    """The scene's spec with every shank's collision capsule bent (:func:`bend_shanks`).

    Args:
        scene: the scene XML (default: the shipped ``scene.xml``).
        low: length of the lower, upright segment, m (:func:`bend_shanks`).
        pitch: shank pitch at which that segment is vertical, rad (:func:`bend_shanks`).
    """
    spec = mujoco.MjSpec.from_file(str(scene or paths.asset(paths.SCENE_XML)))
    return bend_shanks(spec, low, pitch)


def bend_shanks(
    spec: mujoco.MjSpec, low: float = KINKED_LOW, pitch: float = KINKED_PITCH
) -> mujoco.MjSpec:
    """Bend every shank's collision capsule in ``spec``, in place (module docstring).

    Each ``{leg}_shank`` capsule runs from the knee to a kink point ``low`` above the foot's
    centre along the direction that is vertical at shank pitch ``pitch``; a new capsule
    ``{leg}_shank_low`` (same radius, class and collision bits) runs from there to the foot.
    The shank's mass is split between the two by length; the joints, the foot and every
    other body are unchanged.

    Args:
        spec: a spec of the scene (or of the robot alone) with body v1's straight shanks.
        low: length of the lower, upright segment, m (0 < low < 0.2).
        pitch: shank pitch at which that segment is vertical, rad (|pitch| < pi / 2).

    Returns:
        ``spec``.
    """
    if not 0.0 < low < 0.2:
        raise ValueError(f"low must lie in (0, 0.2) m, got {low}")
    if not abs(pitch) < np.pi / 2:
        raise ValueError(f"pitch must lie in (-pi/2, pi/2) rad, got {pitch}")
    for prefix in names.LEGS:
        shank = spec.geom(f"{prefix}_shank")
        if shank is None:
            raise KeyError(f"the scene has no geom {prefix}_shank")
        if spec.geom(f"{prefix}_shank_low") is not None:
            raise ValueError(f"the shanks of this spec are bent already ({prefix}_shank_low)")
        start, foot = _capsule_ends(shank)
        # In the shank's frame the direction R_y(-pitch) z is world-vertical at that pitch.
        kink = foot + low * np.array([-np.sin(pitch), 0.0, np.cos(pitch)])
        upper = float(np.linalg.norm(kink - start))
        mass = shank.mass
        shank.pos, shank.quat = [0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]  # fromto places it
        shank.fromto = [*start, *kink]
        shank.mass = mass * upper / (upper + low)
        g = shank.parent.add_geom()
        g.name = f"{prefix}_shank_low"
        g.type = mujoco.mjtGeom.mjGEOM_CAPSULE
        g.fromto = [*kink, *foot]
        g.size = shank.size
        g.mass = mass * low / (upper + low)
        g.rgba, g.group = shank.rgba, shank.group
        g.contype, g.conaffinity, g.condim = shank.contype, shank.conaffinity, shank.condim
    return spec


def servo_speed(spec: mujoco.MjSpec, speed: float) -> mujoco.MjSpec:
    """Give every position servo of ``spec`` the no-load speed ``speed`` rad/s, in place.

    Each actuator's velocity gain kv (``biasprm[2] = -kv``) becomes its upper force limit (the
    stall torque) over ``speed``; kp, the torque and everything else are unchanged.

    Returns:
        ``spec``.
    """
    if not (np.isfinite(speed) and speed > 0):
        raise ValueError(f"speed must be a positive number of rad/s, got {speed}")
    for act in spec.actuators:
        stall = float(act.forcerange[1])
        if not stall > 0:
            raise ValueError(f"actuator {act.name} has no positive force limit to scale from")
        bias = np.array(act.biasprm, dtype=np.float64)
        bias[2] = -stall / speed
        act.biasprm = bias
    return spec


def _capsule_ends(geom) -> tuple[np.ndarray, np.ndarray]:
    """A capsule's (body-side, far) end points in its body's frame.

    From ``fromto`` or, in a spec read from a compiled model (``write_assets``: ``fromto``
    unset, NaN), from its ``pos``, ``quat`` and half-length; the far end is the one farther
    from the body's origin (a shank's body origin is its knee).
    """
    ends = np.array(geom.fromto, dtype=np.float64)  # a copy: fromto is a view of the spec
    if np.all(np.isfinite(ends)):
        return ends[:3], ends[3:]
    axis = np.zeros(3)
    mujoco.mju_rotVecQuat(axis, np.array([0.0, 0.0, float(geom.size[1])]), np.array(geom.quat))
    pos = np.array(geom.pos, dtype=np.float64)
    a, b = pos - axis, pos + axis
    return (a, b) if np.linalg.norm(a) <= np.linalg.norm(b) else (b, a)


def write_assets(spec: mujoco.MjSpec, out: str | Path) -> Path:
    """Write a whole assets directory for ``spec`` (use it with ``NEUROCOG_ASSETS=out``).

    The shipped files are copied (each written atomically) and ``scene.xml`` is replaced by the
    spec, compiled into one file (the robot included).
    """
    out = Path(out)
    src = paths.assets_dir()
    if out.resolve() == src.resolve():
        raise ValueError(f"refusing to overwrite the shipped assets in {src}")
    for f in src.rglob("*"):
        if f.is_file():
            nio.atomic_write_bytes(out / f.relative_to(src), f.read_bytes())
    spec.compile()
    nio.atomic_write_text(out / paths.SCENE_XML, spec.to_xml())
    return out
