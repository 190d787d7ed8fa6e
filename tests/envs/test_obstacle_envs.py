import gymnasium as gym
import mujoco
import numpy as np
import pytest

import neurocog_gym  # noqa: F401
from neurocog_gym.perception.pipeline import PipelineParams
from neurocog_gym.robot.obstacles import Block

SUDDEN = "NeuroCog/SuddenObstacle-v3"
STATIC = "NeuroCog/StaticObstacle-v3"


def _walk_until(env, cond, max_steps=700):
    obs = None
    for _ in range(max_steps):
        obs, r, term, trunc, info = env.step(np.zeros(15, np.float32))
        if cond(info) or term or trunc:
            return obs, info, term, trunc
    return obs, info, term, trunc


def _blind_until_the_block(env, seed):
    """Zero actions (the blind policy) until the sudden block appears.

    Returns the last info, each front leg's last lift-off seen from the observation (its touch
    drops below ``touch_off`` while the CPG swings it) and the effectivity's predicted footholds
    of the cycle before the appearance ((4, 3), world) — what the policy saw.
    """
    u = env.unwrapped
    obs, _ = env.reset(seed=seed)
    off = u.effectivity.p.touch_off
    lift, was_down, foothold, info = {}, {0: True, 1: True}, None, {}
    for _ in range(700):
        foothold = u.eff.foothold.copy()
        obs, _, term, trunc, info = env.step(np.zeros(15, np.float32))
        for leg in (0, 1):
            down = obs["touch"][leg] > off
            if was_down[leg] and not down and u.generator.swinging[leg]:
                lift[leg] = u.data.time
            was_down[leg] = down
        if u.appeared_at is not None or term or trunc:
            break
    return info, lift, foothold


def test_sudden_obstacle_appears_a_tenth_of_a_second_into_a_front_swing():
    """§6.2: the block appears about 0.1 s after a front leg's swing starts: appear_delay after
    the lift-off, within one control cycle, with that foot still in the air."""
    env = gym.make(SUDDEN)
    u = env.unwrapped
    for seed in range(6):
        info, lift, _ = _blind_until_the_block(env, seed)
        assert u.appeared_at is not None and 1.0 <= u.appeared_at <= 2.5
        assert not u.appear_forced  # a real lift-off, well before the deadline
        leg = u.appear_leg
        assert leg in (0, 1) and leg in lift
        assert abs(u.appeared_at - lift[leg] - 0.1) <= 0.01 + 1e-9
        assert info["appear_swing_phase"] == pytest.approx(u.appeared_at - lift[leg], abs=1e-6)
        assert info["obstacles"] and 0.055 <= u.pool.boxes()[0, 1, 2] <= 0.085
        assert u.touch()[leg] <= u.effectivity.p.touch_off  # mid-swing: the foot is up
        assert u.data.site_xpos[u.robot.foot_site[leg], 2] > 0.02


def test_sudden_obstacle_covers_the_swing_legs_predicted_foothold():
    """The block lies over the effectivity's predicted foothold of the swinging leg (the one
    the policy observed): inside its footprint, or at most a sole radius before its near face,
    with the foot behind that face — an unchanged swing lands on it or runs into it."""
    env = gym.make(SUDDEN)
    u = env.unwrapped
    r = u.effectivity.p.foot_radius
    for seed in range(20, 30):
        _, _, foothold = _blind_until_the_block(env, seed)
        leg = u.appear_leg
        b = u.pool.blocks[0]
        c, s = np.cos(b.yaw), np.sin(b.yaw)

        def local(xy, b=b, c=c, s=s):  # world x, y -> the block's frame (x along its length)
            d = np.asarray(xy[:2]) - (b.x, b.y)
            return c * d[0] + s * d[1], -s * d[0] + c * d[1]

        along, across = local(foothold[leg])
        assert -b.length / 2 - r - 1e-9 <= along <= b.length / 2, (seed, along, b.length)
        assert abs(across) <= b.width / 2, (seed, across, b.width)
        np.testing.assert_allclose(u.appear_foothold, foothold[leg, :2])
        foot_along, _ = local(u.data.site_xpos[u.robot.foot_site[leg]])
        assert foot_along < -b.length / 2  # the foot is still behind the near face


