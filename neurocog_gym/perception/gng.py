"""DD-GNG, the paper's dynamic attention, and its two baselines GNG and ML-GNG (§4.1, §7.1).

All three share one API (SPEC §9)::

    net = DDGNG(seed=0)                      # or GNG(...), MLGNG(...)
    net.update(points, attention_boxes)      # one learning cycle of λ input signals
    net.nodes, net.edges, net.strength       # (n, 3) metres, (m, 2) int64, (n,) δ

Readings of the paper (SPEC §3 settles most; the rest are choices made here):

* Base: GNG-U2 (Toda et al. 2016) with exactly Table 2's parameters. Error and utility use
  squared distances (SPEC §3, Fritzke) where Algorithm 2 prints norms; they decay every input.
* An edge is removed when its age exceeds g_max (Algorithm 2, line 14 prints "<").
* Utility test every κ inputs: remove l = argmin U when E_u / U_l > k·δ_l with u = argmax E.
  The paper prints δ_u; δ_l (the removal candidate's own strength) protects attended nodes,
  the intent SPEC §3 names. The test never shrinks the net below two nodes.
* Insertion once per learning cycle, after the λ-th input (= every λ inputs, as GNG does),
  at the midpoint of u = argmax E·δ^p and its neighbour f = argmax E·δ^p (p =
  ``strength_power``); the strength weighting is DD-GNG's (SPEC §3). U_r = (U_u + U_f)/2.
* Strength δ = 1 + number of attention boxes strictly containing the node (Algorithm 3),
  recomputed for every node when ``update`` is called (the boxes may have changed) and for
  every node that moves or is created.
* Attention sampling (Algorithm 1, lines 7–10): with boxes given, every ``attention_period``-th
  input (the paper's t mod 2) is a random point inside the boxes, the rest random frame
  points. Reading: the box inputs are drawn from a reservoir of the ``box_reservoir`` most
  recent box points (about the last five frames, each contributing ``box_refresh`` new
  ones). With 3 % of a frame inside the box, 150 fresh box points per frame mean ~5,000 rows
  read, a third of the cycle's time budget; drawing the 150 inputs from fewer distinct points
  lowers the attended density instead (measured on the benchmark cloud, 2,000 cycles, 3
  seeds: obstacle/floor node density 10.7 with 150 fresh points per frame, 8.4 with this
  reservoir, 6.5 with 16 fresh points reused). Set ``box_refresh = box_reservoir`` for
  current-frame-only sampling. Box points are found from short runs of consecutive rows at
  random starts, never by scanning the frame (see :mod:`neurocog_gym.perception._gng_kernels`).
* The two initial nodes (Algorithm 1, line 1) are placed at two random points of the first
  frame, so the net starts where the data is, whatever the world frame.
* μ (Table 2) is GNG-U2's kernel width for node normals; it is kept in the parameters for
  completeness and not used here (SPEC §3).
* Rows that are not finite or lie farther than ``coord_limit`` from the origin are never
  learned: each drawn sample is checked and redrawn, so the frame is never scanned.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from neurocog_gym.perception import _gng_kernels as K

__all__ = ["DDGNG", "DDGNGParams", "GNG", "MLGNG", "PaddedGraph"]

_MASK64 = (1 << 64) - 1


@dataclass(frozen=True)
class DDGNGParams:
    """Parameters of DD-GNG and its baselines; defaults are Table 2 where Table 2 has them."""

    lam: int = 300
    """λ, input signals per learning cycle (Table 2; ≈ 0.2 % of a 154,112-point frame, §6.1)."""
    kappa: int = 10
    """κ, inputs between two utility tests (Table 2, GNG-U2)."""
    eta1: float = 0.08
    """η1, winner learning rate, dimensionless (Table 2)."""
    eta2: float = 0.008
    """η2, learning rate of the winner's topological neighbours, dimensionless (Table 2)."""
    g_max: int = 100
    """g_max, maximum edge age in inputs; older edges are removed (Table 2). Must be ≥ 1."""
    alpha: float = 0.5
    """α, error decay of u and f at an insertion, dimensionless (Table 2)."""
    beta: float = 0.005
    """β, error decay per input, dimensionless (Table 2)."""
    chi: float = 0.005
    """χ, utility decay per input, dimensionless (Table 2)."""
    mu: float = 0.5
    """μ, GNG-U2 node-normal kernel width (Table 2); kept for completeness, unused (SPEC §3)."""
    k: float = 1000.0
    """k, utility-removal threshold on E_u / U_l, dimensionless (Table 2)."""
    max_nodes: int = 300
    """Hard cap on the node count; arrays are preallocated to it (Algorithm 2, line 23).

    With Table 2's k the utility test alone holds a net well below this cap on typical
    frames (about 140 DD-GNG / 200 GNG nodes on a 6 m² floor with an obstacle); a larger
    k lets the net grow towards the cap.
    """
    max_degree: int = 16
    """Neighbour-list length per node; a full list drops its oldest edge (implementation)."""
    strength_power: float = 1.0
    """p in the insertion priority E·δ^p, 0..16 (DD-GNG strength weighting, SPEC §3; choice)."""
    attention_period: int = 2
    """Every this-many-th input comes from the attention boxes (Algorithm 1, t mod 2)."""
    box_reservoir: int = 150
    """Recent box points kept to draw the attended inputs from (implementation, Algorithm 1)."""
    box_refresh: int = 32
    """New box points sought in each frame for the reservoir (implementation)."""
    box_sniff: int = 8
    """Rows a box-point probe reads before giving up without a hit (implementation)."""
    box_window: int = 128
    """Rows a box-point probe reads at most, once it has hit a box (implementation)."""
    box_max_probes: int = 256
    """Probes per frame at most when seeking box points (each reads 8 to 128 rows)."""
    box_min_points: int = 8
    """A reservoir with fewer points counts as empty: the cycle samples the whole frame."""
    sample_tries: int = 16
    """Draws per whole-frame input before it is dropped (invalid rows are redrawn)."""
    coord_limit: float = 1.0e4
    """Rows with any |coordinate| above this, metres, are treated as invalid."""
    grid_min_nodes: int = 24
    """Below this node count the nearest-two search is brute force, above it grid-based."""
    grid_cell_factor: float = 2.0
    """Grid cell edge as a multiple of the RMS edge length of the net."""

    def __post_init__(self) -> None:
        """Validate ranges; raises ValueError on a nonsensical value."""
        ints = {
            "lam": 1,
            "kappa": 1,
            "g_max": 1,
            "max_nodes": 2,
            "max_degree": 2,
            "attention_period": 1,
            "box_reservoir": 1,
            "box_refresh": 0,
            "box_window": 1,
            "box_sniff": 1,
            "box_max_probes": 0,
            "box_min_points": 1,
            "sample_tries": 1,
            "grid_min_nodes": 2,
        }
        for name, lo in ints.items():
            v = getattr(self, name)
            if not isinstance(v, (int, np.integer)) or isinstance(v, bool) or v < lo:
                raise ValueError(f"DDGNGParams.{name} must be an int >= {lo}, got {v!r}")
        for name in ("eta1", "eta2", "alpha"):
            v = float(getattr(self, name))
            if not 0.0 <= v <= 1.0:
                raise ValueError(f"DDGNGParams.{name} must lie in [0, 1], got {v!r}")
        for name in ("beta", "chi"):
            v = float(getattr(self, name))
            if not 0.0 <= v < 1.0:
                raise ValueError(f"DDGNGParams.{name} must lie in [0, 1), got {v!r}")
        for name in ("k", "coord_limit", "grid_cell_factor", "mu"):
            v = float(getattr(self, name))
            if not (np.isfinite(v) and v > 0.0):
                raise ValueError(f"DDGNGParams.{name} must be finite and > 0, got {v!r}")
        if not 0.0 <= self.strength_power <= 16.0:
            raise ValueError(
                f"DDGNGParams.strength_power must lie in [0, 16], got {self.strength_power!r}"
            )


