"""Numba kernels for affordance detection (§4.2, Eq. 1–4) and surface matching (§6.5.3, Eq. 12–15).

Pure ``@njit(cache=True)`` functions over NumPy arrays: no Python objects, no state (the integer
constants below are compile-time constants). The public wrappers, with validation and the
documentation of every choice, are :mod:`neurocog_gym.perception.affordance` and
:mod:`neurocog_gym.perception.similarity`.

Adjacency is CSR with slack, built in two passes over the edge array (count, fill), in two
forms: the forward rows ``fwd`` (each node's higher neighbours) and the full rows ``adj``. Row
``i`` starts at ``fstart[i]`` (``start[i]``), holds ``fdeg[i]`` (``deg[i]``) entries and has room
for ``SLACK`` more, so the quad diagonals are appended in place. The slot of ``hi`` in forward row
``lo`` is the id of edge ``lo-hi``; ``aeid`` gives the edge id of each full-row slot. Edge ids
index the edge-to-facet table ``ecnt``/``eface``. Triangles are enumerated over the forward rows
only (each once, no order tests in the inner loop).

Facets are stored as ``fi`` (F, 6) int32 ``(v0, v1, v2, e0, e1, e2)`` (vertices wound so the
right-hand normal is the oriented one, and the ids of the three edges) and ``ff`` (F, 7)
float64 ``(nx, ny, nz, cx, cy, cz, area)``.

Speed notes (measured on the 2-core project machine): hot loops call no helper that takes arrays
(numba reference-counts array arguments of a non-inlined call with atomic operations, which cost
more than the geometry), arrays are never re-bound inside loops, and index arrays are int32 to
keep the working set in cache. On a graph the branch predictors have not seen (a map changes
every frame) mispredicted data-dependent branches cost as much as the work: ``detect_kernel``
takes about 50 µs at 300 nodes on one graph called over and over, 90–110 µs on five in turn
(issue 23). So the loops over rows a graph decides are kept to the nodes that can contribute
(listed beforehand in one flat pass, each node written and counted by a test, not branched on),
and where a branch follows the graph alone and breaks no chain of loads and stores, a select
replaces it (triangle hits, two-facet links). Selects that make the stack pointer and the
visited flags of a flood fill a chain through memory were slower (tried, dropped).
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numba.cpython.unsafe.numbers import trailing_zeros

KIND_TERRAIN = 0
KIND_WALL = 1
KIND_OBJECT = 2
SLACK = 4
"""Free adjacency slots per row for quad diagonals."""
MAX_PER_EDGE = 3
"""Facets remembered per edge (a manifold surface has at most two; a third flags internal ones)."""

# Packed parameter vector (``AffordanceParams.packed``).
P_MAX_FACETS = 0
P_MIN_QUALITY = 1
P_COS_GROW = 2
P_COS_REGION = 3
P_TERRAIN_TILT = 4
P_WALL_TILT = 5
P_WALL_HEIGHT = 6
P_GROUND_TOL = 7
P_GROUND_SHARE = 8
P_DENSITY = 9
P_PADDING = 10
P_RAISE_TOL = 11
N_PARAMS = 12

# Label table columns (one row per label; positions, normals and boxes are separate arrays).
L_KIND = 0
L_HEIGHT = 1
L_WIDTH = 2
L_LENGTH = 3
L_GAMMA = 4
L_DENSITY = 5
L_SIZE = 6
L_NNODES = 7
L_SUSPECTED = 8
N_LABEL_COLS = 9

# Mode bits of ``detect_kernel``.
MODE_ORIENT_AWAY = 1
MODE_GROUND_KNOWN = 2


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
def build_adjacency(valid, edges, slack):
    """Forward and full adjacency, CSR with slack, in two passes over ``edges`` (count, fill).

    Args:
        valid: (n,) bool, nodes that may carry edges (finite coordinates).
        edges: (m, 2) int64 node indices; self-loops, duplicates and edges touching an invalid
            node are dropped.
        slack: free slots per non-isolated row, for the quad diagonals.

    Returns:
        ``(fwd, fstart, fcap, fdeg, adj, aeid, start, cap, deg, n_bad, fsrc)``: the forward
        rows (each node's higher neighbours; the slot of ``hi`` in row ``lo`` is the id of edge
        ``lo-hi``; free slots hold -1), the full rows with the edge id of each slot, the number
        of edges with an index outside [0, n), and the row of each used forward slot.
    """
    n = valid.shape[0]
    m = edges.shape[0]
    deg = np.zeros(n, np.int64)
    fdeg = np.zeros(n, np.int64)
    n_bad = 0
    # Edges as a GNG exports them, (i, j) with i < j in strictly rising order, hold no
    # duplicate: the fill then skips the duplicate scan, a loop of data-dependent length per
    # edge (its exit is a mispredicted branch more often than not).
    ordered = True
    prev = -1
    for e in range(m):
        a = edges[e, 0]
        b = edges[e, 1]
        if a < 0 or b < 0 or a >= n or b >= n:
            n_bad += 1
            continue
        key = a * n + b
        ordered &= (a < b) & (key > prev)
        prev = key
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
    # Free (slack) forward slots hold -1; ``fsrc`` is each used slot's row.
    fwd = np.full(max(ftotal, 1), -1, np.int32)
    fsrc = np.zeros(max(ftotal, 1), np.int32)
    deg[:] = 0
    fdeg[:] = 0
    for e in range(m):
        a = edges[e, 0]
        b = edges[e, 1]
        if a < 0 or b < 0 or a >= n or b >= n or a == b or not valid[a] or not valid[b]:
            continue
        lo = min(a, b)
        hi = max(a, b)
        if not ordered:
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
        fsrc[eid] = lo
        fdeg[lo] += 1
        s = start[lo] + deg[lo]
        adj[s] = hi
        aeid[s] = eid
        deg[lo] += 1
        s = start[hi] + deg[hi]
        adj[s] = lo
        aeid[s] = eid
        deg[hi] += 1
    return fwd, fstart, fcap, fdeg, adj, aeid, start, cap, deg, n_bad, fsrc


@njit(cache=True)
def triangulate_graph(nodes, edges, origin, away, max_facets, min_quality):
    """Facets of a graph: 3-cycles, then quads closed by their shorter diagonal (SPEC §4).

    Runs :func:`_triangulate_once` with a capacity for a surface mesh (1.5 facets per edge) and
    retries with twice the capacity, up to ``max_facets``, if that was too small. (Growing the
    arrays inside the enumeration loop instead makes numba refcount them on every iteration,
    which tripled the run time.) Only the last attempt, whose truncation is kept, tries every
    node as a quad's start (see :func:`_triangulate_once`).

    Returns:
        As :func:`_triangulate_once`; ``truncated`` means ``max_facets`` was reached.
    """
    m = edges.shape[0]
    fcap = max(16, min(max_facets, m + m // 2 + 16))
    while True:
        fi, ff, nf, truncated, n_bad, ecnt, eface = _triangulate_once(
            nodes, edges, origin, away, fcap, min_quality, fcap >= max_facets
        )
        if not truncated or fcap >= max_facets:
            return fi, ff, nf, truncated, n_bad, ecnt, eface
        fcap = min(max_facets, 2 * fcap)


@njit(cache=True)
def _triangulate_once(nodes, edges, origin, away, fcap, min_quality, all_starts):
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
        all_starts: try every node with two low edges as a quad's lowest node. Without it only
            those with two low edges up are tried, which finds the same quads unless the
            capacity runs out (then a diagonal may be left with fewer than two facets, hence
            low, and serve as a later quad's edge); a truncated result is only kept from the
            last attempt, which sets it.

    Returns:
        ``(fi, ff, nf, truncated, n_bad, ecnt, eface)``: facet arrays (first ``nf`` rows
        valid), whether ``fcap`` was hit, the number of edges with an out-of-range index, and
        the edge-to-facet table of the returned facets (facet count per edge id, first
        ``MAX_PER_EDGE`` facets).
    """
    n = nodes.shape[0]
    valid = finite_rows(nodes)
    fwd, fstart, fcapr, fdeg, adj, aeid, start, cap, deg, n_bad, fsrc = build_adjacency(
        valid, edges, SLACK
    )
    ne = max(fstart[n], 1)
    ecnt = np.zeros(ne, np.int32)
    # Candidate facets (u, v, w, e_uv, e_vw, e_uw) before the geometry tests.
    cand = np.empty((fcap, 6), np.int32)
    nc = 0
    truncated = False
    mark = np.full(n, -1, np.int64)
    mslot = np.zeros(n, np.int64)

    # All 3-cycles u < v < w over the forward rows; every edge of one is a forward edge. Its
    # lowest node u has two forward neighbours: the others (a third of a GNG's nodes) are
    # left out of the loop beforehand, in one flat pass, not skipped in it (each skip, and
    # each end of their short rows, was a mispredicted branch as often as not).
    us = np.empty(n, np.int64)
    nus = 0
    for u in range(n):
        us[nus] = u
        nus += fdeg[u] >= 2
    for iu in range(nus):
        u = us[iu]
        fu = fstart[u]
        for k in range(fdeg[u]):
            mark[fwd[fu + k]] = u
            mslot[fwd[fu + k]] = fu + k
        for k in range(fdeg[u]):
            v = fwd[fu + k]
            fv = fstart[v]
            for k2 in range(fdeg[v]):
                # Each (u, v, w) written and counted by whether it closes a triangle, without
                # a branch on it (which pairs do is a pattern no predictor learns across
                # graphs). ``mslot`` of a node not marked for ``u`` is a valid slot, counted 0.
                w = fwd[fv + k2]
                hit = np.int32(mark[w] == u)
                if nc >= fcap:
                    truncated |= hit != 0
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
                ecnt[e0] += hit
                ecnt[e1] += hit
                ecnt[e2] += hit
                nc += hit

    # Low edges (at most one facet), both directions, as CSR: a quad hole has only low edges.
    # A fifth of the edges are low. Their slots are listed first in one flat pass over the
    # forward slots (in slot order, which is row order), each slot written and counted by
    # whether it is low: the nested passes over the rows this replaces paid a mispredicted
    # branch per row end and per low test, on patterns that change from graph to graph.
    nslot = fstart[n]
    lows = np.empty(max(nslot, 1), np.int32)
    nlow = 0
    for e in range(nslot):
        lows[nlow] = e
        nlow += (fwd[e] >= 0) & (ecnt[e] <= 1)
    lcnt = np.zeros(n + 1, np.int64)
    lup = np.zeros(n, np.int64)
    for q in range(nlow):
        e = lows[q]
        lcnt[fsrc[e] + 1] += 1
        lcnt[fwd[e] + 1] += 1
        lup[fsrc[e]] += 1
    for i in range(n):
        lcnt[i + 1] += lcnt[i]
    lfill = lcnt[:n].copy()
    low = np.empty(max(lcnt[n], 1), np.int32)
    leid = np.empty(max(lcnt[n], 1), np.int32)
    for q in range(nlow):
        e = lows[q]
        u = fsrc[e]
        v = fwd[e]
        low[lfill[u]] = v
        leid[lfill[u]] = e
        lfill[u] += 1
        low[lfill[v]] = u
        leid[lfill[v]] = e
        lfill[v] += 1
    # The nodes a quad can start from, listed the same way, in rising order: its lowest node
    # a has two low edges up, to b and to d (b < d; an edge a-d low when the quad is checked
    # was low here, as edge counts only grow, or is a diagonal added since, which has two
    # facets unless the capacity ran out). Most boundary nodes have one.
    qa = np.empty(n, np.int64)
    nqa = 0
    for a in range(n):
        qa[nqa] = a
        nqa += (lup[a] >= 2) | (all_starts & (lcnt[a + 1] - lcnt[a] >= 2))

    # Quad holes a-b-c-d over low edges, found once from their lowest node a with b < d.
    mark[:] = -1
    mark2 = np.full(n, -1, np.int64)
    mslot2 = np.empty(n, np.int64)
    ndiag = 0
    for ia in range(nqa):
        a = qa[ia]
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
    eface = np.zeros((ne, MAX_PER_EDGE), np.int32)
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
    nbr = np.empty((nf, 3), np.int64)
    ncos = np.empty((nf, 3))
    for f in range(nf):
        for e in range(3):
            eid = fi[f, 3 + e]
            cnt = ecnt[eid]
            if cnt <= 2:
                # Nearly every edge: the facet and at most one other, in either order. The
                # other is the pair's sum minus ``f`` (slot 1 is zero-filled on a boundary
                # edge, which then has no link): no branch on the order, which is as random
                # as the graph.
                g = eface[eid, 0] + eface[eid, 1] - f
                c = ff[f, 0] * ff[g, 0] + ff[f, 1] * ff[g, 1] + ff[f, 2] * ff[g, 2]
                two = cnt == 2
                nbr[f, e] = g if two else -1
                ncos[f, e] = c if two else -2.0
                continue
            best = -1
            bestc = -2.0
            for q in range(min(cnt, MAX_PER_EDGE)):
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
def detect_kernel(nodes, edges, origin, fx, fy, ground_z, mode, prm):
    """Affordance detection on a graph, §4.2: triangulate, Eq. (1)–(2), segment, Eq. (3)–(4).

    :func:`_detect` without the floor level.

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
    out = _detect(nodes, edges, origin, fx, fy, ground_z, mode, prm, False)
    return out[:11]


@njit(cache=True)
def _detect(nodes, edges, origin, fx, fy, ground_z, mode, prm, floor):
    """:func:`detect_kernel`, and with ``floor`` the floor level of :func:`floor_level` too.

    The floor level (the median height of the terrain facets' distinct nodes, or the ground
    level without a terrain facet) is collected on the labelling pass instead of in a pass of
    its own ("map" mode's ``map_floor_plane``): the same nodes, so the same median.

    Returns:
        :func:`detect_kernel`'s tuple and the floor level (the ground level without ``floor``).
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
    tseen = np.zeros(n if floor else 0, np.bool_)
    zs = np.empty(n + 1 if floor else 0)
    nz = 0
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
        terrain = floor and gk == KIND_TERRAIN
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
            if terrain:
                # Each terrain node's height once over all terrain labels (written, then
                # counted if new, as in floor_level).
                for c in range(3):
                    v = fi[i, c]
                    zs[nz] = nodes[v, 2]
                    nz += not tseen[v]
                    tseen[v] = True
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
        np.median(zs[:nz]) if nz > 0 else ground,
    )


