import pickle

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import neurocog_gym
from neurocog_gym.robot.model import RobotIndex, load_model

WALK = "NeuroCog/Walk-v3"


def rollout(env, seed, steps, action_seed=None):
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(action_seed)
    out = [obs]
    for _ in range(steps):
        a = (
            np.zeros(15, np.float32)
            if action_seed is None
            else rng.uniform(-0.3, 0.3, 15).astype(np.float32)
        )
        obs, r, term, trunc, info = env.step(a)
        out.append((obs, r, term, trunc))
        if term or trunc:
            break
    return out, env.unwrapped.data.qpos.copy()


def test_registered():
    assert WALK in gym.registry
    assert WALK in neurocog_gym.ENV_IDS


def test_same_seed_same_episode_bit_for_bit():
    env = gym.make(WALK)
    _, q1 = rollout(env, 123, 150, action_seed=5)
    _, q2 = rollout(env, 123, 150, action_seed=5)
    _, q3 = rollout(env, 124, 150, action_seed=5)
    assert np.array_equal(q1, q2)
    assert not np.array_equal(q1, q3)


def test_pickle_roundtrip():
    env = gym.make(WALK)
    env.reset(seed=0)
    env2 = pickle.loads(pickle.dumps(env))
    obs, _ = env2.reset(seed=0)
    assert env2.observation_space.contains(obs)


def test_spaces_and_info_terms():
    env = gym.make(WALK)
    obs, _ = env.reset(seed=0)
    assert env.action_space.shape == (15,)
    assert set(obs) >= {"joint_pos", "joint_vel", "touch", "torso_quat", "cpg"}
    obs, r, term, trunc, info = env.step(env.action_space.sample())
    assert r == pytest.approx(info["reward_tracking"] + info["reward_energy"])
    assert not term and not trunc


def test_time_limit_from_registration():
    assert gym.spec(WALK).max_episode_steps == 2000


@pytest.mark.parametrize(
    "bad, match",
    [
        (np.full(15, np.nan, np.float32), "NaN or inf"),
        (np.zeros(14, np.float32), "shape"),
        (np.array(["a"] * 15), "real numbers"),
    ],
)
def test_bad_actions_raise_before_sim(bad, match):
    env = gym.make(WALK)
    env.reset(seed=0)
    t0 = env.unwrapped.data.time
    with pytest.raises(ValueError, match=match):
        env.step(bad)
    assert env.unwrapped.data.time == t0
    env.step(np.zeros(15, np.float32))  # still usable


def test_out_of_range_actions_are_clipped():
    env = gym.make(WALK)
    env.reset(seed=0)
    _, r1, *_ = env.step(np.full(15, 5.0, np.float32))
    env.reset(seed=0)
    _, r2, *_ = env.step(np.full(15, 1.0, np.float32))
    assert r1 == r2


def test_rgb_and_depth_render():
    env = gym.make(WALK, render_mode="rgb_array", width=160, height=120)
    env.reset(seed=0)
    img = env.render()
    assert img.shape == (120, 160, 3) and img.dtype == np.uint8 and img.std() > 1
    env.close()
    env = gym.make(WALK, render_mode="depth_array", width=160, height=120)
    env.reset(seed=0)
    depth = env.render()
    assert depth.shape == (120, 160) and np.isfinite(depth).all()
    env.close()


def test_human_without_display_says_so(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(RuntimeError, match="needs a display"):
        gym.make(WALK, render_mode="human")


def test_model_loads_with_named_parts():
    model = load_model()
    idx = RobotIndex.build(model)
    assert model.nu == 12 and len(idx.touch_adr) == 4
    assert 3.0 < idx.mass < 7.0
    assert np.all(model.geom_group[idx.robot_geoms] == 2)


def test_scene_steps_under_random_controls_without_warnings():
    model = load_model()
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    rng = np.random.default_rng(0)
    lo, hi = model.actuator_ctrlrange.T
    for _ in range(100):  # 1 s at 10 ms per control
        data.ctrl[:] = rng.uniform(lo, hi)
        mujoco.mj_step(model, data, nstep=5)
    assert all(w.number == 0 for w in data.warning)
    assert np.isfinite(data.qpos).all()


def test_sim_fault_truncates_with_flag_and_reset_is_clean():
    env = gym.make(WALK)
    env.reset(seed=0)
    env.unwrapped.data.qvel[:] = 1e9  # a diverging state
    obs, r, term, trunc, info = env.step(np.zeros(15, np.float32))
    assert trunc and not term and info["sim_unstable"]
    obs, _ = env.reset(seed=0)
    obs, r, term, trunc, info = env.step(np.zeros(15, np.float32))
    assert not info["sim_unstable"] and not trunc


def test_default_gait_walks_10s_at_half_a_metre_per_second():
    env = gym.make(WALK)
    for seed in (0, 1):
        env.reset(seed=seed)
        xs = []
        for _ in range(1000):
            _, _, term, _, info = env.step(np.zeros(15, np.float32))
            assert not term, f"fell at seed {seed}"
            xs.append(info["x_position"])
        speed = (xs[-1] - xs[199]) / 8.0
        assert 0.4 <= speed <= 0.6, (seed, speed)


def test_unknown_camera_name_is_a_clear_error():
    with pytest.raises(
        ValueError, match="unknown camera_name 'nosuchcam': the scene's cameras are .*follow"
    ):
        gym.make("NeuroCog/Walk-v3", camera_name="nosuchcam")
    gym.make("NeuroCog/Walk-v3", camera_name=None).close()  # the free camera stays available