def test_appear_delay_is_an_argument():
    """appear_delay 0 puts the block down at the lift-off itself; a bad value is refused; the
    value survives pickling (the vector envs' workers rebuild the env from it)."""
    import pickle

    env = gym.make(SUDDEN, appear_delay=0.0)
    info, lift, _ = _blind_until_the_block(env, 3)
    u = env.unwrapped
    assert u.appeared_at == pytest.approx(lift[u.appear_leg]) and info["appear_swing_phase"] == 0
    assert (
        pickle.loads(pickle.dumps(gym.make(SUDDEN, appear_delay=0.05).unwrapped)).appear_delay
        == 0.05
    )
    for bad in (-0.1, float("nan")):
        with pytest.raises(ValueError, match="appear_delay"):
            gym.make(SUDDEN, appear_delay=bad)


def test_sudden_obstacle_appears_by_the_deadline_without_a_lift_off():
    """An agent cannot keep the block away by never lifting a front foot (a PPO policy learned
    exactly that and walked 7 s without meeting a block): at ``appear_after + appear_deadline``
    it appears anyway, ahead of a front foot, flagged ``appear_forced``."""
    env = gym.make(SUDDEN, appear_deadline=0.5)
    u = env.unwrapped
    for seed in range(2):
        env.reset(seed=seed)
        u.touch = lambda: np.ones(4)  # every sole reads loaded: no lift-off is ever seen
        _, info, _, _ = _walk_until(env, lambda i: u.appeared_at is not None)
        assert u.appear_forced and info["appear_forced"]
        assert u.appear_after + 0.5 <= u.appeared_at <= u.appear_after + 0.6
        foot = u.data.site_xpos[u.robot.foot_site[u.appear_leg]]
        box = u.pool.boxes()[0]
        assert foot[0] - 0.02 < box[0, 0] < foot[0] + 0.25
    with pytest.raises(ValueError, match="appear_deadline"):
        gym.make(SUDDEN, appear_deadline=-1.0)


def test_sudden_obstacle_never_appears_inside_the_robot():
    """Placed by hand in front of the robot, not into it: at appearance every block keeps
    min_gap from every robot geom. (Without the placement check, 18 of the first 100 benchmark
    trials dropped a wide block onto the other front leg.)"""
    from neurocog_gym.bench.runner import trial_seed

    env = gym.make(SUDDEN)
    u = env.unwrapped
    gaps = []
    for i in range(30):
        env.reset(seed=trial_seed(0, "sudden", i))
        _walk_until(env, lambda info: u.appeared_at is not None)
        assert u.appeared_at is not None
        gaps.append(min(
            mujoco.mj_geomDistance(u.model, u.data, int(g), int(r), 1.0, None)
            for g in u.pool.geom_ids[: len(u.pool.blocks)] for r in u.robot.robot_geoms
        ))  # fmt: skip
    assert min(gaps) >= u.min_gap - 1e-9
    with pytest.raises(ValueError, match="min_gap"):
        gym.make(SUDDEN, min_gap=-0.01)


def test_static_obstacles_lie_ahead_across_the_path():
    env = gym.make(STATIC)
    env.reset(seed=0)
    boxes = env.unwrapped.pool.boxes()
    assert 1 <= len(boxes) <= 3
    assert np.all(boxes[:, 0, 0] > 0.8)
    assert np.all(np.abs(boxes[:, :, 1].mean(axis=1)) < 0.2)


def test_outcome_touch_then_pass():
    env = gym.make(STATIC, n_blocks=(1, 1))
    env.reset(seed=0)
    u = env.unwrapped
    # Stage it: a low block right under the front-left foot's path, then teleport past it.
    foot = u.data.site_xpos[u.robot.foot_site[0]].copy()
    u.pool.place(u.model, u.data, [Block(foot[0] + 0.06, foot[1], 0.06, 0.06, 0.06)])
    obs, info, term, trunc = _walk_until(env, lambda i: i["touched"], 200)
    assert info["touched"] and info["touch_events"] >= 1
    u.data.qpos[0] += 1.0
    mujoco.mj_forward(u.model, u.data)
    obs, r, term, trunc, info = env.step(np.zeros(15, np.float32))
    assert info["passed"] and term
    assert info["outcome"] == "touch"


