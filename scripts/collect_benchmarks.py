"""Merge the per-benchmark sections (docs/benchmarks_*.md) into docs/benchmarks.md.

Each ``scripts/bench_*.py`` writes its own section with the command and the machine it ran on;
this script only concatenates them under one table of contents, in a fixed order.

Usage: python scripts/collect_benchmarks.py
"""

from __future__ import annotations

from pathlib import Path

ORDER = [
    "walk",
    "tof",
    "gng",
    "affordance",
    "perception",
    "attention",
    "nsga",
    "env",
    "env_history",
    "env_compare",
    "aef",
    "bench",
    "ppo",
    "soak",
]


def main() -> None:
    docs = Path(__file__).resolve().parent.parent / "docs"
    parts = sorted(docs.glob("benchmarks_*.md"))
    key = {p: (ORDER.index(p.stem[11:]) if p.stem[11:] in ORDER else 99, p.stem) for p in parts}
    parts.sort(key=key.get)
    lines = [
        "# Measured performance",
        "",
        "Every number here was measured by the script named in its section, on the machine named",
        "there; ratios are against a reference measured in the same run, times are medians.",
        "Regenerate a section by rerunning its script, then "
        "`python scripts/collect_benchmarks.py`.",
        "",
    ]
    lines += [f"- [{p.stem[11:]}](#{p.stem})" for p in parts]
    lines.append("")
    for p in parts:
        lines += [f'<a id="{p.stem}"></a>', "", p.read_text().rstrip(), "", "---", ""]
    from neurocog_gym.io import atomic_write_text

    atomic_write_text(docs / "benchmarks.md", "\n".join(lines))
    print(f"wrote {docs / 'benchmarks.md'} from {len(parts)} sections")


if __name__ == "__main__":
    main()
