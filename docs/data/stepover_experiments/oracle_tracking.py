"""Experimental step-over oracle: IK-tracked swing paths through the pools (knee-behind body)."""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

IDLE, DROP, HOLD, STEP, LANDED = 0, 1, 2, 3, 4
L = 0.20
R_FOOT = 0.018
import os
DEBUG = bool(os.environ.get('O2DEBUG'))


@dataclass(frozen=True)
class P:
    T: float = 0.30          # step duration, s
    t1: float = 0.35         # fraction of T at which the apex is reached
    t2: float = 0.70         # fraction at which the descent starts
    clr: float = 0.035       # sole above the top at the apex, m
    margin: float = 0.08     # landing: sole this far past the far face, m
    pre: float = 0.02        # sole stops rising this far before the near face, m
    tau_p: float = 0.04
    vmax: float = 6.6
    A: float = 800.0
    trigger: float = 0.04    # swing meets a block whose near face is < foothold + this
    max_over: float = 0.32   # farthest far face (from the sole) to step over from onset, m
    drop_gap: float = 0.03   # drop when the sole is this close to the near face, m
    drop_back: float = 0.04
    back: float = 0.0
    clr_ok: float = 0.02     # rise until the sole is this far above the top
    over: float = 0.03       # targets this far above top + clr (the tracker lags)
    lead: float = 0.08       # carry target this far ahead of the sole
    carry_max: float = 0.2
    wait_partner: bool = True
    open_rise: bool = True
    hold_z: float = 0.0
    skip_partner: bool = False
    brake: float = 0.0
    lift_hip: float = 0.3
    partner_down: bool = False
    min_beyond: float = 0.04
    reach: float = 0.24      # a swing meets a block whose near face is within this of the sole
    lane: float = 0.03
    fresh: float = 0.03
    hold_hip: float = 0.3
    hold_knee: float = -0.5
    max_step: float = 0.6
    touch_off: float = 0.05
    dt: float = 0.01


def _rot_body(q):
    w, x, y, z = q
    R = np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])
    yaw = np.arctan2(R[1, 0], R[0, 0])
    c, s = np.cos(yaw), np.sin(yaw)
    Rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    return Rz.T @ R  # torso orientation in the heading frame


def ik(v_b):
    """Pool (hip, knee) putting the foot centre at v_b (torso frame, from the hip pitch joint)."""
    x, z = v_b[0], v_b[2]
    r = float(np.clip(np.hypot(x, z), 0.12, 0.395))
    k = 2.0 * np.arccos(r / (2 * L))
    phi = np.arctan2(-x, -z)
    return phi - k / 2.0, k


