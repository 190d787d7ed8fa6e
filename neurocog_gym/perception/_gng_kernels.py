"""Numba kernels of the DD-GNG family: GNG-U2 base, DD-GNG attention, plain GNG, ML-GNG.

Pure ``@njit(cache=True)`` functions over preallocated NumPy arrays (paper §4.1,
Algorithms 1–3, Table 2; SPEC §3). The classes in :mod:`neurocog_gym.perception.gng` own the
arrays and validate inputs; nothing here allocates in the hot path, reads a global that can
change, or draws from NumPy's global random state. One learning cycle (sampling, λ adaptation
steps, κ-periodic utility tests, one insertion) runs inside ONE compiled call.

Inlining: a call to a numba function that takes arrays and that LLVM does not inline costs
~70 ns here (more than one adaptation step), and numba's IR-level ``inline="always"`` was
measured no better. So small scalar helpers are plain ``@njit`` functions that LLVM inlines,
and the per-input path of :func:`learn` is written out by hand; only rare events call out.

Semantics are pinned down exactly so that the slow oracle
(:mod:`neurocog_gym.perception.gng_oracle`) reproduces them from the same random stream:

* Random numbers: SplitMix64 on a 64-bit state stored in ``isc[I_RNG]``; an integer in
  ``[0, n)`` is ``((x >> 32) * n) >> 32``.
* Sampling (Algorithm 1, lines 5–11): sample ``i`` of a cycle comes from the attention boxes
  when boxes are given and ``i % period == 0`` (the paper's ``t mod 2``), otherwise from the
  whole frame. Box samples are drawn uniformly from a reservoir of recent box points
  (:func:`refresh_reservoir`): each cycle drops reservoir points no longer in a box, then adds
  up to ``box_refresh`` box points of the current frame, found without scanning the frame by
  short runs of consecutive rows from random starts, at most ``box_refresh // 8`` points
  per run (:func:`fill_box_pool`); the oldest points
  leave a full reservoir. A reservoir with fewer than ``box_min_points`` points counts as
  empty, and that cycle samples the whole frame only. A whole-frame sample is a random row,
  redrawn up to ``tries`` times until it is finite and within ``coord_limit`` of the origin;
  a sample that never validates is dropped (only frames that are mostly invalid lose samples).
* Nearest two (Algorithm 2, lines 3–4): lexicographic minimum of (squared distance, slot index),
  so ties go to the lower slot. A uniform hashed grid answers it exactly once the net has
  ``grid_min`` nodes; below that, and when the grid search is inconclusive, brute force.
* Errors and utilities decay per input (Algorithm 2, lines 21–22, applied every input as in
  GNG-U2). The kernel stores them lazily as ``E = E_scaled * scale_E`` so that the decay of all
  nodes costs one multiplication; this differs from the oracle only by rounding.

Layout of the packed state (one net; ML-GNG stacks a leading layer axis):

* ``pos``   (M, 3) float64, metres: node positions h_i (free slots hold stale values).
* ``fnode`` (3, M) float64: rows ``R_E`` scaled error, ``R_U`` scaled utility, ``R_D`` strength δ.
* ``inode`` (9, M) int64: degree, alive flag, grid next/prev, grid cell x/y/z, alive list,
  position in the alive list.
* ``adj``   (3, M, D) int64: neighbour slot, edge age g, and the entry's twin (the position of
  this edge in the neighbour's own list, so both copies of an age update in O(1)).
* ``res``   (P, 3) float64, metres: the reservoir of attended points, oldest first.
* ``ibuf``  (B + R,) int64: grid bucket heads (B, a power of two), then room for the R box-row
  indices found in one frame.
* ``fsc``   (NF,) float64 and ``isc`` (NI,) int64: parameters, lazy-decay scales, counters.
"""

from __future__ import annotations

import numpy as np
from numba import njit

# fnode rows
R_E = 0
R_U = 1
R_D = 2
N_FROWS = 3

# inode rows
N_DEG = 0
N_ALIVE = 1
N_NXT = 2
N_PRV = 3
N_CX = 4
N_CY = 5
N_CZ = 6
N_LIST = 7
N_LPOS = 8
N_IROWS = 9

# adj planes
A_NBR = 0
A_AGE = 1
A_TWIN = 2
N_APLANES = 3

# fsc entries
F_ETA1 = 0
F_ETA2 = 1
F_ALPHA = 2
F_BETA = 3
F_CHI = 4
F_K = 5
F_LIMIT = 6
F_CELLFAC = 7
F_SPOW = 8
F_SE = 9
F_SU = 10
F_H = 11
F_EMAX = 12
NF = 13

# isc entries
I_LAM = 0
I_KAPPA = 1
I_GMAX = 2
I_MAXN = 3
I_MAXDEG = 4
I_PERIOD = 5
I_POOLCAP = 6
I_WIN = 7
I_MAXPROBE = 8
I_TRIES = 9
I_GRIDMIN = 10
I_NBUCKET = 11
I_POOLMIN = 12
I_T = 13
I_NALIVE = 14
I_RNG = 15
I_NV = 16
I_NBOX = 17
I_NPOOL = 18
I_NREMOVED = 19
I_NINSERTED = 20
I_NBRUTE = 21
I_EDIRTY = 22
I_ULI = 23
I_NRES = 24
I_SNIFF = 25
NI = 26

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)
# Shrinks pruning gaps by a relative 1e-9 so rounding can never prune a cell holding a tie.
_SAFE = 1.0 - 1e-9
_RING_MAX = 2


# --------------------------------------------------------------------------------------------
# random numbers
# --------------------------------------------------------------------------------------------
# The state lives in a local uint64 inside the sampling loops (scalar helpers inline for
# free; a helper taking the state array would cost a call per draw) and goes back to
# ``isc[I_RNG]`` at the end.
@njit(cache=True)
def _sm64(s):
    # SplitMix64 step: returns (next state, 64 random bits)
    s = s + _GOLDEN
    z = (s ^ (s >> np.uint64(30))) * _MIX1
    z = (z ^ (z >> np.uint64(27))) * _MIX2
    return s, z ^ (z >> np.uint64(31))


@njit(cache=True)
def _below(z, n):
    # an integer in [0, n) from 64 random bits (n < 2**32)
    return np.int64(((z >> np.uint64(32)) * np.uint64(n)) >> np.uint64(32))


