"""Numba kernels for affordance detection (§4.2, Eq. 1–4) and surface matching (§6.5.3, Eq. 12–15).

Pure ``@njit(cache=True)`` functions over NumPy arrays: no Python objects, no state. The public
wrappers, with validation and the documentation of every choice, are
:mod:`neurocog_gym.perception.affordance` and :mod:`neurocog_gym.perception.similarity`.

Adjacency is CSR with slack, built in two passes over the edge array (count, fill): row ``i`` of
the flat array ``adj`` starts at ``start[i]``, holds ``deg[i]`` neighbours and has room for
``cap[i]`` (its input degree plus ``DIAGONAL_SLACK``), so the 4-cycle diagonals are appended in
place. The undirected edge ``(lo, hi)``, ``lo < hi``, is identified by its slot ``start[lo] + k``
where ``adj[start[lo] + k] == hi``; the slots index the edge-to-facet table.
"""

from __future__ import annotations

import numpy as np
from numba import njit

KIND_TERRAIN = 0
KIND_WALL = 1
KIND_OBJECT = 2
DIAGONAL_SLACK = 8
MAX_FACETS_PER_EDGE = 4


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
def _row_find(adj, start, deg, a, b):
    """Return the slot of ``b`` in row ``a``, or -1."""
    s = start[a]
    for k in range(deg[a]):
        if adj[s + k] == b:
            return s + k
    return -1


@njit(cache=True)
def build_adjacency(valid, edges, slack):
    """CSR-with-slack adjacency from an undirected edge list.

    Args:
        valid: (n,) bool, nodes that may carry edges (finite coordinates).
        edges: (m, 2) int64 node indices; self-loops, duplicates and edges touching an invalid
            node are dropped.
        slack: free slots per non-isolated row, for the diagonals.

    Returns:
        ``(adj, start, cap, deg, n_bad)``: flat neighbour array, (n + 1,) row starts, (n,) row
        capacities, (n,) degrees, and the number of edges with an index outside [0, n).
    """
    n = valid.shape[0]
    m = edges.shape[0]
    deg = np.zeros(n, np.int64)
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
    start = np.empty(n + 1, np.int64)
    cap = np.empty(n, np.int64)
    total = 0
    for i in range(n):
        start[i] = total
        cap[i] = deg[i] + slack if deg[i] > 0 else 0
        total += cap[i]
    start[n] = total
    adj = np.empty(max(total, 1), np.int64)
    deg[:] = 0
    for e in range(m):
        a = edges[e, 0]
        b = edges[e, 1]
        if a < 0 or b < 0 or a >= n or b >= n or a == b or not valid[a] or not valid[b]:
            continue
        if _row_find(adj, start, deg, a, b) >= 0:
            continue
        adj[start[a] + deg[a]] = b
        deg[a] += 1
        adj[start[b] + deg[b]] = a
        deg[b] += 1
    return adj, start, cap, deg, n_bad


@njit(cache=True)
def _sqdist(nodes, a, b):
    dx = nodes[a, 0] - nodes[b, 0]
    dy = nodes[a, 1] - nodes[b, 1]
    dz = nodes[a, 2] - nodes[b, 2]
    return dx * dx + dy * dy + dz * dz


@njit(cache=True)
def _link(adj, start, cap, deg, a, b):
    """Append the edge a-b if both rows have room; return whether it was added."""
    if deg[a] >= cap[a] or deg[b] >= cap[b]:
        return False
    adj[start[a] + deg[a]] = b
    deg[a] += 1
    adj[start[b] + deg[b]] = a
    deg[b] += 1
    return True