def test_outcome_success_when_passed_without_contact():
    env = gym.make(STATIC, n_blocks=(1, 1))
    env.reset(seed=0)
    u = env.unwrapped
    u.data.qpos[0] = u.pool.boxes()[0, 1, 0] + 0.5  # already past, never touched
    mujoco.mj_forward(u.model, u.data)
    _, _, term, _, info = env.step(np.zeros(15, np.float32))
    assert term and info["outcome"] == "success" and not info["touched"]


def test_outcome_fail_on_fall():
    env = gym.make(STATIC)
    env.reset(seed=0)
    u = env.unwrapped
    u.data.qpos[3:7] = (0.0, 1.0, 0.0, 0.0)  # upside down
    mujoco.mj_forward(u.model, u.data)
    _, _, term, _, info = env.step(np.zeros(15, np.float32))
    assert term and info["fell"] and info["outcome"] == "fail"


def test_timeout_is_a_fail():
    env = gym.make(STATIC, max_episode_steps=20)
    env.reset(seed=0)
    info = {}
    for _ in range(20):
        *_, term, trunc, info = env.step(np.zeros(15, np.float32))
    assert trunc and info["outcome"] == "fail" and not info["passed"]


def test_attention_off_uses_plain_gng():
    env = gym.make(SUDDEN, perception=PipelineParams(gng="gng"))
    env.reset(seed=0)
    assert type(env.unwrapped.pipeline.net).__name__ == "GNG"


@pytest.mark.parametrize("noise", [0.0, 0.01])
def test_env_pipeline_drops_the_raw_point_additions_it_never_reads(noise):
    from neurocog_gym.robot.tof import ToFParams

    tof = ToFParams(backend="numba", noise_std_rel=noise)
    given = PipelineParams(gng="gng", refine_noise=True, view_wall_width=0.3)
    env = gym.make("NeuroCog/StaticObstacle-v3", tof=tof, perception=given)
    p = env.unwrapped.pipeline.params
    assert p.view_wall_width == 0.0  # no walls in the scene; wall labels reach nothing
    assert p.refine_noise is (noise > 0)  # a noise-free frame has no noise to take out
    assert p.gng == "gng"  # the rest as given
    env.close()


def test_env_frame_is_the_latest_and_read_only():
    env = gym.make(SUDDEN)
    env.reset(seed=0)
    u = env.unwrapped
    first = u.frame
    with pytest.raises(ValueError):
        first.points[0, 0] = 1.0  # the sensor's buffer: read-only for the env's users
    for _ in range(5):  # 45 fps against 100 Hz cycles: a new frame within 3 cycles
        env.step(np.zeros(15, np.float32))
    assert u.frame is not first and u.frame.time > first.time
    # The older frame's arrays view the same buffers: documented, copy a frame to keep it.
    assert np.shares_memory(first.points, u.frame.points)
    env.close()


def test_graph_in_observation_behind_a_flag():
    env = gym.make(SUDDEN, include_graph=True, graph_max_nodes=256, graph_max_edges=1024)
    obs, _ = env.reset(seed=0)
    n, m = obs["graph_counts"]
    # 1-D keys, row-major: node i is graph_nodes[3 i : 3 i + 3], edge j graph_edges[2 j : 2 j + 2]
    assert 0 < n <= 256 and obs["graph_nodes"].shape == (256 * 3,)
    assert obs["graph_edges"].shape == (1024 * 2,)
    nodes, edges = obs["graph_nodes"].reshape(-1, 3), obs["graph_edges"].reshape(-1, 2)
    g = env.unwrapped.pipeline.net.padded(256, 1024)  # the (rows, 3) and (rows, 2) tables
    np.testing.assert_array_equal(nodes, g.nodes.astype(np.float32))
    np.testing.assert_array_equal(edges, g.edges)
    assert np.all(nodes[n:] == 0)
    assert np.all(edges[:m] < n) and np.all(edges[:m] >= 0) and np.all(edges[m:] == -1)
    assert "graph_nodes" not in gym.make(SUDDEN).reset(seed=0)[0]


def test_perception_sees_a_placed_block():
    env = gym.make(STATIC, n_blocks=(1, 1), first_distance=(0.25, 0.3))
    env.reset(seed=1)
    u = env.unwrapped
    for _ in range(30):
        env.step(np.zeros(15, np.float32))
    box = u.pool.boxes()[0]
    pts = u.frame.points
    inside = np.all((pts >= box[0] - 0.01) & (pts <= box[1] + 0.01), axis=1)
    assert inside.sum() > 20
    assert pts[inside, 2].max() == pytest.approx(box[1, 2], abs=0.01)


