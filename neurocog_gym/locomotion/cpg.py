"""Matsuoka central pattern generator, Eq. (5)-(7), §5.1, Table 3.

Reading of Table 3 (as printed, a mutually inhibiting pair does not oscillate):

* The print swaps the two time constants: the rise time is ``tau = 1.2`` and the adaptation time
  ``T = 12.0`` (Matsuoka's oscillator needs T well above tau; T = 10 tau here).
* Their unit is not given. We take one CPG time unit as ``time_unit = 0.03 s``, so tau = 36 ms and
  T = 0.36 s; an isolated pair with b = 2.5, u0 = 1, mutual inhibition 2 then runs at about 1.4 Hz,
  and the default trot network (``assets/default_gait.json``) at the frequency measured in
  ``tests/locomotion/test_cpg.py``.
* ``tau_f`` is the frequency scale: it multiplies both right-hand sides, so the frequency is
  proportional to it (Table 3's 1.0 is the nominal value).

Each joint has a flexor/extensor pair (24 neurons); neuron ``6 * leg + n`` with n = 0, 1 hip
flexion, 2, 3 knee, 4, 5 abduction (see ``chromosome.py``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from neurocog_gym.locomotion._kernels import matsuoka_step_into
from neurocog_gym.locomotion.chromosome import N_NEURONS, decode


@dataclass(frozen=True)
class CPGParams:
    """Matsuoka network constants (Table 3, with the reading in the module docstring)."""

    tau: float = 1.2
    """tau, rise time constant of the inner state, CPG time units (Table 3 prints T's slot)."""
    T: float = 12.0
    """T, adaptation (self-inhibition) time constant, CPG time units (Table 3, swapped)."""
    tau_f: float = 1.0
    """tau_f, frequency scale multiplying Eq. (5)-(6), dimensionless (Table 3)."""
    b: float = 2.5
    """b, adaptation gain, dimensionless (Table 3)."""
    u0: float = 1.0
    """u0 = x_0, tonic input, dimensionless (Table 3)."""
    time_unit: float = 0.03
    """Length of one CPG time unit, s (our reading; the paper does not give it)."""
    substeps: int = 4
    """Euler sub-steps per control cycle (numerical, not in the paper)."""

    def __post_init__(self):
        for name in ("tau", "T", "tau_f", "time_unit"):
            if not getattr(self, name) > 0:
                raise ValueError(f"CPGParams.{name} must be positive, got {getattr(self, name)}")
        if self.substeps < 1:
            raise ValueError(f"CPGParams.substeps must be >= 1, got {self.substeps}")


class MatsuokaCPG:
    """The 24-neuron Matsuoka network with weights decoded from a 77-gene chromosome.

    Args:
        genes: (77,) chromosome (see ``chromosome.decode``).
        params: network constants.
        dt: control cycle, s.
    """

    def __init__(self, genes: np.ndarray, params: CPGParams | None = None, dt: float = 0.01):
        self.params = params or CPGParams()
        self.dt = float(dt)
        weights = decode(genes)
        self.W = np.ascontiguousarray(weights.W)
        self.V = np.ascontiguousarray(weights.V)
        self.ring = weights.ring
        self.x = np.zeros(N_NEURONS)
        self.v = np.zeros(N_NEURONS)
        self.y = np.zeros(N_NEURONS)

    def reset(self, x0: np.ndarray | None = None) -> None:
        """Reset the state; ``x0`` (24,) sets the inner states (zeros when None)."""
        self.x[:] = 0.0 if x0 is None else x0
        self.v[:] = 0.0
        self.y[:] = np.maximum(self.x, 0.0)

    def step(self, touch: np.ndarray, freq_scale: float = 1.0) -> np.ndarray:
        """Advance one control cycle.

        Args:
            touch: (4,) touch inputs s_l (FL, FR, HL, HR), dimensionless.
            freq_scale: multiplies tau_f (the walking provision's frequency change).

        Returns:
            (24,) outputs y_i (a view of the internal buffer).
        """
        p = self.params
        matsuoka_step_into(
            self.x, self.v, self.W, self.V, np.asarray(touch, dtype=np.float64),
            p.u0, p.b, p.tau, p.T, p.tau_f * freq_scale,
            self.dt / p.time_unit / p.substeps, p.substeps, self.y,
        )  # fmt: skip
        return self.y
