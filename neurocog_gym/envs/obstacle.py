"""ObstacleEnv: QuadrupedEnv plus the eyes, the attention loop, the effectivity and the outcome.

Shared by ``NeuroCog/SuddenObstacle-v3`` and ``NeuroCog/StaticObstacle-v3``. Every control cycle:
the physics steps; the four ToF sensors cast a frame when one is due (their frame rate); the
attention pipeline runs one DD-GNG learning cycle on the latest frame and detects affordances;
the effectivity predicts footholds and swing paths against the perceived obstacle boxes.

Wall-clock perception timings are not in ``info`` (it must be deterministic for a seed); read
``env.unwrapped.pipeline.timings`` (last step) and ``env.unwrapped.perception_time`` (episode).
``env.unwrapped.frame`` is the latest ToF frame (``ToFFrame``); its arrays are read-only views of
the sensor's buffers that the next frame overwrites: copy them to keep them.

Outcome v1 of an episode (§6.5, SPEC §8; ``info["outcome"]`` on its last step), from MuJoCo
contacts and poses, checked once per control cycle (after its physics steps) on every placed
block, with the thresholds of :class:`OutcomeParams`:

* **touched**: a MuJoCo contact joined a robot geom (geom group 2) and a block's geom.
* **knocked**: a block's centre moved more than ``knock_shift`` (2 cm) in the horizontal plane
  from where it was placed, or it turned by more than ``knock_turn_deg`` (10°) about any axis
  from its placed orientation (the angle of the relative rotation, 2 acos |q_now · q_placed|).
  The blocks are loose wood: a kick moves them.
* **stood on**: a robot geom carried part of the body's weight on a block's top face: the
  contacts between robot geoms and the block whose normal (from the block to the robot) is
  within ``stand_tilt_deg`` (30°) of world up and whose point lies within ``stand_face_tol``
  (1 cm) of the top face (the block-frame plane z = +h/2, inside the face grown by the same
  tolerance) carry a total normal force of at least ``stand_weight_fraction`` (10 %) of the
  robot's weight for ``stand_cycles`` (3) control cycles in a row.
* **passed**: every foot is beyond the far side of every block: the smallest foot position
  along world x exceeds the largest x of the blocks' current axis-aligned boxes by
  ``pass_margin``, with the robot upright (not fallen). Walking round a block passes it too.
* **stepped over** (recorded, not part of the outcome): block k's frame has u along its length
  axis (the walking direction +u) and v across. A foot crosses the block above it when it goes
  from before the near face (u < -length/2) to beyond the far face (u > +length/2) while every
  part of its path over the length (-length/2 <= u <= +length/2, the straight segments between
  control cycles) has |v| <= width/2; a block is stepped over when at least one front foot and
  one hind foot crossed it so; the trial's ``stepped_over`` = every placed block was (walking
  round a block leaves no foot above it). See :func:`neurocog_gym.envs._kernels.step_over_step`.
* ``success`` = passed, never touched; ``touch`` = passed, touched, never stood on a block and
  never knocked one; ``fail`` = knocked a block, stood on a block, fell, the physics became
  unstable, or not passed when the time limit ran out (stuck). Climbing a block is not avoiding
  it.

Also in ``info``: ``interrupt_cycles`` / ``provision_cycles``, the control cycles whose clipped
action had a non-zero interrupt group (entries 0..11) / provision group (12..14), and
``time_to_pass_from_appear``, s from the block's appearance (static: from t = 0) to the pass.
The episode terminates when the robot passes (or falls); the time limit truncates it.

``observation_mode`` (for end-to-end learning from depth, as in Agarwal et al. 2022 and ViNL):

* ``"default"``: the keys of ``SuddenObstacleEnv``'s table, every one 1-D.
* ``"depth"``: the same keys plus ``depth``, the latest ToF frame as a uint8 image
  ``(4, DEPTH_HEIGHT, DEPTH_WIDTH)`` = (4, 43, 56), channels first: channel k is sensor
  ``tof_k`` (0 the leftmost, yawed +60°; 3 the rightmost, -60°), row 0 the top of its image,
  column 0 its left side. Each sensor's image is resampled to 43 × 56 by nearest pixel (the
  default sensors are 43 × 56 already, a quarter of the Pico Flexx's 172 × 224 per axis; a
  full-resolution frame is read at every fourth pixel). Value = round(255 · z / 2 m) for a
  z-depth z along the sensor's optical axis (``DEPTH_RANGE`` 2 m, 7.8 mm a level), 255 for
  z >= 2 m and for a pixel without a return in the sensors' range gate. The image changes only
  when a frame comes (45 fps: every 2 or 3 control cycles) and holds in between. It is an image
  by stable-baselines3's rules (``is_image_space``; 43 and 56 are over NatureCNN's 36), so
  ``MultiInputPolicy`` puts a CNN on it and MLPs on the rest. The attention pipeline runs.
* ``"depth_only"``: Walk's proprioceptive keys, ``feet``, ``leg_joints`` and ``depth``
  (``true_blocks`` with ``privileged``): the attention pipeline does not run (no DD-GNG, no
  affordances, no map warm-up at reset: about half of a step) and the keys built from it are
  left out
  (``objects``, ``objects_mask``, ``aef_input``, ``interrupt_direction``, ``foothold``,
  ``foothold_safe``, ``path_meets_block``, ``block_met``, ``remembered_blocks``). The
  effectivity still predicts the footholds (against no perceived box), where the sudden block
  is placed, so the task is the same. Not with ``include_graph``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import mujoco
import numpy as np
from gymnasium import spaces
from gymnasium.utils import EzPickle

from neurocog_gym.envs import _kernels as _k
from neurocog_gym.envs._kernels import depth_image
from neurocog_gym.envs.base import QuadrupedEnv, _as_slice, _as_stride
from neurocog_gym.locomotion.effectivity import Effectivity, EffectivityParams, EffectivityState
from neurocog_gym.perception.pipeline import AttentionPipeline, PipelineParams
from neurocog_gym.robot.model import GRAVITY
from neurocog_gym.robot.names import FRONT_LEGS
from neurocog_gym.robot.obstacles import ObstaclePool
from neurocog_gym.robot.tof import ToFArray, ToFParams

N_OBJECTS = 4
OBJECT_FIELDS = ("dx", "dy", "dz", "height", "width", "length", "gamma", "density")
AEF_INPUTS = 31
TRUE_BLOCK_SLOTS = 4
"""Blocks in the privileged ``true_blocks`` observation (``privileged=True``)."""
BLOCK_FIELDS = ("valid", "x", "y", "yaw", "half_length", "half_width", "top")
"""One row of ``remembered_blocks`` and ``true_blocks``."""
MEMORY_SLOTS = 8
"""Remembered boxes in the ``remembered_blocks`` observation (the nearest, if there are more)."""
OBSERVATION_MODES = ("default", "depth", "depth_only")
"""Values of ``observation_mode`` (module docstring)."""
DEPTH_HEIGHT = 43
"""Rows of each sensor's image in the ``depth`` observation."""
DEPTH_WIDTH = 56
"""Columns of each sensor's image in the ``depth`` observation."""
DEPTH_RANGE = 2.0
"""m, z-depth that maps to 255 in the ``depth`` observation (and beyond it, clipped)."""


