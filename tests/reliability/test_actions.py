"""Issue 9, item 1: bad actions are refused before the simulation is touched; every env id."""

import gymnasium as gym
import numpy as np
import pytest

import neurocog_gym

IDS = list(neurocog_gym.ENV_IDS)


def _state(env):
    u = env.unwrapped
    s = {
        "time": u.data.time,
        "qpos": u.data.qpos.copy(),
        "qvel": u.data.qvel.copy(),
        "ctrl": u.data.ctrl.copy(),
        "cpg_x": u.generator.cpg.x.copy(),
        "q_ref": u.generator.pools.q_ref.copy(),
        "rng": u.np_random.bit_generator.state,
    }
    if hasattr(u, "pipeline"):
        s["nodes"] = u.pipeline.net.nodes.copy()
    return s


def _same(a, b):
    assert a.keys() == b.keys()
    for k in a:
        if isinstance(a[k], np.ndarray):
            np.testing.assert_array_equal(a[k], b[k], err_msg=k)
        else:
            assert a[k] == b[k], k


def _bad_cases():
    def nan_at(idx, value=np.nan):
        a = np.zeros(15, np.float32)
        a[idx] = value
        return a

    return [
        # (action, message must contain ...)
        (nan_at([3]), ["[3]", "NaN or inf"]),
        (nan_at([0, 14], np.inf), ["[0, 14]", "NaN or inf"]),
        (nan_at([7], -np.inf), ["[7]", "NaN or inf"]),
        (np.where(np.arange(15) % 2 == 0, np.nan, 0.0), ["[0, 2, 4, 6, 8, 10, 12, 14]"]),
        (np.zeros(14, np.float32), ["shape (15,)", "(14,)"]),
        (np.zeros(16), ["shape (15,)", "(16,)"]),
        (np.zeros((1, 15), np.float32), ["shape (15,)", "(1, 15)"]),
        (np.zeros((15, 1), np.float32), ["shape (15,)", "(15, 1)"]),
        (np.float32(0.0), ["shape (15,)", "()"]),
        ([0.0] * 3, ["shape (15,)", "(3,)"]),
        (np.array(["a"] * 15), ["real numbers", "<U1"]),
        (np.zeros(15, complex), ["real numbers", "complex"]),
        (np.zeros(15, bool), ["real numbers", "bool"]),
        (np.array([None] * 15), ["real numbers", "object"]),
    ]


@pytest.mark.parametrize("env_id", IDS)
def test_bad_actions_raise_naming_the_problem_and_leave_the_env_untouched(env_id):
    env = gym.make(env_id)
    env.reset(seed=4)
    env.step(np.zeros(15, np.float32))
    before = _state(env)
    for action, says in _bad_cases():
        with pytest.raises(ValueError) as err:
            env.step(action)
        for s in says:
            assert s in str(err.value), (action, str(err.value))
        _same(before, _state(env))
    # Still usable, and exactly as if the bad calls had never been made.
    ref = gym.make(env_id)
    ref.reset(seed=4)
    ref.step(np.zeros(15, np.float32))
    rng = np.random.default_rng(0)
    for _ in range(30):
        a = rng.uniform(-0.5, 0.5, 15).astype(np.float32)
        o1, r1, *_ = env.step(a)
        o2, r2, *_ = ref.step(a)
        assert r1 == r2
    np.testing.assert_array_equal(env.unwrapped.data.qpos, ref.unwrapped.data.qpos)


@pytest.mark.parametrize("env_id", IDS)
def test_out_of_range_actions_are_clipped_to_the_box(env_id):
    rng = np.random.default_rng(1)
    actions = rng.uniform(-4.0, 4.0, (25, 15))
    runs = []
    for clip in (False, True):
        env = gym.make(env_id)
        env.reset(seed=2)
        trace = []
        for a in actions:
            obs, r, *_ = env.step(np.clip(a, -1, 1) if clip else a)
            trace.append((r, obs["joint_pos"].copy()))
        runs.append((trace, env.unwrapped.data.qpos.copy()))
    np.testing.assert_array_equal(runs[0][1], runs[1][1])
    assert all(a[0] == b[0] for a, b in zip(runs[0][0], runs[1][0], strict=True))
    # ... and the clipping matters: the same actions scaled into the box differ.
    env = gym.make(env_id)
    env.reset(seed=2)
    for a in actions:
        env.step(a / 4.0)
    assert not np.array_equal(env.unwrapped.data.qpos, runs[0][1])


@pytest.mark.parametrize("env_id", IDS)
def test_integer_and_float64_actions_are_accepted(env_id):
    env = gym.make(env_id)
    env.reset(seed=0)
    env.step(np.zeros(15, np.int64))
    env.step([0.1] * 15)
    env.step(np.full(15, 0.1, np.float64))
