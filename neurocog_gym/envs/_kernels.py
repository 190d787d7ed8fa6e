"""numba kernels of the env's per-cycle checks."""

from __future__ import annotations

import math

from numba import njit


@njit(cache=True)
def fault_check(qpos, qvel, warning_number, fault_ids, seen, vel_limit):  # pragma: no cover
    """The physics-fault test of one control cycle.

    Args:
        qpos: (nq,) float64 positions.
        qvel: (nv,) float64 velocities.
        warning_number: (nwarn,) int counts of each MuJoCo warning (``data.warning.number``).
        fault_ids: (k,) int64 the warnings that count as faults.
        seen: number of fault warnings counted at the previous check.
        vel_limit: largest |qvel| of a sound state.

    Returns:
        ``(unstable, count)``: whether a new fault warning was raised, a position is NaN or
        inf, or a velocity is NaN, inf or beyond ``vel_limit``; and the fault-warning count.
    """
    count = 0
    for i in fault_ids:
        count += warning_number[i]
    s = 0.0
    for x in qpos:
        s += x
    unstable = count > seen or not math.isfinite(s)
    for x in qvel:
        if not abs(x) <= vel_limit:
            unstable = True
    return unstable, count


@njit(cache=True)
def clip_action(action, out):  # pragma: no cover - compiled
    """``out[:] = clip(action, -1, 1)`` as float64; False (``out`` partly written) on a NaN/inf."""
    for i in range(action.shape[0]):
        x = action[i]
        if not math.isfinite(x):
            return False
        out[i] = min(max(x, -1.0), 1.0)
    return True


@njit(cache=True)
def abs_power(force, vel):  # pragma: no cover - compiled
    """Sum of |force * vel| over 8 to 128 joints, W, in NumPy's pairwise summation order.

    ``np.abs(force * vel).sum()`` for such n: eight running sums of strided terms, combined as
    ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7)), then the remaining n mod 8 terms one by
    one (the reward's energy term keeps its bits; checked against NumPy in the tests).
    """
    n = force.shape[0]
    r0 = abs(force[0] * vel[0])
    r1 = abs(force[1] * vel[1])
    r2 = abs(force[2] * vel[2])
    r3 = abs(force[3] * vel[3])
    r4 = abs(force[4] * vel[4])
    r5 = abs(force[5] * vel[5])
    r6 = abs(force[6] * vel[6])
    r7 = abs(force[7] * vel[7])
    full = n - n % 8
    for i in range(8, full, 8):
        r0 += abs(force[i] * vel[i])
        r1 += abs(force[i + 1] * vel[i + 1])
        r2 += abs(force[i + 2] * vel[i + 2])
        r3 += abs(force[i + 3] * vel[i + 3])
        r4 += abs(force[i + 4] * vel[i + 4])
        r5 += abs(force[i + 5] * vel[i + 5])
        r6 += abs(force[i + 6] * vel[i + 6])
        r7 += abs(force[i + 7] * vel[i + 7])
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    for i in range(full, n):
        res += abs(force[i] * vel[i])
    return res
