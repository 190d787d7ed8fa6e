"""Where the sudden block appears relative to the foot it is meant for (SuddenObstacle-v3).

For ``--trials`` benchmark trials (the seeds ``neurocog bench --seed S`` uses), runs the blind
trot up to the block's appearance and prints percentiles of the gap from the swinging sole to
the block's near face and of the sole's height at that moment, and the share of trials whose gap
is under 2 and 3 cm: what any controller has left to answer with (docs/oracle_notes.md).

    python scripts/sudden_placement.py [--trials 40] [--seed 0]
    NEUROCOG_ASSETS=DIR python scripts/sudden_placement.py   # another body or gait
"""

from __future__ import annotations

import argparse

import numpy as np

R_FOOT = 0.018
"""Sole sphere radius, m (assets/quadruped.xml)."""


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--trials", type=int, default=40)
    p.add_argument("--seed", type=int, default=0)
    a = p.parse_args(argv)
    if a.trials < 1:
        p.error("--trials must be >= 1")
    import gymnasium as gym

    import neurocog_gym  # noqa: F401  (registers the ids)
    from neurocog_gym.bench.runner import trial_seed

    env = gym.make("NeuroCog/SuddenObstacle-v3", privileged=True)
    gaps, heights = [], []
    for i in range(a.trials):
        obs, _ = env.reset(seed=trial_seed(a.seed, "sudden", i))
        u = env.unwrapped
        while True:
            obs, _, term, trunc, _ = env.step(np.zeros(env.action_space.shape, np.float32))
            b = obs["true_blocks"].reshape(-1, 7)[0]
            if b[0] != 0.0 or term or trunc:
                break
        if b[0] == 0.0:
            continue
        foot = obs["feet"].reshape(4, 3)[u.appear_leg]
        c, s = np.cos(b[3]), np.sin(b[3])
        along = c * (foot[0] - b[1]) + s * (foot[1] - b[2])  # in the block's frame
        gaps.append(-b[4] - along - R_FOOT)
        heights.append(foot[2] - R_FOOT)
    env.close()
    g, h = np.array(gaps) * 100, np.array(heights) * 100
    q = (10, 25, 50, 75, 90)
    print(f"{len(g)} trials with a block (seed {a.seed})")
    print("sole to near face at the appearance, cm, percentiles 10/25/50/75/90:",
          np.round(np.percentile(g, q), 1))  # fmt: skip
    print("sole height at the appearance, cm, percentiles 10/25/50/75/90:",
          np.round(np.percentile(h, q), 1))  # fmt: skip
    print(f"gap under 2 cm: {np.mean(g < 2):.0%}, under 3 cm: {np.mean(g < 3):.0%}")


if __name__ == "__main__":
    main()
