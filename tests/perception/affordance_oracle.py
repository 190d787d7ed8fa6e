"""Test oracle of the affordance kernels: the compiled functions as they were before issue 23's
speed-ups (commit 3d26d7f of ``neurocog_gym/perception/_affordance_kernels.py``), kept verbatim
so the faster kernels can be checked against them bit for bit on many graphs
(``test_affordance_oracle.py``). The compiled helpers they call are copied too (numba's cache
would otherwise keep another file's helpers as they were when it compiled); the constants are
imported.

``detect_kernel`` here is the detection of the default "points" mode and of
``detect_affordances``; ``detect_kernel`` followed by ``map_step_kernel`` is the "map" mode's,
which ``AttentionPipeline._detect_map`` then wraps as :func:`detect_map` does.
"""

# ruff: noqa: E501

from __future__ import annotations

import math

import numpy as np
from numba import njit

from neurocog_gym.perception._affordance_kernels import (
    KIND_OBJECT,
    KIND_TERRAIN,
    KIND_WALL,
    L_DENSITY,
    L_GAMMA,
    L_HEIGHT,
    L_KIND,
    L_LENGTH,
    L_NNODES,
    L_SIZE,
    L_SUSPECTED,
    L_WIDTH,
    M_BOX,
    M_F0,
    M_F1,
    M_HBOX,
    M_HEIGHT,
    M_L0,
    M_L1,
    M_NHIGH,
    M_NNODES,
    M_SPACING,
    M_VIEW,
    MAX_PER_EDGE,
    MODE_GROUND_KNOWN,
    MODE_ORIENT_AWAY,
    N_LABEL_COLS,
    N_MAP_COLS,
    P_COS_GROW,
    P_COS_REGION,
    P_DENSITY,
    P_GROUND_SHARE,
    P_GROUND_TOL,
    P_MAX_FACETS,
    P_MIN_QUALITY,
    P_PADDING,
    P_RAISE_TOL,
    P_TERRAIN_TILT,
    P_WALL_HEIGHT,
    P_WALL_TILT,
    Q_EDGE_CORRECTION,
    Q_FLOOR_PLANE,
    Q_HIGH_BOX,
    Q_MERGE,
    Q_MIN_HEIGHT,
    Q_VIEW_BINS,
    Q_VIEW_CUT,
    Q_VIEW_FIRST,
    SLACK,
)
from neurocog_gym.perception.affordance import (
    _KIND_OF,
    AffordanceObject,
    Affordances,
    _empty_result,
    _forward_xy,
    _origin,
)


@njit(cache=True)
def finite_rows(points):
    """Return (n,) bool: True where all three coordinates of ``points`` (n, 3) are finite."""
    n = points.shape[0]
    ok = np.empty(n, np.bool_)
    for i in range(n):
        ok[i] = (
            np.isfinite(points[i, 0]) and np.isfinite(points[i, 1]) and np.isfinite(points[i, 2])
        )
    return ok


@njit(cache=True)
def _tilt(sx, sy, sz):
    """Eq. (3): angle between a (non-unit) normal and the vertical (0, 0, 1), radians."""
    nn = np.sqrt(sx * sx + sy * sy + sz * sz)
    if nn <= 1e-12:
        return 0.5 * np.pi
    return np.arccos(min(1.0, max(-1.0, sz / nn)))


@njit(cache=True)
def _centroid(nodes, edges):
    """Mean of the finite nodes that carry an edge (orientation centre for closed shapes)."""
    n = nodes.shape[0]
    used = np.zeros(n, np.bool_)
    for e in range(edges.shape[0]):
        for c in range(2):
            i = edges[e, c]
            if 0 <= i < n:
                used[i] = True
    out = np.zeros(3)
    cnt = 0
    for i in range(n):
        if used[i] and np.isfinite(nodes[i, 0] + nodes[i, 1] + nodes[i, 2]):
            out[0] += nodes[i, 0]
            out[1] += nodes[i, 1]
            out[2] += nodes[i, 2]
            cnt += 1
    if cnt > 0:
        out /= cnt
    return out


@njit(cache=True)
def _root(root, a):
    while root[a] != a:
        a = root[a]
    return a


@njit(cache=True, error_model="numpy")
def _view_slopes(points, fx, fy, of, ol, oz, umax, scale, slope, q):
    """Per point, tan of its elevation seen from the sensors and its azimuth-bin coordinate.

    Computed for every row, valid or not (the caller skips the rows behind the sensors), so
    the loop has no branch; with NumPy's error model (no zero-divisor checks) and the rows
    first copied into columns (strided loads), LLVM vectorises its divisions and square
    roots, about 2.5 times faster than the scalar loop. Same operations in the same order.

    Args:
        points: (N, 3) float32 or float64, metres, the frame.
        fx: x of the unit walking direction in the ground plane.
        fy: y of the unit walking direction in the ground plane.
        of: the sensors' position along the walking direction, metres.
        ol: the sensors' position across it, metres.
        oz: the sensors' height, metres.
        umax: the bins cover tan(azimuth) in [-umax, umax] about the walking direction.
        scale: bins per unit of tan(azimuth).
        slope: (N,) float64, written: (z - oz) / horizontal distance from the sensors.
        q: (N,) float64, written: the azimuth bin before truncation and clamping.
    """
    n = points.shape[0]
    xs = np.empty(n, points.dtype)
    ys = np.empty(n, points.dtype)
    zs = np.empty(n, points.dtype)
    for i in range(n):
        xs[i] = points[i, 0]
        ys[i] = points[i, 1]
        zs[i] = points[i, 2]
    for i in range(n):
        df = xs[i] * fx + ys[i] * fy - of
        dl = ys[i] * fx - xs[i] * fy - ol
        slope[i] = (zs[i] - oz) / np.sqrt(df * df + dl * dl)
        q[i] = (dl / df + umax) * scale


@njit(cache=True)
def view_edge_kernel(points, fx, fy, origin, nbins, umax):
    """The upper edge of the view per azimuth bin, and each point's elevation and bin.

    Seen from ``origin``, a point's tan(elevation) is (z - origin z) / its horizontal distance
    and its bin the truncated (tan(azimuth) + ``umax``) × ``nbins`` / (2 ``umax``) about the
    walking direction, clamped to the end bins; the edge of a bin is the largest tan(elevation)
    in it. Points level with or behind the sensors (along the walking direction), or absurdly
    high, get bin -1 and no edge. Shared by ``refine_objects_kernel`` and
    ``view_walls_kernel`` (one pass per frame).

    Returns:
        ``(slope, bins, edge)``: (N,) float64, (N,) int64, (nbins,) float64 (-inf: empty bin).
    """
    n = points.shape[0]
    of = origin[0] * fx + origin[1] * fy
    ol = origin[1] * fx - origin[0] * fy
    oz = origin[2]
    scale = nbins / (2.0 * umax)
    slope = np.empty(n)
    q = np.empty(n)
    _view_slopes(points, fx, fy, of, ol, oz, umax, scale, slope, q)
    edge = np.full(nbins, -np.inf)
    bins = np.empty(n, np.int64)
    for i in range(n):
        pf = points[i, 0] * fx + points[i, 1] * fy
        if not (pf - of > 1e-6 and abs(points[i, 2]) < 1e4):
            bins[i] = -1
            continue
        b = int(q[i])
        b = min(max(b, 0), nbins - 1)
        bins[i] = b
        if slope[i] > edge[b]:
            edge[b] = slope[i]
    return slope, bins, edge


