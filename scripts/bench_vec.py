"""Vector-env throughput: one env, SyncVectorEnv, SpinVectorEnv and BatchVectorEnv at N envs.

For each env id (default ``NeuroCog/SuddenObstacle-v3`` and ``NeuroCog/Walk-v3``) and each N
(default 2 and 8), env steps/s of

* one env stepped in this process (``gymnasium.make``, its own episode);
* one env at a time: the N envs of the vector rows, seeded and autoreset as ``SyncVectorEnv``
  does it, stepped in turn in this process with no vector env — one env's speed on exactly the
  episodes the vector rows step, the reference of their ratios (an obstacle episode's steps
  cost more once the block is in view, and a reset with the map's warm-up costs some 50 steps,
  so one env on another episode is a noisy reference);
* ``gymnasium.make_vec(id, N, vectorization_mode="sync")``: Gymnasium's ``SyncVectorEnv``;
* ``gymnasium.make_vec(id, N)``: the registered vector entry point's default, ``SpinVectorEnv``
  (env 0 in this process, the others in worker processes that wait on shared memory);
* ``gymnasium.make_vec(id, N, vector_backend="threads")``: ``BatchVectorEnv``, N sub-envs on
  one thread per CPU of this process.

Zero actions (CPG walking); the vector envs autoreset, and a single env resets when its episode
ends, inside the timed steps. Each round steps every sub-env of every row the same number of
times, so that all rows time the same stretch of their episodes. The rows are timed interleaved
in rounds (so load from other processes falls on every row alike) and reported as medians over
the rounds; each ratio is the median over rounds of the row's rate over the reference's rate
in the same round (in brackets: the lowest and highest round). The load average (``uptime``) is
recorded before and after each id. Writes ``--out`` (docs/generated/benchmarks_vec.md).

    python scripts/bench_vec.py
    python scripts/bench_vec.py --ids NeuroCog/Walk-v3 --ns 2 --rounds 3 --steps 50
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import subprocess
import sys
import time

import gymnasium as gym
import numpy as np

import neurocog_gym  # noqa: F401  (registers the env ids)
from neurocog_gym.bench.machine import field_doc, machine

TARGETS = {2: 1.85, 8: 1.9}
"""Issue 24: a batch env's env steps/s over one env's, on 2 cores, by N."""


@dataclasses.dataclass(frozen=True)
class Args:
    """Command-line arguments."""

    ids: tuple[str, ...] = ("NeuroCog/SuddenObstacle-v3", "NeuroCog/Walk-v3")
    """Env ids to measure."""
    ns: tuple[int, ...] = (2, 8)
    """Numbers of sub-envs."""
    rounds: int = 7
    """Interleaved timing rounds (medians over them)."""
    steps: int = 200
    """Steps of every sub-env per round and row, for an id whose step takes 0.6 ms (scaled by
    the measured step time of each id). Every row's sub-envs advance alike, so all rows time the
    same stretch of their episodes (an obstacle-env step costs more once the block is in view)."""
    out: str = "docs/generated/benchmarks_vec.md"
    """Markdown output ('' to skip)."""


def parse_args(argv: list[str] | None = None) -> Args:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for f in dataclasses.fields(Args):
        name = "--" + f.name.replace("_", "-")
        help_ = field_doc(__file__, f.name)
        if isinstance(f.default, tuple):
            kind = int if f.default and isinstance(f.default[0], int) else str
            parser.add_argument(name, nargs="+", type=kind, default=list(f.default), help=help_)
        else:
            parser.add_argument(name, type=type(f.default), default=f.default, help=help_)
    ns = vars(parser.parse_args(argv))
    args = Args(**{k: tuple(v) if isinstance(v, list) else v for k, v in ns.items()})
    if args.rounds < 1 or args.steps < 1:
        parser.error("--rounds and --steps must be positive")
    if any(n < 1 for n in args.ns):
        parser.error("--ns must be positive integers")
    unknown = [i for i in args.ids if i not in gym.registry]
    if unknown:
        parser.error(f"unknown env ids {unknown}")
    return args


def _uptime() -> str:
    try:
        return subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    except OSError:
        one, five, fifteen = os.getloadavg()
        return f"load average: {one:.2f}, {five:.2f}, {fifteen:.2f}"


def _one_env(env_id: str):
    env = gym.make(env_id)
    env.reset(seed=0)
    zero = np.zeros(env.action_space.shape, env.action_space.dtype)

    def step():
        _, _, term, trunc, _ = env.step(zero)
        if term or trunc:
            env.reset()

    return step, 1, env


def _serial(env_id: str, n: int):
    """N plain envs stepped one after another: one env's speed on the vector rows' episodes.

    Seeded and autoreset as ``SyncVectorEnv`` (env i reset with seed i, a finished env resets on
    its next step), so every vector row of this N steps these very episodes.
    """
    from gymnasium.vector.vector_env import AutoresetMode

    from neurocog_gym.envs.vector import _Slot

    slots = [_Slot(gym.make(env_id), AutoresetMode.NEXT_STEP) for _ in range(n)]
    for i, slot in enumerate(slots):
        slot.reset(i, None)
    space = slots[0].env.action_space
    zero = np.zeros(space.shape, space.dtype)

    def step():
        for slot in slots:
            slot.step(zero)

    class _Envs:
        def close(self):
            for slot in slots:
                slot.env.close()

    return step, n, _Envs()


def _vector(env_id: str, n: int, **kwargs):
    envs = gym.make_vec(env_id, num_envs=n, **kwargs)
    envs.reset(seed=0)
    zero = np.zeros((n, *envs.single_action_space.shape), envs.single_action_space.dtype)

    def step():
        envs.step(zero)

    return step, n, envs


def measure(env_id: str, args: Args) -> tuple[list[str], dict]:
    """The table of one env id; also returns ``{(row kind, n): median ratio}``."""
    load0 = _uptime()
    rows: dict[str, tuple] = {"one env": _one_env(env_id)}
    for n in args.ns:
        rows[f"serial {n}"] = _serial(env_id, n)
        rows[f"sync {n}"] = _vector(env_id, n, vectorization_mode="sync")
        rows[f"spin {n}"] = _vector(env_id, n)
        rows[f"batch {n}"] = _vector(env_id, n, vector_backend="threads")
    try:
        # warm up (JIT, caches, workers) and size the rounds by this id's step time
        t0 = time.perf_counter()
        for _ in range(50):
            rows["one env"][0]()
        step_s = (time.perf_counter() - t0) / 50
        for fn, _, _ in rows.values():
            for _ in range(10):
                fn()
        calls = max(16, int(args.steps * 6e-4 / step_s))
        rates: dict[str, list[float]] = {k: [] for k in rows}
        for _ in range(args.rounds):
            for name, (fn, per_call, _) in rows.items():
                t = time.perf_counter()
                for _ in range(calls):
                    fn()
                rates[name].append(calls * per_call / (time.perf_counter() - t))
    finally:
        for _, _, env in rows.values():
            env.close()
    load1 = _uptime()
    med = {k: float(np.median(v)) for k, v in rates.items()}
    # each row of N against one env on the same N episodes, round by round
    ratio = {k: np.array(v) / np.array(rates[f"serial {k.split()[-1]}"]) for k, v in rates.items()
             if k != "one env"}  # fmt: skip
    lines = [
        f"### `{env_id}`",
        "",
        f"`uptime` before: `{load0}`  ",
        f"`uptime` after: `{load1}`",
        "",
        f"One env: {1e3 / med['one env']:.3f} ms a step; {calls} steps of every sub-env per row "
        f"and round, {args.rounds} rounds.",
        "",
        "| vector env | N | env steps/s | x one env (rounds) | target | met |",
        "|---|---:|---:|---:|---:|:-:|",
        f"| one env (`gymnasium.make`), its own episode | 1 | {med['one env']:,.0f} | | | |",
    ]
    names = {
        "serial": "one env at a time: the N envs stepped in turn, no vector env (the reference)",
        "sync": "`SyncVectorEnv` (`vectorization_mode='sync'`)",
        "spin": "`SpinVectorEnv` (`make_vec` default)",
        "batch": "`BatchVectorEnv` (`vector_backend='threads'`)",
    }
    summary = {}
    for n in args.ns:
        for kind, label in names.items():
            r = ratio[f"{kind} {n}"]
            summary[(kind, n)] = float(np.median(r))
            target = TARGETS.get(n) if kind in ("spin", "batch") else None
            met = "" if target is None else ("yes" if np.median(r) >= target else "no")
            lines.append(
                f"| {label} | {n} | {med[f'{kind} {n}']:,.0f} | {np.median(r):.2f} "
                f"({r.min():.2f}-{r.max():.2f}) | {'' if target is None else f'>= {target}'} "
                f"| {met} |"
            )
    return lines + [""], summary


def main(argv: list[str] | None = None) -> None:
    from neurocog_gym.io import atomic_write_text

    args = parse_args(argv)
    cmd = "python scripts/bench_vec.py " + " ".join(sys.argv[1:] if argv is None else argv)
    lines = [
        "## Vector-env throughput (`scripts/bench_vec.py`)",
        "",
        f"Machine: {machine('mujoco', 'numba', 'gymnasium')}.",
        "",
        f"Command: `{cmd.strip()}`. Env steps/s over all sub-envs, zero actions, autoresets "
        "inside the timed steps; rows interleaved in rounds, medians over the rounds; ratios are "
        "the medians of the per-round ratios to one env at a time on the same N episodes in "
        "the same round (lowest-highest "
        "round in brackets). Targets: issue 24's for a batch env on 2 cores, beside the "
        "SpinVectorEnv and BatchVectorEnv rows.",
        "",
    ]
    for env_id in args.ids:
        table, _ = measure(env_id, args)
        lines += table
        print("\n".join(table), flush=True)
    if args.out:
        atomic_write_text(args.out, "\n".join(lines) + "\n")
        print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
