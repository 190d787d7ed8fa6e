"""The effectivity's answer to a block that appears within reach: stop, side-step, walk past.

Why the AEF does not step over such a block here: the motor-neuron pools (Eq. 8 with the
restoring term) hold a joint at most about 0.9 rad from the standing posture, so a foot rises
~8-10 cm and only close under its hip, while the blocks are 6-8 cm high and appear 4-13 cm
ahead of the hip of a leg that is already swinging (measured: ``docs/avoid_notes.md``). The
affordance (the block's height, its distance) does not fit that effectivity, so the fit chooses
the other action the paper gives the AEF, a change of the walking provision (§5.2, Fig. 20b) —
here a fast one: the provision's brake (``generator.py``: s_SAG below ``brake_from`` scales the
stride down to the reversed trot at s_SAG = -1) stops the body, then the side step (s_COR) moves
every leg's lane off the block, then the trot walks past with the heading held (s_DIR).

This is the avoid reflex (``neurocog_gym/avoid.py``, which drives the hips through the interrupt
group and reads the env from outside) recast as a geometric teacher inside the effectivity: its
states and distances are the reflex's, its outputs are the three walking-provision values, and
the AEF network's provision head turns them into the action (``policies.AEFPolicy``). Measured
on dev trials (run seed 2, sudden 0..99): reflex 94 / 4 / 2, this provision form 83 / 15 / 2
(success / touch / fail; ``docs/avoid_notes.md``, 2026-12-01).

States, for the remembered boxes that were first seen within ``sudden_range`` of the leading
foot (boxes seen from afar stay with the effectivity's walk-around provision):

* ``walk``: not engaged; the effectivity's own rules act.
* ``reverse``: a box overlaps a leg's lane (the band between its thigh and its foot, grown by
  the foot radius and ``margin``) and its near face is within ``trigger`` of the leading foot:
  s_SAG = -1 (the trot reversed) until every in-lane leg is ``backoff`` behind the near face,
  and at least ``t_rev``.
* ``side``: the hips march in place, back more the closer a leg is to the box (stride
  1 - k with k = clip(``k_side`` + ``kx`` (``side_backoff`` - gap), ``k_min``, ``k_max``)),
  s_COR = ±``side_cor`` towards the side that needs the smaller shift, s_DIR holds the heading,
  until no lane overlaps the box.
* ``pass``: the trot walks on, s_COR keeps the lanes clear, s_DIR holds the heading; back to
  ``side`` if a lane overlaps again near the box, back to ``walk`` once every foot is past it.

A leg's gap to a box is measured from its most forward point below the box's top (thigh, shank
or sole capsule), not from the sole: the shank leans ahead of the sole at block height.

Geometry is in the frame of the heading the robot had at its first cycle (``yaw0``; the obstacle
tasks walk along it): x ahead, y left. Boxes are the effectivity's remembered world boxes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

FOOT_RADIUS = 0.018
"""Sole sphere radius, m (assets/quadruped.xml)."""
THIGH_RADIUS = 0.017
"""Thigh capsule radius, m (assets/quadruped.xml)."""
SHANK_RADIUS = 0.012
"""Shank capsule radius, m (assets/quadruped.xml)."""

WALK, REVERSE, SIDE, PASS = 0, 1, 2, 3
STATE_NAMES = ("walk", "reverse", "side", "pass")
_S = np.linspace(0.0, 1.0, 6)


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
    same_box: float = 0.15
    """Box centres closer than this are the same box across memory updates, m."""
    t_rev: float = 0.25
    """Shortest back-off, s."""
    backoff: float = 0.07
    """Back off until every in-lane leg is this far behind the near face, m."""
    k_side: float = 1.0
    """Stride cancellation while side-stepping (1: the hips march in place)."""
    kx: float = 10.0
    """Extra cancellation per metre a leg is closer than ``side_backoff`` to the box."""
    side_backoff: float = 0.07
    """Leg-to-near-face distance kept while side-stepping, m."""
    k_min: float = 1.0
    """Least stride cancellation while side-stepping."""
    k_max: float = 2.0
    """Most stride cancellation while side-stepping (2: the trot reversed)."""
    side_cor: float = 1.0
    """s_COR while side-stepping."""
    side_dir: float = 2.0
    """s_DIR per radian of heading error while side-stepping."""
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
    top = 1.0 + sag_gain * brake_from
    if scale >= top:
        s = (scale - 1.0) / sag_gain
    else:
        s = -1.0 + (scale + 1.0) * (brake_from + 1.0) / (top + 1.0)
    return float(min(max(s, -1.0), 1.0))


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
        self.engaged_far = 0.0
        self._known: list[list] = []  # [centre (2,), sudden?]

    @property
    def state_name(self) -> str:
        """The current state: "walk", "reverse", "side" or "pass"."""
        return STATE_NAMES[self.state]

    def _sudden(self, boxes: np.ndarray, lead: float) -> list[np.ndarray]:
        """Boxes (task frame) high enough that were first seen near the leading foot."""
        keep = []
        for box in boxes:
            if not box[1, 2] > self.p.min_height:
                continue
            c = box[:, :2].mean(axis=0)
            match = None
            for entry in self._known:
                if np.hypot(*(c - entry[0])) < self.p.same_box:
                    entry[0] = c
                    match = entry
                    break
            if match is None:
                match = [c, bool(box[0, 0] - lead < self.p.sudden_range)]
                self._known.append(match)
            if match[1]:
                keep.append(box)
        return keep

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
        if self.yaw0 is None:
            self.yaw0 = float(yaw)
        if not p.enabled or (self.state == WALK and len(boxes) == 0):
            return None
        c, s = np.cos(self.yaw0), np.sin(self.yaw0)
        rot = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
        feet = feet @ rot.T
        thighs = thighs @ rot.T
        knees = knees @ rot.T
        boxes = _boxes_in_frame(np.asarray(boxes, dtype=np.float64), rot)
        ey = float(np.angle(np.exp(1j * (yaw - self.yaw0))))
        lead = float(feet[:, 0].max())
        lanes = np.stack(
            [np.minimum(thighs[:, 1], feet[:, 1]), np.maximum(thighs[:, 1], feet[:, 1])], 1
        )
        r = FOOT_RADIUS + p.margin
        hyst = p.lane_hysteresis if self.state in (SIDE, PASS) else 0.0
        rel = [b for b in self._sudden(boxes, lead) if feet[:, 0].min() < b[1, 0] + 0.03]
        inlane = np.zeros(4, dtype=bool)
        gap = np.full(4, np.inf)
        close = False
        need_left = need_right = deficit = 0.0
        for b in rel:
            lo, hi = b[0, 1], b[1, 1]
            ahead = b[0, 0] - lead < p.trigger
            front = _reach(feet, thighs, knees, float(b[1, 2]))
            for leg in range(4):
                if feet[leg, 0] > b[1, 0] + 0.03:
                    continue  # this foot is past the box
                if lanes[leg, 1] + r + hyst > lo and lanes[leg, 0] - r - hyst < hi:
                    inlane[leg] = True
                    close = close or ahead
            gap = np.minimum(gap, b[0, 0] - front)
            need_right = max(need_right, lanes[:, 1].max() + r - lo)
            need_left = max(need_left, hi + r - lanes[:, 0].min())
            if self.direction > 0:
                deficit = max(deficit, hi + r - lanes[:, 0].min())
            elif self.direction < 0:
                deficit = max(deficit, lanes[:, 1].max() + r - lo)
        if self.state == WALK and close:
            self.engaged_far = max(float(b[1, 0]) for b in rel)
            self.direction = 1.0 if need_left < need_right else -1.0
            self._set(REVERSE, t)
        elif self.state == REVERSE:
            if bool(np.all(gap[inlane] >= p.backoff)) and t - self.t_state >= p.t_rev:
                self._set(SIDE, t)
        elif self.state == SIDE:
            if not inlane.any():
                self._set(PASS, t)
        elif self.state == PASS:
            if inlane.any() and close:
                self._set(SIDE, t)
            elif feet[:, 0].min() > self.engaged_far + 0.03:
                self._set(WALK, t)
        if self.state == WALK:
            return None
        out = np.zeros(3)
        if self.state == REVERSE:
            out[0] = -1.0
        elif self.state == SIDE:
            k = p.k_side
            if inlane.any():
                k += p.kx * (p.side_backoff - gap[inlane].min())
                k = float(np.clip(k, p.k_min, p.k_max))
            out[0] = sag_for_stride(1.0 - k, p.sag_gain, p.brake_from)
            out[1] = self.direction * p.side_cor
            out[2] = -p.side_dir * ey
        else:
            out[1] = self.direction * p.cor_gain * max(deficit + 0.01, 0.0)
            out[2] = -p.dir_gain * ey
        return np.clip(out, -1.0, 1.0)

    def _set(self, state: int, t: float) -> None:
        if state != self.state:
            self.state = state
            self.t_state = t


def _boxes_in_frame(boxes: np.ndarray, rot: np.ndarray) -> np.ndarray:
    """(K, 2, 3) world boxes -> the bounding boxes of their corners in the frame of ``rot``."""
    if boxes.size == 0:
        return boxes.reshape(0, 2, 3)
    lo, hi = boxes[:, 0], boxes[:, 1]
    corners = np.stack(
        [np.stack([xs[:, 0], ys[:, 1], lo[:, 2]], 1) for xs in (lo, hi) for ys in (lo, hi)],
        1,
    )  # (K, 4, 3): the four ground-plane corners
    rc = corners @ rot.T
    out = np.empty_like(boxes)
    out[:, 0, :2] = rc[:, :, :2].min(axis=1)
    out[:, 1, :2] = rc[:, :, :2].max(axis=1)
    out[:, 0, 2] = lo[:, 2]
    out[:, 1, 2] = hi[:, 2]
    return out


def _reach(feet: np.ndarray, thighs: np.ndarray, knees: np.ndarray, top: float) -> np.ndarray:
    """(4,) most forward x of each leg (thigh, shank and sole capsules) below ``top``."""
    out = feet[:, 0] + FOOT_RADIUS
    for a, b, rad in ((thighs, knees, THIGH_RADIUS), (knees, feet, SHANK_RADIUS)):
        for s in _S:
            pt = a + s * (b - a)
            low = pt[:, 2] - rad <= top
            out = np.where(low, np.maximum(out, pt[:, 0] + rad), out)
    return out
