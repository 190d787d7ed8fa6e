"""The Affordance–Effectivity Fit network (§5.2, Fig. 7).

31 inputs — A_h, A_w, A_s of the relevant object (3), the 3-D interrupt direction of each leg's
swing (4 x 3), the 12 joint angles, the 4 touch sensors — and two output groups used alternately:
12 joint angular accelerations (the interrupt Theta into the motor-neuron pools, in [-1, 1]) and
3 walking-provision values (s_SAG, s_COR, s_DIR, in [-1, 1]). One shared hidden trunk, two tanh
heads.

Training is in ``neurocog_gym.train.aef`` (torch, backpropagation). At run time the forward pass
is NumPy on the exported weights (``AEFWeights``), so the policy does not need torch and costs a
few microseconds.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from neurocog_gym import io as nio

N_INPUTS = 31
N_INTERRUPT = 12
N_PROVISION = 3
INPUT_NAMES = (
    ("A_h", "A_w", "A_s")
    + tuple(f"v{leg}_{a}" for leg in range(1, 5) for a in "xyz")
    + tuple(f"theta{j}" for j in range(1, 13))
    + tuple(f"T{leg}" for leg in range(1, 5))
)
assert len(INPUT_NAMES) == N_INPUTS


@dataclass(frozen=True)
class AEFWeights:
    """Exported AEF weights: a tanh MLP trunk and two tanh heads, plus input normalisation.

    Attributes:
        layers: list of (W, b) for the trunk, W (out, in).
        head_interrupt: (W, b) of the 12-output head.
        head_provision: (W, b) of the 3-output head.
        in_mean, in_std: (31,) input normalisation.
    """

    layers: tuple[tuple[np.ndarray, np.ndarray], ...]
    head_interrupt: tuple[np.ndarray, np.ndarray]
    head_provision: tuple[np.ndarray, np.ndarray]
    in_mean: np.ndarray
    in_std: np.ndarray

    def _trunk(self, x: np.ndarray) -> np.ndarray:
        h = (np.asarray(x, dtype=np.float64) - self.in_mean) / self.in_std
        for W, b in self.layers:
            h = np.tanh(h @ W.T + b)
        return h

    def forward(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(..., 31) inputs -> ((..., 12) interrupt, (..., 3) provision), both in [-1, 1]."""
        h = self._trunk(x)
        Wi, bi = self.head_interrupt
        Wp, bp = self.head_provision
        return np.tanh(h @ Wi.T + bi), np.tanh(h @ Wp.T + bp)

    def save(self, path: str | os.PathLike) -> None:
        """Write an ``.npz`` atomically."""
        arrays = {"in_mean": self.in_mean, "in_std": self.in_std}
        for k, (W, b) in enumerate(self.layers):
            arrays[f"layer{k}_W"], arrays[f"layer{k}_b"] = W, b
        arrays["head_interrupt_W"], arrays["head_interrupt_b"] = self.head_interrupt
        arrays["head_provision_W"], arrays["head_provision_b"] = self.head_provision
        import io

        buf = io.BytesIO()
        np.savez(buf, **arrays)
        nio.atomic_write_bytes(path, buf.getvalue())

    @classmethod
    def load(cls, path: str | os.PathLike) -> AEFWeights:
        """Read an ``.npz`` written by :meth:`save`; clear errors for missing or corrupt files."""
        path = Path(path)
        if not path.exists():
            raise FileNotFoundError(f"AEF weights file {path} does not exist")
        try:
            with np.load(path) as z:
                data = {k: z[k] for k in z.files}
        except Exception as e:  # zipfile/pickle errors of a corrupt file
            raise ValueError(f"AEF weights file {path} is corrupt: {e}") from None
        try:
            layers = []
            k = 0
            while f"layer{k}_W" in data:
                layers.append((data[f"layer{k}_W"], data[f"layer{k}_b"]))
                k += 1
            w = cls(
                layers=tuple(layers),
                head_interrupt=(data["head_interrupt_W"], data["head_interrupt_b"]),
                head_provision=(data["head_provision_W"], data["head_provision_b"]),
                in_mean=data["in_mean"],
                in_std=data["in_std"],
            )
        except KeyError as e:
            raise ValueError(f"AEF weights file {path} lacks {e}") from None
        if not layers or layers[0][0].shape[1] != N_INPUTS:
            raise ValueError(f"AEF weights file {path} does not take {N_INPUTS} inputs")
        return w


def build_torch_net(hidden: tuple[int, ...] = (64, 64)):
    """The trainable torch module with the same layout as :class:`AEFWeights`."""
    import torch
    from torch import nn

    class AEFNet(nn.Module):
        def __init__(self):
            super().__init__()
            dims = (N_INPUTS, *hidden)
            self.trunk = nn.ModuleList(
                nn.Linear(a, b) for a, b in zip(dims[:-1], dims[1:], strict=True)
            )
            self.head_interrupt = nn.Linear(dims[-1], N_INTERRUPT)
            self.head_provision = nn.Linear(dims[-1], N_PROVISION)
            self.register_buffer("in_mean", torch.zeros(N_INPUTS))
            self.register_buffer("in_std", torch.ones(N_INPUTS))

        def forward(self, x):
            h = (x - self.in_mean) / self.in_std
            for layer in self.trunk:
                h = torch.tanh(layer(h))
            return torch.tanh(self.head_interrupt(h)), torch.tanh(self.head_provision(h))

        def export(self) -> AEFWeights:
            def np_(t):
                return t.detach().cpu().double().numpy().copy()

            return AEFWeights(
                layers=tuple((np_(layer.weight), np_(layer.bias)) for layer in self.trunk),
                head_interrupt=(np_(self.head_interrupt.weight), np_(self.head_interrupt.bias)),
                head_provision=(np_(self.head_provision.weight), np_(self.head_provision.bias)),
                in_mean=np_(self.in_mean),
                in_std=np_(self.in_std),
            )

    return AEFNet()
