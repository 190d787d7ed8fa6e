"""BlindPolicy: never interrupts (the paper's "improved process disabled", Fig. 16b)."""

from __future__ import annotations

import numpy as np

from neurocog_gym.policies.base import ACTION_DIM


class BlindPolicy:
    """Never interrupts and never changes the walking provision: plain CPG walking."""

    name = "blind"

    def __call__(self, obs) -> np.ndarray:
        """Return the all-zero action."""
        return np.zeros(ACTION_DIM, dtype=np.float32)
