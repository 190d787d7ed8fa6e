"""NeuroCog/SteppingStones-v3: flat stones over a pit, where the footing position decides (§6.4).

The paper's Supplementary Videos S2 and S3 (§6.4): the affordance marks where the next step
would land, green when the area is safe and red when it is not, and the robot steps onto the
green area of the map; in S3 the stones move. Issue 26.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
from gymnasium import spaces
from gymnasium.utils import EzPickle

from neurocog_gym.envs.obstacle import ObstacleEnv
from neurocog_gym.robot.names import FRONT_LEGS
from neurocog_gym.robot.stones import (
    N_STONE_SLOTS,
    Course,
    CourseParams,
    StonePool,
    build_model,
    draw_course,
)

STONE_FIELDS = ("valid", "x", "y", "half_length", "half_width", "top", "speed_y")
"""One row of the privileged ``true_stones`` observation."""
TRUE_STONE_SLOTS = N_STONE_SLOTS
"""Rows of ``true_stones``: the start platform, the end platform, then the stones."""


@dataclass(frozen=True)
class SupportParams:
    """How a predicted foothold is judged supported from the map (``foothold_supported``)."""

    tilt_deg: float = 20.0
    """degrees: a supporting facet's normal lies within this of world up."""
    level_tol: float = 0.02
    """m: a supporting facet's three nodes lie within this of the walking level."""
    drop_tol: float = 0.05
    """m: a map node this far below the walking level is the pit."""
    radius: float = 0.03
    """m: no pit node may lie within this (horizontally) of the foothold (about a sole and a
    half: the foot needs its whole sole on the stone)."""

    def __post_init__(self):
        for name in ("tilt_deg", "level_tol", "drop_tol", "radius"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"SupportParams.{name} must be a positive number, got {v}")


def perceived_support(
    points_xy: np.ndarray,
    nodes: np.ndarray,
    facets: np.ndarray,
    facet_normals: np.ndarray,
    level: float,
    params: SupportParams,
) -> np.ndarray:
    """Whether the map shows level ground under each point.

    A point is supported when (1) its horizontal position lies in the ground-plane projection of
    a facet whose normal is within ``tilt_deg`` of up and whose three nodes lie within
    ``level_tol`` of ``level``, and (2) no graph node within ``radius`` of it horizontally lies
    more than ``drop_tol`` below ``level`` (the pit seen next to it). No facets: unsupported.

    Args:
        points_xy: (N, 2) world x, y, m.
        nodes: (n, 3) graph node positions, m.
        facets: (F, 3) node indices.
        facet_normals: (F, 3) unit normals.
        level: m, height of the walking surface.
        params: thresholds.

    Returns:
        (N,) bool.
    """
    pts = np.asarray(points_xy, dtype=np.float64).reshape(-1, 2)
    out = np.zeros(len(pts), dtype=bool)
    if len(facets) == 0 or len(nodes) == 0 or int(facets.max()) >= len(nodes):
        return out
    tri = nodes[facets]  # (F, 3, 3)
    level_ok = np.all(np.abs(tri[:, :, 2] - level) <= params.level_tol, axis=1)
    level_ok &= np.abs(facet_normals[:, 2]) >= math.cos(math.radians(params.tilt_deg))
    tri = tri[level_ok]
    if len(tri):
        a, b, c = tri[:, 0, :2], tri[:, 1, :2], tri[:, 2, :2]
        v0, v1 = b - a, c - a
        den = v0[:, 0] * v1[:, 1] - v0[:, 1] * v1[:, 0]
        good = np.abs(den) > 1e-12
        d = pts[:, None, :] - a[None]  # (N, F, 2)
        with np.errstate(divide="ignore", invalid="ignore"):
            u = (d[..., 0] * v1[None, :, 1] - d[..., 1] * v1[None, :, 0]) / den
            w = (v0[None, :, 0] * d[..., 1] - v0[None, :, 1] * d[..., 0]) / den
        inside = good & (u >= -1e-9) & (w >= -1e-9) & (u + w <= 1 + 1e-9)
        out = inside.any(axis=1)
    low = nodes[nodes[:, 2] < level - params.drop_tol]
    if len(low) and out.any():
        dist2 = ((pts[:, None, :] - low[None, :, :2]) ** 2).sum(axis=2)
        out &= ~(dist2 <= params.radius**2).any(axis=1)
    return out


