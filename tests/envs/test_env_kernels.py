"""The env's compiled per-cycle checks against the NumPy expressions they replace."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from neurocog_gym.envs._kernels import abs_power, clip_action_groups, fault_check
from neurocog_gym.envs.base import _as_slice
from neurocog_gym.robot.obstacles import _touching_kernel

FAULTS = np.array([5, 3, 4, 1, 2], dtype=np.int64)


def test_fault_check_sound_state_counts_the_fault_warnings():
    warn = np.array([9, 1, 2, 0, 0, 3, 7], dtype=np.int32)  # 0 and 6 are not faults
    unstable, count = fault_check(np.zeros(19), np.full(18, 999.0), warn, FAULTS, 6, 1e3)
    assert (unstable, count) == (False, 6)


@pytest.mark.parametrize(
    "qpos_bad, qvel_bad, seen",
    [
        (np.nan, None, 6),  # NaN position
        (np.inf, None, 6),  # infinite position
        (None, np.nan, 6),  # NaN velocity
        (None, -1000.5, 6),  # velocity beyond the limit
        (None, None, 5),  # a new fault warning since the last check
    ],
)
def test_fault_check_flags_each_fault(qpos_bad, qvel_bad, seen):
    qpos, qvel = np.zeros(19), np.zeros(18)
    if qpos_bad is not None:
        qpos[7] = qpos_bad
    if qvel_bad is not None:
        qvel[11] = qvel_bad
    warn = np.array([0, 1, 2, 0, 0, 3, 0], dtype=np.int32)
    unstable, count = fault_check(qpos, qvel, warn, FAULTS, seen, 1e3)
    assert unstable and count == 6


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_clip_action_matches_numpy(dtype):
    rng = np.random.default_rng(0)
    for _ in range(200):
        a = (rng.normal(size=15) * 2).astype(dtype)
        a[rng.integers(15)] = -0.0
        if rng.random() < 0.3:
            a[rng.integers(2) * 12 :][:12] = 0.0  # one group all zero
        out = np.empty(15)
        groups = clip_action_groups(a, out, 12)
        expect = np.minimum(np.maximum(a.astype(np.float64), -1.0), 1.0)
        assert out.tobytes() == expect.tobytes()
        assert groups == int(expect[:12].any()) + 2 * int(expect[12:].any())


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_clip_action_refuses_non_finite(bad):
    a = np.zeros(15, np.float32)
    a[4] = bad
    assert clip_action_groups(a, np.empty(15), 12) == -1


@pytest.mark.parametrize("n", [8, 12, 15, 16, 23, 64, 128])
def test_abs_power_is_numpys_sum_bit_for_bit(n):
    rng = np.random.default_rng(n)
    for _ in range(500):
        f = rng.normal(size=n) * rng.uniform(0, 50)
        v = rng.normal(size=n) * rng.uniform(0, 10)
        assert abs_power(f, v) == float(np.abs(f * v).sum())


def test_touching_kernel_marks_blocks_in_contact_with_the_robot():
    # geoms 0-3 robot, 4-6 block slots 0-2, 7 the floor
    slot_of = np.array([-1, -1, -1, -1, 0, 1, 2, -1], dtype=np.int64)
    is_robot = np.array([1, 1, 1, 1, 0, 0, 0, 0], dtype=bool)
    contacts = np.array(
        [
            [7, 4],  # block 0 on the floor: not the robot
            [2, 5],  # block 1 touched by the robot (robot geom first)
            [6, 0],  # block 2 touched (block first) ...
            [7, 1],  # robot on the floor
        ],
        dtype=np.int32,
    )
    hit = np.zeros(3, dtype=bool)
    assert _touching_kernel(contacts, slot_of, is_robot, 3, hit)
    assert hit.tolist() == [False, True, True]
    hit = np.zeros(3, dtype=bool)
    assert _touching_kernel(contacts, slot_of, is_robot, 2, hit)  # ... but slot 2 is not placed
    assert hit.tolist() == [False, True, False]
    hit = np.zeros(3, dtype=bool)
    assert not _touching_kernel(contacts[[0, 3]], slot_of, is_robot, 3, hit)  # floor only
    assert not hit.any()


def test_as_slice_only_for_runs():
    assert _as_slice(np.array([7, 8, 9])) == slice(7, 10)
    ix = np.array([2, 5, 8])
    assert isinstance(_as_slice(ix), np.ndarray) and np.array_equal(_as_slice(ix), ix)
    x = np.arange(20.0)
    assert np.array_equal(x[_as_slice(np.arange(3, 15))], x[np.arange(3, 15)])


# -- outcome v1 kernels -------------------------------------------------------------------------


def _pose(yaw=0.0, pos=(0.0, 0.0, 0.035)):
    """One body (id 0) at ``pos`` turned by ``yaw``: xpos (1, 3), xmat (1, 9), xquat (1, 4)."""
    c, s = np.cos(yaw), np.sin(yaw)
    xmat = np.array([[c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0]])
    xquat = np.array([[np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]])
    return np.array([pos], dtype=float), xmat, xquat


HALF = np.array([[0.04, 0.10, 0.035]])  # an 8 x 20 x 7 cm block


def _walk(path, yaw=0.0, heading=(1.0, 0.0)):
    """Run step_over_step along one foot's path (the other three feet stay far behind)."""
    from neurocog_gym.envs._kernels import step_over_step

    xpos, xmat, _ = _pose(yaw)
    state = np.full((1, 4), -1, np.int8)
    crossed = np.zeros((1, 4), bool)
    sign = np.ones(1)
    prev = np.zeros((4, 3))
    for i, (x, y) in enumerate(path):
        feet = np.array([[x, y, 0.02], [-1.0, 0, 0], [-1.0, 0, 0], [-1.0, 0, 0]])
        step_over_step(feet, prev, i > 0, np.array(heading), 1, np.array([0]), xpos, xmat,
                       HALF, sign, state, crossed)  # fmt: skip
        prev = feet
    return bool(crossed[0, 0])


