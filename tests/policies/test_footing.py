"""The privileged footing oracle (neurocog_gym/policies/footing.py) on staged observations."""

import gymnasium as gym
import numpy as np
import pytest

import neurocog_gym  # noqa: F401
from neurocog_gym.policies.footing import (
    LIFT_DELAY,
    NOMINAL_HIP,
    NOMINAL_LANDING,
    FootingOracle,
    FootingParams,
)
from neurocog_gym.policies.oracle import OraclePolicy

FEET = np.array([[0.15, 0.12, 0.018], [0.20, -0.12, 0.018], [-0.20, 0.12, 0.018],
                 [-0.15, -0.12, 0.018]])  # fmt: skip


def _stones(rows):
    """A ``true_stones`` observation: the platforms far away, then ``rows`` of (x, y, hl, hw)."""
    st = np.zeros((24, 7), np.float32)
    st[0] = (1.0, -3.0, 0.0, 1.5, 1.5, 0.0, 0.0)  # start platform, far behind
    st[1] = (1.0, 4.0, 0.0, 1.5, 1.5, 0.0, 0.0)  # end platform, far ahead
    for k, (x, y, hl, hw) in enumerate(rows):
        st[2 + k] = (1.0, x, y, hl, hw, 0.0, 0.0)
    return st.ravel()


def _obs(stones, swinging=(), fl_hip=None, fl_z=0.018):
    """A staged observation; the legs in ``swinging`` have their CPG hip flexor leading."""
    y = np.zeros((4, 6), np.float32)
    for leg in range(4):
        y[leg, 0 if leg in swinging else 1] = 1.0
    servo = np.zeros(12, np.float32)
    servo[[1, 4]] = NOMINAL_HIP[0, 0]
    servo[[7, 10]] = NOMINAL_HIP[1, 0]
    if fl_hip is not None:
        servo[1] = fl_hip
    feet = FEET.copy()
    feet[0, 2] = fl_z
    touch = np.array([0.0 if fl_z > 0.03 else 1.0, 1.0, 1.0, 1.0], np.float32)
    return {"true_stones": stones, "feet": feet.astype(np.float32).ravel(), "cpg": y.ravel(),
            "servo_target": servo, "torso_quat": np.array([1.0, 0, 0, 0], np.float32),
            "touch": touch}  # fmt: skip


def _fl_swing(policy, stones, cycles):
    """Run FL's swing from its CPG onset for ``cycles`` cycles, the hip pool on its nominal."""
    policy(_obs(stones))  # FL in stance: no onset yet
    actions = []
    for t in range(cycles):
        z = 0.05 if t >= LIFT_DELAY[0] else 0.018
        actions.append(policy(_obs(stones, swinging=(0,), fl_hip=NOMINAL_HIP[0, t], fl_z=z)))
    return np.array(actions)


def test_plan_shift_by_hand():
    policy = FootingOracle()
    iv = np.array([[0.40, 0.50], [0.70, 0.80]])
    assert policy.plan_shift(0.45, iv) == 0.0  # on a stone
    assert policy.plan_shift(0.38, iv) == pytest.approx(0.02)  # 2 cm short of one: lengthen
    assert policy.plan_shift(0.52, iv) == pytest.approx(-0.02)  # 2 cm past one: shorten
    assert policy.plan_shift(0.60, iv) is None  # 10 cm from both: out of reach
    # Front legs: lengthen <= 5 cm, shorten <= 2.5 cm; hind legs 4 and 3.5 cm.
    assert policy.plan_shift(0.355, iv, leg=0) == pytest.approx(0.045)
    assert policy.plan_shift(0.355, iv, leg=2) is None
    assert policy.plan_shift(0.533, iv, leg=0) is None
    assert policy.plan_shift(0.533, iv, leg=2) == pytest.approx(-0.033)


def test_safe_intervals_keep_the_margins_and_the_lane():
    policy = FootingOracle()
    p = policy.p
    st = _stones([(0.50, 0.12, 0.08, 0.07), (0.80, 0.30, 0.08, 0.07)]).reshape(24, 7)
    iv = policy.safe_intervals(st, foot_y=0.12, t_left=0.2)
    # Both platforms and the first stone (0.42-0.58 less the margins); the second stone's
    # side is 11 cm from the foot's lane (0.30 - 0.07 = 0.23 > 0.12 + side margin).
    assert iv.shape == (3, 2)
    assert iv[2] == pytest.approx([0.42 + p.margin, 0.58 - p.margin])


