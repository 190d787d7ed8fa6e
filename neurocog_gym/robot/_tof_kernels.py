"""numba kernels of the ToF sensor array (``tof.ToFArray`` owns the buffers they write).

Site and geom poses are copied into local scalars before the per-ray loops: numba cannot prove
that the output buffers do not alias them, and would reload them for every ray otherwise.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
from numba import njit

MINVAL = 1e-15
"""MuJoCo's mjMINVAL."""
PLANE, SPHERE, CAPSULE, ELLIPSOID, CYLINDER, BOX = (
    int(mujoco.mjtGeom.mjGEOM_PLANE),
    int(mujoco.mjtGeom.mjGEOM_SPHERE),
    int(mujoco.mjtGeom.mjGEOM_CAPSULE),
    int(mujoco.mjtGeom.mjGEOM_ELLIPSOID),
    int(mujoco.mjtGeom.mjGEOM_CYLINDER),
    int(mujoco.mjtGeom.mjGEOM_BOX),
)
PRIMITIVES = (PLANE, SPHERE, CAPSULE, ELLIPSOID, CYLINDER, BOX)
"""``mjtGeom`` values of the geom types the numba caster casts against."""


@njit(cache=True)
def rotate_rays(dirs_t, site_xmat, site_ids, out):  # pragma: no cover - compiled
    """Rotate site-frame rays into the world: ``out[s, :, k] = R_s @ dirs_t[:, k]``.

    Rays are stored a row per axis (x, y, z), so that this loop and the casts' loops over the
    rays vectorise (strided rows of three keep them scalar).

    Args:
        dirs_t: (3, n) float64, unit rays in the site frame, a row per axis.
        site_xmat: (nsite, 9) float64, row-major site orientations (``data.site_xmat``).
        site_ids: (S,) int64, the sensors' site ids.
        out: (S, 3, n) float64, written.
    """
    for s in range(site_ids.shape[0]):
        i = site_ids[s]
        r0, r1, r2 = site_xmat[i, 0], site_xmat[i, 1], site_xmat[i, 2]
        r3, r4, r5 = site_xmat[i, 3], site_xmat[i, 4], site_xmat[i, 5]
        r6, r7, r8 = site_xmat[i, 6], site_xmat[i, 7], site_xmat[i, 8]
        for k in range(dirs_t.shape[1]):
            d0, d1, d2 = dirs_t[0, k], dirs_t[1, k], dirs_t[2, k]
            out[s, 0, k] = r0 * d0 + r1 * d1 + r2 * d2
            out[s, 1, k] = r3 * d0 + r4 * d1 + r5 * d2
            out[s, 2, k] = r6 * d0 + r7 * d1 + r8 * d2


# nogil: the two kernels of a frame that run long enough (0.02-0.4 ms) for another thread to
# use the GIL meanwhile (BatchVectorEnv steps sub-envs on threads); the short ones keep it, a
# GIL hand-over costs tens of microseconds.
@njit(cache=True, nogil=True)
def pack_frame(
    vec,
    cos_axis,
    site_xpos,
    site_ids,
    dist,
    geomid,
    min_range,
    max_range,
    noise_std_rel,
    dropout,
    gauss,
    unif,
    depth,
    valid,
    points,
    origins,
    counts,
):  # pragma: no cover - compiled
    """Apply noise and the range gate, write depth, validity and packed world points.

    Args:
        vec: (S, 3, n) float64, unit rays in the world frame (:func:`rotate_rays`).
        cos_axis: (n,) float64, cosine of each ray to the optical axis (z-depth = d · cos).
        site_xpos: (nsite, 3) float64, metres, site positions (``data.site_xpos``).
        site_ids: (S,) int64, the sensors' site ids.
        dist: (S, n) float64, metres, ray length to the hit, < 0 for none.
        geomid: (S, n) int32, geom hit; set to -1 where the pixel ends up invalid.
        min_range: metres, nearest valid ray length.
        max_range: metres, farthest valid ray length.
        noise_std_rel: σ_d / d, 1.
        dropout: probability a valid pixel is dropped, 1.
        gauss: (S, n) float64, standard normal draws (read only if noise_std_rel > 0).
        unif: (S, n) float64, uniform [0, 1) draws (read only if dropout > 0).
        depth: (S, n) float32, metres, written (0 where invalid).
        valid: (S, n) bool, written.
        points: (S·n, 3) float32, metres, world frame; the first ``total`` rows are written.
        origins: (S, 3) float64, metres, written with the sensor positions.
        counts: (S,) int64, written with points per sensor.

    Returns:
        total, the number of points written.
    """
    noisy = noise_std_rel > 0.0
    drop = dropout > 0.0
    total = 0
    for s in range(site_ids.shape[0]):
        i = site_ids[s]
        o0, o1, o2 = site_xpos[i, 0], site_xpos[i, 1], site_xpos[i, 2]
        origins[s, 0], origins[s, 1], origins[s, 2] = o0, o1, o2
        start = total
        for k in range(vec.shape[2]):
            d = dist[s, k]
            ok = d >= 0.0
            if ok and noisy:
                d = d * (1.0 + noise_std_rel * gauss[s, k])
            if ok and drop and unif[s, k] < dropout:
                ok = False
            if ok and (d < min_range or d > max_range):
                ok = False
            valid[s, k] = ok
            if not ok:
                depth[s, k] = 0.0
                geomid[s, k] = -1
                continue
            depth[s, k] = d * cos_axis[k]
            points[total, 0] = o0 + d * vec[s, 0, k]
            points[total, 1] = o1 + d * vec[s, 1, k]
            points[total, 2] = o2 + d * vec[s, 2, k]
            total += 1
        counts[s] = total - start
    return total


