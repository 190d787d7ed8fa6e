"""Diagnose obstacle trials: when the obstacle was perceived, when the AEF acted, what touched it.

For controller development. Per trial it prints the outcome, the obstacle's appearance time, the
first cycle an attention box overlapped the true block (perception latency), the first interrupt
and provision cycles, the first contact of each robot geom with a block, and the peak foot height
of each leg while the block was near.

    python scripts/diagnose_obstacle.py --scenario sudden --policy aef --trials 10 --seed 0
"""

from __future__ import annotations

import argparse
from collections import Counter

import mujoco
import numpy as np

from neurocog_gym.bench.runner import make_env, trial_seed
from neurocog_gym.policies import make_policy


def _overlap_xy(a: np.ndarray, b: np.ndarray) -> bool:
    return bool(np.all(a[0, :2] <= b[1, :2]) and np.all(b[0, :2] <= a[1, :2]))


def diagnose(env, policy, seed: int) -> dict:
    u = env.unwrapped
    obs, info = env.reset(seed=seed)
    m = u.model
    names = {
        g: mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom{g}"
        for g in u.robot.robot_geoms
    }
    first_seen = first_int = first_prov = None
    contacts: dict[str, float] = {}
    foot_peak = np.zeros(4)
    done = False
    while not done:
        obs, _, term, trunc, info = env.step(policy(obs))
        done = term or trunc
        t = float(u.data.time)
        if not u.pool.blocks:
            continue
        truth = u.pool.boxes()
        if first_seen is None:
            for b in u.pipeline.attention_boxes:
                if any(_overlap_xy(b, tb) for tb in truth):
                    first_seen = t
                    break
        mode = int(info.get("aef_mode", 0))
        if mode == 1 and first_int is None:
            first_int = t
        if mode == 2 and first_prov is None:
            first_prov = t
        d = u.data
        block_geoms = set(u.pool.geom_ids[: len(u.pool.blocks)].tolist())
        for i in range(d.ncon):
            g1, g2 = int(d.contact.geom1[i]), int(d.contact.geom2[i])
            if g1 in block_geoms and g2 in names:
                contacts.setdefault(names[g2], t)
            elif g2 in block_geoms and g1 in names:
                contacts.setdefault(names[g1], t)
        feet = u._feet()
        near = np.abs(feet[:, 0] - truth[:, :, 0].mean(axis=1).min()) < 0.25
        foot_peak = np.where(near, np.maximum(foot_peak, feet[:, 2]), foot_peak)
    return {
        "outcome": info["outcome"] if info.get("passed") else "fail",
        "appeared": getattr(u, "appeared_at", None),
        "leg": getattr(u, "appear_leg", None),
        "seen": first_seen,
        "interrupt": first_int,
        "provision": first_prov,
        "contacts": contacts,
        "foot_peak_cm": np.round(100 * foot_peak, 1).tolist(),
        "heights_cm": [round(100 * b.height, 1) for b in u.pool.blocks],
        "lengths_cm": [round(100 * b.length, 1) for b in u.pool.blocks],
        "t_end": float(u.data.time),
        "fell": bool(info.get("fell")),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="sudden", choices=["sudden", "static"])
    ap.add_argument("--policy", default="aef")
    ap.add_argument("--trials", type=int, default=10)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--attention", default="on", choices=["on", "off"])
    ap.add_argument(
        "--weights", default=None, help="AEF weights (.npz) instead of the shipped ones"
    )
    ap.add_argument("--start", type=int, default=0, help="first trial index")
    ap.add_argument(
        "--gain", type=float, default=1.0, help="AEFPolicy interrupt_gain (with --weights)"
    )
    args = ap.parse_args()
    env = make_env(args.scenario, args.attention, None)
    if args.weights:
        from neurocog_gym.policies import AEFPolicy

        policy = AEFPolicy(args.weights, interrupt_gain=args.gain)
    else:
        policy = make_policy(args.policy)
    tally = Counter()
    for i in range(args.start, args.start + args.trials):
        r = diagnose(env, policy, trial_seed(args.seed, args.scenario, i))
        tally[r["outcome"]] += 1
        fmt = lambda x: "-" if x is None else f"{x:.2f}"  # noqa: E731
        print(
            f"{i:3d} {r['outcome']:8s} app={fmt(r['appeared'])} leg={r['leg']} "
            f"seen={fmt(r['seen'])} int={fmt(r['interrupt'])} prov={fmt(r['provision'])} "
            f"end={r['t_end']:.2f} fell={r['fell']} "
            f"h={r['heights_cm']} l={r['lengths_cm']} peak={r['foot_peak_cm']} "
            f"contacts={ {k: round(v, 2) for k, v in r['contacts'].items()} }",
            flush=True,
        )
    print(dict(tally))


if __name__ == "__main__":
    main()