@njit(cache=True)
def triangulate_kernel(nodes, edges, origin, away, max_facets, min_quality):
    """Facets of a graph without segmentation: ``(facets, normals, n_bad)``."""
    if away:
        origin = _centroid(nodes, edges)
    fi, ff, nf, _, n_bad, _, _ = triangulate_graph(
        nodes, edges, origin, away, max_facets, min_quality
    )
    return fi[:nf, :3].astype(np.int64), ff[:nf, :3].copy(), n_bad


@njit(cache=True)
def facet_weights_kernel(nodes, edges, origin, away, max_facets, min_quality):
    """Facets, normals and Eq. (2) links: ``(facets, normals, nbr (F, 3), w (F, 3) radians)``.

    ``w`` is ``inf`` where a facet has no neighbour across an edge.
    """
    if away:
        origin = _centroid(nodes, edges)
    fi, ff, nf, _, _, ecnt, eface = triangulate_graph(
        nodes, edges, origin, away, max_facets, min_quality
    )
    nbr, ncos = facet_links(fi, ff, nf, ecnt, eface)
    w = np.full((nf, 3), np.inf)
    for f in range(nf):
        for e in range(3):
            if nbr[f, e] >= 0:
                # Eq. (2): w_ij = arccos(N_i . N_j / (|N_i| |N_j|)).
                w[f, e] = np.arccos(min(1.0, max(-1.0, ncos[f, e])))
    return fi[:nf, :3].astype(np.int64), ff[:nf, :3].copy(), nbr, w


