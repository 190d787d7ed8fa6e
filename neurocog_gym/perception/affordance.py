"""Affordance detection on a GNG graph (§4.2, Eq. 1–4; SPEC §4).

Pipeline, one compiled call (``_affordance_kernels.detect_kernel``):

1. **Triangulation.** Neighbour lists are built in two passes over the edge array (CSR with
   slack for the diagonals, never a dense n × n matrix). All 3-cycles are facets. Then every
   chordless 4-cycle whose four edges each border at most one facet gets its shorter diagonal and
   the 3-cycles through the diagonal become facets (SPEC §4: without them a flat GNG floor falls
   apart). We read "each 4-cycle that lacks a diagonal" as each such *quad hole*: the chordless
   4-cycle round a degree-4 node has two facets on every edge, and a diagonal there would lay
   facets over the node's fan. Slivers (twice the area over the squared longest edge below
   ``min_facet_quality``: collinear or duplicate nodes) are skipped; a facet whose three edges
   each carry two other facets is internal (spanned across a closed shape) and dropped.
2. **Eq. (1)** facet normal ``(n0 - n1) x (n0 - n2)``, oriented towards ``sensor_origin`` (a depth
   sensor only sees surfaces that face it). With ``sensor_origin=None`` facets are oriented away
   from the node centroid instead, which gives outward normals on closed convex shapes.
3. **Eq. (2)** weight between facets sharing an edge, the angle between their normals; each facet
   keeps at most three links (on an edge shared by more facets, the most coplanar one).
4. **Region growing** (the segmentation of [43], not printed in the paper): a facet joins a
   neighbour's region when the Eq. (2) weight is below ``grow_angle`` and its normal is within
   ``region_angle`` of the region's running mean normal.
5. **Classes.** The ground level is ``ground_z`` or, if None, the area-weighted height of the
   lowest near-horizontal region among those with at least ``ground_area_share`` of the largest
   one's area (else the lowest facet node). A region is *terrain* if near-horizontal (γ ≤
   ``terrain_max_tilt``) and at ground level (mean height within ``ground_tolerance``); a *wall* if
   near-vertical (γ ≥ ``wall_min_tilt``) and tall (top ≥ ``wall_min_height`` above ground);
   otherwise an *object*. Connected object facets merge into one object (a block's top, its short
   vertical sides and the bevels a GNG puts round its base). An object component whose top stays
   within ``ground_tolerance`` of the ground is terrain (GNG noise, steppable bumps); one that
   touches a wall is part of the wall (the bevel at a wall's foot). Finally connected facets of one
   class are one label: all connected terrain is one terrain label, each wall region one wall.
   Before the object components are formed, a terrain facet with a node higher than
   ``raised_node_tolerance`` above the ground becomes an object facet: the paper's
   "non-homogeneous nodes" (§6.2) that start the attention. Without this rule a sparse net (Table
   2's k holds ~60 nodes on the robot's 3 m² view, 15–25 cm apart) hides a new 6–8 cm block in
   the floor's region until nodes crowd onto it, because the facets round one raised node tilt
   less than ``terrain_max_tilt`` and join the floor (measured in the walking trials of
   ``scripts/attention_timing.py``: attention on a new block after 0.23–0.91 s without the rule,
   0.01–0.3 s with it). Such an object's box spans the raised node's fan of facets, the
   "circle of a particular radius centred on a suspected node" of §4.1.
6. **Per label** (§4.2.1): ``normal`` = the mean facet normal Ob^(v), normalised; ``position`` =
   the mean facet centre Ob^(pos); ``size`` = total facet area (m²); ``gamma`` Eq. (3) against the
   vertical (0, 0, 1) — the paper prints (0, 1, 0), its y-up frame; ``density`` Eq. (4) = distinct
   nodes / size (nodes/m²; boundary nodes count in full, so a small region reads up to about twice
   its interior density — v is chosen with that in mind).

Our reading of the garbled A_h, A_w, A_s of §4.2.1 (SPEC §4: height, width, length):

- ``height`` A_h = highest node of the label minus the ground level (metres; negative for a
  label wholly below ground). The paper maximises over facet centres; a GNG rounds a block's
  edges, so facet centres undershoot the top by up to a third of a facet, the highest node does
  not.
- ``width`` A_w / ``length`` A_s = full extent of the label's nodes across / along ``forward``
  in the ground plane (the paper's forms measure from Ob^(pos) to the farthest facet centre
  along y / x, a half-extent in its frame). For objects only nodes higher than
  ``ground_tolerance`` above the ground count, so the bevel facets a GNG spans from a block's top
  edge to the floor do not widen the block.

A non-homogeneous region (an object) whose density is below ``density_threshold`` v is a
*suspected obstacle* (§4.2, Eq. 4: "if d > v the perception changes the behaviour"): it is
reported with ``suspected=True`` and its box, padded by ``suspect_padding``, goes back to the
DD-GNG as an attention box, which raises node density there until d > v and the object is
confirmed. Consumers should act only on objects with ``suspected=False``.

v = 400 nodes/m² (the paper gives no value): a mesh of spacing h holds about 1.15 / h² nodes per
m² inside a surface, and a small object reads up to twice that because its boundary nodes count
in full. The 20 × 20 × 7 cm block of the tests reads about 180 at 10 cm spacing, 290 at 8 cm
(suspected), 600 at 6 cm and 780 at 4 cm (confirmed): the attention must bring the GNG spacing on
an obstacle below about 6 cm (a node per 5 cm × 5 cm, about one per obstacle height) before the
robot acts on it, which is what measuring a 6–8 cm obstacle's height to 1 cm needs.

Degenerate input (no edges, no triangles, collinear or duplicate nodes, NaN) returns an empty
result, never an exception: edges touching a non-finite node, self-loops and duplicate edges are
dropped, the rest is processed. Malformed input (wrong shapes, edge indices outside [0, n), a
non-finite sensor origin, a vertical ``forward``) raises ``ValueError``.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from neurocog_gym.perception import _affordance_kernels as _k

KIND_NAMES: tuple[str, str, str] = ("terrain", "wall", "object")
"""Label kind names, indexed by the kernels' KIND_TERRAIN, KIND_WALL, KIND_OBJECT."""