@njit(cache=True)
def build_adjacency(valid, edges, slack):
    """Forward and full adjacency, CSR with slack, in two passes over ``edges`` (count, fill).

    Args:
        valid: (n,) bool, nodes that may carry edges (finite coordinates).
        edges: (m, 2) int64 node indices; self-loops, duplicates and edges touching an invalid
            node are dropped.
        slack: free slots per non-isolated row, for the quad diagonals.

    Returns:
        ``(fwd, fstart, fcap, fdeg, adj, aeid, start, cap, deg, n_bad)``: the forward rows (each
        node's higher neighbours; the slot of ``hi`` in row ``lo`` is the id of edge ``lo-hi``),
        the full rows with the edge id of each slot, and the number of edges with an index
        outside [0, n).
    """
    n = valid.shape[0]
    m = edges.shape[0]
    deg = np.zeros(n, np.int64)
    fdeg = np.zeros(n, np.int64)
    n_bad = 0
    for e in range(m):
        a = edges[e, 0]
        b = edges[e, 1]
        if a < 0 or b < 0 or a >= n or b >= n:
            n_bad += 1
            continue
        if a != b and valid[a] and valid[b]:
            deg[a] += 1
            deg[b] += 1
            fdeg[min(a, b)] += 1
    start = np.empty(n + 1, np.int64)
    cap = np.empty(n, np.int64)
    fstart = np.empty(n + 1, np.int64)
    fcap = np.empty(n, np.int64)
    total = 0
    ftotal = 0
    for i in range(n):
        start[i] = total
        fstart[i] = ftotal
        cap[i] = deg[i] + slack if deg[i] > 0 else 0
        fcap[i] = fdeg[i] + slack if deg[i] > 0 else 0
        total += cap[i]
        ftotal += fcap[i]
    start[n] = total
    fstart[n] = ftotal
    adj = np.empty(max(total, 1), np.int32)
    aeid = np.empty(max(total, 1), np.int32)
    fwd = np.empty(max(ftotal, 1), np.int32)
    deg[:] = 0
    fdeg[:] = 0
    for e in range(m):
        a = edges[e, 0]
        b = edges[e, 1]
        if a < 0 or b < 0 or a >= n or b >= n or a == b or not valid[a] or not valid[b]:
            continue
        lo = min(a, b)
        hi = max(a, b)
        # Duplicate edges: scan the (short) forward row; no helper call in the hot loop.
        s = fstart[lo]
        dup = False
        for k in range(fdeg[lo]):
            if fwd[s + k] == hi:
                dup = True
                break
        if dup:
            continue
        eid = fstart[lo] + fdeg[lo]
        fwd[eid] = hi
        fdeg[lo] += 1
        s = start[lo] + deg[lo]
        adj[s] = hi
        aeid[s] = eid
        deg[lo] += 1
        s = start[hi] + deg[hi]
        adj[s] = lo
        aeid[s] = eid
        deg[hi] += 1
    return fwd, fstart, fcap, fdeg, adj, aeid, start, cap, deg, n_bad


