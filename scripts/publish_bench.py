"""Publish finished benchmark runs: docs/bench/ (report with plots) and docs/benchmarks_bench.md.

    python scripts/publish_bench.py runs/bench_200/aef_provision runs/bench_final/aef ... \
        --commands "neurocog bench ..." --notes docs/bench_notes.md

The section lists Table 4 and Table 5 of every run side by side (from each run's
``trials.jsonl``), the commands that produced them, the machine, and an optional notes file
appended verbatim (what was tried on the controller).
"""

from __future__ import annotations

import argparse
import os
import platform
from pathlib import Path

from neurocog_gym import io as nio
from neurocog_gym.bench.report import _table4, _table5, load_run, write_report


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", help="bench run folders")
    ap.add_argument("--commands", nargs="*", default=[], help="the commands that made the runs")
    ap.add_argument("--notes", default=None, help="markdown appended to the section")
    ap.add_argument("--report-dir", default="docs/bench")
    ap.add_argument("--out", default="docs/benchmarks_bench.md")
    args = ap.parse_args()
    report = write_report(args.runs, args.report_dir)
    runs = [load_run(d) for d in args.runs]
    md = [
        "## Obstacle benchmark (Table 4, Table 5)",
        "",
        "Simulated trials of `NeuroCog/SuddenObstacle-v1` and `NeuroCog/StaticObstacle-v1` "
        "(outcomes do not depend on the machine's load). Full report with plots: "
        f"[{report}]({Path(report).relative_to('docs')}).",
        "",
        f"Machine: {platform.node()}, {os.cpu_count()} cores, Python {platform.python_version()}.",
        "",
        "Commands:",
        "",
        "```",
        *args.commands,
        "```",
        "",
    ]
    md += _table4(runs)
    md += ["", "Table 5 (failure analysis, surface similarity μ of the attention nodes):", ""]
    md += _table5(runs)
    if args.notes:
        md += ["", Path(args.notes).read_text().rstrip()]
    nio.atomic_write_text(args.out, "\n".join(md) + "\n")
    print(f"wrote {args.out} and {report}")


if __name__ == "__main__":
    main()