@dataclass(frozen=True)
class AffordanceParams:
    """Parameters of the affordance detection (§4.2). Override with ``dataclasses.replace``."""

    grow_angle: float = math.radians(25.0)
    """θ_w, rad: max Eq. (2) weight between neighbouring facets of one region (region growing)."""
    region_angle: float = math.radians(30.0)
    """rad: max angle between a joining facet and its region's running mean normal (no drift)."""
    terrain_max_tilt: float = math.radians(20.0)
    """rad: max Eq. (3) tilt γ of safe terrain; a quadruped of this size walks 20° slopes."""
    wall_min_tilt: float = math.radians(70.0)
    """rad: min Eq. (3) tilt γ of a wall (near-vertical)."""
    wall_min_height: float = 0.20
    """m: min top height above ground of a wall; §6.4 blocks are 6–8 cm, 20 cm cannot be stepped."""
    ground_tolerance: float = 0.02
    """m: terrain lies within this of the ground level; lower bumps are terrain (ToF/GNG noise)."""
    ground_area_share: float = 0.25
    """1: the ground is the lowest horizontal region with this share of the largest one's area."""
    density_threshold: float = 400.0
    """v, nodes/m²: objects below it are suspected (Eq. 4); 400 ≈ one node per 5 cm × 5 cm."""
    suspect_padding: float = 0.03
    """m: padding on each side of a suspected object's box sent back to the DD-GNG (§4.2.2)."""
    raised_node_tolerance: float = 0.02
    """m: a terrain facet with a node higher than this above the ground joins an object
    (the paper's "non-homogeneous nodes", §6.2); 0 switches the rule off."""
    max_facets: int = 16384
    """Facet capacity per detection; enumeration stops there (``truncated`` is set)."""
    min_facet_quality: float = 1e-3
    """1: facets with 2·area / longest_edge² below it are slivers, skipped (equilateral: 0.866)."""

    @functools.cached_property
    def packed(self) -> np.ndarray:
        """(N_PARAMS,) float64: the parameters as the kernels read them (computed once)."""
        p = np.empty(_k.N_PARAMS)
        p[_k.P_MAX_FACETS] = self.max_facets
        p[_k.P_MIN_QUALITY] = self.min_facet_quality
        p[_k.P_COS_GROW] = math.cos(self.grow_angle)
        p[_k.P_COS_REGION] = math.cos(self.region_angle)
        p[_k.P_TERRAIN_TILT] = self.terrain_max_tilt
        p[_k.P_WALL_TILT] = self.wall_min_tilt
        p[_k.P_WALL_HEIGHT] = self.wall_min_height
        p[_k.P_GROUND_TOL] = self.ground_tolerance
        p[_k.P_GROUND_SHARE] = self.ground_area_share
        p[_k.P_DENSITY] = self.density_threshold
        p[_k.P_PADDING] = self.suspect_padding
        p[_k.P_RAISE_TOL] = self.raised_node_tolerance
        p.flags.writeable = False
        return p


