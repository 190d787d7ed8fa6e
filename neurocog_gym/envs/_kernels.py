"""numba kernels of the env's per-cycle checks."""

from __future__ import annotations

import math

import numpy as np
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


@njit(cache=True)
def block_outcome_step(
    geom, pos, frame, efc_address, dim, efc_force, elliptic,
    slot_of, is_robot, n_blocks, body_ids, xpos, xmat, xquat, half, placed_pos, placed_quat,
    cos_max_tilt, face_tol, min_force, stand_cycles, max_shift, cos_half_max_turn,
    touching, top_force, stand_run, stood, shift, turn, knocked,
):  # pragma: no cover - compiled  # fmt: skip
    """One control cycle's contact and pose checks of the placed blocks (the outcome, §6.5).

    Touch: a contact joins a robot geom and block k. Standing: the contacts of robot geoms
    on block k's top face whose normal, taken from the block to the robot, is within the
    tilt limit of world up (``frame[c, 2]`` >= ``cos_max_tilt``), whose point lies within
    ``face_tol`` of the top face's plane (block frame ``z = +h/2``) and inside the face grown
    by ``face_tol``, carry a total normal force ``top_force[k]``; when it is at least
    ``min_force`` for ``stand_cycles`` checks in a row the block was stood on. Knock: its
    centre moved more than ``max_shift`` in the horizontal plane from where it was placed, or it
    turned (any axis) by more than the angle whose half-cosine is ``cos_half_max_turn``.

    Args:
        geom: (n, 2) int geom ids of each contact (``data.contact.geom``; n may be 0).
        pos: (n, 3) float64 contact points, m, world frame.
        frame: (n, 9) float64 contact frames; ``frame[c, :3]`` the normal from geom 0 to 1.
        efc_address: (n,) int first constraint row of each contact (-1: none).
        dim: (n,) int contact dimensionality.
        efc_force: (nefc,) float64 constraint forces, N.
        elliptic: whether the cone is elliptic (its first row is the normal force); a pyramidal
            contact's normal force is the sum of its 2 (dim - 1) edge forces.
        slot_of: (ngeom,) int64 block slot of each geom, -1 for the rest.
        is_robot: (ngeom,) bool, whether each geom is the robot's.
        n_blocks: number of placed blocks K.
        body_ids: (>= K,) int64 body id of each slot.
        xpos: (nbody, 3) float64 body positions, m (``data.xpos``).
        xmat: (nbody, 9) float64 body orientations, row-major (``data.xmat``).
        xquat: (nbody, 4) float64 body orientations, (w, x, y, z) (``data.xquat``).
        half: (>= K, 3) float64 half-sizes, m.
        placed_pos: (>= K, 3) float64 centres at placement, m.
        placed_quat: (>= K, 4) float64 orientations at placement, (w, x, y, z).
        cos_max_tilt: cosine of the largest angle between a standing contact's normal and up.
        face_tol: m, distance tolerance to the top face.
        min_force: N, the smallest total normal force that counts as carrying weight.
        stand_cycles: checks in a row needed.
        max_shift: m, horizontal displacement beyond which a block is knocked.
        cos_half_max_turn: cos(theta_max / 2) of the largest rotation theta_max.
        touching: (>= K,) bool, written: in contact with the robot now.
        top_force: (>= K,) float64, written: N on the top face now.
        stand_run: (>= K,) int64, updated: checks in a row with weight on the top face.
        stood: (>= K,) bool, updated (latched).
        shift: (>= K,) float64, written: horizontal displacement, m.
        turn: (>= K,) float64, written: rotation angle from the placed orientation, rad.
        knocked: (>= K,) bool, updated (latched).

    Returns:
        Whether any block touches the robot now.
    """
    for k in range(n_blocks):
        touching[k] = False
        top_force[k] = 0.0
    anyhit = False
    for c in range(geom.shape[0]):
        g0 = geom[c, 0]
        g1 = geom[c, 1]
        s0 = slot_of[g0]
        s1 = slot_of[g1]
        if 0 <= s0 < n_blocks and is_robot[g1]:
            k = s0
            sign = 1.0  # the normal already points from the block (geom 0) to the robot
        elif 0 <= s1 < n_blocks and is_robot[g0]:
            k = s1
            sign = -1.0
        else:
            continue
        touching[k] = True
        anyhit = True
        adr = efc_address[c]
        if adr < 0 or sign * frame[c, 2] < cos_max_tilt:
            continue
        b = body_ids[k]
        dx = pos[c, 0] - xpos[b, 0]
        dy = pos[c, 1] - xpos[b, 1]
        dz = pos[c, 2] - xpos[b, 2]
        # Block frame coordinates: R^T d, with R row-major in xmat.
        lx = xmat[b, 0] * dx + xmat[b, 3] * dy + xmat[b, 6] * dz
        ly = xmat[b, 1] * dx + xmat[b, 4] * dy + xmat[b, 7] * dz
        lz = xmat[b, 2] * dx + xmat[b, 5] * dy + xmat[b, 8] * dz
        if (
            abs(lz - half[k, 2]) > face_tol
            or abs(lx) > half[k, 0] + face_tol
            or abs(ly) > half[k, 1] + face_tol
        ):
            continue
        if elliptic or dim[c] == 1:
            fn = efc_force[adr]
        else:
            fn = 0.0
            for r in range(2 * (dim[c] - 1)):
                fn += efc_force[adr + r]
        top_force[k] += fn
    for k in range(n_blocks):
        if top_force[k] >= min_force:
            stand_run[k] += 1
        else:
            stand_run[k] = 0
        if stand_run[k] >= stand_cycles:
            stood[k] = True
        b = body_ids[k]
        sx = xpos[b, 0] - placed_pos[k, 0]
        sy = xpos[b, 1] - placed_pos[k, 1]
        shift[k] = math.sqrt(sx * sx + sy * sy)
        q = xquat[b]
        p = placed_quat[k]
        dot = abs(q[0] * p[0] + q[1] * p[1] + q[2] * p[2] + q[3] * p[3])
        turn[k] = 2.0 * math.acos(min(dot, 1.0))
        if shift[k] > max_shift or dot < cos_half_max_turn:
            knocked[k] = True
    return anyhit