@njit(cache=True)
def node_normals_kernel(nodes, facets, facet_normals):
    """Area-weighted mean of the incident facet normals per node, unit length or zero.

    Args:
        nodes: (n, 3) float64, metres.
        facets: (F, 3) int64 node indices.
        facet_normals: (F, 3) float64 unit normals (their orientation is kept).

    Returns:
        (n, 3) float64.
    """
    n = nodes.shape[0]
    out = np.zeros((n, 3))
    for f in range(facets.shape[0]):
        a = facets[f, 0]
        b = facets[f, 1]
        c = facets[f, 2]
        if a < 0 or b < 0 or c < 0 or a >= n or b >= n or c >= n:
            continue
        e1x = nodes[b, 0] - nodes[a, 0]
        e1y = nodes[b, 1] - nodes[a, 1]
        e1z = nodes[b, 2] - nodes[a, 2]
        e2x = nodes[c, 0] - nodes[a, 0]
        e2y = nodes[c, 1] - nodes[a, 1]
        e2z = nodes[c, 2] - nodes[a, 2]
        cx = e1y * e2z - e1z * e2y
        cy = e1z * e2x - e1x * e2z
        cz = e1x * e2y - e1y * e2x
        area = 0.5 * np.sqrt(cx * cx + cy * cy + cz * cz)
        if not np.isfinite(area):
            continue
        for v in (a, b, c):
            for d in range(3):
                out[v, d] += area * facet_normals[f, d]
    for i in range(n):
        nn = np.sqrt(out[i, 0] ** 2 + out[i, 1] ** 2 + out[i, 2] ** 2)
        if nn > 1e-15 and np.isfinite(nn):
            for d in range(3):
                out[i, d] /= nn
        else:
            for d in range(3):
                out[i, d] = 0.0
    return out


@njit(cache=True)
def match_surface_kernel(att_p, att_n, ref_p, ref_n, radius, cos_gate, e_pos, e_ang):
    """Eq. (12)–(15): match attention nodes to reference nodes, mean position and angle error.

    Each attention node takes, among the reference nodes within ``radius`` (Eq. 12) whose normal
    is within the gate (Eq. 13, read as a normal difference), the one closest in the normalised
    6-D sense ``(l / e_pos)**2 + (angle / e_ang)**2``. Unmatched nodes, non-finite rows and zero
    normals are skipped.

    Returns:
        ``(s_dot, theta_dot, n_matched)``: mean |point-to-plane distance| along the attention
        normal (Eq. 14, metres), mean angle between matched normals (Eq. 15, radians), count.
    """
    na = att_p.shape[0]
    nr = ref_p.shape[0]
    r2 = radius * radius
    s_sum = 0.0
    t_sum = 0.0
    nm = 0
    for i in range(na):
        ax = att_n[i, 0]
        ay = att_n[i, 1]
        az = att_n[i, 2]
        an = np.sqrt(ax * ax + ay * ay + az * az)
        if not (an > 1e-12) or not np.isfinite(an):
            continue
        if not (np.isfinite(att_p[i, 0]) and np.isfinite(att_p[i, 1]) and np.isfinite(att_p[i, 2])):
            continue
        ax /= an
        ay /= an
        az /= an
        best = -1
        best_cost = np.inf
        best_ang = 0.0
        for j in range(nr):
            dx = ref_p[j, 0] - att_p[i, 0]
            dy = ref_p[j, 1] - att_p[i, 1]
            dz = ref_p[j, 2] - att_p[i, 2]
            # Eq. (12): l = |Q_j - A_i|.
            d2 = dx * dx + dy * dy + dz * dz
            if not (d2 <= r2):
                continue
            qx = ref_n[j, 0]
            qy = ref_n[j, 1]
            qz = ref_n[j, 2]
            qn = np.sqrt(qx * qx + qy * qy + qz * qz)
            if not (qn > 1e-12):
                continue
            c = (qx * ax + qy * ay + qz * az) / qn
            if c < cos_gate:
                continue
            ang = np.arccos(min(1.0, max(-1.0, c)))
            cost = d2 / (e_pos * e_pos) + (ang / e_ang) ** 2
            if cost < best_cost:
                best_cost = cost
                best = j
                best_ang = ang
        if best < 0:
            continue
        # Eq. (14): ((Q - A) . A_hat) A_hat; its length is the point-to-plane distance.
        proj = (
            (ref_p[best, 0] - att_p[i, 0]) * ax
            + (ref_p[best, 1] - att_p[i, 1]) * ay
            + (ref_p[best, 2] - att_p[i, 2]) * az
        )
        s_sum += abs(proj)
        t_sum += best_ang
        nm += 1
    if nm == 0:
        return np.nan, np.nan, 0
    return s_sum / nm, t_sum / nm, nm


_N_ENDS = 16


@njit(cache=True)
def _trimmed_extent(values, cnt, q_lo, gap, low, high):
    """Both ends of ``values[:cnt]`` after the quantile cut ``q_lo`` and the stray-point walk.

    The same numbers as sorting the values, cutting ``q_lo`` of them at each end and then
    dropping an end value while its gap to the next one inwards exceeds ``gap`` (repeatedly).
    Without a quantile cut, only the ``_N_ENDS`` smallest and largest values are needed, found
    in one pass; a full sort is the fallback when the walk goes deeper or ``q_lo`` > 0. Most
    ends have no stray point, which the two smallest and two largest values show: they are
    found first, in registers, and the ``_N_ENDS`` only when a walk starts (a sensor-ordered
    frame gives the values in runs of rising or falling order, where each insertion into a
    list of ``_N_ENDS`` shifts the whole list). A NaN value takes the long way, whose lists
    place it as before.
    """
    n_end = _N_ENDS
    if q_lo == 0.0 and cnt > 2 * n_end:
        # The two smallest (lo0 <= lo1) and largest (hi0 >= hi1), by the same strict
        # comparisons as the insertion into lists of two.
        lo0 = np.inf
        lo1 = np.inf
        hi0 = -np.inf
        hi1 = -np.inf
        nan = False
        for i in range(cnt):
            v = values[i]
            nan |= v != v
            if v < lo1:
                if v < lo0:
                    lo1 = lo0
                    lo0 = v
                else:
                    lo1 = v
            if v > hi1:
                if v > hi0:
                    hi1 = hi0
                    hi0 = v
                else:
                    hi1 = v
        if not nan and not lo1 - lo0 > gap and not hi0 - hi1 > gap:
            return lo0, hi0
        # The n_end smallest (ascending) and largest (descending) values, by insertion.
        nl = 0
        nh = 0
        for i in range(cnt):
            v = values[i]
            if nl < n_end or v < low[nl - 1]:
                j = nl if nl < n_end else n_end - 1
                while j > 0 and low[j - 1] > v:
                    low[j] = low[j - 1]
                    j -= 1
                low[j] = v
                if nl < n_end:
                    nl += 1
            if nh < n_end or v > high[nh - 1]:
                j = nh if nh < n_end else n_end - 1
                while j > 0 and high[j - 1] < v:
                    high[j] = high[j - 1]
                    j -= 1
                high[j] = v
                if nh < n_end:
                    nh += 1
        a = 0
        while a < n_end - 1 and low[a + 1] - low[a] > gap:
            a += 1
        b = 0
        while b < n_end - 1 and high[b] - high[b + 1] > gap:
            b += 1
        if a < n_end - 1 and b < n_end - 1:
            return low[a], high[b]
    s = np.sort(values[:cnt])
    lo = int(q_lo * (cnt - 1))
    hi = cnt - 1 - lo
    a = lo
    b = hi
    while a < b and s[a + 1] - s[a] > gap:
        a += 1
    while b > a and s[b] - s[b - 1] > gap:
        b -= 1
    return s[a], s[b]


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