@njit(cache=True)
def add_diagonals(nodes, adj, start, cap, deg):
    """Close every chordless 4-cycle with its shorter diagonal, in place (SPEC §4).

    For each node ``a`` the wedges ``a-b-c`` (``c > a``, ``c`` not adjacent to ``a``) are
    collected per ``c``; two wedges ``a-b-c`` and ``a-d-c`` with ``b``, ``d`` not adjacent form a
    chordless 4-cycle, closed by ``a-c`` or ``b-d``, whichever is shorter (``a-c`` on a tie). The
    pass is greedy: a cycle that already got a chord from an earlier addition is left alone, so
    no quad gets both (crossing) diagonals. A row without free slots skips the diagonal.

    Returns:
        Number of diagonals added.
    """
    n = nodes.shape[0]
    mark = np.full(n, -1, np.int64)
    nmid = np.zeros(n, np.int64)
    mids = np.empty((n, 4), np.int64)
    touched = np.empty(n, np.int64)
    added = 0
    for a in range(n):
        if deg[a] < 2:
            continue
        mark[a] = a
        sa = start[a]
        for k in range(deg[a]):
            mark[adj[sa + k]] = a
        nt = 0
        ka = 0
        while ka < deg[a]:
            b = adj[sa + ka]
            ka += 1
            sb = start[b]
            nb = deg[b]
            for kb in range(nb):
                c = adj[sb + kb]
                if c <= a or mark[c] == a:
                    continue
                cnt = nmid[c]
                if cnt == 0:
                    touched[nt] = c
                    nt += 1
                closed = False
                for q in range(min(cnt, 4)):
                    d = mids[c, q]
                    if d == b or _row_find(adj, start, deg, b, d) >= 0:
                        continue
                    # Chordless 4-cycle a-b-c-d: add the shorter diagonal.
                    if _sqdist(nodes, a, c) <= _sqdist(nodes, b, d):
                        if _link(adj, start, cap, deg, a, c):
                            mark[c] = a
                            added += 1
                            closed = True
                            break
                    elif _link(adj, start, cap, deg, b, d):
                        added += 1
                if closed:
                    continue
                if cnt < 4:
                    mids[c, cnt] = b
                nmid[c] = cnt + 1
        for t in range(nt):
            nmid[touched[t]] = 0
    return added