@njit(cache=True)
def step_over_step(
    feet, prev_feet, has_prev, heading, n_blocks, body_ids, xpos, xmat, half,
    axis_sign, state, crossed,
):  # pragma: no cover - compiled  # fmt: skip
    """Track which feet cross each block above its footprint (one control cycle).

    In block k's frame a foot is at (u, v): u along the block's length axis, signed so that
    the walking direction is +u (``axis_sign``, fixed from ``heading`` at the block's first
    check), v across. A foot is armed while it is before the near face (u < -length/2); it
    crosses the block above it when, armed, it gets beyond the far face (u > +length/2) and
    every part of its path (the straight segments between control cycles) with
    -length/2 <= u <= +length/2 had |v| <= width/2. A path segment over the length that leaves
    the width (walking round the block) disarms the foot until it is back before the near face.

    Args:
        feet: (4, 3) float64 foot positions now, m, world frame.
        prev_feet: (4, 3) float64 foot positions at the previous check.
        has_prev: whether ``prev_feet`` holds the previous check's positions.
        heading: (2,) float64 walking direction, world xy (unit).
        n_blocks: number of placed blocks K.
        body_ids: (>= K,) int64 body id of each slot.
        xpos: (nbody, 3) float64 body positions, m (``data.xpos``).
        xmat: (nbody, 9) float64 body orientations, row-major (``data.xmat``).
        half: (>= K, 3) float64 half-sizes, m.
        axis_sign: (>= K,) float64, +1 or -1, written at a block's first check.
        state: (>= K, 4) int8, updated: -1 unseen (first check pending), 0 not armed, 1 armed.
        crossed: (>= K, 4) bool, updated (latched): the foot crossed the block above it.
    """
    for k in range(n_blocks):
        b = body_ids[k]
        hx = half[k, 0]
        hy = half[k, 1]
        # Block x and y axes in the world: the first and second columns of R.
        ax0, ax1, ax2 = xmat[b, 0], xmat[b, 3], xmat[b, 6]
        ay0, ay1, ay2 = xmat[b, 1], xmat[b, 4], xmat[b, 7]
        if state[k, 0] == -1:
            axis_sign[k] = 1.0 if ax0 * heading[0] + ax1 * heading[1] >= 0.0 else -1.0
        sg = axis_sign[k]
        for f in range(4):
            dx = feet[f, 0] - xpos[b, 0]
            dy = feet[f, 1] - xpos[b, 1]
            dz = feet[f, 2] - xpos[b, 2]
            u1 = sg * (ax0 * dx + ax1 * dy + ax2 * dz)
            v1 = ay0 * dx + ay1 * dy + ay2 * dz
            if state[k, f] == -1:
                state[k, f] = 1 if u1 < -hx else 0
                continue
            if state[k, f] == 1 and has_prev:
                ex = prev_feet[f, 0] - xpos[b, 0]
                ey = prev_feet[f, 1] - xpos[b, 1]
                ez = prev_feet[f, 2] - xpos[b, 2]
                u0 = sg * (ax0 * ex + ax1 * ey + ax2 * ez)
                v0 = ay0 * ex + ay1 * ey + ay2 * ez
                du = u1 - u0
                # The part of the segment over the block's length: t in [ta, tb].
                if abs(du) < 1e-12:
                    ta, tb = (0.0, 1.0) if -hx <= u0 <= hx else (1.0, 0.0)
                else:
                    t_lo = (-hx - u0) / du
                    t_hi = (hx - u0) / du
                    ta = max(0.0, min(t_lo, t_hi))
                    tb = min(1.0, max(t_lo, t_hi))
                # |v| is convex along the segment: the ends of that part bound it.
                if ta <= tb and max(abs(v0 + ta * (v1 - v0)), abs(v0 + tb * (v1 - v0))) > hy:
                    state[k, f] = 0
            if u1 < -hx:
                state[k, f] = 1
            elif u1 > hx and state[k, f] == 1:
                crossed[k, f] = True
                state[k, f] = 0


@njit(cache=True)
def depth_image(depth, valid, rows, cols, range_m, out):  # pragma: no cover - compiled
    """The ``depth`` observation: the ToF frame resampled and quantised to uint8.

    Args:
        depth: (S, H, W) float32, metres, z-depth of each sensor's pixels (``ToFFrame.depth``).
        valid: (S, H, W) bool, a return within the range gate (``ToFFrame.valid``).
        rows: (h,) int64, the source row of each image row (nearest pixel).
        cols: (w,) int64, the source column of each image column.
        range_m: metres of depth that map to 255 (and beyond, clipped).
        out: (S, h, w) uint8, written: round(255 * depth / range_m), 255 where invalid.
    """
    scale = 255.0 / range_m
    for s in range(out.shape[0]):
        for i in range(out.shape[1]):
            r = rows[i]
            for j in range(out.shape[2]):
                c = cols[j]
                # A select, not a branch: the loop runs a third faster.
                level = min(depth[s, r, c] * scale + 0.5, 255.0)
                out[s, i, j] = np.uint8(level) if valid[s, r, c] else np.uint8(255)
