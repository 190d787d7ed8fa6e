"""The attention loop as one object (§4, Fig. 1, Algorithm 1).

    point cloud -> DD-GNG -> affordance detection -> suspected boxes -> DD-GNG (next cycle)

One :meth:`AttentionPipeline.step` is one control cycle: one DD-GNG learning cycle on the latest
frame (λ samples), then affordance detection on the graph. Per-stage wall times of the last step
are in :attr:`AttentionPipeline.timings`.

Attention memory (our choice, the paper leaves it open): an object box found by the affordance
detector keeps attracting attention for ``hold`` seconds after it was last reported, suspected
(density below v) or confirmed. Without the memory a confirmed object would drop out of the
attention as soon as its density crossed v, its nodes would lose their strength, the density
would fall below v again, and the attention would flicker. Boxes that overlap are merged into
the newest one. The same memory is the robot's short-term knowledge of obstacles it can no
longer see (under its body), which the effectivity uses for the hind legs.

Raw points round each object (``refine``, on by default; §4.1: "the raw data around the
suspected obstacle are processed separately"). The graph finds objects and says how sure it is
(density, ``suspected``); each object's height, width, length and box are then measured on the
frame's own points above the ground round it (``refine_objects_kernel``: gathered within
``refine_margin`` of the object, grown until stable, isolated stray points dropped, half a point
spacing added at each end). A GNG's nodes sit inside the surface they quantise, so node extents
fall short of a block's edges by about half a node spacing each side — 10–13 cm short on the
sparse nets of Table 2 (``scripts/bench_affordance_accuracy.py``). On dense noisy frames the
outermost points overshoot instead: among hundreds of points near an edge, the ones whose range
noise carried them farthest set the extent (+1.2 cm median on the length at the ToF's full
resolution with 1 % noise). ``refine_noise`` estimates the range noise from the frame's floor
and, at each end where that noise exceeds the mean point spacing, takes the expected overshoot
out (simulation-extrapolation); a noise-free frame is left as it was, and so are ends whose
point spacing exceeds their noise (the boxes at the default 56 × 43 resolution, where the
outermost sample falls short of the edge by about half a spacing and the noise mostly fills that
gap: correcting there too lowered "all three" from 89 % to 85 %, the noise-free figure,
re-measured offline on the benchmark's end-state frames). Two checks ride on it:

* ``verify``: an object without a single raw point above the ground tolerance round it is a
  graph artefact (a node behind a new block, pulled up by the points on its top) and is
  relabelled terrain, so it is never attended.
* ``view_cut``: an object whose highest points touch the upper edge of the view (the largest
  elevation seen from the sensors in their azimuth) is the foot of something taller whose top
  is out of sight — a wall seen by sensors pitched 45° down — and is relabelled wall.
* ``view_wall_width``: the same cut seen on the raw points alone, for walls the graph misses.
  A wall 0.9–1.1 m ahead shows the sensors only a 2–8 cm strip at its foot; the sparse net of
  Table 2 puts one to four nodes there, less than 2 cm up, in flat facets of the floor's
  region, so the graph has nothing to label (``scripts/bench_affordance_accuracy.py``: 44 of
  the 94 seen walls). Every frame, the points higher than the ground tolerance that lie at the
  upper edge of the view (within ``view_cut``) are grouped into runs of adjacent azimuth bins
  (``view_walls_kernel``); a run spanning at least ``view_wall_width`` across the walking
  direction — wider than any block the robot steps over — and not overlapping a wall label
  already found is added as a wall label of its own, with no facets (``n_nodes`` 0, ``size``
  and ``density`` 0, ``gamma`` 90°, ``normal`` horizontal towards the sensors, ``height`` the
  top of the strip seen: a lower bound). Objects are left as they are: the rule adds walls,
  it never removes or relabels an object, so the attention and the env's obstacles do not
  change. On a floor with fewer raised points than ``refine_min_points`` it costs one pass
  over the frame's heights.

``timings`` has a ``"refine"`` entry for this step (0 when there is no object).

Two affordance sources (``PipelineParams.affordance_source``): everything above is the
``"points"`` source, this project's addition and the default. ``"map"`` is the paper's
(§4.2.1): no raw point is read after the learning cycle; each object's measures come from the
graph's nodes and facets, with the map-mode steps (:meth:`AttentionPipeline._detect_map`):
heights against the floor plane of the terrain nodes, overlapping object labels merged (not a
label at the view edge), width and length grown by the node spacing at the edges (boundary
handling; with ``map_rect``, from the minimum-area rectangle round the high nodes at least half
the height up, projected on the walking axes), the box (Algorithm 3's A_min/A_max, hence the
attention box) on the high nodes and, with ``map_attend_above``, starting at the ground
tolerance above the floor plane, and objects at the top of the graph's own view relabelled wall.
In "map" mode these steps are compiled into the detection's call, and the ``"affordance"``
timing holds both (``"refine"`` is 0).
``scripts/bench_affordance_map.py`` measures both sources.
"""

