"""The 77-gene chromosome of §6.3 / Fig. 12 and its map onto the CPG's weight matrices.

Genes, in order: ``[structure, C1..C64, S1..S12]`` (Table 3's "7 real numbers" is a typo for 77).

Reading of Fig. 12 (the printed table is partly garbled; this is the reading that makes every row
consistent):

* Each leg has six CPG neurons, numbered 1..6 as in Fig. 12. The inter-leg couplings only leave
  and enter neurons 1..4 and neurons 3..4 talk to other legs only through their neurons 1..2, so
  neurons 1..2 are the rhythm-generating pair. We map them to hip flexion (1 = flexor, protracts
  the leg; 2 = extensor, retracts it), 3..4 to the knee (3 folds, 4 stretches) and 5..6 to hip
  abduction (5 abducts, 6 adducts).
* ``C1..C28`` form the 6x6 intra-leg block shared by all legs. ``C1`` is both 1->2 and 2->1; row 4
  prints ``C17`` twice (4->3 and 4->5) and we keep that as printed, which is what makes exactly 28
  genes.
* The inter-leg blocks depend only on the relation between transmitter and receiver leg around a
  ring of the four legs: receiver = transmitter + 1 uses ``C53..C64`` ("LEG-A"), + 2 uses
  ``C41..C52`` ("LEG-B"), + 3 uses ``C29..C40`` ("LEG-C"). Rows 1..2 reach receiver neurons 1..4,
  rows 3..4 reach receiver neurons 1..2 (12 genes per relation, 36 in all).
* Sensor rows: touch sensor of ring leg ``l`` reaches its own leg's neurons 1..6 through
  ``S1..S6``, and neurons 1..2 of leg l+1, l+2, l+3 through ``S11,S12``, ``S9,S10``, ``S7,S8``.
* The structure gene ("the combined neuron structure", red in Fig. 12) selects how the four legs
  sit on that ring: one of the six directed rings that start at FL. Ring 0 (FL, FR, HR, HL) makes
  relation B the diagonal, so a trot is in-phase B and anti-phase A and C.

In the weight matrix ``W`` used by Eq. (5), ``W[i, j]`` is the weight *from* neuron ``j`` *to*
neuron ``i`` (Fig. 12 lists transmitter rows and receiver columns, so ``W`` is its transpose); a
positive weight inhibits. ``V[i, l]`` is the weight from touch sensor ``l`` (physical leg order) to
neuron ``i``. Neuron index ``6 * leg + n`` follows the physical leg order FL, FR, HL, HR.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from neurocog_gym.robot.names import LEGS

N_GENES = 77
N_NEURONS = 24
N_CPG_WEIGHTS = 64
N_SENSOR_WEIGHTS = 12
STRUCTURE_GENE = 0

#: Directed rings of the legs (indices into FL, FR, HL, HR), selected by the structure gene.
RINGS: tuple[tuple[int, int, int, int], ...] = (
    (0, 1, 3, 2),  # FL FR HR HL: B = diagonal
    (0, 2, 3, 1),  # FL HL HR FR: B = diagonal, reversed
    (0, 1, 2, 3),  # FL FR HL HR: B = ipsilateral
    (0, 3, 2, 1),  # FL HR HL FR: B = ipsilateral, reversed
    (0, 2, 1, 3),  # FL HL FR HR: B = contralateral
    (0, 3, 1, 2),  # FL HR FR HL: B = contralateral, reversed
)

# Fig. 12 intra-leg block, 1-based (transmitter, receiver) -> gene number C_k.
_INTRA: dict[tuple[int, int], int] = {
    (1, 2): 1, (1, 3): 2, (1, 4): 3, (1, 5): 4, (1, 6): 5,
    (2, 1): 1, (2, 3): 6, (2, 4): 7, (2, 5): 8, (2, 6): 9,
    (3, 1): 10, (3, 2): 11, (3, 4): 12, (3, 5): 13, (3, 6): 14,
    (4, 1): 15, (4, 2): 16, (4, 3): 17, (4, 5): 17, (4, 6): 18,
    (5, 1): 19, (5, 2): 20, (5, 3): 21, (5, 4): 22, (5, 6): 23,
    (6, 1): 24, (6, 2): 25, (6, 3): 26, (6, 4): 27, (6, 5): 28,
}  # fmt: skip


def _inter_block(first: int) -> dict[tuple[int, int], int]:
    """Inter-leg block whose genes start at C_first (12 genes, rows 1-4 of Fig. 12)."""
    k = first
    block: dict[tuple[int, int], int] = {}
    for t, receivers in ((1, (1, 2, 3, 4)), (2, (1, 2, 3, 4)), (3, (1, 2)), (4, (1, 2))):
        for r in receivers:
            block[(t, r)] = k
            k += 1
    return block


# Ring offset (receiver - transmitter) -> block: +1 "LEG-A", +2 "LEG-B", +3 "LEG-C".
_INTER: dict[int, dict[tuple[int, int], int]] = {
    1: _inter_block(53),
    2: _inter_block(41),
    3: _inter_block(29),
}
# Touch sensor -> neurons: own leg S1..S6; ring offset +1: S11,S12; +2: S9,S10; +3: S7,S8.
_SENSOR_OWN = {n: n for n in range(1, 7)}
_SENSOR_OTHER = {1: (11, 12), 2: (9, 10), 3: (7, 8)}

#: Bounds of each gene for the optimiser: structure in [0, 1], C in [-3, 3], S in [-2, 2].
GENE_LOWER = np.concatenate([[0.0], np.full(N_CPG_WEIGHTS, -3.0), np.full(N_SENSOR_WEIGHTS, -2.0)])
GENE_UPPER = np.concatenate([[1.0], np.full(N_CPG_WEIGHTS, 3.0), np.full(N_SENSOR_WEIGHTS, 2.0)])


def gene_name(index: int) -> str:
    """Return the Fig. 12 name of gene ``index`` ("structure", "C1".."C64", "S1".."S12")."""
    if index == STRUCTURE_GENE:
        return "structure"
    if 1 <= index <= N_CPG_WEIGHTS:
        return f"C{index}"
    if N_CPG_WEIGHTS < index < N_GENES:
        return f"S{index - N_CPG_WEIGHTS}"
    raise IndexError(f"gene index {index} outside 0..{N_GENES - 1}")


def ring_of(structure_gene: float) -> tuple[int, int, int, int]:
    """Return the leg ring selected by the structure gene (a value in [0, 1])."""
    idx = int(np.clip(np.floor(float(structure_gene) * len(RINGS)), 0, len(RINGS) - 1))
    return RINGS[idx]


@dataclass(frozen=True)
class CPGWeights:
    """Decoded chromosome.

    Attributes:
        W: (24, 24) float64, Eq. (5) w_ij, weight from neuron j to neuron i (positive inhibits).
        V: (24, 4) float64, Eq. (5) V_il, weight from touch sensor l (FL, FR, HL, HR) to neuron i.
        ring: the leg ring chosen by the structure gene, as leg indices.
    """

    W: np.ndarray
    V: np.ndarray
    ring: tuple[int, int, int, int]


def validate_genes(genes: np.ndarray) -> np.ndarray:
    """Return ``genes`` as a float64 (77,) array, or raise ``ValueError`` saying what is wrong."""
    g = np.asarray(genes, dtype=np.float64)
    if g.shape != (N_GENES,):
        raise ValueError(f"a chromosome has {N_GENES} genes, got an array of shape {g.shape}")
    if not np.all(np.isfinite(g)):
        bad = np.flatnonzero(~np.isfinite(g)).tolist()
        raise ValueError(f"chromosome genes {bad} are not finite")
    return g


def decode(genes: np.ndarray) -> CPGWeights:
    """Map a 77-gene chromosome to the CPG's weight matrices (Fig. 12).

    Args:
        genes: (77,) float, ``[structure, C1..C64, S1..S12]``.

    Returns:
        The 24x24 neuron weights, the 24x4 touch-sensor weights and the leg ring.
    """
    g = validate_genes(genes)
    ring = ring_of(g[STRUCTURE_GENE])
    c = g[1 : 1 + N_CPG_WEIGHTS]  # c[k - 1] is C_k
    s = g[1 + N_CPG_WEIGHTS :]  # s[k - 1] is S_k
    W = np.zeros((N_NEURONS, N_NEURONS))
    V = np.zeros((N_NEURONS, len(LEGS)))
    for pos_t, leg_t in enumerate(ring):
        for (t, r), k in _INTRA.items():
            W[6 * leg_t + r - 1, 6 * leg_t + t - 1] = c[k - 1]
        for offset, block in _INTER.items():
            leg_r = ring[(pos_t + offset) % 4]
            for (t, r), k in block.items():
                W[6 * leg_r + r - 1, 6 * leg_t + t - 1] = c[k - 1]
        for n, k in _SENSOR_OWN.items():
            V[6 * leg_t + n - 1, leg_t] = s[k - 1]
        for offset, (k1, k2) in _SENSOR_OTHER.items():
            leg_r = ring[(pos_t + offset) % 4]
            V[6 * leg_r + 0, leg_t] = s[k1 - 1]
            V[6 * leg_r + 1, leg_t] = s[k2 - 1]
    return CPGWeights(W=W, V=V, ring=ring)


def gene_entries(index: int, structure_gene: float = 0.0) -> list[tuple[str, int, int]]:
    """List the matrix entries gene ``index`` sets, as ``("W" or "V", row, col)``.

    Used by tests and for documentation: a C gene sets 4 (or, for C1 and C17, 8) entries of ``W``,
    one per leg; an S gene sets 4 entries of ``V``.
    """
    if index == STRUCTURE_GENE:
        raise ValueError("the structure gene selects the ring; it sets no single entry")
    base = np.zeros(N_GENES)
    base[STRUCTURE_GENE] = structure_gene
    probe = base.copy()
    probe[index] = 1.0
    d0, d1 = decode(base), decode(probe)
    out = [("W", int(i), int(j)) for i, j in zip(*np.nonzero(d1.W != d0.W), strict=True)]
    out += [("V", int(i), int(j)) for i, j in zip(*np.nonzero(d1.V != d0.V), strict=True)]
    return out