class SteppingStonesEnv(ObstacleEnv):
    """A course of flat stones over a pit: the robot must put every foot on a stone.

    The walking surface is z = 0: a start platform (the robot stands on it), two rows of stones
    (one under each track of feet, the left at y = +12 cm, the right at -12 cm) and an end
    platform, all flat boxes with their tops at z = 0, over a pit whose floor is ``pit_depth``
    (25 cm) below. Course figures (:class:`~neurocog_gym.robot.stones.CourseParams`, drawn from
    the env's seeded ``np_random`` at every reset): stones 12-25 cm long and wide, 5-15 cm gaps
    along each row (also between the platforms and the first and last stones), centres within
    ±4 cm of their row's line, the start platform's edge 25-50 cm ahead of the front feet, the
    rows 1.0-1.5 m long. With ``moving=True`` every stone slides sideways (world y) back and
    forth within ±5 cm of its place at 2-5 cm/s (Video S3). The boxes are preallocated mocap
    bodies placed at reset (the model is built once per env, with ``MjSpec``).

    ## Action space

    As ``NeuroCog/Walk-v3``: ``Box(-1, 1, (15,), float32)``, 12 joint interrupts and 3 walking
    provisions; all zeros is plain CPG walking.

    ## Observation space

    The keys of ``NeuroCog/StaticObstacle-v3`` (same observation modes; the block keys stay,
    and are empty unless the map reports an object), plus:

    | key | shape | meaning |
    |---|---|---|
    | foothold_supported | (4,) | 1 if the map shows level ground under the leg's predicted foothold (``perceived_support``: inside a level facet at the walking level, no pit node within 3 cm); from the DD-GNG map and its facets, never from the stones' poses |
    | foothold_safe | (4,) | the obstacle envs' check (outside every remembered block) and ``foothold_supported`` |
    | true_stones | (168,) | privileged (``privileged=True`` only): 24 rows of ``STONE_FIELDS`` (valid, centre x, y in the heading frame, half length, half width along world x, y, top height, sliding velocity along world y now, m/s), row 0 the start platform, row 1 the end platform; the simulator's truth, for a privileged oracle |

    The walking level for ``foothold_supported`` is the height the robot stands at: the median
    height of its stance soles (the effectivity's stance legs) less the sole radius.
    ``foothold_supported`` and ``foothold_safe`` are not in the ``depth_only`` mode (no map).

    ## Rewards

    As ``NeuroCog/Walk-v3``, plus ``reward_pass`` = +100 on the step that completes the
    crossing (as the obstacle envs' pass bonus: the episode ends there).

    ## Episode end and outcome (``info["outcome"]``)

    Checked once per control cycle, after its physics steps:

    * **in the pit**: a sole's centre (its foot site) is more than ``pit_tolerance`` (2 cm,
      about a sole's radius: the whole foot below the stones' tops) below the walking surface
      z = 0. Terminates the episode.
    * **crossed**: every sole is beyond the end platform's near edge (world x) by
      ``pass_margin`` (2 cm), with the robot upright (not fallen) and never in the pit.
      Terminates the episode.
    * ``success`` = crossed; ``fail`` = a foot in the pit, a fall (torso tilted over 60° or
      lower than 0.12 m above the walking surface), the physics became unstable, or not
      crossed when the time limit (1500 steps, 15 s, from the registration) truncates it.
      ``touch`` is never given. ``info`` also has ``in_pit``, ``pit_leg`` (0..3 FL, FR, HL,
      HR, -1 none), ``pit_at`` (s), ``crossed``, ``course`` (the drawn course).

    ## Arguments

    As ``WalkEnv`` and the obstacle envs' perception arguments (``tof``, ``perception``,
    ``effectivity``, ``include_graph``, ``draw_overlay``, ``warmup_cycles``, ``pass_margin``,
    ``privileged``, ``affordance_source``, ``observation_mode``; ``outcome``, the blocks'
    thresholds, is unused: there are no blocks), plus:

    | argument | default | meaning |
    |---|---|---|
    | moving | False | stones slide sideways (Video S3) |
    | pit_depth | 0.25 | m, the pit floor below the walking surface |
    | pit_tolerance | 0.02 | m, how far below the surface a sole's centre is in the pit |
    | course | None | ``CourseParams``; None: the defaults above |
    | support | None | ``SupportParams`` of ``foothold_supported``; None: the defaults |
    """  # noqa: E501

    def __init__(
        self,
        moving: bool = False,
        pit_depth: float = 0.25,
        pit_tolerance: float = 0.02,
        course: CourseParams | None = None,
        support: SupportParams | None = None,
        **kwargs,
    ):
        if not isinstance(moving, bool | np.bool_):
            raise ValueError(f"moving must be True or False, got {moving!r}")
        if not (math.isfinite(pit_depth) and 0.05 <= pit_depth <= 2.0):
            raise ValueError(f"pit_depth must be in [0.05, 2] m, got {pit_depth}")
        if not (math.isfinite(pit_tolerance) and 0.0 < pit_tolerance < pit_depth):
            raise ValueError(
                f"pit_tolerance must be in (0, pit_depth) m, got {pit_tolerance} "
                f"(pit_depth {pit_depth})"
            )
        if course is not None and not isinstance(course, CourseParams):
            raise ValueError(f"course must be a CourseParams or None, got {type(course).__name__}")
        if support is not None and not isinstance(support, SupportParams):
            raise ValueError(
                f"support must be a SupportParams or None, got {type(support).__name__}"
            )
        self.moving = bool(moving)
        self.pit_depth = float(pit_depth)
        self.pit_tolerance = float(pit_tolerance)
        self.course_params = course or CourseParams()
        self.support_params = support or SupportParams()
        super().__init__(**kwargs)
        EzPickle.__init__(
            self, moving=moving, pit_depth=pit_depth, pit_tolerance=pit_tolerance, course=course,
            support=support, **self._ezpickle_kwargs,
        )  # fmt: skip
        self.stones = StonePool(self.model, self.pit_depth)
        self.course: Course | None = None
        self._level = 0.0
        self._reset_pit()

    def _build_model(self) -> mujoco.MjModel:
        """The stones scene (``robot.stones.build_model``) with this env's body."""
        return build_model(self.pit_depth, body=self.body)

    # -- spaces -------------------------------------------------------------------------------

    def _observation_spaces(self) -> dict[str, spaces.Space]:
        s = super()._observation_spaces()
        if self._perceive:
            s["foothold_supported"] = spaces.MultiBinary(4)
        if self.privileged:
            n = TRUE_STONE_SLOTS * len(STONE_FIELDS)
            s["true_stones"] = spaces.Box(-np.inf, np.inf, (n,), np.float32)
        return s

    # -- episode ------------------------------------------------------------------------------

    def _reset_pit(self) -> None:
        self.in_pit = False
        self.pit_leg = -1
        self.pit_at: float | None = None
        self.crossed = False
        self._crossed_now = False

    def _place_initial_obstacles(self) -> None:
        super()._place_initial_obstacles()
        self._reset_pit()
        front = float(self._feet()[list(FRONT_LEGS), 0].max())
        self.course = draw_course(self.np_random, self.course_params, front, self.moving)
        self.stones.place(self.model, self.data, self.course)
        self._level = 0.0

    def _before_control(self, interrupt: np.ndarray, provision: np.ndarray) -> None:
        super()._before_control(interrupt, provision)
        if self.stones.moving:
            # Where the stones are at the end of this cycle (mocap: moved, not driven).
            self.stones.move(self.data, float(self.data.time) + self._cycle_dt)

    def _after_physics(self) -> None:
        super()._after_physics()
        feet = self._feet()
        low = feet[:, 2] < -self.pit_tolerance
        if low.any() and not self.in_pit:
            self.in_pit = True
            self.pit_leg = int(np.flatnonzero(low)[0])
            self.pit_at = float(self.data.time)
        self._crossed_now = False
        if self.course is not None and not self.in_pit and not self.crossed:
            beyond = bool(feet[:, 0].min() > self.course.end_edge + self.pass_margin)
            if beyond and not self._fell():
                self.crossed = self._crossed_now = True
                self.passed_at = float(self.data.time)
        self.passed = self.crossed

    def step(self, action):
        """One control cycle; terminates when the robot crosses, steps into the pit or falls."""
        obs, reward, terminated, truncated, info = super().step(action)
        if self.in_pit and not info.get("sim_unstable"):
            terminated = True
        return obs, reward, terminated, truncated, info

    def _outcome(self, fell: bool, unstable: bool) -> dict:
        """The outcome so far (defined in the class docstring); provisional until the end."""
        outcome = "success" if self.crossed and not (unstable or fell or self.in_pit) else "fail"
        return {
            "outcome": outcome,
            "passed": self.crossed,
            "crossed": self.crossed,
            "in_pit": self.in_pit,
            "pit_leg": self.pit_leg,
            "pit_at": self.pit_at,
            "touched": False,
            "knocked": False,
            "stood_on": False,
            "stepped_over": False,
            "touch_events": 0,
            "fell": fell,
            "interrupt_cycles": self.interrupt_cycles,
            "provision_cycles": self.provision_cycles,
            "time_to_pass_from_appear": self.passed_at,
            "obstacles": [],
            "course": self.course.to_json() if self.course is not None else None,
        }

    def _reward(self, x_vel: float, power: float) -> tuple[float, dict]:
        """The walk's reward and ``reward_pass`` +100 on crossing (see the class docstring)."""
        r, terms = super()._reward(x_vel, power)
        bonus = 100.0 if self._crossed_now else 0.0
        terms["reward_pass"] = bonus
        return r + bonus, terms

    # -- observation --------------------------------------------------------------------------

    def walking_level(self) -> float:
        """m, the height the robot stands at: median stance-sole height less the sole radius."""
        eff = self.eff
        if eff is not None:
            stance = ~eff.swinging
            if stance.any():
                z = self._feet()[stance, 2]
                self._level = float(np.median(z)) - self.effectivity.p.foot_radius
        return self._level

    def foothold_supported(self) -> np.ndarray:
        """(4,) bool: the map shows level ground under each leg's predicted foothold."""
        if self.eff is None or not self._perceive:
            return np.zeros(4, dtype=bool)
        aff = self.pipeline.last
        if aff is None:
            return np.zeros(4, dtype=bool)
        nodes = np.asarray(self.pipeline.net.nodes, dtype=np.float64).reshape(-1, 3)
        return perceived_support(
            self.eff.foothold[:, :2], nodes, aff.facets, aff.facet_normals,
            self.walking_level(), self.support_params,
        )  # fmt: skip

    def foothold_marker_safe(self) -> np.ndarray:
        """(4,) bool: which predicted footholds the overlay draws green.

        Here ``foothold_safe``'s answer, the map's support included, with no block in the swing's
        way (Video S2's green and red circles).
        """
        return super().foothold_marker_safe() & self.foothold_supported()

    def _get_obs(self) -> dict[str, np.ndarray]:
        obs = super()._get_obs()
        if self._perceive:
            sup = self.foothold_supported()
            obs["foothold_supported"] = sup.astype(np.int8)
            obs["foothold_safe"] = (obs["foothold_safe"].astype(bool) & sup).astype(np.int8)
        if self.privileged:
            obs["true_stones"] = self._true_stones()
        return obs

    def _true_stones(self) -> np.ndarray:
        """(TRUE_STONE_SLOTS * 7,) float32 rows of ``STONE_FIELDS`` (privileged truth)."""
        out = np.zeros((TRUE_STONE_SLOTS, len(STONE_FIELDS)), np.float32)
        if self.course is None:
            return out.ravel()
        yaw = self._yaw() if self._yaw_now is None else self._yaw_now
        c, s = math.cos(yaw), math.sin(yaw)
        torso = self.data.xpos[self.robot.torso_body]
        boxes = self.stones.boxes(self.data)
        t = float(self.data.time)
        speeds = [0.0, 0.0] + [st.vy_at(t) for st in self.course.stones]
        for k, b in enumerate(boxes[:TRUE_STONE_SLOTS]):
            centre = 0.5 * (b[0] + b[1])
            dx, dy = centre[0] - torso[0], centre[1] - torso[1]
            half = 0.5 * (b[1] - b[0])
            out[k] = (1.0, c * dx + s * dy, -s * dx + c * dy, half[0], half[1], b[1, 2],
                      speeds[k])  # fmt: skip
        return out.ravel()


__all__ = ["STONE_FIELDS", "SteppingStonesEnv", "SupportParams", "perceived_support"]
