"""The benchmark report: our Table 4 and Table 5 beside the paper's, with plots.

:func:`write_report` reads one or more run folders (each written by
:func:`neurocog_gym.bench.runner.run_benchmark`) and writes ``report.md`` and PNG plots next to
it. Several runs (AEF, blind, attention off, ...) appear side by side.
"""

from __future__ import annotations

import math
import os
import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from neurocog_gym import io
from neurocog_gym.bench.outcome import (
    OUTCOMES,
    PAPER_TABLE4,
    PAPER_TABLE5,
    SCENARIOS,
    failure_analysis,
    scenario_summary,
    wilson_interval,
)
from neurocog_gym.bench.records import load_trials

COLOURS = {"success": "#2e7d32", "touch": "#f9a825", "fail": "#c62828"}


@dataclass
class Run:
    """One run folder: its label, config and trial records."""

    path: Path
    label: str
    config: dict
    records: list[dict]

    @property
    def scenarios(self) -> list[str]:
        """Scenarios with at least one finished trial, in the paper's order."""
        have = {r["scenario"] for r in self.records}
        return [s for s in SCENARIOS if s in have]

    def of(self, scenario: str) -> list[dict]:
        """Records of one scenario, by index."""
        return sorted(
            (r for r in self.records if r["scenario"] == scenario), key=lambda r: r["index"]
        )


def load_run(path: str | os.PathLike) -> Run:
    """Read a run folder (``trials.jsonl`` and, if there, ``summary.json``)."""
    path = Path(path)
    if not path.is_dir():
        raise FileNotFoundError(f"run folder {path} does not exist")
    if not (path / "trials.jsonl").exists():
        raise FileNotFoundError(f"{path} has no trials.jsonl (not a benchmark run folder)")
    records = load_trials(path)
    config = {}
    if (path / "summary.json").exists():
        import json

        config = json.loads((path / "summary.json").read_text(encoding="utf-8")).get("config", {})
    if records:
        config = {"policy": records[0].get("policy"), "attention": records[0].get("attention"),
                  **config}  # fmt: skip
    return Run(path=path, label=run_label(config), config=config, records=records)


def run_label(config: dict) -> str:
    """Short name of a run: policy (model file stem) and attention setting."""
    policy = str(config.get("policy") or "?")
    names = {
        "aef": "AEF",
        "aef-provision": "AEF provision only",
        "blind": "blind",
        "avoid": "avoid reflex + AEF provision",
        "oracle": "oracle (privileged step-over)",
        "ppo": "PPO (shipped, v0 envs)",  # trained and benched on v0; v1 refuses it
    }
    if policy not in names:
        policy = Path(policy).stem
    name = names.get(policy, policy)
    label = f"{name}, attention {config.get('attention') or 'on'}"
    seed = config.get("seed")
    return label if seed in (None, 0) else f"{label}, seed {seed}"


def _slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-") or "run"


def _pct(x: float | None) -> str:
    return "–" if x is None else f"{100 * x:.0f} %"


def _ci(k: int, n: int) -> str:
    if n == 0:
        return "–"
    lo, hi = wilson_interval(k, n)
    return f"{100 * k / n:.0f} % [{100 * lo:.0f}, {100 * hi:.0f}]"


def _f(x, fmt: str = ".2f") -> str:
    return "–" if x is None or (isinstance(x, float) and not math.isfinite(x)) else format(x, fmt)


def _limit(max_seconds) -> str:
    if max_seconds is None:
        return "as registered (7 s sudden, 10 s static)"
    return f"{max_seconds:g} s"


