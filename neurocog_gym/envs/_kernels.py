"""numba kernels of the env's per-cycle checks."""

from __future__ import annotations

import math

import numpy as np
from numba import njit, types
from numba.extending import intrinsic


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
def clip_action_groups(action, out, n_first):  # pragma: no cover - compiled
    """``out[:] = clip(action, -1, 1)`` as float64, and which output groups it uses.

    Returns:
        -1 (``out`` partly written) on a NaN or inf; else bit 0 set when an entry below
        ``n_first`` is non-zero and bit 1 when one from ``n_first`` on is (``a[:n].any()``,
        ``a[n:].any()`` of the clipped action).
    """
    groups = 0
    for i in range(action.shape[0]):
        x = action[i]
        if not math.isfinite(x):
            return -1
        y = min(max(x, -1.0), 1.0)
        out[i] = y
        if y != 0.0:
            groups |= 1 if i < n_first else 2
    return groups


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


@intrinsic
def _fma(typingctx, a, b, c):
    """Fused multiply-add a * b + c, one rounding (LLVM's ``llvm.fma.f64``)."""
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        return builder.fma(*args)

    return sig, codegen


# The observation's heading-frame arithmetic reproduces NumPy's (so an observation keeps its
# bits): NumPy hands ``(P - t) @ rot.T`` with P of 2 or more rows to BLAS's gemm and ``rot @ v``
# and ``R.T @ v`` to gemv, and OpenBLAS's kernels sum the three products with fused
# multiply-adds: gemm and the transposed gemv from k = 0 up, the plain gemv from k = 2 down
# (checked against NumPy on 10^5 random cases each, tests/envs/test_kernels.py).


@njit(cache=True, inline="always")
def _dot3_up(a0, a1, a2, b0, b1, b2):  # pragma: no cover - compiled
    return _fma(a2, b2, _fma(a1, b1, _fma(a0, b0, 0.0)))


@njit(cache=True, inline="always")
def _dot3_down(a0, a1, a2, b0, b1, b2):  # pragma: no cover - compiled
    return _fma(a0, b0, _fma(a1, b1, a2 * b2))


# Offsets of the keys in the float32 observation buffer (``observation_kernel``), key order.
O_JOINT_POS, O_JOINT_VEL, O_TOUCH, O_QUAT, O_LIN_VEL, O_ANG_VEL, O_HEIGHT = (
    0,
    12,
    24,
    28,
    32,
    35,
    38,
)
O_CPG, O_SERVO, O_OBJECTS, O_MASK, O_AEF, O_DIRECTION, O_FOOTHOLD = 39, 63, 75, 107, 111, 142, 154
O_MEETS, O_MET, O_BLOCKS, O_FEET, O_LEG_JOINTS, N_OBS = 166, 170, 174, 230, 242, 278


@njit(cache=True, inline="always")
def _heading_rows(px, py, pz, tx, ty, tz, c, s, out, at):  # pragma: no cover - compiled
    """One point in the heading frame as gemm computes ``(P - t) @ rot.T`` (x, y; z as is)."""
    dx = px - tx
    dy = py - ty
    dz = pz - tz
    out[at] = np.float32(_dot3_up(c, s, 0.0, dx, dy, dz))
    out[at + 1] = np.float32(_dot3_up(-s, c, 0.0, dx, dy, dz))
    out[at + 2] = np.float32(pz)