@njit(cache=True, inline="always")
def _quad_roots(a, b, c):  # pragma: no cover - compiled
    """Roots of a·x² + 2b·x + c = 0 as MuJoCo's ray_quad; (-1, -1) if none."""
    det = b * b - a * c
    if det < MINVAL:
        return -1.0, -1.0
    det = math.sqrt(det)
    return (-b - det) / a, (-b + det) / a


@njit(cache=True, inline="always")
def _first_root(a, b, c):  # pragma: no cover - compiled
    """Nearest non-negative root of a·x² + 2b·x + c = 0, -1 if none (MuJoCo's ray_quad)."""
    x0, x1 = _quad_roots(a, b, c)
    if x0 >= 0.0:
        return x0
    if x1 >= 0.0:
        return x1
    return -1.0


@njit(cache=True, inline="always")
def _take(x, sol):  # pragma: no cover - compiled
    """The nearer of two ray lengths, -1 meaning none."""
    if sol >= 0.0 and (x < 0.0 or sol < x):
        return sol
    return x


@njit(cache=True, inline="always")
def _ray_box_face(x, lpi, lvi, si, lpj, lvj, sj, lpk, lvk, sk):  # pragma: no cover - compiled
    """Nearer of ``x`` and the hits on the two box faces normal to local axis i."""
    if abs(lvi) > MINVAL:
        for side in (-1.0, 1.0):
            sol = (side * si - lpi) / lvi
            if sol >= 0.0 and abs(lpj + sol * lvj) <= sj and abs(lpk + sol * lvk) <= sk:
                x = _take(x, sol)
    return x


@njit(cache=True, inline="always")
def _ray_geom(gtype, s0, s1, s2, lp0, lp1, lp2, lv0, lv1, lv2):  # pragma: no cover - compiled
    """Ray length to a primitive geom in its own frame, -1 if none (MuJoCo's engine_ray.c).

    Args:
        gtype: mjtGeom of the geom (a primitive).
        s0: ``geom_size[0]``, metres.
        s1: ``geom_size[1]``, metres.
        s2: ``geom_size[2]``, metres.
        lp0: ray origin x in the geom frame, metres.
        lp1: ray origin y in the geom frame, metres.
        lp2: ray origin z in the geom frame, metres.
        lv0: ray direction x in the geom frame (unit vector).
        lv1: ray direction y in the geom frame.
        lv2: ray direction z in the geom frame.
    """
    if gtype == PLANE:
        if lv2 > -MINVAL:
            return -1.0
        x = -lp2 / lv2
        if x < 0.0:
            return -1.0
        if (s0 <= 0.0 or abs(lp0 + x * lv0) <= s0) and (s1 <= 0.0 or abs(lp1 + x * lv1) <= s1):
            return x
        return -1.0
    if gtype == BOX:  # cast_frame casts boxes with _cast_box, the same test without branches
        x = _ray_box_face(-1.0, lp0, lv0, s0, lp1, lv1, s1, lp2, lv2, s2)
        x = _ray_box_face(x, lp1, lv1, s1, lp0, lv0, s0, lp2, lv2, s2)
        return _ray_box_face(x, lp2, lv2, s2, lp0, lv0, s0, lp1, lv1, s1)
    if gtype == SPHERE:
        b = lv0 * lp0 + lv1 * lp1 + lv2 * lp2
        c = lp0 * lp0 + lp1 * lp1 + lp2 * lp2 - s0 * s0
        return _first_root(lv0 * lv0 + lv1 * lv1 + lv2 * lv2, b, c)
    if gtype == ELLIPSOID:
        i0 = 1.0 / (s0 * s0)
        i1 = 1.0 / (s1 * s1)
        i2 = 1.0 / (s2 * s2)
        a = i0 * lv0 * lv0 + i1 * lv1 * lv1 + i2 * lv2 * lv2
        b = i0 * lv0 * lp0 + i1 * lv1 * lp1 + i2 * lv2 * lp2
        c = i0 * lp0 * lp0 + i1 * lp1 * lp1 + i2 * lp2 * lp2 - 1.0
        return _first_root(a, b, c)
    if gtype == CYLINDER:
        x = -1.0
        if abs(lv2) > MINVAL:
            for side in (-1.0, 1.0):
                sol = (side * s1 - lp2) / lv2
                if sol >= 0.0:
                    p0 = lp0 + sol * lv0
                    p1 = lp1 + sol * lv1
                    if p0 * p0 + p1 * p1 <= s0 * s0:
                        x = _take(x, sol)
        a = lv0 * lv0 + lv1 * lv1
        b = lv0 * lp0 + lv1 * lp1
        c = lp0 * lp0 + lp1 * lp1 - s0 * s0
        sol = _first_root(a, b, c)
        if sol >= 0.0 and abs(lp2 + sol * lv2) <= s1:
            x = _take(x, sol)
        return x
    if gtype == CAPSULE:
        x = -1.0
        a = lv0 * lv0 + lv1 * lv1
        b = lv0 * lp0 + lv1 * lp1
        c = lp0 * lp0 + lp1 * lp1 - s0 * s0
        sol = _first_root(a, b, c)
        if sol >= 0.0 and abs(lp2 + sol * lv2) <= s1:
            x = _take(x, sol)
        a = lv0 * lv0 + lv1 * lv1 + lv2 * lv2
        for side in (-1.0, 1.0):
            dz = lp2 - side * s1
            b = lv0 * lp0 + lv1 * lp1 + lv2 * dz
            c = lp0 * lp0 + lp1 * lp1 + dz * dz - s0 * s0
            x0, x1 = _quad_roots(a, b, c)
            # each cap's hemisphere only (MuJoCo accepts z >= s1 at the top, z <= -s1 below)
            if x0 >= 0.0 and side * (lp2 + x0 * lv2) >= s1:
                x = _take(x, x0)
            if x1 >= 0.0 and side * (lp2 + x1 * lv2) >= s1:
                x = _take(x, x1)
        return x
    return -1.0


