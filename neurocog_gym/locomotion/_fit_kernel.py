"""numba kernels of the fit (``fit.py``): the walk-round rule, the box the interrupts are for."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def walk_around_kernel(hip, front_legs, hx, hy, boxes, lookahead, near, corridor, provision):
    """Walking provision for the nearest box in the corridor ahead, written into ``provision``.

    Args:
        hip: (4, 3) hip positions, m; the corridor starts between the front legs' hips.
        front_legs: (2,) int64 indices of the front legs.
        hx: cos of the heading.
        hy: sin of the heading.
        boxes: (K, 2, 3) obstacle boxes (min/max corners), m.
        lookahead: ``FitParams.lookahead``, m.
        near: ``FitParams.near``, m.
        corridor: ``FitParams.corridor``, m.
        provision: (3,) written: (s_SAG, s_COR, s_DIR); zeros when no box counts.

    Only boxes whose near side lies beyond ``near`` and within ``lookahead`` ahead and that
    overlap the corridor count.

    Returns:
        The box's index, or -1.
    """
    fx = 0.0
    fy = 0.0
    for leg in front_legs:
        fx += hip[leg, 0]
        fy += hip[leg, 1]
    fx /= len(front_legs)
    fy /= len(front_legs)
    lx, ly = -hy, hx
    best = -1
    best_d = np.inf
    lateral = 0.0
    for k in range(boxes.shape[0]):
        a_lo, a_hi = np.inf, -np.inf
        s_lo, s_hi = np.inf, -np.inf
        for i in range(2):
            for j in range(2):
                rx = boxes[k, i, 0] - fx
                ry = boxes[k, j, 1] - fy
                a = rx * hx + ry * hy
                s = rx * lx + ry * ly
                a_lo, a_hi = min(a_lo, a), max(a_hi, a)
                s_lo, s_hi = min(s_lo, s), max(s_hi, s)
        if a_hi < 0.0 or a_lo > lookahead:
            continue
        # The box blocks the corridor if its lateral extent overlaps [-corridor, corridor].
        if s_lo > corridor or s_hi < -corridor:
            continue
        d = max(a_lo, 0.0)
        if d < near:
            continue
        if d < best_d:
            best, best_d = k, d
            # Move to the side that needs the shorter side step.
            go_left = abs(s_lo - corridor) > abs(s_hi + corridor)
            need = (s_hi + corridor) if go_left else (corridor - s_lo)
            lateral = (1.0 if go_left else -1.0) * min(1.0, 0.4 + 2.5 * need)
    provision[:] = 0.0
    if best >= 0:
        provision[0] = -0.3 if best_d < 0.6 else 0.0
        provision[1] = lateral
    return best


@njit(cache=True)
def interrupt_target(direction, hit, feet, boxes):
    """The box the interrupts are for, -1 when no leg is interrupted or there is no box.

    The box met by the last interrupted leg that meets one, else the box whose centre is nearest
    the feet's mean (ground plane).

    Args:
        direction: (4, 3) interrupt directions v^l; a leg with a non-zero row is interrupted.
        hit: (4,) int64 box each leg's foothold or swing path meets, -1 none.
        feet: (4, 3) foot positions, m.
        boxes: (K, 2, 3) obstacle boxes (min/max corners), m.
    """
    target = -1
    interrupted = False
    for leg in range(4):
        if direction[leg, 0] != 0.0 or direction[leg, 1] != 0.0 or direction[leg, 2] != 0.0:
            interrupted = True
            if hit[leg] >= 0:
                target = hit[leg]
    if not interrupted:
        return -1
    if target < 0 and boxes.shape[0] > 0:
        cx = (feet[0, 0] + feet[1, 0] + feet[2, 0] + feet[3, 0]) / 4.0
        cy = (feet[0, 1] + feet[1, 1] + feet[2, 1] + feet[3, 1]) / 4.0
        best_d = np.inf
        for k in range(boxes.shape[0]):
            dx = (boxes[k, 0, 0] + boxes[k, 1, 0]) / 2.0 - cx
            dy = (boxes[k, 0, 1] + boxes[k, 1, 1]) / 2.0 - cy
            d = np.sqrt(dx * dx + dy * dy)
            if d < best_d:
                best_d, target = d, k
    return target
