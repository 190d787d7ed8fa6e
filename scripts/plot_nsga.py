"""Redraw Fig. 13 (fitness over generations) and Fig. 14 (CPG outputs) of an NSGA-II run folder.

Works on a finished run or on one still going (it reads ``history.jsonl``): Fig. 14 shows the
gait the selection rule picks from the last finished generation.

Usage: python scripts/plot_nsga.py DIR [--seconds S]
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from neurocog_gym.train.evaluate import GaitEvaluator
from neurocog_gym.train.nsga import choose_gait, read_history, read_run
from neurocog_gym.train.nsga_plots import plot_cpg_outputs, plot_fitness_history


@dataclass
class Args:
    out: Path
    seconds: float = 3.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path, help="run folder")
    ap.add_argument("--seconds", type=float, default=Args.seconds, help="Fig. 14 window, s")
    args = Args(**vars(ap.parse_args()))
    history = read_history(args.out)
    if not history:
        raise SystemExit(f"{args.out} has no finished generation yet")
    config, base_gait = read_run(args.out)
    plot_fitness_history(history, args.out / "fitness.png")
    last = history[-1]
    i = choose_gait(np.asarray(last["F"]), np.asarray(last["G"]), config.speed_tol)
    genes = np.asarray(last["X"][i])
    score, trace = GaitEvaluator(base_gait, config.eval).trace(genes, config.seed)
    plot_cpg_outputs(trace, args.out / "cpg.png", window=args.seconds)
    print(
        f"generation {last['generation']}: chosen speed {score.speed:.3f} m/s, "
        f"CoT {score.cost_of_transport:.2f}; wrote fitness.png and cpg.png in {args.out}"
    )


if __name__ == "__main__":
    main()
