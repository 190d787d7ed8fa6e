"""Effectivity (§4.2.3, §5.2): what each leg is about to do, and whether the terrain affords it.

Two effectivities are used, as the paper names them: the prediction of each swinging leg's next
foothold and the inertial path of its swing. Both are predicted from the leg's state and the body
motion; both are checked against the obstacle boxes the perception reports (never against the
simulator's ground truth).

Per control cycle, for each leg:

* **Swing state.** A leg swings from lift-off (its touch sensor reads less than ``touch_off``)
  until touch-down. ``t_swing`` is the time since lift-off.
* **Foothold.** ``hip + R_yaw (reach, 0) + v_body * t_left``, with ``t_left = max(T_swing -
  t_swing, t_min)``: the foot lands ``reach`` ahead of its hip after the rest of a nominal swing
  of the body moving at its current velocity (a stance leg's foothold is where it stands).
* **Swing path.** ``n_path`` points from the foot to the foothold along an arc with apex
  ``clearance`` above the straight line (the nominal swing).
* **Safety.** A foothold is unsafe when it lies in an obstacle box grown by ``margin``; a swing
  path is unsafe when any of its points (as a sphere of the foot's radius) enters such a box.
* **Interrupt direction** v^l (the AEF's 3-D input per leg, Fig. 7) when a swinging leg's path
  or foothold is unsafe: "up and over" — the foot rises, then moves forward over the block — as
  the wanted foot velocity relative to the torso (see :class:`Effectivity`); zero for a leg
  with no interrupt in progress.

The effectivity predicts and checks; it decides nothing. Which of the AEF's output groups acts
on these predictions — the interrupt group on v^l, or the walking provision (walk round an
obstacle ahead, or stop, side-step and pass a block that appeared within reach) — is the fit,
``fit.py``, which runs on the policy's side of the observation (``policies.AEFPolicy``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from neurocog_gym.locomotion import _effectivity_kernel as _k
from neurocog_gym.locomotion._effectivity_kernel import (  # noqa: F401  (public constants)
    PHASE_NONE,
    PHASE_OVER,
    PHASE_UP,
)


@dataclass(frozen=True)
class EffectivityParams:
    """Effectivity geometry (our reading of §4.2.3; lengths in metres, times in seconds)."""

    reach: float = 0.06
    """Foothold ahead of the hip at touch-down, along the heading, m (measured on the gait)."""
    swing_time: float = 0.22
    """Nominal swing duration T_swing, s (measured on the gait)."""
    min_time_left: float = 0.03
    """Shortest predicted remaining swing, s."""
    clearance: float = 0.035
    """Nominal swing apex above the straight foot path, m (below the 6-8 cm blocks)."""
    foot_radius: float = 0.018
    """Sole sphere radius, m (assets/quadruped.xml)."""
    margin: float = 0.02
    """Safety margin around obstacle boxes, m."""
    n_path: int = 8
    """Points sampled along the predicted swing path."""
    touch_off: float = 0.05
    """Touch input below which a foot is in the air (1 = a quarter of the body weight)."""
    lift_speed: float = 0.8
    """Upward foot speed of the "up" phase of an interrupt, m/s."""
    carry_speed: float = 0.8
    """Forward foot speed over the block in the "over" phase, m/s (relative to the ground)."""
    lift_clearance: float = 0.0
    """How far the sole clears the (margin-grown) block top before the foot moves over it, m."""
    approach_gap: float = 0.02
    """Closest the foot may come to the grown block's near face while still below its top, m."""
    max_interrupt_time: float = 0.6
    """Longest an interrupt holds a leg, s."""
    forget_behind: float = 0.05
    """A remembered box is forgotten once every foot is this far past its far face, m."""
    forget_distance: float = 1.5
    """... or once it is farther than this from the torso, m."""


@dataclass
class EffectivityState:
    """Per-cycle effectivity output (all world frame unless noted)."""

    swinging: np.ndarray
    """(4,) bool."""
    foothold: np.ndarray
    """(4, 3) predicted footholds, m."""
    foothold_safe: np.ndarray
    """(4,) bool."""
    path_safe: np.ndarray
    """(4,) bool."""
    direction: np.ndarray
    """(4, 3) interrupt direction v^l per leg in the torso's yaw frame (x ahead, y left, z up):
    the foot velocity the interrupt asks for, relative to the torso, m/s; 0 without one."""
    hit: np.ndarray
    """(4,) int, index in :attr:`Effectivity.memory` of the box the leg's foothold lies in
    (checked first) or its swing path meets, -1 none."""
    phase: np.ndarray | None = None
    """(4,) int, each leg's interrupt phase: 0 none, 1 up, 2 over."""


