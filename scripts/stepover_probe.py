"""The isolated step-over probe of docs/oracle_notes.md: can body v1's front leg clear a block?

On ``NeuroCog/Walk-v1`` (trotting, no obstacle env), a block is placed 20 ms before a front-left
lift-off with its near face ``gap`` ahead of the FL sole, centred on the FL lane (20 cm wide);
from the lift-off the FL leg runs the oracle's primitive (lift: hip +0.3, knee +1 until the sole
is 3 cm above the top; carry: hip -1, knee +0.5, +1 whenever the sole sinks within 1.5 cm of the
top, until the sole is 3 cm past the far face; then released). Prints, per case, which robot
geoms touched the block and where the foot ended relative to the far face.

    python scripts/stepover_probe.py [--seeds 2]
"""

from __future__ import annotations

import argparse

import gymnasium as gym
import numpy as np

import neurocog_gym  # noqa: F401  (registers the env ids)
from neurocog_gym.bench.body import _lift_offs
from neurocog_gym.robot.obstacles import Block, ObstaclePool


def probe(seed: int, gap: float, height: float, length: float) -> dict:
    lifts, _ = _lift_offs(gym, "NeuroCog/Walk-v1", seed, 0, 2.0, 1)
    env = gym.make("NeuroCog/Walk-v1")
    env.reset(seed=seed)
    u = env.unwrapped
    m, d = u.model, u.data
    pool = ObstaclePool(m)
    a = np.zeros(15)
    while d.time < lifts[0] - 0.02 - 1e-9:
        env.step(a)
    foot = d.site_xpos[u.robot.foot_site[0]].copy()
    near = foot[0] + 0.018 + gap
    pool.place(m, d, [Block(near + length / 2, foot[1], length, 0.20, height, 0.0)])
    block, robot = int(pool.geom_ids[0]), {int(g) for g in u.robot.robot_geoms}
    state, hit = 0, set()
    for _ in range(80):
        sole = d.site_xpos[u.robot.foot_site[0], 2] - 0.018
        fx = d.site_xpos[u.robot.foot_site[0], 0]
        if state == 0 and d.time >= lifts[0] - 1e-9:
            state = 1
        a[:] = 0.0
        if state == 1:
            a[1], a[2] = 0.3, 1.0
            if sole > height + 0.03:
                state = 2
        elif state == 2:
            a[1], a[2] = -1.0, (1.0 if sole < height + 0.015 else 0.5)
            if fx - 0.018 > near + length + 0.03:
                state = 3
        env.step(a)
        for i in range(d.ncon):
            c = d.contact[i]
            if block in (c.geom1, c.geom2):
                other = c.geom2 if c.geom1 == block else c.geom1
                if other in robot:
                    hit.add(m.geom(other).name)
    beyond = float(d.site_xpos[u.robot.foot_site[0], 0] - (near + length))
    env.close()
    return {"touched_by": sorted(hit), "foot_past_far_face_m": round(beyond, 3)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=2)
    args = ap.parse_args()
    print("| seed | gap, cm | height, cm | length, cm | touched by | foot past far face, cm |")
    print("|---|---|---|---|---|---|")
    for seed in range(args.seeds):
        for gap in (0.02, 0.04, 0.06, 0.08):
            for h, length in ((0.06, 0.08), (0.08, 0.08), (0.08, 0.12)):
                r = probe(seed, gap, h, length)
                print(f"| {seed} | {gap * 100:.0f} | {h * 100:.0f} | {length * 100:.0f} | "
                      f"{', '.join(r['touched_by']) or '-'} | "
                      f"{r['foot_past_far_face_m'] * 100:.1f} |")  # fmt: skip


if __name__ == "__main__":
    main()