# --------------------------------------------------------------------------------------------
# boxes, validity, strength (Algorithm 3)
# --------------------------------------------------------------------------------------------
@njit(cache=True)
def _strength(x, y, z, boxes, nbox):
    # Algorithm 3: δ = 1 + number of suspected-obstacle boxes strictly containing the node.
    d = 1.0
    for b in range(nbox):
        if (
            boxes[b, 0, 0] < x
            and x < boxes[b, 1, 0]
            and boxes[b, 0, 1] < y
            and y < boxes[b, 1, 1]
            and boxes[b, 0, 2] < z
            and z < boxes[b, 1, 2]
        ):
            d += 1.0
    return d


@njit(cache=True)
def _valid(x, y, z, lim):
    # NaN and inf fail ``abs(.) <= lim``, so this one test also drops non-finite rows.
    return abs(x) <= lim and abs(y) <= lim and abs(z) <= lim


@njit(cache=True)
def fill_box_pool(points, boxes, nbox, ibuf, fsc, isc):
    """Collect indices of frame points inside the attention boxes without scanning the frame.

    Each probe starts at a uniformly random row and reads on along consecutive rows
    (wrapping at the end): it gives up after ``S`` rows without a box point, otherwise reads
    up to ``W`` rows and keeps the first ``max(1, box_refresh // 8)`` box points. Probing
    stops once ``box_refresh`` indices were found or ``max_probes`` probes were made.
    Sequential rows are cheap, so short runs find box points of randomly ordered clouds
    several times cheaper than single random rows; in sensor-ordered frames box points come
    in runs along image rows, so a hit yields several points, and the per-probe cap keeps
    them from at least eight places. (Slight bias: in a sensor-ordered frame the first few
    points of each run are found less often than the rest.)

    Args:
        points: (N, 3) float32/float64, metres, the frame.
        boxes: (K, 2, 3) float64, metres, min/max corners of the attention boxes.
        nbox: number of boxes to use (0 disables).
        ibuf: (B + R,) int64 buffer; the indices are written to ``ibuf[B:B + R]``.
        fsc: (NF,) float64 scalars (uses the coordinate limit).
        isc: (NI,) int64 scalars (uses and advances the random state).

    Returns:
        Number of indices written.
    """
    n = points.shape[0]
    cap = isc[I_POOLCAP]
    if nbox == 0 or n == 0 or cap == 0:
        return 0
    lim = fsc[F_LIMIT]
    base = isc[I_NBUCKET]
    win = min(isc[I_WIN], n)
    sniff = isc[I_SNIFF]
    per_probe = max(1, cap // 8)
    # the one-box case (the usual one) with its bounds in registers
    l0 = boxes[0, 0, 0]
    l1 = boxes[0, 0, 1]
    l2 = boxes[0, 0, 2]
    h0 = boxes[0, 1, 0]
    h1 = boxes[0, 1, 1]
    h2 = boxes[0, 1, 2]
    npool = 0
    rs = np.uint64(isc[I_RNG])
    for _p in range(isc[I_MAXPROBE]):
        rs, z = _sm64(rs)
        j = _below(z, n)
        got = 0
        for o in range(win):
            if o == sniff and got == 0:
                break
            x = points[j, 0]
            y = points[j, 1]
            z = points[j, 2]
            # branch-free box test (most rows miss); NaN fails every comparison
            inside = (l0 < x) & (x < h0) & (l1 < y) & (y < h1) & (l2 < z) & (z < h2)
            for b in range(1, nbox):
                inside |= (
                    (boxes[b, 0, 0] < x)
                    & (x < boxes[b, 1, 0])
                    & (boxes[b, 0, 1] < y)
                    & (y < boxes[b, 1, 1])
                    & (boxes[b, 0, 2] < z)
                    & (z < boxes[b, 1, 2])
                )
            if inside and _valid(x, y, z, lim):
                ibuf[base + npool] = j
                npool += 1
                got += 1
                if got == per_probe or npool == cap:
                    break
            j += 1
            if j == n:
                j = 0
        if npool == cap:
            break
    isc[I_RNG] = np.int64(rs)
    return npool


@njit(cache=True)
def refresh_reservoir(points, boxes, nbox, res, ibuf, fsc, isc):
    """Update the reservoir of attended points the box inputs are drawn from.

    The reservoir holds the most recent box points, oldest first: points no longer inside a
    box are dropped, up to ``box_refresh`` fresh box points of this frame are appended
    (:func:`fill_box_pool`), and the oldest go when it overflows. So the attended inputs of
    a cycle come from the current frame and the few before it, ``res.shape[0]`` distinct
    points, while only ``box_refresh`` new ones must be found per frame.

    Args:
        points: (N, 3) float32/float64, metres, the frame.
        boxes: (K, 2, 3) float64, metres, attention boxes.
        nbox: number of boxes (0 empties the reservoir).
        res: (P, 3) float64, metres, the reservoir.
        ibuf: (B + R,) int64 work buffer.
        fsc: (NF,) float64 scalars.
        isc: (NI,) int64 scalars; ``isc[I_NRES]`` is the reservoir fill.

    Returns:
        Reservoir fill after the update.
    """
    c = isc[I_NRES]
    if nbox == 0:
        c = 0
    w = 0
    for q in range(c):
        x = res[q, 0]
        y = res[q, 1]
        z = res[q, 2]
        inside = False
        for b in range(nbox):
            inside |= (
                (boxes[b, 0, 0] < x)
                & (x < boxes[b, 1, 0])
                & (boxes[b, 0, 1] < y)
                & (y < boxes[b, 1, 1])
                & (boxes[b, 0, 2] < z)
                & (z < boxes[b, 1, 2])
            )
        if inside:
            res[w, 0] = x
            res[w, 1] = y
            res[w, 2] = z
            w += 1
    c = w
    nf = fill_box_pool(points, boxes, nbox, ibuf, fsc, isc)
    isc[I_NPOOL] = nf
    cap = res.shape[0]
    base = isc[I_NBUCKET]
    skip = 0
    if nf > cap:
        skip = nf - cap
    drop = c + nf - skip - cap
    if drop > 0:
        for q in range(drop, c):
            res[q - drop, 0] = res[q, 0]
            res[q - drop, 1] = res[q, 1]
            res[q - drop, 2] = res[q, 2]
        c -= drop
    for q in range(skip, nf):
        j = ibuf[base + q]
        res[c, 0] = points[j, 0]
        res[c, 1] = points[j, 1]
        res[c, 2] = points[j, 2]
        c += 1
    isc[I_NRES] = c
    return c


@njit(cache=True)
def draw_samples(points, boxes, nbox, V, res, ibuf, fsc, isc):
    """Draw one cycle's input signals V (Algorithm 1, lines 5–11).

    Args:
        points: (N, 3) float32/float64, metres, the frame.
        boxes: (K, 2, 3) float64, metres, attention boxes (min/max corners).
        nbox: number of boxes to use (0 = no attention).
        V: (λ, 3) float64 output, metres.
        res: (P, 3) float64, metres, reservoir of attended points (see
            :func:`refresh_reservoir`).
        ibuf: (B + R,) int64 work buffer.
        fsc: (NF,) float64 scalars.
        isc: (NI,) int64 scalars; the random state advances.

    Returns:
        Number of valid samples written to ``V`` (≤ λ).
    """
    n = points.shape[0]
    lam = isc[I_LAM]
    if n == 0:
        return 0
    lim = fsc[F_LIMIT]
    period = isc[I_PERIOD]
    tries = isc[I_TRIES]
    nres = refresh_reservoir(points, boxes, nbox, res, ibuf, fsc, isc)
    if nres < isc[I_POOLMIN]:
        # (nearly) empty boxes: the whole cycle samples the whole frame
        nres = 0
    nv = 0
    nb = 0
    rs = np.uint64(isc[I_RNG])
    for i in range(lam):
        if nres > 0 and i % period == 0:
            # Algorithm 1, line 8: a random point of P inside the suspected obstacle
            rs, z = _sm64(rs)
            q = _below(z, nres)
            V[nv, 0] = res[q, 0]
            V[nv, 1] = res[q, 1]
            V[nv, 2] = res[q, 2]
            nv += 1
            nb += 1
        else:
            # Algorithm 1, line 10: a random point of P; invalid rows are redrawn
            for _tr in range(tries):
                rs, z = _sm64(rs)
                j = _below(z, n)
                x = points[j, 0]
                y = points[j, 1]
                z = points[j, 2]
                if _valid(x, y, z, lim):
                    V[nv, 0] = x
                    V[nv, 1] = y
                    V[nv, 2] = z
                    nv += 1
                    break
    isc[I_NBOX] = nb
    isc[I_RNG] = np.int64(rs)
    return nv


# --------------------------------------------------------------------------------------------
# uniform hashed grid for the nearest-two search
# --------------------------------------------------------------------------------------------
# Cells are offset by half a cell so that axis-aligned planes at round coordinates (the floor
# at z = 0) run through cell middles instead of along cell faces.
@njit(cache=True)
def _hash(cx, cy, cz, mask):
    return ((cx * 73856093) ^ (cy * 19349663) ^ (cz * 83492791)) & mask


@njit(cache=True)
def _grid_link(i, pos, inode, ibuf, inv_h, mask):
    cx = np.int64(np.floor(pos[i, 0] * inv_h + 0.5))
    cy = np.int64(np.floor(pos[i, 1] * inv_h + 0.5))
    cz = np.int64(np.floor(pos[i, 2] * inv_h + 0.5))
    inode[N_CX, i] = cx
    inode[N_CY, i] = cy
    inode[N_CZ, i] = cz
    b = _hash(cx, cy, cz, mask)
    h0 = ibuf[b]
    inode[N_NXT, i] = h0
    inode[N_PRV, i] = -1
    if h0 >= 0:
        inode[N_PRV, h0] = i
    ibuf[b] = i


@njit(cache=True)
def _grid_unlink(i, inode, ibuf, mask):
    p = inode[N_PRV, i]
    q = inode[N_NXT, i]
    if p >= 0:
        inode[N_NXT, p] = q
    else:
        ibuf[_hash(inode[N_CX, i], inode[N_CY, i], inode[N_CZ, i], mask)] = q
    if q >= 0:
        inode[N_PRV, q] = p


@njit(cache=True)
def grid_rebuild(pos, inode, adj, ibuf, fsc, isc, force):
    """Choose the grid cell size from the current edge lengths; rebuild the grid if it changed.

    Cell size h = ``cell_factor`` × RMS length of each live node's first edge (≥ 1 µm; 1 m
    before any edge exists). The grid is kept (it is maintained incrementally) unless h moved
    by more than 25 % or ``force`` is set.

    Args:
        pos: (M, 3) float64, metres, node positions.
        inode: (9, M) int64 node integers.
        adj: (3, M, D) int64 neighbour lists.
        ibuf: (B + R,) int64; bucket heads are rewritten.
        fsc: (NF,) float64 scalars; ``fsc[F_H]`` receives h.
        isc: (NI,) int64 scalars.
        force: rebuild even if h barely changed.
    """
    n = isc[I_NALIVE]
    acc = 0.0
    cnt = 0
    for q in range(n):
        i = inode[N_LIST, q]
        if inode[N_DEG, i] > 0:
            j = adj[A_NBR, i, 0]
            dx = pos[i, 0] - pos[j, 0]
            dy = pos[i, 1] - pos[j, 1]
            dz = pos[i, 2] - pos[j, 2]
            acc += dx * dx + dy * dy + dz * dz
            cnt += 1
    h = 1.0
    if cnt > 0:
        h = fsc[F_CELLFAC] * np.sqrt(acc / cnt)
    if not h >= 1e-6:
        h = 1e-6
    old = fsc[F_H]
    if not force and 0.8 * old < h and h < 1.25 * old:
        return
    fsc[F_H] = h
    inv_h = 1.0 / h
    nb = isc[I_NBUCKET]
    mask = nb - 1
    for b in range(nb):
        ibuf[b] = -1
    for q in range(n):
        i = inode[N_LIST, q]
        cx = np.int64(np.floor(pos[i, 0] * inv_h + 0.5))
        cy = np.int64(np.floor(pos[i, 1] * inv_h + 0.5))
        cz = np.int64(np.floor(pos[i, 2] * inv_h + 0.5))
        inode[N_CX, i] = cx
        inode[N_CY, i] = cy
        inode[N_CZ, i] = cz
        b = _hash(cx, cy, cz, mask)
        h0 = ibuf[b]
        inode[N_NXT, i] = h0
        inode[N_PRV, i] = -1
        if h0 >= 0:
            inode[N_PRV, h0] = i
        ibuf[b] = i


@njit(cache=True)
def _gap2(d, f, hh):
    # squared distance from a point at fraction f of its cell to the cell d steps away
    if d == 0:
        return 0.0
    if d < 0:
        g = f - d - 1.0
    else:
        g = d - f
    return g * g * hh


@njit(cache=True)
def _consider(i, d, b1, d1, b2, d2):
    # lexicographic (squared distance, slot) top two; a node seen twice (two visited cells
    # sharing a hash bucket) cannot take both places
    if d < d1 or (d == d1 and i < b1):
        if i == b1:
            return b1, d1, b2, d2
        return i, d, b1, d1
    if i != b1 and (d < d2 or (d == d2 and i < b2)):
        return b1, d1, i, d
    return b1, d1, b2, d2


@njit(cache=True)
def _nearest2_brute(vx, vy, vz, pos, inode, n):
    b1 = -1
    b2 = -1
    d1 = np.inf
    d2 = np.inf
    for q in range(n):
        i = inode[N_LIST, q]
        dx = vx - pos[i, 0]
        dy = vy - pos[i, 1]
        dz = vz - pos[i, 2]
        d = dx * dx + dy * dy + dz * dz
        b1, d1, b2, d2 = _consider(i, d, b1, d1, b2, d2)
    return b1, d1, b2, d2


# --------------------------------------------------------------------------------------------
# graph bookkeeping: neighbour lists with ages and twins, alive list, slots
# --------------------------------------------------------------------------------------------
@njit(cache=True)
def _find(adj, i, j, deg):
    for k in range(deg):
        if adj[A_NBR, i, k] == j:
            return k
    return -1


@njit(cache=True)
def _drop_entry(adj, inode, i, k):
    # swap-remove entry k of i's list; the moved entry's twin learns its new position
    last = inode[N_DEG, i] - 1
    if k != last:
        j = adj[A_NBR, i, last]
        t = adj[A_TWIN, i, last]
        adj[A_NBR, i, k] = j
        adj[A_AGE, i, k] = adj[A_AGE, i, last]
        adj[A_TWIN, i, k] = t
        adj[A_TWIN, j, t] = k
    inode[N_DEG, i] = last


@njit(cache=True)
def _remove_edge_at(adj, inode, i, k):
    # remove the edge held in entry k of i's list, from both lists
    j = adj[A_NBR, i, k]
    kj = adj[A_TWIN, i, k]
    _drop_entry(adj, inode, i, k)
    _drop_entry(adj, inode, j, kj)
    return j


@njit(cache=True)
def _add_edge(adj, inode, i, j):
    ki = inode[N_DEG, i]
    kj = inode[N_DEG, j]
    adj[A_NBR, i, ki] = j
    adj[A_AGE, i, ki] = 0
    adj[A_TWIN, i, ki] = kj
    adj[A_NBR, j, kj] = i
    adj[A_AGE, j, kj] = 0
    adj[A_TWIN, j, kj] = ki
    inode[N_DEG, i] = ki + 1
    inode[N_DEG, j] = kj + 1


@njit(cache=True)
def _kill_node(i, fnode, inode, adj, ibuf, fsc, isc):
    # Remove node i and all its edges (neighbours may be left isolated: caller handles them).
    while inode[N_DEG, i] > 0:
        _remove_edge_at(adj, inode, i, inode[N_DEG, i] - 1)
    inode[N_ALIVE, i] = 0
    n = isc[I_NALIVE] - 1
    p = inode[N_LPOS, i]
    last = inode[N_LIST, n]
    inode[N_LIST, p] = last
    inode[N_LPOS, last] = p
    isc[I_NALIVE] = n
    _grid_unlink(i, inode, ibuf, isc[I_NBUCKET] - 1)
    isc[I_NREMOVED] += 1
    if fnode[R_E, i] >= fsc[F_EMAX]:
        isc[I_EDIRTY] = 1
    if isc[I_ULI] == i:
        isc[I_ULI] = -1


@njit(cache=True)
def _new_node(x, y, z, e, u, boxes, nbox, pos, fnode, inode, ibuf, fsc, isc):
    # Lowest free slot (deterministic, mirrored by the oracle). Returns -1 when full.
    m = inode.shape[1]
    r = -1
    for i in range(min(m, isc[I_MAXN])):
        if inode[N_ALIVE, i] == 0:
            r = i
            break
    if r < 0:
        return -1
    pos[r, 0] = x
    pos[r, 1] = y
    pos[r, 2] = z
    fnode[R_E, r] = e
    fnode[R_U, r] = u
    fnode[R_D, r] = _strength(x, y, z, boxes, nbox)
    inode[N_DEG, r] = 0
    inode[N_ALIVE, r] = 1
    n = isc[I_NALIVE]
    inode[N_LIST, n] = r
    inode[N_LPOS, r] = n
    isc[I_NALIVE] = n + 1
    _grid_link(r, pos, inode, ibuf, 1.0 / fsc[F_H], isc[I_NBUCKET] - 1)
    if e > fsc[F_EMAX]:
        fsc[F_EMAX] = e
    li = isc[I_ULI]
    if li >= 0 and (u < fnode[R_U, li] or (u == fnode[R_U, li] and r < li)):
        isc[I_ULI] = r
    return r


@njit(cache=True)
def _connect(s1, s2, fnode, inode, adj, ibuf, fsc, isc):
    # Algorithm 2, lines 5–7: create edge s1–s2 or reset its age. A full neighbour list
    # (max degree D, a bound the paper's dense matrix does not have) first drops its oldest
    # edge (ties: lower neighbour slot); a node left isolated by that is removed.
    k = _find(adj, s1, s2, inode[N_DEG, s1])
    if k >= 0:
        adj[A_AGE, s1, k] = 0
        adj[A_AGE, s2, adj[A_TWIN, s1, k]] = 0
        return
    dmax = adj.shape[2]
    for a in (s1, s2):
        if inode[N_DEG, a] >= dmax:
            bk = 0
            for kk in range(1, dmax):
                ak = adj[A_AGE, a, kk]
                ab = adj[A_AGE, a, bk]
                if ak > ab or (ak == ab and adj[A_NBR, a, kk] < adj[A_NBR, a, bk]):
                    bk = kk
            j = _remove_edge_at(adj, inode, a, bk)
            if inode[N_DEG, j] == 0:
                _kill_node(j, fnode, inode, adj, ibuf, fsc, isc)
    _add_edge(adj, inode, s1, s2)


@njit(cache=True)
def refresh_strength(boxes, nbox, fnode, pos, inode, isc):
    """Recompute δ of every live node for the current boxes (Algorithm 3).

    Args:
        boxes: (K, 2, 3) float64, metres, attention boxes.
        nbox: number of boxes to use.
        fnode: (3, M) float64; row ``R_D`` is rewritten.
        pos: (M, 3) float64, metres.
        inode: (9, M) int64.
        isc: (NI,) int64.
    """
    for q in range(isc[I_NALIVE]):
        i = inode[N_LIST, q]
        x = pos[i, 0]
        y = pos[i, 1]
        z = pos[i, 2]
        st = 1.0
        for b in range(nbox):
            st += (
                (boxes[b, 0, 0] < x)
                & (x < boxes[b, 1, 0])
                & (boxes[b, 0, 1] < y)
                & (y < boxes[b, 1, 1])
                & (boxes[b, 0, 2] < z)
                & (z < boxes[b, 1, 2])
            )
        fnode[R_D, i] = st


@njit(cache=True)
def _emax_scan(fnode, inode, fsc, isc):
    e = -np.inf
    for q in range(isc[I_NALIVE]):
        v = fnode[R_E, inode[N_LIST, q]]
        if v > e:
            e = v
    fsc[F_EMAX] = e
    isc[I_EDIRTY] = 0


@njit(cache=True)
def _umin_scan(fnode, inode, isc):
    lu = np.inf
    li = -1
    for q in range(isc[I_NALIVE]):
        i = inode[N_LIST, q]
        u = fnode[R_U, i]
        if u < lu or (u == lu and i < li):
            lu = u
            li = i
    isc[I_ULI] = li


# --------------------------------------------------------------------------------------------
# the learning cycle (Algorithm 2)
# --------------------------------------------------------------------------------------------
@njit(cache=True)
def _grid_relink(i, pos, inode, ibuf, fsc, isc):
    # node i left its grid cell (rare): move it to the new cell's bucket list
    mask = isc[I_NBUCKET] - 1
    _grid_unlink(i, inode, ibuf, mask)
    _grid_link(i, pos, inode, ibuf, 1.0 / fsc[F_H], mask)


@njit(cache=True)
def _age_out(s1, k, fnode, inode, adj, ibuf, fsc, isc):
    # Algorithm 2, lines 14–15: drop the aged-out edge in entry k of s1's list; a neighbour
    # left without edges is removed (GNG)
    j = _remove_edge_at(adj, inode, s1, k)
    if inode[N_DEG, j] == 0:
        _kill_node(j, fnode, inode, adj, ibuf, fsc, isc)


@njit(cache=True)
def _utility_test(fnode, inode, adj, ibuf, fsc, isc, se, su):
    # Algorithm 2, lines 16–20. u = max-error node, l = min-utility node; remove l when
    # E_u / U_l > k·δ_l. The paper prints δ_u; SPEC §3 reads the intent as protecting the
    # removal candidate, so δ_l. Multiplied out so a zero utility needs no division. The
    # net never drops below two nodes (l's neighbours left without edges go with it).
    if isc[I_EDIRTY] != 0:
        _emax_scan(fnode, inode, fsc, isc)
    if isc[I_ULI] < 0:
        _umin_scan(fnode, inode, isc)
    li = isc[I_ULI]
    if not fsc[F_EMAX] * se > fsc[F_K] * fnode[R_D, li] * fnode[R_U, li] * su:
        return
    c = 0
    for k in range(inode[N_DEG, li]):
        if inode[N_DEG, adj[A_NBR, li, k]] == 1:
            c += 1
    if isc[I_NALIVE] - 1 - c < 2:
        return
    while inode[N_DEG, li] > 0:
        j = _remove_edge_at(adj, inode, li, inode[N_DEG, li] - 1)
        if inode[N_DEG, j] == 0:
            _kill_node(j, fnode, inode, adj, ibuf, fsc, isc)
    _kill_node(li, fnode, inode, adj, ibuf, fsc, isc)


@njit(cache=True)
def learn(V, nv, boxes, nbox, pos, fnode, inode, adj, ibuf, fsc, isc):
    """Adapt the net to the ``nv`` input signals in ``V`` (Algorithm 2, lines 1–22).

    The per-input path is written out in this one function on purpose: a call to a helper
    that takes arrays and is not inlined by LLVM costs ~70 ns here, more than the work
    itself, so only rare events (a new edge, an aged-out edge, a removal) call out.

    Args:
        V: (λ, 3) float64, metres, input signals of this cycle.
        nv: number of valid rows in ``V``.
        boxes: (K, 2, 3) float64, metres, attention boxes.
        nbox: number of boxes (0: every δ is 1, plain GNG-U2).
        pos: (M, 3) float64, metres, node positions.
        fnode: (3, M) float64 scaled error, scaled utility, strength δ.
        inode: (9, M) int64 node integers.
        adj: (3, M, D) int64 neighbour slots, edge ages, twins.
        ibuf: (B + R,) int64 grid buckets and box-row indices.
        fsc: (NF,) float64 scalars.
        isc: (NI,) int64 scalars.
    """
    eta1 = fsc[F_ETA1]
    eta2 = fsc[F_ETA2]
    dec_e = 1.0 - fsc[F_BETA]
    dec_u = 1.0 - fsc[F_CHI]
    se = fsc[F_SE]
    su = fsc[F_SU]
    # inverse scales, kept by multiplication (no division per input); they drift from
    # 1/se, 1/su by rounding only, far below the oracle test's tolerance
    ise = 1.0 / se
    isu = 1.0 / su
    grow_e = 1.0 / dec_e
    grow_u = 1.0 / dec_u
    h = fsc[F_H]
    inv_h = 1.0 / h
    hh = h * h * _SAFE
    mask = isc[I_NBUCKET] - 1
    gmax = isc[I_GMAX]
    kappa = isc[I_KAPPA]
    # inputs left until the next utility test (t % κ == 0) without a division per input
    k_left = kappa - isc[I_T] % kappa
    gmin = isc[I_GRIDMIN]
    t = isc[I_T]
    ee = fnode[R_E]
    uu = fnode[R_U]
    dl = fnode[R_D]
    nbr = adj[A_NBR]
    age = adj[A_AGE]
    twin = adj[A_TWIN]
    deg = inode[N_DEG]
    nxt = inode[N_NXT]
    ccx = inode[N_CX]
    ccy = inode[N_CY]
    ccz = inode[N_CZ]
    for si in range(nv):
        vx = V[si, 0]
        vy = V[si, 1]
        vz = V[si, 2]
        t += 1
        k_left -= 1
        test_now = k_left == 0
        if test_now:
            k_left = kappa
        n = isc[I_NALIVE]
        if n < 2:
            continue  # cannot happen with g_max >= 1; kept so no input can break the net
        # ---- Algorithm 2, lines 3–4: winner s1, second s2 (squared distances d1 <= d2).
        # Exact search on the hashed grid: first the 2×2×2 cells nearest the input (their
        # union reaches at least h/2 around it), then, if the second best could still lie
        # outside, rings of cells at Chebyshev distance 1.._RING_MAX. Cells farther than
        # the current second best are skipped; nodes of other cells sharing a bucket are
        # harmless extra candidates. Brute force below grid_min nodes or if inconclusive.
        s1 = -1
        s2 = -1
        d1 = np.inf
        d2 = np.inf
        found = False
        if n >= gmin:
            fx = vx * inv_h + 0.5
            fy = vy * inv_h + 0.5
            fz = vz * inv_h + 0.5
            ffx = np.floor(fx)
            ffy = np.floor(fy)
            ffz = np.floor(fz)
            cx = np.int64(ffx)
            cy = np.int64(ffy)
            cz = np.int64(ffz)
            fx -= ffx
            fy -= ffy
            fz -= ffz
            ox = -1 if fx < 0.5 else 1
            oy = -1 if fy < 0.5 else 1
            oz = -1 if fz < 0.5 else 1
            for ax in range(2):
                dx = ax * ox
                gx2 = _gap2(dx, fx, hh)
                for ay in range(2):
                    dy = ay * oy
                    gxy2 = gx2 + _gap2(dy, fy, hh)
                    if gxy2 > d2:
                        continue
                    for az in range(2):
                        dz = az * oz
                        if gxy2 + _gap2(dz, fz, hh) > d2:
                            continue
                        i = ibuf[_hash(cx + dx, cy + dy, cz + dz, mask)]
                        while i >= 0:
                            ex = vx - pos[i, 0]
                            ey = vy - pos[i, 1]
                            ez = vz - pos[i, 2]
                            d = ex * ex + ey * ey + ez * ez
                            if d <= d2:
                                s1, d1, s2, d2 = _consider(i, d, s1, d1, s2, d2)
                            i = nxt[i]
            m = 1.0 - max(min(fx, 1.0 - fx), min(fy, 1.0 - fy), min(fz, 1.0 - fz))
            if s2 >= 0 and d2 < m * m * hh:
                found = True
            else:
                mfrac = min(fx, 1.0 - fx, fy, 1.0 - fy, fz, 1.0 - fz)
                for r in range(1, _RING_MAX + 1):
                    for dx in range(-r, r + 1):
                        gx2 = _gap2(dx, fx, hh)
                        if gx2 > d2:
                            continue
                        adx = abs(dx)
                        inx = dx == 0 or dx == ox
                        for dy in range(-r, r + 1):
                            gxy2 = gx2 + _gap2(dy, fy, hh)
                            if gxy2 > d2:
                                continue
                            inxy = inx and (dy == 0 or dy == oy)
                            step = 1
                            if adx != r and abs(dy) != r:
                                step = 2 * r
                            for dz in range(-r, r + 1, step):
                                if inxy and (dz == 0 or dz == oz):
                                    continue  # a cell of the first block
                                if gxy2 + _gap2(dz, fz, hh) > d2:
                                    continue
                                i = ibuf[_hash(cx + dx, cy + dy, cz + dz, mask)]
                                while i >= 0:
                                    ex = vx - pos[i, 0]
                                    ey = vy - pos[i, 1]
                                    ez = vz - pos[i, 2]
                                    d = ex * ex + ey * ey + ez * ez
                                    if d <= d2:
                                        s1, d1, s2, d2 = _consider(i, d, s1, d1, s2, d2)
                                    i = nxt[i]
                    m = mfrac + r
                    if s2 >= 0 and d2 < m * m * hh:
                        found = True
                        break
        if not found:
            s1, d1, s2, d2 = _nearest2_brute(vx, vy, vz, pos, inode, n)
            isc[I_NBRUTE] += 1
        # ---- lines 5–7: reset the age of edge s1–s2, or create it (rarer: out of line)
        k12 = -1
        for k in range(deg[s1]):
            if nbr[s1, k] == s2:
                k12 = k
                break
        if k12 >= 0:
            age[s1, k12] = 0
            age[s2, twin[s1, k12]] = 0
        else:
            _connect(s1, s2, fnode, inode, adj, ibuf, fsc, isc)
        # ---- lines 8–9 (squared distances, SPEC §3 / Fritzke; the paper prints the norm).
        # Only s1 changes, so the max error and the min-utility node are kept incrementally.
        e1 = ee[s1] + d1 * ise
        ee[s1] = e1
        if e1 > fsc[F_EMAX]:
            fsc[F_EMAX] = e1
        uu[s1] += (d2 - d1) * isu
        if s1 == isc[I_ULI]:
            isc[I_ULI] = -1
        # ---- line 10 (+ grid cell and Algorithm 3 strength of the moved node)
        px = pos[s1, 0] + eta1 * (vx - pos[s1, 0])
        py = pos[s1, 1] + eta1 * (vy - pos[s1, 1])
        pz = pos[s1, 2] + eta1 * (vz - pos[s1, 2])
        pos[s1, 0] = px
        pos[s1, 1] = py
        pos[s1, 2] = pz
        if (
            np.int64(np.floor(px * inv_h + 0.5)) != ccx[s1]
            or np.int64(np.floor(py * inv_h + 0.5)) != ccy[s1]
            or np.int64(np.floor(pz * inv_h + 0.5)) != ccz[s1]
        ):
            _grid_relink(s1, pos, inode, ibuf, fsc, isc)
        if nbox > 0:
            st = 1.0
            for b in range(nbox):
                st += (
                    (boxes[b, 0, 0] < px)
                    & (px < boxes[b, 1, 0])
                    & (boxes[b, 0, 1] < py)
                    & (py < boxes[b, 1, 1])
                    & (boxes[b, 0, 2] < pz)
                    & (pz < boxes[b, 1, 2])
                )
            dl[s1] = st
        # ---- lines 11–15: neighbours move by η2, edges age, an edge older than g_max goes
        # (the paper prints "<"; read ">"), and a neighbour left without edges goes too.
        for k in range(deg[s1] - 1, -1, -1):
            j = nbr[s1, k]
            px = pos[j, 0] + eta2 * (vx - pos[j, 0])
            py = pos[j, 1] + eta2 * (vy - pos[j, 1])
            pz = pos[j, 2] + eta2 * (vz - pos[j, 2])
            pos[j, 0] = px
            pos[j, 1] = py
            pos[j, 2] = pz
            if (
                np.int64(np.floor(px * inv_h + 0.5)) != ccx[j]
                or np.int64(np.floor(py * inv_h + 0.5)) != ccy[j]
                or np.int64(np.floor(pz * inv_h + 0.5)) != ccz[j]
            ):
                _grid_relink(j, pos, inode, ibuf, fsc, isc)
            if nbox > 0:
                st = 1.0
                for b in range(nbox):
                    st += (
                        (boxes[b, 0, 0] < px)
                        & (px < boxes[b, 1, 0])
                        & (boxes[b, 0, 1] < py)
                        & (py < boxes[b, 1, 1])
                        & (boxes[b, 0, 2] < pz)
                        & (pz < boxes[b, 1, 2])
                    )
                dl[j] = st
            a = age[s1, k] + 1
            if a > gmax:
                _age_out(s1, k, fnode, inode, adj, ibuf, fsc, isc)
            else:
                age[s1, k] = a
                age[j, twin[s1, k]] = a
        # ---- lines 16–20: the utility test every κ inputs (out of line: 1 in κ inputs)
        if test_now and isc[I_NALIVE] > 2:
            _utility_test(fnode, inode, adj, ibuf, fsc, isc, se, su)
        # ---- lines 21–22: every error and utility decays, lazily through the scales
        se *= dec_e
        su *= dec_u
        ise *= grow_e
        isu *= grow_u
    isc[I_T] = t
    fsc[F_SE] = se
    fsc[F_SU] = su


@njit(cache=True)
def _weight(e, d, p):
    # insertion priority E·δ^p; the common p = 1 skips pow()
    if p == 1.0:
        return e * d
    return e * d**p


@njit(cache=True)
def insert_node(boxes, nbox, pos, fnode, inode, adj, ibuf, fsc, isc):
    """Insert one node between the max-error node and its max-error neighbour.

    Algorithm 2, lines 23–30, with the DD-GNG strength weighting: u = argmax E·δ^p and
    f = argmax over u's neighbours of E·δ^p (p = ``strength_power``), so strong (attended)
    nodes win insertions. E_u, E_f decay by α; E_r = (E_u + E_f)/2 (paper, line 28);
    U_r = (U_u + U_f)/2 (Fritzke's GNG-U; the paper leaves U_r open); δ_r by Algorithm 3.

    Args:
        boxes: (K, 2, 3) float64, metres, attention boxes.
        nbox: number of boxes.
        pos: (M, 3) float64, metres.
        fnode: (3, M) float64.
        inode: (9, M) int64.
        adj: (3, M, D) int64.
        ibuf: (B + R,) int64.
        fsc: (NF,) float64.
        isc: (NI,) int64.

    Returns:
        Slot of the new node, or -1 if none was inserted (net full or degenerate).
    """
    n = isc[I_NALIVE]
    if n < 2 or n >= isc[I_MAXN]:
        return -1
    ee = fnode[R_E]
    uu = fnode[R_U]
    dl = fnode[R_D]
    p = fsc[F_SPOW]
    bu = -1
    best = -np.inf
    for q in range(n):
        i = inode[N_LIST, q]
        w = _weight(ee[i], dl[i], p)
        if w > best or (w == best and i < bu):
            best = w
            bu = i
    if inode[N_DEG, bu] == 0:
        return -1
    bf = -1
    best = -np.inf
    for k in range(inode[N_DEG, bu]):
        i = adj[A_NBR, bu, k]
        w = _weight(ee[i], dl[i], p)
        if w > best or (w == best and i < bf):
            best = w
            bf = i
    x = 0.5 * (pos[bu, 0] + pos[bf, 0])
    y = 0.5 * (pos[bu, 1] + pos[bf, 1])
    z = 0.5 * (pos[bu, 2] + pos[bf, 2])
    a = 1.0 - fsc[F_ALPHA]
    ee[bu] *= a
    ee[bf] *= a
    isc[I_EDIRTY] = 1
    r = _new_node(
        x,
        y,
        z,
        0.5 * (ee[bu] + ee[bf]),
        0.5 * (uu[bu] + uu[bf]),
        boxes,
        nbox,
        pos,
        fnode,
        inode,
        ibuf,
        fsc,
        isc,
    )
    _remove_edge_at(adj, inode, bu, _find(adj, bu, bf, inode[N_DEG, bu]))
    _add_edge(adj, inode, bu, r)
    _add_edge(adj, inode, bf, r)
    isc[I_NINSERTED] += 1
    return r


@njit(cache=True)
def _renormalise(fnode, inode, fsc, isc):
    # fold the lazy decay scales back into the stored values before they underflow
    se = fsc[F_SE]
    su = fsc[F_SU]
    if se < 1e-100 or su < 1e-100:
        for q in range(isc[I_NALIVE]):
            i = inode[N_LIST, q]
            fnode[R_E, i] *= se
            fnode[R_U, i] *= su
        fsc[F_SE] = 1.0
        fsc[F_SU] = 1.0
        isc[I_EDIRTY] = 1
        isc[I_ULI] = -1


@njit(cache=True)
def boxes_valid(boxes):
    """Return True if every box (all K, used or not) is finite with min <= max per axis.

    Args:
        boxes: (K, 2, 3) float64, metres.
    """
    for b in range(boxes.shape[0]):
        for a in range(3):
            lo = boxes[b, 0, a]
            hi = boxes[b, 1, a]
            if not (lo <= hi and abs(lo) < np.inf and abs(hi) < np.inf):
                return False
    return True


@njit(cache=True)
def cycle(points, boxes, nbox, pos, V, res, fnode, inode, adj, ibuf, fsc, isc):
    """Run one full learning cycle of one net on one frame (Algorithms 1–3).

    Args:
        points: (N, 3) float32/float64, metres, the frame.
        boxes: (K, 2, 3) float64, metres, attention boxes (min/max corners).
        nbox: number of boxes used (0 = plain GNG-U2).
        pos: (M, 3) float64, metres, node positions.
        V: (λ, 3) float64 work buffer for the input signals.
        res: (P, 3) float64, metres, reservoir of attended points.
        fnode: (3, M) float64 scaled error, scaled utility, strength.
        inode: (9, M) int64 node integers.
        adj: (3, M, D) int64 neighbour lists, ages, twins.
        ibuf: (B + R,) int64 grid buckets and box-row indices.
        fsc: (NF,) float64 scalars.
        isc: (NI,) int64 scalars.

    Returns:
        Number of input signals learned, or -1 (nothing changed) if a box is not finite or
        has a min corner above its max corner.
    """
    if not boxes_valid(boxes):
        return -1
    _renormalise(fnode, inode, fsc, isc)
    refresh_strength(boxes, nbox, fnode, pos, inode, isc)
    nv = draw_samples(points, boxes, nbox, V, res, ibuf, fsc, isc)
    isc[I_NV] = nv
    if nv == 0:
        return 0
    if isc[I_NALIVE] == 0:
        # Algorithm 1, line 1: two initial nodes, here at two random frame points
        j = min(1, nv - 1)
        fsc[F_H] = 1.0
        grid_rebuild(pos, inode, adj, ibuf, fsc, isc, True)
        fsc[F_EMAX] = 0.0
        isc[I_EDIRTY] = 0
        isc[I_ULI] = -1
        _new_node(
            V[0, 0], V[0, 1], V[0, 2], 0.0, 0.0, boxes, nbox, pos, fnode, inode, ibuf, fsc, isc
        )
        _new_node(
            V[j, 0], V[j, 1], V[j, 2], 0.0, 0.0, boxes, nbox, pos, fnode, inode, ibuf, fsc, isc
        )
    grid_rebuild(pos, inode, adj, ibuf, fsc, isc, False)
    learn(V, nv, boxes, nbox, pos, fnode, inode, adj, ibuf, fsc, isc)
    insert_node(boxes, nbox, pos, fnode, inode, adj, ibuf, fsc, isc)
    return nv


@njit(cache=True)
def cycle_layers(points, boxes, nbox, pos, V, res, fnode, inode, adj, ibuf, fsc, isc):
    """Run one learning cycle of every layer of a stacked multi-layer net (ML-GNG).

    Each layer draws its own λ signals from the same frame with its own random stream.

    Args:
        points: (N, 3) float32/float64, metres, the frame.
        boxes: (K, 2, 3) float64, metres, attention boxes (used only if ``nbox`` > 0).
        nbox: number of boxes used.
        pos: (L, M, 3) float64 stacked node positions.
        V: (λ, 3) float64 shared work buffer.
        res: (L, P, 3) float64 reservoirs.
        fnode: (L, 3, M) float64.
        inode: (L, 9, M) int64.
        adj: (L, 3, M, D) int64.
        ibuf: (L, B + R) int64.
        fsc: (L, NF) float64.
        isc: (L, NI) int64.

    Returns:
        Total number of input signals learned over the layers, or -1 for invalid boxes.
    """
    if not boxes_valid(boxes):
        return -1
    tot = 0
    for lay in range(pos.shape[0]):
        tot += cycle(
            points,
            boxes,
            nbox,
            pos[lay],
            V,
            res[lay],
            fnode[lay],
            inode[lay],
            adj[lay],
            ibuf[lay],
            fsc[lay],
            isc[lay],
        )
    return tot


@njit(cache=True)
def export_graph(pos, fnode, inode, adj, out_nodes, out_edges, out_strength):
    """Compact the live nodes (ascending slot order) and list each edge once.

    Edges come out as (i, j) with i < j in compacted indices, sorted lexicographically.
    Rows beyond the output capacity are dropped (nodes by slot order, and edges that touch
    a dropped node); the returned counts are those written.

    Args:
        pos: (M, 3) float64, metres.
        fnode: (3, M) float64.
        inode: (9, M) int64.
        adj: (3, M, D) int64.
        out_nodes: (Nmax, 3) float64 output, metres.
        out_edges: (Emax, 2) int64 output.
        out_strength: (Nmax,) float64 output, δ.

    Returns:
        (number of nodes written, number of edges written).
    """
    m = inode.shape[1]
    cap_n = out_nodes.shape[0]
    cap_e = out_edges.shape[0]
    remap = np.full(m, -1, dtype=np.int64)
    n = 0
    for i in range(m):
        if inode[N_ALIVE, i] != 0 and n < cap_n:
            remap[i] = n
            out_nodes[n, 0] = pos[i, 0]
            out_nodes[n, 1] = pos[i, 1]
            out_nodes[n, 2] = pos[i, 2]
            out_strength[n] = fnode[R_D, i]
            n += 1
    buf = np.empty(adj.shape[2], dtype=np.int64)
    ne = 0
    for i in range(m):
        ri = remap[i]
        if ri < 0:
            continue
        c = 0
        for k in range(inode[N_DEG, i]):
            j = adj[A_NBR, i, k]
            if j > i and remap[j] >= 0:
                # insertion sort of at most D entries
                p = c
                while p > 0 and buf[p - 1] > j:
                    buf[p] = buf[p - 1]
                    p -= 1
                buf[p] = j
                c += 1
        for k in range(c):
            if ne < cap_e:
                out_edges[ne, 0] = ri
                out_edges[ne, 1] = remap[buf[k]]
                ne += 1
    return n, ne