def _line(a, b, n=40):
    return [tuple(a + (b - a) * t) for t in np.linspace(0, 1, n)]


def test_step_over_a_foot_path_over_the_block_crosses_it():
    over = _line(np.array([-0.2, 0.0]), np.array([0.2, 0.05]))
    assert _walk(over)
    # One long stride from before the near face to beyond the far face (no sample above it):
    # the straight segment stays within the width, so it crossed above the block.
    assert _walk([(-0.1, 0.0), (0.1, 0.02)])


def test_walking_round_the_block_is_not_stepping_over_it():
    a, b, c, d = map(np.array, ([-0.2, 0.0], [-0.06, 0.0], [-0.06, 0.15], [0.2, 0.15]))
    assert not _walk(_line(a, b) + _line(b, c) + _line(c, d))
    # Round it, then sideways back behind the far face: never above the footprint.
    assert not _walk(_line(a, b) + _line(b, c) + _line(c, d) + _line(d, np.array([0.2, 0.0])))
    # Over the near part of the block, then out at its side before the far face.
    e = np.array([0.0, 0.13])
    assert not _walk(_line(a, b) + _line(b, e) + _line(e, np.array([0.2, 0.13])))
    # A diagonal stride whose straight segment leaves the width over the length.
    assert not _walk([(-0.1, 0.0), (0.1, 0.25)])


def test_step_over_follows_the_block_frame_and_the_walking_direction():
    yaw = 0.3
    c, s = np.cos(yaw), np.sin(yaw)
    along = [(u * c, u * s) for u in np.linspace(-0.2, 0.2, 40)]
    assert _walk(along, yaw=yaw)
    # Walking the other way (heading -x): the far face is the other one, the path goes backward.
    assert not _walk(along, yaw=yaw, heading=(-1.0, 0.0))
    assert _walk(along[::-1], yaw=yaw, heading=(-1.0, 0.0))
    # A foot that starts over the block (not before its near face) is never armed.
    assert not _walk(_line(np.array([0.0, 0.0]), np.array([0.2, 0.0])))


