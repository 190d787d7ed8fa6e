"""Tests of the time-of-flight sensor array (neurocog_gym/robot/tof.py).

Every scene is built here with MjSpec (no dependency on the shipped MJCF): a floor plane, optional
obstacles, and a dummy torso (geom group 2) carrying the four sensor sites fanned like Fig. 3:
yaws +60°, +20°, -20°, -60° (composite 165° × 62°), pitched 35° down, at about 0.25 m.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import os
import pickle
import subprocess
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from neurocog_gym.robot.names import ROBOT_GEOM_GROUP, TOF_SITES
from neurocog_gym.robot.tof import FULL_HEIGHT, FULL_WIDTH, ToFArray, ToFFrame, ToFParams

G = mujoco.mjtGeom
BACKENDS = ("mujoco", "numba")
FAN_YAWS_DEG = (60.0, 20.0, -20.0, -60.0)
PITCH_DEG = 35.0
TORSO_Z = 0.22
SITE_POS = (0.21, 0.0, 0.03)  # in the torso frame: sensors at z = 0.25 m


def yaw_pitch_quat(yaw_deg: float, pitch_deg: float) -> np.ndarray:
    """Quaternion of a frame yawed about world z, then pitched (x down for > 0) about its y."""
    yaw, pitch = math.radians(yaw_deg), math.radians(pitch_deg)
    qz = np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])
    qy = np.array([math.cos(pitch / 2), 0.0, math.sin(pitch / 2), 0.0])
    q = np.zeros(4)
    mujoco.mju_mulQuat(q, qz, qy)
    return q


def build(
    floor_z: float | None = 0.0,
    pitch_deg: float = PITCH_DEG,
    add_world=None,
    add_torso=None,
) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """Floor (group 0) + dummy robot (group 2) with the four fanned sensor sites."""
    spec = mujoco.MjSpec()
    world = spec.worldbody
    if floor_z is not None:
        world.add_geom(name="floor", type=G.mjGEOM_PLANE, size=[0, 0, 0.1], pos=[0, 0, floor_z])
    if add_world is not None:
        add_world(world)
    torso = world.add_body(name="torso", pos=[0, 0, TORSO_Z])
    torso.add_freejoint()
    torso.add_geom(type=G.mjGEOM_BOX, size=[0.2, 0.08, 0.05], group=ROBOT_GEOM_GROUP)
    for name, yaw in zip(TOF_SITES, FAN_YAWS_DEG, strict=True):
        torso.add_site(name=name, pos=list(SITE_POS), quat=yaw_pitch_quat(yaw, pitch_deg))
    if add_torso is not None:
        add_torso(torso)
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def one_camera(height: float = 1.0, wall_x: float | None = None, floor: bool = False):
    """A single level sensor 'cam' at (0, 0, height) looking along +x, facing a wall."""
    spec = mujoco.MjSpec()
    world = spec.worldbody
    if floor:
        world.add_geom(type=G.mjGEOM_PLANE, size=[0, 0, 0.1])
    if wall_x is not None:
        # front face at x = wall_x, much larger than the view
        world.add_geom(
            name="wall", type=G.mjGEOM_BOX, size=[0.05, 20, 20], pos=[wall_x + 0.05, 0, height]
        )
    world.add_site(name="cam", pos=[0, 0, height])
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    return model, data


def ray_lengths(frame: ToFFrame) -> np.ndarray:
    """(N,) distance of each point from its own sensor, metres."""
    origins = np.repeat(frame.origins, frame.counts, axis=0)
    return np.linalg.norm(frame.points.astype(np.float64) - origins, axis=1)


def check_frame_invariants(frame: ToFFrame, params: ToFParams) -> None:
    shape = (params.n_sensors, params.height, params.width)
    assert frame.depth.shape == frame.valid.shape == frame.geom.shape == shape
    assert frame.points.dtype == np.float32 and frame.depth.dtype == np.float32
    assert frame.points.shape == (int(frame.valid.sum()), 3)
    assert np.all(np.isfinite(frame.points)) and np.all(np.isfinite(frame.depth))
    np.testing.assert_array_equal(frame.counts, frame.valid.reshape(shape[0], -1).sum(axis=1))
    assert np.all(frame.depth[~frame.valid] == 0.0) and np.all(frame.depth[frame.valid] > 0.0)
    assert np.all(frame.geom[~frame.valid] == -1) and np.all(frame.geom[frame.valid] >= 0)
    d = ray_lengths(frame)
    assert np.all(d >= params.min_range - 1e-5) and np.all(d <= params.max_range + 1e-5)


# -- resolution and field of view ------------------------------------------------------------


@pytest.mark.parametrize("backend", BACKENDS)
def test_full_resolution_casts_154112_rays(backend):
    model, data = build()
    params = ToFParams.at_scale(1.0, backend=backend)
    assert (params.width, params.height) == (FULL_WIDTH, FULL_HEIGHT) == (224, 172)
    tof = ToFArray(model, params)
    assert tof.n_rays == params.n_rays == 4 * 224 * 172 == 154_112
    frame = tof.sense(data)
    assert frame.depth.shape == (4, 172, 224)
    assert 0 < frame.points.shape[0] <= 154_112
    check_frame_invariants(frame, params)


def test_default_resolution_is_a_quarter_per_axis():
    params = ToFParams()
    assert (params.width, params.height) == (56, 43)
    assert ToFParams.at_scale(0.25) == params
    assert params.fps == 45.0 and params.noise_std_rel == 0.0 and params.dropout == 0.0


def test_rays_span_the_field_of_view_on_a_pinhole_grid():
    model, _ = build()
    params = ToFParams(width=9, height=7)
    dirs = ToFArray(model, params).directions.reshape(7, 9, 3)
    np.testing.assert_allclose(np.linalg.norm(dirs, axis=-1), 1.0, atol=1e-12)
    horiz = np.degrees(np.arctan2(dirs[..., 1], dirs[..., 0]))
    vert = np.degrees(np.arctan2(dirs[..., 2], dirs[..., 0]))
    # column 0 is the image's left (+y), row 0 its top (+z); extremes on the FOV edges
    np.testing.assert_allclose(horiz[:, 0], 22.5, atol=1e-9)
    np.testing.assert_allclose(horiz[:, -1], -22.5, atol=1e-9)
    np.testing.assert_allclose(vert[0, :], 31.0, atol=1e-9)
    np.testing.assert_allclose(vert[-1, :], -31.0, atol=1e-9)
    # pinhole: evenly spaced on the image plane x = 1, not in angle
    u = dirs[..., 1] / dirs[..., 0]
    np.testing.assert_allclose(np.diff(u, axis=1), np.diff(u, axis=1)[0, 0], atol=1e-12)
    assert not np.allclose(np.diff(horiz[0]), np.diff(horiz[0])[0], atol=1e-3)


@pytest.mark.parametrize("backend", BACKENDS)
def test_wall_fills_the_frustum_at_constant_z_depth(backend):
    # level camera 2 m from a fronto-parallel wall: z-depth is 2 m at every pixel, and the
    # image spans ±2·tan 22.5° sideways and ±2·tan 31° up and down
    model, data = one_camera(height=1.0, wall_x=2.0)
    params = ToFParams(width=31, height=25, site_names=("cam",), backend=backend)
    frame = ToFArray(model, params).sense(data)
    assert frame.valid.all()
    np.testing.assert_allclose(frame.depth, 2.0, atol=1e-5)
    pts = frame.points
    np.testing.assert_allclose(pts[:, 0], 2.0, atol=1e-5)
    assert pts[:, 1].max() == pytest.approx(2 * math.tan(math.radians(22.5)), abs=1e-5)
    assert pts[:, 1].min() == pytest.approx(-2 * math.tan(math.radians(22.5)), abs=1e-5)
    assert pts[:, 2].max() == pytest.approx(1 + 2 * math.tan(math.radians(31)), abs=1e-5)
    assert pts[:, 2].min() == pytest.approx(1 - 2 * math.tan(math.radians(31)), abs=1e-5)
    # row 0 is the top of the image, column 0 its left
    img = pts.reshape(25, 31, 3)
    assert img[0, 0, 2] > img[-1, 0, 2] and img[0, 0, 1] > img[0, -1, 1]


def test_fan_covers_165_degrees():
    model, _ = build(pitch_deg=0.0)
    params = ToFParams(width=9, height=7)
    tof = ToFArray(model, params)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    yaw = []
    for sid in tof.site_ids:
        world = tof.directions @ data.site_xmat[sid].reshape(3, 3).T
        yaw.append(np.degrees(np.arctan2(world[:, 1], world[:, 0])))
    yaw = np.concatenate(yaw)
    assert yaw.max() == pytest.approx(82.5, abs=1e-6)
    assert yaw.min() == pytest.approx(-82.5, abs=1e-6)


# -- geometry: floor, box, the robot's own geoms -----------------------------------------------


@pytest.mark.parametrize("backend", BACKENDS)
def test_flat_floor_comes_back_at_its_height(backend):
    model, data = build(floor_z=0.05)
    params = ToFParams(backend=backend)
    frame = ToFArray(model, params).sense(data)
    check_frame_invariants(frame, params)
    assert frame.points.shape[0] > 0.9 * params.n_rays
    np.testing.assert_allclose(frame.points[:, 2], 0.05, atol=1e-5)
    # z-depth is the point's offset from its sensor along that sensor's optical axis
    tof = ToFArray(model, params)
    axes = np.stack([data.site_xmat[s].reshape(3, 3)[:, 0] for s in tof.site_ids])
    offsets = frame.points - np.repeat(frame.origins, frame.counts, axis=0)
    along = np.einsum("nk,nk->n", offsets, np.repeat(axes, frame.counts, axis=0))
    np.testing.assert_allclose(frame.depth[frame.valid], along, atol=1e-5)


BOX_CENTER = (0.7, 0.05, 0.04)
BOX_HALF = (0.1, 0.15, 0.04)  # top face at z = 0.08


def add_box(world):
    world.add_geom(
        name="block", type=G.mjGEOM_BOX, size=list(BOX_HALF), pos=list(BOX_CENTER), group=1
    )


@pytest.mark.parametrize("backend", BACKENDS)
def test_box_comes_back_where_it_stands(backend):
    model, data = build(add_world=add_box)
    params = ToFParams.at_scale(0.5, backend=backend)
    frame = ToFArray(model, params).sense(data)
    check_frame_invariants(frame, params)
    pts = frame.points
    lo = np.subtract(BOX_CENTER, BOX_HALF)
    hi = np.add(BOX_CENTER, BOX_HALF)
    above = pts[pts[:, 2] > 1e-4]
    assert above.shape[0] > 100
    assert np.all(above >= lo - 1e-5) and np.all(above <= hi + 1e-5)
    top = pts[np.abs(pts[:, 2] - hi[2]) < 1e-5]
    assert top.shape[0] > 100
    assert np.all(top[:, :2] >= lo[:2] - 1e-5) and np.all(top[:, :2] <= hi[:2] + 1e-5)
    block = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "block")
    assert (frame.geom == block).sum() == above.shape[0]


def blocker(group: int):
    """A wide box on the torso just ahead of the sensors, covering every view."""

    def add(torso):
        torso.add_geom(
            name="blocker", type=G.mjGEOM_BOX, size=[0.02, 0.6, 0.4], pos=[0.4, 0, 0], group=group
        )

    return add


@pytest.mark.parametrize("backend", BACKENDS)
def test_robot_geoms_are_not_seen(backend):
    params = ToFParams(backend=backend)
    model, data = build()
    clear = ToFArray(model, params).sense(data)
    model, data = build(add_torso=blocker(ROBOT_GEOM_GROUP))
    frame = ToFArray(model, params).sense(data)
    np.testing.assert_array_equal(frame.valid, clear.valid)
    np.testing.assert_allclose(frame.points[:, 2], 0.0, atol=1e-5)
    # the same geom in a world group is seen: the test is not vacuous
    model, data = build(add_torso=blocker(1))
    seen = ToFArray(model, params).sense(data)
    blocker_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "blocker")
    assert (seen.geom == blocker_id).mean() > 0.5


@pytest.mark.parametrize("backend", BACKENDS)
def test_transparent_geoms_are_not_seen(backend):
    # mj_multiRay skips geoms with alpha 0: a parked, hidden obstacle must not show up, and
    # showing it at run time (no rebuild) must make it appear
    def hidden(world):
        world.add_geom(
            name="hidden", type=G.mjGEOM_BOX, size=[0.02, 2, 1], pos=[0.6, 0, 0], rgba=[1, 0, 0, 0]
        )

    model, data = build(add_world=hidden)
    tof = ToFArray(model, ToFParams(backend=backend))
    np.testing.assert_allclose(tof.sense(data).points[:, 2], 0.0, atol=1e-5)
    hidden_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "hidden")
    model.geom_rgba[hidden_id, 3] = 1.0
    assert (tof.sense(data).geom == hidden_id).mean() > 0.25


# -- invalid returns ---------------------------------------------------------------------------


@pytest.mark.parametrize("backend", BACKENDS)
def test_sky_rays_are_dropped_and_marked_invalid(backend):
    model, data = build(pitch_deg=-60.0)  # looking up: the lowest ray is 29° above horizontal
    params = ToFParams(backend=backend)
    frame = ToFArray(model, params).sense(data)
    assert not frame.valid.any()
    assert frame.points.shape == (0, 3)
    assert np.all(frame.depth == 0.0) and np.all(frame.geom == -1)
    np.testing.assert_array_equal(frame.counts, 0)
    check_frame_invariants(frame, params)


@pytest.mark.parametrize("backend", BACKENDS)
def test_returns_outside_the_range_are_dropped(backend):
    params = ToFParams(width=21, height=15, site_names=("cam",), backend=backend)
    model, data = one_camera(wall_x=5.0)
    far = ToFArray(model, params).sense(data)
    assert not far.valid.any() and far.points.shape == (0, 3)
    longer = ToFArray(model, dataclasses.replace(params, max_range=7.0)).sense(data)
    assert longer.valid.all()
    model, data = one_camera(wall_x=0.05)  # inside the 0.1 m minimum range
    near = ToFArray(model, params).sense(data)
    assert not near.valid.any()
    # 3.9 m: the centre of the image is in range, its corners (ray length > 4 m) are not
    model, data = one_camera(wall_x=3.9)
    mixed = ToFArray(model, params).sense(data)
    assert mixed.valid[0, 7, 10] and not mixed.valid[0, 0, 0] and not mixed.valid[0, -1, -1]
    check_frame_invariants(mixed, params)


@settings(max_examples=25, deadline=None)
@given(
    pos=st.tuples(st.floats(-3, 3), st.floats(-3, 3), st.floats(0.02, 1.5)),
    quat=st.tuples(*[st.floats(-1, 1)] * 4).filter(lambda q: sum(x * x for x in q) > 0.1),
    backend=st.sampled_from(BACKENDS),
)
def test_any_pose_gives_finite_in_range_points(pos, quat, backend):
    model, data = build(add_world=add_box)
    data.qpos[:3] = pos
    data.qpos[3:7] = np.asarray(quat) / np.linalg.norm(quat)
    mujoco.mj_forward(model, data)
    params = ToFParams(width=24, height=18, backend=backend)
    check_frame_invariants(ToFArray(model, params).sense(data), params)


# -- backends ----------------------------------------------------------------------------------


def every_primitive(world):
    rng = np.random.default_rng(7)
    shapes = [
        (G.mjGEOM_SPHERE, [0.12, 0, 0]),
        (G.mjGEOM_CAPSULE, [0.05, 0.15, 0]),
        (G.mjGEOM_ELLIPSOID, [0.1, 0.2, 0.06]),
        (G.mjGEOM_CYLINDER, [0.08, 0.1, 0]),
        (G.mjGEOM_BOX, [0.1, 0.05, 0.12]),
    ]
    for i in range(15):
        kind, size = shapes[i % len(shapes)]
        angle = rng.uniform(-1.3, 1.3)
        pos = [0.7 * math.cos(angle) + rng.uniform(0, 0.8), 0.9 * math.sin(angle), 0.1]
        quat = rng.normal(size=4)
        world.add_geom(type=kind, size=size, pos=pos, quat=quat / np.linalg.norm(quat), group=1)
    # a finite, tilted plane patch and a hidden box
    world.add_geom(
        type=G.mjGEOM_PLANE, size=[0.3, 0.2, 0.1], pos=[1.2, -0.8, 0.2], quat=[0.989, 0.149, 0, 0]
    )
    world.add_geom(type=G.mjGEOM_BOX, size=[0.3, 0.3, 0.3], pos=[0.6, 0, 0], rgba=[1, 1, 1, 0])


def test_numba_backend_agrees_with_mj_multiray():
    model, data = build(add_world=every_primitive)
    data.qpos[3:7] = yaw_pitch_quat(10.0, -5.0)
    mujoco.mj_forward(model, data)
    ref = ToFArray(model, ToFParams.at_scale(0.5)).sense(data)
    fast = ToFArray(model, ToFParams.at_scale(0.5, backend="numba")).sense(data)
    assert len(np.unique(ref.geom)) >= 10  # the scene really exercises many geoms
    np.testing.assert_array_equal(fast.valid, ref.valid)
    np.testing.assert_array_equal(fast.geom, ref.geom)
    np.testing.assert_allclose(fast.depth, ref.depth, atol=1e-6)
    np.testing.assert_allclose(fast.points, ref.points, atol=1e-6)


def near_boxes(seed: int):
    """Boxes and other primitives close round the sensors, a scene for the pixel-span culling."""

    def add(world):
        rng = np.random.default_rng(seed)
        kinds = [G.mjGEOM_BOX] * 4 + [G.mjGEOM_SPHERE, G.mjGEOM_CAPSULE, G.mjGEOM_CYLINDER]
        for i in range(12):
            kind = kinds[i % len(kinds)]
            size = [rng.uniform(0.01, 0.3), rng.uniform(0.01, 0.3), rng.uniform(0.01, 0.3)]
            # from behind the sensors (x < 0.2) to 1.5 m ahead, some round the sensors themselves
            pos = [rng.uniform(-0.1, 1.5), rng.uniform(-1.2, 1.2), rng.uniform(0.0, 0.5)]
            quat = rng.normal(size=4)
            world.add_geom(type=kind, size=size, pos=pos, quat=quat / np.linalg.norm(quat), group=1)

    return add


@pytest.mark.parametrize("seed", range(6))
def test_numba_pixel_spans_lose_no_hit(seed):
    """Boxes cast only on the pixels their corners' images span: mj_multiRay sees the same."""
    model, data = build(add_world=near_boxes(seed))
    params = ToFParams.at_scale(0.5)
    ref = ToFArray(model, params).sense(data)
    fast = ToFArray(model, dataclasses.replace(params, backend="numba")).sense(data)
    assert len(np.unique(ref.geom)) >= 4
    np.testing.assert_array_equal(fast.valid, ref.valid)
    np.testing.assert_array_equal(fast.geom, ref.geom)
    np.testing.assert_allclose(fast.depth, ref.depth, atol=1e-6)


