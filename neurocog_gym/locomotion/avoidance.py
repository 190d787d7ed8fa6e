"""The fit's answer to a block the legs cannot step over: stop, side-step, walk past.

Why the AEF does not step over such a block here: the motor-neuron pools (Eq. 8 with the
restoring term) hold a joint at most about 0.9 rad from the standing posture, so a foot rises
~8-10 cm and only close under its hip, while the blocks are 6-8 cm high and appear 4-13 cm
ahead of the hip of a leg that is already swinging (measured: ``52b50df:docs/avoid_notes.md``). The
affordance (the block's height, its distance) does not fit that effectivity, so the fit chooses
the other action the paper gives the AEF, a change of the walking provision (§5.2, Fig. 20b) —
here a fast one: the provision's brake (``generator.py``: s_SAG below ``brake_from`` scales the
stride down to the reversed trot at s_SAG = -1) stops the body, then the side step (s_COR) moves
every leg's lane off the block, then the trot walks past with the heading held (s_DIR).

This is the avoid reflex (the v0 ``AvoidPolicy``, which drove the hips through the interrupt
group and read the env from outside; removed with issue 22) recast as a geometric teacher of the
fit (``fit.py``): its states and distances are the reflex's, its outputs are the three
walking-provision values, and the AEF network's provision head turns them into the action
(``policies.AEFPolicy``, which runs the fit on the observation). Dev
trials (run seed 2, sudden 0..99, success / touch / fail): the reflex 94 / 4 / 2, this teacher
through the AEF network 81 / 14 / 5; the benchmark (seed 0, 200 sudden trials): 158 / 34 / 8,
was 0 / 17 / 33 of 50 with the up-and-over interrupt (``52b50df:docs/avoid_notes.md``, 2026-12-01).

States, for the remembered boxes that were first seen within ``sudden_range`` of the leading
foot, and for any box taller than ``step_over_height`` that a swing meets (``adopt``: the legs
cannot carry out the interrupt; boxes seen from afar otherwise stay with the fit's
walk-round rule):

* ``walk``: not engaged; the fit's other rules act.
* ``reverse``: a box overlaps a leg's lane (the band between its thigh and its foot, grown by
  the foot radius and ``margin``) and its near face is within ``trigger`` of the leading foot:
  s_SAG = -1 (the trot reversed) until every in-lane leg is ``backoff`` behind the near face,
  and at least ``t_rev``.
* ``side``: the hips creep forward at a quarter stride, less and then back the closer a leg
  is to the box (stride 1 - k with k = clip(``k_side`` + ``kx`` (``side_backoff`` - gap),
  ``k_min``, ``k_max``)), s_COR = ±``side_cor`` towards the side that needs the smaller shift,
  s_DIR holds the heading and leans against the side step's own turn (``side_dir_ff``), until
  no lane overlaps the box.

  Until issue 22's walk-round work (2026-12-05) the side step marched in place (``k_side`` 1,
  ``k_min`` 1) without the lean. Marching in place, a side step walks the body back at
  0.15 m/s and turns it towards the step at 20 deg/s (Walk-v2, s_COR 1), more than the heading
  feedback held (s_DIR 1 turns 24 deg/s): the yaw ran to 20-70 deg, the tilted body's lanes
  kept overlapping the box, and three sudden trials in four ran out of time. At a quarter
  stride with the lean the same side step goes 0.19 m/s sideways, 0.02-0.06 m/s ahead, and
  turns 3-8 deg/s. Training trials (run seed 5, 60 sudden trials, the fit's provision in place
  of the network's): passed 6 -> 36, time-outs 36 -> 4.
* ``pass``: the trot walks on, s_COR keeps the lanes clear, s_DIR holds the heading; back to
  ``side`` if a lane overlaps again near the box, back to ``walk`` once every foot is past it.

A leg's gap to a box is measured from its most forward point below the box's top (thigh, shank
or sole capsule), not from the sole: the shank leans ahead of the sole at block height.

Geometry is in the frame of the heading the robot had at its first cycle (``yaw0``; the obstacle
tasks walk along it): x ahead, y left. Boxes are the effectivity's remembered boxes; positions
come in any horizontal frame that stays put over the episode (the world, or the odometry frame
of ``policies.AEFPolicy``). Times count in whole control cycles: a duration is reached once it
is within a microsecond (a sum of 0.01 s steps is not exactly a multiple of 0.01).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from neurocog_gym.locomotion import _avoidance_kernel as _k

FOOT_RADIUS = _k.FOOT_RADIUS
"""Sole sphere radius, m (assets/quadruped.xml; the thigh and shank capsules: 0.017, 0.012)."""

WALK, REVERSE, SIDE, PASS = _k.WALK, _k.REVERSE, _k.SIDE, _k.PASS
_T_EPS = _k.T_EPS
"""s, how far short of a duration a sum of control-cycle steps may fall and still reach it."""
STATE_NAMES = ("walk", "reverse", "side", "pass")


@dataclass(frozen=True)
class AvoidanceParams:
    """Distances and gains of the stop / side-step / pass teacher (m, s; the reflex's values)."""

    enabled: bool = True
    """False: never engages (the effectivity's rules alone, as before 2026-12-01)."""
    trigger: float = 0.35
    """A box whose near face is closer than this to the leading foot engages, m."""
    margin: float = 0.03
    """Clearance added to the foot radius round each leg's lane, m."""
    lane_hysteresis: float = 0.01
    """Extra lane width while side-stepping and passing, m."""
    sudden_range: float = 0.5
    """Only boxes first remembered within this of the leading foot engage, m."""
    min_height: float = 0.02
    """Remembered boxes lower than this are ignored, m."""
    step_over_height: float = 0.04
    """Tallest box a swing can carry a foot over, m (the gait's swing clearance: 4.0 cm front on
    body v0). A taller box that a swing meets, lying ahead of the feet, is
    handed to this teacher however far away it was first seen (``adopt``)."""
    same_box: float = 0.15
    """Box centres closer than this are the same box across memory updates, m."""
    t_rev: float = 0.25
    """Shortest back-off, s."""
    backoff: float = 0.07
    """Back off until every in-lane leg is this far behind the near face, m."""
    k_side: float = 0.75
    """Stride cancellation while side-stepping (1: the hips march in place; 0.75: a quarter
    stride ahead, which cancels the side step's drift back)."""
    kx: float = 10.0
    """Extra cancellation per metre a leg is closer than ``side_backoff`` to the box."""
    side_backoff: float = 0.07
    """Leg-to-near-face distance kept while side-stepping, m."""
    k_min: float = 0.7
    """Least stride cancellation while side-stepping."""
    k_max: float = 2.0
    """Most stride cancellation while side-stepping (2: the trot reversed)."""
    side_cor: float = 1.0
    """s_COR while side-stepping."""
    side_dir: float = 2.0
    """s_DIR per radian of heading error while side-stepping."""
    side_dir_ff: float = 0.5
    """s_DIR against the side step's own turn while side-stepping (sign opposite the step)."""
    cor_gain: float = 10.0
    """s_COR per metre of lane overlap while passing."""
    dir_gain: float = 2.0
    """s_DIR per radian of heading error while passing."""
    sag_gain: float = 0.6
    """The generator's ``ProvisionParams.sag_gain`` (to invert the stride scale)."""
    brake_from: float = -0.5
    """The generator's ``ProvisionParams.brake_from`` (to invert the stride scale)."""


def sag_for_stride(scale: float, sag_gain: float = 0.6, brake_from: float = -0.5) -> float:
    """The s_SAG whose stride scale is ``scale`` (the generator's map, inverted), in [-1, 1]."""
    return float(_k.sag_for_stride(float(scale), float(sag_gain), float(brake_from)))


class SuddenAvoidance:
    """The stop / side-step / pass teacher (module docstring); one instance per env."""

    def __init__(self, params: AvoidanceParams | None = None):
        self.p = params or AvoidanceParams()
        self.reset()

    def reset(self) -> None:
        """Forget the state, the heading and the boxes seen."""
        self.state = WALK
        self.t_state = 0.0
        self.direction = 0.0
        self.yaw0: float | None = None
        self._c = 1.0
        self._s = 0.0
        self.engaged_far = 0.0
        self._known = np.zeros((self.known_capacity, 2))
        self._known_sudden = np.zeros(self.known_capacity, dtype=np.bool_)
        self._n_known = 0
        self._inlane = np.zeros(4, dtype=np.bool_)
        self._gap = np.zeros(4)
        self._out = np.zeros(_k.N_OUT)

    known_capacity = _k.KNOWN_CAPACITY
    """Most boxes whose first sighting is remembered (later ones never engage)."""

    def adopt(self, box: np.ndarray, feet: np.ndarray) -> bool:
        """Take ``box`` (world (2, 3)) as one to stop for, if it is taller than a swing clears.

        The effectivity calls this when a swing meets the box (it would fire an interrupt): the
        fit of that affordance with the legs' effectivity. Only a box whose near face is ahead
        of the leading foot is taken (a box under the body is the hind legs' swing business).

        Returns:
            Whether the box is now one to stop for.
        """
        p = self.p
        if not p.enabled or self.state != WALK or not box[1, 2] > p.step_over_height:
            return False
        c, s = self._c, self._s
        xs = [box[a, 0] * c + box[b, 1] * s for a in range(2) for b in range(2)]
        ys = [-box[a, 0] * s + box[b, 1] * c for a in range(2) for b in range(2)]
        lead = max(float(feet[i, 0]) * c + float(feet[i, 1]) * s for i in range(4))
        if min(xs) < lead - 0.02:
            return False
        cx, cy = 0.5 * (min(xs) + max(xs)), 0.5 * (min(ys) + max(ys))
        for j in range(self._n_known):
            if math.hypot(cx - self._known[j, 0], cy - self._known[j, 1]) < p.same_box:
                self._known_sudden[j] = True
                return True
        if self._n_known < self.known_capacity:
            self._known[self._n_known] = (cx, cy)
            self._known_sudden[self._n_known] = True
            self._n_known += 1
            return True
        return False

    def set_heading(self, yaw: float) -> None:
        """Take ``yaw`` (rad) as the path's heading (``yaw0``) unless one is set this episode.

        ``update`` does it too; the fit calls it first, as its walk-round rule works in the
        path's frame (``heading``).
        """
        if self.yaw0 is None:
            self.yaw0 = float(yaw)
            self._c, self._s = math.cos(self.yaw0), math.sin(self.yaw0)

    @property
    def heading(self) -> tuple[float, float]:
        """(cos, sin) of the path's heading: (1, 0) until ``set_heading``."""
        return self._c, self._s

    @property
    def state_name(self) -> str:
        """The current state: "walk", "reverse", "side" or "pass"."""
        return STATE_NAMES[self.state]

    def update(
        self,
        t: float,
        yaw: float,
        feet: np.ndarray,
        thighs: np.ndarray,
        knees: np.ndarray,
        boxes: np.ndarray,
    ) -> np.ndarray | None:
        """One control cycle: the walking provision to use, or None when not engaged.

        Args:
            t: time, s.
            yaw: torso heading, rad.
            feet: (4, 3) sole centres, world, m.
            thighs: (4, 3) hip joints (thigh body origins), world, m.
            knees: (4, 3) knee joints (shank body origins), world, m.
            boxes: (K, 2, 3) remembered obstacle boxes, world min/max corners, m.

        Returns:
            (3,) (s_SAG, s_COR, s_DIR) while engaged, else None.
        """
        p = self.p
        self.set_heading(yaw)
        if not p.enabled or (self.state == WALK and len(boxes) == 0):
            return None
        inlane, gap, out = self._inlane, self._gap, self._out
        self._n_known = _k.avoidance_geometry(
            feet, thighs, knees, boxes, self._c, self._s, self._known, self._known_sudden,
            self._n_known, p.sudden_range, p.min_height, p.same_box, p.trigger,
            FOOT_RADIUS + p.margin, p.lane_hysteresis if self.state in (SIDE, PASS) else 0.0,
            inlane, gap, out,
        )  # fmt: skip
        close = out[_k.O_CLOSE] > 0.0
        any_in = out[_k.O_N_IN] > 0.0
        gap_in = float(out[_k.O_GAP_IN])
        if self.state == WALK:
            if not close:
                return None
            self.engaged_far = float(out[_k.O_FAR])
            self.direction = 1.0 if out[_k.O_NEED_LEFT] < out[_k.O_NEED_RIGHT] else -1.0
            self._set(REVERSE, t)
        elif self.state == REVERSE:
            if gap_in >= p.backoff and t - self.t_state >= p.t_rev - _T_EPS:
                self._set(SIDE, t)
        elif self.state == SIDE:
            if not any_in:
                self._set(PASS, t)
        elif self.state == PASS:
            if any_in and close:
                self._set(SIDE, t)
            elif self._rear(feet) > self.engaged_far + 0.03:
                self._set(WALK, t)
        if self.state == WALK:
            return None
        ey = math.remainder(float(yaw) - self.yaw0, 2.0 * math.pi)
        if self.state == REVERSE:
            sag, cor, turn = -1.0, 0.0, 0.0
        elif self.state == SIDE:
            k = p.k_side
            if any_in:
                k = min(max(k + p.kx * (p.side_backoff - gap_in), p.k_min), p.k_max)
            sag = sag_for_stride(1.0 - k, p.sag_gain, p.brake_from)
            cor = self.direction * p.side_cor
            turn = -p.side_dir * ey - self.direction * p.side_dir_ff
        else:
            need = out[_k.O_NEED_LEFT] if self.direction > 0 else out[_k.O_NEED_RIGHT]
            deficit = float(need) if out[_k.O_N_REL] > 0 else 0.0
            sag = 0.0
            cor = self.direction * p.cor_gain * max(deficit + 0.01, 0.0)
            turn = -p.dir_gain * ey
        return np.array([sag, min(max(cor, -1.0), 1.0), min(max(turn, -1.0), 1.0)])

    def _rear(self, feet: np.ndarray) -> float:
        """The rearmost foot's position along the frame's heading, m."""
        c, s = self._c, self._s
        return min(float(feet[i, 0]) * c + float(feet[i, 1]) * s for i in range(4))

    def _set(self, state: int, t: float) -> None:
        if state != self.state:
            self.state = state
            self.t_state = t


def _reach(feet: np.ndarray, thighs: np.ndarray, knees: np.ndarray, top: float) -> np.ndarray:
    """(4,) most forward x of each leg (thigh, shank and sole capsules) below ``top`` (kernel)."""
    out = np.empty(4)
    _k.leg_reach(
        np.asarray(feet, float),
        np.asarray(thighs, float),
        np.asarray(knees, float),
        float(top),
        out,
    )
    return out