def _outcome_step(contacts, xpos, xmat, xquat, state, placed=None, mass_g=40.0):
    """block_outcome_step with geom 0 = block slot 0 and geom 1 = a robot geom."""
    from neurocog_gym.envs._kernels import block_outcome_step

    geom, pos, frame, force = contacts
    n = len(force)  # contacts
    placed_pos, placed_quat = placed if placed is not None else (xpos.copy(), xquat.copy())
    return block_outcome_step(
        np.array(geom, np.int32).reshape(n, 2), np.array(pos, float).reshape(n, 3),
        np.array(frame, float).reshape(n, 9), np.arange(n, dtype=np.int32) * 4,
        np.full(n, 3, np.int32), np.repeat(np.array(force, float) / 4, 4), False,
        np.array([0, -1]), np.array([False, True]), 1, np.array([0]), xpos, xmat, xquat, HALF,
        placed_pos, placed_quat, np.cos(np.radians(30)), 0.01, 0.1 * mass_g, 3, 0.02,
        np.cos(np.radians(10) / 2), *state,
    )  # fmt: skip


def _fresh():
    return (np.zeros(1, bool), np.zeros(1), np.zeros(1, np.int64), np.zeros(1, bool),
            np.zeros(1), np.zeros(1), np.zeros(1, bool))  # fmt: skip


UP = [0, 0, 1, 1, 0, 0, 0, 1, 0]
SIDE = [-1, 0, 0, 0, 1, 0, 0, 0, 1]


def test_stood_on_needs_weight_on_the_top_face_for_three_cycles():
    xpos, xmat, xquat = _pose()
    state = _fresh()
    top = ([0, 1], [0.01, 0.02, 0.07], UP, [5.0])  # 5 N >= 10 % of 40 N, on the top face
    for cycle in range(3):
        assert _outcome_step(top, xpos, xmat, xquat, state)
        assert state[0][0] and state[1][0] == pytest.approx(5.0)
        assert state[3][0] == (cycle == 2)  # stood on at the third cycle in a row
    # Geoms in the other order: the normal points from the robot down to the block.
    state = _fresh()
    down = [0, 0, -1, 1, 0, 0, 0, -1, 0]
    for _ in range(3):
        _outcome_step(([1, 0], [0.0, 0.0, 0.07], down, [5.0]), xpos, xmat, xquat, state)
    assert state[3][0]


@pytest.mark.parametrize(
    "contact",
    [
        ([0, 1], [0.01, 0.02, 0.07], UP, [3.0]),  # too light: 3 N < 4 N
        ([0, 1], [-0.04, 0.0, 0.03], SIDE, [30.0]),  # a side push, however hard
        ([0, 1], [0.01, 0.02, 0.05], UP, [30.0]),  # 2 cm under the top face
        ([0, 1], [0.08, 0.0, 0.07], UP, [30.0]),  # beyond the face's edge
    ],
)
def test_no_stand_without_weight_on_the_top_face(contact):
    xpos, xmat, xquat = _pose()
    state = _fresh()
    for _ in range(5):
        assert _outcome_step(contact, xpos, xmat, xquat, state)  # touching all the same
    assert not state[3][0] and state[2][0] == 0


def test_a_weight_that_lifts_resets_the_run():
    xpos, xmat, xquat = _pose()
    state = _fresh()
    top = ([0, 1], [0.0, 0.0, 0.07], UP, [5.0])
    none = ([], [], [], [])
    for c in (top, top, none, top, top):
        _outcome_step(c, xpos, xmat, xquat, state)
    assert not state[3][0] and state[2][0] == 2


