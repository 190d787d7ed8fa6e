"""The vector entry points of our ids: what ``gymnasium.make_vec(env_id, num_envs)`` returns.

Kept apart from :mod:`neurocog_gym.envs.vector` (the spin-polling processes) and
:mod:`neurocog_gym.envs.batch` (the threads), which both import the shared batching helpers of
``vector``; the choice between them lives here, so neither imports the other's module back.
"""

from __future__ import annotations

from gymnasium.vector.vector_env import VectorEnv

from neurocog_gym.envs.batch import make_batch_vector
from neurocog_gym.envs.vector import make_spin_vector

VECTOR_BACKENDS = ("spin", "threads")
"""``vector_backend`` values of the vector entry points:
:class:`neurocog_gym.envs.vector.SpinVectorEnv` (the default: on 2 cores it steps 2 and 8 envs
1.5-2 x faster than the threads do, ``docs/performance.md``) or
:class:`neurocog_gym.envs.batch.BatchVectorEnv`."""


def make_vector(
    env_id: str, num_envs: int = 1, vector_backend: str = "spin", **env_kwargs
) -> VectorEnv:
    """The vector env ``gymnasium.make_vec(env_id, num_envs)`` builds for our ids.

    ``vector_backend="spin"`` (default): :func:`neurocog_gym.envs.vector.make_spin_vector`;
    ``"threads"``: :func:`neurocog_gym.envs.batch.make_batch_vector`. Both step the sub-envs of
    ``vectorization_mode="sync"`` with its results, bit for bit.
    """
    if vector_backend == "spin":
        return make_spin_vector(env_id, num_envs, **env_kwargs)
    if vector_backend == "threads":
        return make_batch_vector(env_id, num_envs, **env_kwargs)
    raise ValueError(f"vector_backend must be one of {VECTOR_BACKENDS}, got {vector_backend!r}")


def walk_vector(num_envs: int = 1, **kwargs) -> VectorEnv:
    """Vector entry point of ``NeuroCog/Walk-v3`` (see :func:`make_vector`)."""
    return make_vector("NeuroCog/Walk-v3", num_envs, **kwargs)


def sudden_obstacle_vector(num_envs: int = 1, **kwargs) -> VectorEnv:
    """Vector entry point of ``NeuroCog/SuddenObstacle-v3`` (see :func:`make_vector`)."""
    return make_vector("NeuroCog/SuddenObstacle-v3", num_envs, **kwargs)


def static_obstacle_vector(num_envs: int = 1, **kwargs) -> VectorEnv:
    """Vector entry point of ``NeuroCog/StaticObstacle-v3`` (see :func:`make_vector`)."""
    return make_vector("NeuroCog/StaticObstacle-v3", num_envs, **kwargs)


def stepping_stones_vector(num_envs: int = 1, **kwargs) -> VectorEnv:
    """Vector entry point of ``NeuroCog/SteppingStones-v3`` (see :func:`make_vector`)."""
    return make_vector("NeuroCog/SteppingStones-v3", num_envs, **kwargs)
