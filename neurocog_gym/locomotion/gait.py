"""A gait: the chromosome plus the CPG-to-motor-neuron synapses, saved as JSON in ``assets/``.

The NSGA-II tuner writes the same format (``neurocog tune-cpg``), so a tuned gait is a drop-in
replacement for ``assets/default_gait.json``. Fields:

* ``genes``: the 77-gene chromosome (``chromosome.py``).
* ``flexor_gain``, ``extensor_gain``: (12,) m_i, the synaptic weight from a joint's flexor and
  extensor CPG neuron to its motor-neuron pool, activation per unit of CPG output (§5.1's m_i).
* ``posture``: (12,) the joint angles the pattern oscillates around, rad (also theta_opt, Eq. 9).
* ``tau_f``: the CPG frequency scale (Table 3's tau_f).
* ``acc_max``, ``k_rest``, ``d_rest``: the motor-neuron pools' theta_dd_MAX (Eq. 8, "chosen
  through preliminary testing") and restoring stiffness and damping (``motor.py``).
* ``vel_max``: theta_dot_MAX of the pools, rad/s (Eq. 10): the servo's no-load speed, which
  also bounds the target rate the pools write (``motor.py``). Missing in a file means 6.6
  (the shipped body's Dynamixel MX-64); a body with other servos needs its own figure.
* ``vestibular_gain``: the roll reflex's gain, 1/s (``_kernels.vestibular_step``; our addition,
  0 = none, as in the shipped gait). Missing in a file means 0.
"""

from __future__ import annotations

import json
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from neurocog_gym import paths
from neurocog_gym.locomotion.chromosome import validate_genes

FORMAT = "neurocog-gait/1"


@dataclass(frozen=True)
class Gait:
    """A complete gait for the locomotion generator (see module docstring)."""

    genes: tuple[float, ...]
    flexor_gain: tuple[float, ...]
    extensor_gain: tuple[float, ...]
    posture: tuple[float, ...]
    tau_f: float = 1.0
    acc_max: float = 120.0
    k_rest: float = 160.0
    d_rest: float = 12.6
    vel_max: float = 6.6
    vestibular_gain: float = 0.0
    name: str = "gait"
    notes: dict = field(default_factory=dict)

    def __post_init__(self):
        validate_genes(np.asarray(self.genes))
        for key in ("flexor_gain", "extensor_gain", "posture"):
            arr = np.asarray(getattr(self, key), dtype=np.float64)
            if arr.shape != (12,) or not np.all(np.isfinite(arr)):
                raise ValueError(f"gait field {key!r} must be 12 finite numbers, got {arr.shape}")
        for key in ("tau_f", "acc_max", "k_rest", "d_rest", "vel_max"):
            value = getattr(self, key)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"gait {key} must be a positive number, got {value}")
        if not (np.isfinite(self.vestibular_gain) and self.vestibular_gain >= 0):
            raise ValueError(
                f"gait vestibular_gain must be a number >= 0 (0: no roll reflex), "
                f"got {self.vestibular_gain}"
            )

    @property
    def genes_array(self) -> np.ndarray:
        """The chromosome as a (77,) float64 array."""
        return np.asarray(self.genes, dtype=np.float64)

    def with_genes(self, genes: np.ndarray, **notes) -> Gait:
        """Return a copy with a new chromosome (and notes merged in)."""
        from dataclasses import replace

        g = validate_genes(genes)
        return replace(
            self,
            genes=tuple(float(v) for v in g),
            name=notes.pop("name", self.name),
            notes={**self.notes, **notes},
        )

    def to_json(self) -> dict:
        """The JSON-ready dict of this gait."""
        return {"format": FORMAT, **asdict(self)}

    def save(self, path: str | os.PathLike) -> None:
        """Write the gait atomically (temp file, then rename)."""
        from neurocog_gym import io as nio

        nio.atomic_write_text(path, json.dumps(self.to_json(), indent=1))

    @classmethod
    def from_dict(cls, raw: dict, name: str = "gait") -> Gait:
        """A gait from its JSON dict (``to_json``).

        Missing optional fields take the defaults documented above; a missing ``name`` is
        ``name``.
        """
        return cls(
            genes=tuple(float(v) for v in raw["genes"]),
            flexor_gain=tuple(float(v) for v in raw["flexor_gain"]),
            extensor_gain=tuple(float(v) for v in raw["extensor_gain"]),
            posture=tuple(float(v) for v in raw["posture"]),
            tau_f=float(raw.get("tau_f", 1.0)),
            acc_max=float(raw.get("acc_max", 120.0)),
            k_rest=float(raw.get("k_rest", 160.0)),
            d_rest=float(raw.get("d_rest", 12.6)),
            vel_max=float(raw.get("vel_max", 6.6)),
            vestibular_gain=float(raw.get("vestibular_gain", 0.0)),
            name=str(raw.get("name", name)),
            notes=dict(raw.get("notes", {})),
        )

    @classmethod
    def load(cls, path: str | os.PathLike) -> Gait:
        """Read a gait file; raise ``ValueError`` naming the file and the problem."""
        path = Path(path)
        try:
            raw = json.loads(path.read_text())
        except FileNotFoundError:
            raise FileNotFoundError(f"gait file {path} does not exist") from None
        except (json.JSONDecodeError, UnicodeDecodeError) as e:
            raise ValueError(f"gait file {path} is not valid JSON: {e}") from None
        if not isinstance(raw, dict) or raw.get("format") != FORMAT:
            raise ValueError(f"gait file {path} is not a {FORMAT} file")
        try:
            return cls.from_dict(raw, name=path.stem)
        except (KeyError, TypeError, ValueError) as e:
            raise ValueError(f"gait file {path} is malformed: {e}") from None


def default_gait() -> Gait:
    """The shipped default gait (``assets/default_gait.json``)."""
    return Gait.load(paths.asset(paths.DEFAULT_GAIT))
