"""observation_mode: the ToF depth image as an observation SB3 takes (envs/obstacle.py)."""

import pickle

import gymnasium as gym
import numpy as np
import pytest

import neurocog_gym  # noqa: F401  (registers the ids)
from neurocog_gym.envs._kernels import depth_image
from neurocog_gym.envs.obstacle import DEPTH_HEIGHT, DEPTH_RANGE, DEPTH_WIDTH
from neurocog_gym.robot.obstacles import Block
from neurocog_gym.robot.tof import ToFParams

SUDDEN = "NeuroCog/SuddenObstacle-v3"
STATIC = "NeuroCog/StaticObstacle-v3"
OBSTACLE_IDS = [SUDDEN, STATIC]
DEPTH_MODES = ["depth", "depth_only"]
ZERO = np.zeros(15, np.float32)
PERCEPTION_KEYS = {
    "objects", "objects_mask", "aef_input", "interrupt_direction", "foothold", "foothold_safe",
    "path_meets_block", "block_met", "remembered_blocks",
}  # fmt: skip


def _levels(frame) -> np.ndarray:
    """NumPy reading of the documented quantisation: round(255 z / 2 m), 255 if no return."""
    z = frame.depth.astype(np.float64)
    q = np.minimum(np.floor(z * (255.0 / DEPTH_RANGE) + 0.5), 255.0).astype(np.uint8)
    return np.where(frame.valid, q, np.uint8(255))


@pytest.mark.parametrize("mode", DEPTH_MODES)
@pytest.mark.parametrize("env_id", OBSTACLE_IDS)
def test_the_depth_key_is_an_image_sb3_takes(env_id, mode):
    from stable_baselines3.common.preprocessing import (
        is_image_space,
        is_image_space_channels_first,
    )

    env = gym.make(env_id, observation_mode=mode)
    space = env.observation_space["depth"]
    assert space.shape == (4, DEPTH_HEIGHT, DEPTH_WIDTH) and space.dtype == np.uint8
    assert is_image_space(space) and is_image_space_channels_first(space)
    # NatureCNN (MultiInputPolicy's extractor for images) needs 36 x 36 or more
    assert min(DEPTH_HEIGHT, DEPTH_WIDTH) >= 36
    obs, _ = env.reset(seed=0)
    for _ in range(5):
        assert env.observation_space.contains(obs)
        obs, *_ = env.step(ZERO)
    # every other key stays 1-D
    assert all(len(s.shape) <= 1 for k, s in env.observation_space.spaces.items() if k != "depth")


@pytest.mark.parametrize("mode", DEPTH_MODES)
@pytest.mark.parametrize("env_id", OBSTACLE_IDS)
def test_sb3_check_env_is_silent_in_the_depth_modes(env_id, mode, check_env_silently):
    env = gym.make(env_id, observation_mode=mode)
    check_env_silently(env)


def test_the_image_is_the_latest_frame_quantised_as_documented():
    env = gym.make(SUDDEN, observation_mode="depth")
    obs, _ = env.reset(seed=3)
    u = env.unwrapped
    assert np.array_equal(obs["depth"], _levels(u.frame))
    changed = 0
    for _ in range(12):
        before = obs["depth"]
        obs, *_ = env.step(ZERO)
        # between frames the image holds; every observation is its own copy
        assert np.array_equal(obs["depth"], _levels(u.frame))
        assert not np.shares_memory(obs["depth"], before)
        changed += not np.array_equal(obs["depth"], before)
    assert 3 <= changed <= 12  # a frame every 2 or 3 control cycles (45 fps)


def test_the_floor_gives_a_gradient():
    """The sensors look down at the floor: far (high values) at the top, near at the bottom."""
    env = gym.make(SUDDEN, observation_mode="depth")
    obs, _ = env.reset(seed=0)
    img = obs["depth"].astype(int)
    assert (img < 255).all()  # the whole view is floor within 2 m
    rows = img.mean(axis=2)  # (4, 43)
    # nearer row by row (near the bottom two rows can share a 7.8 mm level)
    assert (np.diff(rows, axis=1) <= 0).all() and (np.diff(rows[:, :20], axis=1) < 0).all()
    # a level is 2 m / 255: the top rows see the floor about 1.2 m away, the bottom ones 0.3 m
    assert rows[:, 0] == pytest.approx(1.23 * 255 / DEPTH_RANGE, abs=8)
    assert rows[:, -1] == pytest.approx(0.31 * 255 / DEPTH_RANGE, abs=4)
    # the fan is symmetric: the outer two sensors alike, the inner two alike
    assert np.abs(img[0] - img[3][:, ::-1]).max() <= 1
    assert np.abs(img[1] - img[2][:, ::-1]).max() <= 1


def _first_step(block: Block | None, seed: int = 0):
    env = gym.make(SUDDEN, observation_mode="depth")
    env.reset(seed=seed)
    u = env.unwrapped
    if block is not None:
        u.pool.place(u.model, u.data, [block])
    obs, *_ = env.step(ZERO)  # the first cycle after reset senses a frame
    return obs["depth"].astype(int), u


def test_a_block_in_front_shows_where_the_sensors_see_it():
    bare, u = _first_step(None)
    torso = u.data.xpos[u.robot.torso_body]
    block = Block(float(torso[0]) + 0.6, float(torso[1]), 0.1, 0.2, 0.08)
    seen, u = _first_step(block)
    sees_block = np.isin(u.frame.geom, u.pool.geom_ids[:1])
    changed = seen != bare
    # the two inner sensors (yaw +-20 deg) see it straight ahead, the outer two (+-60) do not
    assert sees_block[1].sum() > 30 and sees_block[2].sum() > 30
    assert not sees_block[0].any() and not sees_block[3].any()
    # only the pixels on the block change, and they come nearer (the block stands on the floor)
    assert changed.any() and not (changed & ~sees_block).any()
    assert (seen[sees_block] <= bare[sees_block]).all()
    assert changed[sees_block].mean() > 0.8
    # its near face at 0.55 m ahead of the torso is nearer than the floor behind it by > 10 levels
    assert (bare[sees_block] - seen[sees_block]).max() > 10


