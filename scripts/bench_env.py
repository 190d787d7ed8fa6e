"""Obstacle-env throughput beside Gymnasium's Ant-v5, and PPO throughput beside PPO on Ant-v5.

Parts (each printed as a markdown table; all timed interleaved in rounds, so that load from other
processes falls on every row alike, and reported as medians over the rounds):

1. ``--part env``: env steps/s of ``NeuroCog/SuddenObstacle-v3`` with full perception at default
   settings (ToF 56 x 43 per sensor, numba caster, DD-GNG + affordances + effectivity every
   cycle), zero actions (CPG walking; an episode ends when the robot passes the block or at 7 s,
   and resets are counted in the time), beside ``Ant-v5`` with uniform random actions; the same
   env at full sensor resolution (224 x 172 per sensor, 154,112 rays a frame); and
   ``gymnasium.make_vec`` with 2 envs in the registered vector entry point's mode (our
   ``SpinVectorEnv``: env 0 in this process, env 1 in a spinning worker), in ``async`` mode
   (Gymnasium's ``AsyncVectorEnv``, one process each) and in ``sync`` mode against 1 env in this
   process (env steps/s = vector steps/s x 2; ratios also paired round by round); the lock-step
   ceiling of recorded step times under both parallel vector envs; then the time of each
   stage of an obstacle-env step at default and full resolution. Writes ``--out``
   (docs/generated/benchmarks_env.md).
2. ``--part ppo``: stable-baselines3 PPO training throughput (env steps/s of ``model.learn``,
   rollouts and updates) of ``scripts/train_ppo.py`` with the same hyper-parameters on
   ``NeuroCog/SuddenObstacle-v3`` and on ``Ant-v5``; optionally the success rates of finished
   ``neurocog bench`` runs (``--bench-runs``) side by side. Writes ``--ppo-out``
   (docs/generated/benchmarks_ppo.md).

The load average (``uptime``) is recorded before and after each part: on a shared machine the
absolute numbers move with it, the ratios much less.

    python scripts/bench_env.py --part env
    python scripts/bench_env.py --part ppo --bench-runs runs/bench_aef10 runs/bench_ppo10
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import subprocess
import sys
import time
import types
from pathlib import Path

import gymnasium as gym
import numpy as np

import neurocog_gym  # noqa: F401  (registers the env ids)
from neurocog_gym.bench.machine import field_doc, machine

SUDDEN = "NeuroCog/SuddenObstacle-v3"


@dataclasses.dataclass(frozen=True)
class Args:
    """Command-line arguments."""

    part: str = "env"
    """env, ppo or all."""
    rounds: int = 7
    """Interleaved timing rounds (medians over them)."""
    steps: int = 300
    """Timed env steps per round and row (Ant-v5: 5x as many)."""
    full_steps: int = 60
    """Timed env steps per round at full sensor resolution."""
    vec_steps: int = 150
    """Timed vector steps per round of the make_vec rows."""
    profile_steps: int = 400
    """Steps of the per-stage profile (part env; 0 skips it)."""
    ppo_steps: int = 4096
    """PPO env steps per round and env (over all its envs)."""
    ppo_rounds: int = 3
    """Interleaved PPO rounds."""
    ppo_envs: int = 2
    """Envs of each PPO run (subproc when > 1), as in scripts/train_ppo.py's default."""
    train_run: str = ""
    """A scripts/train_ppo.py run folder whose train_summary.json goes into the PPO section."""
    bench_runs: tuple[str, ...] = ()
    """neurocog bench run folders whose summary.json goes into the PPO section."""
    out: str = "docs/generated/benchmarks_env.md"
    """Markdown of part env ('' to skip)."""
    ppo_out: str = "docs/generated/benchmarks_ppo.md"
    """Markdown of part ppo ('' to skip)."""


def parse_args(argv: list[str] | None = None) -> Args:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for f in dataclasses.fields(Args):
        name = "--" + f.name.replace("_", "-")
        help_ = f"{field_doc(__file__, f.name)} (default {f.default!r})"
        if f.name == "bench_runs":
            parser.add_argument(name, nargs="*", default=[], help=help_)
        else:
            parser.add_argument(name, type=type(f.default), default=f.default, help=help_)
    ns = vars(parser.parse_args(argv))
    ns["bench_runs"] = tuple(ns["bench_runs"])
    args = Args(**ns)
    if args.part not in ("env", "ppo", "all"):
        parser.error(f"--part must be env, ppo or all, got {args.part!r}")
    counts = (args.rounds, args.steps, args.full_steps, args.vec_steps, args.ppo_steps,
              args.ppo_rounds, args.ppo_envs)  # fmt: skip
    if args.profile_steps < 0 or min(counts) < 1:
        parser.error("counts must be >= 1")
    return args


