"""Leg coordinates of the motor-neuron pools and the knee-behind body variant."""

import mujoco
import numpy as np
import pytest

from neurocog_gym.locomotion.motor import MotorNeuronPools, MotorParams, leg_coordinates
from neurocog_gym.robot.model import RobotIndex, load_model
from neurocog_gym.robot.variants import knee_behind


def test_leg_coordinates_marks_the_hips_of_knee_behind_legs():
    c = leg_coordinates([True, False, False, True])
    assert c.shape == (12,)
    assert np.flatnonzero(c).tolist() == [1, 10]
    with pytest.raises(ValueError, match="4 booleans"):
        leg_coordinates([True, False])


def test_body_v1_has_no_knee_behind_leg():
    assert not RobotIndex.build(load_model()).knee_behind.any()


def _feet(model, robot, q):
    data = mujoco.MjData(model)
    data.qpos[robot.qpos_adr] = q
    mujoco.mj_kinematics(model, data)
    return data.site_xpos[robot.foot_site] - data.xpos[robot.torso_body]


def test_same_pool_angles_put_the_feet_of_both_bodies_at_the_same_place():
    v1 = load_model()
    kb = knee_behind().compile()
    r1, rk = RobotIndex.build(v1), RobotIndex.build(kb)
    assert rk.knee_behind.all()
    rng = np.random.default_rng(0)
    for _ in range(20):
        # pool angles inside both bodies' ranges: abduct, hip (v1 range), knee
        q = np.concatenate([[rng.uniform(-0.3, 0.3), rng.uniform(-1.6, 0.2), rng.uniform(0.4, 2.4)]
                            for _ in range(4)])  # fmt: skip
        pools = MotorNeuronPools(q, rk.joint_lo, rk.joint_hi, MotorParams(), 0.01, rk.knee_behind)
        pools.reset(q)
        np.testing.assert_allclose(_feet(kb, rk, pools.target), _feet(v1, r1, q), atol=1e-9)
        # and the knees sit on opposite sides of the hip-foot line: behind on the variant
        d1, dk = mujoco.MjData(v1), mujoco.MjData(kb)
        d1.qpos[r1.qpos_adr], dk.qpos[rk.qpos_adr] = q, pools.target
        mujoco.mj_kinematics(v1, d1)
        mujoco.mj_kinematics(kb, dk)
        knee_x_v1 = d1.xpos[r1.shank_body, 0] - d1.site_xpos[r1.foot_site, 0]
        knee_x_kb = dk.xpos[rk.shank_body, 0] - dk.site_xpos[rk.foot_site, 0]
        assert np.all(knee_x_kb < knee_x_v1)


def test_pool_range_is_every_reachable_shank_pitch():
    rk = RobotIndex.build(knee_behind().compile())
    pools = MotorNeuronPools(np.zeros(12), rk.joint_lo, rk.joint_hi, knee_behind=rk.knee_behind)
    hip, knee = 1, 2
    assert pools.q_lo[hip] == pytest.approx(rk.joint_lo[hip] - rk.joint_hi[knee])
    assert pools.q_hi[hip] == pytest.approx(rk.joint_hi[hip] - rk.joint_lo[knee])
    # the servo target never leaves the joint range
    q = pools.q_lo.copy()
    pools.reset(q)
    assert np.all(pools.target >= rk.joint_lo) and np.all(pools.target <= rk.joint_hi)


def test_home_pose_of_the_variant_keeps_each_foot_under_its_hip():
    kb = knee_behind().compile()
    rk = RobotIndex.build(kb)
    d = mujoco.MjData(kb)
    mujoco.mj_resetDataKeyframe(kb, d, 0)
    mujoco.mj_kinematics(kb, d)
    dx = d.site_xpos[rk.foot_site, 0] - d.xpos[rk.thigh_body, 0]
    assert np.all(np.abs(dx) < 1e-6)
