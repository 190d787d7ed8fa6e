"""The numba effectivity against its NumPy oracle, cycle by cycle, on random walks past boxes."""

import numpy as np
import pytest

from neurocog_gym.locomotion.effectivity import Effectivity, EffectivityParams
from tests.locomotion.effectivity_oracle import EffectivityOracle

HIP = np.array([[0.12, 0.07, 0.2], [0.12, -0.07, 0.2], [-0.12, 0.07, 0.2], [-0.12, -0.07, 0.2]])


def _random_episode(seed: int, cycles: int = 400):
    """Inputs of a robot trotting forward (with wobble) through random boxes that appear,
    vanish and move; feet rise and fall with a trot, sometimes high (an interrupt's lift)."""
    rng = np.random.default_rng(seed)
    x = 0.0
    boxes_world = []
    for _ in range(rng.integers(1, 4)):
        cx, cy = rng.uniform(0.2, 1.5), rng.uniform(-0.25, 0.25)
        lx, ly, h = rng.uniform(0.05, 0.2), rng.uniform(0.1, 0.3), rng.uniform(0.04, 0.09)
        boxes_world.append(
            np.array([[cx - lx / 2, cy - ly / 2, 0.0], [cx + lx / 2, cy + ly / 2, h]])
        )
    for i in range(cycles):
        t = 0.01 * i
        yaw = 0.2 * np.sin(0.7 * t) + rng.normal(0, 0.01)
        v = np.array([0.5 * np.cos(yaw), 0.5 * np.sin(yaw), 0.0]) + rng.normal(0, 0.05, 3)
        x += 0.005
        c, s = np.cos(yaw), np.sin(yaw)
        hip = HIP @ np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]]) + np.array([x, 0.0, 0.0])
        phase = 2 * np.pi * t / 0.44 + np.array([0, np.pi, np.pi, 0])
        lift = np.maximum(np.sin(phase), 0.0)
        foot = hip.copy()
        foot[:, 0] += 0.05 * np.cos(phase)
        foot[:, 2] = 0.018 + lift * rng.uniform(0.02, 0.12)
        touch = np.where(lift > 0.05, 0.0, rng.uniform(0.5, 1.5, 4))
        # Perception reports each box now and then, with jitter; sometimes nothing at all.
        seen = [b + rng.normal(0, 0.005, (2, 3)) for b in boxes_world if rng.random() < 0.6]
        boxes = np.array(seen).reshape(-1, 2, 3)
        yield t, touch, foot, hip, yaw, v, boxes


@pytest.mark.parametrize("seed", range(12))
def test_kernel_matches_the_oracle_cycle_by_cycle(seed):
    params = EffectivityParams(margin=0.01 + 0.01 * (seed % 3))
    fast, slow = Effectivity(params), EffectivityOracle(params)
    phases, hits = set(), 0
    for args in _random_episode(seed):
        a, b = fast.step(*args), slow.step(*args)
        for name in ("swinging", "foothold_safe", "path_safe", "phase", "hit"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
        for name in ("foothold", "direction"):
            np.testing.assert_allclose(
                getattr(a, name), getattr(b, name), rtol=0, atol=1e-12, err_msg=name
            )
        np.testing.assert_array_equal(fast.memory, slow.memory)
        phases.update(a.phase.tolist())
        hits += int((a.hit >= 0).sum())
    # Every seed's walk goes past boxes: both interrupt phases and met boxes must have been seen.
    assert phases == {0, 1, 2} and hits > 0


def test_memory_keeps_the_newest_boxes_when_full():
    eff = Effectivity()
    foot = HIP.copy()
    for k in range(eff.memory_capacity + 5):
        box = np.array([[0.3, -0.5 + 0.01 * k, 0.0], [0.35, -0.5 + 0.01 * k + 0.005, 0.05]])
        eff.remember(box[None], foot, HIP.mean(axis=0), np.array([1.0, 0.0, 0.0]))
    assert len(eff.memory) == eff.memory_capacity
    assert eff.memory[-1, 0, 1] == pytest.approx(-0.5 + 0.01 * (eff.memory_capacity + 4))
