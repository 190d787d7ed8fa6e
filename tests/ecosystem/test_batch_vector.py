"""BatchVectorEnv (neurocog_gym/envs/batch.py): the results of SyncVectorEnv, bit for bit, on
threads; and BatchVecEnv, its stable-baselines3 face, the results of DummyVecEnv."""

import threading

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import SyncVectorEnv
from test_spin_vector import (
    SUDDEN,
    _assert_same,
    _assert_same_rollouts,
    _sb3_rollout,
    _tiny,
    _TinyEnv,
)

from neurocog_gym.envs.batch import BatchVectorEnv, make_batch_vector


@pytest.mark.parametrize("mode", ["NextStep", "SameStep"])
@pytest.mark.parametrize("threads", [1, 2, 3])
def test_tiny_env_matches_sync_with_every_info_kind_and_autoreset(mode, threads):
    # horizons 4, 6, 5: the sub-envs end and autoreset on different steps
    fns = [_tiny(0, horizon=4), _tiny(1, horizon=6), _tiny(2, horizon=5)]
    _assert_same_rollouts(
        SyncVectorEnv(fns, autoreset_mode=mode),
        BatchVectorEnv(fns, num_threads=threads, autoreset_mode=mode),
        30,
        seed=11,
    )


def test_obstacle_env_matches_sync_bit_for_bit_through_autoresets():
    # a 60-step time limit: the sub-envs truncate and reset inside the rollout; 3 envs on 2
    # threads: one thread steps two of them
    fns = [lambda: gym.make(SUDDEN, max_episode_steps=60)] * 3
    envs = BatchVectorEnv(fns, num_threads=2)
    assert envs.num_threads == 2
    _assert_same_rollouts(SyncVectorEnv(fns), envs, 150, seed=5)


def test_make_vec_threads_backend_agrees_with_sync():
    batch = gym.make_vec(SUDDEN, num_envs=2, vector_backend="threads", max_episode_steps=30)
    sync = gym.make_vec(SUDDEN, num_envs=2, vectorization_mode="sync", max_episode_steps=30)
    assert isinstance(batch, BatchVectorEnv)
    assert batch.observation_space == sync.observation_space
    assert batch.action_space == sync.action_space
    _assert_same_rollouts(sync, batch, 40, 2)


def test_the_sub_envs_step_on_the_worker_threads():
    seen = []

    class Where(gym.Wrapper):
        def step(self, action):
            seen.append((self.env.unwrapped.tag, threading.current_thread().name))
            return super().step(action)

    envs = BatchVectorEnv([lambda i=i: Where(_TinyEnv(i)) for i in range(4)], num_threads=2)
    try:
        envs.reset(seed=0)
        envs.step(np.zeros((4, 2), np.float32))
        where = dict(seen)
        main = threading.current_thread().name
        assert where[0] == where[1] == main  # the first group steps in the calling thread
        assert where[2] == where[3] == "BatchVectorEnv-1"
    finally:
        envs.close()


def test_copy_false_returns_the_batched_arrays():
    envs = BatchVectorEnv([_tiny(0), _tiny(1)], copy=False)
    try:
        obs, _ = envs.reset(seed=0)
        first = obs["x"].copy()
        obs2, *_ = envs.step(np.zeros((2, 2), np.float32))
        assert obs2["x"] is obs["x"]  # the same buffer, overwritten in place
        assert not np.array_equal(obs["x"], first)
    finally:
        envs.close()


def test_call_get_set_attr_and_reset_mask():
    envs = BatchVectorEnv([_tiny(0), _tiny(1), _tiny(2)])
    try:
        assert envs.get_attr("tag") == (0, 1, 2)
        envs.set_attr("horizon", [2, 3, 4])
        assert envs.get_attr("horizon") == (2, 3, 4)
        envs.set_attr("horizon", 9)
        assert envs.get_attr("horizon") == (9, 9, 9)
        assert [o["x"][2] for o in envs.call("_obs")] == [0, 1, 2]
        envs.reset(seed=[1, 2, 3])
        envs.step(np.zeros((3, 2), np.float32))
        obs, info = envs.reset(options={"reset_mask": np.array([False, True, False])})
        assert obs["x"][1, 1] == 0 and obs["x"][0, 1] == 1 and obs["x"][2, 1] == 1
        assert info["_i"].tolist() == [False, True, False]
    finally:
        envs.close()


def test_disabled_autoreset_asks_for_a_reset():
    envs = BatchVectorEnv([_tiny(0, horizon=1), _tiny(1, horizon=3)], autoreset_mode="Disabled")
    try:
        envs.reset(seed=0)
        _, _, term, _, _ = envs.step(np.zeros((2, 2), np.float32))
        assert term.tolist() == [True, False]
        with pytest.raises(RuntimeError, match=r"Disabled.*\[0\]"):
            envs.step(np.zeros((2, 2), np.float32))
        envs.reset(options={"reset_mask": np.array([True, False])})
        envs.step(np.zeros((2, 2), np.float32))
    finally:
        envs.close()