from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass, replace

import numpy as np

from neurocog_gym.perception import _affordance_kernels as _k
from neurocog_gym.perception.affordance import (
    AffordanceObject,
    AffordanceParams,
    Affordances,
    _check_graph,
    _empty_result,
    _forward_xy,
    _origin,
    assemble,
    detect_affordances,
)
from neurocog_gym.perception.gng import DDGNG, GNG, MLGNG, DDGNGParams

GNG_KINDS = {"ddgng": DDGNG, "gng": GNG, "mlgng": MLGNG}
AFFORDANCE_SOURCES = ("map", "points")
"""``PipelineParams.affordance_source`` values: the paper's map, or the raw points round it."""

_NOISE_DRAWS = np.random.default_rng(0).standard_normal((64, 512))
"""Fixed standard normal draws of the noise-overshoot estimate (``refine_noise``)."""
_NOISE_DRAWS.flags.writeable = False


@dataclass(frozen=True)
class PipelineParams:
    """Attention-loop settings."""

    gng: str = "ddgng"
    """Topological map: "ddgng" (attention on), "gng" (attention off), "mlgng" (baseline)."""
    affordance_source: str = "points"
    """Where the objects' sizes come from: "map" (the paper's, §4.2.1: position, normal, γ,
    A_h, A_w, A_s from the graph's nodes and facets only, with the map-mode steps below) or
    "points" (this project's addition: the raw-point refinement, ``refine`` and the checks
    that ride on it). In "map" mode ``refine`` and the raw-point checks are not run."""
    map_merge: bool = True
    """"map" mode: object labels whose boxes overlap in the ground plane are one object (a
    sparse net splits a block's facets into pieces)."""
    map_edge_correction: float = 1.5
    """"map" mode, boundary handling: the high nodes' extents grow by this × their spacing
    (the median edge length between them), 0.75 spacing at each end; 0 = off. Half a
    spacing (1.0) is the Voronoi argument; measured on 40 scenes of seed 1 (the benchmark
    uses seed 0): 0 of 40 all three sizes within tolerance with 1.0, 5 with 1.5, 2 with 2.0
    (the back edge of a block, seen at a grazing angle, holds fewer nodes). Re-checked with
    ``map_view_first``, ``map_box_from_high`` and ``map_floor_plane`` on 100 scenes of
    series 1: all three 4 % with 1.0, 13 % with 1.25, 10 % with 1.5 (kept)."""
    map_rect: bool = True
    """"map" mode, boundary handling (§4.2.1's A_w, A_s): width and length are those of the
    high nodes' minimum-area rectangle (rotating calipers on their convex hull), each side
    grown by ``map_rect_correction`` × their spacing, projected across and along the walking
    direction, not the nodes' own extents on those axes. The blocks lie at any yaw; the nodes
    on one sit inside its edges and are rarest at its corners, which set a yawed block's
    extents on the walking axes: the extents fell short there, the rectangle's sides follow
    the edges where the nodes are. With ``map_attend_above`` (issue 23, 100 scenes of
    ``scripts/bench_affordance_map.py``; docs/perception.md)."""
    map_rect_correction: float = 0.5
    """"map" mode, with ``map_rect``: each side of the rectangle grows by this × the high nodes'
    spacing (a quarter spacing at each edge). Smaller than ``map_edge_correction``: the
    rectangle's sides already lie on the outermost nodes of each edge, and the nodes on a
    block's visible side faces stand at its edge, not inside it."""
    map_rect_height: float = 0.5
    """"map" mode, with ``map_rect``: the rectangle is taken round the high nodes at least this
    share of A_h above the floor; the lower high nodes are the bevel nodes a GNG hangs between
    a block's top edge and the floor, 2–5 cm up and up to 10 cm outside its footprint."""
    map_attend_above: bool = True
    """"map" mode, Algorithm 3's A_min/A_max = Ob^(pos) ∓ Ob^(size)/2 in three dimensions:
    the attention box of an object (the memory, Algorithm 1's "random of P in suspected
    obstacle" and Algorithm 3's δ) starts at the ground tolerance above the floor plane, the
    bottom of the object's high part, not ``suspect_padding`` below its lowest node. The
    box's floor points round a block (its ground-plane box is grown by the edge correction and
    the padding) held more than half of the attended inputs and drew the δ-weighted
    insertions onto the floor; above the floor they fall on the block's top and side faces
    (9–10 → 16–17 nodes on the block after 0.5 s). "points" mode keeps the padded box."""
    map_view_cut: float = 0.02
    """"map" mode: an object whose high nodes reach the upper edge of the view as the graph
    shows it (the largest node elevation in their azimuth bin, within this tan, ≈ 1.1°) is
    relabelled wall; < 0 switches the rule off. 0.02 (was 0): a wall foot's fragments whose
    high nodes sit just below the wall label's own stay objects at 0, so the wall was not
    classed wall (``scripts/bench_affordance_map.py``, 100 scenes, wall is wall 66 % → 82 %
    on series 0 and 63 % → 78 % on series 1; all three sizes 16 % → 10 % and 10 % → 12 %,
    within the run-to-run spread of the attention loop)."""
    map_view_bins: int = 16
    """"map" mode: azimuth bins of the graph's view edge (tan(azimuth) in [-4, 4])."""
    map_view_first: bool = True
    """"map" mode, §4.2.1 segmentation: the view edge (``map_view_cut``) is read on each object
    label alone before the merge, and a label at the view edge is merged with none. A wall's
    foot seen as an object label has a box that spans the block in front of it, so merged
    first, the block went into the wall label: 24 of the 100 scenes had no object on the block
    (issue 23, ``scripts/bench_affordance_map.py``, series 0: object found 76 % → 85 %)."""
    map_box_from_high: bool = True
    """"map" mode, Algorithm 3's A_min/A_max = Ob^(pos) ∓ Ob^(size)/2: an object's box in the
    ground plane is its high nodes' (those on the block, higher than the ground tolerance)
    grown by half the edge correction, not all the nodes of its facets (the bevel facets'
    floor nodes lie 10–20 cm round a block on Table 2's net). The attention box (the memory,
    Algorithm 1's "random of P in suspected obstacle") is this box padded, so the attended
    inputs fall on the block, not on the floor round it. Series 0, 100 scenes, with
    ``map_view_first``: found 85 % → 96 %, height within 1 cm 50 % → 76 %."""
    map_floor_plane: bool = True
    """"map" mode, A_h against the floor: the ground level is the median height of the terrain
    facets' distinct nodes (the floor plane as the map holds it), not the detection's
    area-weighted height of the floor region, which the raised facets at a block's and a
    wall's foot lift by 0.3–1.4 cm. Heights of the objects and the high-node test use it, and
    ``Affordances.ground_z`` reports it (labels other than objects keep the detection's
    heights). Series 0, 100 scenes, with the two above: height within 1 cm 76 % → 95 %,
    all three 9 % → 16 %."""
    hold: float = 1.5
    """s: how long an object box stays in the attention memory after it was last detected."""
    max_boxes: int = 8
    """Most boxes kept in memory (oldest dropped first)."""
    min_height: float = 0.025
    """m: objects lower than this are ignored (GNG ripples on a flat floor)."""
    refine: bool = True
    """Measure each object's height, width and length on the frame's raw points round it."""
    verify: bool = True
    """With ``refine``: an object without a single raw point higher than the ground tolerance
    within ``refine_margin`` of it is relabelled terrain (never attended, never reported)."""
    view_cut: float = 0.02
    """With ``refine``: an object whose highest raw points lie within this (tan of the elevation
    angle, ≈ 1.1°) of the view's upper edge in their azimuth is cut off by the field of view and
    relabelled wall (its top is out of sight); < 0 switches the rule off."""
    view_wall_width: float = 0.3
    """m, with ``refine``: raw points cut off by the top of the view (``view_cut``) across at
    least this span (across the walking direction; wider than the 30 cm blocks of §6.4) are a
    wall label even where the graph has no facet on them; <= 0 switches the rule off."""
    refine_margin: float = 0.04
    """m: search margin round an object's extent when gathering its raw points."""
    refine_iters: int = 10
    """Growing iterations of the raw-point extent (see ``refine_objects_kernel``)."""
    refine_min_points: int = 8
    """Objects with fewer raw points round them keep the graph's measures."""
    refine_quantile: float = 0.0
    """Share of the raw points cut off at each end of an extent (0: keep them all)."""
    refine_gap: float = 0.03
    """m: an extent's end point farther than this from the next point inwards is a stray
    point (range noise) and dropped, repeatedly."""
    refine_noise: bool = True
    """Noise-aware extent ends: the range noise σ/d is estimated on the frame's floor points
    (``noise_level_kernel``) and each end whose noise exceeds the mean point spacing is moved
    back by the outermost noisy points' expected overshoot (``refine_objects_kernel``). No
    effect on a noise-free frame. ``scripts/bench_affordance_accuracy.py --scale 1.0``, 1 %
    noise: "all three" 84 % → 92 % (50 scenes; length error +1.2 → +0.5 cm median) and 85 %
    → 92 % (100 scenes; noise-free 95 %); at the default resolution the boxes' measures are
    unchanged (100 scenes), only dense wall-foot strips trigger it."""
    refine_edge: float = 1.0
    """Edge correction: each end of an extent moves out by this × half the mean raw-point
    spacing on the object, sqrt(footprint / points); 0 = off."""

    def __post_init__(self):
        if self.gng not in GNG_KINDS:
            raise ValueError(
                f"PipelineParams.gng must be one of {sorted(GNG_KINDS)}, got {self.gng!r}"
            )
        if not self.hold >= 0:
            raise ValueError(f"PipelineParams.hold must be >= 0, got {self.hold}")
        if self.affordance_source not in AFFORDANCE_SOURCES:
            raise ValueError(
                f"PipelineParams.affordance_source must be one of {AFFORDANCE_SOURCES}, "
                f"got {self.affordance_source!r}"
            )
        if not (math.isfinite(self.map_edge_correction) and self.map_edge_correction >= 0):
            raise ValueError(
                f"PipelineParams.map_edge_correction must be >= 0, got {self.map_edge_correction}"
            )
        if not (math.isfinite(self.map_rect_correction) and self.map_rect_correction >= 0):
            raise ValueError(
                f"PipelineParams.map_rect_correction must be >= 0, got {self.map_rect_correction}"
            )
        if not (isinstance(self.map_view_bins, int) and self.map_view_bins >= 1):
            raise ValueError(
                f"PipelineParams.map_view_bins must be an int >= 1, got {self.map_view_bins!r}"
            )

    @functools.cached_property
    def map_packed(self) -> np.ndarray:
        """(N_MAP_PARAMS,) float64: the map settings as ``map_step_kernel`` reads them (once)."""
        mq = np.empty(_k.N_MAP_PARAMS)
        mq[_k.Q_MERGE] = 1.0 if self.map_merge else 0.0
        mq[_k.Q_VIEW_BINS] = self.map_view_bins
        mq[_k.Q_EDGE_CORRECTION] = self.map_edge_correction
        mq[_k.Q_VIEW_CUT] = self.map_view_cut
        mq[_k.Q_MIN_HEIGHT] = self.min_height
        mq[_k.Q_HIGH_BOX] = 1.0 if self.map_box_from_high else 0.0
        mq[_k.Q_VIEW_FIRST] = 1.0 if self.map_view_first else 0.0
        mq[_k.Q_FLOOR_PLANE] = 1.0 if self.map_floor_plane else 0.0
        mq[_k.Q_RECT] = 1.0 if self.map_rect else 0.0
        mq[_k.Q_RECT_CORRECTION] = self.map_rect_correction
        mq[_k.Q_RECT_HEIGHT] = self.map_rect_height
        mq.flags.writeable = False
        return mq

    @functools.cached_property
    def map_packed_known_ground(self) -> np.ndarray:
        """:attr:`map_packed` for a given ground level: the floor-plane step off."""
        mq = self.map_packed.copy()
        mq[_k.Q_FLOOR_PLANE] = 0.0
        mq.flags.writeable = False
        return mq