@njit(cache=True)
def find_facets(nodes, adj, start, deg, origin, orient_away, max_facets, min_quality):
    """All 3-cycles of the graph as oriented facets, Eq. (1).

    Args:
        nodes: (n, 3) float64, metres.
        adj, start, deg: CSR adjacency (see module docstring).
        origin: (3,) float64, sensor position; with ``orient_away`` the facets are oriented away
            from it instead (used with the node centroid for closed shapes).
        orient_away: bool.
        max_facets: capacity; enumeration stops there.
        min_quality: facets with 2 * area / longest_edge**2 below this (slivers, collinear or
            duplicate nodes) are skipped; an equilateral triangle scores 0.866.

    Returns:
        ``(facets, normals, centres, areas, n_facets, truncated)``; arrays have ``max_facets``
        rows, the first ``n_facets`` valid. ``facets`` rows are wound so that the right-hand
        normal is the oriented one.
    """
    n = nodes.shape[0]
    facets = np.empty((max_facets, 3), np.int64)
    normals = np.empty((max_facets, 3), np.float64)
    centres = np.empty((max_facets, 3), np.float64)
    areas = np.empty(max_facets, np.float64)
    mark = np.full(n, -1, np.int64)
    nf = 0
    truncated = False
    for u in range(n):
        su = start[u]
        for k in range(deg[u]):
            mark[adj[su + k]] = u
        for k in range(deg[u]):
            v = adj[su + k]
            if v <= u:
                continue
            sv = start[v]
            for k2 in range(deg[v]):
                w = adj[sv + k2]
                if w <= v or mark[w] != u:
                    continue
                if nf >= max_facets:
                    truncated = True
                    continue
                # Eq. (1): N = (n0 - n1) x (n0 - n2) / |...|.
                e1x = nodes[u, 0] - nodes[v, 0]
                e1y = nodes[u, 1] - nodes[v, 1]
                e1z = nodes[u, 2] - nodes[v, 2]
                e2x = nodes[u, 0] - nodes[w, 0]
                e2y = nodes[u, 1] - nodes[w, 1]
                e2z = nodes[u, 2] - nodes[w, 2]
                cx = e1y * e2z - e1z * e2y
                cy = e1z * e2x - e1x * e2z
                cz = e1x * e2y - e1y * e2x
                c2 = np.sqrt(cx * cx + cy * cy + cz * cz)
                l1 = e1x * e1x + e1y * e1y + e1z * e1z
                l2 = e2x * e2x + e2y * e2y + e2z * e2z
                l3 = _sqdist(nodes, v, w)
                longest = max(l1, max(l2, l3))
                if not (c2 > 1e-14) or c2 < min_quality * longest:
                    continue
                nx = cx / c2
                ny = cy / c2
                nz = cz / c2
                mx = (nodes[u, 0] + nodes[v, 0] + nodes[w, 0]) / 3.0
                my = (nodes[u, 1] + nodes[v, 1] + nodes[w, 1]) / 3.0
                mz = (nodes[u, 2] + nodes[v, 2] + nodes[w, 2]) / 3.0
                side = nx * (origin[0] - mx) + ny * (origin[1] - my) + nz * (origin[2] - mz)
                flip = side > 0.0 if orient_away else side < 0.0
                facets[nf, 0] = u
                if flip:
                    nx, ny, nz = -nx, -ny, -nz
                    facets[nf, 1] = w
                    facets[nf, 2] = v
                else:
                    facets[nf, 1] = v
                    facets[nf, 2] = w
                normals[nf, 0] = nx
                normals[nf, 1] = ny
                normals[nf, 2] = nz
                centres[nf, 0] = mx
                centres[nf, 1] = my
                centres[nf, 2] = mz
                areas[nf] = 0.5 * c2
                nf += 1
    return facets, normals, centres, areas, nf, truncated


@njit(cache=True)
def _facet_edge_slot(adj, start, deg, facets, f, e):
    a = facets[f, e]
    b = facets[f, (e + 1) % 3]
    if a < b:
        return _row_find(adj, start, deg, a, b)
    return _row_find(adj, start, deg, b, a)


@njit(cache=True)
def facet_neighbours(adj, start, deg, facets, normals, nf):
    """Facet-to-facet links across shared edges with their Eq. (2) weights.

    A facet whose three edges each carry two or more other facets is internal (a triangle
    spanned across a closed shape by diagonals, or a tetrahedron face of a volumetric GNG
    artefact) and is dropped. On an edge shared by more than two facets the link goes to the
    most coplanar one, so each facet keeps at most three links (§4.2).

    Returns:
        ``(keep, nbr, wgt)``: (nf,) bool, (nf, 3) int64 neighbour across edge ``e`` (from vertex
        ``e`` to ``e + 1``) or -1, (nf, 3) float64 weight w_ij in radians (inf without link).
    """
    total = start[start.shape[0] - 1]
    ecnt = np.zeros(max(total, 1), np.int64)
    eface = np.empty((max(total, 1), MAX_FACETS_PER_EDGE), np.int64)
    slots = np.empty((nf, 3), np.int64)
    for f in range(nf):
        for e in range(3):
            s = _facet_edge_slot(adj, start, deg, facets, f, e)
            slots[f, e] = s
            c = ecnt[s]
            if c < MAX_FACETS_PER_EDGE:
                eface[s, c] = f
            ecnt[s] = c + 1
    keep = np.empty(nf, np.bool_)
    for f in range(nf):
        keep[f] = not (ecnt[slots[f, 0]] >= 3 and ecnt[slots[f, 1]] >= 3 and ecnt[slots[f, 2]] >= 3)
    nbr = np.full((nf, 3), -1, np.int64)
    wgt = np.full((nf, 3), np.inf)
    for f in range(nf):
        if not keep[f]:
            continue
        for e in range(3):
            s = slots[f, e]
            best = -1
            bestw = np.inf
            for q in range(min(ecnt[s], MAX_FACETS_PER_EDGE)):
                g = eface[s, q]
                if g == f or not keep[g]:
                    continue
                # Eq. (2): w_ij = arccos(N_i . N_j / (|N_i| |N_j|)); the normals are unit.
                c = (
                    normals[f, 0] * normals[g, 0]
                    + normals[f, 1] * normals[g, 1]
                    + normals[f, 2] * normals[g, 2]
                )
                w = np.arccos(min(1.0, max(-1.0, c)))
                if w < bestw:
                    bestw = w
                    best = g
            nbr[f, e] = best
            wgt[f, e] = bestw
    return keep, nbr, wgt