# -- machine -------------------------------------------------------------------------------------


def load_average() -> str:
    """The three load averages, as ``uptime`` prints them."""
    one, five, fifteen = os.getloadavg()
    return f"{one:.2f}, {five:.2f}, {fifteen:.2f}"


def _uptime() -> str:
    try:
        return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    except OSError:
        return f"load average: {load_average()}"


def _affinity() -> str:
    """A sentence on the CPUs this process may run on, if fewer than the machine's."""
    if not hasattr(os, "sched_getaffinity"):
        return ""
    cpus = sorted(os.sched_getaffinity(0))
    if len(cpus) >= (os.cpu_count() or 1):
        return ""
    return (
        f" Pinned (`taskset`) to CPU {', '.join(map(str, cpus))}: every row and the vector rows' "
        "worker processes share it, so the vector rows measure no parallel speed-up."
    )


# -- part env ------------------------------------------------------------------------------------


def _stepper(env, rng: np.random.Generator | None):
    """A callable that steps ``env`` once (zero or random action), resetting when it ends."""
    zero = np.zeros(env.action_space.shape, env.action_space.dtype)
    lo, hi = env.action_space.low, env.action_space.high
    env.reset(seed=0)

    def step():
        a = zero if rng is None else rng.uniform(lo, hi).astype(env.action_space.dtype)
        _, _, term, trunc, _ = env.step(a)
        if term or trunc:
            env.reset()

    return step, 1


def _vec_stepper(env_id: str, mode: str | None, n: int):
    envs = gym.make_vec(env_id, num_envs=n, vectorization_mode=mode)
    envs.reset(seed=list(range(n)))
    zero = np.zeros((n, *envs.single_action_space.shape), envs.single_action_space.dtype)

    def step():
        envs.step(zero)  # autoreset: a finished sub-env resets on its next step

    return step, n, envs