def test_bad_arguments_are_clear_errors():
    with pytest.raises(ValueError, match="at least one env factory"):
        BatchVectorEnv([])
    with pytest.raises(ValueError, match="num_threads"):
        BatchVectorEnv([_tiny()], num_threads=0)
    with pytest.raises(ValueError, match="num_envs"):
        make_batch_vector(SUDDEN, 0)
    with pytest.raises(ValueError, match="vector_backend"):
        gym.make_vec(SUDDEN, 2, vector_backend="ray")
    with pytest.raises(RuntimeError, match="another observation space"):
        BatchVectorEnv([_tiny(0), lambda: gym.make("CartPole-v1")])
    envs = BatchVectorEnv([_tiny(0), _tiny(1)])
    try:
        with pytest.raises(ValueError, match="num_envs=2"):
            envs.reset(seed=[1, 2, 3])
        with pytest.raises(ValueError, match="reset_mask"):
            envs.reset(options={"reset_mask": [True, False]})
    finally:
        envs.close()
    with pytest.raises(RuntimeError, match="closed"):
        envs.step(np.zeros((2, 2), np.float32))


def test_a_sub_env_error_is_raised_as_it_was_after_every_group_finished():
    # env 2 (on the worker thread) and env 0 (calling thread) both fail: the lowest index wins,
    # raised as SyncVectorEnv would raise it
    envs = BatchVectorEnv(
        [_tiny(0, fail_at=3), _tiny(1), _tiny(2, fail_at=2), _tiny(3)], num_threads=2
    )
    try:
        envs.reset(seed=0)
        envs.step(np.zeros((4, 2), np.float32))
        with pytest.raises(ValueError, match="tiny env 2 fails at step 2"):
            envs.step(np.zeros((4, 2), np.float32))
        with pytest.raises(ValueError, match="tiny env 0 fails at step 3"):
            envs.step(np.zeros((4, 2), np.float32))
        # each group stops at its failing env, as SyncVectorEnv stops at it: envs 0 and 2
        # stepped three times (the third raised), env 1 not in the third step, env 3 once
        assert envs.get_attr("t") == (3, 2, 3, 1)
    finally:
        envs.close()


def test_close_stops_the_threads():
    envs = BatchVectorEnv([_tiny(i) for i in range(3)], num_threads=3)
    threads = [g._thread for g in envs._groups]
    assert len(threads) == 2 and all(t.is_alive() for t in threads)
    envs.reset(seed=0)
    envs.step(np.zeros((3, 2), np.float32))
    envs.close()
    assert envs.closed
    assert not any(t.is_alive() for t in threads)
    single = BatchVectorEnv([_tiny(0)], num_threads=4)  # one env: no worker thread
    assert single.num_threads == 1 and single._groups == []
    single.reset(seed=0)
    single.step(np.zeros((1, 2), np.float32))
    single.close()


def test_sb3_batch_vec_env_matches_dummy_vec_env():
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.monitor import Monitor
    from stable_baselines3.common.vec_env import DummyVecEnv

    from neurocog_gym.envs.sb3_vec import BatchVecEnv

    kw = dict(n_envs=2, seed=3, env_kwargs={"max_episode_steps": 40})
    dummy = make_vec_env(SUDDEN, vec_env_cls=DummyVecEnv, **kw)
    batch = make_vec_env(SUDDEN, vec_env_cls=BatchVecEnv, **kw)
    try:
        a, b = _sb3_rollout(dummy, 90, 1), _sb3_rollout(batch, 90, 1)
        ended = 0
        for t, (x, y) in enumerate(zip(a, b, strict=True)):
            if t == 0:
                _assert_same(x, y, "reset")
                continue
            _assert_same(x[0], y[0], f"step {t} obs")
            for part in (1, 2):
                assert x[part].dtype == y[part].dtype and np.array_equal(x[part], y[part]), t
            assert len(x[3]) == len(y[3]) == 2
            for i, (p, q) in enumerate(zip(x[3], y[3], strict=True)):
                _assert_same(p, q, f"step {t} info {i}")
                ended += "terminal_observation" in p
        assert ended >= 4  # both sub-envs ended (time limit 40) and reset in the rollout
        assert batch.reset_infos[0].keys() == dummy.reset_infos[0].keys()
        assert batch.env_is_wrapped(Monitor) == [True, True]
        assert batch.env_method("get_wrapper_attr", "spec", indices=1)[0].id == SUDDEN
        batch.set_attr("neurocog_test_flag", 7, indices=[1])
        assert batch.get_attr("neurocog_test_flag", indices=[1]) == [7]
        with pytest.raises(IndexError, match="out of range"):
            batch.get_attr("render_mode", indices=[2])
    finally:
        dummy.close()
        batch.close()


def test_sb3_ppo_learns_a_few_steps_on_batch_vec_env():
    from stable_baselines3 import PPO

    from neurocog_gym.envs.sb3_vec import BatchVecEnv

    venv = BatchVecEnv([lambda: gym.make(SUDDEN, max_episode_steps=30)] * 2)
    try:
        model = PPO("MultiInputPolicy", venv, n_steps=32, batch_size=32, n_epochs=1, seed=0)
        model.learn(64)
        assert model.num_timesteps == 64
    finally:
        venv.close()