@pytest.mark.parametrize(
    ("shift", "yaw", "tilt_deg", "knocked"),
    [
        ((0.015, 0.0), 0.0, 0.0, False),
        ((0.015, 0.015), 0.0, 0.0, True),  # 2.1 cm
        ((0.0, 0.0), np.radians(9.0), 0.0, False),
        ((0.0, 0.0), np.radians(11.0), 0.0, True),
        ((0.0, 0.0), 0.0, 11.0, True),  # tipped about x: any axis counts
        ((0.0, 0.0), 0.0, 9.0, False),
    ],
)
def test_knocked_when_moved_two_cm_or_turned_ten_degrees(shift, yaw, tilt_deg, knocked):
    xpos0, xmat0, xquat0 = _pose(0.1)
    placed = (xpos0.copy(), xquat0.copy())
    # The block now: shifted, turned about z by yaw, then tipped about x by tilt.
    q_yaw = np.array([np.cos((0.1 + yaw) / 2), 0, 0, np.sin((0.1 + yaw) / 2)])
    t = np.radians(tilt_deg) / 2
    q = np.empty(4)
    mujoco.mju_mulQuat(q, q_yaw, np.array([np.cos(t), np.sin(t), 0, 0]))
    mat = np.empty(9)
    mujoco.mju_quat2Mat(mat, q)
    xpos = xpos0 + np.array([[shift[0], shift[1], 0.0]])
    state = _fresh()
    assert not _outcome_step(([], [], [], []), xpos, mat[None], q[None], state, placed)
    assert state[6][0] == knocked
    assert state[4][0] == pytest.approx(np.hypot(*shift))


# -- heading-frame arithmetic and the fused per-cycle kernels ---------------------------------


def _rot(yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.0]).reshape(3, 3)


def test_heading_frame_arithmetic_is_numpys_bit_for_bit():
    """The kernels' fused multiply-add sums give NumPy's (BLAS's) float64 results exactly."""
    from numba import njit

    from neurocog_gym.envs._kernels import _dot3_down, _dot3_up

    @njit
    def both(p, t, c, s, rot, out):
        for i in range(p.shape[0]):
            dx, dy, dz = p[i, 0] - t[0], p[i, 1] - t[1], p[i, 2] - t[2]
            out[0, i, 0] = _dot3_up(c, s, 0.0, dx, dy, dz)
            out[0, i, 1] = _dot3_up(-s, c, 0.0, dx, dy, dz)
            out[1, i, 0] = _dot3_down(c, s, 0.0, dx, dy, dz)
            out[1, i, 1] = _dot3_down(-s, c, 0.0, dx, dy, dz)
            v = p[i]
            for j in range(3):
                out[2, i, j] = _dot3_up(rot[0, j], rot[1, j], rot[2, j], v[0], v[1], v[2])

    rng = np.random.default_rng(0)
    for trial in range(3000):
        yaw = rng.uniform(-4.0, 4.0)
        n = 2 + trial % 11
        p = rng.normal(size=(n, 3)) * rng.uniform(0.01, 5.0)
        t = rng.normal(size=3)
        r = _rot(yaw)
        m = rng.normal(size=(3, 3))
        out = np.empty((3, n, 3))
        both(p, t, r[0, 0], r[0, 1], m, out)
        gemm = (p - t) @ r.T  # (N >= 2, 3) @ (3, 3): BLAS gemm
        assert out[0, :, :2].tobytes() == gemm[:, :2].tobytes()
        gemv = np.stack([r @ (x - t) for x in p])  # (3, 3) @ (3,): gemv
        assert out[1, :, :2].tobytes() == gemv[:, :2].tobytes()
        gemv_t = np.stack([m.T @ x for x in p])  # transposed gemv
        assert out[2].tobytes() == gemv_t.tobytes()