_NOISE_MIN_POINTS = 16
"""Fewest floor points round an object for a noise estimate (fewer: no noise correction)."""
_NOISE_SAMPLE = 512
"""Most floor points the noise estimate uses (its relative error with 512: about 5 %)."""


@njit(cache=True)
def noise_level_kernel(points, ground, tol, oz):
    """Range noise σ/d of the sensors, estimated on the floor of a frame.

    A range error δ = σ d along a ray moves a floor point's height by σ (oz - z), whatever its
    distance (d and the ray's drop scale together), so (z - median z) / (oz - z) over floor
    points (within ``tol`` of ``ground``) has spread σ; its median absolute deviation × 1.4826
    estimates σ (0 on a noise-free frame; the few points of walls' and objects' lowest ``tol``
    do not move a median). Up to ``_NOISE_SAMPLE`` floor points are taken, evenly through the
    frame; fewer than ``_NOISE_MIN_POINTS`` give 0.

    Args:
        points: (N, 3) float32 or float64, metres, the frame.
        ground: metres, the ground level.
        tol: metres, floor points lie within this of ``ground``.
        oz: metres, the sensors' height.
    """
    n = points.shape[0]
    step = max(1, n // (2 * _NOISE_SAMPLE))
    zs = np.empty(_NOISE_SAMPLE)
    m = 0
    for i in range(0, n, step):
        z = points[i, 2]
        if abs(z - ground) <= tol and oz - z > 1e-3:
            zs[m] = z
            m += 1
            if m == _NOISE_SAMPLE:
                break
    if m < _NOISE_MIN_POINTS:
        return 0.0
    zmed = np.median(zs[:m])
    rel = np.empty(m)
    for i in range(m):
        rel[i] = (zs[i] - zmed) / (oz - zs[i])
    med = np.median(rel)
    for i in range(m):
        rel[i] = abs(rel[i] - med)
    return 1.4826 * np.median(rel)


@njit(cache=True)
def _simex_end(values, cnt, sign, o, end, sig, spacing, draws):
    """One end of an extent with the range noise's overshoot taken out (SIMEX).

    With ``sign`` = +1 the end is the largest of ``values[:cnt]`` not beyond ``end`` (the walked
    extent), with -1 the smallest (``end`` and the result are then negated, as for +1). Point
    i's range noise moves it along this axis with standard deviation ``sig`` × |values[i] -
    o| (the ray's component along the axis × its length). The outermost of many noisy points
    overshoots the edge; simulation-extrapolation (Cook & Stefanski 1994) measures by how much:
    T(λ) = E[max_i(y_i + √λ s_i Z_i)] for λ = 1, 2 (added noise of λ times the variance, over
    the fixed draws), and the quadratic through T(0) = end, T(1), T(2) is read at λ = -1 (no
    noise). Applied only where the outermost point's noise exceeds the mean point ``spacing``:
    on sparser points the outermost sample falls short of the edge by about half a spacing
    (the pipeline's edge correction) and the noise mostly fills that gap. Never moves the end
    outwards.
    """
    s_out = -1.0
    best = -np.inf
    for i in range(cnt):
        y = sign * values[i]
        if y <= end and y > best:
            best = y
            s_out = sig * abs(values[i] - o)
    if not s_out > spacing:
        return end
    # The candidates: points that can reach the end with twice the variance (6.5 sd).
    r2 = np.sqrt(2.0)
    cy = np.empty(cnt)
    cs = np.empty(cnt)
    nc = 0
    for i in range(cnt):
        y = sign * values[i]
        s = sig * abs(values[i] - o)
        if y <= end and y + 6.5 * r2 * s >= end:
            cy[nc] = y
            cs[nc] = s
            nc += 1
    nb = draws.shape[0]
    nd = draws.shape[1]
    t1 = 0.0
    t2 = 0.0
    for b in range(nb):
        m1 = -np.inf
        m2 = -np.inf
        for j in range(nc):
            z = draws[b, j % nd] * cs[j]
            m1 = max(m1, cy[j] + z)
            m2 = max(m2, cy[j] + r2 * z)
        t1 += m1
        t2 += m2
    t1 /= nb
    t2 /= nb
    return min(end, 3.0 * end - 3.0 * t1 + t2)


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
def count_above(points, thr):
    """Number of points higher than ``thr`` (metres)."""
    c = 0
    for i in range(points.shape[0]):
        c += points[i, 2] > thr
    return c


@njit(cache=True)
def refine_objects_kernel(
    points, boxes, ground, tol, margin, fx, fy, iters, q_lo, q_top, gap, origin, slope, bins,
    edge, noise, draws,
):  # fmt: skip
    """Object sizes from the raw frame points round each object (pipeline ``refine``).

    The paper's "raw data around the suspected obstacle" (Algorithm 1, §4.1). The frame's
    points higher than ``tol`` above ``ground`` are gathered once; for each object
    box, those within ``margin`` of its ground-plane extent (in the walking frame) are taken,
    the extent is reset to their ``q_lo``..``1 - q_lo`` quantiles along and across the walking
    direction, and this repeats ``iters`` times, so the extent grows over an obstacle the graph
    only partly covers and stops at its edge (floor points are never gathered).

    Args:
        points: (N, 3) float32 or float64, metres, the frame.
        boxes: (K, 2, 3) float64 object boxes (min/max corners of their nodes), metres.
        ground: metres, the ground level.
        tol: metres, points higher than ground + tol count as obstacle surface.
        margin: metres, search margin round the current extent.
        fx: x of the unit walking direction in the ground plane.
        fy: y of the unit walking direction in the ground plane.
        iters: growing iterations (≥ 1).
        q_lo: quantile of the extent's ends (robust to stray points), e.g. 0.01.
        q_top: quantile of the height, e.g. 0.9 (most surface points of a block are on its top).
        gap: metres; after the quantile cut, an end point farther than this from the next
            point inwards is dropped, and so on (isolated stray points: range noise).
        origin: (3,) float64, metres, the sensors' position.
        slope: (N,) float64, each point's tan(elevation) (``view_edge_kernel``).
        bins: (N,) int64, each point's azimuth bin, -1 to skip it (``view_edge_kernel``).
        edge: (nbins,) float64, the view's upper edge per bin (``view_edge_kernel``).
        noise: range noise σ/d (``noise_level_kernel``); > 0 moves each end whose noise
            exceeds the mean point spacing back by its expected overshoot (``_simex_end``).
        draws: (B, D) float64 standard normal draws for ``_simex_end`` (fixed: deterministic).

    Returns:
        (K, 10) float64: points used, height above ground, width (across), length (along), then
        the extent as along-min, along-max, across-min, across-max, the smallest distance
        (in tan(elevation) seen from ``origin``) of an object point below the upper edge of the
        view in its azimuth bin: near 0 when the view cuts the surface off (a wall whose top is
        out of sight), and the ``noise`` used.
        A row with 0 points is left at NaN.
    """
    n = points.shape[0]
    k_n = boxes.shape[0]
    out = np.full((k_n, 10), np.nan)
    thr = ground + tol
    hz = np.empty(n)
    hf = np.empty(n)
    hl = np.empty(n)
    hs = np.empty(n)
    hb = np.empty(n, np.int64)
    of = origin[0] * fx + origin[1] * fy
    ol = origin[1] * fx - origin[0] * fy
    m = 0
    for i in range(n):
        b = bins[i]
        if b < 0:
            continue
        x = points[i, 0]
        y = points[i, 1]
        z = points[i, 2]
        pf = x * fx + y * fy
        pl = y * fx - x * fy
        if z > thr:
            hz[m] = z
            hf[m] = pf
            hl[m] = pl
            hs[m] = slope[i]
            hb[m] = b
            m += 1
    bz = np.empty(max(m, 1))
    bf = np.empty(max(m, 1))
    bl = np.empty(max(m, 1))
    bg = np.empty(max(m, 1))
    low = np.empty(_N_ENDS)
    high = np.empty(_N_ENDS)
    for k in range(k_n):
        # The box's ground-plane corners in the walking frame.
        f0 = np.inf
        f1 = -np.inf
        l0 = np.inf
        l1 = -np.inf
        for a in range(2):
            for b in range(2):
                x = boxes[k, a, 0]
                y = boxes[k, b, 1]
                pf = x * fx + y * fy
                pl = y * fx - x * fy
                f0 = min(f0, pf)
                f1 = max(f1, pf)
                l0 = min(l0, pl)
                l1 = max(l1, pl)
        cnt = 0
        for _ in range(iters):
            cnt = 0
            for i in range(m):
                if (
                    hf[i] >= f0 - margin
                    and hf[i] <= f1 + margin
                    and hl[i] >= l0 - margin
                    and hl[i] <= l1 + margin
                ):
                    bz[cnt] = hz[i]
                    bf[cnt] = hf[i]
                    bl[cnt] = hl[i]
                    bg[cnt] = edge[hb[i]] - hs[i]
                    cnt += 1
            if cnt == 0:
                break
            nf0, nf1 = _trimmed_extent(bf, cnt, q_lo, gap, low, high)
            nl0, nl1 = _trimmed_extent(bl, cnt, q_lo, gap, low, high)
            if nf0 == f0 and nf1 == f1 and nl0 == l0 and nl1 == l1:
                break
            f0, f1, l0, l1 = nf0, nf1, nl0, nl1
        if cnt == 0:
            continue
        sig = noise
        if sig > 0.0:
            sp = np.sqrt(max(f1 - f0, 0.0) * max(l1 - l0, 0.0) / cnt)
            nf0 = -_simex_end(bf, cnt, -1.0, of, -f0, sig, sp, draws)
            nf1 = _simex_end(bf, cnt, 1.0, of, f1, sig, sp, draws)
            nl0 = -_simex_end(bl, cnt, -1.0, ol, -l0, sig, sp, draws)
            nl1 = _simex_end(bl, cnt, 1.0, ol, l1, sig, sp, draws)
            f0, f1, l0, l1 = nf0, nf1, nl0, nl1
        out[k, 9] = sig
        out[k, 0] = cnt
        out[k, 1] = np.partition(bz[:cnt], int(q_top * (cnt - 1)))[int(q_top * (cnt - 1))] - ground
        out[k, 2] = l1 - l0
        out[k, 3] = f1 - f0
        out[k, 4] = f0
        out[k, 5] = f1
        out[k, 6] = l0
        out[k, 7] = l1
        gmin = np.inf
        for i in range(cnt):
            gmin = min(gmin, bg[i])
        out[k, 8] = gmin
    return out


@njit(cache=True)
def view_walls_kernel(points, ground, tol, fx, fy, slope, bins, edge, cut, min_width, min_points):
    """Surfaces cut off by the top of the view across a wide azimuth span (pipeline ``view_wall``).

    Per azimuth bin (``view_edge_kernel``), the upper edge of the view is the largest
    tan(elevation) seen from the sensors; a point is *cut off* when it is higher than ``tol``
    above ``ground`` and within ``cut`` of that edge: the surface it lies on rises out of
    sight. On a bare floor the view's upper edge is floor (z ≈ 0), so no point is cut off; a
    box whose top is in sight has the floor behind it above it in the view. Runs of
    consecutive bins holding cut-off points are candidate surfaces; a run whose cut-off points
    span at least ``min_width`` across the walking direction, with at least ``min_points``
    points, is returned.

    Args:
        points: (N, 3) float32 or float64, metres, the frame.
        ground: metres, the ground level.
        tol: metres, cut-off points are higher than ground + tol.
        fx: x of the unit walking direction in the ground plane.
        fy: y of the unit walking direction in the ground plane.
        slope: (N,) float64, each point's tan(elevation) (``view_edge_kernel``).
        bins: (N,) int64, each point's azimuth bin, -1 to skip it (``view_edge_kernel``).
        edge: (nbins,) float64, the view's upper edge per bin (``view_edge_kernel``).
        cut: tan(elevation) distance to the view's edge within which a point is cut off.
        min_width: metres, smallest span across the walking direction of a returned run.
        min_points: fewest cut-off points of a returned run.

    Returns:
        (R, 11) float64, one row per run: points, top height above ground, min x, min y,
        max x, max y, mean x, mean y, mean z, across-extent, along-extent.
    """
    n = points.shape[0]
    nbins = edge.shape[0]
    thr = ground + tol
    # Per bin: count, top z, x/y box, sums, across and along extents of the cut-off points.
    acc = np.zeros((nbins, 13))
    for b in range(nbins):
        acc[b, 1] = -np.inf
        acc[b, 2] = np.inf
        acc[b, 3] = np.inf
        acc[b, 4] = -np.inf
        acc[b, 5] = -np.inf
        acc[b, 9] = np.inf
        acc[b, 10] = -np.inf
        acc[b, 11] = np.inf
        acc[b, 12] = -np.inf
    for i in range(n):
        z = points[i, 2]
        b = bins[i]
        if not (z > thr and b >= 0 and edge[b] - slope[i] <= cut):
            continue
        x = points[i, 0]
        y = points[i, 1]
        pf = x * fx + y * fy
        pl = y * fx - x * fy
        acc[b, 0] += 1.0
        acc[b, 1] = max(acc[b, 1], z)
        acc[b, 2] = min(acc[b, 2], x)
        acc[b, 3] = min(acc[b, 3], y)
        acc[b, 4] = max(acc[b, 4], x)
        acc[b, 5] = max(acc[b, 5], y)
        acc[b, 6] += x
        acc[b, 7] += y
        acc[b, 8] += z
        acc[b, 9] = min(acc[b, 9], pl)
        acc[b, 10] = max(acc[b, 10], pl)
        acc[b, 11] = min(acc[b, 11], pf)
        acc[b, 12] = max(acc[b, 12], pf)
    out = np.empty((nbins, 11))
    r = 0
    b = 0
    while b < nbins:
        if acc[b, 0] == 0.0:
            b += 1
            continue
        run = acc[b].copy()
        b += 1
        while b < nbins and acc[b, 0] > 0.0:
            run[0] += acc[b, 0]
            for c in (1, 4, 5, 10, 12):
                run[c] = max(run[c], acc[b, c])
            for c in (2, 3, 9, 11):
                run[c] = min(run[c], acc[b, c])
            for c in (6, 7, 8):
                run[c] += acc[b, c]
            b += 1
        if run[0] >= min_points and run[10] - run[9] >= min_width:
            out[r, 0] = run[0]
            out[r, 1] = run[1] - ground
            out[r, 2] = run[2]
            out[r, 3] = run[3]
            out[r, 4] = run[4]
            out[r, 5] = run[5]
            out[r, 6] = run[6] / run[0]
            out[r, 7] = run[7] / run[0]
            out[r, 8] = run[8] / run[0]
            out[r, 9] = run[10] - run[9]
            out[r, 10] = run[12] - run[11]
            r += 1
    return out[:r]


# Columns of ``map_objects_kernel``'s result.
M_NNODES = 0
M_NHIGH = 1
M_HEIGHT = 2
M_F0 = 3
M_F1 = 4
M_L0 = 5
M_L1 = 6
M_SPACING = 7
M_VIEW = 8
M_BOX = 9  # 9..14: min x, y, z, max x, y, z of the group's nodes
M_HBOX = 15  # 15..18: min x, y, max x, y of the group's high nodes
N_MAP_COLS = 19


@njit(cache=True)
def min_area_rect(pf, pl, k, hull):
    """The minimum-area rectangle round ``k`` points of the ground plane (rotating calipers).

    The points' convex hull (Andrew's monotone chain), then each hull edge's direction as a
    rectangle axis (the minimum-area rectangle has a side on a hull edge, Freeman & Shapira
    1975). A block's footprint is a rectangle at any yaw, and the nodes on it sit inside its
    edges, rarest at its corners: the rectangle's sides follow the edges, where the nodes
    are, and its corners stand where the nodes are not.

    Args:
        pf: (>= k,) float64, metres, the points' coordinates along the walking direction.
        pl: (>= k,) float64, metres, across it.
        k: number of points.
        hull: (>= 3k + 2,) int64 work buffer.

    Returns:
        ``(a, b, c, s)``: the side along the rectangle's axis, the side across it (metres),
        and |cos|, |sin| of the angle between that axis and the walking direction; so the
        rectangle spans ``a c + b s`` along the walking direction and ``a s + b c`` across
        it. One point, or none: ``(0, 0, 1, 0)``.
    """
    if k < 2:
        return 0.0, 0.0, 1.0, 0.0
    # Lexicographic order (pf, then pl) by insertion, in hull[2k + 2:], the hull in
    # hull[:2k + 2]: a block's 5-40 points, where an argsort's allocation cost more than
    # the sort. Points equal in both coordinates may come in any order: the hull and the
    # rectangle read coordinates only.
    order = hull[2 * k + 2 : 3 * k + 2]
    for q in range(k):
        v = q
        x = pf[v]
        y = pl[v]
        r = q
        while r > 0:
            o = order[r - 1]
            if pf[o] < x or (pf[o] == x and pl[o] <= y):
                break
            order[r] = o
            r -= 1
        order[r] = v
    h = 0
    for q in range(k):  # lower hull
        i = order[q]
        while h >= 2:
            a = hull[h - 2]
            b = hull[h - 1]
            cr = (pf[b] - pf[a]) * (pl[i] - pl[a]) - (pl[b] - pl[a]) * (pf[i] - pf[a])
            if cr > 0.0:
                break
            h -= 1
        hull[h] = i
        h += 1
    lo = h + 1
    for q in range(k - 2, -1, -1):  # upper hull
        i = order[q]
        while h >= lo:
            a = hull[h - 2]
            b = hull[h - 1]
            cr = (pf[b] - pf[a]) * (pl[i] - pl[a]) - (pl[b] - pl[a]) * (pf[i] - pf[a])
            if cr > 0.0:
                break
            h -= 1
        hull[h] = i
        h += 1
    h -= 1  # the last vertex is the first again
    best = np.inf
    ra = 0.0
    rb = 0.0
    rc = 1.0
    rs = 0.0
    for e in range(h):  # h >= 2 here
        i = hull[e]
        j = hull[(e + 1) % h]
        ux = pf[j] - pf[i]
        uy = pl[j] - pl[i]
        norm = np.sqrt(ux * ux + uy * uy)
        if not norm > 0.0:
            continue
        ux /= norm
        uy /= norm
        a0 = np.inf
        a1 = -np.inf
        b0 = np.inf
        b1 = -np.inf
        for q in range(h):
            v = hull[q]
            pa = pf[v] * ux + pl[v] * uy
            pb = pl[v] * ux - pf[v] * uy
            a0 = min(a0, pa)
            a1 = max(a1, pa)
            b0 = min(b0, pb)
            b1 = max(b1, pb)
        area = (a1 - a0) * (b1 - b0)
        if area < best:
            best = area
            ra = a1 - a0
            rb = b1 - b0
            rc = abs(ux)
            rs = abs(uy)
    return ra, rb, rc, rs


@njit(cache=True)
def group_rect(nodes, hnode, h0, h1, floor, zmin, fx, fy, pf, pl, hull):
    """The minimum-area rectangle of the high nodes ``hnode[h0:h1]`` at least ``zmin`` up.

    Args:
        nodes: (n, 3) float64, metres.
        hnode: (H,) int64 node indices: a group's distinct high nodes, as
            :func:`map_objects_lists` lists them (``hnode[hstart[g]:hstart[g + 1]]``).
        h0: first entry of the group's high nodes in ``hnode``.
        h1: one past the last.
        floor: metres, the ground level the high nodes were found against.
        zmin: metres above ``floor``: the nodes at least this high are taken.
        fx: x of the unit walking direction in the ground plane.
        fy: y of the unit walking direction in the ground plane.
        pf: (>= h1 - h0,) float64 work buffer.
        pl: (>= h1 - h0,) float64 work buffer.
        hull: (>= 3 (h1 - h0) + 2,) int64 work buffer.

    Returns:
        :func:`min_area_rect`'s ``(a, b, c, s)``.
    """
    k = 0
    for q in range(h0, h1):
        v = hnode[q]
        if nodes[v, 2] - floor >= zmin:
            pf[k] = nodes[v, 0] * fx + nodes[v, 1] * fy
            pl[k] = nodes[v, 1] * fx - nodes[v, 0] * fy
            k += 1
    return min_area_rect(pf, pl, k, hull)


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
    return map_objects_lists(
        nodes, edges, facets, fgroup, ngroups, ground, tol, fx, fy, slope, bins, edge
    )[0]


@njit(cache=True)
def _median_sorting(buf, lo, hi):
    """``np.median(buf[lo:hi])`` (``hi > lo``, no NaN), sorting that slice in place.

    The same value as NumPy's and numba's median (the middle element, or the halved sum of
    the two middle ones), without the copy numba's ``np.median`` allocates: a group's edges
    number 1-60.
    """
    for q in range(lo + 1, hi):
        x = buf[q]
        r = q
        while r > lo and buf[r - 1] > x:
            buf[r] = buf[r - 1]
            r -= 1
        buf[r] = x
    k = hi - lo
    half = lo + (k >> 1)
    if k & 1 == 0:
        return (buf[half - 1] + buf[half]) / 2
    return buf[half]


@njit(cache=True, nogil=True)
def map_objects_lists(
    nodes, edges, facets, fgroup, ngroups, ground, tol, fx, fy, slope, bins, edge
):
    """:func:`map_objects_kernel`'s measures, and each group's distinct high nodes.

    Returns:
        ``(out, hstart, hnode)``: :func:`map_objects_kernel`'s (G, N_MAP_COLS) table, and
        group ``g``'s high nodes as ``hnode[hstart[g]:hstart[g + 1]]`` (int64, in the order
        its facets reach them), for :func:`group_rect`.
    """
    n = nodes.shape[0]
    out = np.empty((ngroups, N_MAP_COLS))
    stamp = np.full(n, -1, np.int64)
    # The facets grouped by group, in facet order within a group (a counting sort: the order
    # of a stable argsort, without its sort; the facets of no group are left out).
    nf = fgroup.shape[0]
    gstart = np.zeros(ngroups + 1, np.int64)
    for f in range(nf):
        if fgroup[f] >= 0:
            gstart[fgroup[f] + 1] += 1
    for g in range(ngroups):
        gstart[g + 1] += gstart[g]
    order = np.empty(gstart[ngroups], np.int64)
    gfill = gstart[:ngroups].copy()
    for f in range(nf):
        g = fgroup[f]
        if g >= 0:
            order[gfill[g]] = f
            gfill[g] += 1
    hstart = np.empty(ngroups + 1, np.int64)
    hnode = np.empty(3 * gstart[ngroups], np.int64)
    nhn = 0
    # Up to 62 groups, one pass over the edges for all of them (each high node's groups as
    # bits of ``hmember``) instead of one pass per group; the spacings are the same medians.
    bits = ngroups <= 62
    hmember = np.zeros(n if bits else 0, np.int64)
    lens = np.empty(1 if bits else max(edges.shape[0], 1))  # the per-group pass's lengths
    for g in range(ngroups):
        # The group's facets are contiguous in ``order``; ``stamp`` marks its nodes (a node
        # on facets of two groups counts in both). The measures are kept in locals, each
        # the same min / max / count as a column of ``out`` updated in place.
        hstart[g] = nhn
        nn = 0.0
        nh = 0.0
        height = -np.inf
        f0 = np.inf
        f1 = -np.inf
        l0 = np.inf
        l1 = -np.inf
        view = np.inf
        bx0 = np.inf
        by0 = np.inf
        bz0 = np.inf
        bx1 = -np.inf
        by1 = -np.inf
        bz1 = -np.inf
        hx0 = np.inf
        hy0 = np.inf
        hx1 = -np.inf
        hy1 = -np.inf
        bit = np.int64(1) << min(g, 62)
        for q in range(gstart[g], gstart[g + 1]):
            f = order[q]
            for c in range(3):
                v = facets[f, c]
                if stamp[v] == g:
                    continue
                stamp[v] = g
                nn += 1.0
                x = nodes[v, 0]
                y = nodes[v, 1]
                z = nodes[v, 2]
                bx0 = min(bx0, x)
                by0 = min(by0, y)
                bz0 = min(bz0, z)
                bx1 = max(bx1, x)
                by1 = max(by1, y)
                bz1 = max(bz1, z)
                if z - ground > tol:
                    hnode[nhn] = v
                    nhn += 1
                    if bits:
                        hmember[v] |= bit
                    nh += 1.0
                    height = max(height, z - ground)
                    pf = x * fx + y * fy
                    pl = y * fx - x * fy
                    f0 = min(f0, pf)
                    f1 = max(f1, pf)
                    l0 = min(l0, pl)
                    l1 = max(l1, pl)
                    hx0 = min(hx0, x)
                    hy0 = min(hy0, y)
                    hx1 = max(hx1, x)
                    hy1 = max(hy1, y)
                    b = bins[v]
                    if b >= 0:
                        view = min(view, edge[b] - slope[v])
        if nh == 0.0:
            height = np.nan
            f0 = np.nan
            f1 = np.nan
            l0 = np.nan
            l1 = np.nan
        out[g, M_NNODES] = nn
        out[g, M_NHIGH] = nh
        out[g, M_HEIGHT] = height
        out[g, M_F0] = f0
        out[g, M_F1] = f1
        out[g, M_L0] = l0
        out[g, M_L1] = l1
        out[g, M_SPACING] = 0.0
        out[g, M_VIEW] = view
        out[g, M_BOX] = bx0
        out[g, M_BOX + 1] = by0
        out[g, M_BOX + 2] = bz0
        out[g, M_BOX + 3] = bx1
        out[g, M_BOX + 4] = by1
        out[g, M_BOX + 5] = bz1
        out[g, M_HBOX] = hx0
        out[g, M_HBOX + 1] = hy0
        out[g, M_HBOX + 2] = hx1
        out[g, M_HBOX + 3] = hy1
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
    hstart[ngroups] = nhn
    if bits and ngroups > 0:
        # Edges joining two high nodes of a group: listed in one flat pass (each edge written
        # and counted by whether it is one: a tenth of the edges, scattered), then counted
        # per group, gathered per group (CSR), and each group's median taken.
        m = edges.shape[0]
        elist = np.empty(max(m, 1), np.int64)
        ne = 0
        for e in range(m):
            elist[ne] = e
            ne += (hmember[edges[e, 0]] & hmember[edges[e, 1]]) != 0
        start = np.zeros(ngroups + 1, np.int64)
        for q in range(ne):
            e = elist[q]
            both = hmember[edges[e, 0]] & hmember[edges[e, 1]]
            while both != 0:
                start[trailing_zeros(both) + 1] += 1
                both &= both - 1
        for g in range(ngroups):
            start[g + 1] += start[g]
        fill = start[:ngroups].copy()
        buf = np.empty(max(start[ngroups], 1))
        for q in range(ne):
            e = elist[q]
            a = edges[e, 0]
            b = edges[e, 1]
            both = hmember[a] & hmember[b]
            dx = nodes[a, 0] - nodes[b, 0]
            dy = nodes[a, 1] - nodes[b, 1]
            d = np.sqrt(dx * dx + dy * dy)
            while both != 0:
                g = trailing_zeros(both)
                buf[fill[g]] = d
                fill[g] += 1
                both &= both - 1
        for g in range(ngroups):
            if start[g + 1] > start[g]:
                out[g, M_SPACING] = _median_sorting(buf, start[g], start[g + 1])
    return out, hstart, hnode


# Packed parameters of ``map_step_kernel`` (the pipeline's map-mode settings).
Q_MERGE = 0
Q_VIEW_BINS = 1
Q_EDGE_CORRECTION = 2
Q_VIEW_CUT = 3
Q_MIN_HEIGHT = 4
Q_HIGH_BOX = 5  # PipelineParams.map_box_from_high
Q_VIEW_FIRST = 6  # PipelineParams.map_view_first
Q_FLOOR_PLANE = 7  # PipelineParams.map_floor_plane
Q_RECT = 8  # PipelineParams.map_rect
Q_RECT_CORRECTION = 9  # PipelineParams.map_rect_correction
Q_RECT_HEIGHT = 10  # PipelineParams.map_rect_height
N_MAP_PARAMS = 11


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
    zs = np.empty(n + 1)
    k = 0
    # Each node's height written and counted by whether it is a terrain facet's and new (no
    # branch on either: they follow the graph); the median does not depend on the order.
    for f in range(facets.shape[0]):
        terrain = lab[flabels[f], L_KIND] == KIND_TERRAIN
        for c in range(3):
            v = facets[f, c]
            zs[k] = nodes[v, 2]
            k += terrain & (not seen[v])
            seen[v] |= terrain
    if k == 0:
        return ground
    return np.median(zs[:k])


@njit(cache=True)
def _root(root, a):
    while root[a] != a:
        a = root[a]
    return a


@njit(cache=True)
def map_step_kernel(
    nodes, edges, origin, fx, fy, ground, facets, flabels, lab, pos, normal, box, prm, mq
):
    """:func:`_map_step`, the floor level computed by :func:`floor_level`."""
    return _map_step(
        nodes, edges, origin, fx, fy, ground, facets, flabels, lab, pos, normal, box, prm, mq,
        floor_level(nodes, facets, flabels, lab, ground) if mq[Q_FLOOR_PLANE] != 0.0 else ground,
    )  # fmt: skip


@njit(cache=True)
def _map_step(
    nodes, edges, origin, fx, fy, ground, facets, flabels, lab, pos, normal, box, prm, mq, floor
):
    """The map-mode object steps on ``detect_kernel``'s labels, in one compiled call.

    ``AttentionPipeline`` reads an object's measures from the map alone ("map" mode): with
    ``Q_FLOOR_PLANE`` the ground level is first the floor plane of the terrain facets' nodes
    (:func:`floor_level`); object labels whose boxes overlap in the ground plane are one group
    (union in label order; the group takes its first label's place), except, with
    ``Q_VIEW_FIRST``, a label whose own high nodes reach the graph's view edge (merged with
    none); each group is measured by :func:`map_objects_kernel` (high-node extents plus
    ``Q_EDGE_CORRECTION`` × their spacing, or with ``Q_RECT`` their minimum-area rectangle,
    each side grown by ``Q_RECT_CORRECTION`` × their spacing, projected; the box is the high
    nodes' with ``Q_HIGH_BOX``, else all the group's nodes', grown by half the correction in
    the ground plane),
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
        floor: metres, the floor level (:func:`floor_level`), read with ``Q_FLOOR_PLANE``.

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
        ground = floor
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
    shs = np.zeros(1, np.int64)  # the singles' high-node lists (map_objects_lists)
    shn = np.empty(0, np.int64)
    if view_cut >= 0.0 and mq[Q_MERGE] != 0.0 and mq[Q_VIEW_FIRST] != 0.0:
        obj_of = np.full(nl, -1, np.int64)
        for a in range(nobj):
            obj_of[objs[a]] = a
        fsingle = np.empty(nf, np.int64)
        for f in range(nf):
            fsingle[f] = obj_of[flabels[f]]
        single, shs, shn = map_objects_lists(
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
    gobj = np.empty(nobj, np.int64)  # each group's first object label (index into objs)
    label_group = np.full(nl, -1, np.int64)
    ng = 0
    for a in range(nobj):
        r = _root(root, a)
        if gid[r] < 0:
            gid[r] = ng
            gobj[ng] = a
            ng += 1
        label_group[objs[a]] = gid[r]
    fgroup = np.empty(nf, np.int64)
    counts = np.zeros(nl, np.int64)
    for f in range(nf):
        fgroup[f] = label_group[flabels[f]]
        counts[flabels[f]] += 1
    # Each group's members in label order; the group's first label is where it goes.
    first = np.full(ng, -1, np.int64)
    nmem = np.zeros(ng, np.int64)
    for k in range(nl):
        g = label_group[k]
        if g >= 0:
            if first[g] < 0:
                first[g] = k
            nmem[g] += 1
    # Each group's high nodes: hnode[hstart[g]:hend[g]] (the rectangle's points).
    if ng == nobj and single.shape[0] == nobj:
        # No label merged: the groups are the labels in order, measured already.
        res = single
        hstart = shs[:ng]
        hend = shs[1:]
        hnode = shn
    elif single.shape[0] == nobj:
        # Only the merged groups are measured again: a group of one label is that label,
        # measured already (map_objects_kernel measures each group on its own facets alone).
        mid = np.full(ng, -1, np.int64)
        nmg = 0
        for g in range(ng):
            if nmem[g] > 1:
                mid[g] = nmg
                nmg += 1
        fmerged = np.empty(nf, np.int64)
        for f in range(nf):
            fmerged[f] = mid[fgroup[f]] if fgroup[f] >= 0 else -1
        res2, mhs, mhn = map_objects_lists(
            nodes, edges, facets, fmerged, nmg, ground, tol, fx, fy, slope, bins, vedge
        )
        res = np.empty((ng, N_MAP_COLS))
        for g in range(ng):
            for c in range(N_MAP_COLS):
                res[g, c] = res2[mid[g], c] if mid[g] >= 0 else single[gobj[g], c]
        # The two lists one after the other; the merged groups' entries shifted by the first's.
        nsh = shn.shape[0]
        hnode = np.empty(nsh + mhn.shape[0], np.int64)
        hnode[:nsh] = shn
        hnode[nsh:] = mhn
        hstart = np.empty(ng, np.int64)
        hend = np.empty(ng, np.int64)
        for g in range(ng):
            if mid[g] >= 0:
                hstart[g] = nsh + mhs[mid[g]]
                hend[g] = nsh + mhs[mid[g] + 1]
            else:
                hstart[g] = shs[gobj[g]]
                hend[g] = shs[gobj[g] + 1]
    else:
        res, ghs, hnode = map_objects_lists(
            nodes, edges, facets, fgroup, ng, ground, tol, fx, fy, slope, bins, vedge
        )
        hstart = ghs[:ng]
        hend = ghs[1:]
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
    use_rect = mq[Q_RECT] != 0.0
    # The rectangle's work buffers, for the largest group's high nodes.
    hmax = 0
    if use_rect:
        for g in range(ng):
            hmax = max(hmax, hend[g] - hstart[g])
    rpf = np.empty(hmax)
    rpl = np.empty(hmax)
    rhull = np.empty(3 * hmax + 2, np.int64)
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
                at_view_edge = (
                    view_cut >= 0.0
                    and res[g, M_VIEW] <= view_cut
                    and res[g, M_HEIGHT] >= mq[Q_MIN_HEIGHT]
                )
                if use_rect and res[g, M_NHIGH] >= 3.0 and not at_view_edge:
                    # The minimum-area rectangle of the upper high nodes, each side grown by
                    # the correction, projected on the walking direction and across it (an
                    # object about to be relabelled wall keeps its extents).
                    ra, rb, rc, rs = group_rect(
                        nodes, hnode, hstart[g], hend[g], ground,
                        mq[Q_RECT_HEIGHT] * res[g, M_HEIGHT], fx, fy, rpf, rpl, rhull,
                    )  # fmt: skip
                    cr = mq[Q_RECT_CORRECTION] * res[g, M_SPACING]
                    olab[j, L_WIDTH] = (ra + cr) * rs + (rb + cr) * rc
                    olab[j, L_LENGTH] = (ra + cr) * rc + (rb + cr) * rs
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


@njit(cache=True)
def detect_map_kernel(nodes, edges, origin, fx, fy, ground_z, mode, prm, mq):
    """:func:`detect_kernel` and then :func:`map_step_kernel`, in one compiled call ("map" mode).

    The pipeline's map-mode detection (``AttentionPipeline._detect_map``) without a return to
    Python between the two: the detection's arrays go straight into the map step. The map step
    runs when the detection found facets, every edge index was valid, its ground level is
    finite and the facets face ``origin`` (``mode`` without ``MODE_ORIENT_AWAY``); otherwise the
    detection's arrays come back as they are.

    Args:
        nodes: (n, 3) float64, metres.
        edges: (m, 2) int64.
        origin: (3,) float64, metres, the sensors.
        fx: x of the unit walking direction in the ground plane.
        fy: y of the unit walking direction in the ground plane.
        ground_z: metres, used with ``MODE_GROUND_KNOWN``; else the ground is estimated.
        mode: bit mask of ``MODE_*``.
        prm: (N_PARAMS,) float64 packed detection parameters (``P_*``).
        mq: (N_MAP_PARAMS,) float64 map-mode parameters (``Q_*``).

    Returns:
        ``(n_bad, truncated, ground, facets, normals, flabels, lab, pos, normal, box, sboxes,
        merged)``: as :func:`detect_kernel`'s, after the map step (``merged``: the labels whose
        normals come unnormalised, see :func:`map_step_kernel`; empty without the step).
    """
    n_bad, truncated, ground, facets, normals, flabels, lab, pos, normal, box, sboxes, floor = (
        _detect(nodes, edges, origin, fx, fy, ground_z, mode, prm, mq[Q_FLOOR_PLANE] != 0.0)
    )
    merged = np.zeros(0, np.int64)
    if (
        n_bad == 0
        and facets.shape[0] > 0
        and (mode & MODE_ORIENT_AWAY) == 0
        and np.isfinite(ground)
    ):
        lab, pos, normal, box, flabels, merged, sboxes, ground = _map_step(
            nodes, edges, origin, fx, fy, ground, facets, flabels, lab, pos, normal, box, prm, mq,
            floor,
        )  # fmt: skip
    return n_bad, truncated, ground, facets, normals, flabels, lab, pos, normal, box, sboxes, merged