def test_numba_frame_does_not_depend_on_the_tile_size(monkeypatch):
    """The numba backend casts in tiles of image rows; one row a tile gives the same bits."""
    from neurocog_gym.robot import _tof_kernels

    model, data = build(add_world=near_boxes(1))
    params = ToFParams.at_scale(0.5, backend="numba", noise_std_rel=0.02, dropout=0.05)
    default = ToFArray(model, params, seed=5).sense(data)
    monkeypatch.setattr(_tof_kernels, "TILE_RAYS", 1)
    single = ToFArray(model, params, seed=5)
    assert single._tile_dist.shape[0] == params.width
    by_row = single.sense(data)
    for name in ("points", "depth", "valid", "geom", "origins", "counts"):
        np.testing.assert_array_equal(getattr(by_row, name), getattr(default, name))


def test_numba_backend_refuses_meshes():
    spec = mujoco.MjSpec()
    spec.add_mesh(name="tet", uservert=[0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1])
    spec.worldbody.add_geom(type=G.mjGEOM_MESH, meshname="tet", pos=[1, 0, 0])
    spec.worldbody.add_site(name="cam")
    model = spec.compile()
    params = ToFParams(site_names=("cam",))
    ToFArray(model, params)  # mj_multiRay handles meshes
    with pytest.raises(ValueError, match="backend='mujoco'"):
        ToFArray(model, dataclasses.replace(params, backend="numba"))