@njit(cache=True, inline="always")
def _bound_radius(gtype, s0, s1, s2):  # pragma: no cover - compiled
    """Radius of a sphere about the geom's centre that holds it, metres (inf for planes)."""
    if gtype == PLANE:
        return math.inf
    if gtype == SPHERE:
        return s0
    if gtype == CAPSULE:
        return s0 + s1
    if gtype == CYLINDER:
        return math.sqrt(s0 * s0 + s1 * s1)
    if gtype == ELLIPSOID:
        return max(s0, max(s1, s2))
    return math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)


# Columns of the geom table, one row per geom a sensor keeps: type, bounding radius, size,
# sensor minus geom position e, mat, the ray origin in the geom frame (mat^T e), the
# bounding-sphere term e·e - rb² (both the same for every ray of a sensor, so computed once per
# sensor and geom), and the first and last pixel row and column whose rays can meet the geom.
T_TYPE, T_RB, T_SIZE, T_E, T_MAT, T_LP, T_C = 0, 1, 2, 5, 8, 17, 20
T_ROW0, T_ROW1, T_COL0, T_COL1, T_LEN = 21, 22, 23, 24, 25
TILE_RAYS = 512
"""Rays per tile of :func:`cast_frame` (whole image rows, at least one): a tile's rays, ray
lengths and geom ids (4 × 512 × 8 bytes and 2 kB) stay in the L1 cache while every geom is cast
and the tile is packed."""
_SPAN_RADIUS_REL = 1e-6  # a sphere's pixel span is taken for a radius this much larger ...
_SPAN_RADIUS_ABS = 1e-6  # ... plus this (m), and grown by a pixel each side: rounding never cuts
_SPAN_MAX_ANGLE = 1.5  # rad; a tangent this far off the axis: no bound on that side


@njit(cache=True, inline="always")
def _span(lo, hi, tan_half, n):  # pragma: no cover - compiled
    """Pixels along one image axis that look along tangents in ``[lo, hi]``, grown by one.

    Pixel ``i`` looks along ``tan_half - i · 2 tan_half / (n - 1)`` (the pinhole grid of
    ``ToFArray``; ``n >= 2``); ``lo`` may be -inf and ``hi`` +inf.

    Returns:
        ``(first, last)`` within ``[0, n - 1]``; ``last < first`` when no pixel does.
    """
    step = 2.0 * tan_half / (n - 1)
    first = max(0.0, (tan_half - hi) / step - 1.0)
    last = min(n - 1.0, (tan_half - lo) / step + 1.0)
    if first > last:
        return 1, 0
    return int(math.floor(first)), int(math.ceil(last))


@njit(cache=True, inline="always")
def _sphere_span(across, along, radius, tan_half, n):  # pragma: no cover - compiled
    """Pixels along one image axis whose rays can meet a sphere wholly in front of the sensor.

    They lie between the two tangents from the sensor to the sphere's outline in the plane of
    the axis (a tangent more than ``_SPAN_MAX_ANGLE`` off the optical axis bounds nothing).

    Args:
        across: sphere centre's coordinate along the image axis (site y for columns, z for rows;
            +y and +z are pixel 0's side), metres.
        along: sphere centre's coordinate along the optical axis (site x), metres, > radius.
        radius: sphere radius, metres.
        tan_half: tangent of half the field of view along the axis.
        n: pixels along the axis, >= 2.

    Returns:
        ``(first, last)`` as :func:`_span`.
    """
    centre = math.atan2(across, along)
    half = math.asin(min(1.0, radius / math.sqrt(along * along + across * across)))
    hi = math.tan(centre + half) if centre + half < _SPAN_MAX_ANGLE else math.inf
    lo = math.tan(centre - half) if centre - half > -_SPAN_MAX_ANGLE else -math.inf
    return _span(lo, hi, tan_half, n)


