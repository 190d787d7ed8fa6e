"""Fig. 18: foot heights around a sudden obstacle, with and without the AEF.

Runs the same ``NeuroCog/SuddenObstacle-v3`` trial (same seed, so the same block appears at the
same moment) once per policy and plots the height of each front foot's sole over time, with the
obstacle's appearance and height marked, the effectivity's interrupt phases and the AEF fit's
stop / side-step / pass states (``locomotion/avoidance.py``, run by the policy) shaded, and, on
the right axis, the
leading foot's distance to the block's near face (the stop shows there, not in the foot heights:
the AEF does not step over a block that appears within reach).

    python scripts/plot_foot_height.py --seed 0 --index 0 --out docs/img/fig18_foot_height.png
"""

from __future__ import annotations

import argparse

import numpy as np

from neurocog_gym import io as nio
from neurocog_gym.bench.runner import make_env, trial_seed
from neurocog_gym.locomotion.avoidance import STATE_NAMES
from neurocog_gym.policies import make_policy, start_episode
from neurocog_gym.robot.names import LEGS


def record(policy_name: str, seed: int) -> dict:
    """One trial; per control cycle: time, sole heights, interrupt phases."""
    policy = make_policy(policy_name)
    env = make_env("sudden", "on", None, getattr(policy, "needs_privileged", False))
    u = env.unwrapped
    obs, info = env.reset(seed=seed)
    radius = u.effectivity.p.foot_radius
    start_episode(policy, env)
    t, z, phase, state, lead = [], [], [], [], []
    done = False
    while not done:
        obs, _, term, trunc, info = env.step(policy(obs))
        done = term or trunc
        t.append(float(u.data.time))
        z.append(u._feet()[:, 2] - radius)
        phase.append(u.eff.phase.copy() if u.eff.phase is not None else np.zeros(4, int))
        # The AEF's walk-round teacher: the state its last action came from (0: walk).
        state.append(getattr(policy, "teacher_state", 0))
        lead.append(float(u._feet()[:, 0].max()))
    outcome = info["outcome"] if info.get("passed") else "fail"
    outcome += "".join(f", {k}" for k in ("knocked", "stood_on", "fell") if info.get(k))
    blocks = [b.to_json() for b in u.pool.blocks]
    env.close()
    return {"t": np.array(t), "z": np.array(z), "phase": np.array(phase), "outcome": outcome,
            "appeared": u.appeared_at, "leg": u.appear_leg, "blocks": blocks,
            "state": np.array(state), "lead": np.array(lead)}  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0, help="benchmark seed of the trial")
    ap.add_argument("--index", type=int, default=0, help="trial index (sudden scenario)")
    ap.add_argument("--policies", default="aef,blind")
    ap.add_argument("--out", default="docs/img/fig18_foot_height.png")
    args = ap.parse_args()
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    seed = trial_seed(args.seed, "sudden", args.index)
    names = [p.strip() for p in args.policies.split(",")]
    runs = {name: record(name, seed) for name in names}
    fig, axes = plt.subplots(
        len(names), 1, figsize=(9, 2.8 * len(names)), sharex=True, squeeze=False
    )
    for ax, name in zip(axes[:, 0], names, strict=True):
        r = runs[name]
        for leg in (0, 1):
            ax.plot(r["t"], 100 * r["z"][:, leg], label=f"{LEGS[leg]} sole")
            on = r["phase"][:, leg] > 0
            if on.any():
                ax.fill_between(r["t"], 0, 1, where=on, alpha=0.15, step="mid",
                                transform=ax.get_xaxis_transform(),
                                label=f"{LEGS[leg]} interrupt phase")  # fmt: skip
        colours = {1: "tab:red", 2: "tab:purple", 3: "tab:green"}
        if name not in ("blind", "oracle"):  # they ignore the effectivity's provision
            for st, colour in colours.items():
                on = r["state"] == st
                if on.any():
                    ax.fill_between(r["t"], 0, 1, where=on, alpha=0.12, step="mid",
                                    color=colour, transform=ax.get_xaxis_transform(),
                                    label=f"AEF provision: {STATE_NAMES[st]}")  # fmt: skip
        if r["appeared"] is not None:
            ax.axvline(r["appeared"], color="k", ls="--", lw=1, label="obstacle appears")
        for b in r["blocks"]:
            ax.axhline(100 * b["height"], color="tab:red", ls=":", lw=1)
        if r["blocks"]:
            near = min(b["x"] - 0.5 * b["length"] for b in r["blocks"])
            ax2 = ax.twinx()
            ax2.plot(r["t"], 100 * (near - r["lead"]), color="0.3", lw=1,
                     label="lead foot behind the near face")  # fmt: skip
            ax2.axhline(0.0, color="0.3", lw=0.5, ls=":")
            ax2.set_ylabel("lead foot behind the near face, cm", fontsize=8)
            ax2.legend(fontsize=7, loc="upper right")
        ax.set_ylabel("sole height, cm")
        ax.set_title(f"{name}: {r['outcome']} (block appeared in {LEGS[r['leg']]}'s swing; "
                     f"red: block height)", fontsize=9)  # fmt: skip
        ax.legend(fontsize=7, loc="upper left", ncol=3)
        if r["appeared"] is not None:
            ax.set_xlim(r["appeared"] - 0.5, min(r["t"][-1], r["appeared"] + 2.5))
    axes[-1, 0].set_xlabel("time, s")
    fig.suptitle("Fig. 18 reproduction: front-foot heights around a sudden obstacle", fontsize=10)
    fig.tight_layout()
    nio.atomic_savefig(fig, args.out, dpi=110)
    for name, r in runs.items():
        print(f"{name}: {r['outcome']}, peak front sole {100 * r['z'][:, :2].max():.1f} cm")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
