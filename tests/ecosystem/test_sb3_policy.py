"""SB3Policy: a saved model with (and without) the VecNormalize statistics train_ppo saves."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces

from neurocog_gym.policies import SB3Policy, make_policy, vecnormalize_path


class _DictEnv(gym.Env):
    """A stand-in with the obstacle envs' kinds of keys (Box and MultiBinary), 15-d actions."""

    observation_space = spaces.Dict(
        {
            "joint_vel": spaces.Box(-np.inf, np.inf, (12,), np.float32),
            "objects": spaces.Box(-np.inf, np.inf, (32,), np.float32),
            "foothold_safe": spaces.MultiBinary(4),
        }
    )
    action_space = spaces.Box(-1.0, 1.0, (15,), np.float32)

    def reset(self, seed=None, options=None):
        super().reset(seed=seed)
        return self.observation_space.sample(), {}

    def step(self, action):
        return self.observation_space.sample(), 0.0, False, False, {}


def _obs(rng):
    return {
        "joint_vel": rng.normal(40.0, 5.0, 12).astype(np.float32),
        "objects": rng.normal(-3.0, 1.0, 32).astype(np.float32),
        "foothold_safe": np.array([1, 0, 1, 1], np.int8),
    }


@pytest.fixture
def saved(tmp_path):
    """A fresh PPO model saved as OUT/model.zip and as a checkpoint, with statistics."""
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    venv = VecNormalize(
        DummyVecEnv([_DictEnv]), norm_obs_keys=["joint_vel", "objects"], norm_reward=True
    )
    model = PPO("MultiInputPolicy", venv, n_steps=8, batch_size=8, seed=0, device="cpu")
    # statistics far from the raw observations' scale
    venv.obs_rms["joint_vel"].mean[:] = 40.0
    venv.obs_rms["joint_vel"].var[:] = 25.0
    venv.obs_rms["objects"].mean[:] = -3.0
    venv.obs_rms["objects"].var[:] = 1.0
    model.save(tmp_path / "model.zip")
    venv.save(str(tmp_path / "vecnormalize.pkl"))
    ckpts = tmp_path / "checkpoints"
    ckpts.mkdir()
    model.save(ckpts / "ppo_128_steps.zip")
    venv.save(str(ckpts / "ppo_vecnormalize_128_steps.pkl"))
    return tmp_path, model, venv


def test_vecnormalize_path_names_train_ppos_files(tmp_path):
    assert vecnormalize_path(tmp_path / "model.zip") == tmp_path / "vecnormalize.pkl"
    ck = tmp_path / "checkpoints" / "ppo_2048_steps.zip"
    assert vecnormalize_path(ck) == tmp_path / "checkpoints" / "ppo_vecnormalize_2048_steps.pkl"


@pytest.mark.parametrize("name", ["model.zip", "checkpoints/ppo_128_steps.zip"])
def test_sb3_policy_normalizes_with_the_saved_statistics(saved, name):
    out, model, venv = saved
    policy = make_policy(str(out / name))
    assert isinstance(policy, SB3Policy) and policy.obs_normalizer is not None
    assert policy.obs_normalizer.training is False and policy.obs_normalizer.norm_reward is False
    rng = np.random.default_rng(0)
    for _ in range(3):
        obs = _obs(rng)
        raw = {k: np.copy(v) for k, v in obs.items()}
        action = policy(obs)
        assert all(np.array_equal(obs[k], raw[k]) for k in obs)  # the caller's obs untouched
        norm = venv.normalize_obs(raw)
        assert np.abs(norm["joint_vel"]).max() < 5
        np.testing.assert_array_equal(norm["foothold_safe"], [1, 0, 1, 1])  # not normalised
        expected, _ = model.predict(norm, deterministic=True)
        unnormalized, _ = model.predict(raw, deterministic=True)
        np.testing.assert_allclose(action, expected, rtol=0, atol=1e-6)
        assert not np.allclose(action, unnormalized, rtol=0, atol=1e-5)
    # frozen: evaluating does not move the statistics
    np.testing.assert_array_equal(policy.obs_normalizer.obs_rms["joint_vel"].mean, 40.0)


def test_sb3_policy_without_statistics_uses_raw_observations(saved):
    out, model, _ = saved
    (out / "vecnormalize.pkl").unlink()
    policy = SB3Policy(out / "model.zip")
    assert policy.obs_normalizer is None
    obs = _obs(np.random.default_rng(1))
    expected, _ = model.predict(obs, deterministic=True)
    np.testing.assert_allclose(policy(obs), expected, rtol=0, atol=1e-6)


def test_sb3_policy_explicit_statistics(saved, tmp_path):
    out, _, _ = saved
    stats = out / "vecnormalize.pkl"
    moved = tmp_path / "elsewhere.pkl"
    stats.rename(moved)
    assert SB3Policy(out / "model.zip", vecnormalize=moved).obs_normalizer is not None
    with pytest.raises(FileNotFoundError, match="VecNormalize statistics"):
        SB3Policy(out / "model.zip", vecnormalize=tmp_path / "missing.pkl")
    (tmp_path / "bad.pkl").write_bytes(__import__("pickle").dumps({"not": "stats"}))
    with pytest.raises(ValueError, match="not a VecNormalize"):
        SB3Policy(out / "model.zip", vecnormalize=tmp_path / "bad.pkl")


def test_shipped_ppo_policy_says_it_needs_retraining(capsys, tmp_path):
    """The shipped model was trained on SuddenObstacle-v0 (another body, 2-D observation keys):
    ``make_policy("ppo")`` and ``--policy ppo`` stop with one line that says so, instead of an
    observation-shape error from deep inside stable-baselines3 at the first step."""
    import neurocog_gym
    from neurocog_gym import cli
    from neurocog_gym.policies import shipped_ppo_env

    assert shipped_ppo_env() == "NeuroCog/SuddenObstacle-v0"
    assert shipped_ppo_env() not in neurocog_gym.ENV_IDS
    with pytest.raises(
        ValueError, match=r"trained on the v0 envs .* retrained on .*-v3 \(issue 24\)"
    ):
        make_policy("ppo")
    assert cli.main(["bench", "--policy", "ppo", "--trials", "1", "--workers", "1",
                     "--out", str(tmp_path / "bench")]) == 2  # fmt: skip
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "retrained" in err and "issue 24" in err
    assert not (tmp_path / "bench" / "trials.jsonl").exists()


def test_a_model_of_ones_own_still_loads_by_path(saved):
    """Only the name ``ppo`` is refused; a path is an :class:`SB3Policy`, whatever env it knew."""
    out, _, _ = saved
    assert isinstance(make_policy(str(out / "model.zip")), SB3Policy)