class PaddedGraph(NamedTuple):
    """A graph in fixed-size arrays, for fixed-size observations."""

    nodes: np.ndarray
    """(max_nodes, 3) float64, metres; rows from ``n_nodes`` on are 0."""
    edges: np.ndarray
    """(max_edges, 2) int64 indices into ``nodes``; rows from ``n_edges`` on are -1."""
    strength: np.ndarray
    """(max_nodes,) float64 node strength δ; rows from ``n_nodes`` on are 0."""
    n_nodes: int
    """Number of valid node rows."""
    n_edges: int
    """Number of valid edge rows."""


def _seed_state(seed: int, salt: int = 0) -> int:
    """Map any Python int seed (and a salt) to a signed 64-bit SplitMix64 state."""
    s = (int(seed) + salt * 0xD1B54A32D192ED03) & _MASK64
    return s - (1 << 64) if s >= 1 << 63 else s


def _check_points(points) -> np.ndarray:
    """Return ``points`` as a C-contiguous native float32/float64 (N, 3) array or raise."""
    if not isinstance(points, np.ndarray):
        points = np.asarray(points)
    if points.ndim != 2 or points.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3), got {points.shape}")
    dt = points.dtype
    if dt.kind != "f" or dt.itemsize not in (4, 8):
        raise ValueError(f"points must be float32 or float64, got {dt}")
    if not dt.isnative:
        points = points.astype(dt.newbyteorder("="))
    if not points.flags.c_contiguous:
        points = np.ascontiguousarray(points)
    return points


