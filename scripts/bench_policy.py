"""Benchmark: the AEF's forward pass and decision against an env step (issue 22: <= 5 %).

On ``NeuroCog/SuddenObstacle-v3`` (default perception), ``--episodes`` episodes run with the
shipped AEF policy; each control cycle times the policy call (``AEFPolicy.__call__``: the fit's
decision on the observation and, when it asks for it, the network's forward pass) and the env
step that follows, with ``time.perf_counter``. Both are timed on the same cycles of the same
run, so machine load touches them alike; the table gives medians (and p90) per cycle and the
ratio of the medians, and the ratio of the totals. Written to ``--out`` with the command and
the machine.

    .venv/bin/python scripts/bench_policy.py [--episodes 6] [--out FILE]
"""

from __future__ import annotations

import argparse
import datetime
import os
import sys
import time
from pathlib import Path

import numpy as np

from neurocog_gym import io as nio
from neurocog_gym.bench.machine import machine

TARGET = 0.05
"""Issue 22: the AEF's forward pass and decision at most 5 % of an env step."""


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--episodes", type=int, default=6)
    p.add_argument("--out", type=Path, default=Path("docs/generated/benchmarks_policy.md"))
    a = p.parse_args(argv)
    if a.episodes < 1:
        p.error("--episodes must be >= 1")
    import gymnasium as gym

    import neurocog_gym  # noqa: F401  (registers the ids)
    from neurocog_gym.policies import make_policy, start_episode

    env = gym.make("NeuroCog/SuddenObstacle-v3")
    policy = make_policy("aef")
    obs, _ = env.reset(seed=1000)  # warm-up: numba compiles outside the timed episodes
    start_episode(policy, env)
    for _ in range(50):
        obs, *_ = env.step(policy(obs))
    pol, step = [], []
    for ep in range(a.episodes):
        obs, _ = env.reset(seed=ep)
        start_episode(policy, env)
        while True:
            t0 = time.perf_counter()
            action = policy(obs)
            t1 = time.perf_counter()
            obs, _, term, trunc, _ = env.step(action)
            t2 = time.perf_counter()
            pol.append(t1 - t0)
            step.append(t2 - t1)
            if term or trunc:
                break
    env.close()
    pol_us, step_us = np.array(pol) * 1e6, np.array(step) * 1e6
    med = float(np.median(pol_us)) / float(np.median(step_us))
    tot = float(pol_us.sum()) / float(step_us.sum())
    verdict = "met" if max(med, tot) <= TARGET else "missed"
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    lines = [
        "# AEF policy call against an env step",
        "",
        f"`{' '.join(['python', 'scripts/bench_policy.py', *sys.argv[1:]])}` — "
        f"{datetime.date.today().isoformat()}, {machine('numpy', 'numba', 'mujoco')}, "
        f"load {load:.1f}; {len(pol)} control cycles of {a.episodes} SuddenObstacle-v3 episodes.",
        "",
        "| per control cycle | median, µs | p90, µs |",
        "|---|---:|---:|",
        f"| `AEFPolicy.__call__` (decision + forward pass) | {np.median(pol_us):.1f} | "
        f"{np.percentile(pol_us, 90):.1f} |",
        f"| `env.step` | {np.median(step_us):.1f} | {np.percentile(step_us, 90):.1f} |",
        "",
        f"Policy / env step: {med:.1%} of the medians, {tot:.1%} of the totals "
        f"(issue 22 target: at most {TARGET:.0%}; {verdict}).",
        "",
    ]
    text = "\n".join(lines)
    print(text)
    nio.atomic_write_text(a.out, text)


if __name__ == "__main__":
    main()
