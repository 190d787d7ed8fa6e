"""scripts/train_ppo.py end to end on a tiny budget, resumed, then evaluated by neurocog bench."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "train_ppo.py"
TINY = [
    "--n-envs",
    "2",
    "--n-steps",
    "64",
    "--batch-size",
    "64",
    "--n-epochs",
    "1",
    "--checkpoint-every",
    "128",
    "--seed",
    "1",
]


def _run(*argv, timeout=600):
    return subprocess.run([sys.executable, *argv], capture_output=True, text=True, timeout=timeout)


@pytest.mark.slow
def test_train_resume_and_bench_the_model(tmp_path):
    out = tmp_path / "ppo"
    r = _run(str(SCRIPT), "--total-steps", "256", "--out", str(out), *TINY)
    assert r.returncode == 0, r.stderr
    s = json.loads((out / "train_summary.json").read_text())
    assert s["total_steps"] == 256 and s["n_envs"] == 2 and s["vec"] == "spin"
    assert (out / "model.zip").is_file()
    assert (out / "vecnormalize.pkl").is_file()  # observation statistics beside the model
    assert s["normalize_obs"] is True
    assert sum(s["fails_this_session"].values()) == s["outcomes_this_session"]["fail"]
    assert set(s["sudden_blocks_this_session"]) == {"forced", "none"}
    assert sorted(p.name for p in (out / "checkpoints").iterdir()) == [
        "ppo_128_steps.zip",
        "ppo_256_steps.zip",
        "ppo_vecnormalize_128_steps.pkl",
        "ppo_vecnormalize_256_steps.pkl",
    ]
    assert any((out / "tb").rglob("events.out.tfevents.*"))
    assert json.loads((out / "args.json").read_text())["total_steps"] == 256

    # a second start without --resume refuses to overwrite; with it, it continues
    r = _run(str(SCRIPT), "--total-steps", "256", "--out", str(out), *TINY)
    assert r.returncode == 2 and "--resume" in r.stderr
    # the checkpoint has statistics: resuming without normalisation is refused
    r = _run(str(SCRIPT), "--total-steps", "384", "--out", str(out), "--resume",
             "--no-normalize-obs", *TINY)  # fmt: skip
    assert r.returncode == 2 and "VecNormalize statistics" in r.stderr
    stats_256 = (out / "checkpoints" / "ppo_vecnormalize_256_steps.pkl").read_bytes()
    r = _run(str(SCRIPT), "--total-steps", "384", "--out", str(out), "--resume", *TINY)
    assert r.returncode == 0, r.stderr
    assert "resuming from" in r.stdout and "ppo_256_steps.zip" in r.stdout
    s = json.loads((out / "train_summary.json").read_text())
    assert s["total_steps"] == 384 and s["steps_this_session"] == 128
    # the resumed session went on from the checkpoint's statistics, and updated them
    import pickle

    before = pickle.loads(stats_256).obs_rms["joint_vel"]
    after = pickle.loads((out / "vecnormalize.pkl").read_bytes()).obs_rms["joint_vel"]
    assert before.count + 128 <= after.count <= before.count + 128 + 2  # + the reset obs

    bench = tmp_path / "bench"
    r = _run(
        "-m",
        "neurocog_gym.cli",
        "bench",
        "--policy",
        str(out / "model.zip"),
        "--trials",
        "1",
        "--workers",
        "1",
        "--max-seconds",
        "1",
        "--out",
        str(bench),
    )
    assert r.returncode == 0, r.stderr
    summary = json.loads((bench / "summary.json").read_text())
    for scenario in ("sudden", "static"):
        c = summary[scenario]
        assert c["trials"] == 1 and c["success"] + c["touch"] + c["fail"] == 1


def test_bad_arguments_exit_2():
    r = _run(str(SCRIPT), "--n-envs", "0")
    assert r.returncode == 2 and "--n-envs" in r.stderr
    r = _run(str(SCRIPT), "--vec", "threads")
    assert r.returncode == 2 and "--vec" in r.stderr
    r = _run(str(SCRIPT), "--target-kl", "-0.1")
    assert r.returncode == 2 and "--target-kl" in r.stderr
    r = _run(str(SCRIPT), "--resume", "--out", "/nonexistent/ppo_run")
    assert r.returncode == 2 and "no checkpoint" in r.stderr


def test_outcome_callback_counts_blocks_kept_away():
    """The training log shows a policy that keeps the sudden block from appearing."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("train_ppo", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # its dataclasses look their module up there
    spec.loader.exec_module(mod)
    cb = mod._outcome_callback()
    infos = [
        {"outcome": "touch", "passed": True, "appeared_at": 1.3, "appear_forced": False},
        {"outcome": "touch", "passed": True, "appeared_at": 2.9, "appear_forced": True},
        {"outcome": "fail", "passed": False, "fell": True, "appeared_at": None},
        {"outcome": "fail", "passed": False, "appeared_at": 1.8, "appear_forced": False},
        {"x_position": 0.3},  # not finished: not counted
    ]
    cb.locals = {"infos": infos, "dones": [True, True, True, True, False]}
    assert cb._on_step()
    assert cb.counts == {"success": 0, "touch": 2, "fail": 2}
    assert cb.fails == {"fell": 1, "stuck": 1}
    assert cb.blocks == {"forced": 1, "none": 1}


def test_train_with_subproc_vec_env(tmp_path):
    out = tmp_path / "ppo_subproc"
    r = _run(str(SCRIPT), "--total-steps", "128", "--out", str(out), "--vec", "subproc",
             "--no-tensorboard", *TINY)  # fmt: skip
    assert r.returncode == 0, r.stderr
    s = json.loads((out / "train_summary.json").read_text())
    assert s["total_steps"] == 128 and s["n_envs"] == 2 and s["vec"] == "subproc"
    assert (out / "model.zip").is_file()