# -- noise, determinism, buffers --------------------------------------------------------------


def test_noise_off_is_deterministic_whatever_the_seed():
    model, data = build(add_world=add_box)
    a = ToFArray(model, seed=0).sense(data)
    b = ToFArray(model, seed=1).sense(data)
    c = ToFArray(model, seed=1).sense(data)
    for x in (b, c):
        np.testing.assert_array_equal(x.depth, a.depth)
        np.testing.assert_array_equal(x.points, a.points)


def test_noise_is_seeded_and_of_the_stated_size():
    model, data = build()
    params = ToFParams.at_scale(0.5, noise_std_rel=0.01, dropout=0.1)
    exact = ToFArray(model, ToFParams.at_scale(0.5)).sense(data)
    a = ToFArray(model, params, seed=3).sense(data)
    b = ToFArray(model, params, seed=3).sense(data)
    c = ToFArray(model, params, seed=4).sense(data)
    np.testing.assert_array_equal(a.depth, b.depth)
    np.testing.assert_array_equal(a.points, b.points)
    assert not np.array_equal(a.depth, c.depth)
    check_frame_invariants(a, params)
    # dropout: ~10 % of the valid pixels lost; noise: σ = 1 % of the distance
    both = a.valid & exact.valid
    assert a.valid.sum() / exact.valid.sum() == pytest.approx(0.9, abs=0.02)
    rel = a.depth[both] / exact.depth[both] - 1.0
    assert rel.std() == pytest.approx(0.01, rel=0.05) and abs(rel.mean()) < 1e-3
    # the stream restarts on reset(seed)
    tof = ToFArray(model, params, seed=3)
    first = tof.sense(data)
    tof.reset(seed=3)
    np.testing.assert_array_equal(tof.sense(data).depth, first.depth)