def test_a_landing_short_of_a_stone_gets_a_negative_hip_interrupt():
    # FL's nominal landing lies 2 cm before the stone's safe part: lengthen, i.e. protract the
    # hip, which is a negative hip interrupt on this body.
    p = FootingParams()
    x0 = NOMINAL_LANDING[0] + 0.02 - p.margin
    stones = _stones([(x0 + 0.08, 0.12, 0.08, 0.10)])
    policy = FootingOracle()
    a = _fl_swing(policy, stones, 14)
    assert policy.plans[-1][1] == 0 and policy.plans[-1][3] == pytest.approx(0.02)
    assert np.abs(a[: LIFT_DELAY[0], 1]).max() < 1e-4  # nothing before the lift-off
    assert a[LIFT_DELAY[0] :, 1].min() < -0.05 and a[:, 1].max() < 1e-4
    assert np.all(a[:, [0, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11]] == 0.0)  # the other joints: CPG


def test_a_landing_past_a_stone_gets_a_positive_hip_interrupt():
    p = FootingParams()
    x1 = NOMINAL_LANDING[0] - 0.015 + p.margin  # the stone's far edge, 1.5 cm short of it
    stones = _stones([(x1 - 0.08, 0.12, 0.08, 0.10)])
    policy = FootingOracle()
    a = _fl_swing(policy, stones, 14)
    assert policy.plans[-1][3] == pytest.approx(-0.015)
    assert a[LIFT_DELAY[0] :, 1].max() > 0.02 and a[:, 1].min() > -1e-4


def test_a_landing_on_a_stone_is_left_alone():
    stones = _stones([(NOMINAL_LANDING[0], 0.12, 0.10, 0.10)])
    policy = FootingOracle()
    a = _fl_swing(policy, stones, 14)
    assert policy.plans[-1][3] == 0.0
    assert np.all(a[:, :12] == 0.0)


def test_a_landing_out_of_reach_of_a_shift_brakes_with_s_sag():
    # The FL stone's safe part ends 10 cm short of the nominal landing, the next starts 20 cm
    # past it: no shift reaches either; the brake's second level (-10.8 cm) lands it on the
    # first (the first level, -5.6 cm, would still need 4.4 cm of shortening: out of reach).
    p = FootingParams()
    x = NOMINAL_LANDING[0]
    stones = _stones([(x - 0.10 + p.margin - 0.06, 0.12, 0.06, 0.10),
                      (x + 0.20 - p.margin + 0.06, 0.12, 0.06, 0.10)])  # fmt: skip
    policy = FootingOracle()
    a = _fl_swing(policy, stones, 5)
    assert policy.plans[-1][1] == 0 and policy.plans[-1][3] == 0.0
    assert policy.brake_level == 2
    assert np.all(a[:, 12] == pytest.approx(p.brake_levels[2]))


def test_a_landing_out_of_every_reach_is_left_alone():
    x = NOMINAL_LANDING[0]
    stones = _stones([(x - 0.45, 0.12, 0.10, 0.10), (x + 0.45, 0.12, 0.10, 0.10)])
    policy = FootingOracle()
    a = _fl_swing(policy, stones, 5)
    assert np.isnan(policy.plans[-1][3])
    assert np.all(a[:, :13] == 0.0)


def test_no_stones_gives_the_zero_action():
    policy = FootingOracle()
    stones = np.zeros(24 * 7, np.float32)
    for swinging in ((), (0, 3), (1, 2)):
        a = policy(_obs(stones, swinging=swinging))
        assert a.shape == (15,) and a.dtype == np.float32
        assert np.all(a == 0.0)


def test_missing_privileged_keys_is_a_clear_error():
    obs = _obs(_stones([]))
    del obs["true_stones"]
    with pytest.raises(KeyError, match="privileged=True"):
        FootingOracle()(obs)


def test_the_oracle_hands_the_stepping_stones_to_the_footing_oracle():
    stones = _stones([(NOMINAL_LANDING[0] + 0.02 - FootingParams().margin + 0.08, 0.12, 0.08,
                       0.10)])  # fmt: skip
    oracle, footing = OraclePolicy(), FootingOracle()
    oracle(_obs(stones))
    footing(_obs(stones))
    for t in range(10):
        obs = _obs(stones, swinging=(0,), fl_hip=NOMINAL_HIP[0, t], fl_z=0.05 if t >= 6 else 0.018)
        np.testing.assert_array_equal(oracle(obs), footing(obs))
    oracle.reset()
    assert oracle.footing.plans == []


def test_the_oracle_walks_the_stepping_stones_env():
    env = gym.make("NeuroCog/SteppingStones-v3", privileged=True)
    obs, _ = env.reset(seed=0)
    policy = OraclePolicy()
    policy.reset(env)
    for _ in range(150):
        a = policy(obs)
        assert env.action_space.contains(a)
        obs, _, term, trunc, _ = env.step(a)
        if term or trunc:
            break
    assert policy.footing.plans  # it planned the swings of the trot
    env.close()
