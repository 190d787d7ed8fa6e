"""Every recorded run of ``scripts/bench_env.py --part env``, one row each, from git history.

``bench_env.py`` overwrites ``docs/benchmarks_env.md`` with its latest run. The earlier runs are
in the repository's history: this script reads each committed version of that file (and the
working tree's, if it differs), takes the machine line and the rows of the obstacle env, Ant-v5
and the two parallel vector envs, and writes them as one table to
``docs/benchmarks_env_history.md``. Nothing is measured here; every figure is one that a run of
the benchmark wrote at the time.

    python scripts/env_speed_history.py
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
REL = "docs/benchmarks_env.md"
OUT = ROOT / "docs" / "benchmarks_env_history.md"

_ROWS = {
    "env": "full perception, default settings",
    "ant": "| `Ant-v5`, random actions |",
    "spin": "registered vector entry point",
    "async": "Gymnasium's `AsyncVectorEnv` |",
}


def _git(*args: str) -> str:
    return subprocess.run(
        ["git", *args], cwd=ROOT, check=True, capture_output=True, text=True
    ).stdout


def _cells(text: str, key: str) -> list[str] | None:
    for line in text.splitlines():
        if line.startswith("|") and _ROWS[key] in line:
            return [c.strip() for c in line.strip().strip("|").split("|")]
    return None


def parse(text: str) -> dict | None:
    """The figures of one version of the file, or None when it lacks the env rows."""
    env, ant = _cells(text, "env"), _cells(text, "ant")
    if env is None or ant is None:
        return None
    cpu = re.search(r"^Machine: ([^,]+),", text, re.M)
    row = {
        "cpu": cpu.group(1) if cpu else "?",
        "env": env[1],
        "ant": ant[1],
        "ratio": env[3].replace("x Ant-v5", " ×"),
        "spin": "",
        "async": "",
    }
    for key in ("spin", "async"):
        cells = _cells(text, key)
        if cells is not None:
            row[key] = cells[3].replace("x 1 env", " ×").replace("x paired", " × paired")
    return row


def main() -> None:
    versions = []
    log = _git("log", "--format=%h %cs", "--", REL).split("\n")
    for entry in filter(None, log):
        commit, date = entry.split()
        versions.append((commit, date, _git("show", f"{commit}:{REL}")))
    current = (ROOT / REL).read_text() if (ROOT / REL).exists() else ""
    if not versions or current != versions[0][2]:
        versions.insert(0, ("working tree", "uncommitted", current))
    lines = [
        "## Env throughput, every recorded run (`scripts/env_speed_history.py`)",
        "",
        "Each row is one run of `scripts/bench_env.py --part env` as committed in "
        f"`{REL}` (newest first); the machine is the one that run recorded. "
        "Ratios are within a run (Ant-v5 and one env in the same interleaved rounds). "
        "Regenerate with `python scripts/env_speed_history.py`.",
        "",
        "| commit | date | CPU | SuddenObstacle steps/s | Ant-v5 steps/s | × Ant-v5 "
        "| make_vec 2 envs (SpinVectorEnv) × 1 env | AsyncVectorEnv × 1 env |",
        "|---|---|---|---:|---:|---:|---|---|",
    ]
    for commit, date, text in versions:
        row = parse(text)
        if row is None:
            continue
        lines.append(
            f"| {commit} | {date} | {row['cpu']} | {row['env']} | {row['ant']} | {row['ratio']} "
            f"| {row['spin']} | {row['async']} |"
        )
    from neurocog_gym.io import atomic_write_text

    atomic_write_text(OUT, "\n".join(lines) + "\n")
    print("\n".join(lines))
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
