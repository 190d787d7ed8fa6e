"""Policies over the obstacle envs' observations: each is a callable ``policy(obs) -> action``.

One module per controller, and :func:`make_policy` (``registry.py``) to build one by name or
file, as ``--policy`` does:

* :class:`AEFPolicy` (``aef.py``; names ``aef`` and ``aef-provision``) — the paper's controller,
  the Affordance–Effectivity Fit network applied to the env's 31 AEF inputs;
* :class:`BlindPolicy` (``blind.py``; ``blind``) — never interrupts (the paper's "improved
  process disabled", Fig. 16b);
* :class:`AvoidPolicy` (``avoid.py``; ``avoid``) — backs off from a block that appears in front
  of the robot, side-steps out of its path and walks past; reads the env's effectivity, so it
  has a ``reset(env)`` to call after every ``env.reset`` (:func:`start_episode` does it for any
  policy);
* :class:`OraclePolicy` (``oracle.py``; ``oracle``) — the privileged scripted step-over that
  reads the true block boxes (make its env with ``privileged=True``);
* :class:`SB3Policy` (``sb3.py``; ``ppo`` and any ``.zip``) — a saved stable-baselines3 model.

``base.py`` holds what they share: the action's size and :func:`start_episode`.
"""

from neurocog_gym.policies.aef import AEFPolicy
from neurocog_gym.policies.avoid import AvoidParams, AvoidPolicy
from neurocog_gym.policies.base import ACTION_DIM, start_episode
from neurocog_gym.policies.blind import BlindPolicy
from neurocog_gym.policies.oracle import OracleParams, OraclePolicy
from neurocog_gym.policies.registry import POLICY_NAMES, make_policy
from neurocog_gym.policies.sb3 import SB3Policy, shipped_ppo_env, vecnormalize_path

__all__ = [
    "ACTION_DIM",
    "POLICY_NAMES",
    "AEFPolicy",
    "AvoidParams",
    "AvoidPolicy",
    "BlindPolicy",
    "OracleParams",
    "OraclePolicy",
    "SB3Policy",
    "make_policy",
    "shipped_ppo_env",
    "start_episode",
    "vecnormalize_path",
]