def _terms_add_up(r, info):
    parts = ("reward_tracking", "reward_energy", "reward_touch", "reward_pass")
    return r == pytest.approx(sum(info[k] for k in parts))


@pytest.mark.parametrize("cost", [1.0, 50.0])
def test_reward_touch_penalty_once_per_contact_then_pass_bonus(cost):
    """-touch_cost on the cycle a new contact begins (not while it lasts), +100 on passing."""
    env = gym.make(STATIC, n_blocks=(1, 1), touch_cost=cost)
    env.reset(seed=0)
    u = env.unwrapped
    foot = u.data.site_xpos[u.robot.foot_site[0]].copy()
    u.pool.place(u.model, u.data, [Block(foot[0] + 0.06, foot[1], 0.06, 0.06, 0.06)])
    touches = []
    for _ in range(200):
        _, r, term, trunc, info = env.step(np.zeros(15, np.float32))
        assert _terms_add_up(r, info) and info["reward_pass"] == 0.0 and not term
        touches.append(info["reward_touch"])
        if info["touch_events"] >= 1 and not u._was_touching:
            break  # the first contact has ended
    assert info["touch_events"] >= 1 and touches.count(-cost) == info["touch_events"]
    assert set(touches) <= {0.0, -cost}
    u.data.qpos[0] += 1.0
    mujoco.mj_forward(u.model, u.data)
    _, r, term, _, info = env.step(np.zeros(15, np.float32))
    assert term and info["passed"] and info["reward_pass"] == 100.0 and _terms_add_up(r, info)


def test_sudden_pass_bonus_outweighs_walking_on():
    """Passing ends the episode: its bonus is at least the discounted (0.99) value of walking on
    at the best per-step reward (1), so passing is never worth less than not passing."""
    env = gym.make(SUDDEN)
    env.reset(seed=0)
    u = env.unwrapped
    _, info, term, _ = _walk_until(env, lambda i: u.appeared_at is not None)
    assert not term and info["reward_pass"] == 0.0
    u.data.qpos[0] = u.pool.boxes()[:, 1, 0].max() + 0.5
    mujoco.mj_forward(u.model, u.data)
    _, r, term, _, info = env.step(np.zeros(15, np.float32))
    assert term and info["passed"] and _terms_add_up(r, info)
    assert info["reward_tracking"] <= 1.0
    assert info["reward_pass"] >= 1.0 / (1.0 - 0.99)


def test_touch_cost_is_checked_and_survives_pickling():
    import pickle

    for bad in (-1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="touch_cost"):
            gym.make(SUDDEN, touch_cost=bad)
    for env_id in (SUDDEN, STATIC):
        env = gym.make(env_id, touch_cost=20.0)
        assert pickle.loads(pickle.dumps(env)).unwrapped.touch_cost == 20.0


def _documented_keys(envs: set[str]) -> set[str]:
    """The keys of docs/environments.md's observation table whose envs cell is in ``envs``."""
    from pathlib import Path

    text = (Path(__file__).parents[2] / "docs" / "environments.md").read_text()
    table = text.split("## Observation", 1)[1].split("\n## ", 1)[0]
    keys = set()
    for line in table.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("| `") and cells[-1] in envs:
            keys |= {k.strip(" `") for k in cells[0].split(",")}
    return keys


@pytest.mark.parametrize("env_id", [SUDDEN, STATIC])
def test_the_observation_is_perception_and_body_never_a_decision(env_id):
    from gymnasium import spaces

    env = gym.make(env_id)
    keys = set(env.observation_space.spaces)
    # Exactly the documented keys: a new key is a documented one; the fit's mode (once
    # ``aef_mode``, a Discrete key) and its teacher's state are the policy's, not observed.
    assert keys == _documented_keys({"all", "obstacle"})
    assert not keys & {"aef_mode", "mode", "avoid_state"}
    assert all(isinstance(s, spaces.Box | spaces.MultiBinary) and len(s.shape) == 1
               for s in env.observation_space.spaces.values())  # fmt: skip
    # The env holds no decision to hide: the effectivity predicts, nothing in it chooses.
    assert not hasattr(env.unwrapped.effectivity, "avoidance")
    assert (
        "aef_mode" not in env.reset(seed=0)[1]
        and "aef_mode" not in env.step(np.zeros(15, np.float32))[4]
    )
    assert set(gym.make(env_id, privileged=True).observation_space.spaces) == keys | {"true_blocks"}


