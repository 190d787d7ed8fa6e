"""The roll reflex (``Gait.vestibular_gain``): how many walks fall under front-leg disturbances.

``NeuroCog/Walk-v3`` with the shipped gait (and optionally the knee-behind candidate body via
``NEUROCOG_ASSETS``), the gait's roll reflex gain varied. Per gain and per disturbance kind,
``--seeds`` walks of ``--seconds`` in which from 2 s on every ``--every``-th swing of each
front leg is disturbed the way a controller answering a block disturbs it
(``search_gait.walk_stats``): ``h`` a high step (knee interrupt +1 until the sole is 10 cm up),
``d`` a shortened step (from 0.1 s into the swing hip +1, knee -1 until the foot is down: the
drop a sudden block forces), ``o`` a step over (high step, 0.08 s of carry, down). A last
column walks undisturbed: speed, and falls. All in simulated time: the load does not matter.

    python scripts/bench_reflex.py [--gains 0,10,15,20] [--seeds 12] [--out FILE]
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from search_gait import walk_stats  # noqa: E402

from neurocog_gym.bench.machine import machine  # noqa: E402
from neurocog_gym.locomotion.gait import default_gait  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gains", default="0,10,15,20", help="vestibular gains, 1/s, comma-separated")
    ap.add_argument("--seeds", type=int, default=12, help="walks per gain and kind (seeds 0..)")
    ap.add_argument("--seconds", type=float, default=10.0, help="simulated seconds per walk")
    ap.add_argument("--every", type=int, default=2, help="every k-th front swing is disturbed")
    ap.add_argument("--kinds", default="hdo", help="disturbance kinds (h, d, o)")
    ap.add_argument("--out", type=Path, default=Path("docs/generated/benchmarks_reflex.md"))
    args = ap.parse_args()
    try:
        gains = [float(g) for g in args.gains.split(",")]
    except ValueError:
        ap.error(f"--gains must be comma-separated numbers, got {args.gains!r}")
    if args.seeds < 1 or args.every < 1 or not set(args.kinds) <= set("hdo"):
        ap.error("--seeds and --every must be >= 1 and --kinds letters of h, d, o")
    base = default_gait()
    t0 = time.time()
    head = [f"{k}: falls" for k in args.kinds] + ["undisturbed: falls", "undisturbed: speed m/s"]
    rows = []
    for gain in gains:
        gait = replace(base, vestibular_gain=gain)
        cells = []
        for kind in args.kinds:
            falls = sum(
                walk_stats(None, s, args.seconds, args.every, kind, gait=gait)["fell"]
                for s in range(args.seeds)
            )
            cells.append(f"{falls} of {args.seeds}")
        free = [walk_stats(None, s, args.seconds, gait=gait) for s in range(args.seeds)]
        ok = [r["speed"] for r in free if not r["fell"]]
        cells += [f"{sum(r['fell'] for r in free)} of {args.seeds}",
                  f"{np.median(ok):.2f}" if ok else "-"]  # fmt: skip
        rows.append(f"| {gain:g} | " + " | ".join(cells) + " |")
        print(rows[-1], flush=True)
    table = "\n".join(
        ["| gain (1/s) | " + " | ".join(head) + " |", "|---:|" + "---:|" * len(head), *rows]
    )
    text = (
        "## Roll reflex under front-leg disturbances (scripts/bench_reflex.py)\n\n"
        f"Command: `.venv/bin/python scripts/bench_reflex.py --gains {args.gains} --seeds "
        f"{args.seeds} --seconds {args.seconds:g} --every {args.every} --kinds {args.kinds}`  \n"
        f"Machine: {machine('mujoco', 'numpy')}; {time.time() - t0:.0f} s. Simulated time: "
        "the figures do not depend on the load.\n\n"
        f"Gait: {base.name} (the shipped one), `vestibular_gain` varied. Walk-v3, "
        f"{args.seconds:g} s per walk, from 2 s on every {args.every}. swing of each front leg "
        "disturbed (h high step, d shortened step, o step over; the script's docstring).\n\n"
        f"{table}\n"
    )
    from neurocog_gym.io import atomic_write_text

    atomic_write_text(args.out, text)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
