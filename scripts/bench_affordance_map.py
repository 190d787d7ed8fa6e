"""Affordance sizes read from the topological map alone ("map" mode) on floor + box + wall scenes.

Issue 23, items 2 and 3 (perception side). The scenes are those of
``scripts/bench_affordance_accuracy.py`` (``perception_scenes.box_wall_scene``, series
``--seed``): the robot stands in its home pose, its four ToF sensors see a floor, a
box (4–10 cm high, 10–30 cm wide and long, any yaw, 0.35–0.85 m ahead, ≥ 30 rays on it) and
a 2 m × 0.5 m wall 0.3–0.55 m behind the box. Protocol per scene and pipeline:

1. the wall alone for ``--warmup`` s (the map converges);
2. the box appears; ``--sense`` s (≤ 0.5 s) of sensing at the sensor rate, one pipeline step
   (one learning cycle + affordance detection, attention loop closed) per 0.01 s control cycle
   on the latest frame;
3. at the end, the object on the box (the object overlapping the box's footprint with the
   most nodes) against the truth: height within ±1 cm, width and length (across and along the
   robot's heading) within ±2 cm; the wall counts as classified when a wall label overlaps it
   and no object does (scenes with ≥ 30 rays on the wall only).

Latency, on the same runs, from the box's appearance: to the *first non-homogeneous nodes*
(a node within 5 cm of the box's footprint on a facet tilted more than 20° from the vertical,
§6.2, ``perception_scenes.nonhomogeneous_on``) and to the first *accurate affordance* (the
object on the box with its height within 1 cm and its length within 2 cm). Pipelines:
DD-GNG, GNG (no attention) and ML-GNG in "map" mode, and DD-GNG in "points" mode (the
raw-point refinement) for reference.

    .venv/bin/python scripts/bench_affordance_map.py            # 100 scenes
    .venv/bin/python scripts/bench_affordance_map.py --quick    # 5 scenes, no file written

Writes ``docs/generated/benchmarks_affordance_map.md`` (``--out``).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from neurocog_gym.bench.machine import machine
from neurocog_gym.bench.perception_scenes import (
    StaticScene,
    box_wall_scene,
    boxes_overlap,
    extents,
    load_now,
    nonhomogeneous_on,
    object_on,
)
from neurocog_gym.io import atomic_write_text
from neurocog_gym.perception import AttentionPipeline, PipelineParams
from neurocog_gym.robot.tof import ToFParams

TOL_H, TOL_WL = 0.01, 0.02
"""m: the accuracy of issue 23 (height ±1 cm, width and length ±2 cm)."""

PIPELINES = {
    "DD-GNG, map": ("ddgng", "map"),
    "GNG, map": ("gng", "map"),
    "ML-GNG, map": ("mlgng", "map"),
    "DD-GNG, points": ("ddgng", "points"),
}
"""Row name -> (PipelineParams.gng, affordance_source)."""


@dataclass(frozen=True)
class Args:
    """Command-line options."""

    scenes: int = 100
    seed: int = 0
    warmup: float = 1.5
    sense: float = 0.5
    noise: float = 0.0
    scale: float = 0.25
    min_box_points: int = 30
    pipelines: tuple[str, ...] = tuple(PIPELINES)
    out: str = "docs/generated/benchmarks_affordance_map.md"
    write: bool = True


@dataclass
class Run:
    """One pipeline on one scene."""

    found: bool
    dh: float
    dw: float
    dl: float
    wall_seen: bool
    wall_ok: bool
    t_nonhom: float
    """s from the box's appearance to the first non-homogeneous node on it (inf: never)."""
    t_accurate: float
    """s from the box's appearance to the first accurate affordance (inf: never)."""

    @property
    def ok(self) -> bool:
        """All three sizes within the tolerances at the end."""
        return (
            self.found
            and abs(self.dh) <= TOL_H
            and abs(self.dw) <= TOL_WL
            and (abs(self.dl) <= TOL_WL)
        )


