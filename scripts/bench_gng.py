"""Benchmark DD-GNG, GNG, ML-GNG and the NumPy oracle (paper §7.1; SPEC §3).

Prints a markdown table and writes it, with the command line and the machine, to
``docs/generated/benchmarks_gng.md``. All timings are wall-clock medians of single calls on one
core, each call on a different full-resolution frame (154,112 points) from a pool of frames.

    .venv/bin/python scripts/bench_gng.py            # full run (~10 min)
    .venv/bin/python scripts/bench_gng.py --quick    # smoke run (~1 min)
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numba import njit

from neurocog_gym.bench.machine import cpu_model
from neurocog_gym.perception import _gng_kernels as K
from neurocog_gym.perception.gng import DDGNG, GNG, MLGNG, DDGNGParams, _check_boxes
from neurocog_gym.perception.gng_oracle import DDGNGOracle

N_POINTS = 4 * 224 * 172  # 154,112: four 224 x 172 ToF sensors (SPEC §2)
BOX_LO = np.array([1.4, -0.1, 0.0])
BOX_SIZE = 0.2
ATT_BOX = np.array([[[1.38, -0.12, 0.01], [1.62, 0.12, 0.22]]])
AREA_BOX = 5 * BOX_SIZE**2
AREA_FLOOR = 6.0 - BOX_SIZE**2
SENSOR = np.array([-0.5, 0.0, 0.6])


@dataclass(frozen=True)
class Args:
    """Command-line options."""

    quick: bool = False
    frames: int = 12
    repeats: int = 2000
    out: str = "docs/generated/benchmarks_gng.md"


def floor_and_box(n: int, seed: int) -> np.ndarray:
    """(n, 3) float64: a 3 m x 2 m floor (z ~ 0, 2 mm noise) and the 5 faces of a 0.2 m cube.

    Uniform per area (3.2 % of the points on the cube), in random order.
    """
    rng = np.random.default_rng(seed)
    nb = int(round(n * AREA_BOX / (AREA_FLOOR + AREA_BOX)))
    nf = n - nb
    fl = np.c_[rng.uniform(0, 3, 2 * nf), rng.uniform(-1, 1, 2 * nf), rng.normal(0, 0.002, 2 * nf)]
    on_box = (
        (fl[:, 0] > BOX_LO[0]) & (fl[:, 0] < BOX_LO[0] + BOX_SIZE)
        & (fl[:, 1] > BOX_LO[1]) & (fl[:, 1] < BOX_LO[1] + BOX_SIZE)
    )  # fmt: skip
    fl = fl[~on_box][:nf]
    face = rng.integers(0, 5, nb)
    u, v = rng.uniform(0, BOX_SIZE, (2, nb))
    z0, z1 = np.zeros(nb), np.full(nb, BOX_SIZE)
    faces = [(u, v, z1), (z0, u, v), (z1, u, v), (u, z0, v), (u, z1, v)]
    bx = np.empty((nb, 3))
    for f, (x, y, z) in enumerate(faces):
        m = face == f
        bx[m] = np.c_[x[m], y[m], z[m]] + BOX_LO
    pts = np.vstack([fl, bx])
    rng.shuffle(pts)
    return pts


def raster_order(pts: np.ndarray) -> np.ndarray:
    """Reorder a cloud as a depth sensor delivers it: rows of elevation, then azimuth."""
    d = pts - SENSOR
    az = np.arctan2(d[:, 1], d[:, 0])
    el = np.arctan2(d[:, 2], np.hypot(d[:, 0], d[:, 1]))
    row = np.floor((el - el.min()) / (np.ptp(el) + 1e-12) * 172).astype(np.int64)
    return np.ascontiguousarray(pts[np.lexsort((az, row))])


def box_floor_counts(nodes: np.ndarray) -> tuple[int, int]:
    inside = ((nodes > ATT_BOX[0, 0]) & (nodes < ATT_BOX[0, 1])).all(axis=1)
    return int(inside.sum()), int((~inside).sum())


def time_updates(net, frames, boxes, repeats: int) -> tuple[float, float, float]:
    """Median, 10th and 90th percentile seconds of ``net.update`` over ``repeats`` calls."""
    ts = np.empty(repeats)
    nf = len(frames)
    for r in range(repeats):
        f = frames[r % nf]
        t0 = time.perf_counter()
        net.update(f, boxes)
        ts[r] = time.perf_counter() - t0
    return float(np.median(ts)), float(np.percentile(ts, 10)), float(np.percentile(ts, 90))


def converge(net, frames, boxes, cycles: int) -> None:
    for c in range(cycles):
        net.update(frames[c % len(frames)], boxes)


def oracle_from(net: DDGNG) -> DDGNGOracle:
    """An oracle holding exactly the kernel net's current state (to time it at equal size)."""
    s = net._net
    o = DDGNGOracle(seed=0, params=net.params, attention=net._attention)
    alive = s.inode[K.N_ALIVE] != 0
    o.pos[:] = s.pos
    o.E[:] = s.fnode[K.R_E] * s.fsc[K.F_SE]
    o.U[:] = s.fnode[K.R_U] * s.fsc[K.F_SU]
    o.delta[:] = s.fnode[K.R_D]
    o.alive[:] = alive
    for i in np.flatnonzero(alive):
        for k in range(s.inode[K.N_DEG, i]):
            o.age[i, s.adj[K.A_NBR, i, k]] = s.adj[K.A_AGE, i, k]
    o.t = int(s.isc[K.I_T])
    o.state = int(s.isc[K.I_RNG]) & ((1 << 64) - 1)
    return o


