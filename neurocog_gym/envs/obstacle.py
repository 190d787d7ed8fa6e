"""ObstacleEnv: QuadrupedEnv plus the eyes, the attention loop, the effectivity and the outcome.

Shared by ``NeuroCog/SuddenObstacle-v1`` and ``NeuroCog/StaticObstacle-v1``. Every control cycle:
the physics steps; the four ToF sensors cast a frame when one is due (their frame rate); the
attention pipeline runs one DD-GNG learning cycle on the latest frame and detects affordances;
the effectivity predicts footholds and swing paths against the perceived obstacle boxes.

Wall-clock perception timings are not in ``info`` (it must be deterministic for a seed); read
``env.unwrapped.pipeline.timings`` (last step) and ``env.unwrapped.perception_time`` (episode).
``env.unwrapped.frame`` is the latest ToF frame (``ToFFrame``); its arrays are read-only views of
the sensor's buffers that the next frame overwrites: copy them to keep them.

Outcome of an episode (``info["outcome"]`` on its last step), from MuJoCo contacts and positions:

* **touched**: at some control cycle, a MuJoCo contact joined a robot geom (geom group 2) and a
  placed obstacle geom.
* **passed**: every foot is beyond the far side of every placed obstacle: the smallest foot
  position along world x exceeds the largest x of all obstacle boxes (by ``pass_margin``), with
  the robot upright. Walking around an obstacle passes it too.
* ``success`` = passed and never touched; ``touch`` = passed and touched; ``fail`` = the robot
  fell, the physics became unstable, or it had not passed when the time limit ran out (stuck).
The episode terminates when the robot passes (or falls); the time limit truncates it.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from gymnasium import spaces
from gymnasium.utils import EzPickle

from neurocog_gym.envs.base import QuadrupedEnv, _as_slice
from neurocog_gym.locomotion.effectivity import Effectivity, EffectivityParams, EffectivityState
from neurocog_gym.perception.pipeline import AttentionPipeline, PipelineParams
from neurocog_gym.robot.obstacles import ObstaclePool
from neurocog_gym.robot.tof import ToFArray, ToFParams

N_OBJECTS = 4
OBJECT_FIELDS = ("dx", "dy", "dz", "height", "width", "length", "gamma", "density")
AEF_INPUTS = 31


class ObstacleEnv(QuadrupedEnv):
    """Base of the obstacle tasks (see ``SuddenObstacleEnv`` for the documented spaces)."""

    def __init__(
        self,
        tof: ToFParams | None = None,
        perception: PipelineParams | None = None,
        effectivity: EffectivityParams | None = None,
        include_graph: bool = False,
        draw_overlay: bool = True,
        graph_max_nodes: int = 512,
        graph_max_edges: int = 2048,
        pass_margin: float = 0.02,
        warmup_cycles: int = 150,
        **kwargs,
    ):
        self.include_graph = bool(include_graph)
        self.graph_max_nodes = int(graph_max_nodes)
        self.graph_max_edges = int(graph_max_edges)
        self.draw_overlay = bool(draw_overlay)
        kwargs.setdefault("max_geom", 6000)
        super().__init__(**kwargs)
        # Pickle with every argument of the task (the base recorded only its own).
        EzPickle.__init__(
            self, tof=tof, perception=perception, effectivity=effectivity,
            include_graph=include_graph, draw_overlay=draw_overlay,
            graph_max_nodes=graph_max_nodes,
            graph_max_edges=graph_max_edges, pass_margin=pass_margin,
            warmup_cycles=warmup_cycles, **kwargs,
        )  # fmt: skip
        self.tof = ToFArray(self.model, tof or ToFParams(backend="numba"))
        self.pipeline = AttentionPipeline(seed=0, params=_env_perception(perception, self.tof))
        self.effectivity = Effectivity(effectivity)
        self.pool = ObstaclePool(self.model)
        self.pass_margin = float(pass_margin)
        self.warmup_cycles = int(warmup_cycles)
        self.observation_space = spaces.Dict(self._observation_spaces())
        self._foot_ix = _as_slice(self.robot.foot_site)
        self.frame = None
        self._frame_origin = None
        self._boxes_source = self._boxes_cache = None
        self._yaw_now = self._touch_now = None
        self.eff: EffectivityState | None = None
        self.touched = False
        self.touch_events = 0
        self._was_touching = False
        self.passed = False
        self.perception_time = 0.0

    # -- spaces -------------------------------------------------------------------------------

    def _observation_spaces(self) -> dict[str, spaces.Space]:
        s = super()._observation_spaces()
        f32 = np.float32
        # Every key 1-D (SB3's check_env and its MultiInputPolicy take vectors or images): the
        # tables are flattened row by row; ``obs[k].reshape(N_OBJECTS, len(OBJECT_FIELDS))``.
        s["objects"] = spaces.Box(-np.inf, np.inf, (N_OBJECTS * len(OBJECT_FIELDS),), f32)
        s["objects_mask"] = spaces.Box(0.0, 1.0, (N_OBJECTS,), f32)
        s["aef_input"] = spaces.Box(-np.inf, np.inf, (AEF_INPUTS,), f32)
        s["aef_mode"] = spaces.Discrete(3)
        s["foothold"] = spaces.Box(-np.inf, np.inf, (4 * 3,), f32)
        s["foothold_safe"] = spaces.MultiBinary(4)
        if self.include_graph:
            s["graph_nodes"] = spaces.Box(-np.inf, np.inf, (self.graph_max_nodes * 3,), f32)
            s["graph_edges"] = spaces.Box(
                -1, self.graph_max_nodes, (self.graph_max_edges * 2,), np.int64
            )
            s["graph_counts"] = spaces.Box(
                0, max(self.graph_max_nodes, self.graph_max_edges), (2,), np.int64
            )
        return s

    # -- world helpers --------------------------------------------------------------------------

    def _yaw(self) -> float:
        w, x, y, z = self.data.qpos[3:7].tolist()
        # NumPy's arctan2 (not math.atan2): its SIMD loop rounds differently in the last bit.
        return float(np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)))

    def _feet(self) -> np.ndarray:
        """(4, 3) sole positions, m (a view of ``data.site_xpos`` when the sites are adjacent)."""
        return self.data.site_xpos[self._foot_ix]

    def _sense_and_perceive(self, force_frame: bool = False, yaw: float | None = None) -> None:
        # The frame's arrays are the sensor's buffers (read-only views), overwritten by the
        # next frame: only the latest frame is ever read, and copying it cost ~200 kB a frame.
        tof, d = self.tof, self.data
        frame = tof.sense(d, copy=False) if force_frame else tof.maybe_sense(d, copy=False)
        if frame is not None:
            self.frame = frame
            # The facets face the sensors' mean position: one mean per frame, not per cycle
            # (the sum over the sensors divided by their number, as ndarray.mean computes it).
            origins = frame.origins
            self._frame_origin = np.add.reduce(origins, axis=0) / origins.shape[0]
        if self.frame is None:
            return
        if yaw is None:
            yaw = self._yaw()
        forward = (np.cos(yaw), np.sin(yaw), 0.0)
        self.pipeline.step(self.frame.points, self._frame_origin, self.data.time, forward)
        self.perception_time += self.pipeline.timings["total"]

    def perceived_boxes(self) -> np.ndarray:
        """(K, 2, 3) the objects' boxes in the attention memory, without the attention padding.

        The DD-GNG samples a padded box; the effectivity checks the object itself. The array is
        shared until the memory changes: copy it before modifying it.
        """
        source = self.pipeline.attention_boxes
        if source is self._boxes_source:
            # The pipeline replaces (never edits) its memory array: unchanged since last cycle.
            return self._boxes_cache
        boxes = source.copy()
        self._boxes_source, self._boxes_cache = source, boxes
        if len(boxes):
            pad = self.pipeline.affordance_params.suspect_padding
            boxes[:, 0] += pad
            boxes[:, 1] -= pad
            boxes[:, 0, 2] = np.maximum(boxes[:, 0, 2], 0.0)
        return boxes

    def _update_effectivity(
        self, yaw: float | None = None, touch: np.ndarray | None = None
    ) -> None:
        d = self.data
        # Read once per cycle and kept for the observation (nothing moves the robot in between).
        self._yaw_now = self._yaw() if yaw is None else yaw
        self._touch_now = self.touch() if touch is None else touch
        # Fancy indexing already copies feet and hips; the kernel only reads v_body.
        r = self.robot
        self.eff = self.effectivity.step(
            d.time, self._touch_now, self._feet(), d.xpos[r.hip_body],
            self._yaw_now, d.qvel[0:3], self.perceived_boxes(),
            d.xpos[r.thigh_body], d.xpos[r.shank_body],
        )  # fmt: skip

    # -- episode --------------------------------------------------------------------------------

    def _reset_task(self) -> None:
        self.pool.clear(self.model, self.data)
        self.tof.reset(seed=int(self.np_random.integers(2**31)))
        self.pipeline.reset(seed=int(self.np_random.integers(2**31)))
        self.effectivity.reset()
        self.touched = False
        self.touch_events = 0
        self._was_touching = False
        self.passed = False
        self.perception_time = 0.0
        self._touch_events_rewarded = 0
        self.frame = None
        self._place_initial_obstacles()
        import mujoco

        mujoco.mj_forward(self.model, self.data)
        # The robot has looked at the scene before the trial starts: warm the map up.
        self._sense_and_perceive(force_frame=True)
        self.pipeline.warm_up(self.frame.points, self._frame_origin, self.warmup_cycles)
        self.tof.reset(seed=int(self.np_random.integers(2**31)))
        self._update_effectivity()

    def _place_initial_obstacles(self) -> None:
        """Tasks place their obstacles here."""

    def _after_physics(self) -> None:
        # This cycle's touch, read once: placing a block (mj_kinematics) leaves the sensors alone.
        touch = self._touch_now = self.touch()
        self._task_event()
        yaw = self._yaw()
        self._sense_and_perceive(yaw=yaw)
        self._update_effectivity(yaw, touch)
        touching = self.pool.touching_any(self.data, self.robot.robot_geoms)
        if touching and not self._was_touching:
            self.touch_events += 1
        self._was_touching = touching
        self.touched |= touching
        if self.pool.blocks:
            far = float(self.pool.boxes()[:, 1, 0].max())
            self.passed = bool(self._feet()[:, 0].min() > far + self.pass_margin)

    def _task_event(self) -> None:
        """Tasks add sudden obstacles here (runs right after the physics step)."""

    def _fell(self) -> bool:
        return super()._fell()

    def step(self, action):
        """One control cycle; terminates when the robot passes the obstacles or falls."""
        obs, reward, terminated, truncated, info = super().step(action)
        if info.get("sim_unstable"):
            info.update(self._outcome(fell=False, unstable=True))
            return obs, reward, terminated, truncated, info
        if self.passed and not terminated:
            terminated = True
        info.update(self._outcome(fell=info["fell"], unstable=False))
        return obs, reward, terminated, truncated, info

    def _outcome(self, fell: bool, unstable: bool) -> dict:
        if unstable or fell:
            outcome = "fail"
        elif self.passed:
            outcome = "touch" if self.touched else "success"
        else:
            outcome = "fail"  # provisional: not passed (yet); final when the episode ends
        return {
            "outcome": outcome,
            "passed": self.passed,
            "touched": self.touched,
            "touch_events": self.touch_events,
            "fell": fell,
            "obstacles": self.pool.blocks_json(),
            "aef_mode": int(self.eff.mode) if self.eff is not None else 0,
        }

    # -- observation ----------------------------------------------------------------------------

    def _objects(self, rot: np.ndarray) -> tuple[np.ndarray, np.ndarray, tuple]:
        """The K nearest objects ahead in the torso's yaw frame (``rot``: world to yaw frame)."""
        out = np.zeros((N_OBJECTS, len(OBJECT_FIELDS)), np.float32)
        mask = np.zeros(N_OBJECTS, np.float32)
        aff = self.pipeline.last
        best = (0.0, 0.0, 0.0)
        if aff is None:
            return out, mask, best
        min_height = self.pipeline.params.min_height
        objs = [o for o in aff.objects if o.kind == "object" and o.height >= min_height]
        if not objs:
            return out, mask, best
        torso = self.data.xpos[self.robot.torso_body]
        rel = [rot @ (o.position - torso) for o in objs]
        if len(objs) == 1:
            order = (0,)  # the usual case: nothing to sort
        else:
            order = np.argsort([np.hypot(r[0], r[1]) + (10 if r[0] < 0 else 0) for r in rel])
        for slot, k in enumerate(order[:N_OBJECTS]):
            o = objs[k]
            out[slot] = (*rel[k], o.height, o.width, o.length, o.gamma, o.density)
            mask[slot] = 1.0
        if len(order):
            o = objs[order[0]]
            best = (o.height, o.width, o.length)
        return out, mask, best

    def _get_obs(self) -> dict[str, np.ndarray]:
        obs = self._proprioception(self._touch_now)
        yaw = self._yaw() if self._yaw_now is None else self._yaw_now
        c, s = np.cos(yaw), np.sin(yaw)
        rot = np.array([c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.0]).reshape(3, 3)
        objects, mask, (a_h, a_w, a_s) = self._objects(rot)
        eff = self.eff
        torso = self.data.xpos[self.robot.torso_body]
        if eff is None:
            direction = np.zeros((4, 3))
            foothold = np.zeros((4, 3))
            safe = np.ones(4, np.int8)
            mode = 0
        else:
            direction = eff.direction
            foothold = (eff.foothold - torso) @ rot.T
            safe = (eff.foothold_safe & eff.path_safe).astype(np.int8)
            mode = int(eff.mode)
        # Fig. 7's 31 inputs: the object's size, the interrupt directions, joint angles, touch.
        aef = np.empty(AEF_INPUTS, np.float32)
        aef[0:3] = (a_h, a_w, a_s)
        aef[3:15] = direction.ravel()
        aef[15:27] = obs["joint_pos"]
        aef[27:31] = obs["touch"]
        obs.update(
            objects=objects.ravel(),
            objects_mask=mask,
            aef_input=aef,
            aef_mode=mode,
            foothold=foothold.astype(np.float32).ravel(),
            foothold_safe=safe,
        )
        if self.include_graph:
            g = self.pipeline.net.padded(self.graph_max_nodes, self.graph_max_edges)
            obs["graph_nodes"] = g.nodes.astype(np.float32).ravel()
            obs["graph_edges"] = g.edges.astype(np.int64).ravel()
            obs["graph_counts"] = np.array([g.n_nodes, g.n_edges], np.int64)
        return obs

    # -- rendering ------------------------------------------------------------------------------

    def render(self):
        """Render the scene, or the ToF depth images.

        ``rgb_array``/``human``: the scene with the DD-GNG graph, its facets filled by surface
        kind, the attention boxes and the predicted footholds drawn in (``draw_overlay``);
        ``depth_array``: the four ToF depth images side by side, (H, 4 W) float32 metres, 0
        where invalid.
        """
        if self.render_mode == "depth_array":
            if self.frame is None:
                self._sense_and_perceive(force_frame=True)
            d = self.frame.depth
            return np.concatenate(list(d), axis=1).astype(np.float32)
        if self.draw_overlay and self.render_mode in ("rgb_array", "human"):
            # Gymnasium draws "markers" (extra visual geoms) into the scene of its next frame.
            viewer = self.mujoco_renderer._get_viewer(self.render_mode)
            for marker in overlay_markers(self):
                viewer.add_marker(**marker)
        return super().render()


