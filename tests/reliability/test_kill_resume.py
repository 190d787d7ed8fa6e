"""Issue 9, item 5: real ``tune-cpg``, ``train-aef`` and ``bench`` runs killed with SIGKILL at
random (seeded) moments resume losing at most the unit in progress (one generation, epoch or
trial) and end with the same files, and the same results, as an uninterrupted run."""

import json
import os
import pickle
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from neurocog_gym import io

CLI = [sys.executable, "-m", "neurocog_gym.cli"]
ENV = {**os.environ, "RAY_AUTH_MODE": "disabled"}


def _run(args, timeout=300):
    res = subprocess.run(CLI + args, capture_output=True, text=True, timeout=timeout, env=ENV)
    assert res.returncode == 0, res.stderr
    return res


def kill_at_random_moments(args, resume_args, progress, total, seed, kills=2, timeout=240):
    """Start ``args``; ``kills`` times wait until ``progress()`` reaches a random unit count,
    wait a random part of a unit more, SIGKILL the process group and restart with
    ``resume_args``; finally run ``resume_args`` to the end.

    Returns the (observed before the kill, on disk after the kill) progress of every kill.
    """
    rng = np.random.default_rng(seed)
    history = []
    cmd = args
    for _ in range(kills):
        p0 = progress()
        target = int(rng.integers(p0, total))  # kill once the run has at least this many units
        proc = subprocess.Popen(CLI + cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                start_new_session=True, env=ENV)  # fmt: skip
        deadline = time.monotonic() + timeout
        seen, t_seen, unit_s = p0, time.monotonic(), 0.5
        try:
            while time.monotonic() < deadline and proc.poll() is None:
                p = progress()
                if p > seen:
                    now = time.monotonic()
                    unit_s = (now - t_seen) / (p - seen) if seen > p0 else unit_s
                    seen, t_seen = p, now
                if seen >= target:
                    time.sleep(float(rng.uniform(0.0, 1.0)) * unit_s)
                    seen = max(seen, progress())
                    break
                time.sleep(0.01)
        finally:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
        after = progress()
        history.append((seen, after))
        # What was on disk before the kill is still there: no file was left half-written.
        assert after >= seen, history
        cmd = resume_args
    _run(resume_args, timeout=timeout)
    assert progress() == total
    return history


def _files(folder: Path) -> set[str]:
    return {p.name for p in folder.iterdir() if not p.name.startswith(".")}


def _no_temp_files(folder: Path) -> None:
    # A kill between the temp file's creation and the rename may leave one; a finished run that
    # leaves them behind would fill the folder over many kills.
    assert not [p for p in folder.iterdir() if p.name.endswith(".tmp")]


# -- tune-cpg ------------------------------------------------------------------------------------

NSGA = ["tune-cpg", "--pop-size", "6", "--generations", "6", "--eval-seconds", "0.4",
        "--seed", "3", "--workers", "1"]  # fmt: skip


def _nsga_checkpoint_generation(out: Path) -> int:
    ck = out / "checkpoint.pkl"
    if not ck.exists():
        return 0
    with open(ck, "rb") as f:
        return int(pickle.load(f)["generation"])


@pytest.mark.parametrize("seed", [0])
def test_tune_cpg_killed_at_random_moments(tmp_path, seed):
    from neurocog_gym.train.nsga import read_history

    out, ref = tmp_path / "run", tmp_path / "ref"

    def progress():
        return len(read_history(out))

    kills = kill_at_random_moments([*NSGA, "--out", str(out)],
                                   ["tune-cpg", "--out", str(out), "--resume", "--workers", "1"],
                                   progress, 6, seed)  # fmt: skip
    _run([*NSGA, "--out", str(ref)])
    assert kills and all(after >= seen for seen, after in kills)
    assert _files(out) == _files(ref)
    _no_temp_files(out)
    h, r = read_history(out), read_history(ref)
    assert [x["generation"] for x in h] == [1, 2, 3, 4, 5, 6]
    for a, b in zip(h, r, strict=True):
        assert (a["X"], a["F"], a["G"], a["n_evals"]) == (b["X"], b["F"], b["G"], b["n_evals"])
    for name in ("pareto.json", "best_gait.json"):
        assert json.loads((out / name).read_text()) == json.loads((ref / name).read_text())


