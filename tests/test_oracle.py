"""The privileged step-over oracle (neurocog_gym/oracle.py): what it reads, what it returns."""

import gymnasium as gym
import numpy as np
import pytest

import neurocog_gym  # noqa: F401
from neurocog_gym.oracle import OraclePolicy
from neurocog_gym.policies import make_policy


def test_make_policy_oracle_is_the_privileged_oracle():
    policy = make_policy("oracle")
    assert isinstance(policy, OraclePolicy) and policy.needs_privileged


def test_oracle_refuses_an_observation_without_the_privileged_keys():
    env = gym.make("NeuroCog/StaticObstacle-v1")
    obs, _ = env.reset(seed=0)
    with pytest.raises(KeyError, match="privileged=True"):
        OraclePolicy()(obs)
    env.close()


def test_inverse_kinematics_inverts_the_leg():
    policy = OraclePolicy()
    l1, l2 = policy.l1, policy.l2
    for hip, knee in [(-0.8, 1.6), (-1.2, 2.3), (-0.5, 0.9), (-1.6, 1.9)]:
        # Foot centre from the hip joint, sagittal plane (x ahead, z up), as the body is built.
        x = -l1 * np.sin(hip) - l2 * np.sin(hip + knee)
        z = -l1 * np.cos(hip) - l2 * np.cos(hip + knee)
        assert np.allclose(policy._ik(x, z), (hip, knee), atol=1e-9)


def test_true_blocks_observation_gives_the_placed_blocks():
    env = gym.make("NeuroCog/StaticObstacle-v1", privileged=True)
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
    env = gym.make("NeuroCog/SuddenObstacle-v1", privileged=True)
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
