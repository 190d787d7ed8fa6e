"""Env steps/s of this checkout against an earlier commit, beside Ant-v5, in the same run.

A speed change is only believed when measured against what it replaced on the same machine at
the same time. This script checks the baseline commit out into a temporary git worktree, then
times, in interleaved rounds, one fresh process per row:

* ``NeuroCog/SuddenObstacle-v3`` (zero actions, resets inside) with the baseline's package
  (``PYTHONPATH`` points at the worktree);
* the same with this checkout's package;
* Gymnasium's ``Ant-v5`` with random actions (the reference of the issue's target).

It also checks that both trees give the same episode, bit for bit (qpos after every step of two
seeded episodes), so the speed-up is known not to have changed what the env computes.

    .venv/bin/python scripts/bench_env_compare.py --baseline 4fd0b6d --rounds 5 --seconds 8

Writes ``docs/generated/benchmarks_env_compare.md`` (``--out``).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

_RATE = r"""
import sys, time, numpy as np, gymnasium as gym
env_id, seconds = sys.argv[1], float(sys.argv[2])
if env_id.startswith("NeuroCog/"):
    import neurocog_gym  # noqa: F401
env = gym.make(env_id)
rng = np.random.default_rng(0)
zero = np.zeros(env.action_space.shape, env.action_space.dtype)
lo, hi = env.action_space.low, env.action_space.high
def act():
    if env_id.startswith("NeuroCog/"):
        return zero
    return rng.uniform(lo, hi).astype(env.action_space.dtype)
env.reset(seed=0)
for _ in range(200):  # warm-up: numba loads its cache, first episode settles
    _, _, te, tr, _ = env.step(act())
    if te or tr:
        env.reset()
n, t0 = 0, time.perf_counter()
while time.perf_counter() - t0 < seconds:
    _, _, te, tr, _ = env.step(act())
    n += 1
    if te or tr:
        env.reset()
print(n / (time.perf_counter() - t0))
"""

_TRAJ = r"""
import sys, hashlib, numpy as np, gymnasium as gym
import neurocog_gym  # noqa: F401
from neurocog_gym.policies import make_policy
h = hashlib.sha256()
for env_id in ("NeuroCog/SuddenObstacle-v3", "NeuroCog/StaticObstacle-v3"):
    for seed in (0, 1):
        env = gym.make(env_id)
        policy = make_policy("aef")
        obs, _ = env.reset(seed=seed)
        for _ in range(1000):
            obs, _, te, tr, info = env.step(policy(obs))
            h.update(env.unwrapped.data.qpos.tobytes())
            if te or tr:
                break
        h.update(info["outcome"].encode())
