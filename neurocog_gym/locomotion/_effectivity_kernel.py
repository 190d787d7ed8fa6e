"""numba kernel of the effectivity (``effectivity.py``): one control cycle in one call.

The Python class owns the state arrays and the parameters; this module holds the arithmetic, so
a cycle costs one compiled call instead of a few hundred small NumPy operations. The reference
it was checked against, operation for operation, is ``tests/locomotion/effectivity_oracle.py``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

PHASE_NONE = 0
PHASE_UP = 1
PHASE_OVER = 2

# Index of each parameter in the packed float64 vector handed to the kernel.
(
    P_REACH, P_SWING_TIME, P_MIN_TIME_LEFT, P_CLEARANCE, P_FOOT_RADIUS, P_MARGIN, P_TOUCH_OFF,
    P_LIFT_SPEED, P_CARRY_SPEED, P_LIFT_CLEARANCE, P_APPROACH_GAP, P_MAX_INTERRUPT_TIME,
    P_FORGET_BEHIND, P_FORGET_DISTANCE,
) = range(14)  # fmt: skip
N_PARAMS = 14


@njit(cache=True)
def _overlap(a, b) -> bool:
    for c in range(3):
        if a[0, c] > b[1, c] or b[0, c] > a[1, c]:
            return False
    return True


@njit(cache=True)
def _along(box, hx, hy):
    """Smallest and largest projection of a box's four footprint corners on (hx, hy)."""
    lo = np.inf
    hi = -np.inf
    for i in range(2):
        for j in range(2):
            a = box[i, 0] * hx + box[j, 1] * hy
            lo = min(lo, a)
            hi = max(hi, a)
    return lo, hi


@njit(cache=True)
def remember_kernel(memory, n_memory, boxes, foot, torso, hx, hy, forget_behind, forget_distance):
    """Merge ``boxes`` into ``memory[:n_memory]`` in place and return the new count.

    A remembered box that overlaps a new one is replaced by it; new boxes go after the kept
    ones; a box is forgotten once the rearmost foot is ``forget_behind`` past its far face
    (along the heading (hx, hy)) or its centre is ``forget_distance`` from ``torso``. When more
    boxes survive than ``memory`` holds, the oldest are dropped.
    """
    cap = memory.shape[0]
    nb = boxes.shape[0]
    merged = np.empty((n_memory + nb, 2, 3))
    n = 0
    for m in range(n_memory):
        hit = False
        for b in range(nb):
            if _overlap(memory[m], boxes[b]):
                hit = True
                break
        if not hit:
            merged[n] = memory[m]
            n += 1
    for b in range(nb):
        merged[n] = boxes[b]
        n += 1
    f_min = np.inf
    for leg in range(foot.shape[0]):
        f_min = min(f_min, foot[leg, 0] * hx + foot[leg, 1] * hy)
    keep = np.empty(n, dtype=np.int64)
    k = 0
    for m in range(n):
        _, far = _along(merged[m], hx, hy)
        if f_min > far + forget_behind:
            continue
        dx = (merged[m, 0, 0] + merged[m, 1, 0]) / 2.0 - torso[0]
        dy = (merged[m, 0, 1] + merged[m, 1, 1]) / 2.0 - torso[1]
        if np.sqrt(dx * dx + dy * dy) > forget_distance:
            continue
        keep[k] = m
        k += 1
    start = max(0, k - cap)
    for i in range(start, k):
        memory[i - start] = merged[keep[i]]
    return k - start


@njit(cache=True)
def _steer(prm, phase, leg, box, foot, hx, hy, out):
    """Wanted world foot velocity of an interrupted leg, written into ``out``.

    Returns False when the foot is past its box: the interrupt ends and the CPG sets it down.
    """
    near, far = _along(box, hx, hy)
    f = foot[0] * hx + foot[1] * hy
    d_near = near - f
    d_far = far - f
    r = prm[P_FOOT_RADIUS]
    if d_far + r < 0.0:
        return False
    sole = foot[2] - r
    top = box[1, 2] + prm[P_LIFT_CLEARANCE]
    if phase[leg] == PHASE_UP and sole >= top:
        phase[leg] = PHASE_OVER
    if phase[leg] == PHASE_UP:
        # Hold the ground position while rising; back off if too close to the face.
        gap = d_near - r - prm[P_APPROACH_GAP]
        vx = min(max(4.0 * gap, -0.4), 0.0)
        out[0] = vx * hx
        out[1] = vx * hy
        out[2] = prm[P_LIFT_SPEED]
        return True
    # Over: forward, holding the sole above the top.
    vz = min(max(8.0 * (top + 0.01 - sole), -0.2), prm[P_LIFT_SPEED])
    out[0] = prm[P_CARRY_SPEED] * hx
    out[1] = prm[P_CARRY_SPEED] * hy
    out[2] = vz
    return True


