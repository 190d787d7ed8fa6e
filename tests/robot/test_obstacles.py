import mujoco
import numpy as np
import pytest

from neurocog_gym.robot.model import RobotIndex, load_model
from neurocog_gym.robot.obstacles import Block, ObstaclePool, random_block


@pytest.fixture()
def world():
    model = load_model()
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, 0)
    return model, data, ObstaclePool(model), RobotIndex.build(model)


def test_pool_has_slots_in_world_group(world):
    model, _, pool, _ = world
    assert pool.capacity >= 3
    assert np.all(model.geom_group[pool.geom_ids] == 1)


def test_place_sets_size_pose_and_bounds(world):
    model, data, pool, _ = world
    b = Block(x=1.0, y=0.2, length=0.1, width=0.2, height=0.07, yaw=0.0)
    pool.place(model, data, [b])
    g = pool.geom_ids[0]
    assert model.geom_size[g] == pytest.approx([0.05, 0.1, 0.035])
    assert data.geom_xpos[g] == pytest.approx([1.0, 0.2, 0.035])
    assert model.geom_rbound[g] == pytest.approx(np.linalg.norm([0.05, 0.1, 0.035]))
    assert pool.boxes()[0] == pytest.approx(np.array([[0.95, 0.1, 0.0], [1.05, 0.3, 0.07]]))
    # Parked slots are below the floor.
    assert np.all(data.geom_xpos[pool.geom_ids[1:], 2] < -0.5)


def test_a_placed_block_is_solid_and_contacts_are_reported(world):
    model, data, pool, robot = world
    # Lift the robot 8 cm, put a block under the front-left foot, drop: the foot lands on it.
    data.qpos[2] += 0.08
    mujoco.mj_forward(model, data)
    foot = data.site_xpos[robot.foot_site[0]].copy()
    pool.place(model, data, [Block(foot[0], foot[1], 0.1, 0.1, 0.06)])
    for _ in range(200):
        mujoco.mj_step(model, data)
    assert pool.touching(data, robot.robot_geoms)[0]
    assert data.site_xpos[robot.foot_site[0], 2] > 0.05


def test_clear_parks_everything(world):
    model, data, pool, robot = world
    pool.place(model, data, [Block(0.3, 0.0, 0.1, 0.1, 0.07)])
    pool.clear(model, data)
    mujoco.mj_kinematics(model, data)
    assert not pool.blocks
    assert np.all(data.geom_xpos[pool.geom_ids, 2] < -0.5)


def test_random_block_heights_follow_the_paper():
    rng = np.random.default_rng(0)
    hs = [random_block(rng, 0.0, 0.0).height for _ in range(200)]
    assert min(hs) >= 0.055 and max(hs) <= 0.085
    assert {round(h, 2) for h in hs} >= {0.06, 0.07, 0.08}


def test_bad_block_raises():
    with pytest.raises(ValueError, match="height"):
        Block(0, 0, 0.1, 0.1, -0.01)


def test_too_many_blocks(world):
    model, data, pool, _ = world
    with pytest.raises(ValueError, match="at most"):
        pool.place(model, data, [Block(i, 0, 0.1, 0.1, 0.07) for i in range(pool.capacity + 1)])