@njit(cache=True)
def _tilt(sx, sy, sz):
    """Eq. (3): angle between a (non-unit) normal and the vertical (0, 0, 1), radians."""
    nn = np.sqrt(sx * sx + sy * sy + sz * sz)
    if nn <= 1e-12:
        return 0.5 * np.pi
    return np.arccos(min(1.0, max(-1.0, sz / nn)))


@njit(cache=True)
def _components(nf, nbr, group, wall_of, labels, stack):
    """Label connected facets of equal (group, wall_of); return the number of labels."""
    for f in range(nf):
        labels[f] = -1
    k = 0
    for s in range(nf):
        if labels[s] >= 0:
            continue
        labels[s] = k
        stack[0] = s
        top = 1
        while top > 0:
            top -= 1
            i = stack[top]
            for e in range(3):
                j = nbr[i, e]
                if j < 0 or labels[j] >= 0:
                    continue
                if group[j] != group[i] or wall_of[j] != wall_of[i]:
                    continue
                labels[j] = k
                stack[top] = j
                top += 1
        k += 1
    return k


@njit(cache=True)
def detect_kernel(
    nodes,
    edges,
    origin,
    orient_away,
    forward_xy,
    ground_z,
    ground_known,
    max_facets,
    min_quality,
    grow_angle,
    region_angle,
    terrain_max_tilt,
    wall_min_tilt,
    wall_min_height,
    ground_tolerance,
    ground_area_share,
    density_threshold,
):
    """Affordance detection on a graph, §4.2: triangulate, Eq. (1)–(2), segment, Eq. (3)–(4).

    Args:
        nodes: (n, 3) float64, metres, world frame, z up.
        edges: (m, 2) int64.
        origin: (3,) float64 sensor position (or the node centroid with ``orient_away``).
        orient_away: bool, orient facets away from ``origin`` instead of towards it.
        forward_xy: (2,) float64 unit walking direction in the ground plane.
        ground_z: float, metres, used when ``ground_known``.
        ground_known: bool, else the ground is estimated from near-horizontal regions.
        max_facets, min_quality: see :func:`find_facets`.
        grow_angle, region_angle, terrain_max_tilt, wall_min_tilt: radians.
        wall_min_height, ground_tolerance: metres.
        ground_area_share: float in (0, 1].
        density_threshold: nodes per m², v of §4.2.

    Returns:
        A tuple ``(n_bad, truncated, ground, facets, normals, flabels, kind, pos, normal,
        height, width, length, gamma, density, size, n_nodes, box)``; facet arrays have F rows,
        label arrays K rows, ``box`` is (K, 2, 3) min/max corners.
    """
    n = nodes.shape[0]
    valid = finite_rows(nodes)
    adj, start, cap, deg, n_bad = build_adjacency(valid, edges, DIAGONAL_SLACK)
    add_diagonals(nodes, adj, start, cap, deg)
    if orient_away:
        origin = np.zeros(3)
        cnt = 0
        for i in range(n):
            if deg[i] > 0:
                origin += nodes[i]
                cnt += 1
        if cnt > 0:
            origin /= cnt
    facets0, normals0, centres0, areas0, nf0, truncated = find_facets(
        nodes, adj, start, deg, origin, orient_away, max_facets, min_quality
    )
    keep, nbr0, wgt0 = facet_neighbours(adj, start, deg, facets0, normals0, nf0)

    # Compact away the internal facets.
    newid = np.full(nf0, -1, np.int64)
    nf = 0
    for f in range(nf0):
        if keep[f]:
            newid[f] = nf
            nf += 1
    facets = np.empty((nf, 3), np.int64)
    normals = np.empty((nf, 3), np.float64)
    centres = np.empty((nf, 3), np.float64)
    areas = np.empty(nf, np.float64)
    nbr = np.empty((nf, 3), np.int64)
    wgt = np.empty((nf, 3), np.float64)
    for f in range(nf0):
        g = newid[f]
        if g < 0:
            continue
        for c in range(3):
            facets[g, c] = facets0[f, c]
            normals[g, c] = normals0[f, c]
            centres[g, c] = centres0[f, c]
            j = nbr0[f, c]
            nbr[g, c] = newid[j] if j >= 0 else -1
            wgt[g, c] = wgt0[f, c]
        areas[g] = areas0[f]

    # Region growing on the Eq. (2) weights: a facet joins its neighbour's region when the link
    # weight is below grow_angle and its normal is within region_angle of the region's running
    # mean normal (the second test stops the drift of a purely local criterion round bends).
    cos_region = np.cos(region_angle)
    region = np.full(nf, -1, np.int64)
    stack = np.empty(max(nf, 1), np.int64)
    rsum = np.zeros((max(nf, 1), 3))
    nreg = 0
    for s in range(nf):
        if region[s] >= 0:
            continue
        region[s] = nreg
        sx = normals[s, 0]
        sy = normals[s, 1]
        sz = normals[s, 2]
        stack[0] = s
        top = 1
        while top > 0:
            top -= 1
            i = stack[top]
            for e in range(3):
                j = nbr[i, e]
                if j < 0 or region[j] >= 0 or wgt[i, e] > grow_angle:
                    continue
                ns = np.sqrt(sx * sx + sy * sy + sz * sz)
                d = normals[j, 0] * sx + normals[j, 1] * sy + normals[j, 2] * sz
                if d < cos_region * ns:
                    continue
                region[j] = nreg
                sx += normals[j, 0]
                sy += normals[j, 1]
                sz += normals[j, 2]
                stack[top] = j
                top += 1
        rsum[nreg, 0] = sx
        rsum[nreg, 1] = sy
        rsum[nreg, 2] = sz
        nreg += 1

    # Per-region area, area-weighted mean height, highest vertex.
    rarea = np.zeros(max(nreg, 1))
    rz = np.zeros(max(nreg, 1))
    rtop = np.full(max(nreg, 1), -np.inf)
    for f in range(nf):
        r = region[f]
        rarea[r] += areas[f]
        rz[r] += areas[f] * centres[f, 2]
        for c in range(3):
            rtop[r] = max(rtop[r], nodes[facets[f, c], 2])
    rtilt = np.empty(max(nreg, 1))
    for r in range(nreg):
        rz[r] /= rarea[r]
        rtilt[r] = _tilt(rsum[r, 0], rsum[r, 1], rsum[r, 2])

    # Ground level: given, or the lowest near-horizontal region among those with at least
    # ground_area_share of the largest one's area (a big box top must not pass for the floor).
    ground = ground_z
    if not ground_known:
        amax = 0.0
        for r in range(nreg):
            if rtilt[r] <= terrain_max_tilt and rarea[r] > amax:
                amax = rarea[r]
        ground = np.inf
        for r in range(nreg):
            if rtilt[r] <= terrain_max_tilt and rarea[r] >= ground_area_share * amax:
                ground = min(ground, rz[r])
        if not np.isfinite(ground):
            ground = np.inf
            for f in range(nf):
                for c in range(3):
                    ground = min(ground, nodes[facets[f, c], 2])
            if not np.isfinite(ground):
                ground = np.nan

    # Region classes.
    rkind = np.empty(max(nreg, 1), np.int64)
    for r in range(nreg):
        if rtilt[r] <= terrain_max_tilt and abs(rz[r] - ground) <= ground_tolerance:
            rkind[r] = KIND_TERRAIN
        elif rtilt[r] >= wall_min_tilt and rtop[r] - ground >= wall_min_height:
            rkind[r] = KIND_WALL
        else:
            rkind[r] = KIND_OBJECT

    # Facet groups; object facets are merged into connected components (top, sides and the
    # bevels a GNG puts round a block make one object). A component whose top stays within the
    # ground tolerance is terrain; one touching a wall is part of that wall (the bevel at the
    # foot of a wall).
    group = np.empty(nf, np.int64)
    wall_of = np.full(nf, -1, np.int64)
    for f in range(nf):
        group[f] = rkind[region[f]]
        if group[f] == KIND_WALL:
            wall_of[f] = region[f]
    comp = np.full(nf, -1, np.int64)
    members = np.empty(max(nf, 1), np.int64)
    for s in range(nf):
        if group[s] != KIND_OBJECT or comp[s] >= 0:
            continue
        comp[s] = s
        members[0] = s
        size = 1
        head = 0
        ctop = -np.inf
        touch_wall = -1
        while head < size:
            i = members[head]
            head += 1
            for c in range(3):
                ctop = max(ctop, nodes[facets[i, c], 2])
            for e in range(3):
                j = nbr[i, e]
                if j < 0:
                    continue
                if group[j] == KIND_WALL:
                    if touch_wall < 0:
                        touch_wall = wall_of[j]
                    continue
                if group[j] != KIND_OBJECT or comp[j] >= 0:
                    continue
                comp[j] = s
                members[size] = j
                size += 1
        if ctop - ground <= ground_tolerance:
            for q in range(size):
                group[members[q]] = KIND_TERRAIN
        elif touch_wall >= 0:
            for q in range(size):
                group[members[q]] = KIND_WALL
                wall_of[members[q]] = touch_wall

    # Final labels: connected facets of one group (one wall region per wall).
    flabels = np.empty(nf, np.int64)
    nlab = _components(nf, nbr, group, wall_of, flabels, stack)

    # Counting sort of facets by label.
    beg = np.zeros(nlab + 1, np.int64)
    for f in range(nf):
        beg[flabels[f] + 1] += 1
    for k in range(nlab):
        beg[k + 1] += beg[k]
    fill = beg[:nlab].copy()
    order = np.empty(max(nf, 1), np.int64)
    for f in range(nf):
        k = flabels[f]
        order[fill[k]] = f
        fill[k] += 1

    kind = np.empty(nlab, np.int64)
    pos = np.zeros((nlab, 3))
    normal = np.zeros((nlab, 3))
    height = np.empty(nlab)
    width = np.empty(nlab)
    length = np.empty(nlab)
    gamma = np.empty(nlab)
    density = np.empty(nlab)
    size_ = np.zeros(nlab)
    n_nodes = np.zeros(nlab, np.int64)
    box = np.empty((nlab, 2, 3))
    stamp = np.full(n, -1, np.int64)
    fx = forward_xy[0]
    fy = forward_xy[1]
    for k in range(nlab):
        kind[k] = group[order[beg[k]]]
        sx = 0.0
        sy = 0.0
        sz = 0.0
        top = -np.inf
        lo = np.full(3, np.inf)
        hi = np.full(3, -np.inf)
        # Projections along (f) and across (l) the walking direction, all nodes / high nodes.
        af0 = np.inf
        af1 = -np.inf
        al0 = np.inf
        al1 = -np.inf
        hf0 = np.inf
        hf1 = -np.inf
        hl0 = np.inf
        hl1 = -np.inf
        nh = 0
        nn = 0
        for idx in range(beg[k], beg[k + 1]):
            f = order[idx]
            # Ob^(v) and Ob^(pos) of §4.2.1: plain means of facet normals and centres.
            sx += normals[f, 0]
            sy += normals[f, 1]
            sz += normals[f, 2]
            for c in range(3):
                pos[k, c] += centres[f, c]
            size_[k] += areas[f]
            for c in range(3):
                v = facets[f, c]
                if stamp[v] == k:
                    continue
                stamp[v] = k
                nn += 1
                x = nodes[v, 0]
                y = nodes[v, 1]
                z = nodes[v, 2]
                top = max(top, z)
                for d in range(3):
                    lo[d] = min(lo[d], nodes[v, d])
                    hi[d] = max(hi[d], nodes[v, d])
                pf = x * fx + y * fy
                pl = y * fx - x * fy
                af0 = min(af0, pf)
                af1 = max(af1, pf)
                al0 = min(al0, pl)
                al1 = max(al1, pl)
                if z > ground + ground_tolerance:
                    nh += 1
                    hf0 = min(hf0, pf)
                    hf1 = max(hf1, pf)
                    hl0 = min(hl0, pl)
                    hl1 = max(hl1, pl)
        count = beg[k + 1] - beg[k]
        for c in range(3):
            pos[k, c] /= count
        ns = np.sqrt(sx * sx + sy * sy + sz * sz)
        if ns > 1e-12:
            normal[k, 0] = sx / ns
            normal[k, 1] = sy / ns
            normal[k, 2] = sz / ns
        gamma[k] = _tilt(sx, sy, sz)
        n_nodes[k] = nn
        # Eq. (4): d = number of nodes in object / object size (facet area, m²).
        density[k] = nn / size_[k]
        height[k] = top - ground
        if kind[k] == KIND_OBJECT and nh > 0:
            length[k] = hf1 - hf0
            width[k] = hl1 - hl0
        else:
            length[k] = af1 - af0
            width[k] = al1 - al0
        for d in range(3):
            box[k, 0, d] = lo[d]
            box[k, 1, d] = hi[d]
    return (
        n_bad,
        truncated,
        ground,
        facets,
        normals,
        flabels,
        kind,
        pos,
        normal,
        height,
        width,
        length,
        gamma,
        density,
        size_,
        n_nodes,
        box,
    )


