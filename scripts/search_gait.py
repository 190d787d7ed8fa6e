"""The local random search that found body v1's trot numbers (``scripts/design_gait.py``).

Each candidate is a ``TrotDesign`` (design_gait.py) with one or two numbers multiplied by
``1 + N(0, sigma)``; it walks ``--seconds`` on ``NeuroCog/Walk-v3`` (zero action) for each of
``--seeds`` seeds, the first 2 s left out, and is kept when its cost is lower. Cost per seed:

* 100 for a fall, plus 10 per second it fell short;
* 10 (``--speed_weight``) x |speed - 0.5 m/s| (``--speed``; forward x displacement per second);
* per leg: the median swing clearance below 3.2 cm or above 4.8 cm (per cm), half the amount by
  which its highest swing exceeds 5.8 cm;
* |lateral drift| / 6 m;
* 20 (``--side_weight``) x the share of time both feet of one side are off the ground (a
  pace-like gait);
* 0.3 (``--short_weight``) x short touch-downs (contacts under 80 ms) per second;
* with ``--mismatch W``: W x the share of time a foot's contact disagrees with its CPG phase
  (in the air while the CPG stands it, or down while it swings); with ``--swing S``: 30
  (``--swing_weight``) per second
  by which the median swing is shorter than S; with ``--hip_height H``: 100 (``--hip_weight``)
  per metre by which the mean hip height falls short of H (all three used for body v2, off by
  default); with
  ``--perturb K`` every other seed walks with every K-th front swing a high step; with
  ``--avoid_weight W`` each seed also backs off and side-steps as the AEF's teacher does
  (``avoid_stats``): a fall as above, W per metre the side step falls short of ``--avoid_side``
  and W per radian of heading lost.

Body v1's numbers came from four chained runs of this search (about 1,100 candidates): from the
v0 numbers scaled to the longer legs (theta_dd_MAX x 0.55, tau_f x 1.3, knee synapses x 0.7,
posture hip -0.8 / knee 1.6) with 2 seeds and without the last two terms (400 + 200
candidates), then, after the result turned out pace-like, with 6 seeds and with them (3 seeds,
330 candidates). The best design is written to ``--out`` as JSON; ``python
scripts/design_gait.py --params OUT`` turns it into a gait file.

    python scripts/search_gait.py --start START.json --seeds 3 --iters 400 --rng 5 --out best.json
"""

from __future__ import annotations

import argparse
import dataclasses
import inspect
import json
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_walk import _yaw  # noqa: E402
from design_gait import TrotDesign, build  # noqa: E402

from neurocog_gym.envs.walk import WalkEnv  # noqa: E402

KEYS = ("hg", "hgh", "kf", "kfh", "keh", "tf", "am", "ph", "pk", "phh", "pkh", "kr")
GENE_KEYS = (
    *("ke", "c1", "ring", "ring2", "kk", "kk6", "w", "wb"),
    *("t_hf", "t_he", "t_kf", "t_nf", "t_ne"),
)
"""With ``--genes``: the CPG's synapse weights too (design_gait.py's docstring names them)."""
WALK_GENE_KEYS = tuple(k for k in GENE_KEYS if k not in ("w", "wb")) + ("wa", "wc", "wbw")
"""The same for a walk design (``TrotDesign.walk``): its ring couplings instead of the trot's."""


