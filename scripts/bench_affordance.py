"""Benchmark: affordance detection time per call (§7.2: ~0.136 ms), at 150 / 300 / 500 nodes.

Graphs are GNG-like meshes of a synthetic floor with a 20 × 20 × 7 cm block
(``synthetic_scene_graph``: jittered lattice, a random diagonal in 70 % of the quads, the rest
left as quads for the detector to close; ~2.6 edges per node). Several graphs per size (different
seeds); calls are interleaved across sizes and graphs so that load from other processes spreads
evenly. Reports medians (and p10/p90) of the wall time of

- ``detect_affordances`` (the public call: validation, kernel, result objects),
- ``detect_kernel`` (the compiled part alone),
- ``triangulate_graph`` (neighbour lists, triangles, quad diagonals, edge-to-facet table).

Writes a markdown table (with command, machine and load) to ``--out``.

    .venv/bin/python scripts/bench_affordance.py [--sizes 150 300 500] [--repeats 3000]
"""

from __future__ import annotations

import argparse
import datetime
import os
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from neurocog_gym.bench.machine import machine
from neurocog_gym.perception import _affordance_kernels as _k
from neurocog_gym.perception.affordance import (
    DEFAULT_PARAMS,
    SyntheticScene,
    detect_affordances,
    synthetic_scene_graph,
)

TARGET_US = 136.0
"""§7.2: "10 times faster than the 1.36 ms of [63]"."""

NOTES = """\
Notes (2026-11-22, while writing the detector). With the cores less busy the kernel took about
100 µs at 300 nodes (fastest 5 % of calls, read with the CPU cycle counter: quads 21 %, neighbour
lists 12 %, triangles 11 %, facet geometry 11 %, label statistics 11 %, facet links 10 %, region
growing 9 %), and the Python wrapper adds 15-20 µs: about at the target on an idle core, 2-3
times over it with both hyper-threads busy (the median above). Tried, in order: triangles
enumerated over forward (higher-index) neighbour rows only; quads searched over edges with at
most one facet only; no helper calls with array arguments and no array re-binding inside hot
loops (numba refcounts those with atomic operations: triangulation went from ~290 to ~80 µs at
400 nodes); int32 index arrays; result objects as NamedTuples and parameters packed once (the
Python wrapper from ~45 to ~20 µs). No gain: `error_model="numpy"` with fastmath
`arcp`/`contract`, int32 per-facet arrays.
"""


@dataclass
class Args:
    sizes: list[int] = field(default_factory=lambda: [150, 300, 500])
    repeats: int = 3000
    graphs: int = 5
    out: Path = Path("docs/generated/benchmarks_affordance.md")


def parse(argv: list[str] | None = None) -> Args:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", type=int, nargs="+", default=[150, 300, 500], help="node counts")
    p.add_argument("--repeats", type=int, default=3000, help="timed calls per size")
    p.add_argument("--graphs", type=int, default=5, help="graphs (seeds) per size")
    p.add_argument("--out", type=Path, default=Path("docs/generated/benchmarks_affordance.md"))
    a = p.parse_args(argv)
    if a.repeats < 1 or a.graphs < 1 or min(a.sizes) < 10:
        p.error("need --repeats >= 1, --graphs >= 1 and sizes >= 10")
    return Args(sizes=a.sizes, repeats=a.repeats, graphs=a.graphs, out=a.out)


def scene_with_nodes(target: int, seed: int) -> SyntheticScene:
    """Floor + block graph with about ``target`` nodes (within 2 %).

    The lattice spacing is found by bisection; the node count moves in steps of a lattice row,
    so the floor width is varied too until the count is within 2 % of the target.
    """
    best = None
    for width in (1.0, 0.95, 1.05, 0.9, 1.1, 0.85, 1.15, 0.8, 1.2):
        lo, hi = 0.01, 0.5
        for _ in range(18):
            mid = float(np.sqrt(lo * hi))
            scene = synthetic_scene_graph(
                mid, wall_x=None, floor_x=(0.2, 1.2), floor_y=(-width / 2, width / 2), seed=seed
            )
            n = len(scene.nodes)
            if best is None or abs(n - target) < abs(len(best.nodes) - target):
                best = scene
            if n == target:
                break
            lo, hi = (mid, hi) if n > target else (lo, mid)
        if abs(len(best.nodes) - target) <= 0.02 * target:
            break
    return best


