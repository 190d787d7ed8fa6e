"""scripts/bench_env.py end to end on a tiny budget (its numbers are not checked: speed is
measured by the script, never asserted in a test)."""

import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "bench_env.py"


@pytest.mark.slow
def test_env_part_writes_every_row(tmp_path):
    out = tmp_path / "env.md"
    r = subprocess.run([sys.executable, str(SCRIPT), "--part", "env", "--rounds", "1",
                        "--steps", "5", "--full-steps", "2", "--vec-steps", "2",
                        "--profile-steps", "5", "--out", str(out)],
                       capture_output=True, text=True, timeout=600)  # fmt: skip
    assert r.returncode == 0, r.stderr
    text = out.read_text()
    for row in ("full perception, default settings", "`Ant-v5`, random actions",
                "154,112 rays a frame", "'async')", "'sync')", "load average",
                "2)`: the registered vector entry point",
                "ToF sensing", "**whole step**", "| pinned + FlattenObservation |",
                "two independent processes", "inside `env.step`",
                "Ceiling: a stand-in env", "Under `SpinVectorEnv`",
                "arithmetic bound", "autoresets of that worker's record"):  # fmt: skip
        assert row in text


def test_bad_arguments_exit_2():
    r = subprocess.run([sys.executable, str(SCRIPT), "--part", "nope"], capture_output=True,
                       text=True, timeout=120)  # fmt: skip
    assert r.returncode == 2 and "--part" in r.stderr
    r = subprocess.run([sys.executable, str(SCRIPT), "--rounds", "0"], capture_output=True,
                       text=True, timeout=120)  # fmt: skip
    assert r.returncode == 2 and "counts" in r.stderr


def test_replay_stand_in_busy_waits_the_recorded_times():
    sys.path.insert(0, str(SCRIPT.parent))
    import time

    import bench_env

    env = bench_env._Replay([0.002, 0.004], offset=1)
    obs, info = env.reset(seed=0)
    assert obs.shape == (1,) and info == {}
    took = []
    for _ in range(4):
        t0 = time.perf_counter()
        _, reward, term, trunc, info = env.step(env.action_space.sample())
        took.append(time.perf_counter() - t0)
        assert (reward, term, trunc, info) == (0.0, False, False, {})
    # offset 1 starts with the second time, then cycles: 4, 2, 4, 2 ms (never shorter)
    assert took[0] >= 0.004 and took[1] >= 0.002 and took[2] >= 0.004 and took[3] >= 0.002


def test_lock_step_bound():
    sys.path.insert(0, str(SCRIPT.parent))
    import bench_env

    assert bench_env.lock_step_bound([1.0, 1.0, 1.0, 1.0]) == 2.0
    # steps 1, 3 against their partners 3, 1: every vector step lasts 3, the mean step 2
    assert abs(bench_env.lock_step_bound([1.0, 3.0]) - 2 * 2.0 / 3.0) < 1e-12


def test_step_clock_puts_later_resets_in_the_timeline():
    sys.path.insert(0, str(SCRIPT.parent))
    import bench_env
    import gymnasium as gym
    import numpy as np

    env = bench_env._StepClock(gym.make("NeuroCog/Walk-v3", max_episode_steps=3))
    env.reset(seed=0)  # the first reset is not a vector step
    for _ in range(3):
        env.step(np.zeros(15, np.float32))
    env.reset()
    env.step(np.zeros(15, np.float32))
    calls, resets = env.timeline()
    assert resets == 1 and len(calls) == 5 and len(env.samples()) == 4
    assert all(t > 0 for t in calls)
    env.close()