@dataclasses.dataclass(frozen=True)
class Args:
    """Command-line arguments."""

    start: str = ""
    """JSON of TrotDesign fields to start from ('' = design_gait.py's defaults)."""
    seeds: int = 3
    """Walking seeds per candidate."""
    seconds: float = 8.0
    """Simulated seconds per seed."""
    iters: int = 400
    """Candidates."""
    sigma: float = 0.06
    """Relative perturbation of a number."""
    rng: int = 0
    """Seed of the search's own random draws."""
    out: str = "runs/gait_search/best.json"
    """Best design so far (written atomically whenever it improves)."""
    genes: bool = False
    """Perturb the CPG weights of ``GENE_KEYS`` as well."""
    mismatch: float = 0.0
    """Weight of the contact/CPG mismatch: per leg, the share of time its foot is in the air
    (sole above 4 mm) while its CPG stands or on the ground while it swings (0: not used)."""
    swing: float = 0.0
    """Shortest wanted median swing (sole above 4 mm), s; 30 per second short (0: not used)."""
    speed_weight: float = 10.0
    """Cost per m/s of speed error."""
    speed: float = 0.5
    """Wanted walking speed, m/s."""
    swing_weight: float = 30.0
    """Cost per second by which the median swing is shorter than ``--swing``."""
    perturb: int = 0
    """k > 0: every other seed walks with every k-th front swing a high step (``walk_stats``),
    so a design that falls after a step over a block costs as a fall does (0: not used)."""
    kinds: str = "h"
    """The disturbances of ``--perturb``, in turn: h high step, d shortened step, o step over
    (``walk_stats``); O the step over with a 0.16 s carry."""
    hip_height: float = 0.0
    """Lowest wanted mean hip height while walking, m; ``--hip_weight`` per metre below it (0: not
    used)."""
    hip_weight: float = 100.0
    """Cost per metre by which the mean hip height falls short of ``--hip_height``."""
    cma: bool = False
    """Search with CMA-ES (the ``cma`` package) instead: ``--iters`` evaluations in all, the
    numbers moved relatively (``--sigma``), near-zero ones absolutely."""
    workers: int = 1
    """Processes evaluating a CMA-ES generation."""
    liftoff: bool = False
    """``--perturb``'s disturbances start at the foot's lift-off, not at the CPG's swing onset."""
    short_weight: float = 0.3
    """Cost per short touch-down (a contact under 80 ms) per second."""
    fixed: str = ""
    """Comma-separated ``TrotDesign`` fields the search leaves at the start's values (e.g.
    ``ph,pk``: the front posture, on which the bent shank's geometry depends)."""
    side_weight: float = 20.0
    """Cost per unit share of time with both feet of one side off the ground (pace-like)."""
    support: float = 0.0
    """Weight of the share of time with fewer than three soles on the ground (sole below
    4 mm), for a walk (0: not used)."""
    avoid_weight: float = 0.0
    """Weight of the avoidance provisions (``avoid_stats``): each seed also backs off and
    side-steps as the AEF's teacher commands; cost per metre the side step falls short of
    ``--avoid_side`` and per radian of heading lost, a fall as in the walk (0: not used)."""
    avoid_side: float = 0.4
    """Wanted sideways displacement of ``avoid_stats``' side step, m."""


