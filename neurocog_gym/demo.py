"""The walking demo: trot in ``NeuroCog/Walk-v3``, write a video and a gait plot."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from neurocog_gym import io as nio
from neurocog_gym.robot.names import LEGS


def walk_demo(
    out: str | Path, seconds: float = 20.0, seed: int = 0, video: bool = True, fps: int = 30
) -> dict:
    """Walk the robot for ``seconds`` on the shipped gait.

    Writes ``walk.mp4``, ``gait.png`` and ``walk_summary.json`` into ``out``; returns the summary.
    """
    import gymnasium as gym
    from tqdm import tqdm

    import neurocog_gym  # noqa: F401

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    n = int(round(seconds / 0.01))  # Walk-v3's control cycle
    env = gym.make("NeuroCog/Walk-v3", render_mode="rgb_array" if video else None,
                   max_episode_steps=n, width=640, height=480)  # fmt: skip
    obs, _ = env.reset(seed=seed)
    base = env.unwrapped
    every = max(1, int(round(1.0 / (fps * base.dt))))
    frames = []
    log = {"t": [], "x": [], "foot_z": [], "touch": [], "hip": [], "cpg": []}
    action = np.zeros(env.action_space.shape, dtype=np.float32)
    energy = 0.0
    fell_at = None
    for k in tqdm(range(n), desc="walking", unit="step", leave=False, disable=None):
        obs, _, terminated, truncated, info = env.step(action)
        energy += info["power"] * base.dt
        d = base.data
        log["t"].append(k * base.dt)
        log["x"].append(float(d.qpos[0]))
        log["foot_z"].append(d.site_xpos[base.robot.foot_site, 2].copy())
        log["touch"].append(obs["touch"].copy())
        log["hip"].append(obs["joint_pos"][1::3].copy())
        log["cpg"].append(obs["cpg"].copy())
        if video and k % every == 0:
            frames.append(env.render())
        if terminated:  # a fall (the time limit truncates at the end of the walk)
            fell_at = k * base.dt
        if terminated or truncated:
            break
    env.close()
    t = np.asarray(log["t"])
    x = np.asarray(log["x"])
    start = len(t) // 5
    speed = float((x[-1] - x[start]) / max(t[-1] - t[start], 1e-9)) if len(t) > 10 else 0.0
    dist = max(float(x[-1] - x[0]), 1e-9)
    summary = {
        "seconds": float(t[-1] + base.dt) if len(t) else 0.0,
        "seed": seed,
        "speed_m_per_s": speed,
        "distance_m": float(x[-1] - x[0]),
        "cost_of_transport": energy / (base.robot.mass * 9.81 * dist),
        "fell_at_s": fell_at,
    }
    if frames:
        import imageio.v2 as imageio

        with nio.atomic_path(out / "walk.mp4") as tmp:
            imageio.mimsave(tmp, frames, fps=fps, macro_block_size=1)
        summary["video"] = str(out / "walk.mp4")
    plot_gait(t, np.asarray(log["foot_z"]), np.asarray(log["touch"]), np.asarray(log["hip"]),
              np.asarray(log["cpg"]), out / "gait.png")  # fmt: skip
    summary["plot"] = str(out / "gait.png")
    nio.atomic_write_text(out / "walk_summary.json", json.dumps(summary, indent=1))
    return summary


def plot_gait(t, foot_z, touch, hip, cpg, path: Path, window: float = 3.0) -> None:
    """Foot heights, stance diagram, hip angles and CPG outputs over the last ``window`` s."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sel = t >= t[-1] - window
    fig, axes = plt.subplots(4, 1, figsize=(9, 9), sharex=True)
    for i, leg in enumerate(LEGS):
        axes[0].plot(t[sel], 100 * foot_z[sel, i], label=leg)
        on = touch[sel, i] > 0.05
        axes[1].fill_between(t[sel], i - 0.4, i + 0.4, where=on, step="mid", alpha=0.8)
        axes[2].plot(t[sel], hip[sel, i], label=leg)
        axes[3].plot(t[sel], cpg[sel, 6 * i] - cpg[sel, 6 * i + 1], label=f"{leg} hip y_f - y_e")
    axes[0].set_ylabel("foot height (cm)")
    axes[0].legend(ncol=4, fontsize=8)
    axes[1].set_yticks(range(4), LEGS)
    axes[1].set_ylabel("stance (touch)")
    axes[2].set_ylabel("hip angle (rad)")
    axes[3].set_ylabel("CPG hip output")
    axes[3].legend(ncol=2, fontsize=8)
    axes[3].set_xlabel("time (s)")
    fig.suptitle("NeuroCog/Walk-v3 — default gait")
    fig.tight_layout()
    nio.atomic_savefig(fig, path, dpi=110)
    plt.close(fig)


def bench_demo(
    out: str | Path,
    trials: int = 4,
    policies: tuple[str, ...] = ("oracle", "aef", "aef-provision", "blind"),
    seed: int = 0,
    workers: int | None = None,
) -> tuple[Path, list[str]]:
    """A short obstacle benchmark: ``trials`` per scenario for each policy, one report.

    Writes ``out/<policy>/`` run folders (``trials.jsonl``, ``summary.json``; a rerun resumes)
    and ``out/report.md`` with the policies side by side beside the paper's Table 4.

    Returns:
        The report path and the Table 4 lines (markdown).
    """
    from neurocog_gym.bench.report import load_run, table4, write_report
    from neurocog_gym.bench.runner import BenchConfig, run_benchmark

    out = Path(out)
    dirs = []
    for policy in policies:
        d = out / policy
        run_benchmark(
            BenchConfig(out=str(d), scenarios=("sudden", "static"), trials=trials, seed=seed,
                        policy=policy, workers=workers, resume=True)
        )  # fmt: skip
        dirs.append(d)
    report = write_report(dirs, out)
    return report, table4([load_run(d) for d in dirs])