@njit(cache=True)
def observation_kernel(
    qpos, qvel, qpos_adr, dof_adr, touch, torso_xmat, cpg_y, servo_target, c, s, torso,
    site_xpos, foot_site, xpos, hip_body, thigh_body, shank_body, direction, foothold,
    foothold_safe, path_safe, hit, memory, keep, rel_yaw, along_x, best, slot_of, out, safe_out,
):  # pragma: no cover - compiled  # fmt: skip
    """The obstacle env's 1-D observation keys in one pass (``ObstacleEnv._get_obs``).

    Writes every key of the default observation but ``objects`` and ``objects_mask`` (set
    before, from the perception's Python objects) into ``out`` at the ``O_*`` offsets, as
    float32, and ``foothold_safe`` into ``safe_out``; the same values, bit for bit, as the NumPy
    code it replaced (heading frame: x, y from the torso in the yaw frame (c, s) = (cos, sin)
    of the yaw, z as is).

    Args:
        qpos: (nq,) float64 MuJoCo's positions.
        qvel: (nv,) float64 MuJoCo's velocities.
        qpos_adr: (12,) int64 the joints' qpos entries.
        dof_adr: (12,) int64 the joints' qvel entries.
        touch: (4,) float64 this cycle's touch inputs.
        torso_xmat: (9,) float64 the torso's orientation, row-major.
        cpg_y: (24,) float64 CPG outputs.
        servo_target: (12,) float64 servo targets, rad.
        c: cos of the torso's yaw.
        s: sin of the torso's yaw.
        torso: (3,) float64 torso position, m.
        site_xpos: (nsite, 3) float64 site positions, m.
        foot_site: (4,) int64 the soles' sites.
        xpos: (nbody, 3) float64 body positions, m.
        hip_body: (4,) int64 hip body ids.
        thigh_body: (4,) int64 thigh body ids.
        shank_body: (4,) int64 shank body ids.
        direction: (4, 3) float64 interrupt directions, m/s.
        foothold: (4, 3) float64 predicted footholds, world, m.
        foothold_safe: (4,) bool.
        path_safe: (4,) bool.
        hit: (4,) int64 memory index of the box each leg meets, -1 none.
        memory: (K, 2, 3) float64 remembered boxes, m.
        keep: (<= 8,) int64 the memory rows shown, in memory order.
        rel_yaw: rad, yaw of the boxes' length axis relative to the heading.
        along_x: whether that axis is world x (else y).
        best: (3,) float64 A_h, A_w, A_s of the nearest object (0 without one).
        slot_of: (>= K,) int64 scratch: the row of each memory box, -1 left out.
        out: (N_OBS,) float32, written (objects and objects_mask left as they are).
        safe_out: (4,) int8, written.
    """
    for i in range(12):
        out[O_JOINT_POS + i] = np.float32(qpos[qpos_adr[i]])
        out[O_JOINT_VEL + i] = np.float32(qvel[dof_adr[i]])
        out[O_AEF + 15 + i] = out[O_JOINT_POS + i]
        out[O_SERVO + i] = np.float32(servo_target[i])
    for i in range(4):
        out[O_TOUCH + i] = np.float32(touch[i])
        out[O_AEF + 27 + i] = out[O_TOUCH + i]
        out[O_QUAT + i] = np.float32(qpos[3 + i])
    v0, v1, v2 = qvel[0], qvel[1], qvel[2]
    for i in range(3):
        lin = _dot3_up(torso_xmat[i], torso_xmat[3 + i], torso_xmat[6 + i], v0, v1, v2)
        out[O_LIN_VEL + i] = np.float32(lin)
        out[O_ANG_VEL + i] = np.float32(qvel[3 + i])
        out[O_AEF + i] = np.float32(best[i])
    out[O_HEIGHT] = np.float32(qpos[2])
    for i in range(24):
        out[O_CPG + i] = np.float32(cpg_y[i])
    tx, ty, tz = torso[0], torso[1], torso[2]
    for leg in range(4):
        for j in range(3):
            d = np.float32(direction[leg, j])
            out[O_AEF + 3 + 3 * leg + j] = d
            out[O_DIRECTION + 3 * leg + j] = d
        f = foothold[leg]
        _heading_rows(f[0], f[1], f[2], tx, ty, tz, c, s, out, O_FOOTHOLD + 3 * leg)
        p = site_xpos[foot_site[leg]]
        _heading_rows(p[0], p[1], p[2], tx, ty, tz, c, s, out, O_FEET + 3 * leg)
        at = O_LEG_JOINTS + 9 * leg
        p = xpos[hip_body[leg]]
        _heading_rows(p[0], p[1], p[2], tx, ty, tz, c, s, out, at)
        p = xpos[thigh_body[leg]]
        _heading_rows(p[0], p[1], p[2], tx, ty, tz, c, s, out, at + 3)
        p = xpos[shank_body[leg]]
        _heading_rows(p[0], p[1], p[2], tx, ty, tz, c, s, out, at + 6)
        safe_out[leg] = np.int8(1) if foothold_safe[leg] else np.int8(0)
        out[O_MEETS + leg] = np.float32(0.0) if path_safe[leg] else np.float32(1.0)
    for m in range(memory.shape[0]):
        slot_of[m] = -1
    for slot in range(keep.shape[0]):
        m = keep[slot]
        lo = memory[m, 0]
        hi = memory[m, 1]
        # rot @ (centre - torso), rot = [[c, s, 0], [-s, c, 0], [0, 0, 1]] (gemv).
        dx = 0.5 * (lo[0] + hi[0]) - tx
        dy = 0.5 * (lo[1] + hi[1]) - ty
        dz = 0.5 * (lo[2] + hi[2]) - tz
        hx = 0.5 * (hi[0] - lo[0])
        hy = 0.5 * (hi[1] - lo[1])
        at = O_BLOCKS + 7 * slot
        out[at] = np.float32(1.0)
        out[at + 1] = np.float32(_dot3_down(c, s, 0.0, dx, dy, dz))
        out[at + 2] = np.float32(_dot3_down(-s, c, 0.0, dx, dy, dz))
        out[at + 3] = np.float32(rel_yaw)
        out[at + 4] = np.float32(hx if along_x else hy)
        out[at + 5] = np.float32(hy if along_x else hx)
        out[at + 6] = np.float32(hi[2])
        slot_of[m] = slot
    for leg in range(4):
        h = hit[leg]
        out[O_MET + leg] = np.float32(slot_of[h]) if h >= 0 else np.float32(-1.0)


