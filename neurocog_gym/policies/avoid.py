"""AvoidPolicy: back off, side-step out of a sudden block's path, walk past it; never step over.

Why not step over: the motor-neuron pools (Eq. 8 with the restoring term) hold a joint at most
about 0.9-0.96 rad from the standing posture, so a foot stays below ~8-10 cm and only close
under its hip, while the paper's blocks are 6-8 cm high and appear 4-13 cm ahead of the hip of
a leg that is already swinging at 0.5 m/s. Every step-over pattern tried (inverse kinematics,
timed high arcs, hovering on three legs, slowing the trot) did worse than the blind CPG
(``52b50df:docs/bench_notes.md``). The paper's own answer to an obstacle that is not in the current
swing is the walking provision's walk-around (Fig. 20b); this reflex extends it to a block that
appears in front of the robot: stop and back off first, then side-step with the walking
provision, then walk past with the heading held.

States, for the blocks in the effectivity's obstacle memory that first appeared within
``sudden_range`` of the leading foot (blocks seen from afar are left to the AEF's provision
head, which walks round them):

* ``walk``: the AEF with its interrupt group off (``aef-provision``) acts.
* ``reverse``: a block overlaps a leg's lane (the lateral band between its hip and foot, grown by
  the foot radius and ``margin``) and its near face is within ``trigger`` of the leading foot:
  every hip's CPG drive is reversed through the interrupt group (Θ_hip = -``k_rev``
  clip(drive)/3, so the activation of Eq. 8 is minus the CPG's: the trot walks backwards and
  the body stops within ~5 cm); stance knees straighten (Θ_knee = ``ext_knee``) so the shanks
  swing back from the near face. Until every in-lane leg is ``backoff`` behind the near face,
  and at least ``t_rev``.
* ``side``: the hips march in place, more strongly the closer a leg is to the block
  (k = clip(``k_side`` + ``kx`` (``side_backoff`` - gap), ``k_min``, ``k_max``)), with a
  left/right asymmetry that holds the heading (``kyaw_side`` × yaw error), and s_COR = ±1 moves
  the body towards the side that needs the smaller shift, until no lane overlaps the block.
* ``pass``: the CPG trots on, s_COR keeps the lanes clear of the block and s_DIR holds the
  heading; back to ``side`` if a lane overlaps again near the block; back to ``walk`` once every
  foot is past it.

A leg's gap to a block (``leg_gap``) is measured from its most forward point below the block's
top — thigh, shank or sole capsule, from the hip, knee and foot positions — not from the sole:
the shank leans forward from the sole, and with sole gaps the marching legs' shanks brushed the
near face in most side-step contacts (measured: ``52b50df:docs/avoid_notes.md``, 2026-11-27).

The reflex reads the robot's own state inside the env (``env.unwrapped``): the effectivity's
obstacle memory (perceived boxes only, never the simulator's), feet, knees and hips in the
world, the torso's yaw and the CPG's joint drives — as the effectivity does. It is therefore
bound to an env with :meth:`AvoidPolicy.reset` after every ``env.reset``; the benchmark runner and
``record-video`` do that. It assumes the walking direction of the obstacle tasks, world +x.

First tuned on the sudden benchmark's trials 0-99 (``52b50df:scripts/explore_sudden.py``, its
``BackAround`` with ``BEST``); the leg gap and its distances were then chosen on dev trials of
run seeds 2 and 3 only, disjoint from the benchmark's seeds 0 and 1
(``explore_sudden.py --policy avoid --seed 2``, in git history). The published benchmark runs are in
``docs/benchmark.md`` (v0 results).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from neurocog_gym.policies.aef import AEFPolicy

FOOT_RADIUS = 0.018
"""Sole sphere radius, m (assets/quadruped.xml)."""
_THIGH_Y = np.array([0.045, -0.045, 0.045, -0.045])
"""Lateral offset of each thigh from its hip body, m (+y is left): FL, FR, HL, HR."""
_LEFT = np.array([1.0, -1.0, 1.0, -1.0])
_HIPS = np.array([1, 4, 7, 10])
_KNEES = np.array([2, 5, 8, 11])
_S = np.linspace(0.0, 1.0, 6)


@dataclass(frozen=True)
class AvoidParams:
    """Gains and distances of the avoid reflex (lengths in m, times in s)."""

    trigger: float = 0.35
    """A block whose near face is closer than this to the leading foot starts the reflex."""
    margin: float = 0.03
    """Clearance added to the foot radius round each leg's lane."""
    lane_hysteresis: float = 0.01
    """Extra lane width while side-stepping and passing (no chatter at the lane's edge)."""
    sudden_range: float = 0.5
    """Only blocks first remembered within this of the leading foot are avoided this way."""
    min_height: float = 0.02
    """Remembered boxes lower than this are ignored."""
    k_rev: float = 2.0
    """Hip drive reversal while backing off (2: the hip activation is minus the CPG's)."""
    ext_knee: float = -1.0
    """Knee interrupt of stance legs while backing off (straighten: shanks swing back)."""
    ext_time: float = 0.35
    """Longest the knees are straightened (longer, the tall stance tips over in the back-off
    when a block appears in a real swing: 12 falls in 200 dev trials at 1 s, none at 0.3-0.35;
    shorter, the shanks do not swing clear: 0.2 s touched in half the trials)."""
    t_rev: float = 0.25
    """Shortest back-off."""
    backoff: float = 0.07
    """Back off until every in-lane leg is this far behind the near face."""
    k_side: float = 1.0
    """Hip drive cancellation while side-stepping (1: the hips march in place)."""
    kx: float = 10.0
    """Extra cancellation per metre a leg is closer than ``side_backoff`` to the block."""
    side_backoff: float = 0.07
    """Leg-to-near-face distance kept while side-stepping."""
    k_min: float = 1.0
    """Least hip drive cancellation while side-stepping."""
    k_max: float = 2.0
    """Most hip drive cancellation while side-stepping."""
    kyaw_side: float = -2.0
    """Left/right hip asymmetry per radian of yaw error while side-stepping."""
    side_cor: float = 1.0
    """s_COR while side-stepping."""
    cor_gain: float = 10.0
    """s_COR per metre of lane overlap while passing."""
    dir_gain: float = 2.0
    """s_DIR per radian of yaw error while passing."""
    leg_gap: bool = True
    """Measure a leg's gap to a block from its most forward point at the block's height
    (thigh, shank or sole, whichever reaches furthest below the block's top) instead of from
    the sole alone (the old reflex: the shank leans 3-5 cm ahead of the sole at block height and
    brushed the near face while side-stepping)."""