def _as_boxes(boxes) -> np.ndarray:
    """Return ``boxes`` as a C-contiguous float64 (K, 2, 3) array or raise on a wrong shape.

    Finiteness and corner order are checked inside the kernel (cheaper than NumPy here).
    """
    b = boxes
    if not (
        isinstance(b, np.ndarray) and b.dtype == np.float64 and b.flags.c_contiguous and b.ndim == 3
    ):
        try:
            b = np.ascontiguousarray(boxes, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"attention_boxes must be a (K, 2, 3) float array: {exc}") from None
    if b.ndim != 3 or b.shape[1] != 2 or b.shape[2] != 3:
        raise ValueError(f"attention_boxes must have shape (K, 2, 3), got {b.shape}")
    return b


_BAD_BOXES = "attention_boxes must be finite with each min corner <= its max corner"


def _check_boxes(boxes) -> np.ndarray:
    """Return ``boxes`` as float64 (K, 2, 3), checked for shape, finiteness and corner order."""
    b = _as_boxes(boxes)
    if not K.boxes_valid(b):
        raise ValueError(_BAD_BOXES)
    return b


class _Net:
    """Preallocated state of one GNG-U2 net (one layer) and its scalar parameter arrays."""

    def __init__(self, params: DDGNGParams, seed_state: int) -> None:
        p = params
        m = p.max_nodes
        nbucket = 1 << max(4, int(2 * m - 1).bit_length())
        self.pos = np.zeros((m, 3))
        self.fnode = np.zeros((K.N_FROWS, m))
        self.inode = np.zeros((K.N_IROWS, m), dtype=np.int64)
        self.adj = np.zeros((K.N_APLANES, m, p.max_degree), dtype=np.int64)
        self.ibuf = np.full(nbucket + p.box_refresh, -1, dtype=np.int64)
        self.res = np.zeros((p.box_reservoir, 3))
        self.fsc = np.zeros(K.NF)
        self.isc = np.zeros(K.NI, dtype=np.int64)
        f = self.fsc
        f[K.F_ETA1], f[K.F_ETA2], f[K.F_ALPHA] = p.eta1, p.eta2, p.alpha
        f[K.F_BETA], f[K.F_CHI], f[K.F_K] = p.beta, p.chi, p.k
        f[K.F_LIMIT], f[K.F_CELLFAC], f[K.F_SPOW] = (
            p.coord_limit,
            p.grid_cell_factor,
            p.strength_power,
        )
        f[K.F_SE] = f[K.F_SU] = f[K.F_H] = 1.0
        i = self.isc
        i[K.I_LAM], i[K.I_KAPPA], i[K.I_GMAX] = p.lam, p.kappa, p.g_max
        i[K.I_MAXN], i[K.I_MAXDEG], i[K.I_PERIOD] = m, p.max_degree, p.attention_period
        i[K.I_POOLCAP], i[K.I_WIN], i[K.I_MAXPROBE] = p.box_refresh, p.box_window, p.box_max_probes
        i[K.I_TRIES], i[K.I_GRIDMIN], i[K.I_NBUCKET] = p.sample_tries, p.grid_min_nodes, nbucket
        i[K.I_POOLMIN], i[K.I_RNG] = p.box_min_points, seed_state
        i[K.I_SNIFF] = p.box_sniff

    def export(self, max_nodes: int, max_edges: int):
        out_n = np.zeros((max_nodes, 3))
        out_e = np.full((max_edges, 2), -1, dtype=np.int64)
        out_s = np.zeros(max_nodes)
        n, m = K.export_graph(self.pos, self.fnode, self.inode, self.adj, out_n, out_e, out_s)
        return out_n, out_e, out_s, int(n), int(m)


