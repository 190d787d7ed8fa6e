"""Scratch: a trot that waits for a landing (touch gate in the CPG) + a tuck step-over oracle."""
from __future__ import annotations
import argparse, json, sys, time
from collections import Counter
import gymnasium as gym, mujoco, numpy as np
import neurocog_gym  # noqa
from neurocog_gym.bench.runner import trial_seed
from neurocog_gym.policies import start_episode
from neurocog_gym.policies.base import ACTION_DIM

import os
REACH = float(os.environ.get("REACH", 0.09)); SWING = float(os.environ.get("SWING", 0.29))
GATE = None
OTHER = {0: (1, 2), 3: (1, 2), 1: (0, 3), 2: (0, 3)}  # FL,FR,HL,HR: diagonals FL+HR, FR+HL


class Gate:
    """Touch gate: a loaded leg's flexors are inhibited while a leg of the other diagonal has
    been unloaded longer than t_min."""

    def __init__(self, env, g_hip=3.0, g_knee=3.0, thr=0.05, t_min=0.15, diag=False):
        self.diag = diag
        u = env.unwrapped
        gen = u.generator
        self.gen, self.thr, self.t_min = gen, thr, t_min
        V = gen.cpg.V
        V8 = np.zeros((24, 8)); V8[:, :4] = V
        for i in range(4):
            V8[6 * i + 0, 4 + i] = -g_hip
            V8[6 * i + 2, 4 + i] = -g_knee
        gen.cpg.V = np.ascontiguousarray(V8)
        Z = gen.pools.Z
        Z8 = np.zeros((12, 8)); Z8[:, :4] = Z
        gen.pools.Z = np.ascontiguousarray(Z8)
        gen._cycle_key = None
        self.unloaded = np.zeros(4)
        self.active = np.zeros(4)
        self.orig = gen.step
        gen.step = self.step

    def reset(self):
        self.unloaded[:] = 0.0

    def step(self, provision, interrupt, theta, theta_dot, touch, gyro=None):
        touch = np.asarray(touch, dtype=np.float64)
        loaded = touch >= self.thr
        self.unloaded = np.where(loaded, 0.0, self.unloaded + self.gen.dt)
        gate = np.zeros(4)
        for i in range(4):
            others = OTHER[i] if self.diag else [j for j in range(4) if j != i]
            if loaded[i] and max(self.unloaded[j] for j in others) > self.t_min:
                gate[i] = 1.0
        self.active = gate
        t8 = np.concatenate([touch, gate])
        return self.orig(provision, interrupt, theta, theta_dot, t8, gyro)


IDLE, LIFT, TUCK, LAND = 0, 1, 2, 3


