"""numba kernels of the fit (``fit.py``): the walk-round rule, the box the interrupts are for.

And the whole decision, with the stop / side-step / pass teacher (``avoidance.py``), in one
compiled call (``decide_kernel``): the policy's path (``policies.AEFPolicy``); ``Fit`` and
``SuddenAvoidance`` stay the readable one, and ``tests/policies/test_aef_compiled.py`` checks the
two give the same actions bit for bit.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# numba's cache keys a compiled function on its own file only: after editing
# _avoidance_kernel.py, touch this file (decide_kernel calls its kernels) and _aef_kernel.py.
from neurocog_gym.locomotion._avoidance_kernel import (
    O_CLOSE,
    O_FAR,
    O_GAP_IN,
    O_N_IN,
    O_N_REL,
    O_NEED_LEFT,
    O_NEED_RIGHT,
    PASS,
    REVERSE,
    SIDE,
    T_EPS,
    WALK,
    avoidance_geometry,
    sag_for_stride,
)


@njit(cache=True)
def walk_around_kernel(
    hip, feet, front_legs, hx, hy, boxes, lookahead, corridor, beside, cor_min, cor_gain,
    provision,
):  # fmt: skip
    """The walk-round rule's provision for the boxes on and beside the path, into ``provision``.

    Args:
        hip: (4, 3) hip positions, m; the corridor is centred between the front legs' hips.
        feet: (4, 3) sole centres, m; a box every foot is 3 cm past no longer counts.
        front_legs: (2,) int64 indices of the front legs.
        hx: cos of the path's heading (the teacher's first heading, ``SuddenAvoidance.yaw0``).
        hy: sin of the path's heading.
        boxes: (K, 2, 3) obstacle boxes (min/max corners), m.
        lookahead: ``FitParams.lookahead``, m.
        corridor: ``FitParams.corridor``, m.
        beside: ``FitParams.beside``, m.
        cor_min: ``FitParams.cor_min``.
        cor_gain: ``FitParams.cor_gain``, 1/m.
        provision: (3,) written: (s_SAG, s_COR, s_DIR); zeros when no box counts.

    A box counts from ``lookahead`` ahead of the front hips until every foot is past it, if it
    lies within ``corridor + beside`` of the corridor's centre line (across the path's
    heading). Each box is passed on the side that needs the shorter shift of the corridor; the
    shift that clears every box on its side (for a box alongside: keeps it clear) is stepped
    by s_COR = ±min(1, ``cor_min`` + ``cor_gain`` · shift). Where the boxes passed on the left
    and on the right leave no room between them, the nearest box decides. s_SAG and s_DIR
    stay 0.

    Returns:
        The index of the nearest box that counts, or -1.
    """
    fx = 0.0
    fy = 0.0
    for leg in front_legs:
        fx += hip[leg, 0]
        fy += hip[leg, 1]
    fx /= len(front_legs)
    fy /= len(front_legs)
    lx, ly = -hy, hx
    rear = np.inf
    for leg in range(4):
        rear = min(rear, (feet[leg, 0] - fx) * hx + (feet[leg, 1] - fy) * hy)
    band = corridor + beside
    lo = -np.inf  # the corridor's shift to the left must be at least this ...
    hi = np.inf  # ... and at most this
    best = -1
    best_d = np.inf
    best_left = True
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
        if a_hi < rear - 0.03 or a_lo > lookahead:
            continue
        if s_lo > band or s_hi < -band:
            continue
        need_left = s_hi + corridor
        need_right = corridor - s_lo
        go_left = need_left < need_right
        if go_left:
            lo = max(lo, need_left)
        else:
            hi = min(hi, -need_right)
        if a_lo < best_d:
            best, best_d, best_left = k, a_lo, go_left
    provision[:] = 0.0
    if best < 0:
        return -1
    shift = 0.0
    if lo > 0.0 and hi < 0.0:
        shift = lo if best_left else hi  # no room between them: the nearest box decides
    elif lo > 0.0:
        shift = lo
    elif hi < 0.0:
        shift = hi
    if shift > 0.0:
        provision[1] = min(1.0, cor_min + cor_gain * shift)
    elif shift < 0.0:
        provision[1] = -min(1.0, cor_min - cor_gain * shift)
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


# The compiled decision (``decide_kernel``): the fit's parameters in one float64 array
# (``fit.kernel_params``), the teacher's state in a float64 and an int64 array.
(
    P_LOOKAHEAD, P_BESIDE, P_CORRIDOR, P_ENABLED, P_TRIGGER, P_LANE_R, P_LANE_HYSTERESIS,
    P_SUDDEN_RANGE, P_MIN_HEIGHT, P_STEP_OVER_HEIGHT, P_SAME_BOX, P_T_REV, P_BACKOFF, P_K_SIDE,
    P_KX, P_SIDE_BACKOFF, P_K_MIN, P_K_MAX, P_SIDE_COR, P_SIDE_DIR, P_COR_GAIN, P_DIR_GAIN,
    P_SAG_GAIN, P_BRAKE_FROM, P_SIDE_DIR_FF, P_WR_COR_MIN, P_WR_COR_GAIN,
) = range(27)  # fmt: skip
N_PARAMS = 27
TF_T_STATE, TF_DIRECTION, TF_YAW0, TF_C, TF_S, TF_FAR = range(6)
"""Teacher floats: state entry time, side-step sign, first heading, its cos and sin, far face."""
N_TF = 6
TI_STATE, TI_HAS_YAW0, TI_N_KNOWN = range(3)
"""Teacher integers: state (``avoidance.WALK`` ...), whether the heading is set, boxes known."""
N_TI = 3
MODE_NONE, MODE_INTERRUPT, MODE_PROVISION = 0, 1, 2
"""``fit.MODE_*`` (defined here for the kernels, re-exported there)."""


@njit(cache=True, inline="always")
def _pmin(a, b):
    """Python's ``min(a, b)``: ``a`` unless ``b`` is smaller (ties and signed zeros as Python)."""
    return b if b < a else a


