"""Soak test: many env steps with resets, watching memory and the DD-GNG node count.

One env id per process (so one env's memory does not hide in another's): steps it ``--steps``
times (or until ``--max-minutes`` of wall time) with seeded random actions in [-a, a], resetting
on termination or truncation and every ``--episode-steps`` steps, and samples the process's
resident set size (``/proc/self/status`` VmRSS) every ``--sample-every`` steps. Growth is
measured from the RSS after ``--warmup`` steps (allocators, numba caches and MuJoCo buffers have
settled) to the RSS at the end. For the obstacle envs it also records the largest DD-GNG node
count seen against the map's ``max_nodes``.

Usage:
    python scripts/soak.py --env NeuroCog/Walk-v3 --steps 1000000 --json runs/soak/walk.json
    python scripts/soak.py --report runs/soak/*.json --out docs/generated/benchmarks_soak.md
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np


@dataclass
class Args:
    env: str = "NeuroCog/Walk-v3"
    steps: int = 1_000_000
    warmup: int = 20_000
    episode_steps: int = 1000
    action_scale: float = 0.5
    sample_every: int = 5_000
    max_minutes: float = 0.0
    seed: int = 0
    json: str = ""


def rss_mib() -> float:
    """Resident set size of this process, MiB."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    raise RuntimeError("no VmRSS in /proc/self/status")


def loadavg() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def soak(a: Args) -> dict:
    import gymnasium as gym
    from tqdm import tqdm

    import neurocog_gym  # noqa: F401

    env = gym.make(a.env)
    u = env.unwrapped
    rng = np.random.default_rng(a.seed)
    max_nodes = None
    if hasattr(u, "pipeline"):
        max_nodes = int(u.pipeline.net.params.max_nodes)
    obs, _ = env.reset(seed=a.seed)
    episodes, ep_len, unstable, nonfinite = 1, 0, 0, 0
    node_max, samples = 0, []
    rss_warm = None
    load_start = loadavg()
    t0 = time.perf_counter()
    deadline = t0 + 60.0 * a.max_minutes if a.max_minutes > 0 else None
    done_steps = 0
    bar = tqdm(total=a.steps, desc=a.env.split("/")[-1], unit="step", mininterval=2.0,
               smoothing=0.05)  # fmt: skip
    for step in range(1, a.steps + 1):
        action = rng.uniform(-a.action_scale, a.action_scale, 15).astype(np.float32)
        obs, _, term, trunc, info = env.step(action)
        ep_len += 1
        done_steps = step
        if info.get("sim_unstable"):
            unstable += 1
        if not all(np.all(np.isfinite(np.asarray(v, dtype=np.float64))) for v in obs.values()):
            nonfinite += 1
        if max_nodes is not None:
            node_max = max(node_max, int(u.pipeline.net.n_nodes))
        if term or trunc or ep_len >= a.episode_steps:
            obs, _ = env.reset(seed=int(rng.integers(2**31)))
            episodes += 1
            ep_len = 0
        if step == a.warmup:
            rss_warm = rss_mib()
        if step % a.sample_every == 0:
            samples.append((step, round(time.perf_counter() - t0, 2), round(rss_mib(), 2)))
            bar.update(a.sample_every)
            bar.set_postfix(rss=f"{samples[-1][2]:.0f}MiB", nodes=node_max or "-")
            if deadline is not None and time.perf_counter() > deadline:
                break
    bar.close()
    wall = time.perf_counter() - t0
    rss_end = rss_mib()
    if rss_warm is None:  # stopped before the warm-up ended
        rss_warm = samples[0][2] if samples else rss_end
    env.close()
    return {
        "env": a.env,
        "steps": done_steps,
        "target_steps": a.steps,
        "episodes": episodes,
        "warmup_steps": a.warmup,
        "rss_warm_mib": round(rss_warm, 2),
        "rss_end_mib": round(rss_end, 2),
        "rss_max_mib": round(max([s[2] for s in samples] + [rss_end]), 2),
        "growth_pct": round(100.0 * (rss_end - rss_warm) / rss_warm, 3),
        "max_nodes_seen": node_max if max_nodes is not None else None,
        "max_nodes_param": max_nodes,
        "sim_unstable_steps": unstable,
        "nonfinite_obs_steps": nonfinite,
        "wall_s": round(wall, 1),
        "steps_per_s": round(done_steps / wall, 1),
        "load_start": load_start,
        "load_end": loadavg(),
        "args": asdict(a),
        "samples": samples,
    }