@njit
def _calibration_kernel(V, P):
    # fixed reference work: brute-force nearest-two of 300 inputs among 200 nodes
    s = 0
    for k in range(V.shape[0]):
        b1 = b2 = -1
        d1 = d2 = np.inf
        for i in range(P.shape[0]):
            dx = V[k, 0] - P[i, 0]
            dy = V[k, 1] - P[i, 1]
            dz = V[k, 2] - P[i, 2]
            d = dx * dx + dy * dy + dz * dz
            if d < d1:
                b2, d2, b1, d1 = b1, d1, i, d
            elif d < d2:
                b2, d2 = i, d
        s += b1 + b2
    return s


def calibration(reps: int) -> float:
    """Median seconds of a fixed numba workload, to gauge how loaded the machine is."""
    rng = np.random.default_rng(0)
    V, P = rng.random((300, 3)), rng.random((200, 3))
    _calibration_kernel(V, P)
    ts = []
    for _ in range(reps):
        t0 = time.perf_counter()
        _calibration_kernel(V, P)
        ts.append(time.perf_counter() - t0)
    return float(np.median(ts))


def main(args: Args) -> str:
    reps = 200 if args.quick else args.repeats
    nfr = 4 if args.quick else args.frames
    print(f"building {nfr} frames of {N_POINTS} points ...", flush=True)
    frames = [floor_and_box(N_POINTS, s) for s in range(nfr)]
    raster = [raster_order(f) for f in frames]
    load0 = os.getloadavg()
    cal0 = calibration(200)
    rows: list[tuple[str, str, str, str]] = []
    notes: list[str] = []

    def row(name, nodes, t, extra=""):
        med, p10, p90 = t
        rows.append((name, nodes, f"{med * 1e3:.4f} ({p10 * 1e3:.3f}–{p90 * 1e3:.3f})", extra))
        print(f"{name:58s} {nodes:>6s} {med * 1e3:8.4f} ms  {extra}", flush=True)

    # ---- DD-GNG at ~137 (Table 2 exactly), ~200, ~300, ~500 nodes -------------------------
    # Table 2's utility test holds DD-GNG at ~137 nodes on this cloud whatever max_nodes is;
    # larger nets are held by raising k (fewer utility removals) with max_nodes as the cap.
    configs = [("Table 2 (k = 1e3)", 1e3, 300), ("k = 1e4", 1e4, 220), ("k = 1e6", 1e6, 320)]
    configs.append(("k = 1e12", 1e12, 500))
    dd_ref = None
    for label, k, cap in configs:
        p = DDGNGParams(k=k, max_nodes=cap)
        net = DDGNG(seed=0, params=p)
        converge(net, frames, ATT_BOX, (400 if args.quick else 1200) + cap)
        n0 = net.n_nodes
        t = time_updates(net, frames, ATT_BOX, reps)
        row(f"DD-GNG, box given, {label}, max_nodes {cap}", f"{n0}–{net.n_nodes}", t)
        if k == 1e4:
            dd_ref = (net, t)
            tr = time_updates(net, raster, ATT_BOX, reps)
            row(f"DD-GNG, box given, {label}, sensor-ordered frames", f"{net.n_nodes}", tr)
            tn = time_updates(net, frames, None, reps)
            row(f"DD-GNG, no box, {label}", f"{net.n_nodes}", tn)

    # ---- GNG and ML-GNG on the same input ------------------------------------------------
    p = DDGNGParams(k=1e4, max_nodes=220)
    g = GNG(seed=0, params=p)
    converge(g, frames, ATT_BOX, 1420 if not args.quick else 620)
    row(
        "GNG, same input, k = 1e4, max_nodes 220",
        f"{g.n_nodes}",
        time_updates(g, frames, ATT_BOX, reps),
    )
    ml = MLGNG(seed=0, params=p, n_layers=3)
    converge(ml, frames, ATT_BOX, 1420 if not args.quick else 620)
    sizes = "/".join(str(ml.layer(i)[0].shape[0]) for i in range(3))
    tml = time_updates(ml, frames, ATT_BOX, reps)
    row("ML-GNG (3 layers), same input, k = 1e4, max_nodes 220", sizes, tml)
    if dd_ref is not None:
        notes.append(
            f"ML-GNG / DD-GNG time ratio at ~200 nodes: {tml[0] / dd_ref[1][0]:.2f} "
            "(target ≥ 3; paper 3.08)"
        )
        notes.append(
            f"DD-GNG cycle at ~200 nodes with the box: median {dd_ref[1][0] * 1e3:.4f} ms, "
            f"10th percentile {dd_ref[1][1] * 1e3:.4f} ms (target ≤ 0.10 ms; paper 0.10255 ms)"
        )

    # ---- the NumPy oracle, on a copy of the ~200-node DD-GNG -------------------------------
    if dd_ref is not None:
        o = oracle_from(dd_ref[0])
        to = time_updates(o, frames, ATT_BOX, 3 if args.quick else 10)
        row("NumPy oracle (gng_oracle), same net and input", f"{dd_ref[0].n_nodes}", to)
        notes.append(f"oracle / DD-GNG time ratio: {to[0] / dd_ref[1][0]:.0f}")

    # ---- finding box points at full resolution -------------------------------------------
    net = DDGNG(seed=1)
    s = net._net
    bx = _check_boxes(ATT_BOX)
    for name, fr in (("random-order", frames), ("sensor-order", raster)):
        ts = np.empty(reps)
        hits = 0
        for r in range(reps):
            t0 = time.perf_counter()
            hits += K.fill_box_pool(fr[r % nfr], bx, 1, s.ibuf, s.fsc, s.isc)
            ts[r] = time.perf_counter() - t0
        med = float(np.median(ts))
        rows.append(
            (f"find box points ({name} frame)", f"{hits / reps:.0f} pts", f"{med * 1e3:.4f}", "")
        )
        print(
            f"find box points, {name}: {med * 1e3:.4f} ms for {hits / reps:.0f} points", flush=True
        )
    ts = []
    for r in range(50 if args.quick else 200):
        f = frames[r % nfr]
        t0 = time.perf_counter()
        m = ((f > ATT_BOX[0, 0]) & (f < ATT_BOX[0, 1])).all(axis=1)
        np.flatnonzero(m)
        ts.append(time.perf_counter() - t0)
    rows.append(("(reference: NumPy full-frame box mask)", "all", f"{np.median(ts) * 1e3:.4f}", ""))

    # ---- attention: density on the obstacle, DD-GNG vs GNG --------------------------------
    cycles = 800 if args.quick else 2000
    res = []
    for seed in range(1 if args.quick else 3):
        dd, gg = DDGNG(seed=seed), GNG(seed=seed)
        converge(dd, frames, ATT_BOX, cycles)
        converge(gg, frames, ATT_BOX, cycles)
        b, f = box_floor_counts(dd.nodes)
        bg, fg = box_floor_counts(gg.nodes)
        res.append(((b / AREA_BOX) / (f / AREA_FLOOR), b, bg, dd.n_nodes, gg.n_nodes))
    res = np.array(res)
    att = (
        f"Attention (Table 2 parameters, max_nodes 300, {cycles} cycles, {len(res)} seeds): "
        f"DD-GNG nodes per m² on the obstacle / on the floor = "
        f"{', '.join(f'{r:.1f}' for r in res[:, 0])} (target ≥ 5); "
        f"nodes on the obstacle DD-GNG vs GNG = "
        f"{', '.join(f'{int(a)} vs {int(b)}' for a, b in res[:, 1:3])} "
        f"(ratio {', '.join(f'{a / max(b, 1):.1f}' for a, b in res[:, 1:3])}; target ≥ 3); "
        f"total nodes DD-GNG {', '.join(str(int(x)) for x in res[:, 3])}, "
        f"GNG {', '.join(str(int(x)) for x in res[:, 4])}."
    )
    notes.append(att)
    print(att)
    load1 = os.getloadavg()
    cal1 = calibration(200)

    cmd = "PYTHONPATH=. .venv/bin/python " + " ".join(sys.argv)
    lines = [
        "## DD-GNG perception stage (scripts/bench_gng.py)",
        "",
        f"Command: `{cmd}`  ",
        f"Machine: {platform.platform()}, {cpu_model()}, {os.cpu_count()} logical CPUs, "
        f"Python {platform.python_version()}, NumPy {np.__version__}.  ",
        f"Load average (1/5/15 min) at start {load0[0]:.2f}/{load0[1]:.2f}/{load0[2]:.2f}, "
        f"at end {load1[0]:.2f}/{load1[1]:.2f}/{load1[2]:.2f} (the machine is shared).  ",
        f"Calibration (fixed numba work: 300 brute-force nearest-two searches among 200 "
        f"nodes): {cal0 * 1e3:.3f} ms at start, {cal1 * 1e3:.3f} ms at end; it scales with "
        "the contention the timings below saw.",
        "",
        "One learning cycle = one `update()` call: λ = 300 input signals, with the attention box "
        f"given unless stated, on a new {N_POINTS:,}-point frame each call (a pool of {nfr} "
        "synthetic frames: 3 m × 2 m floor + 0.2 m cube, 3.2 % of the points on the cube, "
        "random point order unless 'sensor-ordered'). Median (10th–90th percentile) of "
        f"{reps} calls, wall clock, one core. Paper (§7.1): DD-GNG 0.10255 ms, ML-GNG 0.31567 ms.",
        "",
        "| what | nodes | ms per cycle / call | |",
        "|---|---|---|---|",
    ]
    lines += [f"| {a} | {b} | {c} | {d} |" for a, b, c, d in rows]
    lines += [""] + [f"- {n}" for n in notes] + [""]
    lines += [
        "Reading the numbers:",
        "",
        "- Node counts: Table 2's utility test holds DD-GNG at ~140 nodes on this cloud "
        "(GNG ~200) whatever `max_nodes` is; the ~200/~300/~500-node rows raise k so the net "
        "grows to its cap. The per-cycle cost hardly depends on the node count (grid search).",
        "- The calibration row measures contention: on a quiet moment it runs in ~0.10 ms, so "
        "timings taken at a higher calibration value are inflated by about that ratio.",
        "- ML-GNG is read as three independent GNG-U2 layers (55/110/220 nodes, utility "
        "thresholds k/100, k/10, k) each learning λ inputs of the same frame; its cost is ~3 GNG "
        "cycles. DD-GNG's attention adds ~50 % to a GNG cycle (finding box points, denser search"
        " near the box), so the ratio lands near 2, not the paper's 3.08; the paper's GNG cost "
        "grows with the node count, ours does not.",
        "",
    ]
    text = "\n".join(lines)
    print()
    print(text)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    from neurocog_gym.io import atomic_write_text

    atomic_write_text(out, text)
    return text


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small smoke run")
    ap.add_argument("--frames", type=int, default=Args.frames, help="distinct frames cycled")
    ap.add_argument("--repeats", type=int, default=Args.repeats, help="timed calls per row")
    ap.add_argument("--out", default=Args.out, help="markdown output file")
    main(Args(**vars(ap.parse_args())))
