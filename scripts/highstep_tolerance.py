"""How well a gait takes a high step or a step over: falls while front swings are lifted.

On ``NeuroCog/Walk-v3`` (no obstacle), from 2 s on every ``--every``-th swing of each leg in
``--legs`` is a high step: knee interrupt ``--knee`` and hip interrupt ``--hip`` from the
swing's start until its sole is ``--height`` up (what a step over a 6-8 cm block asks of the
leg). Then, by default, the CPG's swing again; with ``--carry S`` a step over instead: hip -1
with the knee holding the height (knee +1 below 9 cm, +0.5 above) for S seconds, then knee -1
until the foot is down (the step is released after 0.6 s whatever its state). The swing starts
(``--trigger``) at the leg's CPG swing onset (``cpg``: hip or knee flexor leading, the trot's
timing) or at the foot's lift-off (``liftoff``: the sole rising above 4 mm; a walk's knee lifts
the foot before its hip flexor leads). A gait that falls here cannot step over anything,
whatever the controller does (docs/oracle_notes.md). Prints falls of ``--seeds`` walks of
``--seconds``, the number of high steps and their median top sole height.

    python scripts/highstep_tolerance.py [--legs 0] [--every 3] [--seeds 5]
    python scripts/highstep_tolerance.py --legs 01 --seeds 6 --trigger liftoff --carry 0.16
    NEUROCOG_ASSETS=DIR python scripts/highstep_tolerance.py   # another body or gait
"""

from __future__ import annotations

import argparse

import numpy as np

LIFTED = 0.004
"""Sole height above which a foot is off the ground, m."""


def walk(
    seed: int, legs, every: int, knee: float, hip: float, height: float, seconds: float,
    trigger: str = "cpg", carry: float = -1.0,
):  # fmt: skip
    """One walk; returns (fell, [top sole height of each high step]).

    ``carry`` < 0: a high step (then the CPG's swing); >= 0: a step over with that carry, s.
    """
    import gymnasium as gym

    import neurocog_gym  # noqa: F401  (registers the ids)

    env = gym.make("NeuroCog/Walk-v3")
    obs, _ = env.reset(seed=seed)
    u = env.unwrapped
    radius = 0.018
    was, count = np.zeros(4, bool), np.zeros(4, int)
    stage = np.zeros(4, int)  # 0 idle, 1 lift, 2 carry, 3 land
    since = np.zeros(4)
    tops: list[float] = []
    fell = False
    action = np.zeros(15, np.float32)
    for _ in range(int(seconds / u.dt)):
        y = obs["cpg"].reshape(4, 6)
        sole_all = u.data.site_xpos[u.robot.foot_site, 2] - radius
        if trigger == "cpg":
            start = (y[:, 0] > y[:, 1]) | (y[:, 2] > y[:, 3])  # hip or knee flexor leads
        else:
            start = sole_all > LIFTED
        action[:] = 0.0
        for leg in legs:
            sole = float(sole_all[leg])
            if start[leg] and not was[leg] and u.data.time > 2.0 and stage[leg] == 0:
                count[leg] += 1
                if count[leg] % every == 0:
                    stage[leg], since[leg] = 1, 0.0
                    tops.append(sole)
            if stage[leg] == 0:
                continue
            since[leg] += u.dt
            tops[-1] = max(tops[-1], sole)
            j = 3 * leg
            if stage[leg] == 1:
                if carry < 0 and (trigger == "cpg" and not start[leg]):
                    stage[leg] = 0  # the CPG's swing has ended
                elif sole < height:
                    action[j + 1], action[j + 2] = hip, knee
                else:
                    stage[leg], since[leg] = (2, 0.0) if carry >= 0 else (0, 0.0)
            if stage[leg] == 2:
                action[j + 1], action[j + 2] = -1.0, 1.0 if sole < 0.09 else 0.5
                if since[leg] >= carry:
                    stage[leg] = 3
            elif stage[leg] == 3:
                action[j + 2] = -1.0
                if sole < LIFTED:
                    stage[leg] = 0
            if since[leg] > 0.6:
                stage[leg] = 0
        was = start
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
    p.add_argument("--trigger", default="cpg", help="cpg (CPG swing onset) or liftoff")
    p.add_argument("--carry", type=float, default=-1.0,
                   help="s of carry of a step over (< 0: a high step, the default)")  # fmt: skip
    a = p.parse_args(argv)
    legs = [int(c) for c in a.legs if c.isdigit()]
    if not legs or len(legs) != len(a.legs) or any(leg not in range(4) for leg in legs):
        p.error(f"--legs: digits 0-3 (FL=0 FR=1 HL=2 HR=3), got {a.legs!r}")
    if a.every < 1 or a.seeds < 1:
        p.error("--every and --seeds must be >= 1")
    if a.trigger not in ("cpg", "liftoff"):
        p.error(f"--trigger must be 'cpg' or 'liftoff', got {a.trigger!r}")
    falls, tops = 0, []
    for seed in range(a.seeds):
        fell, t = walk(seed, legs, a.every, a.knee, a.hip, a.height, a.seconds, a.trigger,
                       a.carry)  # fmt: skip
        falls += fell
        tops += t
    top = float(np.median(tops)) * 100 if tops else 0.0
    kind = "high steps" if a.carry < 0 else f"step-overs ({a.carry:.2f} s carry)"
    print(f"legs {a.legs}, every {a.every}th swing from the {a.trigger}, knee {a.knee}, hip "
          f"{a.hip}, to {a.height * 100:.0f} cm: falls {falls} of {a.seeds} walks of "
          f"{a.seconds:.0f} s, {len(tops)} {kind}, median top {top:.1f} cm")  # fmt: skip


if __name__ == "__main__":
    main()