def _env_perception(params: PipelineParams | None, tof: ToFArray) -> PipelineParams:
    """``params`` (or the defaults) without the raw-point additions nothing in the env reads.

    * ``refine_noise`` only when the sensors have range noise: on a noise-free frame it
      estimates no noise and moves no extent end.
    * ``view_wall_width`` 0: the obstacle scenes have no walls, and the wall labels it adds
      (which have no facets) reach neither the observation, the attention nor the effectivity,
      which read objects only.

    Together they cost about 20 µs a control cycle with a block in view (4 % of a step).
    """
    p = params or PipelineParams()
    return replace(
        p, refine_noise=p.refine_noise and tof.params.noise_std_rel > 0.0, view_wall_width=0.0
    )


_KIND_RGBA = {
    "terrain": np.array([0.2, 0.85, 0.3, 1.0]),
    "wall": np.array([0.25, 0.45, 1.0, 1.0]),
    "object": np.array([1.0, 0.2, 0.15, 1.0]),
}
_NODE_RGBA = np.array([1.0, 0.9, 0.1, 1.0])
_GREY_EDGE = np.array([0.6, 0.6, 0.6, 0.8])


def _edge_rgba(kind: str | None) -> np.ndarray:
    if kind is None:
        return _GREY_EDGE
    rgba = 0.4 * _KIND_RGBA[kind] + 0.6
    rgba[3] = 0.9
    return rgba