class Tuck:
    needs_privileged = True
    name = "tuck"

    def __init__(self, **kw):
        self.p = dict(r=0.018, touch_off=0.05, lane=0.03, trigger=0.06, clear=0.03, lift_hip=None,
                      rel=0.03, kh=15.0, kk=20.0, knee0=0.3, margin=0.05, land_hip=0.0,
                      land_knee=-1.0, max_t=0.6, min_gap=0.0, dt=0.01, fresh=0.12, hind=1,
                      land_rel_gain=0.0, near_gap=0.02, push=0.0, push_knee=0.0)
        self.p.update(kw)
        self.reset()

    def reset(self, env=None):
        self.state = np.zeros(4, int); self.blk = np.full(4, -1); self.t = np.zeros(4)
        self.swing_t = np.full(4, np.inf); self.log = []

    def __call__(self, obs):
        p = self.p
        blocks = np.asarray(obs["true_blocks"], float).reshape(-1, 7)
        feet = np.asarray(obs["feet"], float).reshape(4, 3)
        hips = np.asarray(obs["leg_joints"], float).reshape(4, 3, 3)[:, 1]
        fh = np.asarray(obs["foothold"], float).reshape(4, 3)
        touch = np.asarray(obs["touch"], float)
        y = np.asarray(obs["cpg"], float).reshape(4, 6)
        cpg_swing = (y[:, 2] > y[:, 3]) | (y[:, 0] > y[:, 1])
        self.swing_t = np.where(cpg_swing, self.swing_t + p["dt"], np.inf)
        self.swing_t[cpg_swing & ~np.isfinite(self.swing_t)] = 0.0
        a = np.zeros(ACTION_DIM, np.float32)
        for leg in range(4):
            sole = feet[leg, 2] - p["r"]
            down = touch[leg] >= p["touch_off"]
            st = self.state[leg]
            if st != IDLE:
                self.t[leg] += p["dt"]
                b = blocks[self.blk[leg]]
                lx, _ = inblk(feet[leg, :2], b)
                hx, _ = inblk(hips[leg, :2], b)
                if b[0] == 0.0 or self.t[leg] > p["max_t"]:
                    st = IDLE
                else:
                    if st == LIFT and sole > b[6] + p["clear"]:
                        st = TUCK
                    if st == TUCK and hx > b[4] + p["margin"] and lx - p["r"] > b[4] + 0.01:
                        st = LAND
                    if st == LAND and down:
                        st = IDLE
            if st == IDLE and cpg_swing[leg] and self.swing_t[leg] <= p["fresh"] and (leg < 2 or p["hind"]):
                k = self.met(feet[leg, :2], fh[leg, :2], blocks)
                if k >= 0:
                    st, self.blk[leg], self.t[leg] = LIFT, k, 0.0
            self.state[leg] = st
            j = 3 * leg
            if st == IDLE:
                continue
            b = blocks[self.blk[leg]]
            lx, _ = inblk(feet[leg, :2], b)
            hx, _ = inblk(hips[leg, :2], b)
            if st == LIFT:
                near_lim = -b[4] - p["r"] - p["near_gap"]
                xt = min(hx + p["rel"], near_lim)
                a[j + 1] = np.clip(-p["kh"] * (xt - lx), -1, 1) if p["lift_hip"] is None else p["lift_hip"]
                a[j + 2] = 1.0
            elif st == TUCK:
                err_h = b[6] + p["clear"] - sole
                # foot relative to the hip along the block axis -> target rel (hip -1 protracts)
                e = p["rel"] - (lx - hx)
                a[j + 1] = np.clip(-p["kh"] * e, -1, 1)
                a[j + 2] = np.clip(p["knee0"] + p["kk"] * err_h, -1, 1)
            elif st == LAND:
                e = p["rel"] - (lx - hx)
                a[j + 1] = np.clip(p["land_hip"] - p["land_rel_gain"] * e, -1, 1)
                a[j + 2] = p["land_knee"]
        if p["push"] and GATE is not None:
            for leg in range(4):
                if GATE.active[leg] and self.state[leg] == IDLE:
                    a[3 * leg + 1] = p["push"]
                    a[3 * leg + 2] = p["push_knee"]
        return a

    def met(self, foot, fh, blocks):
        p = self.p
        best, bg = -1, np.inf
        for k, b in enumerate(blocks):
            if b[0] == 0.0:
                continue
            lx, ly = inblk(foot, b)
            if abs(ly) > b[5] + p["r"] + p["lane"]:
                continue
            gap = -b[4] - lx - p["r"]
            far = b[4] - lx + p["r"]
            land = inblk(fh, b)[0] - lx
            if far > 0 and gap >= p["min_gap"] - 1.0 and gap < land + p["trigger"] and gap < bg:
                best, bg = k, gap
        return best


def inblk(xy, b):
    c, s = np.cos(b[3]), np.sin(b[3])
    dx, dy = xy[0] - b[1], xy[1] - b[2]
    return c * dx + s * dy, -s * dx + c * dy


def run(policy, n, first=0, seed=7777, gate=None, env_id="NeuroCog/SuddenObstacle-v1", verbose=False):
    from neurocog_gym.locomotion.effectivity import EffectivityParams
    env = gym.make(env_id, privileged=True, effectivity=EffectivityParams(reach=REACH, swing_time=SWING))
    global GATE
    g = Gate(env, **gate) if gate is not None else None
    GATE = g
    u = env.unwrapped
    robot = set(int(x) for x in u.robot.robot_geoms)
    out = Counter(); rows = []
    for i in range(first, first + n):
        obs, _ = env.reset(seed=trial_seed(seed, "sudden" if "Sudden" in env_id else "static", i))
        if g: g.reset()
        policy.reset()
        done = False; first_c = None; app = None
        while not done:
            obs, _, te, tr, info = env.step(policy(obs)); done = te or tr
            if app is None and getattr(u, "appeared_at", None) is not None:
                app = float(u.appeared_at)
            if app is not None and first_c is None:
                bl = set(int(x) for x in u.pool.geoms[: len(u.pool.blocks)])
                for c in u.data.contact[: u.data.ncon]:
                    g1, g2 = int(c.geom[0]), int(c.geom[1])
                    if (g1 in bl and g2 in robot) or (g2 in bl and g1 in robot):
                        r = g2 if g1 in bl else g1
                        nm = mujoco.mj_id2name(u.model, mujoco.mjtObj.mjOBJ_GEOM, r) or "geom%d" % r
                        legi = ["FL", "FR", "HL", "HR"].index(nm[:2]) if nm[:2] in ("FL", "FR", "HL", "HR") else -1
                        stc = int(policy.state[legi]) if (legi >= 0 and hasattr(policy, "state")) else -1
                        first_c = (nm, round(float(u.data.time) - app, 2), "st%d" % stc)
                        break
        fl = [k for k in ("fell", "knocked", "stood_on", "stepped_over") if info.get(k)]
        out[info.get("outcome")] += 1
        for k in fl: out[k] += 1
        rows.append((i, info.get("outcome"), fl, first_c))
        if verbose: print(i, info.get("outcome"), fl, first_c, flush=True)
    env.close()
    return out, rows




