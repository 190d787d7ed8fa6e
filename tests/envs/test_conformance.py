"""The same checks for every registered id (Gymnasium's env checker, determinism, pickling)."""

import pickle
import warnings

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


# Gymnasium's checkers warn about every Box with an infinite bound; joint rates, velocities and
# offsets have none, as in Gymnasium's own MuJoCo envs (Ant-v5 gets the same two warnings).
# These are the only warnings accepted, documented in docs/environments.md.
ACCEPTED_WARNINGS = {
    "A Box observation space maximum value is infinity. This is probably too high.",
    "A Box observation space minimum value is -infinity. This is probably too low.",
}


def _unexpected(caught) -> list[str]:
    texts = {str(w.message).replace("\x1b[33mWARN: ", "").replace("\x1b[0m", "") for w in caught}
    return sorted(texts - ACCEPTED_WARNINGS)


@pytest.mark.parametrize("env_id", IDS)
def test_env_checker(env_id):
    env = gym.make(env_id)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped, skip_render_check=True)
    env.close()
    assert not _unexpected(caught)


@pytest.mark.parametrize("env_id", IDS)
def test_passive_checker_warns_only_about_infinite_bounds(env_id):
    """``gym.make`` wraps the env in Gymnasium's PassiveEnvChecker: reset, step and render."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        env = gym.make(env_id, render_mode="rgb_array", width=64, height=48)
        assert any(type(w).__name__ == "PassiveEnvChecker" for w in _wrappers(env))
        obs, _ = env.reset(seed=0)
        for _ in range(3):
            obs, *_ = env.step(env.action_space.sample())
        frame = env.render()
        env.close()
    assert env.observation_space.contains(obs) and frame.shape == (48, 64, 3)
    assert not _unexpected(caught)


def _wrappers(env):
    while isinstance(env, gym.Wrapper):
        yield env
        env = env.env


def test_the_accepted_warnings_are_still_raised():
    """The filter above matches Gymnasium's current text (else it would hide nothing)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(gym.make(IDS[0]).unwrapped, skip_render_check=True)
    texts = {str(w.message).replace("\x1b[33mWARN: ", "").replace("\x1b[0m", "") for w in caught}
    assert ACCEPTED_WARNINGS <= texts


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
