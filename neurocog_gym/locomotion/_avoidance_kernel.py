"""numba kernel of the avoidance's per-cycle geometry (``avoidance.py``): one call a cycle."""

from __future__ import annotations

import numpy as np
from numba import njit

FOOT_RADIUS = 0.018
THIGH_RADIUS = 0.017
SHANK_RADIUS = 0.012
N_SAMPLES = 6
"""Points sampled along each thigh and shank capsule for a leg's reach."""

# Geometry outputs (``out`` array).
O_CLOSE, O_NEED_LEFT, O_NEED_RIGHT, O_FAR, O_N_REL, O_N_IN, O_GAP_IN = range(7)
N_OUT = 7

WALK, REVERSE, SIDE, PASS = 0, 1, 2, 3
"""The teacher's states (``avoidance.py``; its compiled form is ``_fit_kernel.teacher_update``)."""
T_EPS = 1e-6
"""s, how far short of a duration a sum of control-cycle steps may fall and still reach it."""
KNOWN_CAPACITY = 64
"""Most boxes whose first sighting is remembered (later ones never engage)."""


@njit(cache=True)
def sag_for_stride(scale, sag_gain, brake_from):
    """``avoidance.sag_for_stride``: the s_SAG whose stride scale is ``scale``, in [-1, 1]."""
    top = 1.0 + sag_gain * brake_from
    if scale >= top:
        s = (scale - 1.0) / sag_gain
    else:
        s = -1.0 + (scale + 1.0) * (brake_from + 1.0) / (top + 1.0)
    # Python's min(max(s, -1.0), 1.0), NaN and all.
    if -1.0 > s:
        s = -1.0
    if 1.0 < s:
        s = 1.0
    return s


@njit(cache=True)
def leg_reach(feet, thighs, knees, top, out):
    """Each leg's most forward x (thigh, shank and sole capsules) below ``top``, into ``out``."""
    for leg in range(4):
        best = feet[leg, 0] + FOOT_RADIUS
        for seg in range(2):
            if seg == 0:
                a = thighs
                b = knees
                rad = THIGH_RADIUS
            else:
                a = knees
                b = feet
                rad = SHANK_RADIUS
            for i in range(N_SAMPLES):
                s = i / (N_SAMPLES - 1)
                z = a[leg, 2] + s * (b[leg, 2] - a[leg, 2])
                if z - rad <= top:
                    x = a[leg, 0] + s * (b[leg, 0] - a[leg, 0]) + rad
                    if x > best:
                        best = x
        out[leg] = best


