"""A picture strip of the AEF (or the shipped PPO policy) on a sudden block, or on stepping stones.

One seeded ``NeuroCog/SuddenObstacle-v3`` episode under ``--policy aef`` (the fit and the AEF
network on the observation; its stop / side-step / pass comes from the fit's provision teacher,
``locomotion/avoidance.py``), rendered with
the attention graph, facets and footholds drawn in; four frames side by side: trotting just
before the block appears, the back-off under way, the first frame of the side step's end
("pass"), and the robot walking past near the end of the episode.

    MUJOCO_GL=egl .venv/bin/python scripts/render_strip.py --policy aef --seed 1 \
        --out docs/img/aef_sudden_strip.png

The matching video:
``neurocog record-video --policy aef --seed 1 --out docs/img/aef_sudden.mp4``.

``--env stones``: one ``NeuroCog/SteppingStones-v3`` episode instead, four frames evenly spaced
from the start to the episode's end (a foot in the pit, a fall, across or the time limit); each
predicted foothold is drawn green where the map shows level support under it and no block is
in the way (``foothold_safe``, Video S2's circles), red otherwise:

    MUJOCO_GL=egl .venv/bin/python scripts/render_strip.py --env stones --policy blind --seed 3 \
        --out docs/img/stones_strip.png
"""

from __future__ import annotations

import argparse
import os

os.environ.setdefault("MUJOCO_GL", "egl")

import gymnasium as gym  # noqa: E402
import imageio.v3 as iio  # noqa: E402
import numpy as np  # noqa: E402

import neurocog_gym  # noqa: E402, F401  (registers the env ids)
from neurocog_gym.io import atomic_path  # noqa: E402
from neurocog_gym.locomotion.avoidance import STATE_NAMES  # noqa: E402
from neurocog_gym.policies import make_policy, start_episode  # noqa: E402


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--policy", default="aef", choices=("aef", "ppo", "blind", "oracle"),
                    help="controller (blind and oracle: four frames evenly spaced from the "
                         "block's appearance to 1.2 s later)")  # fmt: skip
    ap.add_argument("--env", default="sudden", choices=("sudden", "stones"),
                    help="SuddenObstacle-v3 or SteppingStones-v3")  # fmt: skip
    ap.add_argument("--seed", type=int, default=1, help="episode seed")
    ap.add_argument("--width", type=int, default=400, help="width of one frame, pixels")
    ap.add_argument("--height", type=int, default=360, help="frame height, pixels")
    ap.add_argument("--camera", default="follow", help="scene camera: follow, side or overhead")
    ap.add_argument("--out", default="docs/img/aef_sudden_strip.png", help="PNG to write")
    args = ap.parse_args(argv)
    policy = make_policy(args.policy)
    env = gym.make(
        "NeuroCog/SuddenObstacle-v3" if args.env == "sudden" else "NeuroCog/SteppingStones-v3",
        render_mode="rgb_array",
        width=args.width,
        height=args.height,
        camera_name=args.camera,
        privileged=bool(getattr(policy, "needs_privileged", False)),
    )
    obs, _ = env.reset(seed=args.seed)
    start_episode(policy, env)
    u = env.unwrapped

    def state() -> str:
        state = getattr(policy, "teacher_state", None)  # the AEF's stop / side-step / pass
        return STATE_NAMES[state] if state is not None else ""

    frames, states, times, appeared = [], [], [], None
    done, info = False, {}
    while not done:
        obs, _, terminated, truncated, info = env.step(policy(obs))
        done = terminated or truncated
        frames.append(env.render())
        states.append(state())
        times.append(float(u.data.time))
        if appeared is None and getattr(u, "appeared_at", None) is not None:
            appeared = len(frames) - 1
    env.close()
    if args.env == "stones":
        picks = [int(round(v)) for v in np.linspace(0, len(frames) - 1, 4)]
        _write(args.out, [frames[i] for i in picks])
        pit = f", a foot in the pit at {info['pit_at']:.2f} s" if info.get("pit_at") else ""
        print(f"wrote {args.out}: frames at t = {', '.join(f'{times[i]:.2f}' for i in picks)} s "
              f"(outcome {info.get('outcome')}{pit})")  # fmt: skip
        return
    if appeared is None:
        raise SystemExit(f"seed {args.seed}: no block appeared; try another seed")
    dt = times[1] - times[0]
    if args.policy in ("blind", "oracle"):
        end = min(appeared + int(1.2 / dt), len(frames) - 1)
        picks = [int(round(v)) for v in np.linspace(appeared, end, 4)]
        _write(args.out, [frames[i] for i in picks])
        print(f"wrote {args.out}: frames at t = {', '.join(f'{times[i]:.2f}' for i in picks)} s")
        return
    before = max(appeared - int(0.05 / dt), 0)
    backing = min(appeared + int(0.15 / dt), len(frames) - 1)
    passing = next((i for i, s in enumerate(states) if s == "pass"), len(frames) // 2)
    last = max(len(frames) - 1 - int(0.3 / dt), passing)
    picks = [before, backing, passing, last]
    _write(args.out, [frames[i] for i in picks])
    print(
        f"wrote {args.out}: frames at t = {', '.join(f'{times[i]:.2f}' for i in picks)} s "
        f"(block appeared at {times[appeared]:.2f} s; episode {times[-1]:.2f} s)"
    )


def _write(out: str, frames: list[np.ndarray]) -> None:
    """The frames side by side as one PNG, written atomically."""
    with atomic_path(out) as tmp:
        iio.imwrite(tmp, np.concatenate(frames, axis=1))


if __name__ == "__main__":
    main()
