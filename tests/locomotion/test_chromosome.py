import numpy as np
import pytest

from neurocog_gym.locomotion.chromosome import (
    GENE_LOWER,
    GENE_UPPER,
    N_GENES,
    RINGS,
    decode,
    gene_entries,
    gene_name,
    ring_of,
)

# Physical legs FL=0, FR=1, HL=2, HR=3; neuron 6*leg + n, n = Fig. 12 number - 1.
RING0 = RINGS[0]  # FL FR HR HL


def neuron(leg, fig12_number):
    return 6 * leg + fig12_number - 1


def test_gene_count_and_names():
    assert N_GENES == 77 == 1 + 64 + 12
    assert gene_name(0) == "structure"
    assert gene_name(1) == "C1" and gene_name(64) == "C64"
    assert gene_name(65) == "S1" and gene_name(76) == "S12"
    assert GENE_LOWER.shape == GENE_UPPER.shape == (77,)


def test_c1_is_the_symmetric_hip_pair_in_every_leg():
    # Fig. 12: C1 is both 1->2 and 2->1; W[receiver, transmitter].
    expected = set()
    for leg in range(4):
        expected.add(("W", neuron(leg, 2), neuron(leg, 1)))
        expected.add(("W", neuron(leg, 1), neuron(leg, 2)))
    assert set(gene_entries(1)) == expected


def test_c17_is_printed_twice_in_row_4():
    expected = set()
    for leg in range(4):
        expected.add(("W", neuron(leg, 3), neuron(leg, 4)))
        expected.add(("W", neuron(leg, 5), neuron(leg, 4)))
    assert set(gene_entries(17)) == expected


@pytest.mark.parametrize("k", [2, 6, 10, 23, 28])
def test_intra_leg_gene_sets_one_entry_per_leg(k):
    entries = gene_entries(k)
    assert len(entries) == 4
    legs = sorted({i // 6 for _, i, _ in entries})
    assert legs == [0, 1, 2, 3]
    assert all(i // 6 == j // 6 for _, i, j in entries)


def test_inter_leg_blocks_follow_the_ring():
    # C53 is "LEG 1 neuron 1 -> LEG-A neuron 1": transmitter ring position p, receiver p + 1.
    e53 = set(gene_entries(53))
    assert e53 == {("W", neuron(RING0[(p + 1) % 4], 1), neuron(RING0[p], 1)) for p in range(4)}
    # C41 -> LEG-B (p + 2, the diagonal in ring 0: FL<->HR, FR<->HL).
    e41 = set(gene_entries(41))
    assert ("W", neuron(3, 1), neuron(0, 1)) in e41  # FL -> HR
    assert ("W", neuron(2, 1), neuron(1, 1)) in e41  # FR -> HL
    # C29 -> LEG-C (p + 3): FL's previous leg in the ring is HL.
    assert ("W", neuron(2, 1), neuron(0, 1)) in set(gene_entries(29))
    # C62: LEG 1 neuron 3 -> LEG-A neuron 2.
    assert ("W", neuron(1, 2), neuron(0, 3)) in set(gene_entries(62))


def test_sensor_genes():
    # S1: own leg, neuron 1; S11/S12: the next leg on the ring, neurons 1/2.
    assert set(gene_entries(65)) == {("V", neuron(leg, 1), leg) for leg in range(4)}
    e75 = set(gene_entries(75))  # S11
    assert ("V", neuron(RING0[1], 1), RING0[0]) in e75
    assert len(e75) == 4


def test_every_weight_gene_touches_something_and_total_counts():
    g = np.arange(N_GENES, dtype=float) + 1.0
    g[0] = 0.0
    d = decode(g)
    # 30 intra slots per leg + 3 relations x 12 per transmitter leg, 4 legs.
    assert np.count_nonzero(d.W) == 4 * (30 + 36)
    assert np.count_nonzero(d.V) == 4 * (6 + 6)
    assert np.all(np.diag(d.W) == 0)
    for k in range(1, N_GENES):
        assert gene_entries(k), gene_name(k)


def test_structure_gene_selects_ring():
    assert ring_of(0.0) == RINGS[0]
    assert ring_of(0.999) == RINGS[5]
    assert ring_of(1.0) == RINGS[5]
    assert ring_of(0.4) == RINGS[2]


@pytest.mark.parametrize("bad", [np.zeros(76), np.zeros((77, 1)), np.full(77, np.nan)])
def test_bad_chromosome_raises(bad):
    with pytest.raises(ValueError):
        decode(bad)
