"""numba kernels of ``AEFPolicy`` (``aef.py``): a cycle's decision in one call (``policy_step``).

The pieces are the readable path's (``Odometry``, ``to_frame``, ``boxes_in_frame`` in
``aef.py``; ``Fit.decide`` through ``_fit_kernel.decide_kernel``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

# numba's cache keys a compiled function on its own file only: after editing _fit_kernel.py or
# _avoidance_kernel.py, clear this file's cache (__pycache__/_aef_kernel*.nb*) or touch it, and
# change this file in the commit, so that a checkout's cached policy_step is compiled again
# (last: the walk-round revised for body v1, issue 22, 2026-12-05).
from neurocog_gym.locomotion._fit_kernel import MODE_NONE, decide_kernel

# ``policy_step``'s state: floats (``sf``) and integers (``si``); the fit's teacher follows
# (``_fit_kernel.TF_*`` from ``SF_TEACHER`` on, ``TI_*`` from ``SI_TEACHER`` on).
SF_VX, SF_VY, SF_X, SF_Y, SF_TEACHER = range(5)
"""The odometry's last world velocity (m/s) and position (m); then the teacher's floats."""
SI_CYCLES, SI_STARTED, SI_MODE, SI_TARGET, SI_HIT, SI_TEACHER = 0, 1, 2, 3, 4, 8
"""Cycles since the reset, whether the odometry has a velocity, the decision's mode and target,
each leg's box met (4, scratch); then the teacher's integers."""
# Rows of the (N_ROWS, 3) per-cycle buffer ``rows3``.
R_FEET, R_HIPS, R_THIGHS, R_KNEES, R_DIRECTION, R_SLOTS, R_PROVISION = 0, 4, 8, 12, 16, 20, 24
N_ROWS = 25
BAD_OBS, SMALL_BUFFER = -1, -2
"""``policy_step``'s return for an observation of the wrong sizes, for a ``boxes`` too small."""


@njit(cache=True)
def points_to_frame(points, c, s, ox, oy, out):
    """(3 N,) flat heading-frame points into ``out`` (N, 3): turned by (c, s), shifted (ox, oy)."""
    for i in range(out.shape[0]):
        x = float(points[3 * i])
        y = float(points[3 * i + 1])
        out[i, 0] = c * x - s * y + ox
        out[i, 1] = s * x + c * y + oy
        out[i, 2] = float(points[3 * i + 2])


@njit(cache=True)
def rows_to_boxes(rows, c, s, ox, oy, out):
    """The valid ``remembered_blocks`` rows ((7 M,) flat) as min/max corners into ``out`` (M, 2, 3).

    Returns:
        How many rows were valid (filled from ``out[0]`` on, in row order).
    """
    k = 0
    for m in range(out.shape[0]):
        r = 7 * m
        if not rows[r] > 0.5:
            continue
        x, y = float(rows[r + 1]), float(rows[r + 2])
        cb, sb = np.cos(float(rows[r + 3])), np.sin(float(rows[r + 3]))
        hl, hw = float(rows[r + 4]), float(rows[r + 5])
        lo_x, lo_y, hi_x, hi_y = np.inf, np.inf, -np.inf, -np.inf
        for a in (-1.0, 1.0):
            for b in (-1.0, 1.0):
                px = x + cb * a * hl - sb * b * hw
                py = y + sb * a * hl + cb * b * hw
                wx = c * px - s * py + ox
                wy = s * px + c * py + oy
                lo_x, hi_x = min(lo_x, wx), max(hi_x, wx)
                lo_y, hi_y = min(lo_y, wy), max(hi_y, wy)
        out[k, 0, 0], out[k, 0, 1], out[k, 0, 2] = lo_x, lo_y, 0.0
        out[k, 1, 0], out[k, 1, 1], out[k, 1, 2] = hi_x, hi_y, float(rows[r + 6])
        k += 1
    return k


@njit(cache=True)
def odometry_step(quat, lin_vel, dt, v_prev, has_prev, position):
    """One odometry cycle: the yaw of ``quat`` (w, x, y, z), and ``position`` ((2,), updated).

    ``lin_vel`` (3,) is the torso-frame velocity; its world x, y go into ``v_prev`` ((2,),
    updated); with ``has_prev`` the position advances by the trapezoidal rule over ``dt``.
    """
    w, x, y, z = float(quat[0]), float(quat[1]), float(quat[2]), float(quat[3])
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    u, v, q = float(lin_vel[0]), float(lin_vel[1]), float(lin_vel[2])
    vx = (1 - 2 * (y * y + z * z)) * u + 2 * (x * y - w * z) * v + 2 * (x * z + w * y) * q
    vy = 2 * (x * y + w * z) * u + (1 - 2 * (x * x + z * z)) * v + 2 * (y * z - w * x) * q
    if has_prev:
        position[0] += 0.5 * dt * (v_prev[0] + vx)
        position[1] += 0.5 * dt * (v_prev[1] + vy)
    v_prev[0] = vx
    v_prev[1] = vy
    return yaw