@dataclass(frozen=True)
class OutcomeParams:
    """Thresholds of the v1 outcome (§6.5, SPEC §8; the definitions are in the module docstring)."""

    knock_shift: float = 0.02
    """m, horizontal displacement of a block's centre from its placed position that knocks it."""
    knock_turn_deg: float = 10.0
    """degrees, rotation (about any axis) from its placed orientation that knocks it."""
    stand_tilt_deg: float = 30.0
    """degrees, largest angle between a standing contact's normal and world up."""
    stand_face_tol: float = 0.01
    """m, how close to the block's top face a standing contact's point must be."""
    stand_weight_fraction: float = 0.1
    """Share of the robot's weight the top-face contacts must carry to count as standing."""
    stand_cycles: int = 3
    """Control cycles (0.01 s each) in a row the top face must carry that weight."""

    def __post_init__(self):
        for name in ("knock_shift", "knock_turn_deg", "stand_tilt_deg", "stand_face_tol",
                     "stand_weight_fraction"):  # fmt: skip
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"OutcomeParams.{name} must be a positive number, got {v}")
        if int(self.stand_cycles) < 1:
            raise ValueError(f"OutcomeParams.stand_cycles must be >= 1, got {self.stand_cycles}")


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
        privileged: bool = False,
        outcome: OutcomeParams | None = None,
        affordance_source: str | None = None,
        observation_mode: str = "default",
        **kwargs,
    ):
        if observation_mode not in OBSERVATION_MODES:
            raise ValueError(
                f"observation_mode must be one of {OBSERVATION_MODES}, got {observation_mode!r}"
            )
        if observation_mode == "depth_only" and include_graph:
            raise ValueError(
                "include_graph needs the attention pipeline, which observation_mode='depth_only' "
                "does not run"
            )
        self.observation_mode = observation_mode
        tof_params = tof or ToFParams(backend="numba")
        self._n_sensors = tof_params.n_sensors
        self._with_depth = observation_mode != "default"
        self._perceive = observation_mode != "depth_only"
        self.include_graph = bool(include_graph)
        self.privileged = bool(privileged)
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
            warmup_cycles=warmup_cycles, outcome=outcome, privileged=privileged,
            affordance_source=affordance_source, observation_mode=observation_mode, **kwargs,
        )  # fmt: skip
        self.tof = ToFArray(self.model, tof_params)
        # affordance_source: "map" (sizes from the DD-GNG graph alone, the paper's) or
        # "points" (the raw-point refinement); None keeps ``perception``'s ("points").
        self.pipeline = AttentionPipeline(
            seed=0,
            params=_env_perception(perception, self.tof),
            affordance_source=affordance_source,
        )
        self.effectivity = Effectivity(effectivity)
        tp = self.tof.params
        # Nearest source pixel of each image row and column (the identity at the default size).
        self._depth_rows = np.rint(np.linspace(0, tp.height - 1, DEPTH_HEIGHT)).astype(np.int64)
        self._depth_cols = np.rint(np.linspace(0, tp.width - 1, DEPTH_WIDTH)).astype(np.int64)
        self._depth_image = np.full((tp.n_sensors, DEPTH_HEIGHT, DEPTH_WIDTH), 255, np.uint8)
        self.pool = ObstaclePool(self.model)
        self.pass_margin = float(pass_margin)
        self.warmup_cycles = int(warmup_cycles)
        self.observation_space = spaces.Dict(self._observation_spaces())
        self._foot_ix = _as_slice(self.robot.foot_site)
        self._hip_ix = _as_stride(self.robot.hip_body)
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
        self.outcome_params = outcome or OutcomeParams()
        self._init_outcome_state()
        self._arange = np.arange(self.effectivity.memory_capacity, dtype=np.int64)
        self._slot_scratch = np.empty(self.effectivity.memory_capacity, np.int64)
        self._no_best = np.zeros(3)  # A_h, A_w, A_s without an object (read only)
        k = _k
        # (key, (start, stop)) in the observation buffer, in the observation's key order.
        self._obs_proprio = (
            ("joint_pos", (k.O_JOINT_POS, k.O_JOINT_VEL)),
            ("joint_vel", (k.O_JOINT_VEL, k.O_TOUCH)),
            ("touch", (k.O_TOUCH, k.O_QUAT)), ("torso_quat", (k.O_QUAT, k.O_LIN_VEL)),
            ("torso_lin_vel", (k.O_LIN_VEL, k.O_ANG_VEL)),
            ("torso_ang_vel", (k.O_ANG_VEL, k.O_HEIGHT)), ("torso_height", (k.O_HEIGHT, k.O_CPG)),
            ("cpg", (k.O_CPG, k.O_SERVO)), ("servo_target", (k.O_SERVO, k.O_OBJECTS)),
        )  # fmt: skip
        self._obs_perceived = (
            ("objects", (k.O_OBJECTS, k.O_MASK)), ("objects_mask", (k.O_MASK, k.O_AEF)),
            ("aef_input", (k.O_AEF, k.O_DIRECTION)),
            ("interrupt_direction", (k.O_DIRECTION, k.O_FOOTHOLD)),
            ("foothold", (k.O_FOOTHOLD, k.O_MEETS)), ("path_meets_block", (k.O_MEETS, k.O_MET)),
            ("block_met", (k.O_MET, k.O_BLOCKS)), ("remembered_blocks", (k.O_BLOCKS, k.O_FEET)),
        )  # fmt: skip

    # -- spaces -------------------------------------------------------------------------------

    def _observation_spaces(self) -> dict[str, spaces.Space]:
        s = super()._observation_spaces()
        f32 = np.float32
        if self._with_depth:
            shape = (self._n_sensors, DEPTH_HEIGHT, DEPTH_WIDTH)
            s["depth"] = spaces.Box(0, 255, shape, np.uint8)
        nb = len(BLOCK_FIELDS)
        if self._perceive:
            # Every key 1-D (SB3's check_env and its MultiInputPolicy take vectors or images):
            # the tables are flattened row by row, e.g.
            # ``obs["objects"].reshape(N_OBJECTS, len(OBJECT_FIELDS))``.
            s["objects"] = spaces.Box(-np.inf, np.inf, (N_OBJECTS * len(OBJECT_FIELDS),), f32)
            s["objects_mask"] = spaces.Box(0.0, 1.0, (N_OBJECTS,), f32)
            s["aef_input"] = spaces.Box(-np.inf, np.inf, (AEF_INPUTS,), f32)
            s["interrupt_direction"] = spaces.Box(-np.inf, np.inf, (4 * 3,), f32)
            s["foothold"] = spaces.Box(-np.inf, np.inf, (4 * 3,), f32)
            s["foothold_safe"] = spaces.MultiBinary(4)
            s["path_meets_block"] = spaces.Box(0.0, 1.0, (4,), f32)
            s["block_met"] = spaces.Box(-1.0, MEMORY_SLOTS - 1, (4,), f32)
            s["remembered_blocks"] = spaces.Box(-np.inf, np.inf, (MEMORY_SLOTS * nb,), f32)
        s["feet"] = spaces.Box(-np.inf, np.inf, (4 * 3,), f32)
        s["leg_joints"] = spaces.Box(-np.inf, np.inf, (4 * 3 * 3,), f32)
        if self.privileged:
            # The simulator's truth, for the privileged oracle only (``privileged=True``).
            s["true_blocks"] = spaces.Box(-np.inf, np.inf, (TRUE_BLOCK_SLOTS * nb,), f32)
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
            if self._with_depth:
                depth_image(frame.depth, frame.valid, self._depth_rows, self._depth_cols,
                            DEPTH_RANGE, self._depth_image)  # fmt: skip
            if not self._perceive:
                return
            # The facets face the sensors' mean position: one mean per frame, not per cycle
            # (the sum over the sensors divided by their number, as ndarray.mean computes it).
            origins = frame.origins
            self._frame_origin = np.add.reduce(origins, axis=0) / origins.shape[0]
        if self.frame is None or not self._perceive:
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
        # Views (the hips are every third body): the kernel only reads them.
        self.eff = self.effectivity.step(
            d.time, self._touch_now, self._feet(), d.xpos[self._hip_ix],
            self._yaw_now, d.qvel[0:3], self.perceived_boxes(),
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
        self._reset_outcome()
        self._place_initial_obstacles()
        mujoco.mj_forward(self.model, self.data)
        # The robot has looked at the scene before the trial starts: warm the map up.
        self._sense_and_perceive(force_frame=True)
        if self._perceive:
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
        touching = self._check_blocks(yaw)
        if touching and not self._was_touching:
            self.touch_events += 1
        self._was_touching = touching
        self.touched |= touching
        if self.pool.blocks:
            # The blocks' far x bound and the rearmost foot, from this cycle's _check_blocks.
            beyond = bool(self._rear_foot > self._far_x + self.pass_margin)
            self.passed = beyond and not self._fell()
            if self.passed and self.passed_at is None:
                self.passed_at = float(self.data.time)

    # -- outcome bookkeeping ----------------------------------------------------------------------

    def _init_outcome_state(self) -> None:
        """Preallocate the per-block outcome state (one row per pool slot)."""
        n = self.pool.capacity
        p = self.outcome_params
        self._cos_max_tilt = math.cos(math.radians(p.stand_tilt_deg))
        self._cos_half_max_turn = math.cos(math.radians(p.knock_turn_deg) / 2.0)
        self._min_stand_force = p.stand_weight_fraction * self.robot.mass * GRAVITY
        self._elliptic = bool(self.model.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC)
        self._is_front = np.zeros(4, dtype=bool)
        self._is_front[list(FRONT_LEGS)] = True
        self._blk_touch = np.zeros(n, dtype=bool)
        self._blk_top_force = np.zeros(n)
        self._blk_stand_run = np.zeros(n, dtype=np.int64)
        self._blk_stood = np.zeros(n, dtype=bool)
        self._blk_shift = np.zeros(n)
        self._blk_turn = np.zeros(n)
        self._blk_knocked = np.zeros(n, dtype=bool)
        self._blk_axis_sign = np.ones(n)
        self._over_state = np.full((n, 4), -1, dtype=np.int8)
        self._over_crossed = np.zeros((n, 4), dtype=bool)
        self._blk_over = np.zeros(n, dtype=bool)
        self._prev_feet = np.zeros((4, 3))
        self._far_x = self._rear_foot = math.nan
        self._reset_outcome()

    def _reset_outcome(self) -> None:
        self._serial_seen = self.pool.serial.copy()
        self._placements_seen = self.pool.placements
        for k in range(self.pool.capacity):
            self._reset_slot(k)
        self._has_prev_feet = False
        self.knocked = False
        self.stood_on = False
        self.interrupt_cycles = 0
        self.provision_cycles = 0
        self.passed_at: float | None = None

    def _reset_slot(self, k: int) -> None:
        """Slot ``k`` holds a new block: forget the last one's state."""
        self._blk_touch[k] = self._blk_stood[k] = self._blk_knocked[k] = False
        self._blk_top_force[k] = self._blk_shift[k] = self._blk_turn[k] = 0.0
        self._blk_stand_run[k] = 0
        self._over_state[k] = -1
        self._over_crossed[k] = False
        self._blk_over[k] = False

    def _check_blocks(self, yaw: float) -> bool:
        """This cycle's contact and pose checks of the blocks (the outcome); True if touching.

        One compiled call (``_kernels.outcome_cycle``), which also keeps the blocks' far x
        bound and the rearmost foot's x for the pass test (``_far_x``, ``_rear_foot``).
        """
        pool, d = self.pool, self.data
        feet = self._feet()
        k = len(pool.blocks)
        touching = False
        if k:
            if pool.placements != self._placements_seen:
                for slot in np.flatnonzero(pool.serial != self._serial_seen):
                    self._reset_slot(int(slot))
                self._serial_seen = pool.serial.copy()
                self._placements_seen = pool.placements
            n, con = d.ncon, d.contact
            p = self.outcome_params
            touching, knocked, stood, self._far_x, self._rear_foot = _k.outcome_cycle(
                con.geom[:n], con.pos[:n], con.frame[:n], con.efc_address[:n], con.dim[:n],
                d.efc_force, self._elliptic, pool.slot_of,
                pool.robot_mask(self.robot.robot_geoms), k, pool.body_ids, d.xpos, d.xmat,
                d.xquat, pool.half_sizes, pool.placed_pos, pool.placed_quat,
                self._cos_max_tilt, p.stand_face_tol, self._min_stand_force,
                int(p.stand_cycles), p.knock_shift, self._cos_half_max_turn, self._blk_touch,
                self._blk_top_force, self._blk_stand_run, self._blk_stood, self._blk_shift,
                self._blk_turn, self._blk_knocked, feet, self._prev_feet, self._has_prev_feet,
                np.array([math.cos(yaw), math.sin(yaw)]), self._blk_axis_sign,
                self._over_state, self._over_crossed, self._is_front, self._blk_over,
            )  # fmt: skip
            self.knocked |= knocked
            self.stood_on |= stood
        else:
            self._prev_feet[:] = feet
        self._has_prev_feet = True
        return touching

    def _blocks_stepped_over(self) -> np.ndarray:
        """(K,) bool: at least one front foot and one hind foot crossed the block above it."""
        # Kept by ``_check_blocks`` (``_kernels.outcome_cycle``) with the crossings.
        return self._blk_over[: len(self.pool.blocks)].copy()

    def _before_control(self, interrupt: np.ndarray, provision: np.ndarray) -> None:
        """Count the cycles whose (clipped) action used each output group."""
        super()._before_control(interrupt, provision)
        # ``_check_action`` found them while clipping (``interrupt.any()``, ``provision.any()``).
        groups = self._action_groups
        if groups & 1:
            self.interrupt_cycles += 1
        if groups & 2:
            self.provision_cycles += 1

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
        """The v1 outcome so far and its parts (the definitions are in the module docstring)."""
        if unstable or fell or self.knocked or self.stood_on:
            outcome = "fail"
        elif self.passed:
            outcome = "touch" if self.touched else "success"
        else:
            outcome = "fail"  # provisional: not passed (yet); final when the episode ends
        k = len(self.pool.blocks)
        over = self._blocks_stepped_over()
        blocks = self.pool.blocks_json()
        if blocks:
            knocked = self._blk_knocked[:k].tolist()
            stood = self._blk_stood[:k].tolist()
            shift = self._blk_shift[:k].tolist()
            turn = self._blk_turn[:k].tolist()
            crossed = self._over_crossed[:k].tolist()
            for i, b in enumerate(blocks):
                b.update(
                    knocked=knocked[i],
                    stood_on=stood[i],
                    moved=round(shift[i], 6),
                    turned_deg=round(math.degrees(turn[i]), 4),
                    feet_over=crossed[i],
                    stepped_over=bool(over[i]),
                )
        appeared = getattr(self, "appeared_at", None)
        from_appear = (
            round(self.passed_at - appeared, 4)
            if self.passed_at is not None and appeared is not None
            else None
        )
        return {
            "outcome": outcome,
            "passed": self.passed,
            "touched": self.touched,
            "knocked": self.knocked,
            "stood_on": self.stood_on,
            "stepped_over": bool(k and over.all()),
            "touch_events": self.touch_events,
            "fell": fell,
            "interrupt_cycles": self.interrupt_cycles,
            "provision_cycles": self.provision_cycles,
            "time_to_pass_from_appear": from_appear,
            "obstacles": blocks,
        }

    # -- observation ----------------------------------------------------------------------------

    def _objects(self, rot: np.ndarray, out: np.ndarray, mask: np.ndarray) -> np.ndarray:
        """The K nearest objects ahead in the torso's yaw frame (``rot``: world to yaw frame).

        Writes them into ``out`` (N_OBJECTS, 8) and ``mask`` (N_OBJECTS,), float32 zeros.

        Returns:
            (3,) float64 A_h, A_w, A_s of the nearest (``_no_best`` without one).
        """
        aff = self.pipeline.last
        if aff is None:
            return self._no_best
        min_height = self.pipeline.params.min_height
        objs = [o for o in aff.objects if o.kind == "object" and o.height >= min_height]
        if not objs:
            return self._no_best
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
        o = objs[order[0]]
        return np.array((o.height, o.width, o.length), dtype=np.float64)

    def _get_obs(self) -> dict[str, np.ndarray]:
        # One compiled pass (``_kernels.observation_kernel``) writes the keys into one new
        # float32 buffer; the observation's arrays are views of it (a new buffer every call,
        # so an observation kept by the caller is never overwritten).
        d, r = self.data, self.robot
        yaw = self._yaw() if self._yaw_now is None else self._yaw_now
        c, s = np.cos(yaw), np.sin(yaw)
        rot = None  # the yaw frame as a matrix, built only for what needs it
        torso = d.xpos[r.torso_body]
        touch = self.touch() if self._touch_now is None else self._touch_now
        buf = np.zeros(_k.N_OBS, np.float32)
        safe = np.empty(4, np.int8)
        best = self._no_best
        aff = self.pipeline.last
        if self._perceive and aff is not None and aff.objects:
            rot = np.array([c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.0]).reshape(3, 3)
            best = self._objects(
                rot, buf[_k.O_OBJECTS : _k.O_MASK].reshape(N_OBJECTS, len(OBJECT_FIELDS)),
                buf[_k.O_MASK : _k.O_AEF],
            )  # fmt: skip
        eff = self.eff
        if eff is None:
            direction, foothold = np.zeros((4, 3)), self._feet().copy()
            f_safe, p_safe, hit = np.ones(4, bool), np.ones(4, bool), np.full(4, -1, np.int64)
        else:
            direction, foothold = eff.direction, eff.foothold
            f_safe, p_safe, hit = eff.foothold_safe, eff.path_safe, eff.hit
        memory = self.effectivity.memory
        k = len(memory)
        if k > MEMORY_SLOTS:
            centre = 0.5 * (memory[:, 0] + memory[:, 1])
            dist = np.hypot(centre[:, 0] - torso[0], centre[:, 1] - torso[1])
            keep = np.sort(np.argsort(dist, kind="stable")[:MEMORY_SLOTS])
        else:
            keep = self._arange[:k]
        # The world axis (of +x, +y, -x, -y) nearest the heading is the boxes' length axis.
        quarter = round(yaw / (0.5 * np.pi))  # half to even, as np.round
        rel_yaw = (0.5 * np.pi * quarter - yaw + np.pi) % (2 * np.pi) - np.pi
        _k.observation_kernel(
            d.qpos, d.qvel, r.qpos_adr, r.dof_adr, touch, d.xmat[r.torso_body],
            self.generator.cpg.y, self.generator.pools.target, c, s, torso, d.site_xpos,
            r.foot_site, d.xpos, r.hip_body, r.thigh_body, r.shank_body, direction, foothold,
            f_safe, p_safe, hit, memory, keep, rel_yaw, quarter % 2 == 0, best,
            self._slot_scratch, buf, safe,
        )  # fmt: skip
        obs = {key: buf[a:b] for key, (a, b) in self._obs_proprio}
        if self._perceive:
            for key, (a, b) in self._obs_perceived:
                obs[key] = buf[a:b]
                if key == "foothold":
                    obs["foothold_safe"] = safe
        obs["feet"] = buf[_k.O_FEET : _k.O_LEG_JOINTS]
        obs["leg_joints"] = buf[_k.O_LEG_JOINTS : _k.N_OBS]
        if self.privileged:
            if rot is None:
                rot = np.array([c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.0]).reshape(3, 3)
            obs["true_blocks"] = self._true_blocks(rot, torso)
        if self.include_graph:
            g = self.pipeline.net.padded(self.graph_max_nodes, self.graph_max_edges)
            obs["graph_nodes"] = g.nodes.astype(np.float32).ravel()
            obs["graph_edges"] = g.edges.astype(np.int64).ravel()
            obs["graph_counts"] = np.array([g.n_nodes, g.n_edges], np.int64)
        if self._with_depth:
            obs["depth"] = self._depth_image.copy()  # the buffer changes with the next frame
        return obs

    def _true_blocks(self, rot: np.ndarray, torso: np.ndarray) -> np.ndarray:
        """(TRUE_BLOCK_SLOTS * 7,) the placed blocks' true current boxes (privileged).

        Per slot: valid (1/0), centre x, y relative to the torso in its yaw frame (m), yaw of
        the block's length axis relative to the heading (rad), half length, half width (m),
        height of its top above the floor (m). Read from MuJoCo's geom poses, so a pushed block
        is where it is now.
        """
        out = np.zeros((TRUE_BLOCK_SLOTS, len(BLOCK_FIELDS)), np.float32)
        d, m = self.data, self.model
        heading = np.arctan2(rot[0, 1], rot[0, 0])
        for k, g in enumerate(self.pool.geom_ids[: min(len(self.pool.blocks), TRUE_BLOCK_SLOTS)]):
            c = d.geom_xpos[g]
            xmat = d.geom_xmat[g].reshape(3, 3)
            rel = rot @ (c - torso)
            yaw = np.arctan2(xmat[1, 0], xmat[0, 0]) - heading
            yaw = (yaw + np.pi) % (2 * np.pi) - np.pi
            half = m.geom_size[g]
            out[k] = (1.0, rel[0], rel[1], yaw, half[0], half[1], c[2] + half[2])
        return out.ravel()

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

    def foothold_marker_safe(self) -> np.ndarray:
        """(4,) bool: which predicted footholds the overlay draws green (the rest red).

        Here: outside every remembered block, on the foothold and along the swing path (the
        ``foothold_safe`` and ``path_meets_block`` checks); the stepping stones add the map's
        support under the foothold.
        """
        return np.asarray(self.eff.foothold_safe, bool) & np.asarray(self.eff.path_safe, bool)


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
    safe, red unsafe: ``env.foothold_marker_safe``).
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
        marker_safe = env.foothold_marker_safe()
        for leg in range(4):
            safe = marker_safe[leg]
            rgba = np.array([0.1, 0.9, 0.2, 0.9]) if safe else np.array([1.0, 0.1, 0.1, 0.9])
            pos = env.eff.foothold[leg].copy()
            pos[2] = max(pos[2], 0.0) + 0.005
            markers.append({"type": mujoco.mjtGeom.mjGEOM_CYLINDER,
                            "size": np.array([0.025, 0.025, 0.004]), "pos": pos,
                            "rgba": rgba})  # fmt: skip
    return markers