def test_tune_cpg_checkpoint_lags_history_by_at_most_one(tmp_path):
    """Kill right after each history line appears: the checkpoint is there or one behind."""
    from neurocog_gym.train.nsga import read_history

    out = tmp_path / "run"
    proc = subprocess.Popen(CLI + [*NSGA, "--out", str(out)], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True, env=ENV)  # fmt: skip
    try:
        deadline = time.monotonic() + 240
        while time.monotonic() < deadline and proc.poll() is None and len(read_history(out)) < 2:
            time.sleep(0.002)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    n_hist = len(read_history(out))
    n_ck = _nsga_checkpoint_generation(out)
    assert n_hist >= 2 and n_hist - 1 <= n_ck <= n_hist, (n_hist, n_ck)
    _run(["tune-cpg", "--out", str(out), "--resume", "--workers", "1"])
    assert [x["generation"] for x in read_history(out)] == [1, 2, 3, 4, 5, 6]


# -- train-aef -----------------------------------------------------------------------------------

AEF = ["train-aef", "--samples", "3000", "--epochs", "8", "--seed", "1"]


def _aef_epoch(out: Path) -> int:
    ck = out / "checkpoint.pt"
    if not ck.exists():
        return 0
    import torch

    for _ in range(5):  # the file may be replaced while we read it: read the new one
        try:
            return int(torch.load(ck, weights_only=False)["state"]["epoch"])
        except (RuntimeError, EOFError, pickle.UnpicklingError, FileNotFoundError):
            time.sleep(0.05)
    raise AssertionError(f"{ck} stays unreadable")


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0])
def test_train_aef_killed_at_random_moments(tmp_path, seed):
    out, ref = tmp_path / "run", tmp_path / "ref"
    kills = kill_at_random_moments([*AEF, "--out", str(out)], [*AEF, "--out", str(out)],
                                   lambda: _aef_epoch(out), 8, seed)  # fmt: skip
    _run([*AEF, "--out", str(ref)])
    assert kills
    assert _files(out) == _files(ref)
    _no_temp_files(out)
    m_out = json.loads((out / "metrics.json").read_text())
    m_ref = json.loads((ref / "metrics.json").read_text())
    assert [e["epoch"] for e in m_out["history"]] == list(range(1, 9))
    assert m_out == m_ref  # the resumed training is the uninterrupted one, bit for bit
    with np.load(out / "aef_weights.npz") as a, np.load(ref / "aef_weights.npz") as b:
        assert a.files == b.files
        for k in a.files:
            np.testing.assert_array_equal(a[k], b[k])


# -- bench ---------------------------------------------------------------------------------------

BENCH = ["bench", "--scenario", "sudden", "--trials", "4", "--workers", "1", "--max-seconds",
         "1.5", "--policy", "blind", "--seed", "5"]  # fmt: skip
TIMING = ("wall_s", "perception_ms")


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0])
def test_bench_killed_at_random_moments(tmp_path, seed):
    out, ref = tmp_path / "run", tmp_path / "ref"
    trials = out / "trials.jsonl"
    kills = kill_at_random_moments([*BENCH, "--out", str(out)],
                                   [*BENCH, "--out", str(out), "--resume"],
                                   lambda: len(io.read_jsonl(trials)), 4, seed)  # fmt: skip
    _run([*BENCH, "--out", str(ref)])
    assert kills
    assert _files(out) == _files(ref)
    _no_temp_files(out)

    def records(folder):
        recs = io.read_jsonl(folder / "trials.jsonl")
        return sorted(({k: v for k, v in r.items() if k not in TIMING} for r in recs),
                      key=lambda r: r["index"])  # fmt: skip

    assert [r["index"] for r in records(out)] == [0, 1, 2, 3]  # each trial once
    assert records(out) == records(ref)
    s_out = json.loads((out / "summary.json").read_text())["sudden"]
    s_ref = json.loads((ref / "summary.json").read_text())["sudden"]
    for key in ("success", "touch", "fail", "trials", "complete"):
        assert s_out[key] == s_ref[key]