def walk_stats(
    design: TrotDesign,
    seed: int,
    seconds: float,
    perturb: int = 0,
    kinds: str = "h",
    liftoff: bool = False,
    gait=None,
) -> dict:
    """Walk the design's gait; fall, speed, clearances, drift, one-side share, short contacts.

    ``perturb`` k > 0: from 2 s on, every k-th swing of each front leg is disturbed the way a
    controller answering a block disturbs it, the kinds taken in turn from ``kinds``: ``h`` a
    high step (knee interrupt +1 until the sole is 10 cm up, then the CPG's swing), ``d`` a
    shortened step (from 0.1 s into the swing hip +1, knee -1 until the foot is down), ``o`` a
    step over (the high step, then hip -1 for 0.08 s, then knee -1 until the foot is down). The
    other swings are the CPG's; the statistics then describe the disturbed walk. ``liftoff``:
    a disturbance starts at the foot's lift-off (sole above 4 mm), not at the CPG's swing
    onset (a walk's knee lifts the foot before its hip flexor leads). ``gait``: walk this gait
    instead of ``build(design)`` (``design`` is then unused).
    """
    env = WalkEnv(gait=gait if gait is not None else build(design))
    env.reset(seed=seed)
    r = env.robot
    radius = float(np.ravel(env.model.geom_size[r.foot_geom, 0])[0])
    xs, feet, touch, cpg, hips, fell = [], [], [], [], [], False
    action = np.zeros(15)
    was, count = np.zeros(4, bool), np.zeros(4, int)
    kind, phase, since = [""] * 4, np.zeros(4, int), np.zeros(4)
    for _ in range(int(seconds / env.dt)):
        if perturb:
            action[:] = 0.0
            now = env.generator.swinging
            if liftoff:
                now = env.data.site_xpos[r.foot_site, 2] - radius > 0.004
            down = env.touch() > 0.05
            for leg in (0, 1):
                sole = env.data.site_xpos[r.foot_site[leg], 2] - radius
                if now[leg] and not was[leg] and env.data.time > 2.0:
                    count[leg] += 1
                    if count[leg] % perturb == 0:
                        kind[leg] = kinds[(count[leg] // perturb) % len(kinds)]
                        phase[leg], since[leg] = 0, 0.0
                since[leg] += env.dt
                k = kind[leg]
                j = 3 * leg
                if k == "h":
                    if (now[leg] or liftoff) and sole < 0.10 and since[leg] < 0.3:
                        action[j + 2] = 1.0
                    else:
                        kind[leg] = ""
                elif k == "d":
                    if since[leg] >= 0.1:
                        if down[leg] and since[leg] > 0.12:
                            kind[leg] = ""
                        else:
                            action[j + 1], action[j + 2] = 1.0, -1.0
                elif k in ("o", "O"):
                    if phase[leg] == 0:
                        action[j + 2] = 1.0
                        if sole >= 0.10:
                            phase[leg], since[leg] = 1, 0.0
                    elif phase[leg] == 1:
                        action[j + 1], action[j + 2] = -1.0, 1.0 if sole < 0.09 else 0.5
                        if since[leg] >= (0.08 if k == "o" else 0.16):
                            phase[leg] = 2
                    else:
                        action[j + 2] = -1.0
                        if down[leg]:
                            kind[leg] = ""
                    if since[leg] > 0.6:
                        kind[leg] = ""
            was = now.copy()
        _, _, term, trunc, _ = env.step(action)
        cpg.append(env.generator.swinging.copy())
        hips.append(env.data.xpos[r.thigh_body, 2].mean())
        xs.append(env.data.qpos[:2].copy())
        feet.append(env.data.site_xpos[r.foot_site][:, 2] - radius)
        touch.append(env.touch() > 0.05)
        if term or trunc:
            fell = True
            break
    env.close()
    n0 = int(2.0 / env.dt)
    xs, feet, on = np.array(xs), np.array(feet), np.array(touch)
    if len(xs) <= n0:
        return {"fell": True, "t": len(xs) * env.dt}
    span = (len(xs) - n0) * env.dt
    med, top = [], []
    for leg in range(4):
        h, peaks, i = feet[n0:, leg], [], 0
        while i < len(h):
            j = i
            while j < len(h) and h[j] > 0.003:
                j += 1
            if j - i >= 6:
                peaks.append(h[i:j].max())
            i = j + 1
        med.append(float(np.median(peaks)) if peaks else 0.0)
        top.append(float(np.max(peaks)) if peaks else 0.0)
    o = on[n0:]
    side = float(((~o[:, 0] & ~o[:, 2]) | (~o[:, 1] & ~o[:, 3])).mean())
    air = feet[n0:] > 0.004
    mismatch = float((air != np.array(cpg)[n0:]).mean())
    swings = []
    for leg in range(4):
        edges = np.flatnonzero(np.diff(air[:, leg].astype(int)))
        swings += [b - a for a, b in zip(edges[:-1], edges[1:], strict=False)
                   if air[a + 1, leg] and b - a >= 5]  # fmt: skip
    swing = float(np.median(swings)) * env.dt if swings else 0.0
    short = 0
    for leg in range(4):
        run = 0
        for k in range(1, len(o)):
            if not o[k, leg]:
                run += 1
            else:
                short += 0 < run < 8
                run = 0
    return {"fell": fell, "t": len(xs) * env.dt, "speed": (xs[-1, 0] - xs[n0, 0]) / span,
            "clear": med, "top": top, "drift": float(xs[-1, 1] - xs[0, 1]), "side": side,
            "short": short / span, "mismatch": mismatch, "swing": swing,
            "hip_height": float(np.mean(hips[n0:])),
            "under3": float((air.sum(1) >= 2).mean())}  # fmt: skip


AVOID_REVERSE = 0.6
"""Seconds of ``avoid_stats``' back-off (s_SAG -1, the teacher's REVERSE)."""
AVOID_SIDE = 2.0
"""Seconds of ``avoid_stats``' side step."""


def avoid_stats(design: TrotDesign, seed: int, gait=None) -> dict:
    """Walk 2 s, back off and side-step as the AEF's teacher commands, walk on 1 s.

    The provisions are those of ``locomotion.avoidance.AvoidanceParams``' REVERSE and SIDE states
    (no block in the lane: the stride cancellation ``k_side``), the side to the left on even
    seeds and to the right on odd ones, the teacher's heading feedback included. Returns
    whether it fell (and when), the sideways displacement in the start heading's frame (signed
    towards the commanded side) and the heading lost at the end, rad.
    """
    from neurocog_gym.locomotion.avoidance import AvoidanceParams, sag_for_stride

    p = AvoidanceParams()
    env = WalkEnv(gait=gait if gait is not None else build(design))
    env.reset(seed=seed)
    side = 1.0 if seed % 2 == 0 else -1.0
    t_rev, t_side = 2.0 + AVOID_REVERSE, 2.0 + AVOID_REVERSE + AVOID_SIDE
    seconds = t_side + 1.0
    action = np.zeros(15)
    sag_side = sag_for_stride(1.0 - p.k_side, p.sag_gain, p.brake_from)
    xy0, yaw0 = None, 0.0
    for _ in range(int(round(seconds / env.dt))):
        t = env.data.time
        if xy0 is None and t >= 2.0:
            xy0, yaw0 = env.data.qpos[:2].copy(), _yaw(env.data.qpos[3:7])
        # heading error as the teacher takes it (SuddenAvoidance.update)
        ey = math.remainder(_yaw(env.data.qpos[3:7]) - yaw0, 2.0 * math.pi)
        if xy0 is None or t >= t_side:
            action[12:] = 0.0
        elif t < t_rev:
            action[12:] = (-1.0, 0.0, 0.0)
        else:
            turn = -p.side_dir * ey - side * p.side_dir_ff
            action[12:] = (sag_side, side * p.side_cor, min(max(turn, -1.0), 1.0))
        _, _, term, trunc, _ = env.step(action)
        if term or trunc:
            env.close()
            return {"fell": True, "t": env.data.time}
    d = env.data.qpos[:2] - xy0
    left = -np.sin(yaw0) * d[0] + np.cos(yaw0) * d[1]
    ey = math.remainder(_yaw(env.data.qpos[3:7]) - yaw0, 2.0 * math.pi)
    env.close()
    return {"fell": False, "t": seconds, "side": float(side * left), "heading": abs(ey)}


def cost(
    design: TrotDesign,
    seeds: int,
    seconds: float,
    mismatch: float = 0.0,
    swing: float = 0.0,
    speed_weight: float = 10.0,
    hip_height: float = 0.0,
    speed: float = 0.5,
    swing_weight: float = 30.0,
    perturb: int = 0,
    kinds: str = "h",
    support: float = 0.0,
    short_weight: float = 0.3,
    liftoff: bool = False,
    hip_weight: float = 100.0,
    side_weight: float = 20.0,
    avoid_weight: float = 0.0,
    avoid_side: float = 0.4,
) -> float:
    """The search's cost (module docstring), summed over the seeds."""
    c = 0.0
    for seed in range(seeds):
        if avoid_weight:
            a = avoid_stats(design, seed)
            if a["fell"]:
                c += 100.0 + 10.0 * (2.0 + AVOID_REVERSE + AVOID_SIDE + 1.0 - a["t"])
            else:
                c += avoid_weight * (max(0.0, avoid_side - a["side"]) + a["heading"])
        s = walk_stats(design, seed, seconds, perturb if seed % 2 else 0, kinds, liftoff)
        if s["fell"]:
            c += 100.0 + 10.0 * (seconds - s["t"])
            if "speed" not in s:
                continue
        c += speed_weight * abs(s["speed"] - speed)
        for med, top in zip(s["clear"], s["top"], strict=True):
            c += 100 * max(0.0, 0.032 - med) + 100 * max(0.0, med - 0.048)
            c += 50 * max(0.0, top - 0.058)
        c += abs(s["drift"]) / 6.0 + side_weight * s["side"] + short_weight * s["short"]
        c += mismatch * s["mismatch"] + swing_weight * max(0.0, swing - s["swing"])
        c += hip_weight * max(0.0, hip_height - s["hip_height"])
        c += support * s["under3"]
        if support:  # a walk may not buy its support by dragging a pair of feet
            c += sum(1000.0 * max(0.0, 0.02 - med) for med in s["clear"])
    return c


def _cma_cost(job) -> float:
    design, seeds, seconds, extra = job
    try:
        return cost(design, seeds, seconds, **extra)
    except ValueError:  # a number out of its range (a negative rate or gain): not a gait
        return 1e4


def _cma_search(args: Args, start: TrotDesign, start_cost: float, keys, extra: dict) -> None:
    """CMA-ES over ``keys`` around ``start``; the best design is written after each generation."""
    from concurrent.futures import ProcessPoolExecutor

    import cma

    from neurocog_gym import io as nio

    base = np.array([getattr(start, k) for k in keys], dtype=float)
    rel = np.abs(base) > 0.05

    def design(x):
        v = np.where(rel, base * (1.0 + x), base + x)
        return dataclasses.replace(start, **{k: float(a) for k, a in zip(keys, v, strict=True)})

    es = cma.CMAEvolutionStrategy(np.zeros(len(keys)), args.sigma,
                                  {"seed": args.rng + 1, "verbose": -9})  # fmt: skip
    best, best_cost, n = start, start_cost, 0
    with ProcessPoolExecutor(max_workers=max(1, args.workers)) as pool:
        while n < args.iters and not es.stop():
            xs = es.ask()
            jobs = [(design(x), args.seeds, args.seconds, extra) for x in xs]
            costs = list(pool.map(_cma_cost, jobs))
            es.tell(xs, costs)
            n += len(xs)
            k = int(np.argmin(costs))
            if costs[k] < best_cost:
                best, best_cost = jobs[k][0], costs[k]
                nio.atomic_write_text(args.out, json.dumps(dataclasses.asdict(best), indent=1))
            print(f"{n}: generation best {min(costs):.3f}, best {best_cost:.3f}", flush=True)


def search_keys(start: TrotDesign, genes: bool, fixed: str) -> tuple[str, ...]:
    """The ``TrotDesign`` fields a search moves: ``KEYS``, with ``genes`` the CPG weights of the
    start's structure too, less the comma-separated ``fixed`` ones (ValueError for a name the
    search would not move anyway)."""
    keys = KEYS + (WALK_GENE_KEYS if start.walk else GENE_KEYS) if genes else KEYS
    names = {k for k in fixed.split(",") if k}
    if names - set(keys):
        raise ValueError(
            f"--fixed names fields the search does not move: {sorted(names - set(keys))}"
        )
    return tuple(k for k in keys if k not in names)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for f in dataclasses.fields(Args):
        if isinstance(f.default, bool):
            parser.add_argument(f"--{f.name}", action="store_true")
        else:
            parser.add_argument(f"--{f.name}", type=type(f.default), default=f.default)
    args = Args(**vars(parser.parse_args(argv)))
    if args.seeds < 1 or args.iters < 0 or not args.sigma > 0:
        parser.error("--seeds must be >= 1, --iters >= 0, --sigma > 0")
    best = TrotDesign()
    if args.start:
        best = dataclasses.replace(best, **json.loads(Path(args.start).read_text()))
    try:
        keys = search_keys(best, args.genes, args.fixed)
    except ValueError as e:
        parser.error(str(e))
    rng = np.random.default_rng(args.rng)
    # Every keyword of cost() past the first three is the Args field of the same name.
    extra = {k: getattr(args, k) for k in list(inspect.signature(cost).parameters)[3:]}
    best_cost = cost(best, args.seeds, args.seconds, **extra)
    print(f"start: cost {best_cost:.3f}", flush=True)
    from neurocog_gym import io as nio

    if args.cma:
        _cma_search(args, best, best_cost, keys, extra)
        return
    for it in range(args.iters):
        changes = {}
        for k in rng.choice(keys, size=int(rng.integers(1, 3)), replace=False):
            v = float(getattr(best, str(k)))
            # A number near zero is moved by an absolute step (a relative one would keep it there).
            step = rng.normal(0.0, args.sigma)
            changes[str(k)] = v * (1.0 + step) if abs(v) > 0.05 else v + step
        cand = dataclasses.replace(best, **changes)
        c = cost(cand, args.seeds, args.seconds, **extra)
        if c < best_cost:
            best, best_cost = cand, c
            print(f"{it}: cost {c:.3f} {changes}", flush=True)
            nio.atomic_write_text(args.out, json.dumps(dataclasses.asdict(best), indent=1))


if __name__ == "__main__":
    main()
