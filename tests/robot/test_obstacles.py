import mujoco
import numpy as np
import pytest

from neurocog_gym.robot.model import RobotIndex, load_model
from neurocog_gym.robot.obstacles import PARK_Z, Block, ObstaclePool, random_block


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


# -- loose wooden blocks ------------------------------------------------------------------------


def _step(model, data, seconds):
    mujoco.mj_step(model, data, nstep=int(round(seconds / model.opt.timestep)))


def test_block_mass_and_inertia_are_wood_and_match_mj_setconst(world):
    import copy

    from neurocog_gym.robot.obstacles import WOOD_DENSITY, box_mass_inertia

    model, data, pool, _ = world
    blocks = [Block(0.8, 0.0, 0.08, 0.2, 0.07, 0.2), Block(1.5, 0.1, 0.12, 0.1, 0.06, -0.1)]
    pool.place(model, data, blocks)
    for slot, b in enumerate(blocks):
        body = pool.bodies[slot]
        # 500 kg/m^3 x 8 x 20 x 7 cm = 0.56 kg for the first block.
        assert model.body_mass[body] == pytest.approx(500.0 * b.length * b.width * b.height)
        mass, inertia = box_mass_inertia(b.half_size)
        assert mass == pytest.approx(WOOD_DENSITY * b.length * b.width * b.height)
        # I_x = m (w^2 + h^2) / 12 with full extents.
        assert inertia[0] == pytest.approx(mass * (b.width**2 + b.height**2) / 12)
        assert model.body_inertia[body] == pytest.approx(inertia)
    # The constants MuJoCo derives from the masses are those mj_setConst computes.
    ref = copy.copy(model)
    mujoco.mj_setConst(ref, mujoco.MjData(ref))
    for field in ("body_subtreemass", "dof_M0", "body_invweight0", "dof_invweight0"):
        assert getattr(model, field) == pytest.approx(getattr(ref, field), rel=1e-12), field


def test_placed_blocks_collide_with_floor_robot_and_each_other(world):
    model, data, pool, robot = world
    pool.place(model, data, [Block(1.0, 0.0, 0.1, 0.1, 0.07), Block(1.2, 0.0, 0.1, 0.1, 0.07)])
    floor = model.geom("floor").id

    def collide(a, b):
        return bool(model.geom_contype[a] & model.geom_conaffinity[b]) or bool(
            model.geom_contype[b] & model.geom_conaffinity[a]
        )

    g0, g1 = pool.geom_ids[:2]
    assert collide(g0, floor) and collide(g0, g1)
    assert all(collide(g0, r) for r in robot.robot_geoms)
    # Parked slots collide with nothing.
    for g in pool.geom_ids[2:]:
        assert not collide(g, floor) and not any(collide(g, r) for r in robot.robot_geoms)
    # A block dropped onto another one comes to rest on top of it.
    pool.place(model, data, [Block(1.0, 0.0, 0.1, 0.1, 0.07), Block(1.0, 0.0, 0.06, 0.06, 0.06)])
    data.qpos[pool.qpos_adr[1] + 2] = 0.07 + 0.03 + 0.01
    _step(model, data, 0.5)
    assert data.xpos[pool.bodies[1], 2] == pytest.approx(0.07 + 0.03, abs=0.003)


def test_resting_block_stays_put_for_two_seconds(world):
    model, data, pool, _ = world
    b = Block(1.0, 0.1, 0.09, 0.25, 0.08, 0.3)
    pool.place(model, data, [b])
    pos0 = pool.poses()[0].copy()
    assert pos0[0] == pytest.approx([1.0, 0.1, 0.04])  # resting on the floor: z = h / 2
    for _ in range(20):
        _step(model, data, 0.1)
        pos, quat = pool.poses()
        # Settling sinks it by the contact's equilibrium depth, far below the knock limits.
        assert np.hypot(*(pos[0, :2] - pos0[0, :2])) < 1e-4
        assert abs(pos[0, 2] - pos0[0, 2]) < 2e-3
        assert abs(quat[0] @ pool.placed_quat[0]) > np.cos(np.radians(0.2) / 2)


def test_pushed_block_moves_and_its_box_follows(world):
    model, data, pool, _ = world
    b = Block(1.0, 0.0, 0.1, 0.2, 0.07)
    pool.place(model, data, [b])
    box0 = pool.boxes()[0].copy()
    body = pool.bodies[0]
    # Friction 0.4 x 1.4 kg x 9.81 = 5.5 N holds it; push with 10 N along x for 0.3 s.
    data.xfrc_applied[body, 0] = 10.0
    _step(model, data, 0.3)
    data.xfrc_applied[body] = 0.0
    _step(model, data, 0.5)
    pos, _ = pool.poses()
    assert pos[0, 0] - b.x > 0.05
    assert pool.placed_pos[0] == pytest.approx(b.center)  # the placed pose is kept
    box = pool.boxes()[0]
    assert box[0, 0] - box0[0, 0] == pytest.approx(pos[0, 0] - b.x, abs=1e-3)
    js = pool.blocks_json()[0]
    assert js["x"] == pytest.approx(b.x) and js["pos"][0] == pytest.approx(pos[0, 0], abs=1e-5)
    assert len(js["quat"]) == 4


def test_parked_blocks_hang_still_and_never_touch_anything(world):
    model, data, pool, robot = world
    pool.place(model, data, [Block(0.3, 0.0, 0.1, 0.1, 0.07)])
    pool.clear(model, data)
    _step(model, data, 2.0)
    mujoco.mj_forward(model, data)
    block_geoms = set(pool.geom_ids.tolist())
    assert not any(int(g) in block_geoms for c in range(data.ncon) for g in data.contact.geom[c])
    for slot, body in enumerate(pool.bodies):
        assert data.xpos[body] == pytest.approx([0.0, 3.0 * slot, PARK_Z], abs=1e-6)
    assert np.all(data.qvel[pool.dof_adr[0] : pool.dof_adr[0] + 6] == pytest.approx(0, abs=1e-9))


def test_add_fills_the_next_slot_and_refuses_a_full_pool(world):
    model, data, pool, _ = world
    pool.place(model, data, [])
    serial = pool.serial.copy()
    for i in range(pool.capacity):
        pool.add(model, data, Block(1.0 + 0.3 * i, 0.0, 0.1, 0.1, 0.07))
    assert len(pool.blocks) == pool.capacity and np.all(pool.serial == serial + 1)
    with pytest.raises(ValueError, match="in use"):
        pool.add(model, data, Block(3.0, 0.0, 0.1, 0.1, 0.07))


def test_scene_with_loose_blocks_steps_random_controls_without_warnings(world):
    """Menagerie's rule: the scene stepped with random controls raises no MuJoCo warning,
    here with every slot holding a block around the robot (the robot kicks, falls on them)."""
    model, data, pool, robot = world
    rng = np.random.default_rng(0)
    blocks = [Block(0.35 * np.cos(a), 0.35 * np.sin(a), 0.1, 0.2, 0.08, float(a))
              for a in np.linspace(0, 2 * np.pi, pool.capacity, endpoint=False)]  # fmt: skip
    pool.place(model, data, blocks)
    lo, hi = model.actuator_ctrlrange[robot.actuator].T
    for _ in range(300):
        data.ctrl[robot.actuator] = rng.uniform(lo, hi)
        _step(model, data, 0.01)
    assert data.warning.number.sum() == 0
    assert np.all(np.isfinite(data.qpos))
