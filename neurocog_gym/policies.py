"""Policies over the obstacle envs' observations: each is a callable ``policy(obs) -> action``.

* :class:`AEFPolicy` — the paper's controller: the Affordance–Effectivity Fit network (shipped
  weights, NumPy forward pass) applied to the env's 31 AEF inputs, nothing else of the env. When
  the effectivity reports a swing that must change (``aef_mode == 1``) the interrupt group drives
  the joints of the legs it named; when the walk must change (``aef_mode == 2``: an object ahead
  to walk round, or a block that appeared within reach, which the legs cannot step over, to stop
  for, side-step and pass — ``locomotion/avoidance.py``) the provision group changes the walk;
  otherwise the CPG walks alone (zero action).
* :class:`BlindPolicy` — never interrupts (the paper's "improved process disabled", Fig. 16b).
* :class:`neurocog_gym.avoid.AvoidPolicy` — backs off from a block that appears in front of the
  robot, side-steps out of its path and walks past; reads the env's effectivity, so it has a
  ``reset(env)`` to call after every ``env.reset`` (:func:`start_episode` does it for any policy).
* :class:`SB3Policy` — a saved stable-baselines3 model.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from neurocog_gym import paths
from neurocog_gym.locomotion.aef import AEFWeights
from neurocog_gym.locomotion.effectivity import MODE_INTERRUPT, MODE_PROVISION

ACTION_DIM = 15


class BlindPolicy:
    """Never interrupts and never changes the walking provision: plain CPG walking."""

    name = "blind"

    def __call__(self, obs) -> np.ndarray:
        """Return the all-zero action."""
        return np.zeros(ACTION_DIM, dtype=np.float32)


class AEFPolicy:
    """The AEF network with the shipped (or given) weights.

    Args:
        weights: path of an ``.npz`` written by ``neurocog train-aef``; None uses
            ``assets/aef_weights.npz``.
        interrupt_gain: scales the interrupt group's output before clipping to [-1, 1].
    """

    name = "aef"

    def __init__(self, weights: str | os.PathLike | None = None, interrupt_gain: float = 1.0):
        path = Path(weights) if weights is not None else paths.asset(paths.AEF_WEIGHTS)
        self.weights = AEFWeights.load(path)
        self.interrupt_gain = float(interrupt_gain)

    def __call__(self, obs) -> np.ndarray:
        """Map one observation of an obstacle env to the 15-value action."""
        action = np.zeros(ACTION_DIM, dtype=np.float32)
        mode = int(np.asarray(obs["aef_mode"]))
        if mode == 0:
            return action
        x = np.asarray(obs["aef_input"], dtype=np.float64)
        interrupt, provision = self.weights.forward(x)
        if mode == MODE_INTERRUPT:
            legs = np.abs(x[3:15].reshape(4, 3)).sum(axis=1) > 0
            mask = np.repeat(legs, 3)
            action[:12] = np.clip(self.interrupt_gain * interrupt * mask, -1.0, 1.0)
        elif mode == MODE_PROVISION:
            action[12:] = provision
        return action


class SB3Policy:
    """A saved stable-baselines3 model (``.zip``), deterministic actions.

    A model trained on ``VecNormalize``-d observations (``scripts/train_ppo.py``) needs their
    statistics: ``vecnormalize`` names the pickle saved by ``VecNormalize.save``; None looks
    beside the zip (:func:`vecnormalize_path`: ``vecnormalize.pkl`` for ``OUT/model.zip``,
    ``ppo_vecnormalize_<n>_steps.pkl`` for the checkpoint ``ppo_<n>_steps.zip``) and uses the
    raw observations if there is none. The statistics are frozen (no update, no reward scaling).

    Attributes:
        obs_normalizer: the loaded ``VecNormalize`` (without its env) or None.
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

    def __call__(self, obs) -> np.ndarray:
        """Deterministic action of the model."""
        if self.obs_normalizer is not None:
            obs = self.obs_normalizer.normalize_obs(obs)
        action, _ = self.model.predict(obs, deterministic=True)
        return np.asarray(action, dtype=np.float32)


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


POLICY_NAMES = ("aef", "aef-provision", "blind", "avoid", "oracle", "ppo")
"""Named policies; anything else is a file (AEF weights or a stable-baselines3 model)."""


def make_policy(spec: str):
    """A policy by name or file.

    * ``"aef"``: :class:`AEFPolicy`, both output groups (interrupts and walking provision);
    * ``"aef-provision"``: :class:`AEFPolicy` with the interrupt group off (``interrupt_gain=0``),
      only the walking provision acts;
    * ``"blind"``: :class:`BlindPolicy`;
    * ``"avoid"``: :class:`neurocog_gym.avoid.AvoidPolicy` (the back-off / side-step reflex for
      sudden blocks on top of ``aef-provision``; bind it with ``policy.reset(env)`` after each
      ``env.reset``);
    * ``"oracle"``: :class:`neurocog_gym.oracle.OraclePolicy`, the privileged scripted
      step-over (reads the true block boxes: make its env with ``privileged=True``);
    * ``"ppo"``: the shipped stable-baselines3 PPO policy (:class:`SB3Policy` on
      ``assets/ppo_sudden/model.zip`` and its observation statistics): cloned from the AEF,
      then 35 min of PPO on ``SuddenObstacle-v0`` (``assets/ppo_sudden/args.json``,
      ``train_summary.json``; docs/benchmarks_ppo.md). The v1 envs replaced v0 (another body,
      1-D observation keys), so until it is retrained on v1 (issue 24) this raises a
      ``ValueError`` that says so (:func:`shipped_ppo_env`);
    * a path ending in ``.npz``: :class:`AEFPolicy` with those weights;
    * any other path: a saved stable-baselines3 model (:class:`SB3Policy`).
    """
    if spec == "aef":
        return AEFPolicy()
    if spec == "aef-provision":
        policy = AEFPolicy(interrupt_gain=0.0)
        policy.name = "aef-provision"
        return policy
    if spec == "blind":
        return BlindPolicy()
    if spec == "avoid":
        from neurocog_gym.avoid import AvoidPolicy

        return AvoidPolicy()
    if spec == "oracle":
        from neurocog_gym.oracle import OraclePolicy

        return OraclePolicy()
    if spec == "ppo":
        env_id = shipped_ppo_env()
        if env_id not in _registered_ids():
            raise ValueError(
                f"the shipped PPO policy (assets/ppo_sudden) was trained on the v0 envs "
                f"({env_id}), which v1 replaced: it must be retrained on "
                "NeuroCog/SuddenObstacle-v1 (issue 24); give a model of your own as a .zip path"
            )
        policy = SB3Policy(paths.asset(paths.PPO_MODEL))
        policy.name = "ppo"
        return policy
    if spec.endswith(".npz"):
        return AEFPolicy(weights=spec)
    return SB3Policy(spec)


def shipped_ppo_env() -> str:
    """The env id the shipped PPO policy was trained on (``assets/ppo_sudden/args.json``)."""
    import json

    args = paths.asset(paths.PPO_MODEL).with_name("args.json")
    return str(json.loads(args.read_text())["env_id"])


def _registered_ids() -> tuple[str, ...]:
    import neurocog_gym

    return neurocog_gym.ENV_IDS


def start_episode(policy, env) -> None:
    """Tell ``policy`` a new episode of ``env`` began (after ``env.reset``), if it cares."""
    reset = getattr(policy, "reset", None)
    if callable(reset):
        reset(env)
