"""Body variants built from the shipped model with ``mujoco.MjSpec`` (design studies, not envs).

``knee_behind`` is the candidate for body v2 (issue 21): every knee folds behind its foot, as
MuJoCo Menagerie's A1 and Go1 do, so that a front foot, not the shank, leads the leg over a
block. It reverses each knee's axis (a positive knee angle still folds the leg), moves the hip
range to the thigh pointing backwards, and mirrors the home pose's hip angle so each foot stays
under its hip. The motor-neuron pools drive such a leg in leg coordinates
(``locomotion.motor.leg_coordinates``), so the shipped gait and interrupts move its feet as they
move body v1's. ``scripts/stepover_geometry.py`` gives the reason in numbers; the envs still use
body v1 until v2 is tuned and benchmarked (docs/oracle_notes.md).
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
