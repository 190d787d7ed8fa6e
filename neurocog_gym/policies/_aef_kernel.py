"""numba kernels of ``AEFPolicy`` (``aef.py``): observed positions into the odometry frame."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def points_to_frame(points, c, s, ox, oy, out):
    """(N, 3) heading-frame points into ``out``, turned by the heading (c, s), shifted (ox, oy)."""
    for i in range(points.shape[0]):
        x = float(points[i, 0])
        y = float(points[i, 1])
        out[i, 0] = c * x - s * y + ox
        out[i, 1] = s * x + c * y + oy
        out[i, 2] = float(points[i, 2])


@njit(cache=True)
def rows_to_boxes(rows, c, s, ox, oy, out):
    """The valid ``remembered_blocks`` rows ((M, 7)) as min/max corners into ``out`` ((M, 2, 3)).

    Returns:
        How many rows were valid (filled from ``out[0]`` on, in row order).
    """
    k = 0
    for m in range(rows.shape[0]):
        if not rows[m, 0] > 0.5:
            continue
        x, y = float(rows[m, 1]), float(rows[m, 2])
        cb, sb = np.cos(float(rows[m, 3])), np.sin(float(rows[m, 3]))
        hl, hw = float(rows[m, 4]), float(rows[m, 5])
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
        out[k, 1, 0], out[k, 1, 1], out[k, 1, 2] = hi_x, hi_y, float(rows[m, 6])
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
