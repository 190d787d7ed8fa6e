"""Test oracle of the effectivity: the plain NumPy implementation the numba kernel
(``neurocog_gym/locomotion/_effectivity_kernel.py``) replaced, kept operation for operation so
the kernel can be checked against it on random cycles (``test_effectivity_kernel.py``).
See ``neurocog_gym/locomotion/effectivity.py`` for the model."""

from __future__ import annotations

import numpy as np

from neurocog_gym.locomotion.effectivity import EffectivityParams, EffectivityState


def _overlap(a: np.ndarray, b: np.ndarray) -> bool:
    return bool(np.all(a[0] <= b[1]) and np.all(b[0] <= a[1]))


PHASE_NONE = 0
PHASE_UP = 1
PHASE_OVER = 2


class EffectivityOracle:
    """The effectivity in plain NumPy, as ``Effectivity`` computed it before its kernel."""

    def __init__(self, params: EffectivityParams | None = None):
        self.p = params or EffectivityParams()
        self.lift_time = np.zeros(4)
        self.was_down = np.ones(4, dtype=bool)
        self.phase = np.zeros(4, dtype=int)
        self.plan_box = np.zeros((4, 2, 3))
        self.plan_start = np.zeros(4)
        self.memory = np.zeros((0, 2, 3))

    def reset(self) -> None:
        """Forget swing timing, interrupts in progress and remembered obstacles."""
        self.lift_time[:] = 0.0
        self.was_down[:] = True
        self.phase[:] = PHASE_NONE
        self.plan_box[:] = 0.0
        self.plan_start[:] = 0.0
        self.memory = np.zeros((0, 2, 3))

    def remember(
        self, boxes: np.ndarray, foot: np.ndarray, torso: np.ndarray, heading: np.ndarray
    ) -> np.ndarray:
        """As ``Effectivity.remember``."""
        p = self.p
        mem = [m for m in self.memory if not any(_overlap(m, b) for b in boxes)]
        mem += list(np.asarray(boxes, dtype=np.float64).reshape(-1, 2, 3))
        keep = []
        f = foot[:, :2] @ heading[:2]
        for m in mem:
            corners = np.array([[m[i, 0], m[j, 1]] for i in (0, 1) for j in (0, 1)])
            far = (corners @ heading[:2]).max()
            centre = m.mean(axis=0)
            if f.min() > far + p.forget_behind:
                continue
            if np.linalg.norm(centre[:2] - torso[:2]) > p.forget_distance:
                continue
            keep.append(m)
        self.memory = np.array(keep).reshape(-1, 2, 3)
        return self.memory

    def step(self, t, touch, foot, hip, yaw, v_body, boxes) -> EffectivityState:
        """As ``Effectivity.step``."""
        p = self.p
        heading = np.array([np.cos(yaw), np.sin(yaw), 0.0])
        boxes = self.remember(np.asarray(boxes).reshape(-1, 2, 3), foot, hip.mean(axis=0), heading)
        down = touch > p.touch_off
        lifted = self.was_down & ~down
        self.lift_time[lifted] = t
        self.was_down = down.copy()
        swinging = ~down
        left = np.array([-np.sin(yaw), np.cos(yaw), 0.0])
        t_left = np.maximum(p.swing_time - (t - self.lift_time), p.min_time_left)
        v = np.array([v_body[0], v_body[1], 0.0])
        foothold = foot.copy()
        for leg in range(4):
            if swinging[leg]:
                foothold[leg] = hip[leg] + p.reach * heading + v * t_left[leg]
                foothold[leg, 2] = 0.0
        grown = boxes.copy() if len(boxes) else np.zeros((0, 2, 3))
        if len(grown):
            grown[:, 0] -= p.margin
            grown[:, 1] += p.margin
        foothold_safe = np.ones(4, dtype=bool)
        path_safe = np.ones(4, dtype=bool)
        hit_box = -np.ones(4, dtype=int)
        s = np.linspace(0.0, 1.0, p.n_path)
        for leg in range(4):
            if len(grown) == 0:
                break
            fh = foothold[leg]
            inside = np.all((fh[:2] >= grown[:, 0, :2]) & (fh[:2] <= grown[:, 1, :2]), axis=1)
            if inside.any():
                foothold_safe[leg] = False
                hit_box[leg] = int(np.flatnonzero(inside)[0])
            if swinging[leg]:
                path = (1 - s)[:, None] * foot[leg] + s[:, None] * fh
                path[:, 2] += 4 * p.clearance * s * (1 - s)
                lo = grown[None, :, 0] - p.foot_radius
                hi = grown[None, :, 1] + p.foot_radius
                inb = np.all((path[:, None] >= lo) & (path[:, None] <= hi), axis=2)
                if inb.any():
                    path_safe[leg] = False
                    if hit_box[leg] < 0:
                        hit_box[leg] = int(np.flatnonzero(inb.any(axis=0))[0])
        # Interrupts in progress end at touch-down (after a short grace) or on time-out.
        for leg in range(4):
            if self.phase[leg] != PHASE_NONE:
                age = t - self.plan_start[leg]
                if age > p.max_interrupt_time or (down[leg] and age > 0.08):
                    self.phase[leg] = PHASE_NONE
        # New interrupts: a swinging leg whose path or foothold meets a box.
        conflict = swinging & ~(foothold_safe & path_safe)
        for leg in np.flatnonzero(conflict & (self.phase == PHASE_NONE)):
            self.phase[leg] = PHASE_UP
            self.plan_box[leg] = grown[hit_box[leg]]
            self.plan_start[leg] = t
        direction = np.zeros((4, 3))
        for leg in np.flatnonzero(self.phase != PHASE_NONE):
            d_world = self._steer(leg, foot[leg], heading, v)
            if d_world is None:  # past the block: the CPG sets the foot down
                self.phase[leg] = PHASE_NONE
                continue
            rel = d_world - v  # relative to the torso
            direction[leg] = (rel @ heading, rel @ left, rel[2])
        return EffectivityState(
            swinging=swinging,
            foothold=foothold,
            foothold_safe=foothold_safe,
            path_safe=path_safe,
            direction=direction,
            hit=hit_box,
            phase=self.phase.copy(),
        )

    def _steer(self, leg: int, foot: np.ndarray, heading: np.ndarray, v: np.ndarray):
        """Wanted world foot velocity of an interrupted leg, or None when it is past its box."""
        p = self.p
        box = self.plan_box[leg]
        corners = np.array([[box[i, 0], box[j, 1]] for i in (0, 1) for j in (0, 1)])
        along = corners @ heading[:2]
        f = foot[:2] @ heading[:2]
        d_near = along.min() - f  # foot centre to the near face, along the heading
        d_far = along.max() - f
        if d_far + p.foot_radius < 0.0:
            return None
        sole = foot[2] - p.foot_radius
        top = box[1, 2] + p.lift_clearance
        if self.phase[leg] == PHASE_UP and sole >= top:
            self.phase[leg] = PHASE_OVER
        if self.phase[leg] == PHASE_UP:
            # Hold the ground position while rising; back off if too close to the face.
            gap = d_near - p.foot_radius - p.approach_gap
            vx = float(np.clip(4.0 * gap, -0.4, 0.0))
            return vx * heading + np.array([0.0, 0.0, p.lift_speed])
        # Over: forward, holding the sole above the top.
        vz = float(np.clip(8.0 * (top + 0.01 - sole), -0.2, p.lift_speed))
        return p.carry_speed * heading + np.array([0.0, 0.0, vz])
