"""Throughput of the NSGA-II gait evaluation: 1 vs N local workers, and evaluator vs raw mj_step.

Evaluates a fixed batch of chromosomes (small perturbations of the shipped default, seed 0, each
running the whole of Table 3's 10 s evaluation) ``--repeats`` times per worker count after a
warm-up batch, and prints a Markdown table of median evaluations per second and of CPU seconds
per evaluation. Then times one 10 s evaluation in this process and the part of it spent inside
``mujoco.mj_step``.

Usage: python scripts/bench_nsga.py [--workers 1 2] [--batch 16] [--repeats 5] [--seconds 10]
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time
from dataclasses import dataclass, field

import mujoco
import numpy as np

from neurocog_gym.locomotion.chromosome import GENE_LOWER, GENE_UPPER
from neurocog_gym.locomotion.gait import default_gait
from neurocog_gym.train.evaluate import (
    EvalParams,
    GaitEvaluator,
    _worker_evaluate,
    _worker_init,
)
from neurocog_gym.train.nsga import LocalPool, make_pool


@dataclass
class Args:
    workers: list[int] = field(default_factory=lambda: [1, 2])
    batch: int = 16
    repeats: int = 5
    seconds: float = 10.0


def batch(n: int) -> list[np.ndarray]:
    """Small perturbations of the shipped chromosome: they walk (or stand) the whole evaluation,
    the worst case for throughput (a diverging or falling chromosome ends early)."""
    rng = np.random.default_rng(0)
    base = default_gait().genes_array
    span = GENE_UPPER - GENE_LOWER
    return [np.clip(base + rng.normal(0, 0.02, 77) * span, GENE_LOWER, GENE_UPPER)
            for _ in range(n)]  # fmt: skip


def _timed_evaluate(genes: np.ndarray) -> float:
    """Worker task: CPU seconds of one evaluation (the tuner's worker state, see evaluate.py)."""
    c0 = time.process_time()
    _worker_evaluate(genes)
    return time.process_time() - c0


def throughput(workers: int, rows, params: EvalParams, repeats: int) -> tuple[list[float], float]:
    """Evaluations per second of each repeat, and median CPU seconds per evaluation."""
    pool = make_pool(workers, None, default_gait(), params, 0)
    try:
        pool(rows[: max(workers, 2)])  # warm-up: worker start, numba cache load
        rates = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            pool(rows)
            rates.append(len(rows) / (time.perf_counter() - t0))
        # CPU time per evaluation inside the workers: unlike wall time, it does not depend on
        # what else the (shared) machine runs, so it shows whether workers slow each other down.
        if isinstance(pool, LocalPool):
            cpu = list(pool._pool.map(_timed_evaluate, rows, chunksize=1))
        else:
            _worker_init(default_gait(), params, 0)
            cpu = [_timed_evaluate(x) for x in rows]
        return rates, statistics.median(cpu)
    finally:
        pool.close()


def evaluator_vs_mj_step(params: EvalParams, repeats: int) -> tuple[float, float]:
    """Median time of one evaluation, and the part of it spent inside ``mujoco.mj_step``."""
    ev = GaitEvaluator(params=params)
    genes = default_gait().genes_array
    ev.evaluate(genes, 0)
    raw_step = mujoco.mj_step
    spent = [0.0]

    def timed_step(*args, **kwargs):
        t0 = time.perf_counter()
        raw_step(*args, **kwargs)
        spent[0] += time.perf_counter() - t0

    t_eval, t_raw = [], []
    mujoco.mj_step = timed_step  # bench only: the evaluator looks it up on the module
    try:
        for _ in range(repeats):
            spent[0] = 0.0
            t0 = time.perf_counter()
            ev.evaluate(genes, 0)
            t_eval.append(time.perf_counter() - t0)
            t_raw.append(spent[0])
    finally:
        mujoco.mj_step = raw_step
    return statistics.median(t_eval), statistics.median(t_raw)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, nargs="+", default=Args().workers)
    ap.add_argument("--batch", type=int, default=Args.batch)
    ap.add_argument("--repeats", type=int, default=Args.repeats)
    ap.add_argument("--seconds", type=float, default=Args.seconds)
    args = Args(**vars(ap.parse_args()))
    params = EvalParams(seconds=args.seconds)
    rows = batch(args.batch)
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"load before {os.getloadavg()}")  # fmt: skip
    base = None
    print("| workers | median evals/s | min | max | speed-up | CPU s / eval (median) |")
    print("|---|---|---|---|---|---|")
    for w in args.workers:
        rates, cpu = throughput(w, rows, params, args.repeats)
        med = statistics.median(rates)
        base = base or med
        print(f"| {w} | {med:.2f} | {min(rates):.2f} | {max(rates):.2f} | {med / base:.2f}x "
              f"| {cpu:.3f} |")  # fmt: skip
    t_eval, t_raw = evaluator_vs_mj_step(params, args.repeats)
    print(f"\none {args.seconds:g} s evaluation (default gait): {t_eval * 1e3:.0f} ms, "
          f"of it inside mj_step: {t_raw * 1e3:.0f} ms "
          f"(overhead outside mj_step {100 * (t_eval / t_raw - 1):.0f} %)")  # fmt: skip
    print(f"load after {os.getloadavg()}")


if __name__ == "__main__":
    main()
