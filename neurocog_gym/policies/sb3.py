"""SB3Policy: a saved stable-baselines3 model, deterministic actions; the shipped PPO policy.

``make_policy("ppo")`` is this class on ``assets/ppo_sudden/model.zip`` (cloned from the AEF,
then PPO on ``SuddenObstacle-v0``; :func:`shipped_ppo_env` names the env it was trained on), and
any other ``.zip`` path given to ``make_policy`` or ``--policy`` is loaded with it.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from neurocog_gym import paths


class SB3Policy:
    """A saved stable-baselines3 model (``.zip``), deterministic actions.

    A model trained on ``VecNormalize``-d observations (``scripts/train_ppo.py``) needs their
    statistics: ``vecnormalize`` names the pickle saved by ``VecNormalize.save``; None looks
    beside the zip (:func:`vecnormalize_path`: ``vecnormalize.pkl`` for ``OUT/model.zip``,
    ``ppo_vecnormalize_<n>_steps.pkl`` for the checkpoint ``ppo_<n>_steps.zip``) and uses the
    raw observations if there is none. The statistics are frozen (no update, no reward scaling).

    Attributes:
        obs_normalizer: the loaded ``VecNormalize`` (without its env) or None.
        env_kwargs: the ``gymnasium.make`` arguments its observations need: ``{}``, or
            ``{"observation_mode": ...}`` for a model trained on the depth image
            (:func:`observation_mode_of` its observation space); the bench builds its envs so.
    """

    name = "sb3"

    def __init__(self, path: str | os.PathLike, vecnormalize: str | os.PathLike | None = None):
        path = Path(path)
        if not path.exists():
            raise FileNotFoundError(f"model file {path} does not exist")
        self.model = _load_sb3(path)
        if vecnormalize is None:
            stats = vecnormalize_path(path)
            stats = stats if stats.exists() else None
        else:
            stats = Path(vecnormalize)
            if not stats.exists():
                raise FileNotFoundError(f"VecNormalize statistics {stats} do not exist")
        self.obs_normalizer = _load_vecnormalize(stats) if stats is not None else None
        mode = observation_mode_of(self.model.observation_space)
        self.env_kwargs = {} if mode == "default" else {"observation_mode": mode}

    def __call__(self, obs) -> np.ndarray:
        """Deterministic action of the model."""
        if self.obs_normalizer is not None:
            obs = self.obs_normalizer.normalize_obs(obs)
        action, _ = self.model.predict(obs, deterministic=True)
        return np.asarray(action, dtype=np.float32)


def observation_mode_of(space) -> str:
    """The obstacle envs' ``observation_mode`` whose observations ``space`` describes.

    ``"default"`` without a ``depth`` key; with one, ``"depth"`` if the perception's keys are
    there too (``objects``), else ``"depth_only"``.
    """
    keys = getattr(space, "spaces", {})
    if "depth" not in keys:
        return "default"
    return "depth" if "objects" in keys else "depth_only"


def vecnormalize_path(model: str | os.PathLike) -> Path:
    """Where ``scripts/train_ppo.py`` saves the VecNormalize statistics of ``model``."""
    import re

    model = Path(model)
    m = re.fullmatch(r"(.*)_(\d+)_steps\.zip", model.name)
    if m:
        return model.with_name(f"{m.group(1)}_vecnormalize_{m.group(2)}_steps.pkl")
    return model.with_name("vecnormalize.pkl")


def _load_vecnormalize(path: Path):
    """A pickled ``VecNormalize`` (``VecNormalize.save``), frozen, usable without its env."""
    import pickle

    from stable_baselines3.common.vec_env import VecNormalize

    with open(path, "rb") as f:
        vn = pickle.load(f)
    if not isinstance(vn, VecNormalize):
        raise ValueError(f"{path} is not a VecNormalize pickle (got {type(vn).__name__})")
    vn.training = False
    vn.norm_reward = False
    return vn


def _load_sb3(path: Path):
    import stable_baselines3 as sb3

    errors = []
    for algo in (sb3.PPO, sb3.SAC, sb3.TD3, sb3.A2C, sb3.DDPG):
        try:
            return algo.load(path, device="cpu")
        except Exception as e:  # the zip names another algorithm
            errors.append(f"{algo.__name__}: {e}")
    raise ValueError(f"{path} is not a stable-baselines3 model ({errors[0]})")


def shipped_ppo_env() -> str:
    """The env id the shipped PPO policy was trained on (``assets/ppo_sudden/args.json``)."""
    import json

    args = paths.asset(paths.PPO_MODEL).with_name("args.json")
    return str(json.loads(args.read_text())["env_id"])