def test_copy_false_returns_views_that_the_next_frame_overwrites():
    model, data = build()
    tof = ToFArray(model)
    a = tof.sense(data, copy=False)
    b = tof.sense(data, copy=False)
    assert np.shares_memory(a.points, b.points) and np.shares_memory(a.depth, b.depth)
    c = tof.sense(data)
    d = tof.sense(data)
    assert not np.shares_memory(c.points, d.points)
    assert not np.shares_memory(c.depth, tof.sense(data, copy=False).depth)


@pytest.mark.parametrize("backend", BACKENDS)
def test_pickled_array_senses_the_same(backend):
    model, data = build(add_world=add_box)
    tof = ToFArray(model, ToFParams(backend=backend, noise_std_rel=0.01), seed=5)
    clone = pickle.loads(pickle.dumps(tof))
    a, b = tof.sense(data), clone.sense(data)
    np.testing.assert_array_equal(a.depth, b.depth)
    np.testing.assert_array_equal(a.points, b.points)


@pytest.mark.parametrize("clone_of", [lambda t: pickle.loads(pickle.dumps(t)), copy.deepcopy])
@pytest.mark.parametrize("backend", BACKENDS)
def test_a_copy_made_after_a_frame_shares_views_of_its_own_buffers(backend, clone_of):
    model, data = build(add_world=add_box)
    tof = ToFArray(model, ToFParams(backend=backend), seed=5)
    tof.sense(data, copy=False)  # the shared views exist now
    clone = clone_of(tof)
    data.qpos[2] += 0.3  # another scene for the clone's frames
    mujoco.mj_forward(model, data)
    owned, view = clone.sense(data), clone.sense(data, copy=False)
    for name in ("depth", "valid", "geom", "origins", "counts"):
        assert getattr(view, name).tobytes() == getattr(owned, name).tobytes(), name