class DDGNG:
    """Dynamic Density Growing Neural Gas (DD-GNG), §4.1, Algorithms 1–3, Table 2.

    GNG-U2 whose node strength δ (Algorithm 3) and attention sampling (Algorithm 1) raise the
    node density inside suspected-obstacle boxes only. See the module docstring for the
    readings of the paper.

    Args:
        seed: seed of the net's own random stream; the same seed and inputs give bit-identical
            graphs.
        params: parameters; ``None`` means :class:`DDGNGParams` defaults (Table 2).
    """

    _attention = True

    def __init__(self, seed: int = 0, params: DDGNGParams | None = None) -> None:
        self.params = params if params is not None else DDGNGParams()
        if not isinstance(self.params, DDGNGParams):
            raise ValueError(f"params must be a DDGNGParams, got {type(self.params).__name__}")
        self.seed = int(seed)
        self._no_boxes = np.zeros((0, 2, 3))
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        """Forget the graph; restart the random stream from ``seed`` (default: the same seed).

        Args:
            seed: new seed, or ``None`` to keep the constructor's.
        """
        if seed is not None:
            self.seed = int(seed)
        self._net = _Net(self.params, _seed_state(self.seed))
        self._V = np.zeros((self.params.lam, 3))
        m = self.params.max_nodes
        # Read-out scratch, written by every export; the graph properties return copies of the
        # written rows (a fresh full-size buffer per cycle costs more than the copies).
        self._out = (
            np.zeros((m, 3)),
            np.zeros((m * self.params.max_degree // 2, 2), np.int64),
            np.zeros(m),
        )
        self._cache = None

    def update(self, points, attention_boxes=None) -> int:
        """Run one learning cycle of λ input signals drawn from ``points``.

        Args:
            points: (N, 3) float32 or float64, metres, one point-cloud frame (world frame).
                Non-finite rows and rows beyond ``coord_limit`` are never learned. N may be 0.
            attention_boxes: (K, 2, 3) float, metres, min and max corners of the suspected
                obstacle boxes, or ``None`` for no attention. Validated, then ignored, by
                :class:`GNG`.

        Returns:
            Number of input signals learned this cycle (λ unless the frame is mostly invalid).

        Raises:
            ValueError: on a wrong shape or dtype, or non-finite/inverted boxes.
        """
        pts = _check_points(points)
        boxes = self._no_boxes if attention_boxes is None else _as_boxes(attention_boxes)
        net = self._net
        self._cache = None
        nv = int(
            K.cycle(
                pts,
                boxes,
                boxes.shape[0] if self._attention else 0,
                net.pos,
                self._V,
                net.res,
                net.fnode,
                net.inode,
                net.adj,
                net.ibuf,
                net.fsc,
                net.isc,
            )
        )
        if nv < 0:
            raise ValueError(_BAD_BOXES)
        return nv

    # ---- read-out -------------------------------------------------------------------------
    def _graph(self):
        if self._cache is None:
            net = self._net
            out_n, out_e, out_s = self._out
            n, ne = K.export_graph(net.pos, net.fnode, net.inode, net.adj, out_n, out_e, out_s)
            nodes, edges, strength = out_n[:n].copy(), out_e[:ne].copy(), out_s[:n].copy()
            for a in (nodes, edges, strength):
                a.flags.writeable = False
            self._cache = (nodes, edges, strength)
        return self._cache

    @property
    def nodes(self) -> np.ndarray:
        """(n, 3) float64, metres: live node positions h_i (read-only)."""
        return self._graph()[0]

    @property
    def edges(self) -> np.ndarray:
        """(m, 2) int64: each undirected edge once as (i, j), i < j, rows of ``nodes``, sorted."""
        return self._graph()[1]

    @property
    def strength(self) -> np.ndarray:
        """(n,) float64: node strength δ ≥ 1 for the boxes of the last update (Algorithm 3)."""
        return self._graph()[2]

    @property
    def n_nodes(self) -> int:
        """Number of live nodes."""
        return int(self._net.isc[K.I_NALIVE])

    @property
    def n_edges(self) -> int:
        """Number of undirected edges."""
        return int(self._net.inode[K.N_DEG].sum() // 2)

    @property
    def n_samples(self) -> int:
        """Total number of input signals learned since the last reset (t)."""
        return int(self._net.isc[K.I_T])

    @property
    def last_box_samples(self) -> int:
        """Input signals drawn from the attention boxes in the last update."""
        return int(self._net.isc[K.I_NBOX])

    @property
    def error(self) -> np.ndarray:
        """(n,) float64: accumulated error E of each node (squared metres)."""
        return self._scaled(K.R_E, K.F_SE)

    @property
    def utility(self) -> np.ndarray:
        """(n,) float64: utility U of each node (squared metres)."""
        return self._scaled(K.R_U, K.F_SU)

    def _scaled(self, row: int, scale: int) -> np.ndarray:
        net = self._net
        alive = net.inode[K.N_ALIVE] != 0
        return net.fnode[row][alive] * net.fsc[scale]

    def padded(self, max_nodes: int | None = None, max_edges: int | None = None) -> PaddedGraph:
        """Return the graph in fixed-size arrays (for a fixed-size observation).

        Args:
            max_nodes: node rows; default ``params.max_nodes`` (never truncates).
            max_edges: edge rows; default ``max_nodes * max_degree // 2`` (never truncates).
                Smaller sizes keep the lowest-index nodes and the first edges among them.

        Returns:
            A :class:`PaddedGraph`.
        """
        mn = self.params.max_nodes if max_nodes is None else int(max_nodes)
        me = mn * self.params.max_degree // 2 if max_edges is None else int(max_edges)
        if mn < 0 or me < 0:
            raise ValueError("max_nodes and max_edges must be >= 0")
        return PaddedGraph(*self._net.export(mn, me))


class GNG(DDGNG):
    """Plain growing neural gas with utility (Fritzke 1995 / GNG-U2), the no-attention baseline.

    The same kernel as :class:`DDGNG` with attention switched off: ``attention_boxes`` is
    accepted and ignored, every strength δ is 1, all inputs are whole-frame samples.

    Args:
        seed: seed of the net's random stream.
        params: parameters; ``None`` means Table 2 defaults.
    """

    _attention = False


class MLGNG:
    """Multi-layer GNG (ML-GNG, Toda et al. 2016), the paper's comparison point (§7.1).

    Reading used here (the paper only names it): ``n_layers`` independent GNG-U2 layers learn
    the same frame, each drawing its own λ input signals per cycle, with different density and
    removal settings. Layer ``l`` (0 = coarsest) has ``max_nodes / 2**(L-1-l)`` nodes and
    utility threshold ``k / 10**(L-1-l)`` (a coarse layer sheds nodes readily, the finest layer
    uses Table 2's k). Multi-density comes from the layers, not from attention: boxes are
    accepted and ignored, every δ is 1. The finest layer carries the detail and is what
    ``nodes``, ``edges`` and ``strength`` return; :meth:`layer` gives every layer. Its cost
    is about ``n_layers`` GNG cycles, which is the comparison §7.1 makes.

    Args:
        seed: seed; layer ``l`` uses its own stream derived from it.
        params: parameters of the finest layer; ``None`` means Table 2 defaults.
        n_layers: number of layers L (≥ 1).
    """

    def __init__(self, seed: int = 0, params: DDGNGParams | None = None, n_layers: int = 3) -> None:
        self.params = params if params is not None else DDGNGParams()
        if not isinstance(self.params, DDGNGParams):
            raise ValueError(f"params must be a DDGNGParams, got {type(self.params).__name__}")
        if int(n_layers) < 1:
            raise ValueError(f"n_layers must be >= 1, got {n_layers}")
        self.n_layers = int(n_layers)
        self.seed = int(seed)
        self.reset()

    def layer_params(self, layer: int) -> DDGNGParams:
        """Parameters of layer ``layer`` (0 = coarsest, ``n_layers - 1`` = finest)."""
        down = self.n_layers - 1 - int(layer)
        p = self.params
        return dataclasses.replace(p, max_nodes=max(2, p.max_nodes // 2**down), k=p.k / 10.0**down)

    def reset(self, seed: int | None = None) -> None:
        """Forget every layer; restart the random streams from ``seed`` (default: same seed).

        Args:
            seed: new seed, or ``None`` to keep the constructor's.
        """
        if seed is not None:
            self.seed = int(seed)
        L = self.n_layers
        m = self.params.max_nodes
        nets = []
        for lay in range(L):
            lp = self.layer_params(lay)
            # every layer uses the finest layer's array sizes; its own cap sits in isc
            net = _Net(dataclasses.replace(lp, max_nodes=m), _seed_state(self.seed, lay + 1))
            net.isc[K.I_MAXN] = lp.max_nodes
            nets.append(net)
        self._pos = np.stack([n.pos for n in nets])
        self._fnode = np.stack([n.fnode for n in nets])
        self._inode = np.stack([n.inode for n in nets])
        self._adj = np.stack([n.adj for n in nets])
        self._ibuf = np.stack([n.ibuf for n in nets])
        self._res = np.stack([n.res for n in nets])
        self._fsc = np.stack([n.fsc for n in nets])
        self._isc = np.stack([n.isc for n in nets])
        self._V = np.zeros((self.params.lam, 3))
        self._no_boxes = np.zeros((0, 2, 3))
        self._cache = {}

    def update(self, points, attention_boxes=None) -> int:
        """Run one learning cycle of every layer on ``points``.

        Args:
            points: (N, 3) float32 or float64, metres, one frame.
            attention_boxes: (K, 2, 3) float, metres; validated, then ignored (no attention).

        Returns:
            Input signals learned by the finest layer this cycle.

        Raises:
            ValueError: on a wrong shape or dtype.
        """
        pts = _check_points(points)
        boxes = self._no_boxes if attention_boxes is None else _as_boxes(attention_boxes)
        self._cache = {}
        nv = K.cycle_layers(
            pts,
            boxes,
            0,
            self._pos,
            self._V,
            self._res,
            self._fnode,
            self._inode,
            self._adj,
            self._ibuf,
            self._fsc,
            self._isc,
        )
        if nv < 0:
            raise ValueError(_BAD_BOXES)
        return int(self._isc[-1, K.I_NV])

    def layer(self, layer: int) -> tuple[np.ndarray, np.ndarray]:
        """Return (nodes (n, 3) metres, edges (m, 2) int64) of one layer (0 = coarsest)."""
        lay = range(self.n_layers)[layer]
        if lay not in self._cache:
            m = self.params.max_nodes
            out_n = np.zeros((m, 3))
            out_e = np.full((m * self.params.max_degree // 2, 2), -1, dtype=np.int64)
            out_s = np.zeros(m)
            n, ne = K.export_graph(
                self._pos[lay],
                self._fnode[lay],
                self._inode[lay],
                self._adj[lay],
                out_n,
                out_e,
                out_s,
            )
            nodes, edges = out_n[:n], out_e[:ne]
            nodes.flags.writeable = False
            edges.flags.writeable = False
            self._cache[lay] = (nodes, edges)
        return self._cache[lay]

    @property
    def nodes(self) -> np.ndarray:
        """(n, 3) float64, metres: nodes of the finest layer (read-only)."""
        return self.layer(-1)[0]

    @property
    def edges(self) -> np.ndarray:
        """(m, 2) int64: edges of the finest layer, i < j, sorted."""
        return self.layer(-1)[1]

    @property
    def strength(self) -> np.ndarray:
        """(n,) float64: all ones (ML-GNG has no node strength)."""
        return np.ones(self.n_nodes)

    @property
    def n_nodes(self) -> int:
        """Live nodes of the finest layer."""
        return int(self._isc[-1, K.I_NALIVE])

    @property
    def n_edges(self) -> int:
        """Edges of the finest layer."""
        return int(self._inode[-1, K.N_DEG].sum() // 2)

    def padded(self, max_nodes: int | None = None, max_edges: int | None = None) -> PaddedGraph:
        """Return the finest layer in fixed-size arrays; see :meth:`DDGNG.padded`."""
        mn = self.params.max_nodes if max_nodes is None else int(max_nodes)
        me = mn * self.params.max_degree // 2 if max_edges is None else int(max_edges)
        if mn < 0 or me < 0:
            raise ValueError("max_nodes and max_edges must be >= 0")
        out_n = np.zeros((mn, 3))
        out_e = np.full((me, 2), -1, dtype=np.int64)
        out_s = np.zeros(mn)
        n, ne = K.export_graph(
            self._pos[-1], self._fnode[-1], self._inode[-1], self._adj[-1], out_n, out_e, out_s
        )
        out_s[:n] = 1.0
        return PaddedGraph(out_n, out_e, out_s, int(n), int(ne))