@njit(cache=True, inline="always")
def _pmax(a, b):
    """Python's ``max(a, b)``: ``a`` unless ``b`` is larger."""
    return b if b > a else a


@njit(cache=True)
def _remainder(x, y):
    """IEEE remainder of ``x`` by ``y``: ``math.remainder`` (not in numba), CPython's way."""
    absx = abs(x)
    absy = abs(y)
    m = np.fmod(absx, absy)
    c = absy - m
    if m < c:
        r = m
    elif m > c:
        r = -c
    else:
        r = m - 2.0 * np.fmod(0.5 * (absx - m), absy)
    return np.copysign(1.0, x) * r


@njit(cache=True)
def teacher_reset(tf, ti, known, known_sudden):
    """``SuddenAvoidance.reset`` over the state arrays: walk, no heading yet, no box seen.

    The heading's (cos, sin) start at (1, 0), as the class's: ``teacher_adopt`` can read them
    before the first ``teacher_update`` sets them.
    """
    tf[:] = 0.0
    tf[TF_C] = 1.0
    ti[:] = 0
    ti[TI_STATE] = WALK
    known[:] = 0.0
    known_sudden[:] = False


@njit(cache=True)
def teacher_adopt(box, feet, par, tf, ti, known, known_sudden):
    """``SuddenAvoidance.adopt`` over the state arrays (``decide_kernel``); returns whether taken.

    ``math.hypot`` here is libm's; CPython's (the Python path's) can differ in the last bit,
    which changes nothing unless a distance is within an ulp of ``same_box``.
    """
    if par[P_ENABLED] == 0.0 or ti[TI_STATE] != WALK or not box[1, 2] > par[P_STEP_OVER_HEIGHT]:
        return False
    c, s = tf[TF_C], tf[TF_S]
    x_lo = x_hi = box[0, 0] * c + box[0, 1] * s
    y_lo = y_hi = -box[0, 0] * s + box[0, 1] * c
    for a in range(2):
        for b in range(2):
            if a == 0 and b == 0:
                continue
            x = box[a, 0] * c + box[b, 1] * s
            y = -box[a, 0] * s + box[b, 1] * c
            x_lo, x_hi = _pmin(x_lo, x), _pmax(x_hi, x)
            y_lo, y_hi = _pmin(y_lo, y), _pmax(y_hi, y)
    lead = feet[0, 0] * c + feet[0, 1] * s
    for i in range(1, 4):
        lead = _pmax(lead, feet[i, 0] * c + feet[i, 1] * s)
    if x_lo < lead - 0.02:
        return False
    cx, cy = 0.5 * (x_lo + x_hi), 0.5 * (y_lo + y_hi)
    n = ti[TI_N_KNOWN]
    for j in range(n):
        if math.hypot(cx - known[j, 0], cy - known[j, 1]) < par[P_SAME_BOX]:
            known_sudden[j] = True
            return True
    if n < known.shape[0]:
        known[n, 0] = cx
        known[n, 1] = cy
        known_sudden[n] = True
        ti[TI_N_KNOWN] = n + 1
        return True
    return False