class Effectivity:
    """Foothold and swing-path prediction and the AEF's interrupt directions (§4.2.3, §5.2).

    An interrupt, once fired for a leg, follows that leg's foot through the rest of its swing
    (closed loop, every cycle, against the box it was fired for):

    * **up** while the sole is below the block's top plus ``lift_clearance``: the foot rises at
      ``lift_speed`` and holds its ground position, backing off when it is closer than
      ``approach_gap`` to the near face;
    * **over** once it is high enough: it moves forward at ``carry_speed`` and keeps its height,
      until it is past the far face; then the CPG's own stance phase sets it down beyond.

    The interrupt ends when the foot is past the block, touches down, or after
    ``max_interrupt_time``. The direction handed to the AEF is the wanted foot velocity relative
    to the torso in its yaw frame, the quantity the AEF's inverse model learned in motor
    babbling (``train/babbling.py``).

    The arithmetic of a cycle is one numba call (``_effectivity_kernel.py``); this class owns
    the state. The obstacle memory holds at most ``memory_capacity`` boxes (the oldest go).
    """

    memory_capacity = 64

    def __init__(self, params: EffectivityParams | None = None):
        self.p = params or EffectivityParams()
        p = self.p
        prm = np.zeros(_k.N_PARAMS)
        for index, value in (
            (_k.P_REACH, p.reach), (_k.P_SWING_TIME, p.swing_time),
            (_k.P_MIN_TIME_LEFT, p.min_time_left), (_k.P_CLEARANCE, p.clearance),
            (_k.P_FOOT_RADIUS, p.foot_radius), (_k.P_MARGIN, p.margin),
            (_k.P_TOUCH_OFF, p.touch_off), (_k.P_LIFT_SPEED, p.lift_speed),
            (_k.P_CARRY_SPEED, p.carry_speed), (_k.P_LIFT_CLEARANCE, p.lift_clearance),
            (_k.P_APPROACH_GAP, p.approach_gap), (_k.P_MAX_INTERRUPT_TIME, p.max_interrupt_time),
            (_k.P_FORGET_BEHIND, p.forget_behind), (_k.P_FORGET_DISTANCE, p.forget_distance),
        ):  # fmt: skip
            prm[index] = float(value)
        self._prm = prm
        self._s_path = np.linspace(0.0, 1.0, p.n_path)
        self.lift_time = np.zeros(4)
        self.was_down = np.ones(4, dtype=bool)
        self.phase = np.zeros(4, dtype=np.int64)
        self.plan_box = np.zeros((4, 2, 3))
        self.plan_start = np.zeros(4)
        self._memory = np.zeros((self.memory_capacity, 2, 3))
        self._n_memory = 0

    @property
    def memory(self) -> np.ndarray:
        """(K, 2, 3) the remembered obstacle boxes (min/max corners), m."""
        return self._memory[: self._n_memory]

    def reset(self) -> None:
        """Forget swing timing, interrupts in progress and remembered obstacles."""
        self.lift_time[:] = 0.0
        self.was_down[:] = True
        self.phase[:] = PHASE_NONE
        self.plan_box[:] = 0.0
        self.plan_start[:] = 0.0
        self._n_memory = 0

    def remember(
        self, boxes: np.ndarray, foot: np.ndarray, torso: np.ndarray, heading: np.ndarray
    ) -> np.ndarray:
        """Merge the perceived boxes into the obstacle memory and return it.

        The sensors look ahead; an obstacle under the body (the hind legs' business) or right at
        the front feet is out of their view. The effectivity therefore keeps every perceived box
        until the robot has walked past it: a new box replaces the remembered ones it overlaps,
        and a box is forgotten once every foot is ``forget_behind`` past its far face or it is
        ``forget_distance`` away. (:meth:`step` does this itself.)
        """
        self._n_memory = _k.remember_kernel(
            self._memory, self._n_memory, _as_boxes(boxes), np.asarray(foot, dtype=np.float64),
            np.asarray(torso, dtype=np.float64), float(heading[0]), float(heading[1]),
            self.p.forget_behind, self.p.forget_distance,
        )  # fmt: skip
        return self.memory

    def step(
        self,
        t: float,
        touch: np.ndarray,
        foot: np.ndarray,
        hip: np.ndarray,
        yaw: float,
        v_body: np.ndarray,
        boxes: np.ndarray,
    ) -> EffectivityState:
        """Predict footholds and swing paths and check them against ``boxes``.

        Args:
            t: time, s.
            touch: (4,) normalised touch inputs.
            foot: (4, 3) foot positions, m.
            hip: (4, 3) hip positions, m.
            yaw: torso heading, rad.
            v_body: (3,) torso linear velocity, m/s (world).
            boxes: (K, 2, 3) perceived obstacle boxes (min/max corners), m; merged into the
                obstacle memory (:meth:`remember`), against which everything is checked.
        """
        swinging = np.empty(4, dtype=bool)
        foothold = np.empty((4, 3))
        foothold_safe = np.empty(4, dtype=bool)
        path_safe = np.empty(4, dtype=bool)
        direction = np.empty((4, 3))
        hit = np.empty(4, dtype=np.int64)
        self._n_memory = _k.effectivity_kernel(
            self._prm, self._s_path, float(t),
            np.asarray(touch, dtype=np.float64), np.asarray(foot, dtype=np.float64),
            np.asarray(hip, dtype=np.float64), float(yaw), float(v_body[0]), float(v_body[1]),
            _as_boxes(boxes), self.lift_time, self.was_down, self.phase, self.plan_box,
            self.plan_start, self._memory, self._n_memory,
            swinging, foothold, foothold_safe, path_safe, direction, hit,
        )  # fmt: skip
        return EffectivityState(
            swinging=swinging,
            foothold=foothold,
            foothold_safe=foothold_safe,
            path_safe=path_safe,
            direction=direction,
            hit=hit,
            phase=self.phase.copy(),
        )


def _as_boxes(boxes) -> np.ndarray:
    b = np.asarray(boxes, dtype=np.float64).reshape(-1, 2, 3)
    return b if b.flags.c_contiguous else np.ascontiguousarray(b)
