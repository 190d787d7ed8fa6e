"""Walk-v3 benchmark: throughput beside Gymnasium's Ant-v5, and the default gait's statistics.

Three parts, printed as markdown tables and written to ``--out``
(``docs/generated/benchmarks_walk.md``):

1. Throughput, one process pinned to one core, timed interleaved in rounds (so load from other
   processes falls on every row alike), medians over the rounds: ``NeuroCog/Walk-v3`` env steps/s
   with zero actions (plain CPG walking) and with uniform random actions, Gymnasium's ``Ant-v5``
   with random actions, and raw ``mujoco.mj_step`` of both scenes.
2. Gait statistics of the shipped default gait on flat ground: ``--seconds`` (60) per seed for
   ``--seeds`` (10) seeds, zero actions, from the home pose with the env's reset noise. The first
   ``--warmup`` (2) seconds are left out of every statistic.
3. The walking provision (action 12-14: s_SAG, s_COR, s_DIR) held at +-0.5 in the same gait.

Definitions (all measured on the env's MuJoCo state after every 10 ms control step):

* speed: forward (x) displacement of the torso / time; lateral drift: y displacement over the
  run (the robot starts facing +x); heading change: torso yaw at the end minus at the start.
  In part 3 forward and sideways speed are measured in the heading frame instead (every 10 ms
  displacement projected on the torso's current heading and its left), so that a turn does not
  show up as a sideways speed.
* cost of transport: sum over the 12 joints of |actuator torque x joint rate| (the env's
  ``info["power"]``, sampled once per control step) integrated over time, divided by
  m g x (horizontal distance).
* duty factor: share of time a foot's touch sensor reads more than 1 mN.
* swing clearance: height of the lowest point of the foot sphere above the floor, its peak over
  every swing (the foot off the ground for at least 60 ms); per leg the median over swings, the
  5th percentile over swings ("every swing lifts at least ...") and the maximum.
* CPG frequency: from the upward zero crossings of the front-left hip drive (flexor minus
  extensor); trot: correlation of the four hip drives (diagonal pairs near +1).

    python scripts/bench_walk.py [--seeds 10] [--seconds 60] [--rounds 10] [--out FILE]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time
from pathlib import Path

import gymnasium as gym
import mujoco
import numpy as np

import neurocog_gym  # noqa: F401  (registers the env ids)
from neurocog_gym.bench.machine import field_doc, machine
from neurocog_gym.robot.names import LEGS

WALK = "NeuroCog/Walk-v3"


@dataclasses.dataclass(frozen=True)
class Args:
    """Command-line arguments."""

    seeds: int = 10
    """Seeds of the gait statistics (0 .. seeds-1)."""
    seconds: float = 60.0
    """Simulated seconds per seed."""
    warmup: float = 2.0
    """Seconds left out at the start of each run."""
    steps: int = 2000
    """Timed env steps per throughput row (split over the rounds)."""
    rounds: int = 10
    """Interleaved timing rounds."""
    provision_seeds: int = 5
    """Seeds of each walking-provision row ('0' skips part 3)."""
    provision_seconds: float = 20.0
    """Simulated seconds per provision run."""
    out: str = "docs/generated/benchmarks_walk.md"
    """Markdown report to write ('' to skip)."""


def parse_args(argv: list[str] | None = None) -> Args:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for f in dataclasses.fields(Args):
        parser.add_argument(
            "--" + f.name.replace("_", "-"), type=type(f.default), default=f.default,
            help=f"{field_doc(__file__, f.name)} (default {f.default!r})",
        )  # fmt: skip
    ns = parser.parse_args(argv)
    args = Args(**vars(ns))
    if args.seeds < 1 or args.steps < 1 or args.rounds < 1 or args.provision_seeds < 0:
        parser.error("--seeds, --steps and --rounds must be >= 1, --provision-seeds >= 0")
    if not args.seconds > args.warmup >= 0:
        parser.error("--seconds must be larger than --warmup, and --warmup >= 0")
    return args


# -- part 1: throughput ------------------------------------------------------------------------


def _stepper(env: gym.Env, rng: np.random.Generator | None):
    """A callable that steps ``env`` once (zero or random action), resetting when it ends."""
    zero = np.zeros(env.action_space.shape, env.action_space.dtype)
    lo, hi = env.action_space.low, env.action_space.high
    env.reset(seed=0)

    def step():
        a = zero if rng is None else rng.uniform(lo, hi).astype(env.action_space.dtype)
        _, _, term, trunc, _ = env.step(a)
        if term or trunc:
            env.reset()

    return step


def _raw_stepper(model: mujoco.MjModel):
    data = mujoco.MjData(model)
    if model.nkey:
        mujoco.mj_resetDataKeyframe(model, data, 0)

    def step():
        mujoco.mj_step(model, data)

    return step


def throughput(args: Args) -> tuple[list[str], dict[str, float]]:
    """Time the rows of part 1; return the table lines and the steps/s of each row."""
    walk = gym.make(WALK, max_episode_steps=-1)
    walk_rand = gym.make(WALK)
    ant = gym.make("Ant-v5")
    rows = {
        "walk_zero": (_stepper(walk, None), args.steps),
        "walk_random": (_stepper(walk_rand, np.random.default_rng(0)), args.steps),
        "ant_random": (_stepper(ant, np.random.default_rng(0)), args.steps),
        "walk_mj_step": (_raw_stepper(walk.unwrapped.model), 5 * args.steps),
        "ant_mj_step": (_raw_stepper(ant.unwrapped.model), 5 * args.steps),
    }
    for fn, _ in rows.values():
        for _ in range(50):  # warm up: JIT, caches
            fn()
    per_round: dict[str, list[float]] = {k: [] for k in rows}
    for _ in range(args.rounds):
        for name, (fn, n) in rows.items():
            k = max(1, n // args.rounds)
            t0 = time.perf_counter()
            for _ in range(k):
                fn()
            per_round[name].append(k / (time.perf_counter() - t0))
    rate = {k: float(np.median(v)) for k, v in per_round.items()}
    dt_walk, dt_ant = walk.unwrapped.dt, ant.unwrapped.dt
    ts_walk, ts_ant = walk.unwrapped.model.opt.timestep, ant.unwrapped.model.opt.timestep
    for env in (walk, walk_rand, ant):
        env.close()
    lines = [
        "| row | steps/s | step (s simulated) | simulated s per wall s | vs Ant-v5 env |",
        "|---|---:|---:|---:|---:|",
    ]
    table = (
        (f"`{WALK}`, zero actions (CPG walking)", "walk_zero", dt_walk),
        (f"`{WALK}`, random actions", "walk_random", dt_walk),
        ("`Ant-v5`, random actions", "ant_random", dt_ant),
        ("raw `mj_step`, our scene (robot + floor + 6 parked blocks)", "walk_mj_step", ts_walk),
        ("raw `mj_step`, Ant-v5 model", "ant_mj_step", ts_ant),
    )
    for label, key, dt in table:
        ratio = rate[key] / rate["ant_random"] if key.endswith(("zero", "random")) else None
        lines.append(
            f"| {label} | {rate[key]:,.0f} | {dt:g} | {rate[key] * dt:,.0f} "
            f"| {'' if ratio is None else f'{ratio:.2f}x'} |"
        )
    return lines, rate


# -- part 2 and 3: gait statistics ---------------------------------------------------------------


def _yaw(quat: np.ndarray) -> float:
    w, x, y, z = quat
    return float(np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)))


def run_gait(seed: int, seconds: float, warmup: float, provision=(0.0, 0.0, 0.0)) -> dict:
    """Walk ``seconds`` with zero interrupts and the given provision; return the statistics."""
    env = gym.make(WALK, max_episode_steps=-1)
    env.reset(seed=seed)
    u = env.unwrapped
    d = u.data
    foot_r = u.model.geom_size[u.robot.foot_geom, 0]
    n = int(round(seconds / u.dt))
    n0 = int(round(warmup / u.dt))
    action = np.zeros(15, np.float32)
    action[12:] = provision
    foot_z = np.zeros((n, 4))
    contact = np.zeros((n, 4), bool)
    hip = np.zeros((n, 4))
    xy = np.zeros((n, 2))
    yaw = np.zeros(n)
    energy = 0.0
    for t in range(n):
        _, _, term, trunc, info = env.step(action)
        if term or trunc:
            env.close()
            return {"fell": True, "t": t * u.dt, "seed": seed}
        foot_z[t] = d.site_xpos[u.robot.foot_site, 2] - foot_r
        contact[t] = d.sensordata[u.robot.touch_adr] > 1e-3
        hip[t] = u.generator.hip_drive
        xy[t] = d.qpos[:2]
        yaw[t] = _yaw(d.qpos[3:7])
        if t >= n0:
            energy += info["power"] * u.dt
    mass = u.robot.mass
    env.close()
    yaw = np.unwrap(yaw)[n0:]
    xy, foot_z, contact, hip = xy[n0:], foot_z[n0:], contact[n0:], hip[n0:]
    dur = (n - n0) * u.dt
    step = np.diff(xy, axis=0)
    heading_fwd = np.cos(yaw[:-1]) * step[:, 0] + np.sin(yaw[:-1]) * step[:, 1]
    heading_left = -np.sin(yaw[:-1]) * step[:, 0] + np.cos(yaw[:-1]) * step[:, 1]
    dist = float(np.linalg.norm(xy[-1] - xy[0]))
    peaks = []
    for leg in range(4):
        edges = np.flatnonzero(np.diff(contact[:, leg].astype(int)))
        p = [
            foot_z[i0 + 1 : i1 + 1, leg].max()
            for i0, i1 in zip(edges[:-1], edges[1:], strict=False)
            if not contact[i0 + 1, leg] and i1 - i0 >= 6
        ]
        peaks.append(np.array(p) if p else np.zeros(1))
    ups = np.flatnonzero(np.signbit(hip[:-1, 0]) & ~np.signbit(hip[1:, 0]))
    cc = np.corrcoef(hip.T)
    return {
        "fell": False,
        "seed": seed,
        "speed": float(xy[-1, 0] - xy[0, 0]) / dur,
        "vy": float(xy[-1, 1] - xy[0, 1]) / dur,
        "v_side": float(np.sum(heading_left)) / dur,
        "v_fwd": float(np.sum(heading_fwd)) / dur,
        "lateral": float(xy[-1, 1] - xy[0, 1]),
        "yaw_deg": float(np.degrees(yaw[-1] - yaw[0])),
        "yaw_rate": float(np.degrees(yaw[-1] - yaw[0])) / dur,
        "cot": energy / (mass * 9.81 * max(dist, 1e-6)),
        "duty": contact.mean(axis=0),
        "clear_med": np.array([np.median(p) for p in peaks]),
        "clear_p05": np.array([np.percentile(p, 5) for p in peaks]),
        "clear_max": np.array([p.max() for p in peaks]),
        "freq": 1.0 / (np.mean(np.diff(ups)) * u.dt) if len(ups) > 2 else 0.0,
        "trot": (cc[0, 3] + cc[1, 2]) / 2.0,
        "pair_anti": cc[0, 1],
    }


def gait_table(runs: list[dict]) -> list[str]:
    ok = [r for r in runs if not r["fell"]]
    fell = [r for r in runs if r["fell"]]
    lines = ["| statistic | median | mean | min | max |", "|---|---:|---:|---:|---:|"]

    def row(label, values, fmt="{:.3f}"):
        v = np.asarray(values, dtype=float)
        cells = [fmt.format(x) for x in (np.median(v), v.mean(), v.min(), v.max())]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")

    lines.append(f"| runs without a fall | {len(ok)} / {len(runs)} | | | |")
    if not ok:
        return lines
    row("forward speed, m/s", [r["speed"] for r in ok])
    row("cost of transport (mechanical)", [r["cot"] for r in ok], "{:.2f}")
    row("CPG frequency, Hz", [r["freq"] for r in ok], "{:.2f}")
    row("lateral drift over the run, m", [r["lateral"] for r in ok])
    row("heading change over the run, deg", [r["yaw_deg"] for r in ok], "{:+.1f}")
    row("trot: corr(FL,HR), corr(FR,HL) hip drives", [r["trot"] for r in ok])
    for i, leg in enumerate(LEGS):
        row(f"duty factor {leg}", [r["duty"][i] for r in ok], "{:.2f}")
    for key, what in (
        ("clear_med", "median over swings"),
        ("clear_p05", "5th percentile"),
        ("clear_max", "highest swing"),
    ):
        for i, leg in enumerate(LEGS):
            row(f"swing clearance {leg}, {what}, cm", [100 * r[key][i] for r in ok], "{:.1f}")
    if fell:
        lines.append("")
        lines.append("Falls: " + ", ".join(f"seed {r['seed']} at {r['t']:.2f} s" for r in fell))
    return lines


PROVISIONS = (
    ("none (all zero)", (0.0, 0.0, 0.0)),
    ("s_SAG = -0.5 (shorter stride)", (-0.5, 0.0, 0.0)),
    ("s_SAG = +0.5 (longer stride)", (0.5, 0.0, 0.0)),
    ("s_COR = +0.5 (side-step left)", (0.0, 0.5, 0.0)),
    ("s_COR = -0.5 (side-step right)", (0.0, -0.5, 0.0)),
    ("s_DIR = +0.5 (turn left)", (0.0, 0.0, 0.5)),
    ("s_DIR = -0.5 (turn right)", (0.0, 0.0, -0.5)),
)


def provision_table(args: Args) -> list[str]:
    lines = [
        "| provision (s_SAG, s_COR, s_DIR) | falls | forward m/s | sideways m/s (+ left) "
        "| turn deg/s (+ left) |",
        "|---|---:|---:|---:|---:|",
    ]
    for label, prov in PROVISIONS:
        runs = [
            run_gait(s, args.provision_seconds, args.warmup, prov)
            for s in range(args.provision_seeds)
        ]
        ok = [r for r in runs if not r["fell"]]

        def med(key, ok=ok):
            return f"{np.median([r[key] for r in ok]):+.3f}" if ok else "-"

        lines.append(
            f"| {label} | {len(runs) - len(ok)} / {len(runs)} | {med('v_fwd')} | {med('v_side')} "
            f"| {med('yaw_rate')} |"
        )
    return lines


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    load_before = os.getloadavg() if hasattr(os, "getloadavg") else None
    speed_lines, rate = throughput(args)
    load_after = os.getloadavg() if hasattr(os, "getloadavg") else None
    t0 = time.perf_counter()
    runs = [run_gait(s, args.seconds, args.warmup) for s in range(args.seeds)]
    gait_lines = gait_table(runs)
    prov_lines = provision_table(args) if args.provision_seeds else []
    wall = time.perf_counter() - t0

    from neurocog_gym.locomotion.gait import default_gait

    gait = default_gait()
    ratio = rate["walk_zero"] / rate["ant_random"]
    load = (
        f" Load average {load_before[0]:.2f} before, {load_after[0]:.2f} after the timing (the "
        "machine is shared; rows were timed interleaved)."
        if load_before and load_after
        else ""
    )
    command = "python scripts/bench_walk.py " + " ".join(sys.argv[1:] if argv is None else argv)
    report = [
        "# Walk-v3 benchmark",
        "",
        f"Command: `{command.strip()}`  ",
        f"Machine: {machine('mujoco', 'gymnasium', 'numpy', pinned=True)}  ",
        f"Gait: `assets/default_gait.json` ({gait.name!r}, tau_f = {gait.tau_f:g}).",
        "",
        "## 1. Throughput",
        "",
        f"Medians over {args.rounds} interleaved rounds, {args.steps} env steps (5x as many "
        "`mj_step`) per row, one process pinned to one core." + load,
        "",
        *speed_lines,
        "",
        f"Walk-v3 (zero actions) runs at {ratio:.2f}x the env steps/s of Ant-v5 (target >= 0.5x). "
        "One Walk-v3 step is 10 ms of simulated time (5 physics steps of 2 ms, the CPG and the "
        "motor-neuron pools), one Ant-v5 step is 50 ms (5 physics steps of 10 ms).",
        "",
        "## 2. Default gait on flat ground",
        "",
        f"{args.seeds} seeds x {args.seconds:g} s, zero actions, from the home pose with reset "
        f"noise; the first {args.warmup:g} s are left out. Statistics over seeds (definitions in "
        "the script's docstring). The env is made with `max_episode_steps=-1`: in Gymnasium "
        f"{gym.__version__} `max_episode_steps=None` keeps the registered 2000-step (20 s) limit.",
        "",
        *gait_lines,
        "",
    ]
    if prov_lines:
        report += [
            "## 3. Walking provision (same gait)",
            "",
            f"Medians over {args.provision_seeds} seeds x {args.provision_seconds:g} s, the "
            "provision held from the start, the first "
            f"{args.warmup:g} s left out.",
            "",
            *prov_lines,
            "",
        ]
    report.append(f"Parts 2 and 3 took {wall:.0f} s of wall time.")
    report.append("")
    text = "\n".join(report)
    print(text)
    if args.out:
        out = Path(args.out)
        out.parent.mkdir(parents=True, exist_ok=True)
        from neurocog_gym.io import atomic_write_text

        atomic_write_text(out, text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