@njit(cache=True)
def effectivity_kernel(
    prm, s_path, t, touch, foot, hip, yaw, vx_body, vy_body, boxes,
    lift_time, was_down, phase, plan_box, plan_start, memory, n_memory,
    swinging, foothold, foothold_safe, path_safe, direction, hit,
):  # fmt: skip
    """One effectivity cycle (see ``Effectivity`` for the model).

    State arrays (``lift_time`` .. ``memory``) are updated in place; the outputs (``swinging``
    .. ``hit``) are written: ``hit`` (4,) int64 is the memory index of the box each leg's
    foothold lies in (first) or its swing path meets, -1 none.

    Returns:
        The new ``n_memory``.
    """
    hx, hy = np.cos(yaw), np.sin(yaw)
    lx, ly = -hy, hx
    tx = (hip[0, 0] + hip[1, 0] + hip[2, 0] + hip[3, 0]) / 4.0
    ty = (hip[0, 1] + hip[1, 1] + hip[2, 1] + hip[3, 1]) / 4.0
    torso = np.array([tx, ty])
    n_mem = remember_kernel(
        memory, n_memory, boxes, foot, torso, hx, hy, prm[P_FORGET_BEHIND], prm[P_FORGET_DISTANCE]
    )
    # Swing timing: a leg swings from lift-off until touch-down.
    for leg in range(4):
        down = touch[leg] > prm[P_TOUCH_OFF]
        if was_down[leg] and not down:
            lift_time[leg] = t
        was_down[leg] = down
        swinging[leg] = not down
    # Footholds: the rest of a nominal swing of the body at its current velocity.
    for leg in range(4):
        if swinging[leg]:
            t_left = max(prm[P_SWING_TIME] - (t - lift_time[leg]), prm[P_MIN_TIME_LEFT])
            foothold[leg, 0] = hip[leg, 0] + prm[P_REACH] * hx + vx_body * t_left
            foothold[leg, 1] = hip[leg, 1] + prm[P_REACH] * hy + vy_body * t_left
            foothold[leg, 2] = 0.0
        else:
            foothold[leg] = foot[leg]
    # Safety of footholds and swing paths against the remembered boxes grown by the margin.
    margin = prm[P_MARGIN]
    r = prm[P_FOOT_RADIUS]
    clearance4 = 4.0 * prm[P_CLEARANCE]
    hit[:] = -1
    foothold_safe[:] = True
    path_safe[:] = True
    for leg in range(4):
        for k in range(n_mem):
            if (
                foothold[leg, 0] >= memory[k, 0, 0] - margin
                and foothold[leg, 1] >= memory[k, 0, 1] - margin
                and foothold[leg, 0] <= memory[k, 1, 0] + margin
                and foothold[leg, 1] <= memory[k, 1, 1] + margin
            ):
                foothold_safe[leg] = False
                hit[leg] = k
                break
        if not swinging[leg] or n_mem == 0:
            continue
        first = -1
        for k in range(n_mem):
            for i in range(s_path.shape[0]):
                s = s_path[i]
                inside = True
                for c in range(3):
                    x = (1.0 - s) * foot[leg, c] + s * foothold[leg, c]
                    if c == 2:
                        x += clearance4 * s * (1.0 - s)
                    if x < memory[k, 0, c] - margin - r or x > memory[k, 1, c] + margin + r:
                        inside = False
                        break
                if inside:
                    first = k
                    break
            if first >= 0:
                break
        if first >= 0:
            path_safe[leg] = False
            if hit[leg] < 0:
                hit[leg] = first
    # Interrupts in progress end at touch-down (after a short grace) or on time-out.
    for leg in range(4):
        if phase[leg] != PHASE_NONE:
            age = t - plan_start[leg]
            if age > prm[P_MAX_INTERRUPT_TIME] or (not swinging[leg] and age > 0.08):
                phase[leg] = PHASE_NONE
    # New interrupts: a swinging leg whose path or foothold meets a box.
    for leg in range(4):
        conflict = swinging[leg] and not (foothold_safe[leg] and path_safe[leg])
        if conflict and phase[leg] == PHASE_NONE:
            phase[leg] = PHASE_UP
            plan_box[leg, 0] = memory[hit[leg], 0] - margin
            plan_box[leg, 1] = memory[hit[leg], 1] + margin
            plan_start[leg] = t
    direction[:] = 0.0
    wanted = np.empty(3)
    for leg in range(4):
        if phase[leg] == PHASE_NONE:
            continue
        if not _steer(prm, phase, leg, plan_box[leg], foot[leg], hx, hy, wanted):
            phase[leg] = PHASE_NONE  # past the block: the CPG sets the foot down
            continue
        rx = wanted[0] - vx_body  # relative to the torso
        ry = wanted[1] - vy_body
        direction[leg, 0] = rx * hx + ry * hy
        direction[leg, 1] = rx * lx + ry * ly
        direction[leg, 2] = wanted[2]
    return n_mem