def test_remembered_blocks_decode_to_the_memory_and_outlive_the_view():
    from neurocog_gym.policies.aef import boxes_in_frame, to_frame

    env = gym.make(STATIC, n_blocks=(1, 1), first_distance=(0.25, 0.3))
    obs, _ = env.reset(seed=1)
    u = env.unwrapped
    remembered_unseen = met = 0
    for _ in range(250):
        obs, _, term, trunc, _ = env.step(np.zeros(15, np.float32))
        if term or trunc:
            break
        torso, yaw = u.data.xpos[u.robot.torso_body], u._yaw()
        memory = u.effectivity.memory
        # Decoded with the true torso pose, the rows give the memory's world boxes back.
        boxes = boxes_in_frame(obs["remembered_blocks"], yaw, torso[:2])
        assert len(boxes) == len(memory)
        np.testing.assert_allclose(boxes[:, :, :2], memory[:, :, :2], rtol=0, atol=2e-5)
        np.testing.assert_allclose(boxes[:, 1, 2], memory[:, 1, 2], rtol=0, atol=1e-6)
        feet = to_frame(obs["feet"].reshape(4, 3), yaw, torso[:2])
        np.testing.assert_allclose(feet, u._feet(), rtol=0, atol=2e-5)
        joints = to_frame(obs["leg_joints"].reshape(12, 3), yaw, torso[:2]).reshape(4, 3, 3)
        np.testing.assert_allclose(joints[:, 2], u.data.xpos[u.robot.shank_body], atol=2e-5)
        # Which block each leg meets, and the path flag, are the effectivity's.
        hit = u.eff.hit
        np.testing.assert_array_equal(obs["block_met"], np.where(hit >= 0, hit, -1))
        np.testing.assert_array_equal(obs["path_meets_block"], ~u.eff.path_safe)
        np.testing.assert_array_equal(obs["interrupt_direction"], obs["aef_input"][3:15])
        met += int((hit >= 0).any())
        remembered_unseen += int(len(memory) > 0 and not obs["objects_mask"].any())
    # The block was met by a leg, and remembered while the sensors did not report it.
    assert met > 0 and remembered_unseen > 0


def test_more_remembered_boxes_than_slots_keeps_the_nearest_in_memory_order():
    from neurocog_gym.envs.obstacle import MEMORY_SLOTS

    env = gym.make(STATIC)
    env.reset(seed=0)
    u = env.unwrapped
    torso = u.data.xpos[u.robot.torso_body].copy()
    eff = u.effectivity
    # Ten boxes, memory order 0..9, at distances 1.0, 0.1, 0.9, 0.2, ... from the torso.
    far = [1.0, 0.1, 0.9, 0.2, 0.8, 0.3, 0.7, 0.4, 0.6, 0.5]
    for m, dx in enumerate(far):
        c = torso[:2] + [dx, 0.0]
        eff._memory[m] = [[c[0] - 0.01, c[1] - 0.05, 0.0], [c[0] + 0.01, c[1] + 0.05, 0.07]]
    eff._n_memory = len(far)
    rows = u._get_obs()["remembered_blocks"].reshape(MEMORY_SLOTS, 7)
    # The two farthest (1.0 and 0.9: memory 0 and 2) are left out; the rest keep their order,
    # as offsets from the torso in its yaw frame.
    yaw = u._yaw()
    kept = [0.1, 0.2, 0.8, 0.3, 0.7, 0.4, 0.6, 0.5]
    assert MEMORY_SLOTS == 8
    np.testing.assert_allclose(rows[:, 1], np.array(kept) * np.cos(yaw), atol=1e-6)
    np.testing.assert_allclose(rows[:, 2], -np.array(kept) * np.sin(yaw), atol=1e-6)
    assert (rows[:, 0] == 1).all() and np.allclose(rows[:, 4:7], [0.01, 0.05, 0.07])
