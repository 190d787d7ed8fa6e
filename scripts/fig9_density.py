"""Fig. 9 reproduction: node density on a suddenly appearing obstacle, DD-GNG against GNG.

The robot trots in ``NeuroCog/Walk-v3``; after ``--appear`` s a wooden block (the paper's: 6–8 cm
high, 5–12 cm long, 10–30 cm wide) appears 0.7–0.9 m ahead. Its four ToF sensors (45 fps) feed the
same frames to two attention pipelines, DD-GNG (attention on) and plain GNG (attention off), each
running one learning cycle + affordance detection per 0.01 s control cycle, as the obstacle envs do
(see ``neurocog_gym.bench.perception_scenes.walking_trial``). Node density is nodes per m² of ground
inside the obstacle region (the block's footprint grown by 3 cm) and elsewhere (the rest of the
graph over the rest of the area the frame covers).

    .venv/bin/python scripts/fig9_density.py [--trials 10] [--seed 0]

Writes ``docs/img/fig9_density.png`` and the ``fig9`` section of
``docs/generated/benchmarks_perception.md``.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from tqdm import tqdm

from neurocog_gym.bench.perception_scenes import Variant, load_now, walking_trial, write_section
from neurocog_gym.io import atomic_write_bytes

VARIANTS = {"DD-GNG": Variant("ddgng"), "GNG": Variant("gng")}
COLOURS = {"DD-GNG": "#d62728", "GNG": "#1f77b4"}
MARKS = (0.2, 0.5, 1.0)


@dataclass(frozen=True)
class Args:
    """Command-line options."""

    trials: int = 10
    seed: int = 0
    appear: float = 1.5
    after: float = 1.0
    out: Path = Path("docs/img/fig9_density.png")
    write: bool = True


def parse(argv: list[str] | None = None) -> Args:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--trials", type=int, default=Args.trials)
    p.add_argument("--seed", type=int, default=Args.seed, help="first trial seed")
    p.add_argument(
        "--appear", type=float, default=Args.appear, help="s of walking before the block"
    )
    p.add_argument("--after", type=float, default=Args.after, help="s recorded after it appears")
    p.add_argument("--out", type=Path, default=Args.out)
    p.add_argument(
        "--no-write",
        action="store_true",
        help="do not touch docs/generated/benchmarks_perception.md",
    )
    a = p.parse_args(argv)
    if a.trials < 1 or a.after <= 0:
        p.error("--trials must be >= 1 and --after > 0")
    return Args(a.trials, a.seed, a.appear, a.after, a.out, not a.no_write)


def collect(args: Args) -> dict[str, dict[str, np.ndarray]]:
    """Run the trials; return per variant (trials, T) arrays of every trace field."""
    runs = []
    for k in tqdm(range(args.trials), desc="walking trials"):
        r = walking_trial(args.seed + k, VARIANTS, t_appear=args.appear, after=args.after)
        runs.append(r)
    out = {}
    for name in VARIANTS:
        arrs = [r.traces[name].arrays() for r in runs]
        n = min(len(a["t"]) for a in arrs)
        out[name] = {
            key: np.stack([a[key][:n] for a in arrs]) for key in arrs[0] if len(arrs[0][key])
        }
    return out


def at(t: np.ndarray, y: np.ndarray, when: float) -> np.ndarray:
    """Per trial, the value of the last sample at or before ``when`` s."""
    i = int(np.searchsorted(t[0], when + 1e-9)) - 1
    return y[:, max(i, 0)]


def report(args: Args, data, elapsed: float, load0: str, load1: str, argv: list[str]) -> str:
    lines = [
        "### Fig. 9: node density on a suddenly appearing obstacle (scripts/fig9_density.py)",
        "",
        f"Command: `.venv/bin/python scripts/fig9_density.py {' '.join(argv)}`",
        f"Load average at start {load0}, at end {load1}; {elapsed:.0f} s. {args.trials} trials "
        f"(seeds {args.seed}–{args.seed + args.trials - 1}), block appears after {args.appear:g} "
        "s of "
        "trotting, 0.7–0.9 m ahead; same frames to both nets; Table 2 parameters; one learning "
        "cycle per 0.01 s control cycle. Mean over trials (min–max in brackets).",
        "",
        "![Fig. 9](../img/fig9_density.png)",
        "",
        "| t after appearance (s) | net | density on obstacle region (nodes/m²) | density "
        "elsewhere | ratio | nodes on obstacle (> 2 cm) | nodes in total |",
        "|---:|---|---:|---:|---:|---:|---:|",
    ]
    for when in MARKS:
        for name, d in data.items():
            t = d["t"]
            din = at(t, d["dens_in"], when)
            dout = at(t, d["dens_out"], when)
            ratio = din / np.maximum(dout, 1e-9)
            on = at(t, d["n_on"], when)
            tot = at(t, d["n_nodes"], when)
            lines.append(
                f"| {when:g} | {name} | {din.mean():.0f} ({din.min():.0f}–{din.max():.0f}) | "
                f"{dout.mean():.1f} | {ratio.mean():.1f} ({ratio.min():.1f}–{ratio.max():.1f}) | "
                f"{on.mean():.1f} ({on.min()}–{on.max()}) | {tot.mean():.0f} |"
            )
    return "\n".join(lines) + "\n"


def plot(args: Args, data, path: Path) -> None:
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    for name, d in data.items():
        t = d["t"][0]
        c = COLOURS[name]
        for ax, key, style in ((axes[0], "dens_in", "-"), (axes[0], "dens_out", ":")):
            y = d[key]
            lab = f"{name}, {'obstacle region' if key == 'dens_in' else 'elsewhere'}"
            ax.plot(t, y.mean(0), style, color=c, label=lab)
            if key == "dens_in":
                ax.fill_between(
                    t, np.percentile(y, 25, 0), np.percentile(y, 75, 0), color=c, alpha=0.15
                )
        ratio = d["dens_in"] / np.maximum(d["dens_out"], 1e-9)
        axes[1].plot(t, ratio.mean(0), color=c, label=name)
        axes[1].fill_between(
            t, np.percentile(ratio, 25, 0), np.percentile(ratio, 75, 0), color=c, alpha=0.15
        )
        on = d["n_on"]
        axes[2].plot(t, on.mean(0), color=c, label=name)
        axes[2].fill_between(
            t, np.percentile(on, 25, 0), np.percentile(on, 75, 0), color=c, alpha=0.15
        )
    axes[0].set(xlabel="time after the obstacle appeared (s)", ylabel="nodes per m² of ground",
                title="(a) node density", yscale="log")  # fmt: skip
    axes[1].set(xlabel="time after the obstacle appeared (s)", ylabel="obstacle / elsewhere",
                title="(b) density ratio")  # fmt: skip
    axes[1].axhline(1.0, color="k", lw=0.6)
    axes[2].set(xlabel="time after the obstacle appeared (s)", ylabel="nodes",
                title="(c) nodes on the obstacle (> 2 cm above the floor)")  # fmt: skip
    for ax in axes:
        ax.grid(alpha=0.3)
        for m in MARKS:
            ax.axvline(m, color="0.6", lw=0.5, ls="--")
        ax.legend(fontsize=8)
    fig.suptitle(
        f"Fig. 9 reproduction: a block appears in front of the trotting robot "
        f"(mean and interquartile band of {args.trials} trials)"
    )
    fig.tight_layout()
    import io

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    atomic_write_bytes(path, buf.getvalue())
    print(f"wrote {path}")


def main(argv: list[str] | None = None) -> str:
    argv = sys.argv[1:] if argv is None else argv
    args = parse(argv)
    load0 = load_now()
    t0 = time.perf_counter()
    data = collect(args)
    text = report(args, data, time.perf_counter() - t0, load0, load_now(), argv)
    plot(args, data, args.out)
    print(text)
    if args.write:
        write_section("fig9", text)
    return text


if __name__ == "__main__":
    main()