@njit(cache=True)
def teacher_heading(yaw, tf, ti):
    """``SuddenAvoidance.set_heading``: the first heading seen becomes the path's (``yaw0``)."""
    if ti[TI_HAS_YAW0] == 0:
        tf[TF_YAW0] = yaw
        tf[TF_C], tf[TF_S] = math.cos(yaw), math.sin(yaw)
        ti[TI_HAS_YAW0] = 1


@njit(cache=True)
def _set_state(state, t, tf, ti):
    if state != ti[TI_STATE]:
        ti[TI_STATE] = state
        tf[TF_T_STATE] = t


@njit(cache=True)
def teacher_update(
    t, yaw, feet, thighs, knees, boxes, par, tf, ti, known, known_sudden, inlane, gap, out,
    avoid,
):  # fmt: skip
    """``SuddenAvoidance.update`` over the state arrays (``decide_kernel``).

    Args:
        t: time, s.
        yaw: torso heading, rad.
        feet: (4, 3) sole centres, m.
        thighs: (4, 3) hip flexion joints, m.
        knees: (4, 3) knees, m.
        boxes: (K, 2, 3) remembered boxes (min/max corners), m.
        par: (N_PARAMS,) the fit's parameters (``fit.kernel_params``).
        tf: (N_TF,) teacher floats, updated.
        ti: (N_TI,) teacher integers, updated.
        known: (M, 2) centres of the boxes seen, updated.
        known_sudden: (M,) bool, whether each was first seen within reach, updated.
        inlane: (4,) bool scratch.
        gap: (4,) scratch.
        out: (``_avoidance_kernel.N_OUT``,) scratch.
        avoid: (3,) written while engaged: (s_SAG, s_COR, s_DIR).

    Returns:
        Whether the teacher is engaged (``update`` returned an array, not None).
    """
    teacher_heading(yaw, tf, ti)
    if par[P_ENABLED] == 0.0 or (ti[TI_STATE] == WALK and boxes.shape[0] == 0):
        return False
    c, s = tf[TF_C], tf[TF_S]
    state = ti[TI_STATE]
    hyst = par[P_LANE_HYSTERESIS] if state == SIDE or state == PASS else 0.0
    ti[TI_N_KNOWN] = avoidance_geometry(
        feet, thighs, knees, boxes, c, s, known, known_sudden, ti[TI_N_KNOWN],
        par[P_SUDDEN_RANGE], par[P_MIN_HEIGHT], par[P_SAME_BOX], par[P_TRIGGER], par[P_LANE_R],
        hyst, inlane, gap, out,
    )  # fmt: skip
    close = out[O_CLOSE] > 0.0
    any_in = out[O_N_IN] > 0.0
    gap_in = out[O_GAP_IN]
    if state == WALK:
        if not close:
            return False
        tf[TF_FAR] = out[O_FAR]
        tf[TF_DIRECTION] = 1.0 if out[O_NEED_LEFT] < out[O_NEED_RIGHT] else -1.0
        _set_state(REVERSE, t, tf, ti)
    elif state == REVERSE:
        if gap_in >= par[P_BACKOFF] and t - tf[TF_T_STATE] >= par[P_T_REV] - T_EPS:
            _set_state(SIDE, t, tf, ti)
    elif state == SIDE:
        if not any_in:
            _set_state(PASS, t, tf, ti)
    elif state == PASS:
        if any_in and close:
            _set_state(SIDE, t, tf, ti)
        else:
            rear = feet[0, 0] * c + feet[0, 1] * s
            for i in range(1, 4):
                rear = _pmin(rear, feet[i, 0] * c + feet[i, 1] * s)
            if rear > tf[TF_FAR] + 0.03:
                _set_state(WALK, t, tf, ti)
    state = ti[TI_STATE]
    if state == WALK:
        return False
    ey = _remainder(yaw - tf[TF_YAW0], 2.0 * math.pi)
    direction = tf[TF_DIRECTION]
    if state == REVERSE:
        sag, cor, turn = -1.0, 0.0, 0.0
    elif state == SIDE:
        k = par[P_K_SIDE]
        if any_in:
            k = k + par[P_KX] * (par[P_SIDE_BACKOFF] - gap_in)
            k = _pmin(_pmax(k, par[P_K_MIN]), par[P_K_MAX])
        sag = sag_for_stride(1.0 - k, par[P_SAG_GAIN], par[P_BRAKE_FROM])
        cor = direction * par[P_SIDE_COR]
        turn = -par[P_SIDE_DIR] * ey - direction * par[P_SIDE_DIR_FF]
    else:
        need = out[O_NEED_LEFT] if direction > 0 else out[O_NEED_RIGHT]
        deficit = need if out[O_N_REL] > 0 else 0.0
        sag = 0.0
        cor = direction * par[P_COR_GAIN] * _pmax(deficit + 0.01, 0.0)
        turn = -par[P_DIR_GAIN] * ey
    avoid[0] = sag
    avoid[1] = _pmin(_pmax(cor, -1.0), 1.0)
    avoid[2] = _pmin(_pmax(turn, -1.0), 1.0)
    return True


