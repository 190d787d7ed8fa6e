"""NeuroCog/SuddenObstacle-v0: a wooden block appears in a front leg's swing path (§6.5.1)."""

from __future__ import annotations

import math

import mujoco
import numpy as np

from neurocog_gym.envs.obstacle import ObstacleEnv
from neurocog_gym.robot.names import FRONT_LEGS
from neurocog_gym.robot.obstacles import Block, random_block


class SuddenObstacleEnv(ObstacleEnv):
    """The robot trots; at the start of a front leg's swing an obstacle appears in front of it.

    §6.5.1: "During the swinging phase (front leg lifted), some pieces of wood are moved and
    placed by hand immediately in front of the robot", at random positions and arrangements.
    Here, after a random ``appear_after`` time (uniform in ``appear_window``), at the next
    lift-off of a front leg (its sole unloads while the CPG is in that leg's swing phase), one
    block (or, with probability ``pair_probability``, two blocks side
    by side) is placed across that leg's swing path: the block's near face lies between the foot
    and its predicted foothold, so an unchanged swing runs into it or lands on it. Heights are the
    paper's 6, 7, 8 cm with ±5 mm jitter; lengths 5-12 cm along the path, widths 10-30 cm.
    The blocks are placed in front of the robot, never into it: a placement that comes closer
    than ``min_gap`` to a robot geom (the other front leg often stands where a wide block would
    go) is drawn again, up to ``placement_tries`` times, and if none fits, the block appears at
    the next front-leg lift-off instead.

    Every episode gets its block: if no front lift-off has come ``appear_deadline`` s after
    ``appear_after`` (an agent can keep the front soles loaded or hold a swing back — a PPO
    policy learned to, and walked 7 s without ever meeting a block), the block appears then,
    across the path of the front leg the CPG swings (or, if it swings neither, of the less loaded
    one), and ``info["appear_forced"]`` is True. The CPG's trot lifts a front foot every ~0.23 s,
    so the default 1 s never fires under the blind, AEF or avoid controllers.

    ## Action space, observation space

    As ``NeuroCog/Walk-v0`` (15-value AEF output layer), plus these observation keys:

    | key | shape | meaning |
    |---|---|---|
    | objects | (4, 8) | the 4 nearest perceived objects ahead: offset from the torso in its yaw frame (3), height, width, length, gamma, density |
    | objects_mask | (4,) | 1 for a valid row |
    | aef_input | (31,) | the AEF's inputs (Fig. 7): A_h, A_w, A_s, 4 x 3 interrupt directions (in mode 2 each leg's slot holds the effectivity's provision s_SAG, s_COR, s_DIR), 12 joint angles, 4 touch |
    | aef_mode | () | 0 nothing to do, 1 a swing must change (interrupt group), 2 change the walk (provision group): walk round an obstacle ahead, or stop, side-step and pass a block that appeared within reach |
    | foothold | (4, 3) | predicted footholds relative to the torso, yaw frame, m |
    | foothold_safe | (4,) | 1 if that foothold and swing path are clear of perceived obstacles |
    | graph_nodes, graph_edges, graph_counts | padded | the DD-GNG graph (``include_graph=True`` only) |

    ## Rewards

    As ``NeuroCog/Walk-v0``, plus ``reward_touch`` = -``touch_cost`` (default 1) on each new
    contact with an obstacle and
    ``reward_pass`` = +100 when the robot passes (the episode ends there; 100 = 1 / (1 - 0.99)
    stands in for the walk that would follow, see ``_reward``).

    ## Episode end and outcome

    Terminates when every foot is past the obstacles (``info["outcome"]`` success or touch) or
    the robot falls (fail); truncated at 700 steps (7 s) by the registration — not passed is a
    fail. See ``ObstacleEnv`` for the exact definitions of passed and touched.

    ## Arguments

    As ``WalkEnv``, plus ``appear_window`` (s, default (1.0, 2.0)), ``appear_deadline`` (s, 1.0),
    ``pair_probability`` (0.3),
    ``min_gap`` (m, 0.01: closest a new block may come to the robot), ``placement_tries`` (5),
    ``touch_cost`` (1.0: the reward lost per new contact with a block; with the pass bonus of 100
    a touched pass earns nearly what a clean one does — raise it to make touching matter),
    ``tof`` (``ToFParams``), ``perception`` (``PipelineParams``: ``gng="gng"`` switches the
    attention off), ``effectivity``, ``include_graph``, ``warmup_cycles``.
    """  # noqa: E501

    def __init__(
        self,
        appear_window: tuple[float, float] = (1.0, 2.0),
        appear_deadline: float = 1.0,
        pair_probability: float = 0.3,
        min_gap: float = 0.01,
        placement_tries: int = 5,
        touch_cost: float = 1.0,
        **kwargs,
    ):
        if not (math.isfinite(touch_cost) and touch_cost >= 0.0):
            raise ValueError(f"touch_cost must be a finite number >= 0, got {touch_cost}")
        self.touch_cost = float(touch_cost)
        lo, hi = appear_window
        if not (0.0 <= lo <= hi):
            raise ValueError(
                f"appear_window must be (lo, hi) with 0 <= lo <= hi, got {appear_window}"
            )
        if not appear_deadline >= 0.0:
            raise ValueError(f"appear_deadline must be >= 0 s, got {appear_deadline}")
        if not 0.0 <= pair_probability <= 1.0:
            raise ValueError(f"pair_probability must be in [0, 1], got {pair_probability}")
        if not min_gap >= 0.0:
            raise ValueError(f"min_gap must be >= 0 m, got {min_gap}")
        if int(placement_tries) < 1:
            raise ValueError(f"placement_tries must be >= 1, got {placement_tries}")
        self.appear_window = (float(lo), float(hi))
        self.appear_deadline = float(appear_deadline)
        self.pair_probability = float(pair_probability)
        self.min_gap = float(min_gap)
        self.placement_tries = int(placement_tries)
        super().__init__(**kwargs)
        from gymnasium.utils import EzPickle

        EzPickle.__init__(
            self, appear_window=appear_window, appear_deadline=appear_deadline,
            pair_probability=pair_probability,
            min_gap=min_gap, placement_tries=placement_tries, touch_cost=touch_cost,
            **self._ezpickle_kwargs,
        )  # fmt: skip

    def _place_initial_obstacles(self) -> None:
        self.appear_after = float(self.np_random.uniform(*self.appear_window))
        self.appeared_at = None
        self.appear_leg = -1
        self.appear_forced = False
        self.rejected_swings = 0
        self._front_down = np.ones(2, dtype=bool)

    def _task_event(self) -> None:
        if self.appeared_at is not None:
            return  # one sudden obstacle per episode
        touch = self._touch_now  # read at the start of this cycle's _after_physics
        down = touch[list(FRONT_LEGS)] > self.effectivity.p.touch_off
        # A lift-off is the sole unloading while the CPG swings that leg: the touch signal alone
        # also drops for a cycle in mid-stance (a planted foot's contact flickers), and half of
        # such drops were not followed by a lift (measured: 51 % of bare touch drops, 95 % of
        # drops in the CPG's swing phase, lift the foot > 3 cm within 0.08 s).
        swinging = self.generator.swinging[list(FRONT_LEGS)]
        lifted = self._front_down & ~down & swinging
        self._front_down = down
        if self.data.time < self.appear_after:
            return
        if lifted.any():
            leg = FRONT_LEGS[int(np.flatnonzero(lifted)[0])]
            forced = False
        elif self.data.time >= self.appear_after + self.appear_deadline:
            # No lift-off by the deadline: the block appears anyway, before the leg the CPG
            # swings, else before the less loaded front leg.
            if swinging.any():
                leg = FRONT_LEGS[int(np.flatnonzero(swinging)[0])]
            else:
                leg = FRONT_LEGS[int(np.argmin(touch[list(FRONT_LEGS)]))]
            forced = True
        else:
            return
        for _ in range(self.placement_tries):
            for b in self._draw_blocks(leg):
                self.pool.add(self.model, self.data, b)
            if self._gap_to_robot() >= self.min_gap:
                self.appeared_at = float(self.data.time)
                self.appear_leg = int(leg)
                self.appear_forced = forced
                return
            # Placed by hand in front of the robot, never into it: take the blocks away again.
            self.pool.place(self.model, self.data, [])
        self.rejected_swings += 1  # no free spot in this swing's path: wait for the next one

    def _draw_blocks(self, leg: int) -> list[Block]:
        """The block (and maybe its neighbour) across the swing path of ``leg``."""
        rng = self.np_random
        p = self.effectivity.p
        yaw = self._yaw()
        heading = np.array([np.cos(yaw), np.sin(yaw)])
        hip = self.data.xpos[self.robot.hip_body[leg], :2]
        foot = self._feet()[leg, :2]
        v = self.data.qvel[0:2]
        foothold = hip + p.reach * heading + v * p.swing_time
        block = random_block(rng, 0.0, 0.0, yaw_range=0.25)
        # Near face between the foot and the foothold: the swing meets the block.
        span = float((foothold - foot) @ heading)
        near = float(rng.uniform(0.45, 0.85)) * max(span, 0.05)
        centre = foot + (near + block.length / 2) * heading
        centre += float(rng.uniform(-0.03, 0.03)) * np.array([-heading[1], heading[0]])
        blocks = [
            Block(centre[0], centre[1], block.length, block.width, block.height, yaw + block.yaw)
        ]
        if rng.random() < self.pair_probability:
            side = 1.0 if rng.random() < 0.5 else -1.0
            other = random_block(rng, 0.0, 0.0, yaw_range=0.25)
            offset = side * (block.width + other.width) / 2 * np.array([-heading[1], heading[0]])
            c2 = centre + offset + float(rng.uniform(-0.03, 0.03)) * heading
            blocks.append(
                Block(c2[0], c2[1], other.length, other.width, other.height, yaw + other.yaw)
            )
        return blocks

    def _gap_to_robot(self) -> float:
        """Smallest distance between a placed block and a robot geom, m (< 0: they overlap)."""
        m, d = self.model, self.data
        cap = 1.0
        return min(
            mujoco.mj_geomDistance(m, d, int(g), int(r), cap, None)
            for g in self.pool.geom_ids[: len(self.pool.blocks)]
            for r in self.robot.robot_geoms
        )

    def _outcome(self, fell: bool, unstable: bool) -> dict:
        out = super()._outcome(fell, unstable)
        out["appeared_at"] = self.appeared_at
        out["appear_leg"] = self.appear_leg
        out["appear_forced"] = self.appear_forced
        out["rejected_swings"] = self.rejected_swings
        return out

    def _reward(self, x_vel: float, power: float) -> tuple[float, dict]:
        """The walk's reward, ``reward_touch`` -touch_cost per contact, ``reward_pass`` +100.

        Passing ends the episode, so its bonus stands in for the walk that would follow it:
        100 = 1 / (1 - 0.99), what walking on at the best per-step reward (1) would be worth at
        the usual discount 0.99. A smaller bonus makes passing a loss to a learner: ending the
        episode forfeits the walk, while dawdling in front of the block until the time limit
        truncates the episode keeps it (learners bootstrap on truncation).
        """
        r, terms = super()._reward(x_vel, power)
        new = self._was_touching and self.touch_events and self._new_touch()
        touch = -self.touch_cost if new else 0.0
        passed = 100.0 if self.passed else 0.0
        terms.update(reward_touch=touch, reward_pass=passed)
        return r + touch + passed, terms

    def _new_touch(self) -> bool:
        new = self.touch_events != getattr(self, "_touch_events_rewarded", 0)
        self._touch_events_rewarded = self.touch_events
        return new