def main(argv: list[str] | None = None) -> None:
    args = parse(argv)
    prm = DEFAULT_PARAMS.packed
    cases = []
    for size in args.sizes:
        for g in range(args.graphs):
            sc = scene_with_nodes(size, seed=g)
            res = detect_affordances(sc.nodes, sc.edges, sc.sensor_origin)  # compiles once
            kernel_args = (sc.nodes, sc.edges, sc.sensor_origin, 1.0, 0.0, 0.0, 0, prm)
            tri_args = (sc.nodes, sc.edges, sc.sensor_origin, False, 16384, 1e-3)
            _k.detect_kernel(*kernel_args)
            _k.triangulate_graph(*tri_args)
            cases.append((size, sc, res, kernel_args, tri_args))
    per_graph = max(1, args.repeats // args.graphs)
    times = {c: {s: [] for s in args.sizes} for c in ("full", "kernel", "tri")}
    load0 = os.getloadavg()
    t_start = time.perf_counter()
    clock = time.perf_counter_ns
    for _ in range(per_graph):
        for size, sc, _res, kernel_args, tri_args in cases:
            t0 = clock()
            detect_affordances(sc.nodes, sc.edges, sc.sensor_origin)
            t1 = clock()
            _k.detect_kernel(*kernel_args)
            t2 = clock()
            _k.triangulate_graph(*tri_args)
            t3 = clock()
            times["full"][size].append(t1 - t0)
            times["kernel"][size].append(t2 - t1)
            times["tri"][size].append(t3 - t2)
    elapsed = time.perf_counter() - t_start
    load1 = os.getloadavg()

    def us(xs: list[int], q: float) -> float:
        return float(np.percentile(np.asarray(xs) / 1e3, q))

    rows = [
        "| nodes (target) | nodes | edges | facets | detect median (µs) | min | p10 | p90 "
        "| kernel median (µs) "
        "| triangulation median (µs) | target (µs) |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for size in args.sizes:
        mine = [c for c in cases if c[0] == size]
        n = np.mean([len(c[1].nodes) for c in mine])
        m = np.mean([len(c[1].edges) for c in mine])
        f = np.mean([len(c[2].facets) for c in mine])
        full = times["full"][size]
        rows.append(
            f"| {size} | {n:.0f} | {m:.0f} | {f:.0f} | {us(full, 50):.1f} | {us(full, 0):.1f} "
            f"| {us(full, 10):.1f} "
            f"| {us(full, 90):.1f} | {us(times['kernel'][size], 50):.1f} "
            f"| {us(times['tri'][size], 50):.1f} | {TARGET_US:.0f} |"
        )
    cmd = " ".join([".venv/bin/python", *sys.argv])
    text = "\n".join(
        [
            "## Affordance detection speed (§7.2)",
            "",
            f"Command: `{cmd}`  ",
            f"Machine: {machine('numpy', 'numba')}  ",
            f"Date: {datetime.datetime.now(datetime.timezone.utc).isoformat(timespec='seconds')}; "
            f"load average {load0[0]:.2f} before, {load1[0]:.2f} after "
            f"({elapsed:.0f} s of timing; the cores are shared).",
            "",
            f"{args.graphs} GNG-like floor + block graphs per size, {per_graph} calls each, "
            "interleaved; wall time per call. *detect*: `detect_affordances` (validation, "
            "compiled kernel, result objects); *kernel*: the compiled call alone; "
            "*triangulation*: neighbour lists + triangles + quad diagonals + edge-to-facet table. "
            f"Paper target: {TARGET_US:.0f} µs per detection. *min* is the best call, close to "
            "what an idle core gives; the median includes the slowdown from other processes "
            "sharing the two cores (hyper-threads).",
            "",
            *rows,
            "",
            NOTES,
        ]
    )
    print(text)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    from neurocog_gym.io import atomic_write_text

    atomic_write_text(args.out, text)


if __name__ == "__main__":
    main()