@njit(cache=True)
def policy_step(
    torso_quat, torso_lin_vel, leg_joints, feet, remembered_blocks, block_met,
    interrupt_direction, aef_input, dt, par, front_legs, in_norm, sf, si, known, known_sudden,
    inlane, geometry, rows3, boxes, x_norm,
):  # fmt: skip
    """One ``AEFPolicy`` cycle up to the network: odometry, frames, the fit's decision, the input.

    What ``AEFPolicy.__call__`` did in NumPy before the forward pass (``Odometry.update``,
    ``to_frame``, ``boxes_in_frame``, ``Fit.decide``, the input with the decision's slots), in
    the same floating-point operations, so bit for bit.

    Args:
        torso_quat: (4,) the observation's (w, x, y, z).
        torso_lin_vel: (3,) the observation's, torso frame, m/s.
        leg_joints: (36,) the observation's hip, thigh and knee positions per leg, heading frame.
        feet: (12,) the observation's sole centres, heading frame, m.
        remembered_blocks: (7 M,) the observation's rows (``boxes_in_frame``).
        block_met: (4,) the observation's box met per leg, -1 none.
        interrupt_direction: (12,) the observation's v^l.
        aef_input: (31,) the observation's network input.
        dt: the control cycle, s.
        par: (``_fit_kernel.N_PARAMS``,) the fit's parameters (``fit.kernel_params``).
        front_legs: (2,) int64, the front legs.
        in_norm: (2, 31) the network's input mean and standard deviation.
        sf: float64 state (``SF_*``), updated.
        si: int64 state (``SI_*``), updated; ``si[SI_MODE]``, ``si[SI_TARGET]`` the decision's.
        known: (M, 2) the teacher's box centres, updated.
        known_sudden: (M,) bool, the teacher's, updated.
        inlane: (4,) bool scratch.
        geometry: (4 + ``_avoidance_kernel.N_OUT``,) scratch: the teacher's gaps and outputs.
        rows3: (N_ROWS, 3) written: feet, hips, thighs, knees, interrupt directions (odometry
            frame, ``R_*``), the decision's slots (4 rows) and provision (1 row).
        boxes: (M, 2, 3) written: the valid remembered boxes, odometry frame, from row 0.
        x_norm: (31,) written unless the mode is none: the network's normalised input.

    Returns:
        The mode (``fit.MODE_*``); ``BAD_OBS`` or ``SMALL_BUFFER`` (nothing updated).
    """
    n_rows = remembered_blocks.size // 7
    if (
        torso_quat.size != 4 or torso_lin_vel.size != 3 or leg_joints.size != 36
        or feet.size != 12 or remembered_blocks.size != 7 * n_rows or block_met.size != 4
        or interrupt_direction.size != 12 or aef_input.size != 31
    ):  # fmt: skip
        return BAD_OBS
    if n_rows > boxes.shape[0]:
        return SMALL_BUFFER
    yaw = odometry_step(torso_quat, torso_lin_vel, dt, sf[SF_VX:SF_X], si[SI_STARTED] != 0,
                        sf[SF_X:SF_TEACHER])  # fmt: skip
    si[SI_STARTED] = 1
    t = si[SI_CYCLES] * dt
    si[SI_CYCLES] += 1
    c, s = np.cos(yaw), np.sin(yaw)
    ox, oy = sf[SF_X], sf[SF_Y]
    points_to_frame(feet, c, s, ox, oy, rows3[R_FEET:R_HIPS])
    for leg in range(4):
        for j in range(3):
            i = 3 * (3 * leg + j)
            x, y = float(leg_joints[i]), float(leg_joints[i + 1])
            r = R_HIPS + 4 * j + leg  # hips, thighs, knees: four rows each
            rows3[r, 0] = c * x - s * y + ox
            rows3[r, 1] = s * x + c * y + oy
            rows3[r, 2] = float(leg_joints[i + 2])
    k = rows_to_boxes(remembered_blocks, c, s, ox, oy, boxes[:n_rows])
    hit = si[SI_HIT:SI_TEACHER]
    for leg in range(4):
        h = np.int64(np.rint(float(block_met[leg])))
        hit[leg] = -1 if h >= k else h
        for a in range(3):
            rows3[R_DIRECTION + leg, a] = float(interrupt_direction[3 * leg + a])
    mode, target = decide_kernel(
        t, yaw, rows3[R_DIRECTION:R_SLOTS], hit, rows3[R_FEET:R_HIPS], rows3[R_HIPS:R_THIGHS],
        rows3[R_THIGHS:R_KNEES], rows3[R_KNEES:R_DIRECTION], boxes[:k], front_legs, par,
        sf[SF_TEACHER:], si[SI_TEACHER:], known, known_sudden, inlane, geometry[:4],
        geometry[4:], rows3[R_PROVISION], rows3[R_SLOTS:R_PROVISION],
    )  # fmt: skip
    si[SI_MODE] = mode
    si[SI_TARGET] = target
    if mode != MODE_NONE:
        for i in range(31):
            if 3 <= i < 15:
                # The slots at the observation's precision, as the env handed them to the net.
                v = float(np.float32(rows3[R_SLOTS + (i - 3) // 3, (i - 3) % 3]))
            else:
                v = float(aef_input[i])
            x_norm[i] = (v - in_norm[0, i]) / in_norm[1, i]
    return mode