def run_one(scene: StaticScene, args: Args, i: int, gng: str, source: str) -> Run:
    """Scene ``i`` of series ``args.seed`` with one pipeline."""
    sc = box_wall_scene(scene, args.seed, i, args.min_box_points)
    box, wall = sc.box, sc.wall
    scene.sensors.reset(seed=sc.tof_seed)
    pipe = AttentionPipeline(seed=sc.seed, params=PipelineParams(gng=gng), affordance_source=source)
    max_tilt = pipe.affordance_params.terrain_max_tilt  # the detector's own (20°)
    scene.place([wall])
    t = scene.run(pipe, args.warmup, 0.0)
    scene.place([box, wall])
    appeared = t
    w_true, l_true = extents(box, scene.forward)
    first = {"nonhom": math.inf, "accurate": math.inf}

    def on_cycle(tc, _frame, aff):
        dt = tc - appeared
        if first["nonhom"] == math.inf and nonhomogeneous_on(box, pipe.net.nodes, aff, max_tilt):
            first["nonhom"] = dt
        if first["accurate"] == math.inf:
            o = object_on(aff, box)
            if (
                o is not None
                and abs(o.height - box.height) <= TOL_H
                and (abs(o.length - l_true) <= TOL_WL)
            ):
                first["accurate"] = dt

    scene.run(pipe, args.sense, t, on_cycle=on_cycle)
    aff = pipe.last
    wall_seen = int((scene.last_frame.geom == scene.pool.geoms[1]).sum()) >= args.min_box_points
    wall_box = wall.aabb() + np.array([[-0.05, -0.05, 0.0], [0.05, 0.05, 0.0]])
    wall_ok = any(o.kind == "wall" and boxes_overlap(o.box, wall_box) for o in aff.objects) and (
        not any(
            boxes_overlap(o.box, wall_box) and not boxes_overlap(o.box, box.aabb())
            for o in aff.obstacles
        )
    )
    o = object_on(aff, box)
    nan = math.nan
    dh, dw, dl = (
        (nan, nan, nan)
        if o is None
        else (o.height - box.height, o.width - w_true, o.length - l_true)
    )
    return Run(o is not None, dh, dw, dl, wall_seen, wall_ok, first["nonhom"], first["accurate"])


def _err(x: np.ndarray) -> str:
    x = x[np.isfinite(x)]
    if len(x) == 0:
        return "–"
    med, p10, p90 = (100 * np.percentile(x, q) for q in (50, 10, 90))
    return f"{med:+.1f} ({p10:+.1f}…{p90:+.1f})"


def _lat(t: np.ndarray, within: float = 0.25) -> str:
    got = np.isfinite(t)
    med = f"{np.median(t[got]):.2f}" if got.mean() >= 0.5 else "> 0.5"
    return f"{med} / {(t <= within + 1e-9).mean():.0%} / {got.mean():.0%}"


