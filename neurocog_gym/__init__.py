"""neurocog_gym: Gymnasium environments for neuro-cognitive quadruped locomotion.

Importing the package registers every environment id (SPEC §9):

* ``NeuroCog/Walk-v3`` — flat-ground trotting on the CPG.
* ``NeuroCog/SuddenObstacle-v3`` — a block appears in a front leg's swing path (§6.5.1).
* ``NeuroCog/StaticObstacle-v3`` — blocks lie across the path (§6.5.2).
* ``NeuroCog/SteppingStones-v3`` — flat stones over a pit, still or sliding (§6.4, Videos S2/S3).
"""

from __future__ import annotations

import os

# Headless machines: pick EGL for offscreen rendering before mujoco is imported anywhere.
if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
    os.environ.setdefault("MUJOCO_GL", "egl")

from gymnasium.envs.registration import register  # noqa: E402

__version__ = "0.1.0"
__all__ = ["ENV_IDS", "__version__"]

ENV_IDS: tuple[str, ...] = (
    "NeuroCog/Walk-v3",
    "NeuroCog/SuddenObstacle-v3",
    "NeuroCog/StaticObstacle-v3",
    "NeuroCog/SteppingStones-v3",
)

# vector_entry_point: ``gymnasium.make_vec(id, n)`` (mode None or "vector_entry_point") gives a
# SpinVectorEnv (neurocog_gym/envs/vector.py): the sync mode's sub-envs, stepped in parallel
# processes that wait for each other by spinning on shared memory; ``vector_backend="threads"``
# gives a BatchVectorEnv (envs/batch.py) on threads instead (docs/performance.md says which wins).
register(
    id="NeuroCog/Walk-v3",
    entry_point="neurocog_gym.envs.walk:WalkEnv",
    vector_entry_point="neurocog_gym.envs.make_vec:walk_vector",
    max_episode_steps=2000,
)
register(
    id="NeuroCog/SuddenObstacle-v3",
    entry_point="neurocog_gym.envs.sudden:SuddenObstacleEnv",
    vector_entry_point="neurocog_gym.envs.make_vec:sudden_obstacle_vector",
    max_episode_steps=700,
)
register(
    id="NeuroCog/StaticObstacle-v3",
    entry_point="neurocog_gym.envs.static:StaticObstacleEnv",
    vector_entry_point="neurocog_gym.envs.make_vec:static_obstacle_vector",
    max_episode_steps=1000,
)
register(
    id="NeuroCog/SteppingStones-v3",
    entry_point="neurocog_gym.envs.stones:SteppingStonesEnv",
    vector_entry_point="neurocog_gym.envs.make_vec:stepping_stones_vector",
    max_episode_steps=1500,
)