@njit(cache=True, inline="always")
def _box_spans(r, c0, c1, c2, x, s0, s1, s2, tan_h, tan_v, width, height):  # pragma: no cover
    """Pixel rows and columns whose rays can meet a box, from its corners' images.

    A ray that meets the box passes through one of its points, whose image lies in the convex
    hull of the corners' images when every corner is in front of the sensor: the rows and
    columns spanned by the corners (grown by a pixel each side) hold every such ray.

    Args:
        r: (9,) float64, the site's orientation (``site_xmat``).
        c0: box centre minus sensor position, world x, metres.
        c1: the same, world y.
        c2: the same, world z.
        x: (9,) float64, the box's orientation (``geom_xmat``).
        s0: half size along the box's x, metres.
        s1: half size along its y.
        s2: half size along its z.
        tan_h: tangent of half the horizontal field of view.
        tan_v: tangent of half the vertical field of view.
        width: W, pixels per row, >= 2.
        height: H, rows, >= 2.

    Returns:
        ``(row0, row1, col0, col1)``; the whole image if a corner is not in front (site x
        below 1 mm).
    """
    u_lo = v_lo = math.inf
    u_hi = v_hi = -math.inf
    for corner in range(8):
        a = s0 if corner & 1 else -s0
        b = s1 if corner & 2 else -s1
        c = s2 if corner & 4 else -s2
        w0 = c0 + a * x[0] + b * x[1] + c * x[2]
        w1 = c1 + a * x[3] + b * x[4] + c * x[5]
        w2 = c2 + a * x[6] + b * x[7] + c * x[8]
        px = r[0] * w0 + r[3] * w1 + r[6] * w2
        if not px > 1e-3:
            return 0, height - 1, 0, width - 1
        u = (r[1] * w0 + r[4] * w1 + r[7] * w2) / px
        v = (r[2] * w0 + r[5] * w1 + r[8] * w2) / px
        u_lo, u_hi = min(u_lo, u), max(u_hi, u)
        v_lo, v_hi = min(v_lo, v), max(v_hi, v)
    row0, row1 = _span(v_lo, v_hi, tan_v, height)
    col0, col1 = _span(u_lo, u_hi, tan_h, width)
    return row0, row1, col0, col1


@njit(cache=True, error_model="numpy")
def _cast_plane(vx, vy, vz, m, g, s0, s1, lp0, lp1, lp2, x, dist, geomid):  # pragma: no cover
    """Take the hits of a tile's rays on plane geom ``g`` where they are the nearest yet.

    The plane branch of :func:`_ray_geom` for every ray of a tile, written without early
    returns and with NumPy's error model (no zero-divisor check), so that LLVM vectorises it.

    Args:
        vx: (T,) float64, the rays' world x components (unit rays).
        vy: (T,) float64, their y components.
        vz: (T,) float64, their z components.
        m: rays of the tile (the first ``m`` entries of the arrays).
        g: geom id.
        s0: ``geom_size[g, 0]``, metres (half size along x; <= 0 is infinite).
        s1: ``geom_size[g, 1]``, metres (half size along y; <= 0 is infinite).
        lp0: sensor position x in the geom frame, metres.
        lp1: sensor position y in the geom frame, metres.
        lp2: sensor position z in the geom frame, metres.
        x: (9,) float64, the geom's orientation (``geom_xmat[g]``).
        dist: (T,) float64, metres, ray lengths to the nearest hit so far (-1: none); updated.
        geomid: (T,) int32, geom of that hit (-1: none); updated.
    """
    x0, x1, x2, x3, x4, x5, x6, x7, x8 = x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7], x[8]
    for j in range(m):
        lv0 = x0 * vx[j] + x3 * vy[j] + x6 * vz[j]
        lv1 = x1 * vx[j] + x4 * vy[j] + x7 * vz[j]
        lv2 = x2 * vx[j] + x5 * vy[j] + x8 * vz[j]
        t = -lp2 / lv2
        best = dist[j]
        if (
            not (lv2 > -MINVAL)
            and t >= 0.0
            and (s0 <= 0.0 or abs(lp0 + t * lv0) <= s0)
            and (s1 <= 0.0 or abs(lp1 + t * lv1) <= s1)
            and (best < 0.0 or t < best)
        ):
            dist[j] = t
            geomid[j] = g


@njit(cache=True)
def _combine(d0, d1, d2, a0, a1, a2, out):  # pragma: no cover - compiled
    """``out[j] = a0 · d0[j] + a1 · d1[j] + a2 · d2[j]`` for the ``len(d0)`` first entries.

    One row of a rotation: the sums in :func:`rotate_rays`'s order, so the values are its own.
    """
    for j in range(d0.shape[0]):
        out[j] = a0 * d0[j] + a1 * d1[j] + a2 * d2[j]


@njit(cache=True)
def _gate(dist, min_range, max_range):  # pragma: no cover - compiled
    """Range gate of noise-free ray lengths in place: -1 where none or outside the gate.

    Args:
        dist: (m,) float64, metres, ray lengths (< 0: no hit); updated.
        min_range: metres, nearest valid ray length (>= 0).
        max_range: metres, farthest valid ray length.
    """
    for j in range(dist.shape[0]):
        d = dist[j]
        ok = (d >= 0.0) & ~((d < min_range) | (d > max_range))
        dist[j] = d if ok else -1.0


