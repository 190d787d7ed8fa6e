"""Re-run a sample of a finished benchmark run's trials here and compare them with its records.

Trials are deterministic for their seed, so a record kept from an earlier commit stays valid as
long as the env and the policy compute the same episode. This script checks that: it reads the
run's settings from ``summary.json``, re-runs every ``--every``-th trial of ``--scenario`` with
the code of this checkout and compares the episode fields of each record (outcome, passed,
touched, touch events, fell, time, steps, distance, obstacles; not the wall-clock timings).

    python scripts/recheck_trials.py runs/v4/blind runs/v4/aef --scenario static --every 10

Prints one line per differing trial and a tally; exits 1 if any trial differs.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from neurocog_gym.bench.runner import TrialSpec, load_trials, make_env, run_trial, trial_seed
from neurocog_gym.policies import make_policy

FIELDS = ("outcome", "passed", "touched", "touch_events", "fell", "time", "steps", "distance",
          "obstacles")  # fmt: skip


def recheck(run: Path, scenario: str, every: int, offset: int = 0) -> tuple[int, list[str]]:
    """Re-run every ``every``-th trial of ``scenario`` in ``run``; return (checked, differences)."""
    summary = run / "summary.json"
    if not summary.exists():
        raise FileNotFoundError(f"{summary} does not exist: not a finished bench run")
    config = json.loads(summary.read_text())["config"]
    kept = {r["index"]: r for r in load_trials(run) if r["scenario"] == scenario}
    if not kept:
        raise ValueError(f"{run} has no {scenario} trials")
    env = make_env(scenario, config["attention"], config["max_seconds"])
    policy = make_policy(config["policy"])
    diffs, checked = [], 0
    for i in sorted(kept)[offset::every]:
        spec = TrialSpec(scenario, i, trial_seed(config["run_seed"], scenario, i))
        rec = run_trial(env, policy, spec)
        checked += 1
        changed = {k: (rec[k], kept[i][k]) for k in FIELDS if rec[k] != kept[i][k]}
        if changed:
            diffs.append(f"{run} {scenario} {i}: {changed}")
    env.close()
    return checked, diffs


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=Path, help="bench run folders")
    ap.add_argument("--scenario", choices=("sudden", "static"), default="static")
    ap.add_argument("--every", type=int, default=10, help="re-run every k-th trial (default 10)")
    ap.add_argument("--offset", type=int, default=0, help="start at this trial (default 0)")
    args = ap.parse_args()
    if args.every < 1:
        ap.error(f"--every must be >= 1, got {args.every}")
    total, bad = 0, []
    for run in args.runs:
        checked, diffs = recheck(run, args.scenario, args.every, args.offset)
        total += checked
        bad += diffs
        print(f"{run}: {checked - len(diffs)} of {checked} {args.scenario} trials identical")
    for line in bad:
        print("DIFF", line)
    print(f"{total - len(bad)} of {total} re-run trials identical to the records")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
