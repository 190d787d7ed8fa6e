"""The walk design of scripts/design_gait.py: ring 5 and a lateral-sequence CPG rhythm."""

import dataclasses
import importlib.util
import sys
from pathlib import Path

import numpy as np

from neurocog_gym.locomotion.chromosome import ring_of
from neurocog_gym.locomotion.cpg import MatsuokaCPG

_SCRIPTS = Path(__file__).resolve().parents[2] / "scripts"


def _load(name):
    spec = importlib.util.spec_from_file_location(name, _SCRIPTS / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


design_gait = _load("design_gait")


def _onset_lags(genes, seconds=20.0, dt=0.01):
    """Each leg's hip-flexor onset after FL's, as a share of the cycle (median), and the period.

    The network starts as ``LocomotionGenerator.reset`` starts it: in a trot phase plus noise.
    """
    cpg = MatsuokaCPG(np.asarray(genes), dt=dt)
    x0 = np.zeros(24)
    x0[[0, 18]] = 0.5  # FL and HR hip flexors
    x0[[7, 13]] = 0.5  # FR and HL hip extensors
    cpg.reset(x0 + np.random.default_rng(0).uniform(-0.05, 0.05, 24))
    ys = np.array([cpg.step(np.zeros(4)).copy() for _ in range(int(seconds / dt))])[500:]
    hip = ys[:, 0::6] - ys[:, 1::6]  # flexor minus extensor, legs FL FR HL HR
    onsets = [np.flatnonzero((hip[1:, leg] > 0) & (hip[:-1, leg] <= 0)) for leg in range(4)]
    period = float(np.median(np.diff(onsets[0])))
    lags = []
    for leg in range(4):
        d = [((o - onsets[0][onsets[0] <= o].max()) / period) for o in onsets[leg][2:]]
        lags.append(float(np.median(d)))
    return np.array(lags), period * dt


def test_the_trot_design_is_unchanged_by_the_walk_fields():
    trot = design_gait.build(design_gait.TrotDesign())
    assert ring_of(trot.genes[0]) == (0, 1, 3, 2)
    lags, _ = _onset_lags(trot.genes)
    # Diagonals together, the pairs half a cycle apart: FR and HL at 0.5, HR with FL.
    assert abs(lags[1] - 0.5) < 0.06 and abs(lags[2] - 0.5) < 0.06
    assert min(lags[3], 1 - lags[3]) < 0.06


def test_the_walk_design_gives_a_lateral_sequence_a_quarter_cycle_apart():
    walk = design_gait.build(dataclasses.replace(design_gait.TrotDesign(), walk=True))
    assert ring_of(walk.genes[0]) == (0, 3, 1, 2)  # FL HR FR HL
    assert walk.name == "hand-designed walk"
    lags, period = _onset_lags(walk.genes)
    # After FL: HR a quarter cycle later, FR half, HL three quarters (a lateral-sequence walk).
    assert np.allclose(lags[[3, 1, 2]], [0.25, 0.5, 0.75], atol=0.06), lags
    assert 0.1 < period < 1.0