@njit(cache=True)
def _gate_noisy(
    dist, gauss, unif, noise_std_rel, dropout, min_range, max_range
):  # pragma: no cover - compiled
    """Range noise, dropout and range gate in place, as :func:`pack_frame` applies them.

    Args:
        dist: (m,) float64, metres, ray lengths (< 0: no hit); updated: the noisy length, or -1
            where there is no hit, the pixel drops out or the length is outside the gate.
        gauss: (m,) float64, standard normal draws.
        unif: (m,) float64, uniform [0, 1) draws.
        noise_std_rel: σ_d / d, 1 (0: no noise).
        dropout: probability a valid pixel is dropped, 1 (0: none).
        min_range: metres, nearest valid ray length (>= 0).
        max_range: metres, farthest valid ray length.
    """
    noisy = noise_std_rel > 0.0
    drop = dropout > 0.0
    for j in range(dist.shape[0]):
        d = dist[j]
        ok = d >= 0.0
        if noisy:
            d = d * (1.0 + noise_std_rel * gauss[j])
        ok = ok & ~(drop & (unif[j] < dropout)) & ~((d < min_range) | (d > max_range))
        dist[j] = d if ok else -1.0


@njit(cache=True)
def _write_pixels(dist, gid, cos_axis, valid, depth, geomid):  # pragma: no cover - compiled
    """Validity, z-depth and geom id of gated pixels (one loop per output, each vectorises).

    Args:
        dist: (m,) float64, metres, gated ray lengths (-1: invalid, else >= 0).
        gid: (m,) int32, geom hit.
        cos_axis: (m,) float64, cosine of each ray to the optical axis.
        valid: (m,) bool, written.
        depth: (m,) float32, metres, written: d · cos, 0 where invalid.
        geomid: (m,) int32, written: the geom, -1 where invalid.
    """
    for j in range(dist.shape[0]):
        valid[j] = dist[j] >= 0.0
    for j in range(dist.shape[0]):
        d = dist[j]
        depth[j] = d * cos_axis[j] if d >= 0.0 else 0.0
    for j in range(dist.shape[0]):
        geomid[j] = gid[j] if dist[j] >= 0.0 else -1


@njit(cache=True)
def _pack_points(dist, ray, o0, o1, o2, scratch, points, total):  # pragma: no cover - compiled
    """Append a tile's valid points to ``points`` in pixel order; return the new count.

    Every pixel's point is computed in vectorised passes into ``scratch`` (one per axis), and
    only the copying of the valid ones is left to the scalar loop.

    Args:
        dist: (m,) float64, metres, gated ray lengths (-1: invalid, else >= 0).
        ray: (3, T) float64, the tile's unit rays in the world, a row per axis (T >= m).
        o0: sensor position x, metres.
        o1: sensor position y, metres.
        o2: sensor position z, metres.
        scratch: (3, T) float32, overwritten.
        points: (N, 3) float32, metres; rows ``total`` on are written.
        total: points already written.
    """
    m = dist.shape[0]
    _point_axis(dist, ray[0], o0, scratch[0])
    _point_axis(dist, ray[1], o1, scratch[1])
    _point_axis(dist, ray[2], o2, scratch[2])
    flat = points.reshape(-1)
    j = 0
    while j < m:
        if not dist[j] >= 0.0:
            j += 1
            continue
        end = j + 1
        while end < m and dist[end] >= 0.0:
            end += 1
        # Unsigned indices: numba adds no negative-index wraparound, and the loop vectorises.
        at = np.uint64(3 * total)
        for q in range(end - j):
            u = np.uint64(q)
            v = np.uint64(j + q)
            flat[at + np.uint64(3) * u] = scratch[0, v]
            flat[at + np.uint64(3) * u + np.uint64(1)] = scratch[1, v]
            flat[at + np.uint64(3) * u + np.uint64(2)] = scratch[2, v]
        total += end - j
        j = end
    return total


@njit(cache=True)
def _point_axis(dist, ray, origin, out):  # pragma: no cover - compiled
    """``out[j] = origin + dist[j] · ray[j]`` as float32, for the ``len(dist)`` first entries."""
    for j in range(dist.shape[0]):
        out[j] = origin + dist[j] * ray[j]


@njit(cache=True, inline="always")
def _box_face(x, lpi, lvi, si, side, lpj, lvj, sj, lpk, lvk, sk):  # pragma: no cover - compiled
    """:func:`_take` of ``x`` and the hit on one box face, without a branch (lvi may be 0)."""
    sol = (side * si - lpi) / lvi
    hit = (
        (abs(lvi) > MINVAL)
        & (sol >= 0.0)
        & (abs(lpj + sol * lvj) <= sj)
        & (abs(lpk + sol * lvk) <= sk)
        & ((x < 0.0) | (sol < x))
    )
    return sol if hit else x