print(h.hexdigest())
"""


def _run(code: str, args: list[str], pythonpath: str | None) -> str:
    env = dict(os.environ)
    env.setdefault("MUJOCO_GL", "egl")
    if pythonpath:
        env["PYTHONPATH"] = pythonpath + os.pathsep + env.get("PYTHONPATH", "")
    out = subprocess.run(
        [sys.executable, "-c", code, *args], env=env, capture_output=True, text=True, cwd="/"
    )
    if out.returncode != 0:
        raise SystemExit(f"error: a timing process failed:\n{out.stderr[-2000:]}")
    return out.stdout.strip().splitlines()[-1]


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", required=True, help="git commit (or ref) to compare against")
    ap.add_argument("--rounds", type=int, default=5, help="interleaved rounds (median over them)")
    ap.add_argument("--seconds", type=float, default=8.0, help="timed seconds per row per round")
    ap.add_argument(
        "--out", type=Path, default=ROOT / "docs" / "generated" / "benchmarks_env_compare.md"
    )
    ap.add_argument("--note", default="", help="a paragraph appended to the section")
    args = ap.parse_args(argv)
    if args.rounds < 1 or not args.seconds > 0:
        ap.error("--rounds must be >= 1 and --seconds > 0")
    sys.path.insert(0, str(ROOT / "scripts"))
    from bench_env import _uptime, load_average

    from neurocog_gym.bench.machine import machine

    rev = subprocess.run(
        ["git", "-C", str(ROOT), "rev-parse", "--short", args.baseline],
        capture_output=True, text=True,
    )  # fmt: skip
    if rev.returncode != 0:
        ap.error(f"--baseline {args.baseline!r} is not a commit of this repository")
    base = rev.stdout.strip()
    head = subprocess.run(
        ["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True, text=True
    ).stdout.strip()
    dirty = bool(
        subprocess.run(
            ["git", "-C", str(ROOT), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True, text=True,
        ).stdout.strip()
    )  # fmt: skip
    with tempfile.TemporaryDirectory() as tmp:
        tree = str(Path(tmp) / "baseline")
        subprocess.run(
            ["git", "-C", str(ROOT), "worktree", "add", "--detach", "-q", tree, base], check=True
        )
        try:
            sudden = "NeuroCog/SuddenObstacle-v3"
            mark = " (uncommitted changes)" if dirty else ""
            rows = {
                f"`{sudden}`, baseline {base}": (sudden, tree),
                f"`{sudden}`, this tree {head}{mark}": (sudden, str(ROOT)),
                "`Ant-v5`, random actions": ("Ant-v5", None),
            }
            # The sameness check first: it also compiles both trees' numba caches (a fresh
            # worktree has none), so no timed round pays for compilation.
            same = _run(_TRAJ, [], tree) == _run(_TRAJ, [], str(ROOT))
            load0, up0 = load_average(), _uptime()
            rates: dict[str, list[float]] = {k: [] for k in rows}
            for r in range(args.rounds):
                for name, (env_id, path) in rows.items():
                    rates[name].append(float(_run(_RATE, [env_id, str(args.seconds)], path)))
                print(f"round {r + 1}/{args.rounds}: "
                      + ", ".join(f"{v[-1]:.0f}" for v in rates.values()), flush=True)  # fmt: skip
            load1, up1 = load_average(), _uptime()
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", tree])
    med = {k: statistics.median(v) for k, v in rates.items()}
    ant = med["`Ant-v5`, random actions"]
    names = list(rows)
    lines = [
        "## Env speed against an earlier commit (`scripts/bench_env_compare.py`)",
        "",
        f"Machine: {machine('mujoco', 'gymnasium', 'numpy')}.  ",
        f"`uptime` before: `{up0}`; after: `{up1}` (load {load0} / {load1}).",
        "",
        f"Command: `python scripts/bench_env_compare.py --baseline {args.baseline} --rounds "
        f"{args.rounds} --seconds {args.seconds:g}`. One fresh process per row and round, rows "
        f"interleaved, {args.seconds:g} s timed after 200 warm-up steps; medians over "
        f"{args.rounds} rounds (min–max in brackets); episode resets inside the timed steps. Both "
        "trees' numba caches are compiled (by the sameness check) before the first round.",
        "",
        "| row | env steps/s | × Ant-v5 | × baseline |",
        "|---|---:|---:|---:|",
    ]
    for k in names:
        v = rates[k]
        lines.append(
            f"| {k} | {med[k]:,.0f} ({min(v):,.0f}–{max(v):,.0f}) | {med[k] / ant:.2f} "
            f"| {med[k] / med[names[0]]:.2f} |"
        )
    paired = [t / b for b, t in zip(rates[names[0]], rates[names[1]], strict=True)]
    vs_ant = [t / a for t, a in zip(rates[names[1]], rates[names[2]], strict=True)]
    lines += [
        "",
        "Paired within each round (the rows of a round ran back to back, so a load change "
        "between rounds cancels): this tree / baseline "
        f"{statistics.median(paired):.2f} (rounds: {', '.join(f'{x:.2f}' for x in paired)}); "
        f"this tree / Ant-v5 {statistics.median(vs_ant):.2f} "
        f"(rounds: {', '.join(f'{x:.2f}' for x in vs_ant)}).",
        "",
        "Same episodes in both trees (qpos after every step and the outcome of two seeded "
        "`aef` episodes per obstacle task, SHA-256): "
        + (
            "**identical**."
            if same
            else "**different** — the change altered what the env computes."
        ),
        "",
    ]
    if args.note:
        lines += [args.note, ""]
    text = "\n".join(lines)
    print(text)
    sys.path.insert(0, str(ROOT))
    from neurocog_gym.io import atomic_write_text

    atomic_write_text(args.out, text)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