@njit(cache=True)
def outcome_cycle(
    geom, pos, frame, efc_address, dim, efc_force, elliptic,
    slot_of, is_robot, n_blocks, body_ids, xpos, xmat, xquat, half, placed_pos, placed_quat,
    cos_max_tilt, face_tol, min_force, stand_cycles, max_shift, cos_half_max_turn,
    touching, top_force, stand_run, stood, shift, turn, knocked,
    feet, prev_feet, has_prev, heading, axis_sign, state, crossed, is_front, over,
):  # pragma: no cover - compiled  # fmt: skip
    """One control cycle's outcome bookkeeping of K >= 1 placed blocks in one call.

    ``block_outcome_step`` (on every contact: those that join no robot geom and a block are
    skipped, so the result is the same as on the robot-block contacts alone), then
    ``step_over_step``; then ``over[k]`` (a front and a hind foot crossed block k), the far
    x bound of the blocks' current axis-aligned boxes (``ObstaclePool.boxes``: centre x plus
    the |R| half-sizes row, summed in NumPy's einsum order) and the rearmost foot's x; and
    ``prev_feet[:] = feet``. The arguments are those of the two kernels, plus ``is_front``
    (4,) bool and ``over`` (>= K,) bool, written.

    Returns:
        ``(touching, knocked, stood, far, rear)``: any block in contact with the robot now,
        any knocked, any stood on (latched), the boxes' largest x, m, and the smallest foot x,
        m (both NaN when a value is NaN, as NumPy's max and min).
    """
    anyhit = block_outcome_step(
        geom, pos, frame, efc_address, dim, efc_force, elliptic, slot_of, is_robot, n_blocks,
        body_ids, xpos, xmat, xquat, half, placed_pos, placed_quat, cos_max_tilt, face_tol,
        min_force, stand_cycles, max_shift, cos_half_max_turn, touching, top_force, stand_run,
        stood, shift, turn, knocked,
    )  # fmt: skip
    step_over_step(
        feet, prev_feet, has_prev, heading, n_blocks, body_ids, xpos, xmat, half, axis_sign,
        state, crossed,
    )  # fmt: skip
    any_knocked = False
    any_stood = False
    far = -np.inf
    for k in range(n_blocks):
        any_knocked |= knocked[k]
        any_stood |= stood[k]
        front = False
        hind = False
        for f in range(4):
            if crossed[k, f]:
                if is_front[f]:
                    front = True
                else:
                    hind = True
        over[k] = front and hind
        b = body_ids[k]
        p0 = abs(xmat[b, 0]) * half[k, 0]
        p1 = abs(xmat[b, 1]) * half[k, 1]
        p2 = abs(xmat[b, 2]) * half[k, 2]
        x = xpos[b, 0] + ((p0 + p2) + p1)
        if x > far or x != x:
            if far == far:
                far = x
    rear = np.inf
    for f in range(4):
        x = feet[f, 0]
        if x < rear or x != x:
            if rear == rear:
                rear = x
        for j in range(3):
            prev_feet[f, j] = feet[f, j]
    return anyhit, any_knocked, any_stood, far, rear