@njit(cache=True)
def decide_kernel(
    t, yaw, direction, hit, feet, hips, thighs, knees, boxes, front_legs, par, tf, ti, known,
    known_sudden, inlane, gap, out, provision, slots,
):  # fmt: skip
    """``Fit.decide`` in one compiled call, bit for bit (module docstring).

    Args are ``Fit.decide``'s (positions float64, ``hit`` int64, ``boxes`` (K, 2, 3)), then
    ``front_legs`` (``Fit._front``), the parameters and the teacher's state and scratch arrays
    (``teacher_update``), and the outputs ``provision`` (3,) and ``slots`` (4, 3), written as
    ``FitDecision``'s.

    Returns:
        (mode, target) as ``FitDecision``'s.
    """
    provision[:] = 0.0
    slots[:] = 0.0
    teacher_heading(yaw, tf, ti)
    target = interrupt_target(direction, hit, feet, boxes)
    mode = MODE_NONE
    interrupted = False
    for leg in range(4):
        for a in range(3):
            if direction[leg, a] != 0.0:
                interrupted = True
    if interrupted:
        mode = MODE_INTERRUPT
        slots[:] = direction
    elif boxes.shape[0] > 0:
        target = walk_around_kernel(
            hips, feet, front_legs, tf[TF_C], tf[TF_S], boxes, par[P_LOOKAHEAD],
            par[P_CORRIDOR], par[P_BESIDE], par[P_WR_COR_MIN], par[P_WR_COR_GAIN], provision,
        )  # fmt: skip
        if target >= 0:
            mode = MODE_PROVISION
            for leg in range(4):
                slots[leg, 0] = provision[0]
                slots[leg, 1] = provision[1]
    if mode == MODE_INTERRUPT and target >= 0:
        # The fit: a box taller than a swing clears is stopped for, not stepped over.
        teacher_adopt(boxes[target], feet, par, tf, ti, known, known_sudden)
    if teacher_update(
        t, yaw, feet, thighs, knees, boxes, par, tf, ti, known, known_sudden, inlane, gap, out,
        provision,
    ):  # fmt: skip
        mode = MODE_PROVISION
        for leg in range(4):
            for a in range(3):
                slots[leg, a] = provision[a]
        target = -1
    return mode, target