def _overlap(a, b) -> bool:
    """Do boxes ``[[x0, y0, z0], [x1, y1, z1]]`` (nested lists of floats) overlap?"""
    (a0, a1), (b0, b1) = a, b
    return (
        a0[0] <= b1[0] and a0[1] <= b1[1] and a0[2] <= b1[2]
        and b0[0] <= a1[0] and b0[1] <= a1[1] and b0[2] <= a1[2]
    )  # fmt: skip


class _Frame:
    """One step's raw-point inputs, checked once.

    The frame, the walking direction, the sensors' position, and the view's upper edge
    (``view_edge_kernel``), computed on first use and shared by the raw-point steps.
    """

    __slots__ = ("pts", "fx", "fy", "origin", "view_cache")

    def __init__(self, pts, fx, fy, origin):
        self.pts, self.fx, self.fy, self.origin = pts, fx, fy, origin
        self.view_cache = None

    def view(self):
        if self.view_cache is None:
            self.view_cache = _k.view_edge_kernel(self.pts, self.fx, self.fy, self.origin, 64, 4.0)
        return self.view_cache


def _frame_inputs(aff: Affordances, points, forward, sensor_origin) -> _Frame | None:
    """The checked inputs of the raw-point steps, or None when they cannot run."""
    pts = np.asarray(points)
    if pts.ndim != 2 or pts.shape[1] != 3 or len(pts) == 0 or not math.isfinite(aff.ground_z):
        return None
    if pts.dtype not in (np.float32, np.float64) or not pts.flags.c_contiguous:
        pts = np.ascontiguousarray(pts, dtype=np.float64)
    fwd = np.asarray(forward, dtype=np.float64).reshape(-1)
    h = float(np.hypot(fwd[0], fwd[1]))
    if not h > 1e-9:
        return None
    origin = np.asarray(sensor_origin, dtype=np.float64).reshape(-1)
    if origin.shape != (3,) or not all(map(math.isfinite, origin.tolist())):
        return None
    # Python floats, not NumPy scalars: the box arithmetic is scalar.
    return _Frame(pts, float(fwd[0]) / h, float(fwd[1]) / h, origin)