DEFAULT_PARAMS = AffordanceParams()


class AffordanceObject(NamedTuple):
    """One labelled surface: terrain, a wall or an object (§4.2.1).

    An immutable record (a ``NamedTuple``: creating one costs well under a microsecond, a
    frozen dataclass several, and detection runs every 10 ms control cycle).

    Attributes:
        kind: "terrain", "wall" or "object".
        position: (3,) float64, metres, world frame: mean facet centre Ob^(pos).
        height: A_h, metres: highest node above the ground level.
        width: A_w, metres: extent across the walking direction.
        length: A_s, metres: extent along the walking direction.
        gamma: γ, radians: Eq. (3) angle between the mean normal and the vertical.
        density: d, nodes/m²: Eq. (4), ``n_nodes / size``.
        normal: (3,) float64 unit mean facet normal Ob^(v) (zero if the normals cancel).
        size: m²: total area of the label's facets.
        n_nodes: number of distinct graph nodes on the label's facets.
        box: (2, 3) float64, metres: min and max corners of those nodes.
        suspected: True for an object whose density is below v (low confidence, attention box).
    """

    kind: str
    position: np.ndarray
    height: float
    width: float
    length: float
    gamma: float
    density: float
    normal: np.ndarray
    size: float
    n_nodes: int
    box: np.ndarray
    suspected: bool


@dataclass(frozen=True, eq=False)
class Affordances:
    """Result of :func:`detect_affordances` (compared by identity: it holds arrays).

    Attributes:
        objects: one :class:`AffordanceObject` per label; label ``k`` is ``objects[k]``.
        suspected_boxes: (K, 2, 3) float64, metres: padded min/max corners of the suspected
            objects, for ``DDGNG.update(points, attention_boxes=...)``; K may be 0.
        facets: (F, 3) int64 node indices, wound so the right-hand normal is ``facet_normals``.
        facet_normals: (F, 3) float64 unit normals, Eq. (1), oriented towards the sensor.
        facet_labels: (F,) int64 label (index into ``objects``) of each facet.
        label_kinds: kind of each label, ``label_kinds[k] == objects[k].kind``.
        ground_z: metres: the ground level used (given or estimated; NaN without facets).
        truncated: True if ``params.max_facets`` was reached.
    """

    objects: list[AffordanceObject]
    suspected_boxes: np.ndarray
    facets: np.ndarray
    facet_normals: np.ndarray
    facet_labels: np.ndarray
    label_kinds: tuple[str, ...]
    ground_z: float
    truncated: bool = False

    @property
    def terrain(self) -> list[AffordanceObject]:
        """Labels of kind "terrain"."""
        return [o for o in self.objects if o.kind == "terrain"]

    @property
    def walls(self) -> list[AffordanceObject]:
        """Labels of kind "wall"."""
        return [o for o in self.objects if o.kind == "wall"]

    @property
    def obstacles(self) -> list[AffordanceObject]:
        """Labels of kind "object", suspected or confirmed."""
        return [o for o in self.objects if o.kind == "object"]


_KIND_OF: tuple[str, str, str] = tuple(
    KIND_NAMES[k] for k in (_k.KIND_TERRAIN, _k.KIND_WALL, _k.KIND_OBJECT)
)


def _empty_result(ground_z: float | None) -> Affordances:
    return Affordances(
        objects=[],
        suspected_boxes=np.zeros((0, 2, 3)),
        facets=np.zeros((0, 3), np.int64),
        facet_normals=np.zeros((0, 3)),
        facet_labels=np.zeros(0, np.int64),
        label_kinds=(),
        ground_z=float("nan") if ground_z is None else float(ground_z),
    )