def test_outcome_cycle_is_the_two_kernels_and_the_pass_bounds():
    """``outcome_cycle`` = block_outcome_step + step_over_step + ObstaclePool.boxes' far x."""
    from neurocog_gym.envs._kernels import block_outcome_step, outcome_cycle, step_over_step

    rng = np.random.default_rng(1)
    nbody, ngeom, k = 6, 8, 3
    for _ in range(200):
        xpos = rng.normal(size=(nbody, 3))
        quat = rng.normal(size=(nbody, 4))
        quat /= np.linalg.norm(quat, axis=1, keepdims=True)
        xmat = np.empty((nbody, 9))
        for b in range(nbody):
            mujoco.mju_quat2Mat(xmat[b], quat[b])
        body_ids = np.array([3, 4, 5, 0], np.int64)
        half = rng.uniform(0.02, 0.2, size=(4, 3))
        slot_of = np.array([-1, -1, -1, -1, 0, 1, 2, 3], np.int64)
        is_robot = np.array([0, 1, 1, 1, 0, 0, 0, 0], bool)
        nc = 5
        geom = rng.integers(0, ngeom, size=(nc, 2)).astype(np.int32)
        pos = rng.normal(size=(nc, 3))
        frame = rng.normal(size=(nc, 9))
        efc_address = np.arange(nc, dtype=np.int32) * 3
        dim = np.full(nc, 3, np.int32)
        efc_force = rng.uniform(0, 20, size=3 * nc)
        feet = rng.normal(size=(4, 3))
        prev = rng.normal(size=(4, 3))
        heading = np.array([1.0, 0.0])
        placed_pos, placed_quat = xpos[body_ids] + 0.01, quat[body_ids]
        consts = (0.8, 0.01, 5.0, 3, 0.02, np.cos(np.radians(5.0)))

        def state():
            return [np.zeros(4, bool), np.zeros(4), np.zeros(4, np.int64), np.zeros(4, bool),
                    np.zeros(4), np.zeros(4), np.zeros(4, bool)]  # fmt: skip

        contacts = (geom, pos, frame, efc_address, dim, efc_force, False, slot_of, is_robot, k,
                    body_ids, xpos, xmat, quat, half, placed_pos, placed_quat)  # fmt: skip
        a, b = state(), state()
        over_a = (np.ones(4), np.full((4, 4), -1, np.int8), np.zeros((4, 4), bool))
        over_b = (np.ones(4), np.full((4, 4), -1, np.int8), np.zeros((4, 4), bool))
        is_front = np.array([True, True, False, False])
        over = np.zeros(4, bool)
        hit = block_outcome_step(*contacts, *consts, *a)
        step_over_step(feet, prev.copy(), True, heading, k, body_ids, xpos, xmat, half, *over_a)
        prev_b = prev.copy()
        res = outcome_cycle(*contacts, *consts, *b, feet, prev_b, True, heading, *over_b,
                            is_front, over)  # fmt: skip
        for x, y in zip(a + list(over_a), b + list(over_b), strict=True):
            assert x.tobytes() == y.tobytes()
        ids = body_ids[:k]
        ext = np.einsum("kij,kj->ki", np.abs(xmat[ids].reshape(k, 3, 3)), half[:k])
        far = float((xpos[ids] + ext)[:, 0].max())
        c = over_b[2][:k]
        expect_over = c[:, is_front].any(axis=1) & c[:, ~is_front].any(axis=1)
        assert res[0] == hit and res[1] == a[6][:k].any() and res[2] == a[3][:k].any()
        assert res[3] == far and res[4] == feet[:, 0].min()
        assert (over[:k] == expect_over).all()
        assert prev_b.tobytes() == feet.tobytes()


def test_as_stride_for_arithmetic_progressions():
    from neurocog_gym.envs.base import _as_stride

    assert _as_stride(np.array([2, 5, 8, 11])) == slice(2, 12, 3)
    assert _as_stride(np.array([4, 5, 6])) == slice(4, 7, 1)
    assert _as_stride(np.array([7])) == slice(7, 8)
    for index in ([2, 5, 9], [5, 3, 1], [3, 3]):
        assert (_as_stride(np.array(index)) == np.array(index)).all()
    x = np.arange(45.0).reshape(15, 3)
    assert (x[_as_stride(np.array([2, 5, 8, 11]))] == x[[2, 5, 8, 11]]).all()
