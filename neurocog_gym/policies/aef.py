"""AEFPolicy: the paper's controller, the Affordance–Effectivity Fit network (§5.2, Fig. 7).

The shipped (or given) weights, NumPy forward pass, applied to the env's 31 AEF inputs, nothing
else of the env. When the effectivity reports a swing that must change (``aef_mode == 1``) the
interrupt group drives the joints of the legs it named; when the walk must change
(``aef_mode == 2``: an object ahead to walk round, or a block that appeared within reach, which
the legs cannot step over, to stop for, side-step and pass — ``locomotion/avoidance.py``) the
provision group changes the walk; otherwise the CPG walks alone (zero action).

With ``interrupt_gain=0`` only the walking provision acts: the ``aef-provision`` ablation
(``make_policy("aef-provision")``).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from neurocog_gym import paths
from neurocog_gym.locomotion.aef import AEFWeights
from neurocog_gym.locomotion.effectivity import MODE_INTERRUPT, MODE_PROVISION
from neurocog_gym.policies.base import ACTION_DIM


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
