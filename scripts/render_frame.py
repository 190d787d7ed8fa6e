"""Render one frame of an obstacle env with the attention graph drawn in (the README picture).

Usage: python scripts/render_frame.py [--env NeuroCog/StaticObstacle-v3] [--seed 1]
       [--steps 60] [--camera overhead] [--out docs/img/attention_frame.png]
"""

from __future__ import annotations

import argparse
import os
from dataclasses import dataclass

os.environ.setdefault("MUJOCO_GL", "egl")


@dataclass
class Args:
    env: str = "NeuroCog/StaticObstacle-v3"
    seed: int = 1
    steps: int = 60
    camera: str = "overhead"
    width: int = 640
    height: int = 480
    out: str = "docs/img/attention_frame.png"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for name, default in vars(Args()).items():
        ap.add_argument(f"--{name}", type=type(default), default=default)
    args = Args(**vars(ap.parse_args()))
    import gymnasium as gym
    import imageio.v2 as imageio
    import numpy as np

    import neurocog_gym  # noqa: F401

    kwargs = {"first_distance": (0.5, 0.6)} if "Static" in args.env else {}
    env = gym.make(args.env, render_mode="rgb_array", width=args.width, height=args.height,
                   camera_name=args.camera, **kwargs)  # fmt: skip
    env.reset(seed=args.seed)
    for _ in range(args.steps):
        env.step(np.zeros(15, np.float32))
    os.makedirs(os.path.dirname(args.out) or ".", exist_ok=True)
    from neurocog_gym.io import atomic_path

    with atomic_path(args.out) as tmp:
        imageio.imwrite(tmp, env.render())
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
