"""Policies over the obstacle envs' observations: each is a callable ``policy(obs) -> action``.

One module per controller, and :func:`make_policy` (``registry.py``) to build one by name or
file, as ``--policy`` does:

* :class:`AEFPolicy` (``aef.py``; names ``aef`` and ``aef-provision``) — the paper's controller:
  the fit decides from the observation which output group acts, the Affordance–Effectivity Fit
  network gives its values; keeps per-episode state (``reset``);
* :class:`BlindPolicy` (``blind.py``; ``blind``) — never interrupts (the paper's "improved
  process disabled", Fig. 16b);
* :class:`OraclePolicy` (``oracle.py``; ``oracle``) — the privileged scripted step-over that
  reads the true block boxes (make its env with ``privileged=True``); keeps per-episode state;
* :class:`FootingOracle` (``footing.py``; used by ``oracle`` on the stepping stones) — the
  privileged scripted footing-position interrupt that reads the true stones;
* :class:`SB3Policy` (``sb3.py``; ``ppo`` and any ``.zip``) — a saved stable-baselines3 model.

``base.py`` holds what they share: the action's size and :func:`start_episode` (calls a stateful
policy's ``reset`` after every ``env.reset``). No policy reads the env beyond its observation.
"""

from neurocog_gym.policies.aef import AEFPolicy
from neurocog_gym.policies.base import ACTION_DIM, start_episode
from neurocog_gym.policies.blind import BlindPolicy
from neurocog_gym.policies.footing import FootingOracle, FootingParams
from neurocog_gym.policies.oracle import OracleParams, OraclePolicy
from neurocog_gym.policies.registry import POLICY_NAMES, make_policy
from neurocog_gym.policies.sb3 import SB3Policy, shipped_ppo_env, vecnormalize_path

__all__ = [
    "ACTION_DIM",
    "POLICY_NAMES",
    "AEFPolicy",
    "BlindPolicy",
    "FootingOracle",
    "FootingParams",
    "OracleParams",
    "OraclePolicy",
    "SB3Policy",
    "make_policy",
    "shipped_ppo_env",
    "start_episode",
    "vecnormalize_path",
]
