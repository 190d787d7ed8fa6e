"""Loop-closed attention timing: how fast the attention reacts to a newly appeared obstacle.

The walking trial of ``fig9_density.py`` (``neurocog_gym.bench.perception_scenes.walking_trial``):
the robot trots in ``NeuroCog/Walk-v3``, a paper-sized block appears 0.7–0.9 m ahead, the four ToF
sensors run at 45 fps and the attention pipeline (DD-GNG → affordance → suspected boxes → DD-GNG) is
in the loop. Four pipelines see the same frames: DD-GNG and GNG, each either stepped every 0.01 s
control cycle on the latest frame (what ``envs/obstacle.py`` does) or once per new frame. Times
after the block appeared (s), per trial:

* **detected**: first cycle with an object (suspected or not) overlapping the block;
* **attended**: first cycle with an attention box over the block in the pipeline's memory;
* **rise**: first cycle whose node count in the obstacle region (footprint + 3 cm) exceeds the
  count at the appearance by at least ``--rise`` nodes — "the attention raises the node count";
* **confirmed**: first cycle with a confirmed object (density d > v, Eq. 4) on the block;
* **accurate**: first cycle whose object on the block has height within ±1 cm and width and
  length within ±2 cm of the truth (the §6.2 "accurate affordance").

    .venv/bin/python scripts/attention_timing.py [--trials 20] [--seed 100]

Writes the ``timing`` section of ``docs/generated/benchmarks_perception.md``.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import dataclass

import numpy as np
from tqdm import tqdm

from neurocog_gym.bench.perception_scenes import Variant, load_now, walking_trial, write_section

VARIANTS = {
    "DD-GNG, every control cycle": Variant("ddgng"),
    "GNG, every control cycle": Variant("gng"),
    "DD-GNG, once per frame": Variant("ddgng", per_frame=True),
    "GNG, once per frame": Variant("gng", per_frame=True),
    "DD-GNG, every control cycle, sizes from the graph only": Variant("ddgng", refine=False),
    "GNG, every control cycle, sizes from the graph only": Variant("gng", refine=False),
}
EVENTS = ("detected", "attended", "rise", "confirmed", "accurate")
TARGET = 0.2


@dataclass(frozen=True)
class Args:
    """Command-line options."""

    trials: int = 20
    seed: int = 100
    rise: int = 3
    after: float = 1.0
    write: bool = True


def first_time(t: np.ndarray, mask: np.ndarray) -> float:
    """Time of the first True sample, or inf."""
    i = np.flatnonzero(mask)
    return float(t[i[0]]) if len(i) else math.inf


def events(a: dict[str, np.ndarray], rise: int) -> dict[str, float]:
    """The event times of one trace (see the module docstring)."""
    t = a["t"]
    acc = (np.abs(a["err_h"]) <= 0.01) & (np.abs(a["err_w"]) <= 0.02) & (np.abs(a["err_l"]) <= 0.02)
    return {
        "detected": first_time(t, a["detected"]),
        "attended": first_time(t, a["attended"]),
        "rise": first_time(t, a["n_region"] >= a["n_region"][0] + rise),
        "confirmed": first_time(t, a["confirmed"]),
        "accurate": first_time(t, np.nan_to_num(acc, nan=False).astype(bool)),
    }


def summarise(times: list[float], horizon: float) -> str:
    x = np.array(times)
    hit = np.isfinite(x)
    med = np.median(x) if hit.mean() > 0.5 else math.inf
    med_s = f"{med:.2f}" if np.isfinite(med) else f"> {horizon:g}"
    within = (x <= TARGET + 1e-9).mean()
    return f"{med_s} / {within:.0%} / {hit.mean():.0%}"


def main(argv: list[str] | None = None) -> str:
    argv = sys.argv[1:] if argv is None else argv
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--trials", type=int, default=Args.trials)
    p.add_argument("--seed", type=int, default=Args.seed, help="first trial seed")
    p.add_argument(
        "--rise", type=int, default=Args.rise, help="nodes above the count at appearance"
    )
    p.add_argument("--after", type=float, default=Args.after, help="s recorded after appearance")
    p.add_argument("--no-write", action="store_true")
    a = p.parse_args(argv)
    if a.trials < 1 or a.rise < 1 or a.after <= 0:
        p.error("--trials, --rise must be >= 1 and --after > 0")
    args = Args(a.trials, a.seed, a.rise, a.after, not a.no_write)
    load0 = load_now()
    t0 = time.perf_counter()
    per = {name: {e: [] for e in EVENTS} for name in VARIANTS}
    for k in tqdm(range(args.trials), desc="walking trials"):
        r = walking_trial(args.seed + k, VARIANTS, after=args.after)
        for name in VARIANTS:
            ev = events(r.traces[name].arrays(), args.rise)
            for e in EVENTS:
                per[name][e].append(ev[e])
    elapsed = time.perf_counter() - t0
    lines = [
        "### Loop-closed attention timing (scripts/attention_timing.py)",
        "",
        f"Command: `.venv/bin/python scripts/attention_timing.py {' '.join(argv)}`",
        f"Load average at start {load0}, at end {load_now()}; {elapsed:.0f} s. {args.trials} "
        "walking trials "
        f"(seeds {args.seed}–{args.seed + args.trials - 1}); the paper's blocks (6–8 cm high) "
        "appear 0.7–0.9 m "
        "ahead of the trotting robot after 1.5 s; ToF 45 fps; Table 2 parameters. Each cell: "
        "median time after "
        f"the block appeared (s) / share of trials within {TARGET:g} s / share in which it "
        "happened within "
        f"{args.after:g} s. *rise* = ≥ {args.rise} more nodes in the obstacle region than at the "
        "appearance. "
        "Target (issue 4): the attention raises the node count on the new obstacle within 0.2 s; "
        "the paper "
        "(§6.2): first non-homogeneous nodes after about 0.1 s, an accurate affordance 0.11 s "
        "later.",
        "",
        "| pipeline | " + " | ".join(EVENTS) + " |",
        "|---|" + "---:|" * len(EVENTS),
    ]
    for name in VARIANTS:
        lines.append(
            f"| {name} | " + " | ".join(summarise(per[name][e], args.after) for e in EVENTS) + " |"
        )
    text = "\n".join(lines) + "\n"
    print(text)
    if args.write:
        write_section("timing", text)
    return text


if __name__ == "__main__":
    main()
