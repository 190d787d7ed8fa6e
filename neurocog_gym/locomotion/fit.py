"""The fit (§5.2): which of the AEF's two output groups acts, and what the walk-change teachers ask.

§5.2: "the AEF determines whether an object affects the robot's immediate needs". The
effectivity (``effectivity.py``) predicts each leg's foothold and swing path, checks them against
the remembered obstacle boxes and gives each interrupted leg its direction v^l; the fit decides,
every control cycle, from those predictions and the legs' positions, which group of the AEF's
output layer acts:

* **interrupt** (mode 1) while any leg has an interrupt direction: the interrupt group drives
  the joints of those legs;
* **provision** (mode 2) when no swing must change but an obstacle lies on or beside the path,
  from ``lookahead`` ahead until every foot is past it: walk round it (the walk-round rule,
  ``_fit_kernel.walk_around_kernel``; Fig. 20b: "moved left to avoid an obstacle further
  ahead"). The corridor (``corridor`` either side of the front hips' mid-point, across the
  path's heading) is shifted by s_COR, towards the side that needs the shorter step, until it
  clears the box, and kept clear while the box is alongside; s_SAG and s_DIR stay 0;
* **provision**, overriding both, while the stop / side-step / pass teacher is engaged
  (``avoidance.py``): for a block that appeared within reach of the legs, or any box taller than
  a swing clears that a swing meets (the box an interrupt would be for is offered to the teacher,
  :meth:`SuddenAvoidance.adopt`);
* **none** (mode 0) otherwise: the CPG walks alone.

In provision mode the AEF network's per-leg direction slots carry the wanted body motion
(s_SAG, s_COR, s_DIR) — the walk-round rule leaves s_DIR 0 — as in the network's training
(``train/aef.py``); in interrupt mode they carry v^l.

The walk-round works in the frame of the path (the heading of the robot's first cycle,
``SuddenAvoidance.yaw0``; the obstacle tasks walk along it), not the torso's current heading:
the trot sways the heading by a few degrees, which moved a box 1 m ahead by several
centimetres across the corridor and flipped the side chosen for a box near the path's middle
from cycle to cycle (issue 22, 2026-12-05). Until then the rule also stopped 0.2 m before the
box (``near``) and slowed to s_SAG -0.3 within 0.6 m; it now keeps the corridor clear until
the feet are past, with a corridor of 0.22 m (was 0.16: the sole's lane edge is at 0.14 m, and
the yaw sway of the trot swings the hind legs a few centimetres). Training trials (run seed
5, 60 static trials): the AEF passed 42 before, 58 after (the fit's own provision in place of
the network's: 54).
Heading hold (s_DIR against the heading error) and slowing for an uncleared box were tried and
dropped: with the provision's 0.5 s low-pass, heading feedback swung the yaw by 20-30 deg and
the trot fell in 6-9 of 40; a side step that ends abruptly (s_COR 1 -> 0) or dwells at
0.2-0.5 fell as often (Walk-v2, constant s_COR 0.2-0.5 for 6.5 s: 1-3 falls in 10; 0.7 and 1:
none).

The fit keeps state across an episode (the teacher's state, the boxes it has seen, its heading):
:meth:`Fit.reset` at every episode start. It runs on the policy's side of the observation; no env
runs it. :class:`Fit` (with ``avoidance.SuddenAvoidance``) is the readable form; the policy
(``policies.AEFPolicy``) runs the same decision as one compiled call
(``_fit_kernel.decide_kernel``, parameters from :func:`kernel_params`), and
``tests/policies/test_aef_compiled.py`` checks the two give the same actions bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from neurocog_gym.locomotion import _fit_kernel as _k
from neurocog_gym.locomotion.avoidance import FOOT_RADIUS, AvoidanceParams, SuddenAvoidance
from neurocog_gym.robot.names import FRONT_LEGS

MODE_NONE, MODE_INTERRUPT, MODE_PROVISION = _k.MODE_NONE, _k.MODE_INTERRUPT, _k.MODE_PROVISION
MODE_NAMES = ("none", "interrupt", "provision")


@dataclass(frozen=True)
class FitParams:
    """The fit's walk-round rule and its stop / side-step / pass teacher (m)."""

    lookahead: float = 1.2
    """Obstacles ahead closer than this change the walking provision, m."""
    corridor: float = 0.22
    """Half-width of the robot's path corridor (the soles' lanes end 0.14 m out), m."""
    beside: float = 0.1
    """Boxes this far beside the corridor still count (a box alongside is kept clear), m."""
    cor_min: float = 0.4
    """s_COR of the walk-round at the smallest shift left."""
    cor_gain: float = 2.5
    """s_COR of the walk-round per metre of shift left, 1/m (saturates at 1)."""
    avoidance: AvoidanceParams = field(default_factory=AvoidanceParams)
    """The stop / side-step / pass teacher for blocks that appear within reach
    (``avoidance.py``); ``AvoidanceParams(enabled=False)`` leaves the two rules above alone."""