def report(paths: list[str], out: Path) -> str:
    from neurocog_gym import io as nio

    runs = [json.loads(Path(p).read_text()) for p in paths]
    lines = [
        "# Soak test: long runs with resets (issue 9, item 4)",
        "",
        f"Machine: {os.cpu_count()}-core {platform.processor() or platform.machine()} VM, "
        f"Python {platform.python_version()}, shared with other engineers' jobs (load averages "
        "below are the 1/5/15-minute figures at start and end of each run).",
        "",
        "```",
        *[
            f".venv/bin/python scripts/soak.py --env {r['env']} --steps {r['target_steps']}"
            + (f" --max-minutes {r['args']['max_minutes']:g}" if r["args"]["max_minutes"] else "")
            + " --json ..."
            for r in runs
        ],  # fmt: skip
        "```",
        "",
        "Random actions uniform in [-a, a] (seeded), reset on termination/truncation and at least "
        "every `episode_steps` steps with a fresh seed. RSS = VmRSS of the process; growth is from "
        "the RSS after the warm-up steps to the RSS at the end. Target: growth ≤ 5 %, node count "
        "bounded by `max_nodes`.",
        "",
        "| env | steps (target) | episodes | steps/s | RSS after warm-up | RSS end | RSS max "
        "| growth | max DD-GNG nodes (limit) | sim_unstable | non-finite obs | load start → end |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in runs:
        nodes = (f"{r['max_nodes_seen']} ({r['max_nodes_param']})"
                 if r["max_nodes_param"] is not None else "n/a (no perception)")  # fmt: skip
        ok = "✓" if r["growth_pct"] <= 5.0 else "✗"
        lines.append(
            f"| {r['env']} | {r['steps']:,} ({r['target_steps']:,}) | {r['episodes']:,} | "
            f"{r['steps_per_s']:.0f} | {r['rss_warm_mib']:.1f} MiB (step {r['warmup_steps']:,}) "
            f"| {r['rss_end_mib']:.1f} MiB | {r['rss_max_mib']:.1f} MiB | "
            f"{r['growth_pct']:+.2f} % {ok} | {nodes} | {r['sim_unstable_steps']} | "
            f"{r['nonfinite_obs_steps']} | {r['load_start']} → {r['load_end']} |"
        )
    lines += ["", "RSS over the run (MiB, sampled):", ""]
    for r in runs:
        s = r["samples"]
        pick = s[:: max(1, len(s) // 10)] + ([s[-1]] if s else [])
        lines.append(f"- {r['env']}: " + ", ".join(f"{st:,}: {m:.1f}" for st, _, m in pick))
    text = "\n".join(lines) + "\n"
    nio.atomic_write_text(out, text)
    return text


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    d = Args()
    ap.add_argument("--env", default=d.env)
    ap.add_argument("--steps", type=int, default=d.steps)
    ap.add_argument("--warmup", type=int, default=d.warmup)
    ap.add_argument("--episode-steps", type=int, default=d.episode_steps)
    ap.add_argument("--action-scale", type=float, default=d.action_scale)
    ap.add_argument("--sample-every", type=int, default=d.sample_every)
    ap.add_argument(
        "--max-minutes",
        type=float,
        default=d.max_minutes,
        help="stop after this wall time (0: no limit); the steps done are reported",
    )
    ap.add_argument("--seed", type=int, default=d.seed)
    ap.add_argument("--json", default=d.json, help="write the result here")
    ap.add_argument("--report", nargs="+", default=None, help="soak JSON files to tabulate")
    ap.add_argument("--out", default="docs/generated/benchmarks_soak.md")
    ns = ap.parse_args(argv)
    if ns.report:
        print(report(ns.report, Path(ns.out)))
        return 0
    a = Args(env=ns.env, steps=ns.steps, warmup=ns.warmup, episode_steps=ns.episode_steps,
             action_scale=ns.action_scale, sample_every=ns.sample_every,
             max_minutes=ns.max_minutes, seed=ns.seed, json=ns.json)  # fmt: skip
    if a.steps < 1 or a.sample_every < 1 or a.warmup < 1:
        ap.error("--steps, --warmup and --sample-every must be positive")
    res = soak(a)
    summary = {k: v for k, v in res.items() if k != "samples"}
    print(json.dumps(summary, indent=1))
    if a.json:
        from neurocog_gym import io as nio

        nio.atomic_write_json(a.json, res)
    return 0 if res["growth_pct"] <= 5.0 and res["nonfinite_obs_steps"] == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
