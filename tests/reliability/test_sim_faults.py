"""Issue 9, item 2: physics faults end the episode as truncated with ``sim_unstable``, never
raise, and the next reset is clean (every env id)."""

import warnings

import gymnasium as gym
import numpy as np
import pytest

import neurocog_gym

IDS = list(neurocog_gym.ENV_IDS)


def _finite(obs):
    return all(np.all(np.isfinite(np.asarray(v, dtype=np.float64))) for v in obs.values())


def _fault_qvel(u):
    u.data.qvel[:] = 1e9  # a diverging state


def _fault_qpos_nan(u):
    u.data.qpos[0:3] = np.nan


def _fault_qacc(u):
    u.data.qacc_warmstart[:] = np.inf  # MuJoCo's solver receives a non-finite warm start
    u.data.qvel[6:] = 1e6


def _fault_timestep(u):
    u.model.opt.timestep = 1.0  # 500 times the model's step: the integrator explodes
    return lambda: setattr(u.model.opt, "timestep", 0.002)


FAULTS = {"qvel": _fault_qvel, "qpos_nan": _fault_qpos_nan, "qacc": _fault_qacc,
          "timestep": _fault_timestep}  # fmt: skip


def _episode(env, seed, steps=40):
    obs, _ = env.reset(seed=seed)
    out = []
    for _ in range(steps):
        obs, r, term, trunc, info = env.step(np.full(15, 0.1, np.float32))
        out.append(r)
        assert not info["sim_unstable"]
        if term or trunc:
            break
    return out, env.unwrapped.data.qpos.copy()


@pytest.mark.parametrize("fault", sorted(FAULTS))
@pytest.mark.parametrize("env_id", IDS)
def test_fault_truncates_then_reset_is_clean(env_id, fault):
    env = gym.make(env_id)
    env.reset(seed=5)
    for _ in range(3):
        env.step(np.zeros(15, np.float32))
    u = env.unwrapped
    restore = FAULTS[fault](u)
    # A diverging integrator may take a cycle or two to show; a corrupted state shows at once.
    for _ in range(1 if fault != "timestep" else 3):
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # Gymnasium's checker: the observation is well typed
            obs, r, term, trunc, info = env.step(np.zeros(15, np.float32))
        if trunc:
            break
    if restore:
        restore()
    assert trunc and not term and info["sim_unstable"] is True, (trunc, term, info)
    assert np.isfinite(r)
    assert _finite(obs) and env.observation_space.contains(obs)
    if env_id != "NeuroCog/Walk-v3":
        assert info["outcome"] == "fail"
    # A caller that ignores the truncation: step still never raises.
    for _ in range(5):
        obs, r, term, trunc, info = env.step(np.zeros(15, np.float32))
        assert np.isfinite(r) and _finite(obs)
    # The next reset is clean: the same episode as a fresh env's, bit for bit.
    r1, q1 = _episode(env, seed=11)
    r2, q2 = _episode(gym.make(env_id), seed=11)
    assert r1 == r2
    np.testing.assert_array_equal(q1, q2)


@pytest.mark.parametrize("env_id", IDS)
def test_no_false_alarm_over_a_normal_episode(env_id):
    env = gym.make(env_id)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(150):
        _, _, term, trunc, info = env.step(rng.uniform(-1, 1, 15).astype(np.float32))
        assert info["sim_unstable"] is False
        if term or trunc:
            env.reset()


@pytest.mark.parametrize("env_id", IDS)
def test_fault_on_the_first_step_gives_a_well_typed_observation(env_id):
    # Gymnasium's passive checker inspects the first step of a made env: the placeholder
    # observation of a faulty step must pass it like a real one (Discrete entries as np.int64).
    env = gym.make(env_id)
    env.reset(seed=0)
    env.unwrapped.data.qvel[:] = 1e9
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        obs, _, _, trunc, info = env.step(np.zeros(15, np.float32))
    assert trunc and info["sim_unstable"]
    for key, space in env.observation_space.items():
        assert space.contains(obs[key]), key