class Oracle2:
    name = "oracle2"
    needs_privileged = True

    def __init__(self, p: P | None = None):
        self.p = p or P()
        self.reset()

    def reset(self, env=None):
        self.state = np.zeros(4, int)
        self.t = np.zeros(4)
        self.block = np.full(4, -1)
        self.swing_t = np.full(4, np.inf)
        self.prev_ref = None
        self.start = np.zeros((4, 2))  # (s0, lateral) of a step in the block frame
        self.hold_pt = np.zeros((4, 3))
        self.prev_des = np.zeros((4, 2))
        self.phase = np.zeros(4, int)
        self.t_ph = np.zeros(4)
        self.skip = np.zeros(4, int)
        self.has_des = np.zeros(4, bool)

    def __call__(self, obs):
        p = self.p
        blocks = np.asarray(obs["true_blocks"], float).reshape(-1, 7)
        feet = np.asarray(obs["feet"], float).reshape(4, 3)
        lj = np.asarray(obs["leg_joints"], float).reshape(4, 3, 3)
        fh = np.asarray(obs["foothold"], float).reshape(4, 3)
        touch = np.asarray(obs["touch"], float)
        y = np.asarray(obs["cpg"], float).reshape(4, 6)
        srv = np.asarray(obs["servo_target"], float)
        Rb = _rot_body(np.asarray(obs["torso_quat"], float))
        ref = srv.copy()
        # pool coordinates: knee-behind legs have pool hip = servo hip - knee
        kb = True
        for leg in range(4):
            if kb:
                ref[3 * leg + 1] = srv[3 * leg + 1] - srv[3 * leg + 2]
        refd = np.zeros(12) if self.prev_ref is None else (ref - self.prev_ref) / p.dt
        self.prev_ref = ref
        cpg_swing = (y[:, 2] > y[:, 3]) | (y[:, 0] > y[:, 1])
        onset = cpg_swing & ~np.isfinite(self.swing_t)
        self.swing_t = np.where(cpg_swing, np.where(np.isfinite(self.swing_t), self.swing_t + p.dt, 0.0), np.inf)
        a = np.zeros(15, np.float32)
        for leg in range(4):
            st = self.state[leg]
            sole = feet[leg, 2] - R_FOOT
            down = touch[leg] >= p.touch_off
            if st != IDLE:
                self.t[leg] += p.dt
            partner = leg ^ 1
            busy = self.state[partner] in (STEP,) or (p.partner_down and touch[partner] < p.touch_off)
            if self.skip[leg] == 1 and cpg_swing[leg]:
                self.skip[leg] = 2
            if self.skip[leg] == 2 and not cpg_swing[leg]:
                self.skip[leg] = 0
            if st == IDLE and self.skip[leg] == 2:
                a[3 * leg + 1], a[3 * leg + 2] = p.hold_hip, p.hold_knee
            elif st == IDLE and cpg_swing[leg] and busy and p.wait_partner:
                a[3 * leg + 1], a[3 * leg + 2] = p.hold_hip, p.hold_knee
            elif st == IDLE and cpg_swing[leg]:
                k, s_sole, s_fh, lat = self._met(feet[leg], fh[leg], blocks)
                if k >= 0:
                    b = blocks[k]
                    far = self._len(b, lat) - s_sole
                    if self.swing_t[leg] <= p.fresh and far <= p.max_over:
                        st, self.t[leg] = STEP, 0.0
                        self.phase[leg] = 0
                        self.start[leg] = (s_sole, lat)
                    else:
                        st, self.t[leg] = DROP, 0.0
                    self.block[leg] = k
            b = blocks[self.block[leg]] if self.block[leg] >= 0 else None
            target = None
            if st == DROP:
                s_sole, lat = self._s(feet[leg], b)
                if down and self.t[leg] > 0.03:
                    st = HOLD
                    self.hold_pt[leg] = (*self._s(feet[leg], b), 0.0)
                    if p.skip_partner:
                        self.skip[leg ^ 1] = 1
                elif -s_sole - R_FOOT <= p.drop_gap or self.t[leg] > 0.0:
                    # put it down now, where it is (a little back)
                    target = feet[leg] + np.array([-p.drop_back, 0.0, -0.05])
            if st == HOLD:
                target = self._to_heading(b, self.hold_pt[leg, 0], self.hold_pt[leg, 1], R_FOOT + p.hold_z)
                if not cpg_swing[leg]:
                    st = IDLE
            if st == STEP:
                s0, lat = self.start[leg]
                s_now, _ = self._s(feet[leg], b)
                top = b[6] + p.clr
                s_end = self._len(b, lat) + p.margin + R_FOOT
                ph = self.phase[leg]
                if ph == 0 and sole >= b[6] + p.clr_ok:
                    ph = 1
                if ph == 0:
                    self.t_ph[leg] = self.t[leg]
                if ph == 1 and (s_now >= s_end - 0.01 or self.t[leg] - self.t_ph[leg] > p.carry_max
                                or (s_now > self._len(b, lat) + R_FOOT + p.min_beyond and self.t[leg] > p.T)):
                    ph = 2
                if ph == 0 and p.open_rise:
                    target = None
                    a[3 * leg + 1], a[3 * leg + 2] = p.lift_hip, 1.0
                elif ph == 0:
                    target = self._to_heading(b, s0 - p.back, lat, top + p.over + R_FOOT)
                elif ph == 1:
                    target = self._to_heading(b, min(s_end, s_now + p.lead), lat, top + p.over + R_FOOT)
                else:
                    target = self._to_heading(b, s_end + 0.02, lat, R_FOOT - 0.01)
                self.phase[leg] = ph
                if (ph == 2 and down) or self.t[leg] > p.max_step:
                    st = LANDED
                    self.hold_pt[leg] = (*self._s(feet[leg], b), 0.0)
            if st == LANDED:
                target = self._to_heading(b, self.hold_pt[leg, 0], self.hold_pt[leg, 1], R_FOOT + p.hold_z)
                if not cpg_swing[leg] or self.t[leg] > p.max_step + 0.3:
                    st = IDLE
            if st == IDLE:
                self.block[leg] = -1
            if target is None:
                self.has_des[leg] = False
            self.state[leg] = st
            if target is not None:
                v_b = Rb.T @ (target - lj[leg, 1])
                hq, kq = ik(v_b)
                hq, kq = float(hq), float(kq)
                j = 3 * leg
                des = np.array([hq, kq])
                prev = self.prev_des[leg] if self.has_des[leg] else des
                qd_des = (des - prev) / p.dt
                self.prev_des[leg] = des
                self.has_des[leg] = True
                qd_cmd = np.clip(qd_des + (des - ref[j + 1 : j + 3]) / p.tau_p, -p.vmax, p.vmax)
                v = refd[j + 1 : j + 3]
                dv = qd_cmd - v
                conc = np.sign(dv) == np.sign(v)
                fv = np.where(conc, (p.vmax - np.abs(v)) / (p.vmax + np.abs(v)), 1.2)
                fv = np.maximum(fv, 0.1)
                th = np.clip(dv / (p.A * fv * p.dt), -1, 1)
                a[j + 1], a[j + 2] = th
                if DEBUG and st == STEP:
                    print(f"   dbg leg{leg} t{self.t[leg]:.2f} des h{hq:+.2f} k{kq:+.2f} ref h{ref[j+1]:+.2f} k{ref[j+2]:+.2f} rd h{refd[j+1]:+.1f} k{refd[j+2]:+.1f} a {a[j+1]:+.2f} {a[j+2]:+.2f} tgt {np.round(target,3)} foot {np.round(feet[leg],3)} b {np.round(b,3)} s0lat {np.round(self.start[leg],3)}")
        if np.isin(self.state, (DROP, HOLD)).any():
            a[12] = p.brake
        late = (self.state == STEP) & ~cpg_swing
        if late.any():
            for o in range(4):
                if self.state[o] == IDLE and cpg_swing[o]:
                    a[3 * o + 1] = p.hold_hip
                    a[3 * o + 2] = p.hold_knee
        return a

    def _span(self, b, dy):
        """(near, far) x of the block, relative to its centre along the heading, at lateral dy +- R."""
        c, s = np.cos(b[3]), np.sin(b[3])
        xs = []
        for yy in (dy - R_FOOT, dy, dy + R_FOOT):
            # box: |c x + s y| <= hl, |-s x + c y| <= hw; solve for x on the line y = yy
            lo, hi = -np.inf, np.inf
            for (a1, a0, h) in ((c, s * yy, b[4]), (-s, c * yy, b[5])):
                if abs(a1) < 1e-9:
                    if abs(a0) > h:
                        lo, hi = np.inf, -np.inf
                    continue
                x1, x2 = (-h - a0) / a1, (h - a0) / a1
                lo, hi = max(lo, min(x1, x2)), min(hi, max(x1, x2))
            if lo <= hi:
                xs += [lo, hi]
        if not xs:
            return -b[4], b[4]
        return min(xs), max(xs)

    def _s(self, foot, b):
        """(s, lat): s from the near face along the heading at the foot's lateral place, lat = dy."""
        dx, dy = foot[0] - b[1], foot[1] - b[2]
        near, far = self._span(b, dy)
        return dx - near, dy

    def _span_miss(self, b, dy):
        c, s = np.cos(b[3]), np.sin(b[3])
        # lateral reach of the rotated box: half extent along y
        half_y = abs(s) * b[4] + abs(c) * b[5]
        return abs(dy) > half_y + R_FOOT + self.p.lane

    def _len(self, b, lat):
        near, far = self._span(b, lat)
        return far - near

    def _to_heading(self, b, s, lat, z):
        near, far = self._span(b, lat)
        return np.array([b[1] + near + s, b[2] + lat, z])

    def _met(self, foot, fh, blocks):
        p = self.p
        best, bs = -1, (0, 0, 0, 0)
        bg = np.inf
        for k, b in enumerate(blocks):
            if b[0] == 0.0:
                continue
            s_sole, lat = self._s(foot, b)
            if not np.isfinite(self._span(b, lat)[0]) or self._span_miss(b, lat):
                continue
            s_fh, _ = self._s(fh, b)
            gap = -s_sole - R_FOOT
            far = self._len(b, lat) - s_sole + R_FOOT
            if far > 0 and (s_fh + R_FOOT > -p.trigger or gap < p.reach) and gap < bg:
                best, bg, bs = k, gap, (k, s_sole, s_fh, lat)
        return bs if best >= 0 else (-1, 0, 0, 0)
