"""Outcome v1 of the obstacle envs (neurocog_gym/envs/obstacle.py) on real MuJoCo contacts.

The scenes are staged on the physics directly (mj_step, then the env's per-cycle check), so the
tests hold whatever gait the CPG walks and need no exact body dimensions.
"""

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import neurocog_gym  # noqa: F401
from neurocog_gym.envs.obstacle import OutcomeParams
from neurocog_gym.robot.obstacles import Block

STATIC = "NeuroCog/StaticObstacle-v3"
SUDDEN = "NeuroCog/SuddenObstacle-v3"


@pytest.fixture(scope="module")
def env():
    e = gym.make(STATIC, n_blocks=(1, 1))
    yield e
    e.close()


def _standing(env, lift=0.0):
    """The robot at its home pose (lifted by ``lift`` m), servos holding it; no blocks."""
    u = env.unwrapped
    env.reset(seed=0)
    mujoco.mj_resetDataKeyframe(u.model, u.data, 0)
    u.data.qpos[2] += lift
    u.pool.place(u.model, u.data, [])
    u._reset_outcome()
    mujoco.mj_forward(u.model, u.data)
    return u


def _cycles(u, n):
    for _ in range(n):
        mujoco.mj_step(u.model, u.data, nstep=u.frame_skip)
        u.touched |= u._check_blocks(u._yaw())  # the contact part of _after_physics


def test_stood_on_when_a_foot_rests_on_a_block(env):
    u = _standing(env, lift=0.08)
    foot = u.data.site_xpos[u.robot.foot_site[0]].copy()
    u.pool.place(u.model, u.data, [Block(foot[0], foot[1], 0.1, 0.1, 0.06)])
    _cycles(u, 100)
    assert u.data.site_xpos[u.robot.foot_site[0], 2] > 0.05  # on top of it
    out = u._outcome(fell=False, unstable=False)
    assert out["touched"] and out["stood_on"] and out["obstacles"][0]["stood_on"]
    assert out["outcome"] == "fail"


def test_a_side_push_is_a_touch_not_standing(env):
    u = _standing(env)
    _cycles(u, 30)  # settle on the floor
    foot = u.data.site_xpos[u.robot.foot_site[0]].copy()
    b = Block(foot[0] + 0.08, foot[1], 0.1, 0.1, 0.07)
    u.pool.place(u.model, u.data, [b])
    body = u.pool.bodies[0]
    touched = False
    for _ in range(40):  # push it gently against the front-left foot
        u.data.xfrc_applied[body, 0] = -8.0
        _cycles(u, 1)
        touched |= bool(u._blk_touch[0])
    u.data.xfrc_applied[body] = 0.0
    out = u._outcome(fell=False, unstable=False)
    assert touched and out["touched"] and not out["stood_on"]


def test_a_pushed_block_is_knocked_and_fails_the_trial(env):
    u = _standing(env)
    u.pool.place(u.model, u.data, [Block(1.5, 0.0, 0.1, 0.2, 0.07)])
    _cycles(u, 10)
    assert not u.knocked
    u.data.xfrc_applied[u.pool.bodies[0], 1] = 15.0  # sideways, away from the robot
    _cycles(u, 20)
    u.data.xfrc_applied[u.pool.bodies[0]] = 0.0
    out = u._outcome(fell=False, unstable=False)
    assert out["knocked"] and not out["touched"] and out["outcome"] == "fail"
    assert out["obstacles"][0]["moved"] > 0.02


def test_a_resting_block_is_not_knocked_by_settling(env):
    u = _standing(env)
    u.pool.place(u.model, u.data, [Block(1.5, 0.05, 0.12, 0.3, 0.085, 0.3)])
    _cycles(u, 200)  # 2 s
    out = u._outcome(fell=False, unstable=False)
    assert not out["knocked"] and not out["touched"]
    assert out["obstacles"][0]["moved"] < 1e-3 and out["obstacles"][0]["turned_deg"] < 0.5


def test_thresholds_are_parameters():
    e = gym.make(STATIC, outcome=OutcomeParams(knock_shift=0.05, knock_turn_deg=20.0))
    assert e.unwrapped.outcome_params.knock_shift == 0.05
    with pytest.raises(ValueError, match="knock_shift"):
        OutcomeParams(knock_shift=-1.0)
    with pytest.raises(ValueError, match="stand_cycles"):
        OutcomeParams(stand_cycles=0)


def test_info_counts_action_groups_and_times_the_pass(env):
    u = env.unwrapped
    env.reset(seed=1)
    a = np.zeros(15, np.float32)
    _, _, _, _, info = env.step(a)
    for key in ("outcome", "passed", "touched", "knocked", "stood_on", "touch_events", "fell",
                "obstacles", "stepped_over", "interrupt_cycles", "provision_cycles",
                "time_to_pass_from_appear"):  # fmt: skip
        assert key in info, key
    assert info["interrupt_cycles"] == 0 and info["provision_cycles"] == 0
    a[3] = 0.5
    env.step(a)
    a[:] = 0
    a[13] = -1e-3
    env.step(a)
    a[0] = a[14] = 2.0  # clipped to 1, still non-zero
    _, _, _, _, info = env.step(a)
    assert info["interrupt_cycles"] == 2 and info["provision_cycles"] == 2
    assert "pos" in info["obstacles"][0] and "feet_over" in info["obstacles"][0]
    # A block behind the robot: passed at the next cycle, 0.05 s after t = 0 (static).
    u.pool.place(u.model, u.data, [Block(-0.6, 0.0, 0.1, 0.1, 0.07)])
    _, _, term, _, info = env.step(np.zeros(15, np.float32))
    assert term and info["passed"] and info["outcome"] == "success"
    assert info["time_to_pass_from_appear"] == pytest.approx(u.data.time, abs=1e-9)
    assert not info["stepped_over"] and not info["obstacles"][0]["stepped_over"]


def test_sudden_time_to_pass_counts_from_the_appearance():
    e = gym.make(SUDDEN)
    u = e.unwrapped
    e.reset(seed=0)
    u.appeared_at = 0.02  # as if the block had appeared then
    u.pool.place(u.model, u.data, [Block(-0.6, 0.0, 0.1, 0.1, 0.07)])
    e.step(np.zeros(15, np.float32))
    _, _, term, _, info = e.step(np.zeros(15, np.float32))
    assert info["passed"]
    assert info["time_to_pass_from_appear"] == pytest.approx(u.passed_at - 0.02, abs=1e-9)
    e.close()
