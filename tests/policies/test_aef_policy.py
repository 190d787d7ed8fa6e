"""AEFPolicy (policies/aef.py): the decision from the observation alone, on staged observations."""

import gymnasium as gym
import numpy as np
import pytest

import neurocog_gym  # noqa: F401  (registers the ids)
from neurocog_gym.locomotion.fit import MODE_INTERRUPT, MODE_NONE, MODE_PROVISION
from neurocog_gym.policies import AEFPolicy, BlindPolicy, make_policy, start_episode
from neurocog_gym.policies.aef import Odometry, boxes_in_frame
from tests.policies.stance import FEET, HIPS, KNEES, THIGHS  # a standing robot

FL = 0


def block(x0, x1, y0, y1, top):
    """A ``remembered_blocks`` row of an axis-aligned box (heading along +x)."""
    return [1.0, (x0 + x1) / 2, (y0 + y1) / 2, 0.0, (x1 - x0) / 2, (y1 - y0) / 2, top]


def staged(blocks=(), v_fl=None, met_fl=-1):
    """An obstacle-env observation by hand: the stance above, ``blocks`` remembered, FL's
    interrupt direction ``v_fl`` and the block its swing meets."""
    rows = np.zeros((8, 7), np.float32)
    rows[: len(blocks)] = np.reshape(blocks, (-1, 7))
    v = np.zeros((4, 3), np.float32)
    if v_fl is not None:
        v[FL] = v_fl
    met = np.full(4, -1.0, np.float32)
    met[FL] = met_fl
    aef = np.zeros(31, np.float32)
    aef[3:15] = v.ravel()
    aef[27:31] = (0.0, 1.0, 1.0, 0.0)  # FL and HR swing
    return {
        "torso_quat": np.array([1.0, 0.0, 0.0, 0.0], np.float32),
        "torso_lin_vel": np.zeros(3, np.float32),
        "aef_input": aef,
        "interrupt_direction": v.ravel(),
        "block_met": met,
        "remembered_blocks": rows.ravel(),
        "feet": FEET.astype(np.float32).ravel(),
        "leg_joints": np.stack([HIPS, THIGHS, KNEES], 1).astype(np.float32).ravel(),
    }


UP = (-0.5, 0.0, 0.8)  # the effectivity's "up" for a swinging foot


def test_nothing_remembered_gives_zeros():
    for policy in (make_policy("aef"), make_policy("aef-provision")):
        assert not policy(staged()).any() and policy.mode == MODE_NONE
    assert not BlindPolicy()(staged()).any()


def test_a_low_block_in_fls_path_interrupts_fl_only():
    # 1.5 cm: below the teacher's 2 cm and a swing's 4 cm clearance, so FL's swing is changed.
    obs = staged([block(0.28, 0.34, 0.0, 0.25, 0.015)], v_fl=UP, met_fl=0)
    policy = AEFPolicy()
    a = policy(obs)
    assert policy.mode == MODE_INTERRUPT
    assert np.any(a[0:3] != 0) and not a[3:].any()  # FL's joints; no other leg, no provision
    # The same observation with the interrupt group off: nothing acts.
    ablation = make_policy("aef-provision")
    assert not ablation(obs).any() and ablation.mode == MODE_INTERRUPT


def test_a_block_that_appears_in_fls_path_stops_the_trot():
    # 7 cm, 9 cm ahead of the feet, in FL's lane: taller than a swing clears and within reach,
    # so the provision stops the trot (s_SAG towards -1) instead of interrupting the swing.
    obs = staged([block(0.28, 0.36, 0.0, 0.25, 0.07)], v_fl=UP, met_fl=0)
    for name in ("aef", "aef-provision"):
        policy = make_policy(name)
        a = policy(obs)
        assert policy.mode == MODE_PROVISION
        assert policy.decision.provision.tolist() == [-1.0, 0.0, 0.0]
        assert not a[:12].any() and a[12] < -0.5


@pytest.mark.parametrize(("y0", "y1", "sign"), [(0.05, 0.25, -1.0), (-0.25, -0.05, 1.0)])
def test_a_block_far_ahead_is_walked_round(y0, y1, sign):
    # 0.6 m ahead, half across the corridor: provision only, the side step away from it.
    obs = staged([block(0.8, 0.9, y0, y1, 0.07)])
    policy = AEFPolicy()
    a = policy(obs)
    assert policy.mode == MODE_PROVISION and not a[:12].any()
    assert np.sign(policy.decision.provision[1]) == sign and sign * a[13] > 0.3


def test_the_decision_state_lasts_the_episode_and_reset_forgets_it():
    policy = AEFPolicy()
    policy(staged([block(0.28, 0.36, 0.0, 0.25, 0.07)], v_fl=UP, met_fl=0))  # the stop
    # The block is gone from the observation, but the back-off lasts at least t_rev.
    assert policy(staged()).any() and policy.mode == MODE_PROVISION
    start_episode(policy, env=None)
    assert not policy(staged()).any() and policy.mode == MODE_NONE


def test_odometry_integrates_the_torso_velocity_in_the_world():
    odo = Odometry()
    half = np.sqrt(0.5)
    quat = np.array([half, 0.0, 0.0, half])  # turned 90 degrees left
    for _ in range(11):
        yaw, pos = odo.update(quat, np.array([0.5, 0.0, 0.0]), 0.01)
    # 10 steps of 0.01 s at 0.5 m/s along the torso's x, which is world +y.
    assert yaw == pytest.approx(np.pi / 2)
    np.testing.assert_allclose(pos, [0.0, 0.05], rtol=0, atol=1e-12)


def test_remembered_rows_decode_to_world_boxes():
    # Heading 30 degrees left; a world box x 1..1.2, y 0..0.4 with the torso at (0.5, 0.1).
    yaw, torso = np.pi / 6, np.array([0.5, 0.1])
    c, s = np.cos(yaw), np.sin(yaw)
    centre = np.array([1.1, 0.2]) - torso
    rel = (c * centre[0] + s * centre[1], -s * centre[0] + c * centre[1])
    # The box side nearest the heading is the world x side: yaw -30 degrees from the heading.
    row = [1.0, rel[0], rel[1], -yaw, 0.1, 0.2, 0.07]
    box = boxes_in_frame(row, yaw, torso)
    np.testing.assert_allclose(box[0], [[1.0, 0.0, 0.0], [1.2, 0.4, 0.07]], rtol=0, atol=1e-12)


def test_the_policy_needs_nothing_but_the_observation():
    """Replayed on the recorded observations alone, after the episode, a fresh policy gives
    the same actions bit for bit: nothing of the env but what it observed went in."""
    env = gym.make("NeuroCog/SuddenObstacle-v3")
    policy = make_policy("aef")
    obs, _ = env.reset(seed=3)
    start_episode(policy, env)
    seen, actions, modes = [], [], set()
    for _ in range(400):
        seen.append({k: np.array(v, copy=True) for k, v in obs.items()})
        actions.append(policy(obs))
        modes.add(policy.mode)
        obs, _, term, trunc, _ = env.step(actions[-1])
        if term or trunc:
            break
    env.close()
    assert MODE_PROVISION in modes  # the block appeared and the fit answered it
    replay = make_policy("aef")
    for o, a in zip(seen, actions, strict=True):
        np.testing.assert_array_equal(replay(o), a)