@njit(cache=True, error_model="numpy")
def _cast_box(vx, vy, vz, g, row, dist, geomid):  # pragma: no cover - compiled
    """Take the hits of a run of rays on box geom ``g`` where they are the nearest yet.

    The box branch of the per-ray cast (bounding-sphere test, then :func:`_ray_geom`'s box),
    written without branches and with NumPy's error model (a face parallel to the ray divides
    by ~0 and is masked out), so that LLVM vectorises it. Every face is tried, in MuJoCo's
    order; the hit is the nearest valid one, the same value as the branching code's.

    Args:
        vx: (m,) float64, the rays' world x components (unit rays).
        vy: (m,) float64, their y components.
        vz: (m,) float64, their z components.
        g: geom id.
        row: (T_LEN,) float64, the geom's row of the geom table (columns ``T_*``).
        dist: (m,) float64, metres, ray lengths to the nearest hit so far (-1: none); updated.
        geomid: (m,) int32, geom of that hit (-1: none); updated.
    """
    s0, s1, s2 = row[T_SIZE], row[T_SIZE + 1], row[T_SIZE + 2]
    e0, e1, e2 = row[T_E], row[T_E + 1], row[T_E + 2]
    lp0, lp1, lp2 = row[T_LP], row[T_LP + 1], row[T_LP + 2]
    c = row[T_C]
    x0, x1, x2 = row[T_MAT], row[T_MAT + 1], row[T_MAT + 2]
    x3, x4, x5 = row[T_MAT + 3], row[T_MAT + 4], row[T_MAT + 5]
    x6, x7, x8 = row[T_MAT + 6], row[T_MAT + 7], row[T_MAT + 8]
    outside = c > 0.0
    for j in range(dist.shape[0]):
        best = dist[j]
        b = vx[j] * e0 + vy[j] * e1 + vz[j] * e2
        disc = b * b - c
        # misses the bounding sphere, it lies behind, or it lies wholly beyond the nearest hit
        sphere = ~outside | (
            (b <= 0.0) & (disc >= 0.0) & ~((best >= 0.0) & (-b - math.sqrt(max(disc, 0.0)) > best))
        )
        lv0 = x0 * vx[j] + x3 * vy[j] + x6 * vz[j]
        lv1 = x1 * vx[j] + x4 * vy[j] + x7 * vz[j]
        lv2 = x2 * vx[j] + x5 * vy[j] + x8 * vz[j]
        t = _box_face(-1.0, lp0, lv0, s0, -1.0, lp1, lv1, s1, lp2, lv2, s2)
        t = _box_face(t, lp0, lv0, s0, 1.0, lp1, lv1, s1, lp2, lv2, s2)
        t = _box_face(t, lp1, lv1, s1, -1.0, lp0, lv0, s0, lp2, lv2, s2)
        t = _box_face(t, lp1, lv1, s1, 1.0, lp0, lv0, s0, lp2, lv2, s2)
        t = _box_face(t, lp2, lv2, s2, -1.0, lp0, lv0, s0, lp1, lv1, s1)
        t = _box_face(t, lp2, lv2, s2, 1.0, lp0, lv0, s0, lp1, lv1, s1)
        take = sphere & (t >= 0.0) & ((best < 0.0) | (t < best))
        dist[j] = t if take else best
        geomid[j] = g if take else geomid[j]