def _yaw(quat: np.ndarray) -> float:
    w, x, y, z = quat
    return float(np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)))


class AvoidPolicy:
    """The avoid reflex on top of the AEF's walking provision (see the module docstring).

    Args:
        params: gains and distances; None for the defaults.
        weights: AEF weights for the provision group (None: the shipped ones).

    Call :meth:`reset` with the env after every ``env.reset``; then ``policy(obs) -> action``.
    """

    name = "avoid"

    def __init__(self, params: AvoidParams | None = None, weights=None):
        self.p = params or AvoidParams()
        self.fallback = AEFPolicy(weights=weights, interrupt_gain=0.0)
        self._u = None

    def reset(self, env) -> None:
        """Bind to ``env`` (an obstacle env, possibly wrapped) at the start of an episode."""
        u = env.unwrapped
        if not hasattr(u, "effectivity"):
            raise ValueError(
                f"AvoidPolicy needs an obstacle env (it reads the effectivity's obstacle "
                f"memory); {type(u).__name__} has none"
            )
        self._u = u
        self.state = "walk"
        self.t_state = 0.0
        self.direction = 0.0
        self.yaw0 = None
        self.engaged_far = 0.0
        self.known: list[tuple[np.ndarray, bool]] = []

    # -- what the robot knows ----------------------------------------------------------------

    def _boxes(self, feet: np.ndarray) -> list[np.ndarray]:
        """Remembered boxes that appeared near the leading foot (the sudden ones)."""
        memory = np.asarray(self._u.effectivity.memory)
        lead = float(feet[:, 0].max())
        keep = []
        for box in memory:
            if not box[1, 2] > self.p.min_height:
                continue
            c = box[:, :2].mean(axis=0)
            match = None
            for k, (ck, _) in enumerate(self.known):
                if np.hypot(*(c - ck)) < 0.15:
                    match = k
                    break
            if match is None:
                self.known.append((c, bool(box[0, 0] - lead < self.p.sudden_range)))
                match = len(self.known) - 1
            else:
                self.known[match] = (c, self.known[match][1])
            if self.known[match][1]:
                keep.append(box)
        return keep

    def _lanes(self, feet: np.ndarray) -> np.ndarray:
        """(4, 2) lateral band of each leg (y min, max) between its thigh and its foot."""
        u = self._u
        hips = u.data.xpos[u.robot.hip_body][:, 1] + _THIGH_Y
        return np.stack([np.minimum(hips, feet[:, 1]), np.maximum(hips, feet[:, 1])], 1)

    def _reach(self, feet: np.ndarray, top: float) -> np.ndarray:
        """(4,) most forward x of each leg (thigh, shank and sole) below ``top``."""
        u = self._u
        hips = u.data.xpos[u.robot.hip_body + 1]
        knees = u.data.xpos[u.robot.hip_body + 2]
        out = feet[:, 0] + FOOT_RADIUS
        for a, b, rad in ((hips, knees, 0.017), (knees, feet, 0.012)):
            for s in _S:
                pt = a + s * (b - a)
                low = pt[:, 2] - rad <= top
                out = np.where(low, np.maximum(out, pt[:, 0] + rad), out)
        return out

    def _reverse(self, act, drive, inlane, gap, t, obs) -> None:
        """Back-off interrupts into ``act``: the hips' CPG drive reversed, knees straightened.

        ``inlane`` and ``gap`` (per leg) were for variants in ``52b50df:scripts/explore_sudden.py``.
        """
        p = self.p
        act[_HIPS] = -p.k_rev * drive / 3.0
        if p.ext_knee and t - self.t_state < p.ext_time:
            stance = ~(self._u.generator.hip_drive > 0)
            act[_KNEES[stance]] = p.ext_knee

    def _set(self, state: str, t: float) -> None:
        if state != self.state:
            self.state = state
            self.t_state = t

    # -- the reflex ----------------------------------------------------------------------------

    def __call__(self, obs) -> np.ndarray:
        """The 15-value action for this control cycle."""
        if self._u is None:
            raise RuntimeError(
                "AvoidPolicy reads the env's effectivity: call policy.reset(env) after each "
                "env.reset(...)"
            )
        p, u = self.p, self._u
        t = float(u.data.time)
        feet = u._feet()
        yaw = _yaw(u.data.qpos[3:7])
        if self.yaw0 is None:
            self.yaw0 = yaw
        ey = yaw - self.yaw0
        lanes = self._lanes(feet)
        r = FOOT_RADIUS + p.margin
        rel = [b for b in self._boxes(feet) if feet[:, 0].min() < b[1, 0] + 0.03]
        inlane = np.zeros(4, dtype=bool)
        gap = np.full(4, np.inf)  # per leg, to the nearest near face
        close = False
        need_left = need_right = deficit = 0.0
        hyst = p.lane_hysteresis if self.state in ("side", "pass") else 0.0
        for b in rel:
            lo, hi = b[0, 1], b[1, 1]
            ahead = b[0, 0] - feet[:, 0].max() < p.trigger
            front = self._reach(feet, float(b[1, 2])) if p.leg_gap else feet[:, 0]
            for leg in range(4):
                if feet[leg, 0] > b[1, 0] + 0.03:
                    continue  # this foot is past the block
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
        # Transitions.
        if self.state == "walk" and close:
            self.engaged_far = max(float(b[1, 0]) for b in rel)
            self.direction = 1.0 if need_left < need_right else -1.0
            self._set("reverse", t)
        elif self.state == "reverse":
            backed = bool(np.all(gap[inlane] >= p.backoff))
            if backed and t - self.t_state >= p.t_rev:
                self._set("side", t)
        elif self.state == "side":
            if not inlane.any():
                self._set("pass", t)
        elif self.state == "pass":
            if inlane.any() and close:
                self._set("side", t)
            elif feet[:, 0].min() > self.engaged_far + 0.03:
                self._set("walk", t)
        # Actions.
        if self.state == "walk":
            return np.asarray(self.fallback(obs), dtype=np.float32)
        act = np.zeros(15)
        drive = np.clip(u.generator.drive[_HIPS], -1.0, 1.0)
        if self.state == "reverse":
            self._reverse(act, drive, inlane, gap, t, obs)
        elif self.state == "side":
            k = p.k_side
            if p.kx and inlane.any():
                k += p.kx * (p.side_backoff - gap[inlane].min())
                k = float(np.clip(k, p.k_min, p.k_max))
            act[_HIPS] = -(k + p.kyaw_side * ey * _LEFT) * drive / 3.0
            act[13] = self.direction * p.side_cor
        else:  # pass
            act[13] = self.direction * p.cor_gain * max(deficit + 0.01, 0.0)
            act[14] = -p.dir_gain * ey
        return np.clip(act, -1.0, 1.0).astype(np.float32)