def kernel_params(params: FitParams | None = None) -> np.ndarray:
    """``params`` (None: the defaults) as ``_fit_kernel.decide_kernel`` reads them: (N_PARAMS,)."""
    p = params or FitParams()
    a = p.avoidance
    out = np.empty(_k.N_PARAMS)
    for index, value in (
        (_k.P_LOOKAHEAD, p.lookahead),
        (_k.P_BESIDE, p.beside),
        (_k.P_CORRIDOR, p.corridor),
        (_k.P_ENABLED, 1.0 if a.enabled else 0.0),
        (_k.P_TRIGGER, a.trigger),
        (_k.P_LANE_R, FOOT_RADIUS + a.margin),  # as SuddenAvoidance.update sums it
        (_k.P_LANE_HYSTERESIS, a.lane_hysteresis),
        (_k.P_SUDDEN_RANGE, a.sudden_range),
        (_k.P_MIN_HEIGHT, a.min_height),
        (_k.P_STEP_OVER_HEIGHT, a.step_over_height),
        (_k.P_SAME_BOX, a.same_box),
        (_k.P_T_REV, a.t_rev),
        (_k.P_BACKOFF, a.backoff),
        (_k.P_K_SIDE, a.k_side),
        (_k.P_KX, a.kx),
        (_k.P_SIDE_BACKOFF, a.side_backoff),
        (_k.P_K_MIN, a.k_min),
        (_k.P_K_MAX, a.k_max),
        (_k.P_SIDE_COR, a.side_cor),
        (_k.P_SIDE_DIR, a.side_dir),
        (_k.P_COR_GAIN, a.cor_gain),
        (_k.P_DIR_GAIN, a.dir_gain),
        (_k.P_SAG_GAIN, a.sag_gain),
        (_k.P_BRAKE_FROM, a.brake_from),
        (_k.P_SIDE_DIR_FF, a.side_dir_ff),
        (_k.P_WR_COR_MIN, p.cor_min),
        (_k.P_WR_COR_GAIN, p.cor_gain),
    ):
        out[index] = value
    return out


@dataclass
class FitDecision:
    """One cycle's decision."""

    mode: int
    """MODE_NONE, MODE_INTERRUPT or MODE_PROVISION."""
    provision: np.ndarray
    """(3,) the teachers' walking provision (s_SAG, s_COR, s_DIR); zeros unless provision."""
    slots: np.ndarray
    """(4, 3) the AEF network's direction inputs: v^l (interrupt), the provision in every leg's
    slot (provision), zeros (none)."""
    target: int
    """Index of the box the decision is about (interrupt: the box met; provision by the
    walk-round rule: the nearest box that counts), -1 none or the teacher's."""


class Fit:
    """The per-cycle decision (module docstring); one instance per episode stream."""

    def __init__(self, params: FitParams | None = None):
        self.p = params or FitParams()
        self.avoidance = SuddenAvoidance(self.p.avoidance)
        self._front = np.array(FRONT_LEGS, dtype=np.int64)

    def reset(self) -> None:
        """Forget the teacher's state and the boxes seen (a new episode)."""
        self.avoidance.reset()

    def decide(
        self,
        t: float,
        yaw: float,
        direction: np.ndarray,
        hit: np.ndarray,
        feet: np.ndarray,
        hips: np.ndarray,
        thighs: np.ndarray,
        knees: np.ndarray,
        boxes: np.ndarray,
    ) -> FitDecision:
        """One control cycle's decision.

        Positions are in one horizontal frame that stays put over the episode (the world, or
        the policy's odometry frame), z above the floor.

        Args:
            t: time since the episode start, s.
            yaw: torso heading in that frame, rad.
            direction: (4, 3) the effectivity's interrupt directions v^l (torso yaw frame).
            hit: (4,) int, the box of ``boxes`` each leg's foothold or swing path meets, -1.
            feet: (4, 3) sole centres, m.
            hips: (4, 3) hip (abduction joint) positions, m.
            thighs: (4, 3) hip flexion joints (thigh origins), m.
            knees: (4, 3) knees (shank origins), m.
            boxes: (K, 2, 3) the remembered obstacle boxes (min/max corners), m.
        """
        direction = np.asarray(direction, dtype=np.float64).reshape(4, 3)
        boxes = np.ascontiguousarray(np.asarray(boxes, dtype=np.float64).reshape(-1, 2, 3))
        feet = np.ascontiguousarray(feet, dtype=np.float64)
        hips = np.ascontiguousarray(hips, dtype=np.float64)
        thighs = np.ascontiguousarray(thighs, dtype=np.float64)
        knees = np.ascontiguousarray(knees, dtype=np.float64)
        p = self.p
        provision = np.zeros(3)
        slots = np.zeros((4, 3))
        self.avoidance.set_heading(yaw)
        target = int(_k.interrupt_target(direction, np.asarray(hit, dtype=np.int64), feet, boxes))
        mode = MODE_NONE
        if direction.any():
            mode = MODE_INTERRUPT
            slots[:] = direction
        elif len(boxes):
            c, s = self.avoidance.heading
            k = _k.walk_around_kernel(
                hips, feet, self._front, c, s, boxes, p.lookahead, p.corridor, p.beside,
                p.cor_min, p.cor_gain, provision,
            )  # fmt: skip
            target = int(k)
            if target >= 0:
                mode = MODE_PROVISION
                slots[:, 0] = provision[0]
                slots[:, 1] = provision[1]
        if mode == MODE_INTERRUPT and target >= 0:
            # The fit: a box taller than a swing clears is stopped for, not stepped over.
            self.avoidance.adopt(boxes[target], feet)
        avoid = self.avoidance.update(t, yaw, feet, thighs, knees, boxes)
        if avoid is not None:
            mode = MODE_PROVISION
            provision[:] = avoid
            slots[:] = avoid  # every leg's slot carries the body motion, as the rules do
            target = -1
        return FitDecision(mode=mode, provision=provision, slots=slots, target=target)
