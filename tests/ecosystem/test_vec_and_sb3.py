"""gymnasium.make_vec (sync and async) and stable-baselines3's env checker for every id."""

import gymnasium as gym
import numpy as np
import pytest

import neurocog_gym

IDS = list(neurocog_gym.ENV_IDS)


def _vec_rollout(env_id, mode, steps=5):
    envs = gym.make_vec(env_id, num_envs=2, vectorization_mode=mode)
    try:
        obs, _ = envs.reset(seed=[3, 4])
        assert envs.observation_space.contains(obs)
        rng = np.random.default_rng(0)
        trace = [obs["joint_pos"].copy()]
        for _ in range(steps):
            a = rng.uniform(-0.2, 0.2, (2, 15)).astype(np.float32)
            obs, rew, term, trunc, _ = envs.step(a)
            assert rew.shape == (2,) and term.shape == (2,) and trunc.shape == (2,)
            assert envs.observation_space.contains(obs)
            trace.append(obs["joint_pos"].copy())
        return np.stack(trace)
    finally:
        envs.close()


@pytest.mark.parametrize("env_id", IDS)
def test_make_vec_sync_and_async_agree(env_id):
    sync = _vec_rollout(env_id, "sync")
    asyn = _vec_rollout(env_id, "async")
    spin = _vec_rollout(env_id, "vector_entry_point")  # SpinVectorEnv, make_vec's default here
    assert sync.shape == (6, 2, 12)
    # same seeds, same actions: the workers of both reproduce the in-process envs bit for bit
    assert np.array_equal(sync, asyn)
    assert np.array_equal(sync, spin)
    # and the two sub-envs (seeds 3 and 4) are different episodes
    assert not np.array_equal(sync[:, 0], sync[:, 1])


# Every observation key is 1-D or an image, as on Gymnasium's Ant-v5: stable-baselines3's env
# checker has nothing to say about any registered id, with or without the DD-GNG graph keys.
SB3_CASES = [(i, {}) for i in IDS] + [
    (i, {"include_graph": True, "graph_max_nodes": 64, "graph_max_edges": 128})
    for i in IDS
    if i != "NeuroCog/Walk-v3"
]


@pytest.mark.parametrize(("env_id", "kwargs"), SB3_CASES)
def test_sb3_check_env_is_silent(env_id, kwargs, check_env_silently):
    env = gym.make(env_id, **kwargs)
    check_env_silently(env)
    for key, space in env.observation_space.spaces.items():
        assert len(space.shape) <= 1, key