@njit(cache=True)
def avoidance_geometry(
    feet_w, thighs_w, knees_w, boxes_w, c, s, known, known_sudden, n_known, sudden_range,
    min_height, same_box, trigger, r, hyst, inlane, gap, out,
):  # fmt: skip
    """Lanes, gaps and needed shifts against the sudden boxes, in the frame of heading (c, s).

    Args:
        feet_w: (4, 3) sole centres, world, m.
        thighs_w: (4, 3) hip flexion joints, world, m.
        knees_w: (4, 3) knees, world, m.
        boxes_w: (K, 2, 3) world boxes (min/max corners), m.
        c: cos of the frame's heading.
        s: sin of the frame's heading.
        known: (M, 2) centres of the boxes seen so far (frame), m; updated.
        known_sudden: (M,) bool, whether each was first seen within ``sudden_range``; updated.
        n_known: how many of ``known`` are in use.
        sudden_range: ``AvoidanceParams.sudden_range``, m.
        min_height: ``AvoidanceParams.min_height``, m.
        same_box: ``AvoidanceParams.same_box``, m.
        trigger: ``AvoidanceParams.trigger``, m.
        r: foot radius + margin, m: the clearance round each lane.
        hyst: extra lane width for the overlap test, m.
        inlane: (4,) bool, written: the leg's lane overlaps a sudden box it has not passed.
        gap: (4,) written: the leg's reach to the nearest near face, m (inf: none).
        out: (N_OUT,) written: close (a lane overlaps a box whose near face is within
            ``trigger`` of the leading foot), the shift to the left (+y) and to the right that
            clears every lane of every box, the farthest far face, the number of boxes, the
            number of in-lane legs and their smallest gap (inf: none).

    Returns:
        The new ``n_known``.
    """
    feet = np.empty((4, 3))
    thighs = np.empty((4, 3))
    knees = np.empty((4, 3))
    for leg in range(4):
        for src, dst in ((feet_w, feet), (thighs_w, thighs), (knees_w, knees)):
            dst[leg, 0] = c * src[leg, 0] + s * src[leg, 1]
            dst[leg, 1] = -s * src[leg, 0] + c * src[leg, 1]
            dst[leg, 2] = src[leg, 2]
    lead = -np.inf
    rear = np.inf
    lane_lo = np.empty(4)
    lane_hi = np.empty(4)
    for leg in range(4):
        lead = max(lead, feet[leg, 0])
        rear = min(rear, feet[leg, 0])
        lane_lo[leg] = min(thighs[leg, 1], feet[leg, 1])
        lane_hi[leg] = max(thighs[leg, 1], feet[leg, 1])
    lanes_min = min(lane_lo[0], min(lane_lo[1], min(lane_lo[2], lane_lo[3])))
    lanes_max = max(lane_hi[0], max(lane_hi[1], max(lane_hi[2], lane_hi[3])))
    inlane[:] = False
    gap[:] = np.inf
    out[:] = 0.0
    out[O_FAR] = -np.inf
    reach = np.empty(4)
    for k in range(boxes_w.shape[0]):
        if not boxes_w[k, 1, 2] > min_height:
            continue
        # The box's ground-plane corners in the frame: its bounding box there.
        x0 = np.inf
        x1 = -np.inf
        y0 = np.inf
        y1 = -np.inf
        for a in range(2):
            for b in range(2):
                wx = boxes_w[k, a, 0]
                wy = boxes_w[k, b, 1]
                fx = c * wx + s * wy
                fy = -s * wx + c * wy
                x0 = min(x0, fx)
                x1 = max(x1, fx)
                y0 = min(y0, fy)
                y1 = max(y1, fy)
        cx = 0.5 * (x0 + x1)
        cy = 0.5 * (y0 + y1)
        match = -1
        for j in range(n_known):
            if np.hypot(cx - known[j, 0], cy - known[j, 1]) < same_box:
                known[j, 0] = cx
                known[j, 1] = cy
                match = j
                break
        if match < 0 and n_known < known.shape[0]:
            match = n_known
            known[match, 0] = cx
            known[match, 1] = cy
            known_sudden[match] = x0 - lead < sudden_range
            n_known += 1
        if match < 0 or not known_sudden[match]:
            continue
        if not rear < x1 + 0.03:
            continue  # every foot is past it
        out[O_N_REL] += 1.0
        out[O_FAR] = max(out[O_FAR], x1)
        ahead = x0 - lead < trigger
        leg_reach(feet, thighs, knees, boxes_w[k, 1, 2], reach)
        for leg in range(4):
            gap[leg] = min(gap[leg], x0 - reach[leg])
            if feet[leg, 0] > x1 + 0.03:
                continue  # this foot is past the box
            if lane_hi[leg] + r + hyst > y0 and lane_lo[leg] - r - hyst < y1:
                inlane[leg] = True
                if ahead:
                    out[O_CLOSE] = 1.0
        out[O_NEED_RIGHT] = max(out[O_NEED_RIGHT], lanes_max + r - y0)
        out[O_NEED_LEFT] = max(out[O_NEED_LEFT], y1 + r - lanes_min)
    out[O_GAP_IN] = np.inf
    for leg in range(4):
        if inlane[leg]:
            out[O_N_IN] += 1.0
            out[O_GAP_IN] = min(out[O_GAP_IN], gap[leg])
    return n_known
