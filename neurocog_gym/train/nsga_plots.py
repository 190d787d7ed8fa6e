"""Figures of an NSGA-II run: Fig. 13 (fitness over generations) and Fig. 14 (CPG outputs)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from neurocog_gym import io as nio
from neurocog_gym.robot.names import LEGS

# Fig. 14 rows: the six neurons of a leg (chromosome.py's numbering, 1-based in Fig. 12).
_NEURON_LABELS = ("1 hip flexor", "2 hip extensor", "3 knee flexor", "4 knee extensor",
                  "5 abductor", "6 adductor")  # fmt: skip
# Fig. 13 colours: orange the first fitness value, blue the second (as the paper's caption).
_COLOURS = ("tab:orange", "tab:blue")


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_fitness_history(history: list[dict], path: str | Path) -> None:
    """Fig. 13: (a) both objectives of every solution per generation, (b) their averages.

    Infeasible solutions (they fell) are drawn hollow; the averages are over the whole population.
    The cost of transport is on a log axis (a standing or backward-walking robot's is large).

    Args:
        history: the records of ``history.jsonl`` (``generation``, ``F``, ``G``).
        path: PNG to write.
    """
    plt = _plt()
    fig, axes = plt.subplots(2, 2, figsize=(11, 7), sharex=True)
    names = ("speed error |v - 0.5| (m/s)", "cost of transport")
    for rec in history:
        F = np.asarray(rec["F"], dtype=np.float64)
        ok = np.asarray(rec["G"], dtype=np.float64).max(axis=1) <= 0
        gen = np.full(len(F), rec["generation"])
        for k in range(2):
            ax = axes[k, 0]
            ax.scatter(gen[ok], F[ok, k], s=6, color=_COLOURS[k], alpha=0.5, linewidths=0)
            ax.scatter(gen[~ok], F[~ok, k], s=8, facecolors="none", edgecolors=_COLOURS[k],
                       alpha=0.4, linewidths=0.5)  # fmt: skip
    gens = np.array([r["generation"] for r in history])
    for k in range(2):
        mean = np.array([np.mean(np.asarray(r["F"], dtype=np.float64)[:, k]) for r in history])
        axes[k, 1].plot(gens, mean, "-o", ms=3, color=_COLOURS[k])
        for j in range(2):
            axes[k, j].set_ylabel(names[k])
            if k == 1:
                axes[k, j].set_yscale("log")
                axes[k, j].set_xlabel("generation")
    from matplotlib.ticker import MaxNLocator

    axes[1, 0].xaxis.set_major_locator(MaxNLocator(integer=True))
    axes[0, 0].set_title("(a) every solution (hollow: fell)")
    axes[0, 1].set_title("(b) population average")
    fig.suptitle("NSGA-II fitness over generations (Fig. 13)")
    fig.tight_layout()
    nio.atomic_savefig(fig, path, dpi=110)
    plt.close(fig)


def plot_cpg_outputs(trace: dict, path: str | Path, window: float = 3.0) -> None:
    """Fig. 14: the 24 CPG neuron outputs y_i (Eq. 7) of a gait over the last ``window`` s.

    Args:
        trace: ``GaitEvaluator.trace`` output (``t`` (n,), ``cpg`` (n, 24)).
        path: PNG to write.
        window: seconds shown, ending at the end of the rollout.
    """
    plt = _plt()
    t, y = np.asarray(trace["t"]), np.asarray(trace["cpg"])
    sel = t >= (t[-1] - window if len(t) else 0.0)
    fig, axes = plt.subplots(6, 4, figsize=(12, 9), sharex=True, sharey=True)
    for leg in range(4):
        for n in range(6):
            ax = axes[n, leg]
            ax.plot(t[sel], y[sel, 6 * leg + n], lw=1.0)
            if n == 0:
                ax.set_title(LEGS[leg])
            if leg == 0:
                ax.set_ylabel(_NEURON_LABELS[n], fontsize=8)
            if n == 5:
                ax.set_xlabel("time (s)")
    fig.suptitle("CPG neuron outputs y_i of the chosen gait (Fig. 14)")
    fig.tight_layout()
    nio.atomic_savefig(fig, path, dpi=110)
    plt.close(fig)
