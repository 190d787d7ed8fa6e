"""The same checks for every registered id (Gymnasium's env checker, determinism, pickling)."""

import pickle

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import neurocog_gym

IDS = list(neurocog_gym.ENV_IDS)


def _rollout(env, seed, steps=120):
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(1)
    trace = []
    for _ in range(steps):
        obs, r, term, trunc, info = env.step(rng.uniform(-0.3, 0.3, 15).astype(np.float32))
        trace.append((r, obs["joint_pos"].copy()))
        if term or trunc:
            break
    return trace, env.unwrapped.data.qpos.copy()


@pytest.mark.parametrize("env_id", IDS)
def test_env_checker(env_id):
    env = gym.make(env_id)
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


@pytest.mark.parametrize("env_id", IDS)
def test_determinism_bit_for_bit(env_id):
    env = gym.make(env_id)
    t1, q1 = _rollout(env, 7)
    t2, q2 = _rollout(env, 7)
    assert np.array_equal(q1, q2)
    assert all(a[0] == b[0] and np.array_equal(a[1], b[1]) for a, b in zip(t1, t2, strict=True))
    _, q3 = _rollout(env, 8)
    assert not np.array_equal(q1, q3)


@pytest.mark.parametrize("env_id", IDS)
def test_pickle(env_id):
    env = gym.make(env_id)
    env.reset(seed=0)
    clone = pickle.loads(pickle.dumps(env))
    obs, _ = clone.reset(seed=0)
    assert clone.observation_space.contains(obs)


@pytest.mark.parametrize("env_id", IDS)
def test_observation_in_space_while_walking(env_id):
    env = gym.make(env_id)
    obs, _ = env.reset(seed=3)
    for _ in range(60):
        obs, *_ = env.step(np.zeros(15, np.float32))
        assert env.observation_space.contains(obs)