def _time_rows(rows: dict, rounds: int, per_round_out: dict | None = None) -> dict[str, float]:
    """Env steps/s of each row, median over interleaved rounds (rows: name -> (fn, per_call, n)).

    ``per_round_out``, if given, receives every round's rate of every row (for paired ratios).
    """
    for fn, _, n in rows.values():
        for _ in range(max(3, n // 10)):  # warm up: JIT, caches, worker start
            fn()
    per_round: dict[str, list[float]] = {k: [] for k in rows}
    for _ in range(rounds):
        for name, (fn, per_call, n) in rows.items():
            t0 = time.perf_counter()
            for _ in range(n):
                fn()
            per_round[name].append(n * per_call / (time.perf_counter() - t0))
    if per_round_out is not None:
        per_round_out.update(per_round)
    return {k: float(np.median(v)) for k, v in per_round.items()}


def _paired(per_round: dict, a: str, b: str) -> tuple[float, float, float]:
    """Median, min and max over rounds of row ``a``'s rate / row ``b``'s in the same round."""
    r = np.array(per_round[a]) / np.array(per_round[b])
    return float(np.median(r)), float(r.min()), float(r.max())


def part_env(args: Args) -> tuple[list[str], float]:
    """The throughput table and the one-env steps/s (the reference of :func:`part_vec`)."""
    from neurocog_gym.robot.tof import ToFParams

    load0, up0 = load_average(), _uptime()
    full = ToFParams.at_scale(1.0, backend="numba")
    sudden = gym.make(SUDDEN, max_episode_steps=700)
    sudden_full = gym.make(SUDDEN, tof=full)
    ant = gym.make("Ant-v5")
    rows = {}
    for name, env, rng, n in (
        ("sudden", sudden, None, args.steps),
        ("ant", ant, np.random.default_rng(0), 5 * args.steps),
        ("sudden_full", sudden_full, None, args.full_steps),
    ):
        fn, per = _stepper(env, rng)
        rows[name] = (fn, per, n)
    vec_envs = []
    for mode in (None, "async", "sync"):
        fn, per, envs = _vec_stepper(SUDDEN, mode, 2)
        rows[f"vec_{mode or 'spin'}_2"] = (fn, per, args.vec_steps)
        vec_envs.append(envs)
    spin_class = type(vec_envs[0]).__name__
    rays = full.n_rays
    per_round: dict[str, list[float]] = {}
    rate = _time_rows(rows, args.rounds, per_round)
    for e in (sudden, sudden_full, ant, *vec_envs):
        e.close()
    load1, up1 = load_average(), _uptime()
    r_ant = rate["sudden"] / rate["ant"]
    r_vec = rate["vec_async_2"] / rate["sudden"]
    r_spin = rate["vec_spin_2"] / rate["sudden"]
    p_spin, lo_spin, hi_spin = _paired(per_round, "vec_spin_2", "sudden")
    p_async = _paired(per_round, "vec_async_2", "sudden")[0]
    dt = 0.01
    lines = [
        "## Env throughput (`scripts/bench_env.py`)",
        "",
        f"Machine: {machine('mujoco', 'gymnasium', 'stable_baselines3', 'torch')}.{_affinity()}",
        f"Load average before / after: {load0} / {load1}  ",
        f"`uptime` before: `{up0}`  ",
        f"`uptime` after: `{up1}`",
        "",
        f"Command: `python scripts/bench_env.py --part env --rounds {args.rounds} --steps "
        f"{args.steps} --full-steps {args.full_steps} --vec-steps {args.vec_steps}`. One process "
        "(the default make_vec row adds one worker, the async row two); rows timed interleaved in "
        f"rounds, medians over {args.rounds} rounds (the vector rows' ratios: of the medians, and "
        "in brackets the median of the per-round paired ratios); episode resets are inside the "
        "timed steps.",
        "",
        "| row | env steps/s | simulated s per wall s | ratio | target | met |",
        "|---|---:|---:|---:|---:|:-:|",
        f"| `{SUDDEN}`, full perception, default settings (ToF 4 x 56 x 43), zero actions "
        f"| {rate['sudden']:,.0f} | {rate['sudden'] * dt:.1f} | {r_ant:.2f}x Ant-v5 "
        f"| >= 0.45x (issue 21), >= 0.75x (issue 24) "
        f"| {'yes' if r_ant >= 0.75 else 'issue 21 only' if r_ant >= 0.45 else 'no'} |",
        f"| `Ant-v5`, random actions | {rate['ant']:,.0f} | {rate['ant'] * 0.05:.1f} | 1 | | |",
        f"| `{SUDDEN}`, full-resolution sensing (4 x 224 x 172 = {rays:,} rays a frame) "
        f"| {rate['sudden_full']:,.0f} | {rate['sudden_full'] * dt:.2f} | | >= 100 steps/s "
        f"| {'yes' if rate['sudden_full'] >= 100 else 'no'} |",
        f"| `gymnasium.make_vec({SUDDEN!r}, 2)`: the registered vector entry point, "
        f"`{spin_class}` (neurocog_gym/envs/vector.py) | {rate['vec_spin_2']:,.0f} "
        f"| {rate['vec_spin_2'] * dt:.1f} | {r_spin:.2f}x 1 env ({p_spin:.2f}x paired, rounds "
        f"{lo_spin:.2f}-{hi_spin:.2f}) | >= 1.85x (issue 24) "
        f"| {'yes' if r_spin >= 1.85 else 'no'} |",
        f"| `gymnasium.make_vec({SUDDEN!r}, 2, 'async')`: Gymnasium's `AsyncVectorEnv` "
        f"| {rate['vec_async_2']:,.0f} | {rate['vec_async_2'] * dt:.1f} | {r_vec:.2f}x 1 env "
        f"({p_async:.2f}x paired) | >= 1.85x (issue 24) | {'yes' if r_vec >= 1.85 else 'no'} |",
        f"| `gymnasium.make_vec({SUDDEN!r}, 2, 'sync')` | {rate['vec_sync_2']:,.0f} "
        f"| {rate['vec_sync_2'] * dt:.1f} | {rate['vec_sync_2'] / rate['sudden']:.2f}x 1 env | | |",
        "",
        "Ant-v5's control step is 0.05 s (frame_skip 5 of 0.01 s); ours is 0.01 s. The async row "
        "is taken apart in the next section, with the lock-step ceiling both vector envs share.",
        "",
    ]
    return lines, rate["sudden"]


# -- why async does not scale here -----------------------------------------------------------------


class _StepClock(gym.Wrapper):
    """Records, inside a worker, how long each ``step`` takes and the gap until the next one."""

    def __init__(self, env):
        super().__init__(env)
        self.inside: list[float] = []
        self.between: list[float] = []
        self.calls: list[float] = []
        """Every step's and every later reset's time, in order (an autoreset is a vector step)."""
        self.resets = 0
        self._end: float | None = None

    def reset(self, **kwargs):
        t0 = time.perf_counter()
        out = self.env.reset(**kwargs)
        if self._end is not None:  # not the first reset: it takes a vector step's place
            self.calls.append(time.perf_counter() - t0)
            self.resets += 1
        return out

    def step(self, action):
        t0 = time.perf_counter()
        if self._end is not None:
            self.between.append(t0 - self._end)
        out = self.env.step(action)
        self._end = time.perf_counter()
        self.inside.append(self._end - t0)
        self.calls.append(self._end - t0)
        return out

    def clock(self) -> tuple[float, float]:
        """Median ms inside ``step`` and between steps (the worker waiting on the vector env)."""
        return float(np.median(self.inside) * 1e3), float(np.median(self.between) * 1e3)

    def samples(self) -> list[float]:
        """Every recorded time inside ``step``, s, in order."""
        return list(self.inside)

    def timeline(self) -> tuple[list[float], int]:
        """Step and reset times in order, s, and how many of them are resets."""
        return list(self.calls), self.resets


class _Replay(gym.Env):
    """Stand-in: each step busy-waits for the next of recorded step times; no observation, no info.

    Two of these under ``AsyncVectorEnv`` give the most any env with those step times can gain
    from Gymnasium's lock-step workers on this machine (the same CPU load per step, none of the
    env's Dict bookkeeping).
    """

    def __init__(self, times: list[float], offset: int = 0):
        self.observation_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (15,), np.float32)
        self._times = list(times)
        self._i = offset

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        return np.zeros(1, np.float32), {}

    def step(self, action):
        end = time.perf_counter() + self._times[self._i % len(self._times)]
        self._i += 1
        while time.perf_counter() < end:
            pass
        return np.zeros(1, np.float32), 0.0, False, False, {}


def _replay_rows(times: list[float], n: int) -> tuple[dict, list]:
    """Timing rows: the replay stand-in alone, two of it under ``AsyncVectorEnv`` and two under
    ``SpinVectorEnv`` (the second stand-in replays from the middle of the record)."""
    from neurocog_gym.envs.vector import SpinVectorEnv

    solo = _Replay(times)
    zero1 = np.zeros(15, np.float32)
    fns = [lambda: _Replay(times), lambda: _Replay(times, offset=len(times) // 2)]
    pair = gym.vector.AsyncVectorEnv(fns)
    spin = SpinVectorEnv(fns)
    for envs in (pair, spin):
        envs.reset(seed=[0, 1])
    zero2 = np.zeros((2, 15), np.float32)
    rows = {
        "stand-in alone": (lambda: solo.step(zero1), 1, n),
        "2 stand-ins, AsyncVectorEnv": (lambda: pair.step(zero2), 2, n),
        "2 stand-ins, SpinVectorEnv": (lambda: spin.step(zero2), 2, n),
    }
    return rows, [pair, spin]


def lock_step_bound(times: list[float]) -> float:
    """2 x mean step time / mean of the slower of two steps: the most a lock-step vector env of
    two envs with these step times can give (the second replays from the middle of the record),
    with free communication and cores that do not slow each other."""
    t = np.asarray(times, dtype=float)
    other = np.roll(t, -(len(t) // 2))
    return float(2.0 * t.mean() / np.maximum(t, other).mean())


class _Tiny(gym.Wrapper):
    """Control: the same env behind a 1-value observation and an empty info."""

    def __init__(self, env):
        super().__init__(env)
        self.observation_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)

    def reset(self, **kwargs):
        self.env.reset(**kwargs)
        return np.zeros(1, np.float32), {}

    def step(self, action):
        _, reward, terminated, truncated, _ = self.env.step(action)
        return np.zeros(1, np.float32), reward, terminated, truncated, {}


def _worker_env(index: int, pin: bool, wrap: str = "", clock: bool = False):
    """An env factory for AsyncVectorEnv: optionally pinned to its own CPU, wrapped, clocked."""

    parent = os.getpid()

    def make():
        # AsyncVectorEnv also calls the factory once in this process (to read the spaces):
        # pin only in the workers, or this process and every later child stays on one CPU.
        if pin and os.getpid() != parent and hasattr(os, "sched_setaffinity"):
            cpus = sorted(os.sched_getaffinity(0))
            os.sched_setaffinity(0, {cpus[index % len(cpus)]})
        env = gym.make(SUDDEN)
        if clock:
            env = _StepClock(env)
        if wrap == "flat":
            env = gym.wrappers.FlattenObservation(env)
        elif wrap == "tiny":
            env = _Tiny(env)
        return env

    return make


def _async_stepper(pin: bool, wrap: str = "", clock: bool = False):
    envs = gym.vector.AsyncVectorEnv([_worker_env(i, pin, wrap, clock) for i in range(2)])
    envs.reset(seed=[0, 1])
    zero = np.zeros((2, *envs.single_action_space.shape), envs.single_action_space.dtype)

    def step():
        envs.step(zero)

    return step, 2, envs


def _solo_rate(seconds: float) -> float:
    """Env steps/s of one SuddenObstacle env stepped in this process for ``seconds``."""
    env = gym.make(SUDDEN)
    step, _ = _stepper(env, None)
    for _ in range(200):
        step()
    n, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        step()
        n += 1
    rate = n / (time.perf_counter() - t0)
    env.close()
    return rate


def part_vec(args: Args, one_env: float) -> list[str]:
    """Async variants against one env, a tiny-observation control, two free processes."""
    import multiprocessing

    rows, opened = {}, []
    for name, pin, wrap in (
        ("plain", False, ""),
        ("workers pinned to one CPU each", True, ""),
        ("pinned + FlattenObservation", True, "flat"),
        ("control: 1-value observation, empty info", False, "tiny"),
    ):
        fn, per, envs = _async_stepper(pin, wrap)
        rows[name] = (fn, per, args.vec_steps)
        opened.append(envs)
    rate = _time_rows(rows, args.rounds)
    for e in opened:
        e.close()
    fn, _, envs = _async_stepper(True, clock=True)
    for _ in range(args.vec_steps * 2):
        fn()
    clocks = envs.call("clock")
    times = envs.call("samples")[0]
    timeline, n_resets = envs.call("timeline")[0]
    envs.close()
    inside = float(np.mean([c[0] for c in clocks]))
    between = float(np.mean([c[1] for c in clocks]))
    replay_rows, replay_envs = _replay_rows(times, args.vec_steps)
    replay = _time_rows(replay_rows, args.rounds)
    for e in replay_envs:
        e.close()
    ceiling = replay["2 stand-ins, AsyncVectorEnv"] / replay["stand-in alone"]
    ceiling_spin = replay["2 stand-ins, SpinVectorEnv"] / replay["stand-in alone"]
    bound = lock_step_bound(times)
    bound_resets = lock_step_bound(timeline)
    seconds = 5.0
    alone = _solo_rate(seconds)
    with multiprocessing.get_context("fork").Pool(2) as pool:
        pair = pool.map(_solo_rate, [seconds, seconds])
    lines = [
        "### Why two async workers do not give two envs' steps here",
        "",
        f"Same rounds; one env = {one_env:,.0f} steps/s (the first row above). Pinned: "
        "`os.sched_setaffinity` in the env factory; `FlattenObservation` makes the 15-key Dict "
        "observation one array; the control hides the observation and info behind a 1-value box "
        "and `{}` (no Dict bookkeeping at all).",
        "",
        "| `AsyncVectorEnv`, 2 envs | env steps/s | × one env |",
        "|---|---:|---:|",
    ]
    for name, r in rate.items():
        lines.append(f"| {name} | {r:,.0f} | {r / one_env:.2f} |")
    lines += [
        f"| two independent processes, each stepping its own env for {seconds:g} s (no vector "
        f"env) | {sum(pair):,.0f} | {sum(pair) / alone:.2f} × one process alone "
        f"({alone:,.0f}) |",
        "",
        f"In a pinned worker (median over {args.vec_steps * 2} steps): {inside:.2f} ms inside "
        f"`env.step`, then {between:.2f} ms until its next step arrives (waiting "
        f"{between / (inside + between):.0%} of the time). Two free env processes run at "
        f"{sum(pair) / alone:.2f} × one and the control without observation or info at "
        f"{rate['control: 1-value observation, empty info'] / one_env:.2f} ×, against "
        f"{rate['workers pinned to one CPU each'] / one_env:.2f} × for the full env pinned: the "
        "cores are there, Gymnasium's Dict bookkeeping is only part of the gap, the rest is the "
        "lock-step itself — each sub-millisecond step waits for the slower worker and a round "
        "trip through the main process.",
        "",
        f"Ceiling: a stand-in env that busy-waits, step by step, for the {len(times)} step times "
        f"recorded in that worker (median {np.median(times) * 1e3:.2f} ms; no observation, no "
        "info) runs at "
        f"{replay['stand-in alone']:,.0f} steps/s alone and "
        f"{replay['2 stand-ins, AsyncVectorEnv']:,.0f} as two under `AsyncVectorEnv` "
        f"(same rounds): {ceiling:.2f} ×. That is the most Gymnasium's lock-step workers can "
        "give any env with these step times on this machine, before any of our observation. "
        "Under `SpinVectorEnv` (one stand-in in this process, one in a spinning worker; shared "
        f"memory, no pipe) two of them run at {replay['2 stand-ins, SpinVectorEnv']:,.0f}: "
        f"{ceiling_spin:.2f} ×. The arithmetic bound of any lock-step pair on these times — "
        "each vector step as long as the slower of two recorded steps, with free communication "
        f"and cores that do not slow each other — is {bound:.2f} ×, and {bound_resets:.2f} × with "
        f"the {n_resets} autoresets of that worker's record among the step times (a reset takes "
        f"{np.median([t for t in timeline if t > 5e-3] or [0.0]) * 1e3:.0f} ms, and the other env "
        "waits it out); two free env processes "
        f"above reach {sum(pair) / alone:.2f} ×, i.e. each core runs an env "
        f"{sum(pair) / alone / 2:.0%} as fast as one alone.",
        "",
    ]
    return lines


# -- profile ---------------------------------------------------------------------------------------


RAW_POINT_KERNELS = {
    "view_edge_kernel": "  of which raw points cut by the top of the view (view_edge_kernel)",
    "refine_objects_kernel": "  of which raw-point object extents (refine_objects_kernel)",
}
"""Kernels of the attention pipeline's raw-point steps (perception/_affordance_kernels.py) that
the profile times: each scans the frame's points, on every control cycle an object is in view."""


def _section_profile(tof, steps: int) -> tuple[float, dict[str, float]]:
    """ms per env step spent in each stage of ``ObstacleEnv.step`` (wall-clock wrappers)."""
    import mujoco

    import neurocog_gym.envs.base as base
    import neurocog_gym.perception._affordance_kernels as affordance_kernels

    env = gym.make(SUDDEN, max_episode_steps=-1, **({"tof": tof} if tof is not None else {}))
    u = env.unwrapped
    acc: dict[str, float] = {}

    def wrap(obj, name, label):
        f = getattr(obj, name)

        def timed(*a, **k):
            t = time.perf_counter()
            r = f(*a, **k)
            acc[label] = acc.get(label, 0.0) + time.perf_counter() - t
            return r

        setattr(obj, name, timed)

    class _Mj:  # base.py calls mujoco.mj_step through its module global
        def __getattr__(self, n):
            return getattr(mujoco, n)

        @staticmethod
        def mj_step(*a, **k):
            t = time.perf_counter()
            mujoco.mj_step(*a, **k)
            acc["mj_step (5 substeps of 2 ms)"] = (
                acc.get("mj_step (5 substeps of 2 ms)", 0.0) + time.perf_counter() - t
            )

    original = base.mujoco
    originals = types.SimpleNamespace(
        **{
            n: getattr(affordance_kernels, n)
            for n in RAW_POINT_KERNELS
            if hasattr(affordance_kernels, n)
        }
    )
    base.mujoco = _Mj()
    try:
        wrap(u.tof, "maybe_sense", "ToF sensing (robot/tof.py)")
        wrap(u.pipeline, "step", "attention pipeline step (perception/pipeline.py)")
        wrap(u.pipeline.net, "update", "  of which DD-GNG learning cycle (net.update)")
        # The raw-point steps scan the whole frame (154,112 points at full resolution).
        for name, label in RAW_POINT_KERNELS.items():
            if hasattr(affordance_kernels, name):
                wrap(affordance_kernels, name, label)
        wrap(u.effectivity, "step", "effectivity (locomotion/effectivity.py)")
        wrap(u, "_check_blocks", "outcome: contacts, stand, knock, step-over (envs/obstacle.py)")
        wrap(u, "_get_obs", "observation (envs/obstacle.py _get_obs)")
        wrap(u.generator, "step", "CPG + motor-neuron pools (locomotion/generator.py)")
        wrap(u, "_sim_unstable", "fault check (envs/base.py _sim_unstable)")
        wrap(u, "_check_action", "action check (envs/base.py _check_action)")
        wrap(u, "_task_event", "sudden-obstacle event (envs/sudden.py)")
        env.reset(seed=0)
        zero = np.zeros(15, np.float32)
        for _ in range(100):
            env.step(zero)
        acc.clear()
        t0 = time.perf_counter()
        for _ in range(steps):
            env.step(zero)
        total = time.perf_counter() - t0
    finally:
        base.mujoco = original
        for name in RAW_POINT_KERNELS:
            if hasattr(originals, name):
                setattr(affordance_kernels, name, getattr(originals, name))
        env.close()
    return 1e3 * total / steps, {k: 1e3 * v / steps for k, v in acc.items()}


def part_profile(args: Args) -> list[str]:
    from neurocog_gym.robot.tof import ToFParams

    load0 = load_average()
    default_ms, default = _section_profile(None, args.profile_steps)
    full_ms, full = _section_profile(ToFParams.at_scale(1.0, backend="numba"), args.profile_steps)
    load1 = load_average()
    # Top-level stages by time, each followed by the stages inside it ("  of which ...").
    parent = {
        "  of which DD-GNG learning cycle (net.update)": "attention pipeline step "
        "(perception/pipeline.py)",
        **{
            label: "attention pipeline step (perception/pipeline.py)"
            for label in RAW_POINT_KERNELS.values()
        },  # fmt: skip
        "  of which proprioception (envs/base.py)": "observation (envs/obstacle.py _get_obs)",
    }
    keys = []
    names = list(default) + [k for k in full if k not in default]
    for k in sorted((k for k in names if k not in parent), key=lambda k: -default.get(k, 0.0)):
        keys += [k] + sorted(
            (c for c in names if parent.get(c) == k), key=lambda c: -default.get(c, 0.0)
        )
    lines = [
        "### Where an obstacle-env step goes",
        "",
        f"`{SUDDEN}`, zero actions, {args.profile_steps} steps after 100 warm-up steps (no "
        "reset inside), each stage timed by a wall-clock wrapper; the rest is the step's own "
        f"Python (rewards, info, outcome, Gymnasium wrappers). Load average {load0} / {load1}.",
        "",
        "| stage | default ms/step | share | full resolution ms/step | share |",
        "|---|---:|---:|---:|---:|",
    ]
    for k in keys:
        lines.append(
            f"| {k} | {default.get(k, 0.0):.3f} | {100 * default.get(k, 0.0) / default_ms:.0f} % "
            f"| {full.get(k, 0.0):.3f} | {100 * full.get(k, 0.0) / full_ms:.0f} % |"
        )
    lines += [f"| **whole step** | {default_ms:.3f} | 100 % | {full_ms:.3f} | 100 % |", ""]
    return lines


# -- part ppo ------------------------------------------------------------------------------------


def _ppo_rate(
    env_id: str, args: Args, seed: int, vec: str = "subproc", n_envs: int | None = None
) -> float:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import tempfile

    import train_ppo

    with tempfile.TemporaryDirectory() as tmp:
        # The settings this section names (train_ppo's defaults when it was first measured).
        a = train_ppo.Args(
            env_id=env_id, total_steps=args.ppo_steps, n_envs=n_envs or args.ppo_envs, seed=seed,
            vec=vec, n_steps=512, batch_size=256, normalize_obs=False, checkpoint_every=10**9,
            out=tmp, tensorboard=False,
        )  # fmt: skip
        return float(train_ppo.train(a)["steps_per_s"])


def _bench_rows(folders: tuple[str, ...]) -> list[str]:
    if not folders:
        return []
    lines = [
        "### Success rates (`neurocog bench`)",
        "",
        "| run | policy | scenario | trials | success | touch | fail | success incl. touch |",
        "|---|---|---|---:|---:|---:|---:|---:|",
    ]
    for folder in folders:
        s = json.loads((Path(folder) / "summary.json").read_text())
        trials = [json.loads(x) for x in (Path(folder) / "trials.jsonl").read_text().splitlines()
                  if x.strip()]  # fmt: skip
        policy = trials[0].get("policy", "?") if trials else "?"
        policy = Path(policy).name if policy not in ("aef", "blind") else policy
        for scen in ("sudden", "static"):
            if scen not in s:
                continue
            c = s[scen]
            n = c["trials"]
            lines.append(
                f"| `{folder}` | {policy} | {scen} | {n} | {c['success']} | {c['touch']} | "
                f"{c['fail']} | {100 * (c['success'] + c['touch']) / max(n, 1):.0f} % |"
            )
    return lines + [""]


def part_ppo(args: Args) -> list[str]:
    load0, up0 = load_average(), _uptime()
    runs = {
        SUDDEN: (SUDDEN, "subproc", None),
        "spin": (SUDDEN, "spin", None),
        "one": (SUDDEN, "dummy", 1),
        "Ant-v5": ("Ant-v5", "subproc", None),
    }
    rates: dict[str, list[float]] = {k: [] for k in runs}
    for r in range(args.ppo_rounds):
        for key, (env_id, vec, n) in runs.items():
            rates[key].append(_ppo_rate(env_id, args, seed=r, vec=vec, n_envs=n))
            print(f"round {r}: PPO on {env_id} ({vec}): {rates[key][-1]:.0f} steps/s", flush=True)
    med = {k: float(np.median(v)) for k, v in rates.items()}
    load1, up1 = load_average(), _uptime()
    lines = [
        "## PPO (stable-baselines3) on the obstacle task (`scripts/train_ppo.py`)",
        "",
        f"Machine: {machine('mujoco', 'gymnasium', 'stable_baselines3', 'torch')}.{_affinity()}",
        f"Load average before / after: {load0} / {load1}  ",
        f"`uptime` before: `{up0}`  ",
        f"`uptime` after: `{up1}`",
        "",
        f"Command: `python scripts/bench_env.py --part ppo --ppo-steps {args.ppo_steps} "
        f"--ppo-rounds {args.ppo_rounds} --ppo-envs {args.ppo_envs}`. Each round trains a fresh "
        f"PPO for {args.ppo_steps} env steps on each env in turn with `scripts/train_ppo.py` "
        f"({args.ppo_envs} env(s), SB3's SubprocVecEnv unless the row says otherwise, n_steps "
        "512, batch 256, 10 epochs, "
        "128x128 networks, no observation normalisation, torch 1 thread); steps/s is env "
        "steps over the wall time of "
        "`model.learn` (rollouts and updates); medians over the rounds.",
        "",
        "| env | policy | PPO env steps/s | rounds | vs Ant-v5 |",
        "|---|---|---:|---|---:|",
        f"| `{SUDDEN}` | MultiInputPolicy | {med[SUDDEN]:,.0f} | "
        f"{', '.join(f'{x:,.0f}' for x in rates[SUDDEN])} | {med[SUDDEN] / med['Ant-v5']:.2f}x |",
        f"| `{SUDDEN}`, `--vec spin` (neurocog_gym.envs.sb3_vec.SpinVecEnv) | MultiInputPolicy "
        f"| {med['spin']:,.0f} | {', '.join(f'{x:,.0f}' for x in rates['spin'])} "
        f"| {med['spin'] / med['Ant-v5']:.2f}x ({med['spin'] / med[SUDDEN]:.2f}x SubprocVecEnv, "
        f"{med['spin'] / med['one']:.2f}x one env) |",
        f"| `{SUDDEN}`, 1 env, `--vec dummy` | MultiInputPolicy | {med['one']:,.0f} "
        f"| {', '.join(f'{x:,.0f}' for x in rates['one'])} | {med['one'] / med['Ant-v5']:.2f}x |",
        f"| `Ant-v5` | MlpPolicy | {med['Ant-v5']:,.0f} | "
        f"{', '.join(f'{x:,.0f}' for x in rates['Ant-v5'])} | 1 |",
        "",
    ]
    return lines + trained_policy_lines(args.train_run, args.bench_runs)


def trained_policy_lines(train_run: str, bench_runs: tuple[str, ...]) -> list[str]:
    """The "trained policy" subsection: a train_ppo run's summary and its bench rows."""
    lines = []
    if train_run:
        t = json.loads((Path(train_run) / "train_summary.json").read_text())
        a = json.loads((Path(train_run) / "args.json").read_text())
        fails = t.get("fails_this_session")
        blocks = t.get("sudden_blocks_this_session")
        lines += [
            "### The trained policy",
            "",
            f"`{train_run}`: {t['total_steps']:,} env steps of `{t['env_id']}` in "
            f"{t['wall_s'] / 60:.0f} min ({t['steps_per_s']} steps/s, {t['n_envs']} envs, "
            f"{t['vec']}; arguments in `args.json`: seed {a['seed']}, n_steps {a['n_steps']}, "
            f"batch {a['batch_size']}, lr {a['learning_rate']}, log_std_init {a['log_std_init']}, "
            f"target_kl {a.get('target_kl', 0.0)}, gamma {a['gamma']}, observation "
            f"normalisation {'on' if a.get('normalize_obs') else 'off'}). "
            f"Outcomes of its training episodes (stochastic actions): "
            f"{t['outcomes_this_session']}"
            + (f", the fails {fails['fell']} fell and {fails['stuck']} stuck" if fails else "")
            + (
                f"; sudden blocks that appeared only at the deadline {blocks['forced']}, never "
                f"{blocks['none']}"
                if blocks
                else ""
            )
            + ". Evaluated with deterministic actions by `neurocog bench --policy MODEL` "
            "(trials per row below), beside the other controllers:",
            "",
        ]
    return lines + _bench_rows(bench_runs)


def main(argv: list[str] | None = None) -> None:
    from neurocog_gym.io import atomic_write_text

    args = parse_args(argv)
    if args.part in ("env", "all"):
        lines, one_env = part_env(args)
        lines += part_vec(args, one_env)
        if args.profile_steps:
            lines += part_profile(args)
        print("\n".join(lines))
        if args.out:
            atomic_write_text(args.out, "\n".join(lines) + "\n")
            print(f"wrote {args.out}")
    if args.part in ("ppo", "all"):
        lines = part_ppo(args)
        print("\n".join(lines))
        if args.ppo_out:
            atomic_write_text(args.ppo_out, "\n".join(lines) + "\n")
            print(f"wrote {args.ppo_out}")


if __name__ == "__main__":
    main()
