"""Shared machinery of the perception figures and benchmarks (issues 3 and 4).

Used by ``scripts/fig9_density.py``, ``attention_timing.py``, ``plot_similarity.py``,
``plot_graph_cloud.py``, ``bench_affordance_accuracy.py`` and ``bench_affordance_map.py``.

Two kinds of scene, both in the robot's own MuJoCo world (``assets/scene.xml``) and sensed by
the robot's four ToF sensors (:class:`neurocog_gym.robot.tof.ToFArray`) at their frame rate:

* :func:`walking_trial` — the robot trots in ``NeuroCog/Walk-v3`` (zero action = plain CPG
  walking); after ``t_appear`` seconds a wooden block appears ahead of it (a mocap block of
  :class:`~neurocog_gym.robot.obstacles.ObstaclePool`, as in ``SuddenObstacle-v3``). Several
  attention pipelines (DD-GNG, GNG, ...) are fed the *same* frames; each control cycle
  (0.01 s) every pipeline runs one learning cycle on the latest frame and detects affordances,
  exactly as ``envs/obstacle.py`` does (``per_frame=True`` variants learn only when a new
  frame arrives). The warm-up is the env's: ``warmup_cycles`` cycles on the first frame.
* :class:`StaticScene` — the robot stands (its home pose, physics not stepped) in front of a
  floor + box + wall arrangement; simulated time advances by control cycles and the sensors
  produce frames at their rate (for the affordance-accuracy benchmark).

Region measures (our definitions, used identically for every variant): the *obstacle region*
is the block's footprint grown by ``pad`` on every side, from the floor to ``pad`` above its
top; "on the obstacle" are the region's nodes higher than ``on_tol`` above the floor. Node
density is per m² of ground: region nodes / padded footprint area, and the other nodes /
(area the frame covers − padded footprint), the covered area being the number of occupied
5 cm × 5 cm cells of the frame's points.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import gymnasium as gym
import mujoco
import numpy as np

import neurocog_gym  # noqa: F401  (registers the env ids)
from neurocog_gym.io import atomic_write_text
from neurocog_gym.perception.affordance import AffordanceParams, Affordances, node_normals
from neurocog_gym.perception.gng import DDGNGParams
from neurocog_gym.perception.pipeline import AttentionPipeline, PipelineParams
from neurocog_gym.perception.similarity import box_surface_reference, surface_match
from neurocog_gym.robot.obstacles import Block, ObstaclePool
from neurocog_gym.robot.tof import ToFArray, ToFParams

DOC = Path(__file__).resolve().parents[2] / "docs" / "generated" / "benchmarks_perception.md"
"""The perception page of the checkout (the repository's docs/, two levels above this package
module: bench/ -> neurocog_gym/ -> the repository)."""
DOC_TITLE = "## Perception in the loop: Fig. 9, attention timing, similarity, accuracy"


# ---------------------------------------------------------------------------------------------
# Geometry of a block and of the graph around it.


def block_local_xy(block: Block, xy: np.ndarray) -> np.ndarray:
    """(N, 2) coordinates of world points ``xy`` (N, 2) in the block's footprint frame."""
    c, s = math.cos(block.yaw), math.sin(block.yaw)
    d = xy - np.array([block.x, block.y])
    return np.stack([d[:, 0] * c + d[:, 1] * s, -d[:, 0] * s + d[:, 1] * c], axis=1)


def in_region(block: Block, pts: np.ndarray, pad: float) -> np.ndarray:
    """(N,) bool: points inside the block grown by ``pad`` (footprint and top; any z below)."""
    if len(pts) == 0:
        return np.zeros(0, dtype=bool)
    loc = block_local_xy(block, pts[:, :2])
    return (
        (np.abs(loc[:, 0]) <= block.length / 2 + pad)
        & (np.abs(loc[:, 1]) <= block.width / 2 + pad)
        & (pts[:, 2] <= block.height + pad)
    )