# -- frame-rate gate ---------------------------------------------------------------------------


def test_frame_gate_runs_at_fps_on_a_0_01_s_control_cycle():
    model, data = build()
    tof = ToFArray(model, ToFParams(fps=45.0))
    times = []
    for k in range(101):  # t = 0.00 ... 1.00 s
        data.time = k * 0.01
        due = tof.due(data.time)
        frame = tof.maybe_sense(data)
        assert (frame is not None) == due
        if frame is not None:
            times.append(frame.time)
    # frames at the first cycle on or after k / 45 s, k = 0..45: 46 frames in [0, 1] s
    assert len(times) == 46
    assert set(np.round(np.diff(times), 6)) <= {0.02, 0.03}
    expected = [math.ceil(round(k / 45 * 100, 9)) / 100 for k in range(46)]
    np.testing.assert_allclose(times, expected, atol=1e-9)


def test_frame_gate_period_divides_the_cycle():
    model, data = build()
    tof = ToFArray(model, ToFParams(fps=25.0))
    hits = []
    for k in range(40):
        data.time = k * 0.01
        if tof.maybe_sense(data) is not None:
            hits.append(k)
    assert hits == list(range(0, 40, 4))


def test_frame_gate_reset_jump_and_rewind():
    model, data = build()
    tof = ToFArray(model, ToFParams(fps=10.0))
    data.time = 0.0
    assert tof.maybe_sense(data) is not None
    data.time = 0.05
    assert not tof.due(0.05) and tof.maybe_sense(data) is None
    tof.reset()
    assert tof.maybe_sense(data) is not None  # reset: next call senses
    data.time = 5.0  # a long gap gives one frame, not a burst of missed ones
    assert tof.maybe_sense(data) is not None and tof.maybe_sense(data) is None
    assert not tof.due(5.09) and tof.due(5.1)
    data.time = 0.0  # time went backwards: a new episode began
    assert tof.maybe_sense(data) is not None
    # sense() ignores the schedule and leaves it alone
    assert tof.sense(data).time == 0.0 and not tof.due(0.05)


