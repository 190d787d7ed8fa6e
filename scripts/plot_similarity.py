"""Surface similarity (§6.5.3, Eq. 12–16) over time after an obstacle appears, DD-GNG vs GNG.

The walking trial of ``fig9_density.py``: a paper-sized block appears 0.7–0.9 m ahead of the
trotting robot; DD-GNG and GNG learn the same ToF frames, one cycle per 0.01 s. Every cycle the
nodes of each net on the obstacle (within its footprint + 3 cm, higher than 2 cm) are matched
against the block's true visible surface sampled every 1 cm with outward normals
(``similarity.box_surface_reference``); node normals come from the detection's facets. The
Table 5 measures per trial (``SimilarityTrace``): best similarity, time to the best, similarity
at 0.5 s. Paper (§8): 0.91 with attention, 0.6 without.

    .venv/bin/python scripts/plot_similarity.py [--trials 10] [--seed 200] [--after 1.5]

Writes ``docs/img/similarity.png`` and the ``similarity`` section of
``docs/generated/benchmarks_perception.md``.
"""

from __future__ import annotations

import argparse
import io
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from tqdm import tqdm

from neurocog_gym.bench.perception_scenes import Variant, load_now, walking_trial, write_section
from neurocog_gym.io import atomic_write_bytes
from neurocog_gym.perception.similarity import SimilarityTrace

VARIANTS = {"DD-GNG": Variant("ddgng"), "GNG": Variant("gng")}
COLOURS = {"DD-GNG": "#d62728", "GNG": "#1f77b4"}
PAPER = {"DD-GNG": 0.91, "GNG": 0.6}


def main(argv: list[str] | None = None) -> str:
    argv = sys.argv[1:] if argv is None else argv
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--trials", type=int, default=10)
    p.add_argument("--seed", type=int, default=200, help="first trial seed")
    p.add_argument("--after", type=float, default=1.5, help="s recorded after appearance")
    p.add_argument("--out", type=Path, default=Path("docs/img/similarity.png"))
    p.add_argument("--no-write", action="store_true")
    a = p.parse_args(argv)
    if a.trials < 1 or a.after <= 0:
        p.error("--trials must be >= 1 and --after > 0")
    load0 = load_now()
    t0 = time.perf_counter()
    curves = {k: [] for k in VARIANTS}
    summ = {k: [] for k in VARIANTS}
    t_axis = None
    for k in tqdm(range(a.trials), desc="walking trials"):
        r = walking_trial(a.seed + k, VARIANTS, after=a.after, with_similarity=True)
        for name in VARIANTS:
            arr = r.traces[name].arrays()
            tr = SimilarityTrace(t0=0.0)
            for t, v in zip(arr["t"], arr["similarity"], strict=True):
                tr.append(float(t), float(v))
            summ[name].append((tr.summary(0.5), tr.best_within(1.0)))
            curves[name].append(arr["similarity"])
            t_axis = arr["t"] if t_axis is None or len(arr["t"]) < len(t_axis) else t_axis
    elapsed = time.perf_counter() - t0
    n = len(t_axis)

    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    for name in VARIANTS:
        y = np.stack([c[:n] for c in curves[name]])
        ax.plot(t_axis, y.mean(0), color=COLOURS[name], label=f"{name} (mean of {a.trials})")
        ax.fill_between(
            t_axis,
            np.percentile(y, 25, 0),
            np.percentile(y, 75, 0),
            color=COLOURS[name],
            alpha=0.15,
        )
        ax.axhline(
            PAPER[name], color=COLOURS[name], ls=":", lw=1, label=f"paper, {name}: {PAPER[name]}"
        )
    ax.axvline(0.5, color="0.5", lw=0.6, ls="--")
    ax.set(xlabel="time after the obstacle appeared (s)", ylabel="surface similarity μ (Eq. 16)",
           ylim=(0, 1),
           title="Similarity of the nodes on the obstacle to its true surface")  # fmt: skip
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=120)
    plt.close(fig)
    atomic_write_bytes(a.out, buf.getvalue())
    print(f"wrote {a.out}")

    lines = [
        "### Surface similarity after an obstacle appears (scripts/plot_similarity.py)",
        "",
        f"Command: `.venv/bin/python scripts/plot_similarity.py {' '.join(argv)}`",
        f"Load average at start {load0}, at end {load_now()}; {elapsed:.0f} s. {a.trials} walking "
        "trials "
        f"(seeds {a.seed}–{a.seed + a.trials - 1}), {a.after:g} s after the block appeared. "
        "Attention nodes = "
        "the net's nodes within the block's footprint + 3 cm and higher than 2 cm (same rule for "
        "both nets); "
        "reference = the block's visible faces sampled every 1 cm; Eq. 16 with e_max^p = 2 cm, "
        "e_max^t = 45°. "
        "Mean over trials (min–max). Paper (§8): 0.91 (DD-GNG) vs 0.6. From about 1.2 s on the "
        "robot is "
        "close to or over the block and only a few nodes on it remain in view, so late values "
        "rest on few nodes.",
        "",
        "![similarity](../img/similarity.png)",
        "",
        "| net | best μ | time to best (s) | μ at 0.5 s | best μ within 0.5 s | best μ within 1 s "
        "|",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for name in VARIANTS:
        s = summ[name]

        def col(attr, fmt="{:.2f}", s=s):
            x = np.array([getattr(v, attr) if attr != "within1" else w for v, w in s], dtype=float)
            x = x[np.isfinite(x)]
            if len(x) == 0:
                return "–"
            return f"{fmt.format(x.mean())} ({fmt.format(x.min())}–{fmt.format(x.max())})"

        lines.append(
            f"| {name} | {col('best')} | {col('time_to_best')} | {col('at_half_second')} | "
            f"{col('best_within_half_second')} | {col('within1')} |"
        )
    text = "\n".join(lines) + "\n"
    print(text)
    if not a.no_write:
        write_section("similarity", text)
    return text


if __name__ == "__main__":
    main()
