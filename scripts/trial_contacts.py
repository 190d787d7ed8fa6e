"""Which part of the robot meets a sudden block first, and when: one line per trial.

For each sudden trial (the benchmark's trial seeds, ``trial_seed(seed, "sudden", i)``) the
script runs a policy on ``NeuroCog/SuddenObstacle-v3`` (privileged, so the oracle can run) and
prints the first robot geoms in contact with a block, each with the time from the block's
appearance, and the trial's outcome flags; the last lines count first contacts by body part and
within ``--early`` seconds of the appearance. ``NEUROCOG_ASSETS`` selects the body and gait, as
everywhere (e.g. the knee-behind variant of ``robot.variants``)::

    python scripts/trial_contacts.py --policy oracle --trials 60
    NEUROCOG_ASSETS=/tmp/kb python scripts/trial_contacts.py --policy oracle --trials 60

Used for docs/oracle_notes.md ("Where the block is met first"): a number there is only as good
as the command that measured it.
"""

from __future__ import annotations

import argparse
import statistics
from collections import Counter

import gymnasium as gym
import mujoco
import numpy as np

import neurocog_gym  # noqa: F401  (registers the envs)
from neurocog_gym.bench.runner import trial_seed
from neurocog_gym.policies import make_policy, start_episode


def first_contacts(env, policy, seed: int, horizon: float | None = None) -> dict:
    """Run one sudden trial and return its first block contacts and outcome.

    Args:
        env: a ``NeuroCog/SuddenObstacle-v3`` env made with ``privileged=True``.
        policy: ``policy(obs) -> action``.
        seed: the env seed of the trial.
        horizon: stop this many simulated seconds after the appearance (None: the episode's end).

    Returns:
        ``contacts``: list of (geom name, seconds after the appearance), in order of first
        contact; ``appeared``: the appearance time (None if the block never appeared);
        ``block``: (length, width, height) m; ``info``: the last step's outcome flags.
    """
    u = env.unwrapped
    obs, _ = env.reset(seed=seed)
    start_episode(policy, env)
    robot = set(int(g) for g in u.robot.robot_geoms)
    seen: dict[str, float] = {}
    appeared, block, info, done = None, None, {}, False
    while not done:
        obs, _, terminated, truncated, info = env.step(policy(obs))
        done = terminated or truncated
        if appeared is None and getattr(u, "appeared_at", None) is not None:
            appeared = float(u.appeared_at)
            b = u.pool.blocks[0]
            block = (b.length, b.width, b.height)
        if appeared is None:
            continue
        blocks = set(int(g) for g in u.pool.geoms[: len(u.pool.blocks)])
        for c in u.data.contact[: u.data.ncon]:
            g1, g2 = int(c.geom[0]), int(c.geom[1])
            for b_geom, r_geom in ((g1, g2), (g2, g1)):
                if b_geom in blocks and r_geom in robot:
                    name = mujoco.mj_id2name(u.model, mujoco.mjtObj.mjOBJ_GEOM, r_geom)
                    if not name:  # the hip servo boxes have no name of their own
                        body = int(u.model.geom_bodyid[r_geom])
                        name = f"{mujoco.mj_id2name(u.model, mujoco.mjtObj.mjOBJ_BODY, body)}_servo"
                    seen.setdefault(name, round(float(u.data.time) - appeared, 3))
        if horizon is not None and float(u.data.time) - appeared > horizon:
            break
    flags = {k: info.get(k) for k in ("outcome", "fell", "knocked", "stood_on", "stepped_over")}
    contacts = sorted(seen.items(), key=lambda kv: kv[1])
    return {"contacts": contacts, "appeared": appeared, "block": block, "info": flags}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--policy", default="oracle", help="as neurocog bench --policy")
    ap.add_argument("--trials", type=int, default=20, help="trials 0 .. n-1")
    ap.add_argument("--first", type=int, default=0, help="index of the first trial")
    ap.add_argument("--seed", type=int, default=7777, help="run seed (7777: the training trials)")
    ap.add_argument("--early", type=float, default=0.15, help="s: a first contact this soon")
    ap.add_argument("--show", type=int, default=3, help="contacts shown per trial")
    args = ap.parse_args(argv)
    if args.trials < 1:
        ap.error(f"--trials must be at least 1, got {args.trials}")
    env = gym.make("NeuroCog/SuddenObstacle-v3", privileged=True)
    policy = make_policy(args.policy)
    firsts, parts, outcomes = [], Counter(), Counter()
    for i in range(args.first, args.first + args.trials):
        r = first_contacts(env, policy, trial_seed(args.seed, "sudden", i))
        info = r["info"]
        flags = [k for k in ("fell", "knocked", "stood_on", "stepped_over") if info.get(k)]
        outcomes[info.get("outcome")] += 1
        size = ""
        if r["block"] is not None:
            size = "block L {:.3f} W {:.3f} H {:.3f}".format(*r["block"])
        shown = ", ".join(f"{g} {t:+.2f} s" for g, t in r["contacts"][: args.show])
        print(f"{i:4d} {info.get('outcome'):8s} {' '.join(flags):28s} {size}  {shown}", flush=True)
        if r["contacts"]:
            geom, t = r["contacts"][0]
            firsts.append(t)
            parts[geom.split("_")[-1]] += 1
    env.close()
    n = args.trials
    print(f"\noutcomes: {dict(outcomes)} of {n}")
    if firsts:
        early = sum(t <= args.early for t in firsts)
        q = np.percentile(firsts, [10, 50, 90])
        print(
            f"first contact in {len(firsts)} of {n} trials; within {args.early:g} s of the "
            f"appearance: {early}; after the appearance p10 / median / p90: "
            f"{q[0]:.2f} / {statistics.median(firsts):.2f} / {q[2]:.2f} s"
        )
        print(f"first contact by part: {dict(parts)}")


if __name__ == "__main__":
    main()