NONHOMOGENEOUS_MARGIN = 0.05
"""m: how far round a block's footprint (and above its top) a node still counts as on it for
the *first non-homogeneous nodes* (:func:`nonhomogeneous_on`): the facets a GNG spans from a
block's top edge down to the floor (its bevels) have their lower nodes outside the footprint,
within about half the 10 cm node spacing the attention brings (Table 2's sparse net, 15–25 cm,
puts them farther, but its top nodes are then inside)."""


def nonhomogeneous_on(
    block: Block,
    nodes: np.ndarray,
    aff: Affordances | None,
    max_tilt: float = AffordanceParams.terrain_max_tilt,
    margin: float = NONHOMOGENEOUS_MARGIN,
) -> bool:
    """Does the graph show *non-homogeneous nodes* on the block (§6.2, Fig. 10)?

    §4 of the paper: "if there is a nonhomogeneous normal vector for any area, the Dynamic
    Attention system increases the density of nodes there". Our reading, per perception step:
    a node is non-homogeneous when it is a corner of a facet whose Eq. (1) normal is tilted
    from the vertical by more than ``max_tilt`` (the Eq. (3) γ of that one facet beyond safe
    terrain's ``terrain_max_tilt``, 20°): its normals no longer agree with the floor's. The
    block shows them when such a node lies in its footprint grown by ``margin`` (and no higher
    than ``margin`` above its top, :func:`in_region`).

    One node lifted a few centimetres above a sparse floor does not count: its facets, 15–25 cm
    across, tilt by less than 20° until the node reaches the block's top or its neighbours
    crowd in; the raised-node rule of the detector (``raised_node_tolerance``) labels such a
    node an object at once, so the two are different events.

    Args:
        block: the block, as placed.
        nodes: (n, 3) float, metres: the graph's nodes (``pipeline.net.nodes``), the ones the
            facets of ``aff`` index.
        aff: the step's affordances (their ``facets`` and ``facet_normals``); None: no.
        max_tilt: rad, the tilt beyond which a facet is non-homogeneous.
        margin: m, the growth of the footprint.
    """
    if aff is None or len(aff.facets) == 0:
        return False
    nodes = np.asarray(nodes, dtype=np.float64).reshape(-1, 3)
    tilted = aff.facets[aff.facet_normals[:, 2] < math.cos(max_tilt)]
    if len(tilted) == 0:
        return False
    ids = np.unique(tilted)
    return bool(in_region(block, nodes[ids], margin).any())


def region_area(block: Block, pad: float) -> float:
    """m²: the padded footprint."""
    return (block.length + 2 * pad) * (block.width + 2 * pad)


def covered_area(points: np.ndarray, cell: float = 0.05) -> float:
    """m²: ground area the frame covers, as occupied ``cell`` × ``cell`` squares."""
    if len(points) == 0:
        return 0.0
    ij = np.floor(points[:, :2] / cell).astype(np.int64)
    return float(len(np.unique(ij[:, 0] * 1_000_003 + ij[:, 1]))) * cell * cell


def extents(block: Block, forward_xy: np.ndarray) -> tuple[float, float]:
    """(width across ``forward_xy``, length along it) of the block's footprint, metres."""
    f = np.asarray(forward_xy, dtype=np.float64)[:2]
    f = f / np.linalg.norm(f)
    side = np.array([-f[1], f[0]])
    xy = block.corners_xy()
    return float(np.ptp(xy @ side)), float(np.ptp(xy @ f))


