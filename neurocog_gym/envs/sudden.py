"""NeuroCog/SuddenObstacle-v3: a wooden block appears in a front leg's swing path (§6.5.1)."""

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
    Here, after a random ``appear_after`` time (uniform in ``appear_window``), the next
    lift-off of a front leg (its sole unloads while the CPG is in that leg's swing phase) starts
    the clock; ``appear_delay`` (0.1 s) later, while that foot is still in the air, one block
    (or, with probability ``pair_probability``, two blocks side by side) appears in the area of
    the leg's next foothold — the effectivity's predicted foothold, as the policy observes it:
    the block's near face lies between the foot (plus its sole radius and ``min_gap``) and the
    foothold, and the foothold lies inside the block's footprint or at most a sole radius short
    of its near face, so an unchanged swing lands on the block or runs into it. A swing that
    touches down before ``appear_delay`` (a flickering contact, not a step) gets no block; the
    next lift-off starts the clock again. ``info["appear_swing_phase"]`` is the seconds since
    that leg's lift-off at the appearance. Heights are the paper's 6, 7, 8 cm with ±5 mm jitter;
    lengths 5-12 cm along the path, widths 10-30 cm. The blocks are placed in front of the
    robot, never into it: a placement that comes closer than ``min_gap`` to a robot geom (the
    other front leg often stands where a wide block would go) is drawn again, up to
    ``placement_tries`` times, and if none fits, the block appears in the next front swing
    instead.

    Every episode gets its block: if no front lift-off has come ``appear_deadline`` s after
    ``appear_after`` (an agent can keep the front soles loaded or hold a swing back — a PPO
    policy learned to, and walked 7 s without ever meeting a block), the block appears then,
    across the path of the front leg the CPG swings (or, if it swings neither, of the less loaded
    one), in the area of its predicted foothold (a nominal swing from now if the effectivity
    sees no swing), and ``info["appear_forced"]`` is True. A lift-off whose ``appear_delay`` is
    running when the deadline comes is waited for. The CPG's trot lifts a front foot every
    ~0.23 s, so the default 1 s never fired under the blind, AEF or (v0) avoid controllers.

    ## Action space, observation space

    As ``NeuroCog/Walk-v3`` (15-value AEF output layer), plus these observation keys. Every
    key is 1-D (tables are flattened row by row; ``reshape`` gives them back), so
    stable-baselines3's ``check_env`` is silent and its ``MultiInputPolicy`` takes them as they
    are. They are what the perception and the effectivity compute (§4.2.3), never a decision:
    which output group acts is the policy's choice (``policies.AEFPolicy`` runs the fit,
    ``locomotion/fit.py``, on these keys). Walk's ``cpg`` and ``servo_target`` are plant state,
    not controller state: the action enters the motor-neuron pools and the CPG's drive where the
    AEF's outputs enter them, so the CPG's rhythm and the pools' targets are the state of the
    system the agent drives, like the joint angles. "Heading frame": x, y from the torso in its
    yaw frame (x ahead, y left), z above the floor, m.

    | key | shape | meaning |
    |---|---|---|
    | objects | (32,) | the 4 nearest perceived objects ahead, 8 values each (``reshape(4, 8)``): offset from the torso in its yaw frame (3), height, width, length, gamma, density |
    | objects_mask | (4,) | 1 for a valid row |
    | aef_input | (31,) | the AEF's inputs (Fig. 7): A_h, A_w, A_s, the 4 x 3 interrupt directions (as ``interrupt_direction``), 12 joint angles, 4 touch |
    | interrupt_direction | (12,) | each leg's interrupt direction v^l (``reshape(4, 3)``): the foot velocity relative to the torso in its yaw frame, m/s, that carries the swing up and over the block it meets; 0 for a leg without one |
    | foothold | (12,) | each leg's predicted foothold in the heading frame (``reshape(4, 3)``; a stance leg's is where it stands) |
    | foothold_safe | (4,) | 1 if that foothold lies outside every remembered block grown by the margin |
    | path_meets_block | (4,) | 1 if the leg swings and its predicted swing path enters a remembered block grown by the margin |
    | block_met | (4,) | the ``remembered_blocks`` row of the block the leg's foothold lies in (first) or its swing path meets, -1 none |
    | remembered_blocks | (56,) | the effectivity's obstacle memory (``reshape(8, 7)``): valid, centre x, y in the heading frame, yaw of the box side nearest the heading (within ±45°), half length along it, half width, top above the floor; kept until the feet are past, also out of the sensors' view (under the body); the nearest 8 |
    | feet | (12,) | soles in the heading frame (``reshape(4, 3)``) |
    | leg_joints | (36,) | each leg's abduction, hip and knee joint in the heading frame (``reshape(4, 3, 3)``) |
    | graph_nodes | (3 graph_max_nodes,) | the DD-GNG graph's node positions, padded with 0 (``reshape(-1, 3)``; ``include_graph=True`` only) |
    | graph_edges | (2 graph_max_edges,) | its edges as node index pairs, padded with -1 (``reshape(-1, 2)``) |
    | graph_counts | (2,) | the valid nodes and edges |

    ## Rewards

    As ``NeuroCog/Walk-v3``, plus ``reward_touch`` = -``touch_cost`` (default 1) on each new
    contact with an obstacle and
    ``reward_pass`` = +100 when the robot passes (the episode ends there; 100 = 1 / (1 - 0.99)
    stands in for the walk that would follow, see ``_reward``).

    ## Episode end and outcome

    Terminates when every foot is past the obstacles (``info["outcome"]`` success or touch) or
    the robot falls (fail); truncated at 700 steps (7 s) by the registration — not passed is a
    fail. See ``ObstacleEnv`` for the exact definitions of passed and touched.

    ## Arguments

    As ``WalkEnv``, plus ``appear_window`` (s, default (1.0, 2.0)), ``appear_delay`` (s, 0.1:
    from a front lift-off to the block's appearance, §6.2), ``appear_deadline`` (s, 1.0),
    ``pair_probability`` (0.3),
    ``min_gap`` (m, 0.01: closest a new block may come to the robot), ``placement_tries`` (5),
    ``touch_cost`` (1.0: the reward lost per new contact with a block; with the pass bonus of 100
    a touched pass earns nearly what a clean one does — raise it to make touching matter),
    ``tof`` (``ToFParams``), ``perception`` (``PipelineParams``: ``gng="gng"`` switches the
    attention off), ``effectivity``, ``include_graph``, ``warmup_cycles``, ``outcome``
    (``OutcomeParams``: the knock and stand-on thresholds), ``privileged`` (False; True adds
    the simulator's truth for the privileged oracle: ``true_blocks`` (4 x 7, flattened: valid,
    centre x, y in the heading frame, yaw of the length axis relative to the heading, half
    length, half width, top height)).
    """  # noqa: E501

    def __init__(
        self,
        appear_window: tuple[float, float] = (1.0, 2.0),
        appear_delay: float = 0.1,
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
        if not (math.isfinite(appear_delay) and appear_delay >= 0.0):
            raise ValueError(f"appear_delay must be a finite number >= 0 s, got {appear_delay}")
        if not appear_deadline >= 0.0:
            raise ValueError(f"appear_deadline must be >= 0 s, got {appear_deadline}")
        if not 0.0 <= pair_probability <= 1.0:
            raise ValueError(f"pair_probability must be in [0, 1], got {pair_probability}")
        if not min_gap >= 0.0:
            raise ValueError(f"min_gap must be >= 0 m, got {min_gap}")
        if int(placement_tries) < 1:
            raise ValueError(f"placement_tries must be >= 1, got {placement_tries}")
        self.appear_window = (float(lo), float(hi))
        self.appear_delay = float(appear_delay)
        self.appear_deadline = float(appear_deadline)
        self.pair_probability = float(pair_probability)
        self.min_gap = float(min_gap)
        self.placement_tries = int(placement_tries)
        super().__init__(**kwargs)
        from gymnasium.utils import EzPickle

        EzPickle.__init__(
            self, appear_window=appear_window, appear_delay=appear_delay,
            appear_deadline=appear_deadline,
            pair_probability=pair_probability,
            min_gap=min_gap, placement_tries=placement_tries, touch_cost=touch_cost,
            **self._ezpickle_kwargs,
        )  # fmt: skip

    def _place_initial_obstacles(self) -> None:
        self.appear_after = float(self.np_random.uniform(*self.appear_window))
        self.appeared_at = None
        self.appear_leg = -1
        self.appear_forced = False
        self.appear_swing_phase = None
        self.appear_foothold = None
        self.rejected_swings = 0
        # Per front leg (lists: this runs every cycle until the block appears, on two values):
        # on the ground at the last cycle; its last lift-off (s), NaN while it is on the
        # ground; and which of them (index into FRONT_LEGS) has its appear_delay running, -1
        # for none.
        self._front_down = [True] * len(FRONT_LEGS)
        self._lift_at = [math.nan] * len(FRONT_LEGS)
        self._pending = -1

    def _task_event(self) -> None:
        if self.appeared_at is not None:
            return  # one sudden obstacle per episode
        front = FRONT_LEGS
        # This cycle's touch, read at the start of its _after_physics.
        all_touch = self._touch_now.tolist()
        touch = [all_touch[leg] for leg in front]
        off = self.effectivity.p.touch_off
        down = [x > off for x in touch]
        # A lift-off is the sole unloading while the CPG swings that leg: the touch signal alone
        # also drops for a cycle in mid-stance (a planted foot's contact flickers), and half of
        # such drops were not followed by a lift (measured: 51 % of bare touch drops, 95 % of
        # drops in the CPG's swing phase, lift the foot > 3 cm within 0.08 s).
        hip = self.generator.hip_drive.tolist()
        swinging = [hip[leg] > 0.0 for leg in front]  # generator.swinging[front]
        lifted = [
            a and not b and c for a, b, c in zip(self._front_down, down, swinging, strict=True)
        ]
        self._front_down = down
        t = float(self.data.time)
        lift_at = self._lift_at
        for i, (up, on_ground) in enumerate(zip(lifted, down, strict=True)):
            if up:
                lift_at[i] = t
            elif on_ground:
                lift_at[i] = math.nan  # on the ground: that swing is over
        if t < self.appear_after:
            return
        if self._pending >= 0 and math.isnan(lift_at[self._pending]):
            self._pending = -1  # it touched down within appear_delay: no swing to meet
        if self._pending < 0 and True in lifted:
            self._pending = lifted.index(True)
        if self._pending >= 0:
            # §6.2: the block appears about 0.1 s after the front leg's swing starts. (The 1e-9
            # absorbs the rounding of a time summed from physics steps.)
            if t - lift_at[self._pending] < self.appear_delay - 1e-9:
                return
            leg = FRONT_LEGS[self._pending]
            self._pending = -1
            forced = False
        elif t >= self.appear_after + self.appear_deadline:
            # No lift-off by the deadline: the block appears anyway, before the leg the CPG
            # swings, else before the less loaded front leg.
            if True in swinging:
                leg = FRONT_LEGS[swinging.index(True)]
            else:
                leg = FRONT_LEGS[int(np.argmin(touch))]
            forced = True
        else:
            return
        lift = lift_at[front.index(leg)]
        for _ in range(self.placement_tries):
            for b in self._draw_blocks(leg):
                self.pool.add(self.model, self.data, b)
            if self._gap_to_robot() >= self.min_gap:
                self.appeared_at = t
                self.appear_leg = int(leg)
                self.appear_forced = forced
                self.appear_swing_phase = None if np.isnan(lift) else round(t - float(lift), 6)
                return
            # Placed by hand in front of the robot, never into it: take the blocks away again.
            self.pool.place(self.model, self.data, [])
        self.appear_foothold = None
        self.rejected_swings += 1  # no free spot in this swing's path: wait for the next one

    def _next_foothold(self, leg: int, heading: np.ndarray) -> np.ndarray:
        """(2,) world x, y where ``leg``'s swing will land: the effectivity's prediction.

        The prediction of the last control cycle, the one the policy observed (``foothold``); a
        leg the effectivity does not see swinging (a forced placement) gets a nominal swing
        from now, the effectivity's rule with the whole swing time left.
        """
        eff = self.eff
        if eff is not None and eff.swinging[leg]:
            return eff.foothold[leg, :2].copy()
        p = self.effectivity.p
        hip = self.data.xpos[self.robot.hip_body[leg], :2]
        return hip + p.reach * heading + self.data.qvel[0:2] * p.swing_time

    def _draw_blocks(self, leg: int) -> list[Block]:
        """The block (and maybe its neighbour) over the next foothold of ``leg``.

        Along the heading, measured from the foot: the foothold is ``span`` ahead; the near face
        is drawn uniformly in ``[max(gap, span - length), max(that, span + r)]`` (``r`` the sole
        radius, ``gap`` = r + ``min_gap``), so the foothold lies inside the footprint or at most
        r short of the near face; across, the block is centred within ±3 cm of the foothold
        (its width is at least 10 cm).
        """
        rng = self.np_random
        p = self.effectivity.p
        yaw = self._yaw()
        heading = np.array([np.cos(yaw), np.sin(yaw)])
        across = np.array([-heading[1], heading[0]])
        foot = self._feet()[leg, :2]
        foothold = self._next_foothold(leg, heading)
        self.appear_foothold = foothold
        block = random_block(rng, 0.0, 0.0, yaw_range=0.25)
        span = float((foothold - foot) @ heading)
        r = p.foot_radius
        lo = max(r + self.min_gap, span - block.length)
        near = float(rng.uniform(lo, max(lo, span + r)))
        lateral = float((foothold - foot) @ across) + float(rng.uniform(-0.03, 0.03))
        centre = foot + (near + block.length / 2) * heading + lateral * across
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
        out["appear_swing_phase"] = self.appear_swing_phase
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
