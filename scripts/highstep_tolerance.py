"""How well the trot takes a high step: falls while front swings are lifted to a block's height.

On ``NeuroCog/Walk-v1`` (no obstacle), from 2 s on every ``--every``-th swing of each leg in
``--legs`` is a high step: knee interrupt ``--knee`` and hip interrupt ``--hip`` from the
leg's CPG swing onset until its sole is ``--height`` up (what a step over a 6-8 cm block asks
of the leg), then the CPG's swing again. A trot that falls here cannot step over anything,
whatever the controller does (docs/oracle_notes.md). Prints falls of ``--seeds`` walks of
``--seconds``, the number of high steps and their median top sole height.

    python scripts/highstep_tolerance.py [--legs 0] [--every 3] [--seeds 5]
    NEUROCOG_ASSETS=DIR python scripts/highstep_tolerance.py   # another body or gait
"""

from __future__ import annotations

import argparse

import numpy as np


def walk(seed: int, legs, every: int, knee: float, hip: float, height: float, seconds: float):
    """One walk; returns (fell, [top sole height of each high step])."""
    import gymnasium as gym

    import neurocog_gym  # noqa: F401  (registers the ids)

    env = gym.make("NeuroCog/Walk-v1")
    obs, _ = env.reset(seed=seed)
    u = env.unwrapped
    radius = 0.018
    was, count, high = np.zeros(4, bool), np.zeros(4, int), np.zeros(4, bool)
    tops: list[float] = []
    fell = False
    action = np.zeros(15, np.float32)
    for _ in range(int(seconds / u.dt)):
        y = obs["cpg"].reshape(4, 6)
        swing = (y[:, 0] > y[:, 1]) | (y[:, 2] > y[:, 3])  # hip or knee flexor leads
        action[:] = 0.0
        for leg in legs:
            sole = float(u.data.site_xpos[u.robot.foot_site[leg], 2]) - radius
            if swing[leg] and not was[leg] and u.data.time > 2.0:
                count[leg] += 1
                high[leg] = count[leg] % every == 0
                if high[leg]:
                    tops.append(sole)
            high[leg] &= bool(swing[leg]) and sole < height
            if high[leg]:
                tops[-1] = max(tops[-1], sole)
                action[3 * leg + 1], action[3 * leg + 2] = hip, knee
        was = swing
        obs, _, term, trunc, _ = env.step(action)
        if term:
            fell = True
            break
    env.close()
    return fell, tops


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--legs", default="0", help="leg indices, FL=0 FR=1 HL=2 HR=3 (e.g. 01)")
    p.add_argument("--every", type=int, default=3)
    p.add_argument("--knee", type=float, default=1.0)
    p.add_argument("--hip", type=float, default=0.0)
    p.add_argument("--height", type=float, default=0.10)
    p.add_argument("--seeds", type=int, default=5)
    p.add_argument("--seconds", type=float, default=10.0)
    a = p.parse_args(argv)
    legs = [int(c) for c in a.legs]
    if not legs or any(leg not in range(4) for leg in legs) or a.every < 1 or a.seeds < 1:
        p.error("--legs: digits 0-3; --every and --seeds >= 1")
    falls, tops = 0, []
    for seed in range(a.seeds):
        fell, t = walk(seed, legs, a.every, a.knee, a.hip, a.height, a.seconds)
        falls += fell
        tops += t
    top = float(np.median(tops)) * 100 if tops else 0.0
    print(f"legs {a.legs}, every {a.every}th swing, knee {a.knee}, hip {a.hip}, to "
          f"{a.height * 100:.0f} cm: falls {falls} of {a.seeds} walks of {a.seconds:.0f} s, "
          f"{len(tops)} high steps, median top {top:.1f} cm")  # fmt: skip


if __name__ == "__main__":
    main()
