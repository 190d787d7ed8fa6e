"""The env's compiled per-cycle checks against the NumPy expressions they replace."""

from __future__ import annotations

import numpy as np
import pytest

from neurocog_gym.envs._kernels import abs_power, clip_action, fault_check
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
        out = np.empty(15)
        assert clip_action(a, out)
        expect = np.minimum(np.maximum(a.astype(np.float64), -1.0), 1.0)
        assert out.tobytes() == expect.tobytes()


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_clip_action_refuses_non_finite(bad):
    a = np.zeros(15, np.float32)
    a[4] = bad
    assert not clip_action(a, np.empty(15))


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