def report(args: Args, runs: dict[str, list[Run]], elapsed: float, load0, load1, argv) -> str:
    """The markdown section."""
    tp = ToFParams.at_scale(args.scale)
    cmd = " ".join(["python scripts/bench_affordance_map.py", *argv])
    lines = [
        "## Affordance from the map alone (scripts/bench_affordance_map.py)",
        "",
        f"Command: `.venv/bin/{cmd}`  ",
        f"Machine: {machine('numpy', 'numba', 'mujoco')}.  ",
        f"Load average (1/5/15 min) at start {load0}, at end {load1}; {elapsed:.0f} s. "
        "Simulated-time results: they do not depend on the load.",
        "",
        f"{args.scenes} floor + box + wall scenes of series {args.seed} (the scenes of "
        "`scripts/bench_affordance_accuracy.py`): robot standing, four ToF sensors "
        f"({tp.width} × {tp.height} px each, 45 fps, range noise σ/d = {args.noise:g}); box "
        "4–10 cm high, 10–30 cm wide and long, any yaw, 0.35–0.85 m ahead; wall 2 m × 0.5 m "
        f"0.3–0.55 m behind it. {args.warmup:g} s with the wall alone, then the box appears and "
        f"each pipeline runs one cycle per 0.01 s on the latest frame for {args.sense:g} s, "
        'attention loop closed (Table 2 parameters). Sizes read at the end; "all three" = '
        "height within ±1 cm, width and length within ±2 cm (issue 23's target: ≥ 80 % with "
        'DD-GNG in "map" mode). Errors in cm, detected minus true: median (10th…90th '
        "percentile). Wall: a wall label on it and no object (scenes with ≥ 30 rays on it).",
        "",
        "| pipeline | object found | h ±1 cm | w ±2 cm | l ±2 cm | all three | h error | "
        "w error | l error | wall is wall |",
        "|---|---:|---:|---:|---:|---:|---|---|---|---:|",
    ]
    for name, rs in runs.items():
        found = np.array([r.found for r in rs])
        dh, dw, dl = (np.array([getattr(r, k) for r in rs]) for k in ("dh", "dw", "dl"))
        okh = found & (np.abs(np.nan_to_num(dh, nan=9)) <= TOL_H)
        okw = found & (np.abs(np.nan_to_num(dw, nan=9)) <= TOL_WL)
        okl = found & (np.abs(np.nan_to_num(dl, nan=9)) <= TOL_WL)
        seen = [r for r in rs if r.wall_seen]
        wall = np.mean([r.wall_ok for r in seen]) if seen else math.nan
        lines.append(
            f"| {name} | {found.mean():.0%} | {okh.mean():.0%} | {okw.mean():.0%} | "
            f"{okl.mean():.0%} | **{(okh & okw & okl).mean():.0%}** | {_err(dh)} | {_err(dw)} | "
            f"{_err(dl)} | {wall:.0%} of {len(seen)} |"
        )
    lines += [
        "",
        "Latency from the box's appearance (the first frame showing it arrives within one "
        "sensor period, 22 ms): median s / share within 0.25 s / share within the "
        f"{args.sense:g} s. *Non-homogeneous*: a node within 5 cm of the box's footprint on a "
        "facet tilted more than 20° from the vertical. *Accurate*: the object on the box with "
        "its height within 1 cm and its length within 2 cm. Paper (§6.2, Fig. 10): first "
        "non-homogeneous nodes after about 0.1 s, an accurate affordance 0.11 s later; issue "
        "23's target: accurate within 0.25 s in ≥ 90 % with DD-GNG.",
        "",
        "| pipeline | first non-homogeneous nodes | accurate affordance |",
        "|---|---:|---:|",
    ]
    for name, rs in runs.items():
        tn = np.array([r.t_nonhom for r in rs])
        ta = np.array([r.t_accurate for r in rs])
        lines.append(f"| {name} | {_lat(tn)} | {_lat(ta)} |")
    return "\n".join(lines) + "\n"


def parse(argv: list[str]) -> Args:
    """Command line -> :class:`Args`."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenes", type=int, default=Args.scenes)
    p.add_argument("--seed", type=int, default=Args.seed, help="scene series")
    p.add_argument("--sense", type=float, default=Args.sense, help="s after the box (≤ 0.5)")
    p.add_argument("--noise", type=float, default=Args.noise, help="ToF range noise σ/d")
    p.add_argument("--scale", type=float, default=Args.scale, help="ToF resolution per axis")
    p.add_argument("--pipelines", nargs="+", default=list(Args.pipelines), choices=PIPELINES)
    p.add_argument("--out", default=Args.out, help="markdown output file")
    p.add_argument("--quick", action="store_true", help="5 scenes, nothing written")
    a = p.parse_args(argv)
    if not 0 < a.sense <= 0.5:
        p.error("--sense must be in (0, 0.5] s")
    if a.scenes < 1:
        p.error("--scenes must be >= 1")
    if a.quick:
        a.scenes = 5
    return Args(
        scenes=a.scenes, seed=a.seed, sense=a.sense, noise=a.noise, scale=a.scale,
        pipelines=tuple(a.pipelines), out=a.out, write=not a.quick,
    )  # fmt: skip


def main(argv: list[str] | None = None) -> str:
    """Run the benchmark; print (and unless ``--quick``, write) the table."""
    argv = sys.argv[1:] if argv is None else list(argv)
    args = parse(argv)
    load0 = load_now()
    t0 = time.perf_counter()
    tof = ToFParams.at_scale(args.scale, backend="numba", noise_std_rel=args.noise)
    scene = StaticScene(tof, seed=args.seed)
    runs: dict[str, list[Run]] = {name: [] for name in args.pipelines}
    with tqdm(total=args.scenes * len(args.pipelines), desc="scenes × pipelines") as bar:
        for i in range(args.scenes):
            for name in args.pipelines:
                gng, source = PIPELINES[name]
                runs[name].append(run_one(scene, args, i, gng, source))
                bar.update()
    scene.close()
    text = report(args, runs, time.perf_counter() - t0, load0, load_now(), argv)
    print(text)
    if args.write:
        atomic_write_text(Path(args.out), text)
    return text


if __name__ == "__main__":
    main()
