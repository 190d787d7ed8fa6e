"""The policy registry: a policy by name or file (``make_policy``, ``--policy``).

The names are those of the benchmark's rows: the paper's AEF, its ablations, the blind CPG, the
privileged oracle and the shipped PPO policy; a file is AEF weights
(``.npz``) or a stable-baselines3 model (any other path).
"""

from __future__ import annotations

from neurocog_gym import paths
from neurocog_gym.policies.aef import AEFPolicy
from neurocog_gym.policies.blind import BlindPolicy
from neurocog_gym.policies.oracle import OraclePolicy
from neurocog_gym.policies.sb3 import SB3Policy, shipped_ppo_env

POLICY_NAMES = ("aef", "aef-provision", "blind", "oracle", "ppo")
"""Named policies; anything else is a file (AEF weights or a stable-baselines3 model)."""


def make_policy(spec: str):
    """A policy by name or file.

    * ``"aef"``: :class:`AEFPolicy`, both output groups (interrupts and walking provision);
    * ``"aef-provision"``: :class:`AEFPolicy` with the interrupt group off (``interrupt_gain=0``),
      only the walking provision acts;
    * ``"blind"``: :class:`BlindPolicy`;
    * ``"oracle"``: :class:`OraclePolicy`, the privileged scripted step-over (reads the true
      block boxes: make its env with ``privileged=True``); on the stepping stones it runs
      :class:`~neurocog_gym.policies.footing.FootingOracle` (reads the true stones);
    * ``"ppo"``: the shipped stable-baselines3 PPO policy (:class:`SB3Policy` on
      ``assets/ppo_sudden/model.zip`` and its observation statistics): cloned from the AEF,
      then 35 min of PPO on ``SuddenObstacle-v0`` (``assets/ppo_sudden/args.json``,
      ``train_summary.json``; docs/generated/benchmarks_ppo.md). The v1 to v3 envs replaced v0
      (other bodies, 1-D observation keys), so until it is retrained (issue 24) this raises a
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
    if spec == "oracle":
        return OraclePolicy()
    if spec == "ppo":
        env_id = shipped_ppo_env()
        if env_id not in _registered_ids():
            raise ValueError(
                f"the shipped PPO policy (assets/ppo_sudden) was trained on the v0 envs "
                f"({env_id}), which v1 to v3 replaced: it must be retrained on "
                "NeuroCog/SuddenObstacle-v3 (issue 24); give a model of your own as a .zip path"
            )
        policy = SB3Policy(paths.asset(paths.PPO_MODEL))
        policy.name = "ppo"
        return policy
    if spec.endswith(".npz"):
        return AEFPolicy(weights=spec)
    return SB3Policy(spec)


def _registered_ids() -> tuple[str, ...]:
    import neurocog_gym

    return neurocog_gym.ENV_IDS
