"""What every policy shares: the action's size and the start-of-episode hook.

A policy is a callable ``policy(obs) -> action`` (a ``(15,)`` float32 array: 12 joint
interrupts, then 3 walking-provision values, as the envs' action space) of the observation
alone. One that keeps state across an episode (the AEF's fit, the oracle's legs) also has
``reset(env)``, which :func:`start_episode` calls after every ``env.reset``; ``env`` is there
for the hook's signature, not to be read.
"""

from __future__ import annotations

from neurocog_gym.locomotion.aef import N_INTERRUPT, N_PROVISION

ACTION_DIM = N_INTERRUPT + N_PROVISION
"""Length of an action: 12 joint interrupts + 3 walking provisions (``envs.base.ACTION_DIM``)."""


def start_episode(policy, env) -> None:
    """Tell ``policy`` a new episode of ``env`` began (after ``env.reset``), if it cares."""
    reset = getattr(policy, "reset", None)
    if callable(reset):
        reset(env)