# -- validation --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("overrides", "match"),
    [
        ({"fps": 46.0}, "fps"),
        ({"fps": 0.0}, "fps"),
        ({"width": 0}, "width"),
        ({"height": -3}, "height"),
        ({"width": 2.5}, "width"),
        ({"h_fov_deg": 180.0}, "h_fov_deg"),
        ({"min_range": 4.0}, "min_range"),
        ({"noise_std_rel": -0.1}, "noise_std_rel"),
        ({"dropout": 1.0}, "dropout"),
        ({"site_names": ()}, "site_names"),
        ({"backend": "opengl"}, "backend"),
    ],
)
def test_bad_params_raise(overrides, match):
    with pytest.raises(ValueError, match=match):
        ToFParams(**overrides)


def test_bad_scale_raises():
    with pytest.raises(ValueError, match="scale"):
        ToFParams.at_scale(0.0)


def test_missing_site_is_named():
    model, _ = build()
    with pytest.raises(ValueError, match="tof_9"):
        ToFArray(model, ToFParams(site_names=("tof_0", "tof_9")))


# -- benchmark script --------------------------------------------------------------------------


@pytest.mark.slow
def test_bench_script_runs_end_to_end(tmp_path):
    root = Path(__file__).resolve().parents[2]
    out = tmp_path / "bench.md"
    env = {**os.environ, "PYTHONPATH": str(root)}
    cmd = [sys.executable, str(root / "scripts" / "bench_tof.py"), "--frames", "1", "--out"]
    subprocess.run([*cmd, str(out)], check=True, env=env, capture_output=True, timeout=300)
    text = out.read_text()
    assert "154,112" in text and "9,632" in text and "| numba |" in text