class AttentionPipeline:
    """DD-GNG + affordance detection with the attention loop closed.

    Args:
        seed: seed of the topological map's random stream.
        params: loop settings.
        gng_params: DD-GNG parameters (Table 2 defaults).
        affordance_params: affordance-detection parameters.
        affordance_source: "map" or "points", overriding ``params.affordance_source``; None
            keeps it.
    """

    def __init__(
        self,
        seed: int = 0,
        params: PipelineParams | None = None,
        gng_params: DDGNGParams | None = None,
        affordance_params: AffordanceParams | None = None,
        affordance_source: str | None = None,
    ):
        self.params = params or PipelineParams()
        if affordance_source is not None:
            self.params = replace(self.params, affordance_source=affordance_source)
        self.affordance_params = affordance_params or AffordanceParams()
        self.net = GNG_KINDS[self.params.gng](seed=seed, params=gng_params)
        self.memory_boxes = np.zeros((0, 2, 3))
        self.memory_time = np.zeros(0)
        self.last: Affordances | None = None
        self.timings = {"gng": 0.0, "affordance": 0.0, "total": 0.0}
        self.n_steps = 0

    def reset(self, seed: int | None = None) -> None:
        """Forget the graph and the attention memory."""
        self.net.reset(seed)
        self.memory_boxes = np.zeros((0, 2, 3))
        self.memory_time = np.zeros(0)
        self.last = None
        self.n_steps = 0

    @property
    def attention_boxes(self) -> np.ndarray:
        """(K, 2, 3) boxes the DD-GNG attends to in the next cycle, metres."""
        return self.memory_boxes

    def step(
        self,
        points: np.ndarray,
        sensor_origin: np.ndarray,
        t: float,
        forward=(1.0, 0.0, 0.0),
        ground_z: float | None = None,
    ) -> Affordances:
        """One control cycle of the attention loop.

        Args:
            points: (N, 3) float, metres, world frame: the latest point-cloud frame.
            sensor_origin: (3,) metres, where the sensors are (facet normals face it).
            t: simulated time, s (ages the attention memory).
            forward: (3,) walking direction (width is across it, length along it).
            ground_z: metres, known ground level, or None to estimate it from the graph.

        Returns:
            The affordances detected on this cycle's graph.
        """
        return self._step(points, sensor_origin, t, forward, ground_z, None)

    def warm_up(
        self, points: np.ndarray, sensor_origin: np.ndarray, cycles: int, forward=(1.0, 0.0, 0.0)
    ) -> Affordances | None:
        """Run ``cycles`` control cycles at t = 0 on one unchanging frame (the map's warm-up).

        The same as ``cycles`` calls of :meth:`step` with these arguments, result for result;
        the frame's view of the raw-point steps (``view_edge_kernel``) is computed once instead
        of once per cycle, as nothing can change the frame between the cycles here.

        Returns:
            The last cycle's affordances (None if ``cycles`` is 0).
        """
        if cycles < 0:
            raise ValueError(f"cycles must be >= 0, got {cycles}")
        holder = [None]
        aff = None
        for _ in range(int(cycles)):
            aff = self._step(points, sensor_origin, 0.0, forward, None, holder)
        return aff

    def _step(self, points, sensor_origin, t, forward, ground_z, holder) -> Affordances:
        """One cycle of :meth:`step`.

        ``holder``: a one-slot list keeping the frame's inputs between calls on the same frame
        (:meth:`warm_up`), or None.
        """
        t0 = time.perf_counter()
        boxes = self.memory_boxes if len(self.memory_boxes) else None
        self.net.update(points, boxes)
        t1 = time.perf_counter()
        if self.params.affordance_source == "map":
            aff = self._detect_map(sensor_origin, forward, ground_z)
            t2 = t3 = time.perf_counter()
        else:
            aff = detect_affordances(
                self.net.nodes, self.net.edges, sensor_origin, self.affordance_params,
                forward=forward, ground_z=ground_z,
            )  # fmt: skip
            t2 = time.perf_counter()
            aff = self._objects(aff, points, sensor_origin, forward, holder)
            t3 = time.perf_counter()
        self._remember(aff, t)
        self.last = aff
        self.n_steps += 1
        self.timings = {
            "gng": t1 - t0,
            "affordance": t2 - t1,
            "refine": t3 - t2,
            "total": time.perf_counter() - t0,
        }
        return aff

    def detect(
        self,
        sensor_origin: np.ndarray,
        forward=(1.0, 0.0, 0.0),
        ground_z: float | None = None,
        points: np.ndarray | None = None,
    ) -> Affordances:
        """The affordance half of a :meth:`step` on the current graph, nothing learned.

        :func:`detect_affordances` on the map, then the source's object steps (the map-mode
        steps of :meth:`_detect_map`, or the raw-point refinement on ``points``), exactly as
        :meth:`step` does after its learning cycle; the attention memory, :attr:`last` and
        :attr:`timings` are left alone. This is the per-frame detection the §7.2 figure
        (0.136 ms) is about (``scripts/bench_affordance.py`` times it).

        Args:
            sensor_origin: (3,) metres, where the sensors are (facet normals face it).
            forward: (3,) walking direction (width is across it, length along it).
            ground_z: metres, known ground level, or None to estimate it from the graph.
            points: (N, 3) float, metres: the frame, read only in "points" mode (None there:
                the graph's measures are kept).

        Returns:
            The affordances on the current graph.
        """
        if self.params.affordance_source == "map":
            return self._detect_map(sensor_origin, forward, ground_z)
        aff = detect_affordances(
            self.net.nodes, self.net.edges, sensor_origin, self.affordance_params,
            forward=forward, ground_z=ground_z,
        )  # fmt: skip
        return self._objects(aff, points, sensor_origin, forward, None)

    def _objects(self, aff, points, sensor_origin, forward, holder) -> Affordances:
        """The "points" source's steps after :func:`detect_affordances` (one cycle)."""
        walls = self.params.view_wall_width > 0.0 and self.params.view_cut >= 0.0
        if self.params.refine and (aff.obstacles or walls):
            if holder is None:
                frame = _frame_inputs(aff, points, forward, sensor_origin)
            else:
                frame = holder[0]
                if frame is None:
                    frame = holder[0] = _frame_inputs(aff, points, forward, sensor_origin)
                elif not math.isfinite(aff.ground_z):
                    frame = None
            if frame is not None and aff.obstacles:
                aff = self._refine(aff, points, forward, sensor_origin, frame)
            if frame is not None and walls:
                aff = self._view_walls(aff, points, forward, sensor_origin, frame)
        return aff

    def _detect_map(self, sensor_origin, forward, ground_z) -> Affordances:
        """Detection and the map-mode object steps ("map" mode, §4.2.1; module docstring).

        The steps on the graph's nodes and facets, nothing from the raw points, compiled
        into one call with the detection (``_affordance_kernels.detect_map_kernel``: the
        detection, then ``map_step_kernel``'s steps):

        * *floor plane* (``map_floor_plane``, unless ``ground_z`` is given): the ground level
          is the median height of the terrain facets' nodes; A_h and the high-node test are
          read against it.
        * *view edge first* (``map_view_first``): an object label whose own high nodes reach
          the view edge (below) is merged with no other label.
        * *fragments*: object labels whose boxes overlap in the ground plane are one object
          (``map_merge``); position and normal are the facet-count-weighted means of the
          pieces' (the mean facet centre and normal, Ob^(pos) and Ob^(v)), size the sum.
        * *boundary handling*: width and length are the extents of the object's nodes higher
          than the ground tolerance plus ``map_edge_correction`` × their spacing (a GNG node
          sits about half a spacing inside the edge of the surface it quantises); the box is
          the high nodes' (``map_box_from_high``; else all the object's nodes') grown by the
          same half spacing in the ground plane, so Algorithm 3's A_min/A_max and Algorithm
          1's attended samples cover the block and its edges.
        * *view edge*: an object whose high nodes are the highest (in elevation, seen from
          the sensors) of the graph in their azimuth, within ``map_view_cut``, is the foot of
          something whose top is out of sight (a wall beyond the 45°-pitched sensors'
          reach): relabelled wall, so it is never attended.

        The result objects are built once, from the kernels' arrays: until the steps were
        compiled (issue 23, §7.2's 0.136 ms) they ran in Python on ``detect_affordances``'s
        objects and cost as much as the detection itself at 300 nodes
        (``scripts/bench_affordance.py``). Without ``sensor_origin`` the steps are skipped.
        """
        p, ap = self.params, self.affordance_params
        nodes, edges = self.net.nodes, self.net.edges
        if sensor_origin is None:
            return detect_affordances(nodes, edges, None, ap, forward, ground_z)
        # The checks of detect_raw, then the detection and the steps in one compiled call.
        nodes, edges = _check_graph(nodes, edges)
        origin, _ = _origin(sensor_origin)
        fx, fy = _forward_xy(forward)
        if ground_z is not None and not math.isfinite(ground_z):
            raise ValueError(f"ground_z must be finite or None, got {ground_z!r}")
        if nodes.shape[0] < 3 or edges.shape[0] < 3:
            return _empty_result(ground_z)
        if ground_z is None:
            mode, ground, mq = 0, 0.0, p.map_packed
        else:
            mode, ground, mq = _k.MODE_GROUND_KNOWN, float(ground_z), p.map_packed_known_ground
        n_bad, truncated, ground, facets, *arrays, merged = _k.detect_map_kernel(
            nodes, edges, origin, fx, fy, ground, mode, ap.packed, mq
        )
        if n_bad:
            raise ValueError(f"{n_bad} edges index nodes outside [0, {nodes.shape[0]})")
        if facets.shape[0] == 0:
            return _empty_result(ground_z)
        if len(merged):
            # The merged normals come unnormalised: normalised as np.linalg.norm does it,
            # sqrt(x . x) (its rounding differs from sqrt(x² + y² + z²) in one case in ten),
            # in the kernel's arrays before the records are made from them.
            # (The divisions on Python floats round as NumPy's.)
            lab, normal = arrays[2], arrays[4]
            for j in merged.tolist():
                nsum = normal[j]
                nn = math.sqrt(float(nsum.dot(nsum)))
                if nn > 1e-12:
                    x, y, z = nsum.tolist()
                    z /= nn
                    normal[j] = (x / nn, y / nn, z)
                    lab[j, _k.L_GAMMA] = math.acos(min(1.0, max(-1.0, z)))
                else:
                    normal[j] = 0.0
                    lab[j, _k.L_GAMMA] = 0.0
        aff = assemble(ground, truncated, facets, *arrays)
        return aff

    def _refine(
        self, aff: Affordances, points: np.ndarray, forward, sensor_origin, frame=None
    ) -> Affordances:
        """Objects' height, width, length and box from the raw points round them.

        The graph finds the objects and says how sure it is (density, ``suspected``); their
        sizes are read on the frame itself ("the raw data around the suspected obstacle are
        processed separately", §4.1): a GNG's nodes sit inside the surface they quantise, so
        node extents fall short of a block's edges by about half a node spacing on each side.
        ``frame``: the step's :class:`_Frame` (built here if None).
        """
        frame = frame or _frame_inputs(aff, points, forward, sensor_origin)
        if frame is None:
            return aff
        pts, fx, fy, origin = frame.pts, frame.fx, frame.fy, frame.origin
        slope, bins, edge = frame.view()
        idx = [i for i, o in enumerate(aff.objects) if o.kind == "object"]
        boxes = np.array([aff.objects[i].box for i in idx], dtype=np.float64)
        ap = self.affordance_params
        p = self.params
        g = float(aff.ground_z)
        noise = (
            _k.noise_level_kernel(pts, g, ap.ground_tolerance, origin[2]) if p.refine_noise else 0.0
        )
        res = _k.refine_objects_kernel(
            pts, boxes, g, ap.ground_tolerance, p.refine_margin, fx, fy, p.refine_iters,
            p.refine_quantile, 0.9, p.refine_gap, origin, slope, bins, edge, noise, _NOISE_DRAWS,
        )  # fmt: skip
        objects = list(aff.objects)
        g = float(aff.ground_z)
        relabelled = False
        # Scalar arithmetic on Python floats (the same IEEE operations as NumPy's, without its
        # per-call overhead on 4-element arrays).
        for row, i in zip(res.tolist(), idx, strict=True):
            if not row[0] > 0 and p.verify:
                # Not one raw point stands above the floor round it: a GNG artefact (e.g. a
                # node behind a new obstacle pulled up by the points on its top), not an object.
                objects[i] = objects[i]._replace(kind="terrain", suspected=False)
                relabelled = True
                continue
            if not row[0] >= p.refine_min_points:
                continue
            o = objects[i]
            f0, f1, l0, l1 = row[4:8]
            # Raw-point spacing on the object, sqrt(footprint / points): the outermost samples
            # stop short of an edge by about half a spacing on each side.
            e = 0.5 * p.refine_edge * math.sqrt(max(f1 - f0, 0.0) * max(l1 - l0, 0.0) / row[0])
            f0, f1, l0, l1 = f0 - e, f1 + e, l0 - e, l1 + e
            cx = (f0 * fx - l0 * fy, f1 * fx - l0 * fy, f1 * fx - l1 * fy, f0 * fx - l1 * fy)
            cy = (f0 * fy + l0 * fx, f1 * fy + l0 * fx, f1 * fy + l1 * fx, f0 * fy + l1 * fx)
            box = np.array(
                [[min(cx), min(cy), min(float(o.box[0, 2]), g)], [max(cx), max(cy), g + row[1]]]
            )
            o = o._replace(height=row[1], width=l1 - l0, length=f1 - f0, box=box)
            if p.view_cut >= 0.0 and row[8] <= p.view_cut and row[1] >= p.min_height:
                # The top of the field of view cuts this surface off: what is seen is the foot
                # of something taller (a wall beyond the 45°-pitched sensors' reach), not a
                # block whose top is in sight. Its height is then only a lower bound.
                o = o._replace(kind="wall", suspected=False)
                relabelled = True
            objects[i] = o
        kinds, sboxes = aff.label_kinds, aff.suspected_boxes
        if relabelled:
            kinds = tuple(o.kind for o in objects)
            boxes_s = [
                o.box + np.array([[-ap.suspect_padding] * 3, [ap.suspect_padding] * 3])
                for o in objects
                if o.kind == "object" and o.suspected
            ]
            sboxes = np.array(boxes_s).reshape(-1, 2, 3)
        return Affordances(
            objects, sboxes, aff.facets, aff.facet_normals, aff.facet_labels, kinds,
            aff.ground_z, aff.truncated,
        )  # fmt: skip

    def _view_walls(
        self, aff: Affordances, points: np.ndarray, forward, sensor_origin, frame=None
    ) -> Affordances:
        """Add a wall label for each wide run of raw points cut off by the top of the view.

        See ``view_wall_width`` in the module docstring. Labels already present are kept as
        they are; the new labels have no facets. ``frame``: the step's :class:`_Frame`.
        """
        frame = frame or _frame_inputs(aff, points, forward, sensor_origin)
        if frame is None:
            return aff
        p = self.params
        tol = self.affordance_params.ground_tolerance
        g = float(aff.ground_z)
        # Most frames (a floor, a low block) hold fewer raised points than a run needs.
        if frame.view_cache is None and _k.count_above(frame.pts, g + tol) < p.refine_min_points:
            return aff
        slope, bins, edge = frame.view()
        runs = _k.view_walls_kernel(
            frame.pts, g, tol, frame.fx, frame.fy, slope, bins, edge, p.view_cut,
            p.view_wall_width, p.refine_min_points,
        )  # fmt: skip
        origin = frame.origin
        if len(runs) == 0:
            return aff
        g = float(aff.ground_z)
        walls = [o.box for o in aff.objects if o.kind == "wall"]
        added = []
        for _n, top, x0, y0, x1, y1, mx, my, mz, width, length in runs.tolist():
            box = np.array([[x0, y0, g], [x1, y1, g + top]])
            if any(b[0, 0] <= x1 and x0 <= b[1, 0] and b[0, 1] <= y1 and y0 <= b[1, 1]
                   for b in walls):  # fmt: skip
                continue
            # Facing the sensors, horizontal: a surface rising out of sight.
            dx, dy = origin[0] - mx, origin[1] - my
            r = math.hypot(dx, dy)
            normal = np.array([dx / r, dy / r, 0.0]) if r > 1e-9 else np.zeros(3)
            added.append(
                AffordanceObject(
                    "wall",
                    np.array([mx, my, mz]),
                    top,
                    width,
                    length,
                    math.pi / 2,
                    0.0,
                    normal,
                    0.0,
                    0,
                    box,
                    False,
                )  # fmt: skip
            )
        if not added:
            return aff
        objects = list(aff.objects) + added
        return Affordances(
            objects, aff.suspected_boxes, aff.facets, aff.facet_normals, aff.facet_labels,
            aff.label_kinds + ("wall",) * len(added), aff.ground_z, aff.truncated,
        )  # fmt: skip

    def _remember(self, aff: Affordances, t: float) -> None:
        pad = self.affordance_params.suspect_padding
        found = [
            o.box + np.array([[-pad, -pad, -pad], [pad, pad, pad]])
            for o in aff.obstacles
            if o.height >= self.params.min_height
        ]
        if found and self.params.affordance_source == "map" and self.params.map_attend_above:
            # Algorithm 3's box in 3-D: the object's high part, above the floor (map_attend_above).
            floor = float(aff.ground_z) + self.affordance_params.ground_tolerance
            for b in found:
                b[0, 2] = min(max(b[0, 2], floor), b[1, 2])
        if not found and (not any(t - tm > self.params.hold for tm in self.memory_time.tolist())):
            return  # nothing new and nothing expired (the memory never exceeds max_boxes)
        # Boxes as nested lists of floats: the overlap tests are plain comparisons.
        boxes = self.memory_boxes.tolist()
        times = self.memory_time.tolist()
        for box in found:
            b = box.tolist()
            keep = [i for i, m in enumerate(boxes) if not _overlap(m, b)]
            boxes = [boxes[i] for i in keep] + [b]
            times = [times[i] for i in keep] + [t]
        alive = [i for i, tm in enumerate(times) if t - tm <= self.params.hold]
        alive = alive[-self.params.max_boxes :]
        self.memory_boxes = np.array([boxes[i] for i in alive], dtype=np.float64).reshape(-1, 2, 3)
        self.memory_time = np.array([times[i] for i in alive], dtype=np.float64)