def _segment_marker(a: np.ndarray, b: np.ndarray, width: float, rgba: np.ndarray) -> dict:
    """A line from ``a`` to ``b`` (metres), ``width`` pixels wide.

    MuJoCo's ``mjGEOM_LINE`` runs along its frame's z axis from ``pos`` for ``size[2]`` metres.
    A line is one draw call; a capsule per edge made the software (EGL) renderer several times
    slower.
    """
    import mujoco

    d = b - a
    length = float(np.linalg.norm(d))
    z = d / max(length, 1e-9)
    x = np.cross(z, [0.0, 0.0, 1.0]) if abs(z[2]) < 0.9 else np.cross(z, [1.0, 0.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return {
        "type": mujoco.mjtGeom.mjGEOM_LINE,
        "size": np.array([width, width, length]),
        "pos": np.array(a, dtype=np.float64),
        "mat": np.column_stack([x, y, z]).ravel(),
        "rgba": rgba,
    }


def triangle_markers(
    a: np.ndarray,
    b: np.ndarray,
    c: np.ndarray,
    normal: np.ndarray,
    rgba: np.ndarray,
    lift: float = 0.0,
) -> list[dict]:
    """Markers that fill the triangles ``a[i], b[i], c[i]`` ((F, 3) each, metres).

    MuJoCo draws only right triangles (``mjGEOM_TRIANGLE``: corners (0, 0, 0), (size[0], 0, 0)
    and (0, size[1], 0) in the marker's frame), so each triangle is cut along the altitude onto
    its longest side (whose foot lies on that side) into two right triangles. Their frames are
    turned so the lit side faces ``normal`` ((F, 3)); ``lift`` moves them along it (metres, to
    keep them off a surface they lie on). Degenerate triangles give no marker.
    """
    import mujoco

    pts = np.stack([a, b, c], axis=1).astype(np.float64)  # (F, 3 corners, 3)
    if len(pts) == 0:
        return []
    opposite = np.stack(
        [np.linalg.norm(pts[:, (k + 2) % 3] - pts[:, (k + 1) % 3], axis=1) for k in range(3)],
        axis=1,
    )
    k = np.argmax(opposite, axis=1)
    rows = np.arange(len(pts))
    apex, p, q = pts[rows, k], pts[rows, (k + 1) % 3], pts[rows, (k + 2) % 3]
    d = q - p
    dd = np.einsum("ij,ij->i", d, d)
    t = np.einsum("ij,ij->i", apex - p, d) / np.maximum(dd, 1e-300)
    foot = p + t[:, None] * d
    h = apex - foot
    hl = np.linalg.norm(h, axis=1)
    normal = np.asarray(normal, dtype=np.float64)
    markers: list[dict] = []
    for i in np.flatnonzero((dd > 1e-18) & (hl > 1e-9)):
        y = h[i] / hl[i]
        for end in (p[i], q[i]):
            e = end - foot[i]
            el = float(np.linalg.norm(e))
            if el <= 1e-9:
                continue
            x = e / el
            z = np.cross(x, y)
            if z @ normal[i] >= 0.0:
                mat, size = np.column_stack([x, y, z]), (el, hl[i], 0.0)
            else:  # swap the legs: the frame stays right-handed, its z turns over
                mat, size = np.column_stack([y, x, -z]), (hl[i], el, 0.0)
            markers.append({"type": mujoco.mjtGeom.mjGEOM_TRIANGLE, "size": np.array(size),
                            "pos": foot[i] + lift * normal[i], "mat": mat.ravel(),
                            "rgba": rgba[i] if np.ndim(rgba) == 2 else rgba})  # fmt: skip
    return markers


def overlay_markers(
    env: ObstacleEnv, max_edges: int = 1500, facet_alpha: float = 0.45
) -> list[dict]:
    """Visual markers of the perception state.

    The facets filled and the graph nodes and edges coloured by the kind of surface their
    label is (terrain green, wall blue, object red), attention boxes, and footholds (green
    safe, red unsafe).
    """
    import mujoco

    markers: list[dict] = []
    net = env.pipeline.net
    nodes = net.nodes
    edges = net.edges
    aff = env.pipeline.last
    node_kind = {}
    if aff is not None and len(aff.facets):
        tri = aff.facets
        if len(nodes) > int(tri.max()):  # the facets index this cycle's graph
            rgba = np.array([_KIND_RGBA[aff.label_kinds[lab]] for lab in aff.facet_labels])
            rgba[:, 3] = facet_alpha
            markers += triangle_markers(
                nodes[tri[:, 0]], nodes[tri[:, 1]], nodes[tri[:, 2]], aff.facet_normals, rgba,
                lift=0.002,
            )  # fmt: skip
        for f, lab in zip(aff.facets, aff.facet_labels, strict=True):
            kind = aff.label_kinds[lab]
            for i in f:
                if node_kind.get(int(i)) != "object":
                    node_kind[int(i)] = kind
    for i, p in enumerate(nodes):
        rgba = _KIND_RGBA.get(node_kind.get(i), _NODE_RGBA)
        markers.append({"type": mujoco.mjtGeom.mjGEOM_SPHERE, "size": np.full(3, 0.009),
                        "pos": p, "rgba": rgba})  # fmt: skip
    for a, b in edges[:max_edges]:
        ka, kb = node_kind.get(int(a)), node_kind.get(int(b))
        kind = ka if ka == kb else None
        # Edges a paler tint of their facets' kind (on no facet, or between kinds: grey).
        rgba = _edge_rgba(kind)
        markers.append(_segment_marker(nodes[a], nodes[b], 2.0, rgba))
    for box in env.pipeline.attention_boxes:
        markers.append({"type": mujoco.mjtGeom.mjGEOM_BOX, "size": (box[1] - box[0]) / 2,
                        "pos": (box[1] + box[0]) / 2,
                        "rgba": np.array([1.0, 0.3, 0.2, 0.18])})  # fmt: skip
    if env.eff is not None:
        for leg in range(4):
            safe = env.eff.foothold_safe[leg] and env.eff.path_safe[leg]
            rgba = np.array([0.1, 0.9, 0.2, 0.9]) if safe else np.array([1.0, 0.1, 0.1, 0.9])
            pos = env.eff.foothold[leg].copy()
            pos[2] = max(pos[2], 0.0) + 0.005
            markers.append({"type": mujoco.mjtGeom.mjGEOM_CYLINDER,
                            "size": np.array([0.025, 0.025, 0.004]), "pos": pos,
                            "rgba": rgba})  # fmt: skip
    return markers