def _table4(runs: list[Run]) -> list[str]:
    lines = [
        "| Scenario | Run | Trials | Success | Touch | Fail | Success (never touched) [95 % CI] "
        "| Success incl. touch [95 % CI] |",
        "|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    for s in SCENARIOS:
        rows = [("**paper (real robot)**", PAPER_TABLE4[s])]
        rows += [(run.label, scenario_summary(run.of(s))) for run in runs if run.of(s)]
        for label, c in rows:
            n = c["trials"]
            lines.append(
                f"| {s} | {label} | {n} | {c['success']} | {c['touch']} | {c['fail']} | "
                f"{_ci(c['success'], n)} | {_ci(c['success'] + c['touch'], n)} |"
            )
    return lines


def _table5(runs: list[Run]) -> list[str]:
    lines = [
        "| Run | Scenario | Case | n | Best similarity (mean) | Time to best, s (mean) "
        "| Similarity at 0.5 s (mean) |",
        "|---|---|---|---:|---:|---:|---:|",
    ]
    for case, name in (("success", "success"), ("fail", "failed")):
        p = PAPER_TABLE5[case]
        lines.append(f"| **paper (real robot)** | – | {name} | – | {p['best']:.2f} | "
                     f"{p['time_to_best']:.2f} | {p['at_0_5']:.2f} |")  # fmt: skip
    for run in runs:
        groups = [(s, run.of(s)) for s in run.scenarios]
        if len(groups) > 1:
            groups.append(("all", run.records))
        for scen, recs in groups:
            fa = failure_analysis(recs)
            for case, name in (("success", "passed"), ("fail", "failed")):
                g = fa[case]
                lines.append(f"| {run.label} | {scen} | {name} | {g['n']} | {_f(g['best'])} | "
                             f"{_f(g['time_to_best'])} | {_f(g['at_0_5'])} |")  # fmt: skip
    return lines


def _other(runs: list[Run]) -> list[str]:
    lines = [
        "| Run | Scenario | Mean time to pass, s | Touch events / trial | Knocked | Stood on "
        "| Stepped over | Falls | Unstable | Perception ms / cycle (mean, max) | Wall s / trial |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for run in runs:
        for s in run.scenarios:
            recs = run.of(s)
            c = scenario_summary(recs)
            wall = np.mean([r.get("wall_s") or 0.0 for r in recs])
            lines.append(
                f"| {run.label} | {s} | {_f(c['mean_time_to_pass_s'])} | "
                f"{_f(c['mean_touch_events'], '.1f')} | {c['knocked']} | {c['stood_on']} | "
                f"{c['stepped_over']} | {c['falls']} | {c['sim_unstable']} | "
                f"{_f(c['perception_ms_mean'], '.2f')}, {_f(c['perception_ms_max'], '.1f')} | "
                f"{wall:.1f} |"
            )
    return lines


# -- plots --------------------------------------------------------------------------------------


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_outcomes(runs: list[Run], path: Path) -> Path:
    """Stacked outcome bars per scenario: the paper and every run."""
    plt = _pyplot()
    scen = [s for s in SCENARIOS if any(run.of(s) for run in runs)]
    n_bars = 1 + len(runs)
    fig, axes = plt.subplots(
        1, len(scen), figsize=(6 * len(scen), 0.6 * n_bars + 1.4), squeeze=False
    )
    for ax, s in zip(axes[0], scen, strict=True):
        rows = [("paper (real robot)", PAPER_TABLE4[s])]
        rows += [(run.label, scenario_summary(run.of(s))) for run in runs if run.of(s)]
        for y, (_, c) in enumerate(rows):
            n = c["trials"]
            left = 0.0
            for o in OUTCOMES:
                w = c[o] / n if n else 0.0
                ax.barh(y, w, left=left, color=COLOURS[o], label=o if y == 0 else None)
                if c[o]:
                    ax.text(
                        left + w / 2,
                        y,
                        str(c[o]),
                        ha="center",
                        va="center",
                        fontsize=8,
                        color="white",
                    )
                left += w
        ax.set_yticks(range(len(rows)), [f"{lbl} (n={c['trials']})" for lbl, c in rows], fontsize=8)
        ax.invert_yaxis()
        ax.set_xlim(0, 1)
        ax.set_xlabel("fraction of trials")
        ax.set_title(f"{s} obstacle")
    fig.legend(*axes[0][0].get_legend_handles_labels(), loc="lower center", ncol=3, fontsize=8)
    fig.tight_layout(rect=(0, 0.12, 1, 1))
    io.atomic_savefig(fig, path, dpi=110)
    plt.close(fig)
    return path


def _curve_on_grid(sim: dict, grid: np.ndarray) -> np.ndarray:
    """A trial's μ(t) as a step function on ``grid`` (NaN outside its samples)."""
    t = np.asarray(sim.get("t") or [], dtype=float)
    mu = np.asarray(sim.get("mu") or [], dtype=float)
    out = np.full(grid.shape, np.nan)
    if len(t) == 0:
        return out
    idx = np.searchsorted(t, grid + 1e-9, side="right") - 1
    ok = (idx >= 0) & (grid <= t[-1] + 1e-9)
    out[ok] = mu[idx[ok]]
    return out


def plot_similarity(runs: list[Run], path: Path, window: float = 2.0) -> Path:
    """μ(t) after the obstacle appears: passed (green) vs failed (red) trials, with the means."""
    plt = _pyplot()
    scen = [s for s in SCENARIOS if any(run.of(s) for run in runs)]
    fig, axes = plt.subplots(len(runs), len(scen), figsize=(5.5 * len(scen), 3.0 * len(runs)),
                             squeeze=False, sharey=True)  # fmt: skip
    grid = np.arange(0.0, window + 1e-9, 0.05)
    for i, run in enumerate(runs):
        for j, s in enumerate(scen):
            ax = axes[i][j]
            for case, colour in (("passed", COLOURS["success"]), ("failed", COLOURS["fail"])):
                recs = [r for r in run.of(s) if (r["outcome"] == "fail") == (case == "failed")]
                curves = [
                    _curve_on_grid(r["similarity"], grid) for r in recs if r.get("similarity")
                ]
                for c in curves:
                    ax.plot(grid, c, color=colour, alpha=0.15, lw=0.7)
                if curves:
                    with warnings.catch_warnings():  # all-NaN columns: no trial that long
                        warnings.simplefilter("ignore", RuntimeWarning)
                        mean = np.nanmean(np.array(curves), axis=0)
                    ax.plot(
                        grid, mean, color=colour, lw=2.2, label=f"{case} mean (n={len(curves)})"
                    )
            ax.axvline(0.5, color="grey", ls=":", lw=1)
            ax.set_ylim(0, 1.02)
            ax.set_title(f"{run.label}: {s}", fontsize=9)
            ax.set_xlabel("s after the obstacle appeared / came into view")
            if j == 0:
                ax.set_ylabel("similarity μ (Eq. 16)")
            if ax.get_legend_handles_labels()[0]:  # no curve when no trial of a case passed
                ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    io.atomic_savefig(fig, path, dpi=110)
    plt.close(fig)
    return path


def plot_timeline(run: Run, path: Path) -> Path:
    """Per-trial timeline: one row per trial, its duration coloured by outcome.

    Markers: when the obstacle appeared (|), the first touch (x) and the pass (>).
    """
    plt = _pyplot()
    rows = [r for s in run.scenarios for r in run.of(s)]
    fig, ax = plt.subplots(figsize=(8, 0.16 * len(rows) + 1.4))
    for y, r in enumerate(rows):
        ax.barh(y, r["time"], color=COLOURS[r["outcome"]], alpha=0.55, height=0.8)
        if r.get("appeared_at") is not None and r["scenario"] == "sudden":
            ax.plot(r["appeared_at"], y, "|", color="black", ms=6)
        seen = (r.get("similarity") or {}).get("t0")
        if seen is not None and r["scenario"] == "static":
            ax.plot(seen, y, "|", color="dimgrey", ms=6)
        first = (r.get("contacts") or {}).get("first_at")
        if first is not None:
            ax.plot(first, y, "x", color="black", ms=4)
        if r.get("passed"):
            ax.plot(r["time"], y, ">", color="black", ms=4)
    ax.set_yticks(range(len(rows)), [f"{r['scenario'][:2]} {r['index']}" for r in rows], fontsize=6)
    ax.invert_yaxis()
    ax.set_xlabel("simulated time, s")
    ax.set_title(f"{run.label}: trials (| obstacle appears or comes into view, x first touch, "
                 "> passed)", fontsize=9)  # fmt: skip
    handles = [plt.Rectangle((0, 0), 1, 1, color=COLOURS[o], alpha=0.55) for o in OUTCOMES]
    ax.legend(handles, OUTCOMES, fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1))
    fig.tight_layout()
    io.atomic_savefig(fig, path, dpi=110)
    plt.close(fig)
    return path


# -- the report ---------------------------------------------------------------------------------


def write_report(
    run_dirs: list[str | os.PathLike], out: str | os.PathLike, plots: bool = True
) -> Path:
    """Write ``out/report.md`` (and PNG plots beside it) for one or more run folders.

    Args:
        run_dirs: benchmark run folders; several appear side by side (ablations).
        out: folder of the report.
        plots: also draw the PNG plots.

    Returns:
        The path of ``report.md``.
    """
    if not run_dirs:
        raise ValueError("give at least one run folder")
    runs = [load_run(d) for d in run_dirs]
    labels = [r.label for r in runs]
    for r in runs:
        if labels.count(r.label) > 1:
            r.label = f"{r.label} ({r.path.name})"
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    md = ["# Obstacle benchmark (§6.5, Tables 4–5)", ""]
    md += [
        "Our trials in simulation (MuJoCo) beside the paper's. **The paper's counts come from a "
        "real robot** (50 trials per scenario, objects placed by hand); ours from the "
        "`NeuroCog/SuddenObstacle-v1` and `NeuroCog/StaticObstacle-v1` envs, so the comparison "
        "is of the method, not of the numbers' conditions.",
        "",
        "Runs:",
        "",
    ]
    for r in runs:
        c = r.config
        md.append(f"- **{r.label}**: `{r.path}`: {len(r.records)} trials, "
                  f"seed {c.get('seed', '?')}, "
                  f"policy `{c.get('policy')}`, attention {c.get('attention')}, "
                  f"time limit {_limit(c.get('max_seconds'))}"
                  + ("" if r.records else " (no finished trial yet)"))  # fmt: skip
    md += ["", "## Table 4: outcomes", ""]
    md += [
        "Outcome v1 (from MuJoCo contacts and poses, `neurocog_gym.envs.obstacle`): success = "
        "passed, no robot geom ever touched a block; touch = passed, touched, but never stood "
        "on a block and never knocked one; fail = knocked a block (moved > 2 cm horizontally or "
        "turned > 10° from where it was placed), stood on a block (its top face carried >= 10 % "
        "of the robot's weight for 3 cycles), fell, unstable, or not passed within the time "
        "limit. Rates with 95 % Wilson intervals.",
        "",
    ]
    md += _table4(runs)
    md += ["", "## Table 5: failure analysis (surface similarity of the attention structure)", ""]
    md += [
        "μ (Eq. 12–16) between the topological-map nodes near the obstacle (inside the placed "
        "blocks' boxes grown by 3 cm, above 1 cm) with their facet normals, and the blocks' true "
        "surface (1 cm samples, top and sides), every 0.05 s for 2 s from the moment the obstacle "
        "appeared (sudden) or first came into view (static). Best = highest μ; time to best = "
        "first sample within 0.01 of it; at 0.5 s = the last sample at or before 0.5 s. Our "
        "*passed* groups success and touch, as the paper's success case.",
        "",
    ]
    md += _table5(runs)
    md += ["", "## Other measures", ""]
    md += _other(runs)
    if plots and any(r.records for r in runs):
        md += ["", "## Plots", ""]
        plot_outcomes([r for r in runs if r.records], out / "outcomes.png")
        md += ["![outcomes](outcomes.png)", ""]
        plot_similarity([r for r in runs if r.records], out / "similarity.png")
        md += ["![similarity curves](similarity.png)", ""]
        for r in runs:
            if r.records:
                name = f"timeline_{_slug(r.label)}.png" if len(runs) > 1 else "timeline.png"
                plot_timeline(r, out / name)
                md += [f"![timeline {r.label}]({name})", ""]
    path = out / "report.md"
    io.atomic_write_text(path, "\n".join(md).rstrip() + "\n")
    return path