def test_misses_read_255():
    """Rays without a return within the range gate (here: beyond a 0.5 m gate) read 255."""
    env = gym.make(SUDDEN, observation_mode="depth", tof=ToFParams(backend="numba", max_range=0.5))
    obs, _ = env.reset(seed=0)
    valid = env.unwrapped.frame.valid
    assert not valid.all() and valid.any()
    assert (obs["depth"][~valid] == 255).all()
    assert (obs["depth"][valid] < 0.5 * 255 / DEPTH_RANGE + 1).all()


def test_a_full_resolution_frame_is_read_at_every_fourth_pixel():
    tof = ToFParams.at_scale(1.0, backend="numba")
    env = gym.make(SUDDEN, observation_mode="depth_only", tof=tof)
    obs, _ = env.reset(seed=0)
    f = env.unwrapped.frame
    assert f.depth.shape == (4, 172, 224)
    rows = np.rint(np.linspace(0, 171, DEPTH_HEIGHT)).astype(np.int64)
    cols = np.rint(np.linspace(0, 223, DEPTH_WIDTH)).astype(np.int64)
    assert np.array_equal(obs["depth"], _levels(f)[:, rows][:, :, cols])


def test_kernel_against_numpy_on_hand_picked_depths():
    depth = np.array([[[0.0, 1.0, 2.0, 3.0], [0.5, 0.003, 1.999, 0.99]]], np.float32)
    valid = np.array([[[False, True, True, True], [True, True, True, True]]])
    out = np.zeros((1, 2, 4), np.uint8)
    depth_image(depth, valid, np.arange(2), np.arange(4), 2.0, out)
    # 255 z / 2: 1 m -> 127.5 -> 128; 2 m -> 255; 3 m clipped; 0.5 -> 63.75 -> 64;
    # 0.003 -> 0.38 -> 0; 1.999 -> 254.87 -> 255; 0.99 -> 126.2 -> 126; invalid -> 255
    assert out.tolist() == [[[255, 128, 255, 255], [64, 0, 255, 126]]]
    # resampling picks the given rows and columns
    small = np.zeros((1, 1, 2), np.uint8)
    depth_image(depth, valid, np.array([1]), np.array([0, 3]), 2.0, small)
    assert small.tolist() == [[[64, 126]]]


def _episode(mode: str, seed: int, steps: int = 250):
    env = gym.make(SUDDEN, observation_mode=mode)
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    trace = [obs]
    for _ in range(steps):
        obs, r, term, trunc, info = env.step((0.03 * rng.standard_normal(15)).astype(np.float32))
        trace.append(obs)
        if term or trunc:
            break
    return trace, env.unwrapped


def test_default_mode_is_unchanged_and_depth_mode_only_adds_the_image():
    default, u = _episode("default", 2)
    depth, _ = _episode("depth", 2)
    assert "depth" not in u.observation_space.spaces and u.observation_mode == "default"
    assert len(default) == len(depth)
    for a, b in zip(default, depth, strict=True):
        assert set(b) == set(a) | {"depth"}
        assert all(np.array_equal(a[k], b[k]) for k in a)


def test_depth_only_skips_the_pipeline_on_the_same_task():
    default, _ = _episode("default", 5)
    only, u = _episode("depth_only", 5)
    depth, _ = _episode("depth", 5)
    assert set(only[0]) == set(default[0]) - PERCEPTION_KEYS | {"depth"}
    assert u.pipeline.n_steps == 0 and u.perception_time == 0.0
    # the same physics and the same block placement for the same actions
    assert len(only) == len(default)
    for a, b, c in zip(default, only, depth, strict=True):
        assert np.array_equal(a["joint_pos"], b["joint_pos"])
        assert np.array_equal(b["depth"], c["depth"])
    assert u.pool.blocks  # the sudden block appeared (over the effectivity's foothold)


def test_privileged_truth_in_depth_only():
    env = gym.make(SUDDEN, observation_mode="depth_only", privileged=True)
    obs, _ = env.reset(seed=0)
    assert "true_blocks" in obs and env.observation_space.contains(obs)


@pytest.mark.parametrize("bad", ["rgb", "Depth", None, ""])
def test_an_unknown_mode_is_refused(bad):
    with pytest.raises(ValueError, match="observation_mode must be one of"):
        gym.make(SUDDEN, observation_mode=bad)


def test_depth_only_refuses_the_graph_keys():
    with pytest.raises(ValueError, match="include_graph"):
        gym.make(STATIC, observation_mode="depth_only", include_graph=True)


def test_the_mode_survives_pickling():
    env = gym.make(STATIC, observation_mode="depth_only")
    copy = pickle.loads(pickle.dumps(env.unwrapped))
    assert copy.observation_mode == "depth_only"
    assert copy.observation_space == env.observation_space


def test_a_model_tells_the_bench_its_mode():
    from gymnasium import spaces

    from neurocog_gym.policies.sb3 import observation_mode_of

    for mode in ("default", "depth", "depth_only"):
        space = gym.make(SUDDEN, observation_mode=mode).observation_space
        assert observation_mode_of(space) == mode
    assert observation_mode_of(spaces.Box(-1, 1, (3,))) == "default"
