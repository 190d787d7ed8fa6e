"""Exploration harness for the SUDDEN-obstacle scenario: candidate controllers and their tallies.

Research scratch (not part of the package). Policies are objects with ``reset(env)`` and
``__call__(obs, env) -> action``; ``env`` is passed so prototypes may read ``env.unwrapped``
(every such read is marked PRIVILEGED below, with what the observation would have to carry).

    .venv/bin/python scripts/explore_sudden.py --policy blind --start 0 --n 100
    .venv/bin/python scripts/explore_sudden.py --policy stepover --scenario static --n 50
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter
from multiprocessing import Pool

import mujoco
import numpy as np

from neurocog_gym.bench.runner import make_env, trial_seed

LEGS = ("FL", "FR", "HL", "HR")
FOOT_R = 0.018


# ------------------------------------------------------------------------------------------------
# Joint override: invert the motor-neuron pool (Eq. 8 + restoring term) so that the servo target
# q_ref follows a PD law towards a chosen joint angle. Needs the CPG drive (computable from
# obs["cpg"] with the gait's gains — here read from the generator, PRIVILEGED-but-derivable),
# q_ref (obs["servo_target"]) and its rate (finite difference of servo_target).
# ------------------------------------------------------------------------------------------------


class Override:
    def __init__(self, env):
        g = env.unwrapped.generator
        self.g = g
        self.posture = g.posture.copy()

    def theta(self, joints, q_des, kp=900.0, kd=60.0, obs=None):
        """Interrupt values for ``joints`` so that q_ref tracks q_des (other joints: 0)."""
        from neurocog_gym.locomotion._kernels import force_length, force_velocity

        g = self.g
        pools = g.pools
        th = np.zeros(12)
        q_ref = pools.q_ref
        qd_ref = pools.qd_ref
        theta_m = obs["joint_pos"].astype(float)
        theta_dot = obs["joint_vel"].astype(float)
        p = pools.params
        k_rest, d_rest = p.k_rest, p.d_rest
        for j, qd in zip(joints, q_des):
            acc_des = kp * (qd - q_ref[j]) - kd * qd_ref[j]
            need = acc_des + k_rest * (q_ref[j] - self.posture[j]) + d_rest * qd_ref[j]
            fl = force_length(theta_m[j], self.posture[j], pools.fl_width[j], p.fl_c)
            sgn = 1.0 if need >= 0 else -1.0
            v_muscle = -theta_dot[j] if sgn > 0 else theta_dot[j]
            fv = force_velocity(v_muscle, pools.vel_max[j], p.fv_K, p.fv_N)
            denom = max(pools.acc_max[j] * fl * max(fv, 0.05), 1e-6)
            a = need / denom
            base = float(np.clip(p.mu1 * g.drive[j], -1, 1))
            th[j] = np.clip((a - base) / p.mu2, -1.0, 1.0)
        return th


def leg_fk(q3):
    """Foot offset from the hip (x fwd, z up) in the torso frame, sagittal plane, for (h, k)."""
    h, k = q3[1], q3[2]
    x = -0.13 * np.sin(h) - 0.13 * np.sin(h + k)
    z = -0.13 * np.cos(h) - 0.13 * np.cos(h + k)
    return x, z


# ------------------------------------------------------------------------------------------------
# Policies
# ------------------------------------------------------------------------------------------------


class Blind:
    name = "blind"

    def reset(self, env):
        pass

    def __call__(self, obs, env):
        return np.zeros(15, np.float32)


class Wrapped:
    """A package policy (``make_policy`` spec)."""

    def __init__(self, spec):
        from neurocog_gym.policies import make_policy

        self.p = make_policy(spec)
        self.name = spec

    def reset(self, env):
        pass

    def __call__(self, obs, env):
        return self.p(obs)


POLICIES = {}


class HighArc:
    """Open-loop high-arc swing pattern, triggered per leg and per swing by the block geometry.

    At a leg's swing start (CPG hip drive turns to protraction; for the leg the block appears
    under, the first cycle the block is known), if the block's near face lies within ``reach``
    ahead of the foot and the foot's lateral position overlaps the block (+``margin_y``):
    tuck (knee +1, hip +1: the foot rises ~9 cm in 0.1 s and stays in place in the world) for
    ``t1`` s, then carry (knee ``kc``, hip -1) for ``t2`` s, then release (Theta = 0). With
    ``short=True`` a swing whose carry cannot reach past the far face (``carry`` m from the
    lift-off point) is instead tucked for ``t_short`` s and released, to land before the near
    face. ``sag``: s_SAG while a block is ahead of the hind feet.

    Needs: block boxes (``source`` "truth" PRIVILEGED or "memory" = effectivity memory, which
    the observation carries only partly as ``objects``), foot positions (PRIVILEGED, FK from
    joint_pos + torso pose would give them), the CPG hip drive (derivable from obs["cpg"]).
    """

    def __init__(self, t1=0.10, t2=0.12, kc=1.0, reach=0.30, margin_y=0.03, sag=0.0,
                 source="memory", short=False, carry=0.16, t_short=0.14, legs=(0, 1, 2, 3),
                 hind_t1=None, hind_t2=None, min_gap=-1.0):
        self.t1, self.t2, self.kc, self.reach, self.margin_y = t1, t2, kc, reach, margin_y
        self.sag, self.source, self.short, self.carry, self.t_short = sag, source, short, carry, t_short
        self.legs = legs
        self.hind_t1 = t1 if hind_t1 is None else hind_t1
        self.hind_t2 = t2 if hind_t2 is None else hind_t2
        self.min_gap = min_gap

    def reset(self, env):
        self.mode = [None] * 4
        self.t0 = np.zeros(4)
        self.prev_swing = np.zeros(4, bool)
        self.nblocks = 0

    def boxes(self, u):
        if self.source == "truth":
            return u.pool.boxes() if u.pool.blocks else np.zeros((0, 2, 3))
        return np.asarray(u.effectivity.memory)

    def decide(self, leg, foot, boxes):
        for b in boxes:
            if b[1, 2] < 0.02:
                continue
            if foot[1] < b[0, 1] - self.margin_y or foot[1] > b[1, 1] + self.margin_y:
                continue
            gap = b[0, 0] - foot[0]
            if gap < self.min_gap or gap > self.reach:
                continue
            need = b[1, 0] + FOOT_R + 0.01 - foot[0]
            if self.short and need > self.carry:
                return "short"
            return "high"
        return None

    def __call__(self, obs, env):
        u = env.unwrapped
        t = float(u.data.time)
        act = np.zeros(15, np.float32)
        boxes = self.boxes(u)
        feet = u._feet()
        swing = u.generator.hip_drive > 0
        start = swing & ~self.prev_swing
        self.prev_swing = swing
        new_blocks = len(boxes) > self.nblocks
        self.nblocks = len(boxes)
        for leg in self.legs:
            if self.mode[leg] is None and len(boxes) and (start[leg] or (new_blocks and swing[leg])):
                m = self.decide(leg, feet[leg], boxes)
                if m:
                    self.mode[leg] = m
                    self.t0[leg] = t
            m = self.mode[leg]
            if m is None:
                continue
            s = t - self.t0[leg]
            hind = leg >= 2
            t1 = self.hind_t1 if hind else self.t1
            t2 = self.hind_t2 if hind else self.t2
            if m == "high":
                if s < t1:
                    act[3 * leg + 1], act[3 * leg + 2] = 1.0, 1.0
                elif s < t1 + t2:
                    act[3 * leg + 1], act[3 * leg + 2] = -1.0, self.kc
                else:
                    self.mode[leg] = None
            elif m == "short":
                if s < self.t_short:
                    act[3 * leg + 1], act[3 * leg + 2] = 1.0, 1.0
                else:
                    self.mode[leg] = None
        if self.sag and len(boxes):
            if feet[:, 0].min() < boxes[:, 1, 0].max() + 0.05:
                act[12] = self.sag
        return act


def leg_ik(x, z, L=0.13):
    """(hip, knee) angles putting the foot at (x fwd, z up) from the hip axis, knee folded back."""
    d = float(np.hypot(x, z))
    d = min(max(d, 0.06), 2 * L - 0.005)
    k = 2.0 * np.arccos(d / (2 * L))
    phi = np.arctan2(x, -z)
    return -phi - k / 2, k


class StepOver:
    """High step over the block for each leg whose swing path crosses it (state machine per leg).

    Per leg: idle -> up (rise in place to block top + clear, not past the near face) -> over
    (carry beyond the far face) -> released (Theta = 0, the CPG puts the foot down).
    Joint targets through inverse kinematics and the pool inversion (``Override``).

    Needs: the block boxes (``source``: "truth" = simulator, PRIVILEGED; "memory" = the
    effectivity's obstacle memory), foot and hip-axis positions (PRIVILEGED, from the model;
    derivable from joint_pos + torso pose by forward kinematics), touch, the CPG drive.
    """

    def __init__(self, clear=0.03, trigger=0.30, margin_y=0.03, sag=0.0, source="truth",
                 land=0.03, kp=900.0, kd=60.0, max_hold=0.35, legs=(0, 1, 2, 3),
                 cancel_diag=False, up_dx=0.0):
        self.clear, self.trigger, self.margin_y, self.sag = clear, trigger, margin_y, sag
        self.source, self.land, self.kp, self.kd = source, land, kp, kd
        self.max_hold, self.legs, self.cancel_diag, self.up_dx = max_hold, legs, cancel_diag, up_dx

    def reset(self, env):
        self.ov = Override(env)
        self.state = ["idle"] * 4
        self.t0 = [0.0] * 4
        self.done_blocks = [set() for _ in range(4)]
        self.target = [None] * 4
        self.was_down = np.ones(4, bool)

    def boxes(self, u):
        if self.source == "truth":
            return u.pool.boxes() if u.pool.blocks else np.zeros((0, 2, 3))
        return np.asarray(u.effectivity.memory)

    def __call__(self, obs, env):
        u = env.unwrapped
        d = u.data
        act = np.zeros(15, np.float32)
        boxes = self.boxes(u)
        t = float(d.time)
        R = d.xmat[u.robot.torso_body].reshape(3, 3)
        feet = u._feet()
        touch = obs["touch"]
        down = touch > 0.05
        lifted = self.was_down & ~down
        self.was_down = down
        joints, qdes = [], []
        any_ahead = False
        for leg in range(4):
            foot = feet[leg]
            hipw = d.xpos[u.robot.hip_body[leg] + 1]
            st = self.state[leg]
            if st == "idle" and leg in self.legs and len(boxes):
                swinging = (not down[leg]) and u.generator.hip_drive[leg] > 0
                if swinging:
                    for bi, b in enumerate(boxes):
                        if foot[1] < b[0, 1] - self.margin_y or foot[1] > b[1, 1] + self.margin_y:
                            continue
                        if foot[0] > b[0, 0] - FOOT_R * 0.5:
                            continue
                        if b[0, 0] - foot[0] < self.trigger:
                            self.state[leg] = st = "up"
                            self.t0[leg] = t
                            self.target[leg] = b.copy()
                            break
            for b in boxes:
                if feet[:, 0].min() < b[1, 0] + 0.02 and b[0, 0] - feet[:, 0].max() < 0.6:
                    any_ahead = True
            if st in ("up", "over"):
                b = self.target[leg]
                top = b[1, 2] + FOOT_R + self.clear
                if st == "up":
                    xt = min(foot[0] + self.up_dx, b[0, 0] - FOOT_R - 0.02)
                    if foot[2] > top - 0.5 * self.clear:
                        self.state[leg] = st = "over"
                if st == "over":
                    xt = b[1, 0] + FOOT_R + self.land + 0.02
                    if foot[0] > b[1, 0] + FOOT_R + self.land:
                        self.state[leg] = st = "idle"
                if t - self.t0[leg] > self.max_hold:
                    self.state[leg] = st = "idle"
                if st in ("up", "over"):
                    rel = R.T @ (np.array([xt, foot[1], top + 0.01]) - hipw)
                    h, k = leg_ik(rel[0], rel[2])
                    joints += [3 * leg + 1, 3 * leg + 2]
                    qdes += [h, k]
        if joints:
            th = self.ov.theta(joints, qdes, self.kp, self.kd, obs)
            act[:12] = th
        if any_ahead and self.sag:
            act[12] = self.sag
        return act




def register(name):
    def deco(f):
        POLICIES[name] = f
        return f

    return deco


register("blind")(lambda **kw: Blind())
register("aef")(lambda **kw: Wrapped("aef"))
register("aef-provision")(lambda **kw: Wrapped("aef-provision"))
register("stepover")(lambda **kw: StepOver(**kw))
register("higharc")(lambda **kw: HighArc(**kw))


# ------------------------------------------------------------------------------------------------
# Trial runner
# ------------------------------------------------------------------------------------------------

_ENV = {}


def _env(scenario):
    if scenario not in _ENV:
        _ENV[scenario] = make_env(scenario, "on", None)
    return _ENV[scenario]


def run_trial(args):
    scenario, idx, pname, kw = args
    env = _env(scenario)
    u = env.unwrapped
    policy = POLICIES[pname](**kw)
    obs, info = env.reset(seed=trial_seed(0, scenario, idx))
    policy.reset(env)
    names = {
        int(g): mujoco.mj_id2name(u.model, mujoco.mjtObj.mjOBJ_GEOM, int(g)) or f"g{g}"
        for g in u.robot.robot_geoms
    }
    first = {}
    done = False
    peak = np.zeros(4)
    while not done:
        obs, _, term, trunc, info = env.step(policy(obs, env))
        done = term or trunc
        if u.pool.blocks:
            d = u.data
            bg = set(u.pool.geom_ids[: len(u.pool.blocks)].tolist())
            for i in range(d.ncon):
                g1, g2 = int(d.contact.geom1[i]), int(d.contact.geom2[i])
                if g1 in bg and g2 in names:
                    first.setdefault(names[g2], round(float(d.time), 2))
                elif g2 in bg and g1 in names:
                    first.setdefault(names[g1], round(float(d.time), 2))
            peak = np.maximum(peak, u._feet()[:, 2])
    out = info["outcome"] if info.get("passed") else "fail"
    return {
        "idx": idx,
        "outcome": out,
        "fell": bool(info.get("fell")),
        "t_end": round(float(u.data.time), 2),
        "appeared": getattr(u, "appeared_at", None),
        "leg": getattr(u, "appear_leg", None),
        "contacts": first,
        "peak_cm": np.round(100 * (peak - FOOT_R), 1).tolist(),
        "blocks": [(round(b.height, 3), round(b.length, 3), round(b.width, 3)) for b in u.pool.blocks],
    }


def evaluate(pname, scenario="sudden", start=0, n=100, kw=None, procs=2, verbose=False):
    jobs = [(scenario, i, pname, kw or {}) for i in range(start, start + n)]
    t0 = time.time()
    if procs > 1:
        with Pool(procs) as pool:
            res = pool.map(run_trial, jobs, chunksize=1)
    else:
        res = [run_trial(j) for j in jobs]
    c = Counter(r["outcome"] for r in res)
    falls = sum(r["fell"] for r in res)
    if verbose:
        for r in res:
            print(json.dumps(r))
    summ = {
        "policy": pname, "kw": kw or {}, "scenario": scenario, "start": start, "n": n,
        "success": c["success"], "touch": c["touch"], "fail": c["fail"], "falls": falls,
        "wall_s": round(time.time() - t0, 1),
    }
    return summ, res


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--policy", default="blind")
    ap.add_argument("--scenario", default="sudden")
    ap.add_argument("--start", type=int, default=0)
    ap.add_argument("--n", type=int, default=20)
    ap.add_argument("--procs", type=int, default=2)
    ap.add_argument("--kw", default="{}")
    ap.add_argument("-v", action="store_true")
    a = ap.parse_args()
    summ, res = evaluate(a.policy, a.scenario, a.start, a.n, json.loads(a.kw), a.procs, a.v)
    print(json.dumps(summ))
    with open("/tmp/explore_sudden_log.jsonl", "a") as f:
        f.write(json.dumps(summ) + "\n")


if __name__ == "__main__":
    sys.exit(main())