def _check_graph(nodes: np.ndarray, edges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Validate shapes and dtypes; return C-contiguous float64 nodes and int64 edges."""
    # Fast path first: a detection costs about 50 µs, a NumPy conversion 1–2 µs.
    if not (type(nodes) is np.ndarray and nodes.dtype == np.float64 and nodes.flags.c_contiguous):
        nodes = np.ascontiguousarray(nodes, dtype=np.float64)
    if nodes.ndim != 2 or nodes.shape[1] != 3:
        raise ValueError(f"nodes must have shape (n, 3), got {nodes.shape}")
    if not (type(edges) is np.ndarray and edges.dtype == np.int64 and edges.flags.c_contiguous):
        edges = np.asarray(edges)
        if edges.size == 0:
            return nodes, np.zeros((0, 2), np.int64)
        if not np.issubdtype(edges.dtype, np.integer):
            raise ValueError(f"edges must be integer node indices, got dtype {edges.dtype}")
        edges = np.ascontiguousarray(edges, dtype=np.int64)
    if edges.size == 0:
        return nodes, np.zeros((0, 2), np.int64)
    if edges.ndim != 2 or edges.shape[1] != 2:
        raise ValueError(f"edges must have shape (m, 2), got {edges.shape}")
    return nodes, edges


_NO_ORIGIN = np.zeros(3)


def _origin(sensor_origin: Sequence[float] | np.ndarray | None) -> tuple[np.ndarray, bool]:
    """Return the (3,) float64 origin and whether facets are oriented away from the centroid."""
    if sensor_origin is None:
        return _NO_ORIGIN, True
    if not (
        type(sensor_origin) is np.ndarray
        and sensor_origin.dtype == np.float64
        and sensor_origin.shape == (3,)
        and sensor_origin.flags.c_contiguous
    ):
        sensor_origin = np.ascontiguousarray(sensor_origin, dtype=np.float64).reshape(-1)
    if sensor_origin.shape != (3,) or not all(map(math.isfinite, sensor_origin.tolist())):
        raise ValueError(f"sensor_origin must be a finite (3,) point, got {sensor_origin!r}")
    return sensor_origin, False


_DEFAULT_FORWARD = (1.0, 0.0, 0.0)


def _forward_xy(forward: Sequence[float] | np.ndarray) -> tuple[float, float]:
    """Unit walking direction in the ground plane from a (3,) vector."""
    if forward is _DEFAULT_FORWARD:
        return 1.0, 0.0
    f = forward.tolist() if isinstance(forward, np.ndarray) else list(forward)
    if len(f) != 3 or not all(map(math.isfinite, f)):
        raise ValueError(f"forward must be a finite (3,) vector, got {forward!r}")
    h = math.hypot(f[0], f[1])
    if h < 1e-9:
        raise ValueError("forward must have a horizontal component")
    return f[0] / h, f[1] / h


def detect_affordances(
    nodes: np.ndarray,
    edges: np.ndarray,
    sensor_origin: Sequence[float] | np.ndarray | None,
    params: AffordanceParams | None = None,
    forward: Sequence[float] | np.ndarray = _DEFAULT_FORWARD,
    ground_z: float | None = None,
) -> Affordances:
    """Detect terrain, walls and objects on a GNG graph (§4.2, Eq. 1–4).

    Args:
        nodes: (n, 3) float, metres, world frame, z up (MuJoCo).
        edges: (m, 2) int node indices, undirected, each edge once (duplicates are ignored).
        sensor_origin: (3,) float, metres: the depth sensor's position; facet normals face it.
            None orients facets away from the node centroid (closed shapes, tests).
        params: detection parameters; None uses :data:`DEFAULT_PARAMS`.
        forward: (3,) float walking direction; its ground-plane part defines length (along) and
            width (across). Default world +x.
        ground_z: metres, the ground level; None estimates it from near-horizontal regions.

    Returns:
        The labelled surfaces, the suspected-obstacle boxes and the facets; empty for a
        degenerate graph.

    Raises:
        ValueError: on wrong shapes or dtypes, edge indices outside [0, n), a non-finite
            ``sensor_origin``, or a ``forward`` without a horizontal part.
    """
    raw = detect_raw(nodes, edges, sensor_origin, params, forward, ground_z)
    if isinstance(raw, Affordances):
        return raw
    return assemble(*raw)


def detect_raw(
    nodes: np.ndarray,
    edges: np.ndarray,
    sensor_origin: Sequence[float] | np.ndarray | None,
    params: AffordanceParams | None = None,
    forward: Sequence[float] | np.ndarray = _DEFAULT_FORWARD,
    ground_z: float | None = None,
):
    """:func:`detect_affordances` up to the kernel's arrays (for callers that go on in numba).

    Same arguments, checks and errors. Returns the empty :class:`Affordances` of a degenerate
    graph, or the tuple ``(ground, truncated, facets, normals, flabels, lab, pos, normal, box,
    sboxes)`` that :func:`assemble` turns into the result.
    """
    p = DEFAULT_PARAMS if params is None else params
    nodes, edges = _check_graph(nodes, edges)
    origin, away = _origin(sensor_origin)
    fx, fy = _forward_xy(forward)
    if ground_z is not None and not math.isfinite(ground_z):
        raise ValueError(f"ground_z must be finite or None, got {ground_z!r}")
    if nodes.shape[0] < 3 or edges.shape[0] < 3:
        return _empty_result(ground_z)
    mode = _k.MODE_ORIENT_AWAY if away else 0
    if ground_z is None:
        ground = 0.0
    else:
        mode |= _k.MODE_GROUND_KNOWN
        ground = float(ground_z)
    n_bad, truncated, ground, facets, normals, flabels, lab, pos, normal, box, boxes = (
        _k.detect_kernel(nodes, edges, origin, fx, fy, ground, mode, p.packed)
    )
    if n_bad:
        raise ValueError(f"{n_bad} edges index nodes outside [0, {nodes.shape[0]})")
    if facets.shape[0] == 0:
        return _empty_result(ground_z)
    return ground, truncated, facets, normals, flabels, lab, pos, normal, box, boxes


def assemble(ground, truncated, facets, normals, flabels, lab, pos, normal, box, boxes):
    """The :class:`Affordances` of the kernel's arrays (see :func:`detect_raw`)."""
    # Label table columns 0..8: L_KIND, L_HEIGHT, L_WIDTH, L_LENGTH, L_GAMMA, L_DENSITY, L_SIZE,
    # L_NNODES, L_SUSPECTED. The records are made by tuple.__new__ on the field tuple, what
    # the NamedTuple's own __new__ does after a Python-level call (about 0.5 µs a label less).
    new, kind_of, cls = tuple.__new__, _KIND_OF, AffordanceObject
    objects = [
        new(
            cls,
            (kind_of[int(r[0])], q, r[1], r[2], r[3], r[4], r[5], u, r[6], int(r[7]), b, r[8] != 0),
        )
        for r, q, u, b in zip(lab.tolist(), pos, normal, box, strict=True)
    ]
    kinds = tuple([o[0] for o in objects])
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


def triangulate(
    nodes: np.ndarray,
    edges: np.ndarray,
    sensor_origin: Sequence[float] | np.ndarray | None,
    params: AffordanceParams | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Facets and Eq. (1) normals of a graph, without segmentation (steps 1–2 of the module).

    Args:
        nodes: (n, 3) float, metres.
        edges: (m, 2) int node indices.
        sensor_origin: (3,) float, metres, or None (orient away from the node centroid).
        params: uses ``max_facets`` and ``min_facet_quality``; None for the defaults.

    Returns:
        ``(facets, facet_normals)``: (F, 3) int64 node indices and (F, 3) float64 unit normals.
    """
    p = DEFAULT_PARAMS if params is None else params
    nodes, edges = _check_graph(nodes, edges)
    origin, away = _origin(sensor_origin)
    if nodes.shape[0] < 3 or edges.shape[0] < 3:
        return np.zeros((0, 3), np.int64), np.zeros((0, 3))
    facets, normals, n_bad = _k.triangulate_kernel(
        nodes, edges, origin, away, int(p.max_facets), float(p.min_facet_quality)
    )
    if n_bad:
        raise ValueError(f"{n_bad} edges index nodes outside [0, {nodes.shape[0]})")
    return facets, normals


def node_normals(nodes: np.ndarray, facets: np.ndarray, facet_normals: np.ndarray) -> np.ndarray:
    """Per-node normal: area-weighted mean of the incident facet normals.

    Args:
        nodes: (n, 3) float, metres.
        facets: (F, 3) int node indices (e.g. ``Affordances.facets``); rows with an index
            outside [0, n) are ignored.
        facet_normals: (F, 3) float unit normals, oriented (e.g. ``Affordances.facet_normals``).

    Returns:
        (n, 3) float64 unit normals; zero rows for nodes on no facet.
    """
    nodes = np.ascontiguousarray(nodes, dtype=np.float64)
    if nodes.ndim != 2 or nodes.shape[1] != 3:
        raise ValueError(f"nodes must have shape (n, 3), got {nodes.shape}")
    facets = np.ascontiguousarray(facets, dtype=np.int64).reshape(-1, 3)
    facet_normals = np.ascontiguousarray(facet_normals, dtype=np.float64).reshape(-1, 3)
    if facets.shape[0] != facet_normals.shape[0]:
        raise ValueError("facets and facet_normals must have the same number of rows")
    return _k.node_normals_kernel(nodes, facets, facet_normals)


# --------------------------------------------------------------------------------------------
# Synthetic scenes for tests, benchmarks and figures.


@dataclass(frozen=True, eq=False)
class SyntheticScene:
    """A GNG-like graph of a floor, an optional block and an optional wall, with ground truth.

    Attributes:
        nodes: (n, 3) float64, metres, world frame, z up; node order shuffled.
        edges: (m, 2) int64, undirected, each once.
        sensor_origin: (3,) float64, metres: a sensor in front of and above the scene, at
            (0, 0, 0.35), looking along +x (it does not see the block's back and side faces,
            which the lattice has anyway; their facets are oriented towards it).
        box_min: (3,) float64 block min corner, or None.
        box_max: (3,) float64 block max corner, or None.
        wall_x: x of the wall's front face, metres, or None.
    """

    nodes: np.ndarray
    edges: np.ndarray
    sensor_origin: np.ndarray
    box_min: np.ndarray | None = None
    box_max: np.ndarray | None = None
    wall_x: float | None = None


def _splits(a: float, b: float, spacing: float) -> np.ndarray:
    return np.linspace(a, b, max(1, int(math.ceil((b - a) / spacing - 1e-9))) + 1)


def _axis(breaks: Sequence[float], spacing: float) -> np.ndarray:
    parts = [_splits(breaks[i], breaks[i + 1], spacing) for i in range(len(breaks) - 1)]
    return np.unique(np.concatenate(parts))


def synthetic_scene_graph(
    spacing: float = 0.04,
    *,
    box_min: Sequence[float] | None = (0.6, -0.1, 0.0),
    box_max: Sequence[float] | None = (0.8, 0.1, 0.07),
    wall_x: float | None = 1.2,
    wall_height: float = 0.4,
    floor_x: tuple[float, float] = (0.2, 1.2),
    floor_y: tuple[float, float] = (-0.5, 0.5),
    diagonal_prob: float = 0.7,
    jitter: float = 0.25,
    noise: float = 0.0015,
    seed: int = 0,
) -> SyntheticScene:
    """Build a GNG-like graph of a floor (z = 0), an axis-aligned block and a wall.

    Each planar face (floor minus the block's footprint, block top, four block sides, wall front)
    is a rectangular lattice aligned on shared break lines, so faces share their boundary nodes.
    Each lattice quad gets one random diagonal with probability ``diagonal_prob`` and stays a
    quad otherwise — a GNG leaves such quads, which the detector must close — giving about
    2 + ``diagonal_prob`` edges per node, the ratio of a GNG on a surface. Nodes inside a face
    are jittered in the face plane by up to ``jitter`` × spacing; every node gets isotropic
    Gaussian noise of ``noise`` metres.

    Args:
        spacing: lattice spacing, metres.
        box_min: (3,) block min corner (its z is the floor, 0), or None for no block.
        box_max: (3,) block max corner.
        wall_x: x of the wall's front face (the floor ends there), or None for no wall (the
            floor ends at ``floor_x[1]``).
        wall_height: metres.
        floor_x: (x0, x1) floor extent, metres.
        floor_y: (y0, y1) floor (and wall) extent, metres.
        diagonal_prob: probability that a lattice quad gets a diagonal.
        jitter: in-plane jitter of face-interior nodes, fraction of ``spacing``.
        noise: standard deviation of the isotropic node noise, metres.
        seed: random seed.

    Returns:
        The scene; ``sensor_origin`` is (0, 0, 0.35) m, in front of and above everything.
    """
    rng = np.random.default_rng(seed)
    x0 = floor_x[0]
    x1 = floor_x[1] if wall_x is None else wall_x
    y0, y1 = floor_y
    has_box = box_min is not None and box_max is not None
    if has_box:
        bmin = np.asarray(box_min, dtype=np.float64)
        bmax = np.asarray(box_max, dtype=np.float64)
        xs = _axis([x0, bmin[0], bmax[0], x1], spacing)
        ys = _axis([y0, bmin[1], bmax[1], y1], spacing)
    else:
        bmin = bmax = None
        xs = _axis([x0, x1], spacing)
        ys = _axis([y0, y1], spacing)

    index: dict[tuple[int, int, int], int] = {}
    points: list[tuple[float, float, float]] = []
    # Per node: in-plane axes for jitter (a, b) and a count of faces/borders it lies on.
    axes: list[tuple[int, int]] = []
    border: list[int] = []
    edge_set: set[tuple[int, int]] = set()

    def node(x: float, y: float, z: float, plane: tuple[int, int], on_border: bool) -> int:
        key = (round(x * 1e7), round(y * 1e7), round(z * 1e7))
        i = index.get(key)
        if i is None:
            i = len(points)
            index[key] = i
            points.append((x, y, z))
            axes.append(plane)
            border.append(1 if on_border else 0)
        else:
            border[i] += 1
        return i

    def add(a: int, b: int) -> None:
        edge_set.add((min(a, b), max(a, b)))

    def face(grid_u: np.ndarray, grid_v: np.ndarray, to_xyz, plane, skip=None) -> None:
        nu, nv = len(grid_u), len(grid_v)
        ids = np.full((nu, nv), -1, np.int64)
        for i in range(nu):
            for j in range(nv):
                if skip is not None and skip(grid_u[i], grid_v[j]):
                    continue
                on_border = i in (0, nu - 1) or j in (0, nv - 1)
                ids[i, j] = node(*to_xyz(grid_u[i], grid_v[j]), plane, on_border)
        for i in range(nu - 1):
            for j in range(nv - 1):
                q = ids[i, j], ids[i + 1, j], ids[i + 1, j + 1], ids[i, j + 1]
                if min(q) < 0:
                    continue
                if skip is not None and skip(
                    0.5 * (grid_u[i] + grid_u[i + 1]), 0.5 * (grid_v[j] + grid_v[j + 1])
                ):
                    continue
                for k in range(4):
                    add(q[k], q[(k + 1) % 4])
                if rng.random() < diagonal_prob:
                    if rng.random() < 0.5:
                        add(q[0], q[2])
                    else:
                        add(q[1], q[3])

    eps = 1e-9

    def inside_footprint(x: float, y: float) -> bool:
        return bool(
            has_box and bmin[0] + eps < x < bmax[0] - eps and bmin[1] + eps < y < bmax[1] - eps
        )

    face(xs, ys, lambda x, y: (x, y, 0.0), (0, 1), skip=inside_footprint)
    if has_box:
        bx = xs[(xs >= bmin[0] - eps) & (xs <= bmax[0] + eps)]
        by = ys[(ys >= bmin[1] - eps) & (ys <= bmax[1] + eps)]
        bz = _splits(0.0, bmax[2], spacing)
        top = bmax[2]
        face(bx, by, lambda x, y: (x, y, top), (0, 1))
        face(by, bz, lambda y, z: (bmin[0], y, z), (1, 2))
        face(by, bz, lambda y, z: (bmax[0], y, z), (1, 2))
        face(bx, bz, lambda x, z: (x, bmin[1], z), (0, 2))
        face(bx, bz, lambda x, z: (x, bmax[1], z), (0, 2))
    if wall_x is not None:
        wz = _splits(0.0, wall_height, spacing)
        face(ys, wz, lambda y, z: (wall_x, y, z), (1, 2))

    pts = np.array(points, dtype=np.float64)
    n = len(pts)
    interior = np.array([b == 0 for b in border])
    for i in np.flatnonzero(interior):
        for ax in axes[i]:
            pts[i, ax] += rng.uniform(-jitter, jitter) * spacing
    pts += rng.normal(0.0, noise, size=pts.shape)
    perm = rng.permutation(n)
    inv = np.empty(n, np.int64)
    inv[perm] = np.arange(n)
    nodes = pts[perm]
    edges = inv[np.array(sorted(edge_set), dtype=np.int64)]
    edges = edges[rng.permutation(len(edges))]
    flip = rng.random(len(edges)) < 0.5
    edges[flip] = edges[flip][:, ::-1]
    return SyntheticScene(
        nodes=nodes,
        edges=np.ascontiguousarray(edges),
        sensor_origin=np.array([0.0, 0.0, 0.35]),
        box_min=None if bmin is None else bmin.copy(),
        box_max=None if bmax is None else bmax.copy(),
        wall_x=wall_x,
    )