def boxes_overlap(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two (2, 3) min/max boxes overlap in the ground plane."""
    return bool(np.all(a[0, :2] <= b[1, :2]) and np.all(b[0, :2] <= a[1, :2]))


def object_on(aff: Affordances | None, block: Block, min_height: float = 0.0):
    """The detected object that best covers ``block`` (most nodes in its footprint), or None."""
    if aff is None:
        return None
    truth = block.aabb()
    best, best_n = None, 0
    for o in aff.obstacles:
        if o.height < min_height or not boxes_overlap(o.box, truth):
            continue
        if o.n_nodes > best_n:
            best, best_n = o, o.n_nodes
    return best


def similarity_to(
    pipe: AttentionPipeline, block: Block, viewpoint: np.ndarray, pad: float, on_tol: float
) -> tuple[float, int]:
    """Surface similarity μ (Eq. 12–16) of the nodes on the obstacle to its true visible surface.

    The attention nodes are the nodes of the obstacle region higher than ``on_tol`` (the same
    selection for DD-GNG and GNG); their normals come from the last detection's facets.

    Returns:
        (μ, number of attention nodes).
    """
    aff = pipe.last
    nodes = pipe.net.nodes
    if aff is None or len(nodes) == 0:
        return 0.0, 0
    sel = in_region(block, nodes, pad) & (nodes[:, 2] > on_tol)
    if not sel.any():
        return 0.0, 0
    normals = node_normals(nodes, aff.facets, aff.facet_normals)
    lo = np.array([block.x - block.length / 2, block.y - block.width / 2, 0.0])
    hi = np.array([block.x + block.length / 2, block.y + block.width / 2, block.height])
    ref_p, ref_n = box_surface_reference(lo, hi, 0.01, yaw=block.yaw, viewpoint=viewpoint)
    m = surface_match(nodes[sel], normals[sel], ref_p, ref_n)
    return m.similarity, int(sel.sum())


# ---------------------------------------------------------------------------------------------
# The walking trial (Fig. 9, attention timing, similarity).


@dataclass(frozen=True)
class Variant:
    """One attention pipeline fed in a trial."""

    gng: str = "ddgng"
    """PipelineParams.gng: "ddgng" (attention on), "gng" (off), "mlgng"."""
    per_frame: bool = False
    """True: one learning cycle per new frame; False: one per control cycle (as the env)."""
    gng_params: DDGNGParams | None = None
    """DD-GNG parameters (None: Table 2)."""
    affordance: AffordanceParams | None = None
    """Affordance-detection parameters (None: defaults)."""
    refine: bool = True
    """PipelineParams.refine: object sizes from the raw points (True) or the graph only."""


@dataclass
class Trace:
    """Per-control-cycle records of one variant in one trial (times relative to appearance)."""

    t: list[float] = field(default_factory=list)
    n_nodes: list[int] = field(default_factory=list)
    n_region: list[int] = field(default_factory=list)
    n_on: list[int] = field(default_factory=list)
    dens_in: list[float] = field(default_factory=list)
    dens_out: list[float] = field(default_factory=list)
    attended: list[bool] = field(default_factory=list)
    detected: list[bool] = field(default_factory=list)
    confirmed: list[bool] = field(default_factory=list)
    similarity: list[float] = field(default_factory=list)
    err_h: list[float] = field(default_factory=list)
    err_w: list[float] = field(default_factory=list)
    err_l: list[float] = field(default_factory=list)

    def arrays(self) -> dict[str, np.ndarray]:
        """Every record as a NumPy array."""
        return {k: np.asarray(v) for k, v in self.__dict__.items()}


@dataclass
class TrialResult:
    """One walking trial: the block, when it appeared, and one trace per variant."""

    seed: int
    block: Block
    appeared_at: float
    traces: dict[str, Trace]
    snapshots: dict[str, dict] = field(default_factory=dict)


def place_ahead(
    data: mujoco.MjData, torso_body: int, rng: np.random.Generator, distance, lateral, size
) -> Block:
    """A block ``distance`` m ahead of the torso (and ``lateral`` m to its left), random size."""
    w, x, y, z = data.qpos[3:7]
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    f = np.array([math.cos(yaw), math.sin(yaw)])
    left = np.array([-f[1], f[0]])
    d = float(rng.uniform(*distance))
    s = float(rng.uniform(-lateral, lateral))
    h = float(rng.uniform(*size["height"]))
    length = float(rng.uniform(*size["length"]))
    width = float(rng.uniform(*size["width"]))
    dyaw = float(rng.uniform(-size["yaw"], size["yaw"]))
    c = data.xpos[torso_body, :2] + d * f + s * left
    return Block(float(c[0]), float(c[1]), length, width, h, yaw + dyaw)


#: The paper's blocks (§6.4): 6–8 cm high, 5–12 cm long, 10–30 cm wide, a little turned.
PAPER_BLOCK = {"height": (0.06, 0.08), "length": (0.05, 0.12), "width": (0.10, 0.30), "yaw": 0.25}


def walking_trial(
    seed: int,
    variants: dict[str, Variant],
    t_appear: float = 1.5,
    after: float = 1.0,
    tof: ToFParams | None = None,
    distance: tuple[float, float] = (0.7, 0.9),
    lateral: float = 0.1,
    size: dict | None = None,
    warmup_cycles: int = 150,
    pad: float = 0.03,
    on_tol: float = 0.02,
    with_similarity: bool = False,
    snapshot_at: tuple[float, ...] = (),
) -> TrialResult:
    """Walk, let a block appear ahead, feed the same frames to every variant, record traces.

    Args:
        seed: env reset seed, block draw seed and every pipeline's seed.
        variants: name -> :class:`Variant`.
        t_appear: s of walking before the block appears.
        after: s recorded after it appeared.
        tof: sensor parameters (default: the env's, numba backend, 56 × 43 per sensor, 45 fps).
        distance: (lo, hi) m, block centre ahead of the torso.
        lateral: m, block centre at most this far to either side of the heading.
        size: block size ranges (default :data:`PAPER_BLOCK`).
        warmup_cycles: cycles on the first frame before walking (the env's warm-up).
        pad: m, obstacle-region padding.
        on_tol: m, height above the floor of nodes "on the obstacle".
        with_similarity: also record the surface similarity every cycle (slower).
        snapshot_at: s after appearance at which to keep a copy of each variant's graph and
            frame (for pictures).

    Returns:
        The :class:`TrialResult`.
    """
    env = gym.make("NeuroCog/Walk-v3")
    env.reset(seed=seed)
    u = env.unwrapped
    rng = np.random.default_rng(seed)
    sensors = ToFArray(u.model, tof or ToFParams(backend="numba"), seed=seed)
    pool = ObstaclePool(u.model)
    pool.clear(u.model, u.data)
    mujoco.mj_forward(u.model, u.data)
    pipes = {
        k: AttentionPipeline(
            seed=seed,
            params=PipelineParams(gng=v.gng, refine=v.refine),
            gng_params=v.gng_params,
            affordance_params=v.affordance,
        )
        for k, v in variants.items()
    }
    frame = sensors.sense(u.data)
    for p in pipes.values():
        for _ in range(warmup_cycles):
            p.step(frame.points, frame.origins.mean(axis=0), 0.0)
    sensors.reset(seed=seed)
    traces = {k: Trace() for k in variants}
    snaps: dict[str, dict] = {}
    pending = sorted(snapshot_at)
    block = None
    appeared = math.nan
    action = np.zeros(u.action_space.shape, np.float32)
    n_steps = int(round((t_appear + after) / u.dt))
    torso = u.robot.torso_body
    for _ in range(n_steps):
        env.step(action)
        t = float(u.data.time)
        if block is None and t >= t_appear - 1e-9:
            block = place_ahead(u.data, torso, rng, distance, lateral, size or PAPER_BLOCK)
            pool.add(u.model, u.data, block)
            appeared = t
        new = sensors.maybe_sense(u.data)
        if new is not None:
            frame = new
        origin = frame.origins.mean(axis=0)
        w, x, y, z = u.data.qpos[3:7]
        yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        fwd = (math.cos(yaw), math.sin(yaw), 0.0)
        for k, v in variants.items():
            if new is not None or not v.per_frame:
                pipes[k].step(frame.points, origin, t, fwd)
        if block is None:
            continue
        area = covered_area(frame.points)
        rarea = region_area(block, pad)
        for k, p in pipes.items():
            tr = traces[k]
            nodes = p.net.nodes
            reg = in_region(block, nodes, pad)
            n_reg = int(reg.sum())
            tr.t.append(t - appeared)
            tr.n_nodes.append(len(nodes))
            tr.n_region.append(n_reg)
            tr.n_on.append(int((reg & (nodes[:, 2] > on_tol)).sum()))
            tr.dens_in.append(n_reg / rarea)
            tr.dens_out.append((len(nodes) - n_reg) / max(area - rarea, 1e-9))
            truth = block.aabb()
            tr.attended.append(any(boxes_overlap(b, truth) for b in p.attention_boxes))
            o = object_on(p.last, block)
            tr.detected.append(o is not None)
            tr.confirmed.append(o is not None and not o.suspected)
            w_true, l_true = extents(block, np.array(fwd[:2]))
            tr.err_h.append(o.height - block.height if o is not None else math.nan)
            tr.err_w.append(o.width - w_true if o is not None else math.nan)
            tr.err_l.append(o.length - l_true if o is not None else math.nan)
            if with_similarity:
                tr.similarity.append(similarity_to(p, block, origin, pad, on_tol)[0])
        while pending and t - appeared >= pending[0] - 1e-9:
            when = pending.pop(0)
            snaps[f"{when:g}"] = {
                "points": frame.points.copy(),
                "origin": origin.copy(),
                "graphs": {
                    k: (
                        p.net.nodes.copy(),
                        p.net.edges.copy(),
                        p.net.strength.copy(),
                        p.last,
                        p.attention_boxes.copy(),
                    )
                    for k, p in pipes.items()
                },
            }
    env.close()
    return TrialResult(seed, block, appeared, traces, snaps)


# ---------------------------------------------------------------------------------------------
# The static scene (affordance accuracy).


class StaticScene:
    """The standing robot's sensors in front of a floor + box + wall arrangement.

    The robot holds its home pose (the physics is not stepped: nothing moves but the clock), so
    every frame shows the same geometry, with the sensors' own noise if it is switched on.

    Args:
        tof: sensor parameters (default: the env's, numba backend).
        seed: env reset seed (tiny joint-angle noise of the home pose) and sensor noise seed.
    """

    def __init__(self, tof: ToFParams | None = None, seed: int = 0) -> None:
        self.env = gym.make("NeuroCog/Walk-v3")
        self.env.reset(seed=seed)
        self.u = self.env.unwrapped
        self.model, self.data = self.u.model, self.u.data
        self.sensors = ToFArray(self.model, tof or ToFParams(backend="numba"), seed=seed)
        self.pool = ObstaclePool(self.model)
        self.pool.clear(self.model, self.data)
        self.data.time = 0.0
        mujoco.mj_forward(self.model, self.data)
        torso = self.u.robot.torso_body
        self.torso_xy = self.data.xpos[torso, :2].copy()
        w, x, y, z = self.data.qpos[3:7]
        self.yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        self.forward = np.array([math.cos(self.yaw), math.sin(self.yaw), 0.0])

    def world(self, ahead: float, left: float) -> tuple[float, float]:
        """World (x, y) of a point ``ahead`` m in front of the torso and ``left`` m to its left."""
        f = self.forward[:2]
        p = self.torso_xy + ahead * f + left * np.array([-f[1], f[0]])
        return float(p[0]), float(p[1])

    def place(self, blocks: list[Block]) -> None:
        """Put exactly these blocks in the scene."""
        self.pool.place(self.model, self.data, blocks)

    def run(
        self, pipe: AttentionPipeline, seconds: float, t0: float, dt: float = 0.01, on_cycle=None
    ):
        """Advance the clock by ``seconds`` from ``t0``; returns the end time.

        Frames come at the sensor rate, one pipeline step per control cycle ``dt`` on the latest
        frame; ``on_cycle(t, frame, aff)`` is called after every step.
        """
        t = t0
        frame = None
        for _ in range(int(round(seconds / dt))):
            t += dt
            self.data.time = t
            new = self.sensors.maybe_sense(self.data)
            if new is not None:
                frame = new
            if frame is None:
                frame = self.sensors.sense(self.data)
            aff = pipe.step(frame.points, frame.origins.mean(axis=0), t, self.forward)
            if on_cycle is not None:
                on_cycle(t, frame, aff)
        self.last_frame = frame
        return t

    def close(self) -> None:
        """Release the env."""
        self.env.close()


def draw_box(rng: np.random.Generator, scene: StaticScene) -> Block:
    """A random box in front of the standing robot (the affordance-accuracy scenes).

    4–10 cm high, 10–30 cm wide and long, any yaw, centre 0.35–0.85 m ahead and up to 0.3 m
    aside; the same draws, in the same order, as ``scripts/bench_affordance_accuracy.py``.
    """
    ahead = float(rng.uniform(0.35, 0.85))
    left = float(rng.uniform(-0.3, 0.3))
    x, y = scene.world(ahead, left)
    return Block(
        x, y,
        length=float(rng.uniform(0.10, 0.30)),
        width=float(rng.uniform(0.10, 0.30)),
        height=float(rng.uniform(0.04, 0.10)),
        yaw=float(rng.uniform(0.0, math.pi)),
    )  # fmt: skip


def wall_behind(rng: np.random.Generator, scene: StaticScene, box: Block | None) -> Block:
    """A 2 m × 0.5 m wall 0.3–0.55 m behind the box's far corner, facing the robot."""
    far = 0.85
    if box is not None:
        rel = box.corners_xy() - scene.torso_xy
        far = float((rel @ scene.forward[:2]).max())
    ahead = far + float(rng.uniform(0.25, 0.5)) + 0.05
    x, y = scene.world(ahead, 0.0)
    return Block(x, y, length=0.10, width=2.0, height=0.5, yaw=scene.yaw)


@dataclass(frozen=True)
class BoxWallScene:
    """One floor + box + wall scene: the geometry and the seeds of its run."""

    box: Block
    wall: Block
    tof_seed: int
    """Seed of the sensors' noise stream for the run."""
    seed: int
    """Seed of the pipeline's random stream."""


def box_wall_scene(scene: StaticScene, seed: int, i: int, min_box_points: int = 30) -> BoxWallScene:
    """Scene ``i`` of the floor + box + wall series ``seed`` (seeded by ``[seed, i]``).

    Boxes are redrawn (up to 100 times) until at least ``min_box_points`` of the sensors' rays
    hit the box; the draws are those of ``scripts/bench_affordance_accuracy.py``, so series
    ``seed`` holds the same scenes there and in ``scripts/bench_affordance_map.py``. Leaves the
    box and the wall placed.
    """
    if min_box_points < 0:
        raise ValueError(f"min_box_points must be >= 0, got {min_box_points}")
    rng = np.random.default_rng([seed, i])
    box_gid = scene.pool.geoms[0]
    for _ in range(100):
        box = draw_box(rng, scene)
        wall = wall_behind(rng, scene, box)
        scene.place([box, wall])
        scene.data.time = 0.0
        f = scene.sensors.sense(scene.data)
        if int((f.geom == box_gid).sum()) >= min_box_points:
            break
    return BoxWallScene(box, wall, int(rng.integers(2**31)), int(rng.integers(2**31)))


# ---------------------------------------------------------------------------------------------
# The shared results document.


def load_now() -> str:
    """The 1/5/15-minute load averages, formatted."""
    try:
        import os

        a = os.getloadavg()
        return f"{a[0]:.2f}/{a[1]:.2f}/{a[2]:.2f}"
    except OSError:  # pragma: no cover
        return "n/a"


def write_section(key: str, text: str, doc: Path = DOC) -> None:
    """Replace (or append) the section ``key`` of the perception page, atomically.

    The page is ``docs/generated/benchmarks_perception.md`` unless ``doc`` says otherwise.

    Each script owns one section between ``<!-- begin KEY -->`` and ``<!-- end KEY -->``.
    """
    begin, end = f"<!-- begin {key} -->", f"<!-- end {key} -->"
    block = f"{begin}\n{text.rstrip()}\n{end}"
    old = doc.read_text() if doc.exists() else f"{DOC_TITLE}\n"
    pat = re.compile(re.escape(begin) + r".*?" + re.escape(end), re.S)
    new = (
        pat.sub(lambda _m: block, old) if pat.search(old) else old.rstrip() + "\n\n" + block + "\n"
    )
    atomic_write_text(doc, new if new.endswith("\n") else new + "\n")
