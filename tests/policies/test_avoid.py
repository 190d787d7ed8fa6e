"""The avoid reflex (neurocog_gym/policies/avoid.py): clean passes where the blind CPG stumbles,
the AEF's provision elsewhere, and a clear error when it is not bound to an obstacle env."""

import gymnasium as gym
import numpy as np
import pytest

import neurocog_gym  # noqa: F401
from neurocog_gym.bench.runner import TrialSpec, make_env, run_trial, trial_seed
from neurocog_gym.policies import make_policy


def _trial(scenario: str, index: int, policy: str) -> dict:
    env = make_env(scenario, "on", None)
    spec = TrialSpec(scenario=scenario, index=index, seed=trial_seed(0, scenario, index))
    try:
        return run_trial(env, make_policy(policy), spec)
    finally:
        env.close()


# The reflex was tuned on body v0 (52b50df:docs/avoid_notes.md): on body v1 it falls in all of the
# first 16 sudden trials, about 0.5 s after the block appears. Kept as a strict xfail so that the
# record stays honest until issue 22 replaces the reflex (or it is retuned): an unexpected pass
# fails.
@pytest.mark.xfail(strict=True, reason="avoid reflex tuned for body v0; it falls on body v1")
@pytest.mark.parametrize("index", [1, 2])
def test_sudden_block_passed_without_contact_where_the_blind_cpg_hits_it(index):
    blind = _trial("sudden", index, "blind")
    avoid = _trial("sudden", index, "avoid")
    assert blind["touched"] or blind["outcome"] == "fail"
    assert avoid["outcome"] == "success" and avoid["contacts"]["steps"] == 0


def test_far_blocks_are_left_to_the_aef_provision():
    """Static blocks are seen from afar: the reflex never engages and the episode is the
    aef-provision one, step for step."""
    a = _trial("static", 0, "avoid")
    b = _trial("static", 0, "aef-provision")
    assert (a["outcome"], a["steps"], a["distance"]) == (b["outcome"], b["steps"], b["distance"])


def test_the_policy_must_be_bound_to_an_obstacle_env():
    policy = make_policy("avoid")
    env = gym.make("NeuroCog/SuddenObstacle-v1")
    obs, _ = env.reset(seed=0)
    with pytest.raises(RuntimeError, match=r"call policy.reset\(env\)"):
        policy(obs)
    policy.reset(env)
    action = policy(obs)
    assert action.shape == (15,) and action.dtype == np.float32
    with pytest.raises(ValueError, match="needs an obstacle env"):
        policy.reset(gym.make("NeuroCog/Walk-v1"))


def test_leg_gap_reaches_from_the_sole_up_to_the_knee():
    """A leg's front point at a block's height: the sole's front below the shank, the knee (or
    the thigh) once the block's top is above them."""
    from neurocog_gym.policies.avoid import FOOT_RADIUS, AvoidPolicy

    env = make_env("sudden", "on", None)
    try:
        env.reset(seed=trial_seed(0, "sudden", 0))
        policy = AvoidPolicy()
        policy.reset(env)
        u = env.unwrapped
        feet = u._feet()
        knees = u.data.xpos[u.robot.hip_body + 2]
        low = policy._reach(feet, 0.0)
        high = policy._reach(feet, 1.0)
        np.testing.assert_allclose(low, feet[:, 0] + FOOT_RADIUS)
        assert np.all(high >= low) and np.all(high >= knees[:, 0])
        assert np.all(np.diff([policy._reach(feet, z) for z in (0.0, 0.05, 0.1, 0.2)], axis=0) >= 0)
    finally:
        env.close()