# nogil: a frame's kernel runs long enough (0.1-1 ms) for another thread to use the GIL
# meanwhile (BatchVectorEnv steps sub-envs on threads).
@njit(cache=True, nogil=True)
def cast_frame(
    dirs_t,
    cone_cos,
    tan_h,
    tan_v,
    width,
    site_xpos,
    site_xmat,
    site_ids,
    cand,
    geom_type,
    geom_size,
    geom_rgba,
    geom_matid,
    mat_rgba,
    geom_xpos,
    geom_xmat,
    min_range,
    max_range,
    noise_std_rel,
    dropout,
    gauss,
    unif,
    table,
    table_id,
    ray_buf,
    dist_buf,
    gid_buf,
    pts_buf,
    depth,
    valid,
    geomid,
    points,
    origins,
    counts,
):  # pragma: no cover - compiled
    """Cast, gate and pack a whole frame against the primitive geoms ``cand`` (numba backend).

    Follows ``mj_multiRay`` with ``flg_static=1``, ``bodyexclude=-1``: geoms whose geom (or
    material) alpha is 0 are skipped; the geom-group mask is already applied in ``cand``.
    Geoms whose bounding sphere lies beyond ``max_range`` or outside the sensor's view cone are
    culled once per sensor; each remaining non-plane geom is cast only on the pixel rows and
    columns whose rays can meet its bounding sphere (for a box, also its corners' images:
    :func:`_box_spans`), and gets a bounding-sphere test per ray; boxes are cast branch-free
    (:func:`_cast_box`), the other primitives ray by ray (:func:`_ray_geom`).

    The image is cast in tiles of whole rows (``ray_buf``'s width): a tile's rays are rotated
    into the world, cast against every kept geom in turn (so each ray meets the geoms in the
    same order, and ties go the same way, as in a geom-by-geom pass over the whole image), then
    gated and packed as :func:`pack_frame` does, while they are in the cache. The result is that
    of :func:`rotate_rays`, a geom-by-geom cast and :func:`pack_frame`, bit for bit.

    Args:
        dirs_t: (3, n) float64, unit rays in the site frame, a row per axis, row-major pixels;
            row 0 is each ray's cosine to the optical axis (z-depth = d · cos).
        cone_cos: cosine of the half-angle of the cone around +x that holds all rays.
        tan_h: tangent of half the horizontal field of view (column 0 looks along +tan_h).
        tan_v: tangent of half the vertical field of view (row 0 looks along +tan_v).
        width: W, pixels per image row (``n = H · W``).
        site_xpos: (nsite, 3) float64, metres, ``data.site_xpos``.
        site_xmat: (nsite, 9) float64, ``data.site_xmat``.
        site_ids: (S,) int64, the sensors' site ids.
        cand: (G,) int64, ids of the ray-visible geoms (all primitives).
        geom_type: (ngeom,) int32, ``model.geom_type``.
        geom_size: (ngeom, 3) float64, ``model.geom_size``.
        geom_rgba: (ngeom, 4) float32, ``model.geom_rgba``.
        geom_matid: (ngeom,) int32, ``model.geom_matid``.
        mat_rgba: (nmat, 4) float32, ``model.mat_rgba``.
        geom_xpos: (ngeom, 3) float64, ``data.geom_xpos``.
        geom_xmat: (ngeom, 9) float64, ``data.geom_xmat``.
        min_range: metres, nearest valid ray length.
        max_range: metres, farthest valid ray length, and the geom cull distance.
        noise_std_rel: σ_d / d, 1.
        dropout: probability a valid pixel is dropped, 1.
        gauss: (S, n) float64, standard normal draws (read only if noise_std_rel > 0).
        unif: (S, n) float64, uniform [0, 1) draws (read only if dropout > 0).
        table: (G, T_LEN) float64, scratch: the kept geoms' columns ``T_*``.
        table_id: (G,) int32, scratch: their ids.
        ray_buf: (3, T) float64, scratch: a tile's rays in the world; T a multiple of W.
        dist_buf: (T,) float64, scratch: their lengths to the nearest hit, -1 if none.
        gid_buf: (T,) int32, scratch: the geom hit, -1 if none.
        pts_buf: (3, T) float32, scratch: the tile's points, a row per axis.
        depth: (S, n) float32, metres, written (0 where invalid).
        valid: (S, n) bool, written.
        geomid: (S, n) int32, written: geom seen, -1 where invalid.
        points: (S·n, 3) float32, metres, world frame; the first ``total`` rows are written.
        origins: (S, 3) float64, metres, written with the sensor positions.
        counts: (S,) int64, written with points per sensor.

    Returns:
        total, the number of points written.
    """
    n = dirs_t.shape[1]
    height = n // width
    rows = max(1, ray_buf.shape[1] // width)
    grid = width >= 2 and height >= 2
    cone_sin = math.sqrt(max(0.0, 1.0 - cone_cos * cone_cos))
    noisy = noise_std_rel > 0.0
    drop = dropout > 0.0
    total = 0
    for s in range(site_ids.shape[0]):
        i = site_ids[s]
        o0, o1, o2 = site_xpos[i, 0], site_xpos[i, 1], site_xpos[i, 2]
        r0, r1, r2 = site_xmat[i, 0], site_xmat[i, 1], site_xmat[i, 2]
        r3, r4, r5 = site_xmat[i, 3], site_xmat[i, 4], site_xmat[i, 5]
        r6, r7, r8 = site_xmat[i, 6], site_xmat[i, 7], site_xmat[i, 8]
        origins[s, 0], origins[s, 1], origins[s, 2] = o0, o1, o2
        start = total
        na = 0
        for gi in range(cand.shape[0]):
            g = cand[gi]
            m = geom_matid[g]
            if (m < 0 and geom_rgba[g, 3] == 0.0) or (m >= 0 and mat_rgba[m, 3] == 0.0):
                continue
            gt = geom_type[g]
            rb = _bound_radius(gt, geom_size[g, 0], geom_size[g, 1], geom_size[g, 2])
            c0 = c1 = c2 = along = 0.0
            if gt != PLANE:
                c0 = geom_xpos[g, 0] - o0
                c1 = geom_xpos[g, 1] - o1
                c2 = geom_xpos[g, 2] - o2
                dc = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
                if dc - rb > max_range:
                    continue
                along = r0 * c0 + r3 * c1 + r6 * c2
                if dc > rb:
                    # distance of the centre from the view cone, dc·sin(θ − α), against rb
                    off = math.sqrt(max(0.0, dc * dc - along * along))
                    if off * cone_cos - along * cone_sin > rb:
                        continue
            table[na, T_TYPE] = gt
            table[na, T_RB] = rb
            for j in range(3):
                table[na, T_SIZE + j] = geom_size[g, j]
            e0 = o0 - geom_xpos[g, 0]
            e1 = o1 - geom_xpos[g, 1]
            e2 = o2 - geom_xpos[g, 2]
            table[na, T_E] = e0
            table[na, T_E + 1] = e1
            table[na, T_E + 2] = e2
            for j in range(9):
                table[na, T_MAT + j] = geom_xmat[g, j]
            x = geom_xmat[g]
            table[na, T_LP] = x[0] * e0 + x[3] * e1 + x[6] * e2
            table[na, T_LP + 1] = x[1] * e0 + x[4] * e1 + x[7] * e2
            table[na, T_LP + 2] = x[2] * e0 + x[5] * e1 + x[8] * e2
            c = e0 * e0 + e1 * e1 + e2 * e2 - rb * rb
            table[na, T_C] = c
            # Pixels whose rays can meet the geom: all of them for a plane, a bounding sphere
            # round the sensor or one reaching behind it; else a rectangle round the sphere's
            # outline, and for a box round its corners' images too.
            row0, row1, col0, col1 = 0, height - 1, 0, width - 1
            radius = rb * (1.0 + _SPAN_RADIUS_REL) + _SPAN_RADIUS_ABS
            if gt != PLANE and grid and c > 0.0 and along > radius:
                col0, col1 = _sphere_span(r1 * c0 + r4 * c1 + r7 * c2, along, radius, tan_h, width)
                row0, row1 = _sphere_span(r2 * c0 + r5 * c1 + r8 * c2, along, radius, tan_v, height)
            if gt == BOX and grid:
                b0, b1, b2, b3 = _box_spans(
                    site_xmat[i], c0, c1, c2, geom_xmat[g], geom_size[g, 0], geom_size[g, 1],
                    geom_size[g, 2], tan_h, tan_v, width, height,
                )  # fmt: skip
                row0, row1 = max(row0, b0), min(row1, b1)
                col0, col1 = max(col0, b2), min(col1, b3)
            table[na, T_ROW0] = row0
            table[na, T_ROW1] = row1
            table[na, T_COL0] = col0
            table[na, T_COL1] = col1
            table_id[na] = g
            na += 1
        for tile0 in range(0, height, rows):
            tile1 = min(height, tile0 + rows)  # rows [tile0, tile1)
            k0 = tile0 * width
            mt = (tile1 - tile0) * width
            # The tile's rays in the world, one loop per axis (each vectorises; one loop writing
            # five arrays needs too many runtime alias checks and stays scalar).
            d0, d1, d2 = dirs_t[0, k0 : k0 + mt], dirs_t[1, k0 : k0 + mt], dirs_t[2, k0 : k0 + mt]
            _combine(d0, d1, d2, r0, r1, r2, ray_buf[0])
            _combine(d0, d1, d2, r3, r4, r5, ray_buf[1])
            _combine(d0, d1, d2, r6, r7, r8, ray_buf[2])
            dist_buf[:mt] = -1.0
            gid_buf[:mt] = -1
            for a in range(na):
                gt = int(table[a, T_TYPE])
                g = table_id[a]
                s0, s1, s2 = table[a, T_SIZE], table[a, T_SIZE + 1], table[a, T_SIZE + 2]
                lp0, lp1, lp2 = table[a, T_LP], table[a, T_LP + 1], table[a, T_LP + 2]
                if gt == PLANE:
                    _cast_plane(
                        ray_buf[0], ray_buf[1], ray_buf[2], mt, g, s0, s1, lp0, lp1, lp2,
                        table[a, T_MAT:T_LP], dist_buf, gid_buf,
                    )  # fmt: skip
                    continue
                first = max(tile0, int(table[a, T_ROW0]))
                last = min(tile1 - 1, int(table[a, T_ROW1]))
                if first > last:
                    continue
                col0, col1 = int(table[a, T_COL0]), int(table[a, T_COL1])
                e0, e1, e2 = table[a, T_E], table[a, T_E + 1], table[a, T_E + 2]
                c = table[a, T_C]
                x0, x1, x2 = table[a, T_MAT], table[a, T_MAT + 1], table[a, T_MAT + 2]
                x3, x4, x5 = table[a, T_MAT + 3], table[a, T_MAT + 4], table[a, T_MAT + 5]
                x6, x7, x8 = table[a, T_MAT + 6], table[a, T_MAT + 7], table[a, T_MAT + 8]
                for row in range(first, last + 1):
                    base = (row - tile0) * width
                    if gt == BOX:
                        _cast_box(
                            ray_buf[0, base + col0 : base + col1 + 1],
                            ray_buf[1, base + col0 : base + col1 + 1],
                            ray_buf[2, base + col0 : base + col1 + 1],
                            g, table[a], dist_buf[base + col0 : base + col1 + 1],
                            gid_buf[base + col0 : base + col1 + 1],
                        )  # fmt: skip
                        continue
                    for j in range(base + col0, base + col1 + 1):
                        vx = ray_buf[0, j]
                        vy = ray_buf[1, j]
                        vz = ray_buf[2, j]
                        best = dist_buf[j]
                        b = vx * e0 + vy * e1 + vz * e2
                        if c > 0.0:
                            disc = b * b - c
                            if b > 0.0 or disc < 0.0:
                                continue  # misses the bounding sphere, or it lies behind
                            if best >= 0.0 and -b - math.sqrt(disc) > best:
                                continue  # bounding sphere wholly beyond the nearest hit so far
                        t = _ray_geom(
                            gt, s0, s1, s2, lp0, lp1, lp2,
                            x0 * vx + x3 * vy + x6 * vz,
                            x1 * vx + x4 * vy + x7 * vz,
                            x2 * vx + x5 * vy + x8 * vz,
                        )  # fmt: skip
                        if t >= 0.0 and (best < 0.0 or t < best):
                            dist_buf[j] = t
                            gid_buf[j] = g
            # Noise and range gate (vectorised passes over the tile), then the packed points.
            if noisy or drop:
                _gate_noisy(
                    dist_buf[:mt], gauss[s, k0 : k0 + mt], unif[s, k0 : k0 + mt],
                    noise_std_rel, dropout, min_range, max_range,
                )  # fmt: skip
            else:
                _gate(dist_buf[:mt], min_range, max_range)
            _write_pixels(
                dist_buf[:mt], gid_buf[:mt], d0, valid[s, k0 : k0 + mt],
                depth[s, k0 : k0 + mt], geomid[s, k0 : k0 + mt],
            )  # fmt: skip
            total = _pack_points(dist_buf[:mt], ray_buf, o0, o1, o2, pts_buf, points, total)
        counts[s] = total - start
    return total