@njit(cache=True)
def triangulate_graph(nodes, edges, origin, away, max_facets, min_quality):
    """Facets of a graph: 3-cycles, then quads closed by their shorter diagonal (SPEC §4).

    Runs :func:`_triangulate_once` with a capacity for a surface mesh (1.5 facets per edge) and
    retries with twice the capacity, up to ``max_facets``, if that was too small. (Growing the
    arrays inside the enumeration loop instead makes numba refcount them on every iteration,
    which tripled the run time.)

    Returns:
        As :func:`_triangulate_once`; ``truncated`` means ``max_facets`` was reached.
    """
    m = edges.shape[0]
    fcap = max(16, min(max_facets, m + m // 2 + 16))
    while True:
        fi, ff, nf, truncated, n_bad, ecnt, eface = _triangulate_once(
            nodes, edges, origin, away, fcap, min_quality
        )
        if not truncated or fcap >= max_facets:
            return fi, ff, nf, truncated, n_bad, ecnt, eface
        fcap = min(max_facets, 2 * fcap)


@njit(cache=True)
def _triangulate_once(nodes, edges, origin, away, fcap, min_quality):
    """One triangulation pass with facet capacity ``fcap``.

    Every 3-cycle is a facet. A chordless 4-cycle whose four edges each border at most one
    3-cycle is a quad hole of the mesh: it gets its shorter diagonal (``a-c`` on a tie), and
    every 3-cycle through the new edge becomes a facet. (A chordless 4-cycle whose edges already
    carry two facets, such as the link of a degree-4 node, is no hole and is left alone.)
    Slivers are then skipped, and a facet whose three edges each carry two or more other facets
    is internal (spanned across a closed shape by diagonals, or a face of a volumetric GNG
    tetrahedron) and is dropped.

    The hot loops call no helper that takes arrays: numba reference-counts array arguments of
    such calls with atomic operations, which cost more than the geometry here.

    Args:
        nodes: (n, 3) float64, metres.
        edges: (m, 2) int64 node indices.
        origin: (3,) float64, metres: facet normals face it, or face away from it with ``away``.
        away: bool, orient away from ``origin`` (the caller passes the node centroid).
        fcap: facet capacity; enumeration stops there.
        min_quality: sliver threshold on 2 * area / longest_edge**2 (equilateral: 0.866).

    Returns:
        ``(fi, ff, nf, truncated, n_bad, ecnt, eface)``: facet arrays (first ``nf`` rows
        valid), whether ``fcap`` was hit, the number of edges with an out-of-range index, and
        the edge-to-facet table of the returned facets (facet count per edge id, first
        ``MAX_PER_EDGE`` facets).
    """
    n = nodes.shape[0]
    valid = finite_rows(nodes)
    fwd, fstart, fcapr, fdeg, adj, aeid, start, cap, deg, n_bad = build_adjacency(
        valid, edges, SLACK
    )
    ne = max(fstart[n], 1)
    ecnt = np.zeros(ne, np.int32)
    # Candidate facets (u, v, w, e_uv, e_vw, e_uw) before the geometry tests.
    cand = np.empty((fcap, 6), np.int32)
    nc = 0
    truncated = False
    mark = np.full(n, -1, np.int64)
    mslot = np.empty(n, np.int64)

    # All 3-cycles u < v < w over the forward rows; every edge of one is a forward edge.
    for u in range(n):
        fu = fstart[u]
        for k in range(fdeg[u]):
            mark[fwd[fu + k]] = u
            mslot[fwd[fu + k]] = fu + k
        for k in range(fdeg[u]):
            v = fwd[fu + k]
            fv = fstart[v]
            for k2 in range(fdeg[v]):
                w = fwd[fv + k2]
                if mark[w] != u:
                    continue
                if nc >= fcap:
                    truncated = True
                    continue
                e0 = fu + k
                e1 = fv + k2
                e2 = mslot[w]
                cand[nc, 0] = u
                cand[nc, 1] = v
                cand[nc, 2] = w
                cand[nc, 3] = e0
                cand[nc, 4] = e1
                cand[nc, 5] = e2
                ecnt[e0] += 1
                ecnt[e1] += 1
                ecnt[e2] += 1
                nc += 1

    # Low edges (at most one facet), both directions, as CSR: a quad hole has only low edges.
    lcnt = np.zeros(n + 1, np.int64)
    for u in range(n):
        fu = fstart[u]
        for k in range(fdeg[u]):
            if ecnt[fu + k] <= 1:
                lcnt[u + 1] += 1
                lcnt[fwd[fu + k] + 1] += 1
    for i in range(n):
        lcnt[i + 1] += lcnt[i]
    lfill = lcnt[:n].copy()
    low = np.empty(max(lcnt[n], 1), np.int32)
    leid = np.empty(max(lcnt[n], 1), np.int32)
    for u in range(n):
        fu = fstart[u]
        for k in range(fdeg[u]):
            if ecnt[fu + k] <= 1:
                v = fwd[fu + k]
                low[lfill[u]] = v
                leid[lfill[u]] = fu + k
                lfill[u] += 1
                low[lfill[v]] = u
                leid[lfill[v]] = fu + k
                lfill[v] += 1

    # Quad holes a-b-c-d over low edges, found once from their lowest node a with b < d.
    mark[:] = -1
    mark2 = np.full(n, -1, np.int64)
    mslot2 = np.empty(n, np.int64)
    ndiag = 0
    for a in range(n):
        if lcnt[a + 1] - lcnt[a] < 2:
            continue
        fa = fstart[a]
        for k in range(fdeg[a]):
            mark[fwd[fa + k]] = a
            mslot[fwd[fa + k]] = fa + k
        for la in range(lcnt[a], lcnt[a + 1]):
            b = low[la]
            e_ab = leid[la]
            if b < a:
                continue
            for lb in range(lcnt[b], lcnt[b + 1]):
                c = low[lb]
                e_bc = leid[lb]
                if c <= a or mark[c] == a:
                    continue
                for lc in range(lcnt[c], lcnt[c + 1]):
                    d = low[lc]
                    if d <= b or mark[d] != a:
                        continue
                    e_ad = mslot[d]
                    if ecnt[leid[lc]] > 1 or ecnt[e_ad] > 1:
                        continue
                    # Facets added for an earlier quad may have closed this one.
                    if ecnt[e_ab] > 1 or ecnt[e_bc] > 1 or mark[c] == a:
                        break
                    chord = False
                    fb = fstart[b]
                    for k in range(fdeg[b]):
                        if fwd[fb + k] == d:
                            chord = True
                            break
                    if chord:
                        continue
                    # The shorter diagonal, a-c on a tie.
                    d_ac = 0.0
                    d_bd = 0.0
                    for x in range(3):
                        d_ac += (nodes[a, x] - nodes[c, x]) ** 2
                        d_bd += (nodes[b, x] - nodes[d, x]) ** 2
                    if d_ac <= d_bd:
                        p = a
                        q = c
                    else:
                        p = b
                        q = d
                    if fdeg[p] >= fcapr[p] or deg[p] >= cap[p] or deg[q] >= cap[q]:
                        continue
                    e_pq = fstart[p] + fdeg[p]
                    fwd[e_pq] = q
                    fdeg[p] += 1
                    adj[start[p] + deg[p]] = q
                    aeid[start[p] + deg[p]] = e_pq
                    deg[p] += 1
                    adj[start[q] + deg[q]] = p
                    aeid[start[q] + deg[q]] = e_pq
                    deg[q] += 1
                    if p == a:
                        mark[c] = a
                        mslot[c] = e_pq
                    # Every 3-cycle through the new edge p-q is a facet.
                    sq = start[q]
                    for kq in range(deg[q] - 1):
                        mark2[adj[sq + kq]] = ndiag
                        mslot2[adj[sq + kq]] = aeid[sq + kq]
                    sp = start[p]
                    for kp in range(deg[p] - 1):
                        x = adj[sp + kp]
                        if mark2[x] != ndiag:
                            continue
                        if nc >= fcap:
                            truncated = True
                            continue
                        e1 = mslot2[x]
                        e2 = aeid[sp + kp]
                        cand[nc, 0] = p
                        cand[nc, 1] = q
                        cand[nc, 2] = x
                        cand[nc, 3] = e_pq
                        cand[nc, 4] = e1
                        cand[nc, 5] = e2
                        ecnt[e_pq] += 1
                        ecnt[e1] += 1
                        ecnt[e2] += 1
                        nc += 1
                    ndiag += 1
                    if p == a:
                        break

    # Geometry of the candidates: Eq. (1) normal, orientation, centre, area; slivers skipped.
    # A facet whose three edges each carry two or more other candidates is internal.
    fi = np.empty((nc, 6), np.int32)
    ff = np.empty((nc, 7), np.float64)
    ox = origin[0]
    oy = origin[1]
    oz = origin[2]
    third = 1.0 / 3.0
    nf = 0
    for t in range(nc):
        if ecnt[cand[t, 3]] >= 3 and ecnt[cand[t, 4]] >= 3 and ecnt[cand[t, 5]] >= 3:
            continue
        u = cand[t, 0]
        v = cand[t, 1]
        w = cand[t, 2]
        # Eq. (1): N = (n0 - n1) x (n0 - n2) / |(n0 - n1) x (n0 - n2)|.
        e1x = nodes[u, 0] - nodes[v, 0]
        e1y = nodes[u, 1] - nodes[v, 1]
        e1z = nodes[u, 2] - nodes[v, 2]
        e2x = nodes[u, 0] - nodes[w, 0]
        e2y = nodes[u, 1] - nodes[w, 1]
        e2z = nodes[u, 2] - nodes[w, 2]
        e3x = nodes[v, 0] - nodes[w, 0]
        e3y = nodes[v, 1] - nodes[w, 1]
        e3z = nodes[v, 2] - nodes[w, 2]
        cx = e1y * e2z - e1z * e2y
        cy = e1z * e2x - e1x * e2z
        cz = e1x * e2y - e1y * e2x
        c2 = np.sqrt(cx * cx + cy * cy + cz * cz)
        longest = max(
            e1x * e1x + e1y * e1y + e1z * e1z,
            max(e2x * e2x + e2y * e2y + e2z * e2z, e3x * e3x + e3y * e3y + e3z * e3z),
        )
        # Slivers (collinear or duplicate nodes): 2 * area / longest_edge**2 below min_quality.
        if not (c2 > 1e-14) or c2 < min_quality * longest:
            continue
        inv = 1.0 / c2
        nx = cx * inv
        ny = cy * inv
        nz = cz * inv
        mx = (nodes[u, 0] + nodes[v, 0] + nodes[w, 0]) * third
        my = (nodes[u, 1] + nodes[v, 1] + nodes[w, 1]) * third
        mz = (nodes[u, 2] + nodes[v, 2] + nodes[w, 2]) * third
        side = nx * (ox - mx) + ny * (oy - my) + nz * (oz - mz)
        fi[nf, 0] = u
        if (side > 0.0) if away else (side < 0.0):
            nx = -nx
            ny = -ny
            nz = -nz
            fi[nf, 1] = w
            fi[nf, 2] = v
        else:
            fi[nf, 1] = v
            fi[nf, 2] = w
        fi[nf, 3] = cand[t, 3]
        fi[nf, 4] = cand[t, 4]
        fi[nf, 5] = cand[t, 5]
        ff[nf, 0] = nx
        ff[nf, 1] = ny
        ff[nf, 2] = nz
        ff[nf, 3] = mx
        ff[nf, 4] = my
        ff[nf, 5] = mz
        ff[nf, 6] = 0.5 * c2
        nf += 1

    # Edge-to-facet table of the kept facets.
    ecnt[:] = 0
    eface = np.empty((ne, MAX_PER_EDGE), np.int32)
    for f in range(nf):
        for e in range(3):
            eid = fi[f, 3 + e]
            c = ecnt[eid]
            if c < MAX_PER_EDGE:
                eface[eid, c] = f
            ecnt[eid] = c + 1
    return fi, ff, nf, truncated, n_bad, ecnt, eface


@njit(cache=True)
def facet_links(fi, ff, nf, ecnt, eface):
    """Facet-to-facet links across shared edges, with the cosine of the Eq. (2) weight.

    On an edge shared by more than two facets the link goes to the most coplanar one, so each
    facet keeps at most three links (§4.2).

    Returns:
        ``(nbr, ncos)``: (nf, 3) int64 neighbour across each edge or -1, and (nf, 3) float64
        ``cos w_ij`` (-2 without link). Eq. (2) is ``w_ij = arccos(ncos)``; the kernels compare
        cosines, which is the same test without the arccos.
    """
    nbr = np.full((nf, 3), -1, np.int64)
    ncos = np.full((nf, 3), -2.0)
    for f in range(nf):
        for e in range(3):
            eid = fi[f, 3 + e]
            best = -1
            bestc = -2.0
            for q in range(min(ecnt[eid], MAX_PER_EDGE)):
                g = eface[eid, q]
                if g == f:
                    continue
                # Eq. (2) with unit normals: cos w_ij = N_i . N_j.
                c = ff[f, 0] * ff[g, 0] + ff[f, 1] * ff[g, 1] + ff[f, 2] * ff[g, 2]
                if c > bestc:
                    bestc = c
                    best = g
            nbr[f, e] = best
            ncos[f, e] = bestc
    return nbr, ncos


@njit(cache=True)
def detect_kernel(nodes, edges, origin, fx, fy, ground_z, mode, prm):
    """Affordance detection on a graph, §4.2: triangulate, Eq. (1)–(2), segment, Eq. (3)–(4).

    Args:
        nodes: (n, 3) float64, metres, world frame, z up.
        edges: (m, 2) int64.
        origin: (3,) float64 sensor position (ignored with ``MODE_ORIENT_AWAY``, which orients
            facets away from the node centroid).
        fx: x of the unit walking direction in the ground plane.
        fy: y of the unit walking direction in the ground plane.
        ground_z: metres, used with ``MODE_GROUND_KNOWN``; else the ground is estimated.
        mode: bit mask of ``MODE_*``.
        prm: (N_PARAMS,) float64 packed parameters (``P_*`` indices).

    Returns:
        ``(n_bad, truncated, ground, facets, normals, flabels, lab, pos, normal, box, sboxes)``:
        out-of-range edge count, capacity flag, ground level used (NaN without facets), (F, 3)
        int64 facets, (F, 3) float64 unit normals, (F,) int64 labels, (K, N_LABEL_COLS) float64
        label table (``L_*`` columns), (K, 3) positions, (K, 3) unit normals, (K, 2, 3) boxes,
        (S, 2, 3) float64 padded boxes of the suspected objects.
    """
    n = nodes.shape[0]
    away = (mode & MODE_ORIENT_AWAY) != 0
    if away:
        origin = _centroid(nodes, edges)
    fi, ff, nf, truncated, n_bad, ecnt, eface = triangulate_graph(
        nodes, edges, origin, away, int(prm[P_MAX_FACETS]), prm[P_MIN_QUALITY]
    )
    nbr, ncos = facet_links(fi, ff, nf, ecnt, eface)
    cos_grow = prm[P_COS_GROW]
    cos_region = prm[P_COS_REGION]
    terrain_tilt = prm[P_TERRAIN_TILT]
    tol = prm[P_GROUND_TOL]
    nf1 = max(nf, 1)

    # Region growing on the Eq. (2) weights: a facet joins a neighbour's region when the link
    # weight is below the growing angle and its normal is within the region angle of the
    # region's running mean normal (the second test stops a purely local criterion from
    # drifting round a bend). Per region: normal sum, area, area-weighted height, top node.
    region = np.full(nf1, -1, np.int64)
    stack = np.empty(nf1, np.int64)
    rsum = np.empty((nf1, 3))
    rarea = np.empty(nf1)
    rz = np.empty(nf1)
    rtop = np.empty(nf1)
    nreg = 0
    for s in range(nf):
        if region[s] >= 0:
            continue
        region[s] = nreg
        sx = 0.0
        sy = 0.0
        sz = 0.0
        area = 0.0
        zsum = 0.0
        top = -np.inf
        stack[0] = s
        sp = 1
        while sp > 0:
            sp -= 1
            i = stack[sp]
            sx += ff[i, 0]
            sy += ff[i, 1]
            sz += ff[i, 2]
            area += ff[i, 6]
            zsum += ff[i, 6] * ff[i, 5]
            for c in range(3):
                top = max(top, nodes[fi[i, c], 2])
            for e in range(3):
                j = nbr[i, e]
                if j < 0 or region[j] >= 0 or ncos[i, e] < cos_grow:
                    continue
                ns = np.sqrt(sx * sx + sy * sy + sz * sz)
                if ff[j, 0] * sx + ff[j, 1] * sy + ff[j, 2] * sz < cos_region * ns:
                    continue
                region[j] = nreg
                stack[sp] = j
                sp += 1
        rsum[nreg, 0] = sx
        rsum[nreg, 1] = sy
        rsum[nreg, 2] = sz
        rarea[nreg] = area
        rz[nreg] = zsum / area
        rtop[nreg] = top
        nreg += 1
    rtilt = np.empty(max(nreg, 1))
    for r in range(nreg):
        rtilt[r] = _tilt(rsum[r, 0], rsum[r, 1], rsum[r, 2])

    # Ground level: given, or the lowest near-horizontal region among those with at least
    # P_GROUND_SHARE of the largest one's area (a big box top must not pass for the floor),
    # else the lowest facet node.
    if (mode & MODE_GROUND_KNOWN) != 0:
        ground = ground_z
    else:
        amax = 0.0
        for r in range(nreg):
            if rtilt[r] <= terrain_tilt and rarea[r] > amax:
                amax = rarea[r]
        ground = np.inf
        for r in range(nreg):
            if rtilt[r] <= terrain_tilt and rarea[r] >= prm[P_GROUND_SHARE] * amax:
                ground = min(ground, rz[r])
        if ground == np.inf:
            for f in range(nf):
                for c in range(3):
                    ground = min(ground, nodes[fi[f, c], 2])
        if ground == np.inf:
            ground = np.nan

    # Region classes.
    rkind = np.empty(max(nreg, 1), np.int64)
    for r in range(nreg):
        if rtilt[r] <= terrain_tilt and abs(rz[r] - ground) <= tol:
            rkind[r] = KIND_TERRAIN
        elif rtilt[r] >= prm[P_WALL_TILT] and rtop[r] - ground >= prm[P_WALL_HEIGHT]:
            rkind[r] = KIND_WALL
        else:
            rkind[r] = KIND_OBJECT

    # Facet groups. Connected object facets form one object (a block's top, its short sides and
    # the bevels a GNG puts round its base); a component whose top stays within the ground
    # tolerance is terrain, one touching a wall belongs to that wall (the bevel at its foot).
    group = np.empty(nf1, np.int64)
    wall_of = np.full(nf1, -1, np.int64)
    raise_tol = prm[P_RAISE_TOL]
    n_raised = 0
    for f in range(nf):
        group[f] = rkind[region[f]]
        if group[f] == KIND_WALL:
            wall_of[f] = region[f]
        elif group[f] == KIND_TERRAIN and raise_tol > 0.0:
            # Non-homogeneous nodes (§6.2, §4.1): a terrain facet with a node standing more
            # than raise_tol above the ground is part of a suspected object, even while the
            # sparse net's facets round it are still too flat to leave the floor's region.
            for c in range(3):
                if nodes[fi[f, c], 2] - ground > raise_tol:
                    group[f] = KIND_OBJECT
                    n_raised += 1
                    break
    seen = np.zeros(nf1, np.bool_)
    for s in range(nf):
        if group[s] != KIND_OBJECT or seen[s]:
            continue
        seen[s] = True
        stack[0] = s
        size = 1
        head = 0
        ctop = -np.inf
        touch_wall = -1
        while head < size:
            i = stack[head]
            head += 1
            for c in range(3):
                ctop = max(ctop, nodes[fi[i, c], 2])
            for e in range(3):
                j = nbr[i, e]
                if j < 0:
                    continue
                if group[j] == KIND_WALL:
                    if touch_wall < 0:
                        touch_wall = wall_of[j]
                elif group[j] == KIND_OBJECT and not seen[j]:
                    seen[j] = True
                    stack[size] = j
                    size += 1
        if ctop - ground <= tol:
            for q in range(size):
                group[stack[q]] = KIND_TERRAIN
        elif touch_wall >= 0:
            for q in range(size):
                group[stack[q]] = KIND_WALL
                wall_of[stack[q]] = touch_wall

    # Final labels: connected facets of one group (each wall region its own wall), with the
    # per-label sums of §4.2.1 accumulated on the way.
    flabels = np.full(nf, -1, np.int64)
    # Whole regions change group, so a label is a union of regions, except where facets were
    # taken out of a terrain region for a raised node: each such facet adds at most two labels
    # (itself, and the piece of terrain it cuts off).
    nreg1 = max(nreg + 2 * n_raised, 1)
    lab = np.zeros((nreg1, N_LABEL_COLS))
    lpos = np.empty((nreg1, 3))
    lnormal = np.zeros((nreg1, 3))
    lbox = np.empty((nreg1, 2, 3))
    stamp = np.full(n, -1, np.int64)
    nlab = 0
    nsus = 0
    for s in range(nf):
        if flabels[s] >= 0:
            continue
        k = nlab
        nlab += 1
        flabels[s] = k
        gk = group[s]
        wk = wall_of[s]
        stack[0] = s
        sp = 1
        count = 0
        sx = 0.0
        sy = 0.0
        sz = 0.0
        px = 0.0
        py = 0.0
        pz = 0.0
        area = 0.0
        nn = 0
        top = -np.inf
        lox = np.inf
        loy = np.inf
        loz = np.inf
        hix = -np.inf
        hiy = -np.inf
        hiz = -np.inf
        # Projections along (f) and across (l) the walking direction: all nodes, high nodes.
        af0 = np.inf
        af1 = -np.inf
        al0 = np.inf
        al1 = -np.inf
        hf0 = np.inf
        hf1 = -np.inf
        hl0 = np.inf
        hl1 = -np.inf
        nh = 0
        while sp > 0:
            sp -= 1
            i = stack[sp]
            count += 1
            # Ob^(v), Ob^(pos) of §4.2.1: plain means of the facet normals and centres.
            sx += ff[i, 0]
            sy += ff[i, 1]
            sz += ff[i, 2]
            px += ff[i, 3]
            py += ff[i, 4]
            pz += ff[i, 5]
            area += ff[i, 6]
            for c in range(3):
                v = fi[i, c]
                if stamp[v] == k:
                    continue
                stamp[v] = k
                nn += 1
                x = nodes[v, 0]
                y = nodes[v, 1]
                z = nodes[v, 2]
                top = max(top, z)
                lox = min(lox, x)
                loy = min(loy, y)
                loz = min(loz, z)
                hix = max(hix, x)
                hiy = max(hiy, y)
                hiz = max(hiz, z)
                pf = x * fx + y * fy
                pl = y * fx - x * fy
                af0 = min(af0, pf)
                af1 = max(af1, pf)
                al0 = min(al0, pl)
                al1 = max(al1, pl)
                if z > ground + tol:
                    nh += 1
                    hf0 = min(hf0, pf)
                    hf1 = max(hf1, pf)
                    hl0 = min(hl0, pl)
                    hl1 = max(hl1, pl)
            for e in range(3):
                j = nbr[i, e]
                if j < 0 or flabels[j] >= 0 or group[j] != gk or wall_of[j] != wk:
                    continue
                flabels[j] = k
                stack[sp] = j
                sp += 1
        lab[k, L_KIND] = gk
        lpos[k, 0] = px / count
        lpos[k, 1] = py / count
        lpos[k, 2] = pz / count
        ns = np.sqrt(sx * sx + sy * sy + sz * sz)
        if ns > 1e-12:
            lnormal[k, 0] = sx / ns
            lnormal[k, 1] = sy / ns
            lnormal[k, 2] = sz / ns
        lab[k, L_GAMMA] = _tilt(sx, sy, sz)
        lab[k, L_SIZE] = area
        lab[k, L_NNODES] = nn
        # Eq. (4): d = number of nodes in the object / object size (facet area, m²).
        lab[k, L_DENSITY] = nn / area
        lab[k, L_HEIGHT] = top - ground
        if gk == KIND_OBJECT and nh > 0:
            lab[k, L_LENGTH] = hf1 - hf0
            lab[k, L_WIDTH] = hl1 - hl0
        else:
            lab[k, L_LENGTH] = af1 - af0
            lab[k, L_WIDTH] = al1 - al0
        lbox[k, 0, 0] = lox
        lbox[k, 0, 1] = loy
        lbox[k, 0, 2] = loz
        lbox[k, 1, 0] = hix
        lbox[k, 1, 1] = hiy
        lbox[k, 1, 2] = hiz
        if gk == KIND_OBJECT and nn / area < prm[P_DENSITY]:
            lab[k, L_SUSPECTED] = 1.0
            nsus += 1

    pad = prm[P_PADDING]
    sboxes = np.empty((nsus, 2, 3))
    q = 0
    for k in range(nlab):
        if lab[k, L_SUSPECTED] != 0.0:
            for d in range(3):
                sboxes[q, 0, d] = lbox[k, 0, d] - pad
                sboxes[q, 1, d] = lbox[k, 1, d] + pad
            q += 1
    return (
        n_bad,
        truncated,
        ground,
        fi[:nf, :3].astype(np.int64),
        ff[:nf, :3].copy(),
        flabels,
        lab[:nlab],
        lpos[:nlab],
        lnormal[:nlab],
        lbox[:nlab],
        sboxes,
    )


@njit(cache=True, nogil=True)
def map_objects_kernel(
    nodes, edges, facets, fgroup, ngroups, ground, tol, fx, fy, slope, bins, edge
):
    """Per group of object labels, its measures on the map's nodes and facets alone.

    A group's nodes are the distinct vertices of its facets (``fgroup[f]`` = group of facet
    ``f``, -1 for facets of no group); its *high* nodes those more than ``tol`` above
    ``ground``. The extents are the high nodes' projections along (f) and across (l) the
    walking direction; the spacing is the median horizontal length of the graph edges that
    join two high nodes of the group (the node spacing on the object's top, 0 without such
    an edge); the view margin is the smallest ``edge[bin] - slope`` of its high nodes, the
    view edge computed on the graph's own nodes (``view_edge_kernel``); ``M_HBOX`` holds the
    high nodes' box in the ground plane (Algorithm 3's A_min/A_max of ``map_box_from_high``).

    Args:
        nodes: (n, 3) float64, metres.
        edges: (m, 2) int64 node indices.
        facets: (F, 3) int64 node indices.
        fgroup: (F,) int64 group of each facet, or -1.
        ngroups: number of groups G.
        ground: metres, the ground level.
        tol: metres, the ground tolerance.
        fx: x of the unit walking direction in the ground plane.
        fy: y of the unit walking direction in the ground plane.
        slope: (n,) float64, each node's tan(elevation) from the sensors.
        bins: (n,) int64, each node's azimuth bin (-1: none).
        edge: (nbins,) float64, the largest tan(elevation) of the nodes in each bin.

    Returns:
        (G, N_MAP_COLS) float64, ``M_*`` columns (NaN extents, inf margin and an empty (inf,
        -inf) high box without a high node).
    """
    n = nodes.shape[0]
    out = np.zeros((ngroups, N_MAP_COLS))
    stamp = np.full(n, -1, np.int64)
    order = np.argsort(fgroup, kind="mergesort")
    # Up to 62 groups, one pass over the edges for all of them (each node's groups as bits of
    # ``member``) instead of one pass per group; the spacings are the same medians.
    bits = ngroups <= 62
    member = np.zeros(n if bits else 0, np.int64)
    lens = np.empty(1 if bits else max(edges.shape[0], 1))  # the per-group pass's lengths
    q = 0
    while q < order.shape[0] and fgroup[order[q]] < 0:
        q += 1
    for g in range(ngroups):
        out[g, M_HEIGHT] = -np.inf
        out[g, M_F0] = np.inf
        out[g, M_F1] = -np.inf
        out[g, M_L0] = np.inf
        out[g, M_L1] = -np.inf
        out[g, M_VIEW] = np.inf
        for d in range(3):
            out[g, M_BOX + d] = np.inf
            out[g, M_BOX + 3 + d] = -np.inf
        for d in range(2):
            out[g, M_HBOX + d] = np.inf
            out[g, M_HBOX + 2 + d] = -np.inf
        # The group's facets are contiguous in ``order``; ``stamp`` marks its nodes (a node
        # on facets of two groups counts in both).
        while q < order.shape[0] and fgroup[order[q]] == g:
            f = order[q]
            q += 1
            for c in range(3):
                v = facets[f, c]
                if stamp[v] == g:
                    continue
                stamp[v] = g
                if bits:
                    member[v] |= np.int64(1) << g
                out[g, M_NNODES] += 1.0
                x = nodes[v, 0]
                y = nodes[v, 1]
                z = nodes[v, 2]
                for d in range(3):
                    out[g, M_BOX + d] = min(out[g, M_BOX + d], nodes[v, d])
                    out[g, M_BOX + 3 + d] = max(out[g, M_BOX + 3 + d], nodes[v, d])
                if z - ground > tol:
                    out[g, M_NHIGH] += 1.0
                    out[g, M_HEIGHT] = max(out[g, M_HEIGHT], z - ground)
                    pf = x * fx + y * fy
                    pl = y * fx - x * fy
                    out[g, M_F0] = min(out[g, M_F0], pf)
                    out[g, M_F1] = max(out[g, M_F1], pf)
                    out[g, M_L0] = min(out[g, M_L0], pl)
                    out[g, M_L1] = max(out[g, M_L1], pl)
                    out[g, M_HBOX] = min(out[g, M_HBOX], x)
                    out[g, M_HBOX + 1] = min(out[g, M_HBOX + 1], y)
                    out[g, M_HBOX + 2] = max(out[g, M_HBOX + 2], x)
                    out[g, M_HBOX + 3] = max(out[g, M_HBOX + 3], y)
                    b = bins[v]
                    if b >= 0:
                        out[g, M_VIEW] = min(out[g, M_VIEW], edge[b] - slope[v])
        if not bits:
            k = 0
            for e in range(edges.shape[0]):
                a = edges[e, 0]
                b = edges[e, 1]
                if stamp[a] != g or stamp[b] != g:
                    continue
                if not (nodes[a, 2] - ground > tol and nodes[b, 2] - ground > tol):
                    continue
                dx = nodes[a, 0] - nodes[b, 0]
                dy = nodes[a, 1] - nodes[b, 1]
                lens[k] = np.sqrt(dx * dx + dy * dy)
                k += 1
            if k > 0:
                out[g, M_SPACING] = np.median(lens[:k])
        if out[g, M_NHIGH] == 0.0:
            out[g, M_HEIGHT] = np.nan
            for c in (M_F0, M_F1, M_L0, M_L1):
                out[g, c] = np.nan
    if bits and ngroups > 0:
        # Edges joining two high nodes of a group, counted per group, then gathered per group
        # in edge order (CSR), then the median of each group's lengths.
        m = edges.shape[0]
        start = np.zeros(ngroups + 1, np.int64)
        shared = np.zeros(m, np.int64)
        for e in range(m):
            a = edges[e, 0]
            b = edges[e, 1]
            both = member[a] & member[b]
            if both == 0 or not (nodes[a, 2] - ground > tol and nodes[b, 2] - ground > tol):
                continue
            shared[e] = both
            for g in range(ngroups):
                if (both >> g) & 1:
                    start[g + 1] += 1
        for g in range(ngroups):
            start[g + 1] += start[g]
        fill = start[:ngroups].copy()
        buf = np.empty(max(start[ngroups], 1))
        for e in range(m):
            both = shared[e]
            if both == 0:
                continue
            a = edges[e, 0]
            b = edges[e, 1]
            dx = nodes[a, 0] - nodes[b, 0]
            dy = nodes[a, 1] - nodes[b, 1]
            d = np.sqrt(dx * dx + dy * dy)
            for g in range(ngroups):
                if (both >> g) & 1:
                    buf[fill[g]] = d
                    fill[g] += 1
        for g in range(ngroups):
            if start[g + 1] > start[g]:
                out[g, M_SPACING] = np.median(buf[start[g] : start[g + 1]])
    return out


@njit(cache=True)
def floor_level(nodes, facets, flabels, lab, ground):
    """The floor plane's height on the map: the median height of the terrain facets' nodes.

    A_h is read against the floor (§4.2.1); ``detect_kernel``'s ground level is the floor
    region's area-weighted height, which the raised facets round a block's or a wall's foot
    (still terrain up to ``raised_node_tolerance``) lift by up to 1.4 cm on Table 2's net.
    The median of the distinct nodes is the level most of the floor's nodes lie on.

    Args:
        nodes: (n, 3) float64, metres.
        facets: (F, 3) int64 node indices.
        flabels: (F,) int64 label of each facet.
        lab: (K, N_LABEL_COLS) float64 label table (``L_KIND`` read).
        ground: metres, returned when no facet is terrain.

    Returns:
        metres, the floor level.
    """
    n = nodes.shape[0]
    seen = np.zeros(n, np.bool_)
    zs = np.empty(n)
    k = 0
    for f in range(facets.shape[0]):
        if lab[flabels[f], L_KIND] != KIND_TERRAIN:
            continue
        for c in range(3):
            v = facets[f, c]
            if not seen[v]:
                seen[v] = True
                zs[k] = nodes[v, 2]
                k += 1
    if k == 0:
        return ground
    return np.median(zs[:k])


@njit(cache=True)
def map_step_kernel(
    nodes, edges, origin, fx, fy, ground, facets, flabels, lab, pos, normal, box, prm, mq
):
    """The map-mode object steps on ``detect_kernel``'s labels, in one compiled call.

    ``AttentionPipeline`` reads an object's measures from the map alone ("map" mode): with
    ``Q_FLOOR_PLANE`` the ground level is first the floor plane of the terrain facets' nodes
    (:func:`floor_level`); object labels whose boxes overlap in the ground plane are one group
    (union in label order; the group takes its first label's place), except, with
    ``Q_VIEW_FIRST``, a label whose own high nodes reach the graph's view edge (merged with
    none); each group is measured by :func:`map_objects_kernel` (high-node extents plus
    ``Q_EDGE_CORRECTION`` × their spacing; the box is the high nodes' with ``Q_HIGH_BOX``,
    else all the group's nodes', grown by half the correction in the ground plane),
    relabelled wall at the top of the graph's own view (``Q_VIEW_CUT``,
    :func:`view_edge_kernel` on the nodes), and suspected below the density threshold. A
    merged group's position is the facet-count-weighted mean of its pieces', its size their
    sum; its normal is returned *unnormalised* (the weighted sum) and its index listed in
    ``merged``, for the caller to normalise as ``np.linalg.norm`` does (whose rounding is not
    a plain square root's) and to set γ from.

    Args:
        nodes: (n, 3) float64, metres.
        edges: (m, 2) int64.
        origin: (3,) float64, metres, the sensors.
        fx: x of the unit walking direction in the ground plane.
        fy: y of the unit walking direction in the ground plane.
        ground: metres, the ground level ``detect_kernel`` used (finite).
        facets: (F, 3) int64, ``detect_kernel``'s facets.
        flabels: (F,) int64, their labels.
        lab: (K, N_LABEL_COLS) float64, the label table.
        pos: (K, 3) float64, the labels' positions.
        normal: (K, 3) float64, their unit normals.
        box: (K, 2, 3) float64, their boxes.
        prm: (N_PARAMS,) float64, the detection's packed parameters (``P_*``).
        mq: (N_MAP_PARAMS,) float64, the map-mode parameters (``Q_*``).

    Returns:
        ``(lab, pos, normal, box, flabels, merged, sboxes, ground)``: the new label table (K',
        L_* columns), positions, normals, boxes, the (F,) int64 new label of each facet, the
        int64 indices of the merged labels, the (S, 2, 3) padded boxes of the suspected
        objects and the ground level the objects were measured from. Without an object label
        the inputs come back as they are (``lab`` itself), with that ground level.
    """
    nl = lab.shape[0]
    tol = prm[P_GROUND_TOL]
    if mq[Q_FLOOR_PLANE] != 0.0:
        ground = floor_level(nodes, facets, flabels, lab, ground)
    objs = np.empty(nl, np.int64)
    nobj = 0
    for k in range(nl):
        if lab[k, L_KIND] == KIND_OBJECT:
            objs[nobj] = k
            nobj += 1
    if nobj == 0:
        return lab, pos, normal, box, flabels, np.zeros(0, np.int64), np.empty((0, 2, 3)), ground
    root = np.arange(nobj)
    nf = facets.shape[0]
    slope, bins, vedge = view_edge_kernel(nodes, fx, fy, origin, int(mq[Q_VIEW_BINS]), 4.0)
    view_cut = mq[Q_VIEW_CUT]
    # The view edge is read on each label alone, before the merge: a wall's foot and a block
    # in front of it have overlapping boxes, and merged, the block went into the wall.
    at_edge = np.zeros(nobj, np.bool_)
    single = np.empty((0, N_MAP_COLS))
    if view_cut >= 0.0 and mq[Q_MERGE] != 0.0 and mq[Q_VIEW_FIRST] != 0.0:
        obj_of = np.full(nl, -1, np.int64)
        for a in range(nobj):
            obj_of[objs[a]] = a
        fsingle = np.empty(nf, np.int64)
        for f in range(nf):
            fsingle[f] = obj_of[flabels[f]]
        single = map_objects_kernel(
            nodes, edges, facets, fsingle, nobj, ground, tol, fx, fy, slope, bins, vedge
        )
        for a in range(nobj):
            at_edge[a] = single[a, M_NHIGH] > 0.0 and single[a, M_VIEW] <= view_cut
    if mq[Q_MERGE] != 0.0:
        for a in range(nobj):
            if at_edge[a]:
                continue
            ka = objs[a]
            for b in range(a + 1, nobj):
                kb = objs[b]
                if at_edge[b]:
                    continue
                if (
                    box[ka, 0, 0] <= box[kb, 1, 0]
                    and box[kb, 0, 0] <= box[ka, 1, 0]
                    and box[ka, 0, 1] <= box[kb, 1, 1]
                    and box[kb, 0, 1] <= box[ka, 1, 1]
                ):
                    root[_root(root, b)] = _root(root, a)
    gid = np.full(nobj, -1, np.int64)
    label_group = np.full(nl, -1, np.int64)
    ng = 0
    for a in range(nobj):
        r = _root(root, a)
        if gid[r] < 0:
            gid[r] = ng
            ng += 1
        label_group[objs[a]] = gid[r]
    fgroup = np.empty(nf, np.int64)
    counts = np.zeros(nl, np.int64)
    for f in range(nf):
        fgroup[f] = label_group[flabels[f]]
        counts[flabels[f]] += 1
    if ng == nobj and single.shape[0] == nobj:
        # No label merged: the groups are the labels in order, measured already.
        res = single
    else:
        res = map_objects_kernel(
            nodes, edges, facets, fgroup, ng, ground, tol, fx, fy, slope, bins, vedge
        )
    # Each group's members in label order; the group's first label is where it goes.
    first = np.full(ng, -1, np.int64)
    nmem = np.zeros(ng, np.int64)
    for k in range(nl):
        g = label_group[k]
        if g >= 0:
            if first[g] < 0:
                first[g] = k
            nmem[g] += 1
    nout = nl - nobj + ng
    olab = np.empty((nout, N_LABEL_COLS))
    opos = np.empty((nout, 3))
    onormal = np.empty((nout, 3))
    obox = np.empty((nout, 2, 3))
    merged = np.empty(nout, np.int64)
    nmerged = 0
    new_of = np.full(nl, -1, np.int64)
    out_of_group = np.full(ng, -1, np.int64)
    corr = mq[Q_EDGE_CORRECTION]
    j = 0
    for k in range(nl):
        g = label_group[k]
        if g >= 0 and first[g] != k:
            continue
        new_of[k] = j
        for c in range(N_LABEL_COLS):
            olab[j, c] = lab[k, c]
        for d in range(3):
            opos[j, d] = pos[k, d]
            onormal[j, d] = normal[k, d]
            obox[j, 0, d] = box[k, 0, d]
            obox[j, 1, d] = box[k, 1, d]
        if g >= 0:
            out_of_group[g] = j
            if nmem[g] > 1:
                # Facet-count-weighted sums in label order (as the NumPy sums of the Python
                # steps they replace), the size a plain sum.
                merged[nmerged] = j
                nmerged += 1
                wsum = 0
                px = 0.0
                py = 0.0
                pz = 0.0
                nx = 0.0
                ny = 0.0
                nz = 0.0
                size = 0.0
                for q in range(k, nl):
                    if label_group[q] != g:
                        continue
                    w = counts[q]
                    wsum += w
                    px += pos[q, 0] * w
                    py += pos[q, 1] * w
                    pz += pos[q, 2] * w
                    nx += normal[q, 0] * w
                    ny += normal[q, 1] * w
                    nz += normal[q, 2] * w
                    size += lab[q, L_SIZE]
                fw = float(wsum)
                opos[j, 0] = px / fw
                opos[j, 1] = py / fw
                opos[j, 2] = pz / fw
                onormal[j, 0] = nx
                onormal[j, 1] = ny
                onormal[j, 2] = nz
                olab[j, L_SIZE] = size
            n_nodes = res[g, M_NNODES]
            if n_nodes == 0.0:
                j += 1
                continue
            for d in range(3):
                obox[j, 0, d] = res[g, M_BOX + d]
                obox[j, 1, d] = res[g, M_BOX + 3 + d]
            if res[g, M_NHIGH] > 0.0:
                cc = corr * res[g, M_SPACING]
                if mq[Q_HIGH_BOX] != 0.0:
                    obox[j, 0, 0] = res[g, M_HBOX]
                    obox[j, 0, 1] = res[g, M_HBOX + 1]
                    obox[j, 1, 0] = res[g, M_HBOX + 2]
                    obox[j, 1, 1] = res[g, M_HBOX + 3]
                obox[j, 0, 0] -= 0.5 * cc
                obox[j, 0, 1] -= 0.5 * cc
                obox[j, 1, 0] += 0.5 * cc
                obox[j, 1, 1] += 0.5 * cc
                olab[j, L_HEIGHT] = res[g, M_HEIGHT]
                olab[j, L_WIDTH] = (res[g, M_L1] - res[g, M_L0]) + cc
                olab[j, L_LENGTH] = (res[g, M_F1] - res[g, M_F0]) + cc
            sz = olab[j, L_SIZE]
            density = n_nodes / sz if sz > 0 else 0.0
            olab[j, L_NNODES] = n_nodes
            olab[j, L_DENSITY] = density
            olab[j, L_SUSPECTED] = 1.0 if density < prm[P_DENSITY] else 0.0
            if (
                view_cut >= 0.0
                and res[g, M_VIEW] <= view_cut
                and olab[j, L_HEIGHT] >= mq[Q_MIN_HEIGHT]
            ):
                olab[j, L_KIND] = KIND_WALL
                olab[j, L_SUSPECTED] = 0.0
        j += 1
    for k in range(nl):
        if label_group[k] >= 0:
            new_of[k] = out_of_group[label_group[k]]
    oflabels = np.empty(nf, np.int64)
    for f in range(nf):
        oflabels[f] = new_of[flabels[f]]
    nsus = 0
    for i in range(nout):
        if olab[i, L_KIND] == KIND_OBJECT and olab[i, L_SUSPECTED] != 0.0:
            nsus += 1
    pad = prm[P_PADDING]
    sboxes = np.empty((nsus, 2, 3))
    q = 0
    for i in range(nout):
        if olab[i, L_KIND] == KIND_OBJECT and olab[i, L_SUSPECTED] != 0.0:
            for d in range(3):
                sboxes[q, 0, d] = obox[i, 0, d] - pad
                sboxes[q, 1, d] = obox[i, 1, d] + pad
            q += 1
    return olab, opos, onormal, obox, oflabels, merged[:nmerged], sboxes, ground


def assemble(ground, truncated, facets, normals, flabels, lab, pos, normal, box, boxes):
    """``affordance.assemble`` as it was (3d26d7f)."""
    objects = [
        AffordanceObject(
            _KIND_OF[int(r[0])], q, r[1], r[2], r[3], r[4], r[5], u, r[6], int(r[7]), b, r[8] != 0.0
        )
        for r, q, u, b in zip(lab.tolist(), pos, normal, box, strict=True)
    ]
    kinds = tuple(o.kind for o in objects)
    return Affordances(
        objects=objects,
        suspected_boxes=boxes,
        facets=facets,
        facet_normals=normals,
        facet_labels=flabels,
        label_kinds=kinds,
        ground_z=float(ground),
        truncated=bool(truncated),
    )


def detect_map(nodes, edges, sensor_origin, ap, pp, forward, ground_z=None):
    """``AttentionPipeline._detect_map`` as it was (3d26d7f), on the kernels above.

    Args:
        nodes: (n, 3) float64 graph nodes, metres.
        edges: (m, 2) int64 graph edges.
        sensor_origin: (3,) float64, metres (not None).
        ap: AffordanceParams.
        pp: PipelineParams.
        forward: (3,) walking direction.
        ground_z: metres or None.
    """
    origin, _ = _origin(sensor_origin)
    fx, fy = _forward_xy(forward)
    if nodes.shape[0] < 3 or edges.shape[0] < 3:
        return _empty_result(ground_z)
    mode = 0 if ground_z is None else MODE_GROUND_KNOWN
    ground = 0.0 if ground_z is None else float(ground_z)
    n_bad, truncated, ground, facets, normals, flabels, lab, pos, normal, box, boxes = (
        detect_kernel(nodes, edges, origin, fx, fy, ground, mode, ap.packed)
    )
    assert n_bad == 0
    if facets.shape[0] == 0:
        return _empty_result(ground_z)
    raw = (ground, truncated, facets, normals, flabels, lab, pos, normal, box, boxes)
    if not math.isfinite(ground):
        return assemble(*raw)
    olab, opos, onormal, obox, oflabels, merged, sboxes, ground = map_step_kernel(
        nodes, edges, origin, fx, fy, ground, facets, flabels, lab, pos, normal, box,
        ap.packed, pp.map_packed if ground_z is None else pp.map_packed_known_ground,
    )  # fmt: skip
    if olab is lab:
        return assemble(ground, *raw[1:])
    aff = assemble(ground, truncated, facets, normals, oflabels, olab, opos, onormal, obox, sboxes)
    for j in merged.tolist():
        o = aff.objects[j]
        nsum = o.normal
        nn = math.sqrt(float(nsum.dot(nsum)))
        unit = nsum / nn if nn > 1e-12 else np.zeros(3)
        gamma = math.acos(min(1.0, max(-1.0, float(unit[2])))) if nn > 1e-12 else 0.0
        aff.objects[j] = o._replace(normal=unit, gamma=gamma)
    return aff
