"""The privileged step-over oracle (neurocog_gym/policies/oracle.py): what it reads and returns."""

import gymnasium as gym
import numpy as np
import pytest

import neurocog_gym  # noqa: F401
from neurocog_gym.policies import make_policy
from neurocog_gym.policies.oracle import OraclePolicy


def test_make_policy_oracle_is_the_privileged_oracle():
    policy = make_policy("oracle")
    assert isinstance(policy, OraclePolicy) and policy.needs_privileged


def test_oracle_refuses_an_observation_without_the_privileged_keys():
    env = gym.make("NeuroCog/StaticObstacle-v3")
    obs, _ = env.reset(seed=0)
    with pytest.raises(KeyError, match="privileged=True"):
        OraclePolicy()(obs)
    env.close()


def _cpg(swinging):
    """A ``cpg`` observation whose knee flexor dominates on the legs in ``swinging``."""
    y = np.zeros((4, 6), np.float32)
    for leg in range(4):
        y[leg, 2 if leg in swinging else 3] = 1.0
    return y.ravel()


def _staged_block_ahead_of_fl():
    # One block 10 cm long, its near face 4 cm ahead of the FL sole, top 7 cm; the FL foot has
    # just lifted (touch 0), its pair partner FR stands; the predicted foothold lies on the block.
    blocks = np.zeros((4, 7), np.float32)
    blocks[0] = (1.0, 0.30, 0.12, 0.0, 0.05, 0.10, 0.07)
    feet = np.array([[0.232, 0.12, 0.02], [0.2, -0.12, 0.018], [-0.2, 0.12, 0.018],
                     [-0.2, -0.12, 0.018]], np.float32)  # fmt: skip
    foothold = feet.copy()
    foothold[0, 0] = 0.33
    return {"true_blocks": blocks.ravel(), "feet": feet.ravel(), "foothold": foothold.ravel(),
            "touch": np.array([0.0, 1.0, 1.0, 0.0], np.float32), "cpg": _cpg({0, 3})}  # fmt: skip


def test_a_swing_that_meets_a_block_from_its_cpg_swing_onset_lifts_that_foot():
    policy = OraclePolicy()
    obs = _staged_block_ahead_of_fl()
    a = policy(obs)
    assert policy.state[0] == 1  # LIFT
    assert a[2] == 1.0 and a[1] == pytest.approx(policy.p.lift_hip)  # knee folds, hip back a bit
    assert np.all(a[3:] == 0.0)
    # The same swing 0.1 s after its CPG onset (not fresh): it cannot be carried over, so it
    # approaches (and drops before the near face).
    policy.reset()
    policy.swing_t[0] = 0.1
    a = policy(obs)
    assert policy.state[0] == 4  # APPROACH: no interrupt until the sole is near the face


def test_a_block_met_in_the_second_half_of_a_swing_is_answered():
    # Late in the swing the CPG's knee extends again (its extensor leads) while the hip still
    # protracts: the swing is on, and a block in its path makes the foot approach and drop.
    policy = OraclePolicy()
    obs = _staged_block_ahead_of_fl()
    y = np.zeros((4, 6), np.float32)
    y[:, 1] = y[:, 3] = 1.0  # every leg: hip and knee extensors lead (stance) ...
    y[0, 0], y[0, 1] = 1.0, 0.0  # ... but FL's hip flexor leads: FL protracts, its knee extends
    obs["cpg"] = y.ravel()
    policy.swing_t[0] = 0.1  # 0.1 s into the swing: not fresh
    policy(obs)
    assert policy.state[0] == 4  # APPROACH


def test_a_foot_the_cpg_holds_in_stance_is_never_lifted():
    # The same block and foot, but the CPG has FL in stance (the foot only lost its load):
    # lifting it would take a support leg away (docs/oracle_notes.md), so nothing acts.
    policy = OraclePolicy()
    obs = _staged_block_ahead_of_fl()
    obs["cpg"] = _cpg({1, 2})
    a = policy(obs)
    assert policy.state[0] == 0 and np.all(a == 0.0)


def test_a_step_over_past_the_cpg_swing_holds_the_legs_the_cpg_would_lift():
    policy = OraclePolicy()
    obs = _staged_block_ahead_of_fl()
    policy(obs)
    assert policy.state[0] == 1
    # The CPG moves on: FL and HR to stance, FR and HL to swing, while FL is still lifting.
    obs["cpg"] = _cpg({1, 2})
    a = policy(obs)
    assert policy.state[0] == 1
    p = policy.p
    for leg in (1, 2):  # FR and HL: held down
        assert a[3 * leg + 1] == pytest.approx(p.hold_hip)
        assert a[3 * leg + 2] == pytest.approx(p.hold_knee)
    assert np.all(a[9:12] == 0.0)  # HR: the CPG keeps it in stance anyway


def test_true_blocks_observation_gives_the_placed_blocks():
    env = gym.make("NeuroCog/StaticObstacle-v3", privileged=True)
    obs, _ = env.reset(seed=3)
    u = env.unwrapped
    tb = obs["true_blocks"].reshape(-1, 7)
    blocks = u.pool.blocks
    assert tb[: len(blocks), 0].tolist() == [1.0] * len(blocks)
    assert (tb[len(blocks) :, 0] == 0).all()
    torso = u.data.xpos[u.robot.torso_body]
    yaw = u._yaw()
    for row, b in zip(tb, blocks, strict=False):
        dx, dy = b.x - torso[0], b.y - torso[1]
        ahead = np.cos(yaw) * dx + np.sin(yaw) * dy
        assert row[1] == pytest.approx(ahead, abs=1e-4)
        assert row[4] == pytest.approx(b.length / 2, abs=1e-6)
        assert row[6] == pytest.approx(b.height, abs=1e-3)
    assert obs["feet"].shape == (12,)
    assert env.observation_space.contains(obs)
    env.close()


def test_oracle_acts_only_on_the_interrupt_and_sagittal_entries_within_bounds():
    env = gym.make("NeuroCog/SuddenObstacle-v3", privileged=True)
    obs, _ = env.reset(seed=1)
    policy = make_policy("oracle")
    policy.reset()
    acted = False
    for _ in range(400):
        a = policy(obs)
        assert a.shape == (15,) and np.all(np.abs(a) <= 1.0)
        assert np.all(a[13:] == 0.0)
        acted |= bool(np.any(a[:12] != 0.0))
        obs, _, term, trunc, _ = env.step(a)
        if term or trunc:
            break
    assert acted  # the sudden block came within a swing's reach
    env.close()