DROP, WAIT, CARRY, APPROACH = 4, 5, 6, 7


class Plan:
    """drop -> wait planted -> step over from the next CPG swing onset."""
    needs_privileged = True
    name = "plan"

    def __init__(self, **kw):
        self.p = dict(r=0.018, touch_off=0.05, lane=0.03, trigger=0.04, clear=0.025, kh=15.0,
                      kk=20.0, knee0=0.3, beyond=0.03, hip_margin=0.04, land_knee=-1.0,
                      max_t=0.6, dt=0.01, fresh=0.03, near_gap=0.015, max_over=0.30,
                      wait_reach=0.25, drop_hip=1.0, drop_knee=-1.0, brake=0.0, hind=1,
                      carry_hip=-1.0, g_step=0.08, drop_gap=0.03, hold_hip=0.3, hold_knee=-0.5)
        self.p.update(kw)
        self.reset()

    def reset(self, env=None):
        self.state = np.zeros(4, int); self.blk = np.full(4, -1); self.t = np.zeros(4)
        self.swing_t = np.full(4, np.inf); self.prev_swing = np.zeros(4, bool); self.x0 = np.zeros(4)

    def lane_block(self, foot, blocks, ahead):
        """nearest block in this foot's lane with its near face within `ahead` and far face ahead."""
        p = self.p
        best, bg = -1, np.inf
        for k, b in enumerate(blocks):
            if b[0] == 0.0:
                continue
            lx, ly = inblk(foot, b)
            if abs(ly) > b[5] + p["r"] + p["lane"]:
                continue
            gap = -b[4] - lx - p["r"]
            far = b[4] - lx + p["r"]
            if far > 0 and gap < ahead and gap < bg:
                best, bg = k, gap
        return best

    def __call__(self, obs):
        p = self.p
        blocks = np.asarray(obs["true_blocks"], float).reshape(-1, 7)
        feet = np.asarray(obs["feet"], float).reshape(4, 3)
        hips = np.asarray(obs["leg_joints"], float).reshape(4, 3, 3)[:, 1]
        fh = np.asarray(obs["foothold"], float).reshape(4, 3)
        touch = np.asarray(obs["touch"], float)
        y = np.asarray(obs["cpg"], float).reshape(4, 6)
        cpg_swing = (y[:, 2] > y[:, 3]) | (y[:, 0] > y[:, 1])
        onset = cpg_swing & ~self.prev_swing
        self.prev_swing = cpg_swing
        self.swing_t = np.where(cpg_swing, self.swing_t + p["dt"], np.inf)
        self.swing_t[cpg_swing & ~np.isfinite(self.swing_t)] = 0.0
        a = np.zeros(ACTION_DIM, np.float32)
        brake = False
        for leg in range(4):
            if leg >= 2 and not p["hind"]:
                continue
            sole = feet[leg, 2] - p["r"]
            down = touch[leg] >= p["touch_off"]
            st = self.state[leg]
            if st != IDLE and (self.blk[leg] < 0 or blocks[self.blk[leg], 0] == 0.0):
                st = IDLE
            if st in (LIFT, CARRY, LAND, DROP, APPROACH):
                self.t[leg] += p["dt"]
                if self.t[leg] > p["max_t"]:
                    st = IDLE
            if st == IDLE:
                if not down and sole < 0.05:
                    k = self.lane_block(feet[leg, :2], blocks, 1.0)
                    if k >= 0:
                        b = blocks[k]
                        lx0 = inblk(feet[leg, :2], b)[0]
                        land = inblk(fh[leg, :2], b)[0] - lx0
                        gap = -b[4] - lx0 - p["r"]
                        if gap < land + p["trigger"]:
                            self.blk[leg], self.t[leg] = k, 0.0
                            if self.swing_t[leg] <= p["fresh"] and gap <= p["g_step"]:
                                st, self.x0[leg] = LIFT, lx0
                            else:
                                st = APPROACH
                elif down:
                    k = self.lane_block(feet[leg, :2], blocks, p["wait_reach"])
                    if k >= 0:
                        st, self.blk[leg] = WAIT, k
            ipsi = leg ^ 2
            pair = leg ^ 1
            others_ok = touch[ipsi] >= p["touch_off"] and touch[pair] >= p["touch_off"] and self.state[ipsi] not in (LIFT, CARRY, LAND) and self.state[pair] not in (LIFT, CARRY, LAND)
            hold = False
            if st == WAIT and (cpg_swing[leg] or (not down and sole > 0.005)) and not others_ok:
                hold = True
            elif st == WAIT:
                if cpg_swing[leg] or (not down and sole > 0.005):
                    b = blocks[self.blk[leg]]
                    lx0 = inblk(feet[leg, :2], b)[0]
                    gap = -b[4] - lx0 - p["r"]
                    self.t[leg] = 0.0
                    if gap <= p["g_step"]:
                        st, self.x0[leg] = LIFT, lx0
                    else:
                        st = APPROACH
            if st == APPROACH:
                b = blocks[self.blk[leg]]
                gap = -b[4] - inblk(feet[leg, :2], b)[0] - p["r"]
                if down and self.t[leg] > 0.05:
                    st = WAIT
                elif gap <= p["drop_gap"]:
                    st = DROP
            if st == DROP and down:
                st = WAIT
            b = blocks[self.blk[leg]] if self.blk[leg] >= 0 else None
            if b is not None:
                lx, _ = inblk(feet[leg, :2], b)
                hx, _ = inblk(hips[leg, :2], b)
            if st == LIFT and sole > b[6] + p["clear"]:
                st = CARRY
            if st == CARRY and lx - p["r"] > b[4] + p["beyond"] and hx > b[4] + p["hip_margin"]:
                st = LAND
            if st == LAND and down:
                st = IDLE
            if st == IDLE:
                self.blk[leg] = -1
            self.state[leg] = st
            j = 3 * leg
            if hold:
                a[j + 1], a[j + 2] = p["hold_hip"], p["hold_knee"]
            if st == DROP:
                a[j + 1], a[j + 2] = p["drop_hip"], p["drop_knee"]
                brake = True
            elif st == LIFT:
                xt = min(-b[4] - p["r"] - p["near_gap"], self.x0[leg])
                a[j + 1] = np.clip(-p["kh"] * (xt - lx), -1, 1)
                a[j + 2] = 1.0
            elif st == CARRY:
                err_h = b[6] + p["clear"] - sole
                xt = b[4] + p["r"] + p["beyond"] + 0.01
                a[j + 1] = p["carry_hip"] if lx < xt else np.clip(-p["kh"] * (xt - lx), -1, 1)
                a[j + 2] = np.clip(p["knee0"] + p["kk"] * err_h, -1, 1)
            elif st == LAND:
                xt = b[4] + p["r"] + p["beyond"] + 0.01
                a[j + 1] = np.clip(-p["kh"] * (xt - lx), -1, 1)
                a[j + 2] = p["land_knee"]
        if brake and p["brake"] != 0.0:
            a[12] = p["brake"]
        return a


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=20)
    ap.add_argument("--first", type=int, default=0)
    ap.add_argument("--gate", default=None, help="json dict or 'none'")
    ap.add_argument("--pol", default="{}")
    ap.add_argument("--blind", action="store_true")
    ap.add_argument("--oracle", default=None)
    ap.add_argument("--plan", default=None)
    ap.add_argument("--env", default="NeuroCog/SuddenObstacle-v1")
    ap.add_argument("-v", action="store_true")
    a = ap.parse_args()
    gate = None if a.gate in (None, "none") else json.loads(a.gate)
    if a.oracle is not None:
        if os.environ.get("O2"):
            # the wait variant: oracle_wait_2026_12_05.patch applied to a copy of
            # neurocog_gym/policies/oracle.py saved as oracle_wait_2026_12_05.py beside this file
            sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
            from oracle_wait_2026_12_05 import OraclePolicy, OracleParams
        else:
            from neurocog_gym.policies.oracle import OraclePolicy, OracleParams
        pol = OraclePolicy(OracleParams(**json.loads(a.oracle)))
    elif a.plan is not None:
        pol = Plan(**json.loads(a.plan))
    elif a.blind:
        class Z:
            needs_privileged = True
            def reset(self, env=None): pass
            def __call__(self, o): return np.zeros(ACTION_DIM, np.float32)
        pol = Z()
    else:
        pol = Tuck(**json.loads(a.pol))
    t0 = time.time()
    out, rows = run(pol, a.n, a.first, gate=gate, env_id=a.env, verbose=a.v)
    print(dict(out), f"{time.time()-t0:.0f}s")