@njit(cache=True)
def triangulate_kernel(nodes, edges, origin, orient_away, max_facets, min_quality):
    """Facets of a graph without segmentation: ``(facets (F, 3), normals (F, 3), n_bad)``."""
    n = nodes.shape[0]
    valid = finite_rows(nodes)
    adj, start, cap, deg, n_bad = build_adjacency(valid, edges, DIAGONAL_SLACK)
    add_diagonals(nodes, adj, start, cap, deg)
    if orient_away:
        origin = np.zeros(3)
        cnt = 0
        for i in range(n):
            if deg[i] > 0:
                origin += nodes[i]
                cnt += 1
        if cnt > 0:
            origin /= cnt
    facets0, normals0, _, _, nf0, _ = find_facets(
        nodes, adj, start, deg, origin, orient_away, max_facets, min_quality
    )
    keep, _, _ = facet_neighbours(adj, start, deg, facets0, normals0, nf0)
    nf = 0
    for f in range(nf0):
        if keep[f]:
            nf += 1
    facets = np.empty((nf, 3), np.int64)
    normals = np.empty((nf, 3), np.float64)
    g = 0
    for f in range(nf0):
        if keep[f]:
            facets[g] = facets0[f]
            normals[g] = normals0[f]
            g += 1
    return facets, normals, n_bad


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
