"""The obstacle benchmark: tally, Wilson intervals, seeding, resume, the CLI, the report, Ray."""

from __future__ import annotations

import json
import math
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import pytest

from neurocog_gym import io
from neurocog_gym.bench import outcome, runner
from neurocog_gym.bench.outcome import tally, wilson_interval
from neurocog_gym.bench.report import write_report

NEUROCOG = [sys.executable, "-m", "neurocog_gym.cli"]
# Small trials: the sudden obstacle appears between 1 and 2 s, so 2.5 s sees it.
SMALL = ["--max-seconds", "2.5"]


def _run(args, timeout=240, **kw):
    env = {**os.environ, "RAY_AUTH_MODE": "disabled"}
    return subprocess.run(NEUROCOG + args, capture_output=True, text=True, timeout=timeout,
                          env=env, **kw)  # fmt: skip


# -- outcome tally and Wilson intervals ---------------------------------------------------------


def test_wilson_interval_by_hand():
    # 41 of 50, z = 1.959964, z² = 3.841459:
    # centre = (41 + 1.920730) / (50 + 3.841459) = 42.920730 / 53.841459 = 0.797169
    # half = z * sqrt(41 * 9 / 50 + 3.841459 / 4) / 53.841459
    #      = 1.959964 * sqrt(7.38 + 0.960365) / 53.841459 = 1.959964 * 2.887969 / 53.841459
    #      = 0.105130  ->  [0.692039, 0.902298]
    lo, hi = wilson_interval(41, 50)
    assert lo == pytest.approx(0.692039, abs=1e-5)
    assert hi == pytest.approx(0.902298, abs=1e-5)
    # 0 of 10: low 0, high z² / (n + z²) = 3.841459 / 13.841459 = 0.277533.
    assert wilson_interval(0, 10) == pytest.approx((0.0, 0.277533), abs=1e-5)
    # 10 of 10 mirrors it.
    assert wilson_interval(10, 10) == pytest.approx((1 - 0.277533, 1.0), abs=1e-5)
    assert wilson_interval(0, 0) == (0.0, 1.0)
    with pytest.raises(ValueError):
        wilson_interval(3, 2)


def test_tally_paper_sudden_counts():
    recs = [{"outcome": "success"}] * 28 + [{"outcome": "touch"}] * 13 + [{"outcome": "fail"}] * 9
    t = tally(recs)
    assert (t["trials"], t["success"], t["touch"], t["fail"]) == (50, 28, 13, 9)
    assert t["success_rate"] == pytest.approx(0.56)
    assert t["success_or_touch_rate"] == pytest.approx(0.82)  # the paper's "82 percent"
    assert t["wilson95"]["success_or_touch"] == pytest.approx([0.692039, 0.902298], abs=1e-5)
    with pytest.raises(ValueError, match="unknown outcome"):
        tally([{"outcome": "maybe"}])
    assert tally([])["success_rate"] is None


def test_failure_analysis_groups_passed_against_failed():
    recs = [
        {"outcome": "success", "similarity": {"best": 0.9, "time_to_best": 0.4, "at_0_5": 0.9}},
        {"outcome": "touch", "similarity": {"best": 0.8, "time_to_best": 0.6, "at_0_5": None}},
        {"outcome": "fail", "similarity": {"best": 0.7, "time_to_best": 0.8, "at_0_5": 0.5}},
        {"outcome": "fail", "similarity": None},
    ]
    fa = outcome.failure_analysis(recs)
    assert fa["success"]["n"] == 2 and fa["fail"]["n"] == 2
    assert fa["success"]["best"] == pytest.approx(0.85)
    assert fa["success"]["time_to_best"] == pytest.approx(0.5)
    assert fa["success"]["at_0_5"] == pytest.approx(0.9)  # the missing value is left out
    assert fa["fail"]["best"] == pytest.approx(0.7)


def test_trial_seed_is_fixed_and_distinct():
    # sha256("neurocog-bench/0/sudden/0")[:4] big-endian & 0x7fffffff.
    assert runner.trial_seed(0, "sudden", 0) == 36141965
    seeds = {runner.trial_seed(0, s, i) for s in ("sudden", "static") for i in range(50)}
    assert len(seeds) == 100
    assert runner.trial_seed(1, "sudden", 0) != runner.trial_seed(0, "sudden", 0)


# -- resume ---------------------------------------------------------------------------------------


class _FakeEnv:
    def close(self):
        pass


def _fake_record(spec):
    even = spec.index % 2 == 0
    return {"scenario": spec.scenario, "index": spec.index, "seed": spec.seed,
            "outcome": "success" if even else "fail", "passed": even, "touched": False,
            "touch_events": 0, "fell": False, "time": 1.0, "similarity": None}  # fmt: skip


def test_resume_runs_only_missing_trials_and_drops_a_torn_line(tmp_path, monkeypatch):
    ran = []

    def fake_run_trial(env, policy, spec, similarity=None):
        ran.append((spec.scenario, spec.index))
        return _fake_record(spec)

    monkeypatch.setattr(runner, "run_trial", fake_run_trial)
    monkeypatch.setattr(runner, "make_env", lambda *a: _FakeEnv())
    cfg = runner.BenchConfig(out=tmp_path, scenarios=("sudden",), trials=4, policy="blind",
                             workers=1, report=False, progress=False)  # fmt: skip
    ident = cfg.identity()
    done = [runner.TrialSpec("sudden", i, runner.trial_seed(0, "sudden", i)) for i in (0, 2)]
    for spec in done:
        io.append_jsonl(tmp_path / "trials.jsonl", {**_fake_record(spec), **ident})
    with open(tmp_path / "trials.jsonl", "a") as f:
        f.write('{"scenario":"sudden","index":1,"outc')  # killed mid-write
    res = runner.run_benchmark(replace(cfg, resume=True))
    assert sorted(ran) == [("sudden", 1), ("sudden", 3)]
    assert (res.ran, res.skipped) == (2, 2)
    lines = (tmp_path / "trials.jsonl").read_text().splitlines()
    assert sorted(json.loads(ln)["index"] for ln in lines) == [0, 1, 2, 3]  # every line parses
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["sudden"]["trials"] == 4 and summary["sudden"]["complete"]
    assert (summary["sudden"]["success"], summary["sudden"]["fail"]) == (2, 2)
    # Nothing left: a second resume runs nothing.
    ran.clear()
    assert runner.run_benchmark(replace(cfg, resume=True)).ran == 0
    assert ran == []
    # Other settings cannot continue this run; without --resume the folder is refused.
    with pytest.raises(ValueError, match="other settings"):
        runner.run_benchmark(replace(cfg, resume=True, seed=1))
    with pytest.raises(ValueError, match="--resume"):
        runner.run_benchmark(cfg)


def test_kill_then_resume_real_run(tmp_path):
    out = tmp_path / "run"
    args = ["bench", "--scenario", "sudden", "--trials", "3", "--workers", "1", "--max-seconds",
            "2", "--policy", "blind", "--out", str(out)]  # fmt: skip
    env = {**os.environ, "RAY_AUTH_MODE": "disabled"}
    proc = subprocess.Popen(NEUROCOG + args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True, env=env)  # fmt: skip
    trials = out / "trials.jsonl"
    deadline = time.monotonic() + 180
    try:
        while time.monotonic() < deadline and proc.poll() is None:
            if trials.exists() and len(io.read_jsonl(trials)) >= 1:
                break
            time.sleep(0.1)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    n_before = len(io.read_jsonl(trials))
    assert n_before >= 1
    res = _run(args + ["--resume"])
    assert res.returncode == 0, res.stderr
    assert f"({n_before} already done)" in res.stdout
    recs = io.read_jsonl(trials)
    assert sorted(r["index"] for r in recs) == [0, 1, 2]


# -- CLI end to end and the report ----------------------------------------------------------------


def test_cli_end_to_end_and_compare_report(tmp_path):
    a, b = tmp_path / "aef", tmp_path / "off"
    res = _run(["bench", "--trials", "2", "--workers", "1", "--out", str(a), *SMALL])
    assert res.returncode == 0, res.stderr
    assert "trials/min" in res.stdout
    recs = io.read_jsonl(a / "trials.jsonl")
    assert sorted((r["scenario"], r["index"]) for r in recs) == [
        ("static", 0), ("static", 1), ("sudden", 0), ("sudden", 1)]  # fmt: skip
    fields = {"seed", "scenario", "index", "policy", "attention", "obstacles", "outcome", "passed",
              "touched", "touch_events", "fell", "time", "time_to_pass", "contacts",
              "perception_ms", "steps", "similarity"}  # fmt: skip
    for r in recs:
        assert fields <= r.keys()
        assert r["outcome"] in ("success", "touch", "fail")
        assert r["seed"] == runner.trial_seed(0, r["scenario"], r["index"])
        assert r["perception_ms"]["mean"] > 0
    sudden = [r for r in recs if r["scenario"] == "sudden"]
    assert all(r["obstacles"] and r["similarity"]["t"] for r in sudden)
    assert all(0.0 <= m <= 1.0 for r in sudden for m in r["similarity"]["mu"])
    summary = json.loads((a / "summary.json").read_text())
    for s in ("sudden", "static"):
        c = summary[s]
        assert c["trials"] == 2 and c["success"] + c["touch"] + c["fail"] == 2
        assert set(c["wilson95"]) == {"success", "success_or_touch", "fail"}
    assert summary["config"]["policy"] == "aef" and summary["config"]["attention"] == "on"
    md = (a / "report.md").read_text()
    for paper in ("| 50 | 28 | 13 | 9 |", "| 50 | 23 | 21 | 6 |", "0.92", "0.45", "0.48"):
        assert paper in md
    c = summary["sudden"]
    assert f"| AEF, attention on | 2 | {c['success']} | {c['touch']} | {c['fail']} |" in md
    for png in ("outcomes.png", "similarity.png", "timeline.png"):
        assert (a / png).stat().st_size > 1000

    res = _run(["bench", "--scenario", "sudden", "--trials", "1", "--workers", "1", "--policy",
                "blind", "--attention", "off", "--out", str(b), *SMALL])  # fmt: skip
    assert res.returncode == 0, res.stderr
    rep = tmp_path / "report"
    res = _run(["bench-report", str(a), str(b), "--out", str(rep)])
    assert res.returncode == 0, res.stderr
    md = (rep / "report.md").read_text()
    assert "AEF, attention on" in md and "blind, attention off" in md
    assert (rep / "timeline_blind-attention-off.png").exists()


def test_report_of_an_empty_run_and_bad_folders(tmp_path):
    (tmp_path / "trials.jsonl").write_text("")
    md = write_report([tmp_path], tmp_path / "r").read_text()
    assert "| 50 | 28 | 13 | 9 |" in md
    with pytest.raises(FileNotFoundError):
        write_report([tmp_path / "missing"], tmp_path / "r")


def _closed_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.parametrize(
    "args, says",
    [
        (["--trials", "-3"], "--trials"),
        (["--scenario", "uphill"], "--scenario"),
        (["--policy", "/nonexistent/model.zip"], "does not exist"),
        (["--ray-address", "127.0.0.1:PORT"], "cannot reach the Ray cluster"),
        (["--ray-address", "no-port-here"], "not of the form"),
        (["--workers", "0"], "--workers"),
    ],
)
def test_bad_arguments_exit_with_one_line(tmp_path, args, says):
    args = [a.replace("PORT", str(_closed_port())) for a in args]
    res = _run(["bench", "--trials", "1", "--out", str(tmp_path / "x"), *args], timeout=120)
    assert res.returncode != 0
    assert "Traceback" not in res.stderr
    errors = [ln for ln in res.stderr.splitlines() if "error:" in ln]
    assert len(errors) == 1 and says in errors[0], res.stderr


def test_bad_model_file_is_one_line(tmp_path):
    bad = tmp_path / "model.zip"
    bad.write_bytes(b"not a zip")
    res = _run(["bench", "--policy", str(bad), "--out", str(tmp_path / "x")], timeout=120)
    assert res.returncode == 2 and "Traceback" not in res.stderr
    assert res.stderr.strip().count("\n") == 0 and "stable-baselines3" in res.stderr


# -- scheduling independence and Ray ---------------------------------------------------------------


@pytest.mark.slow
def test_results_do_not_depend_on_workers(tmp_path):
    outs = []
    for w in ("1", "2"):
        out = tmp_path / f"w{w}"
        res = _run(["bench", "--trials", "2", "--workers", w, "--out", str(out), *SMALL])
        assert res.returncode == 0, res.stderr
        recs = io.read_jsonl(out / "trials.jsonl")
        key = [(r["scenario"], r["index"]) for r in recs]
        val = [(r["outcome"], r["distance"], r["similarity"]["mu"]) for r in recs]
        outs.append(dict(zip(key, val, strict=True)))
    assert outs[0] == outs[1]


def test_ray_cluster_address(tmp_path):
    pytest.importorskip("ray")
    port = _closed_port()
    env = {**os.environ, "RAY_AUTH_MODE": "disabled"}
    # Ray's AF_UNIX socket paths must stay under 108 bytes: a short folder, not tmp_path.
    ray_tmp = tempfile.mkdtemp(prefix="ncb-ray-", dir="/tmp")
    log = open(tmp_path / "ray_head.log", "w")  # noqa: SIM115 (closed in finally)
    head = subprocess.Popen(
        [str(Path(sys.executable).with_name("ray")), "start", "--head", "--block",
         f"--port={port}", "--num-cpus=1", "--include-dashboard=false",
         f"--temp-dir={ray_tmp}", "--disable-usage-stats"],
        stdout=log, stderr=subprocess.STDOUT, start_new_session=True, env=env,
    )  # fmt: skip
    try:
        deadline = time.monotonic() + 90
        while time.monotonic() < deadline and head.poll() is None:
            if "Ray runtime started" in (tmp_path / "ray_head.log").read_text():
                break
            time.sleep(0.5)
        assert head.poll() is None, (tmp_path / "ray_head.log").read_text()[-2000:]
        out = tmp_path / "run"
        res = _run(["bench", "--scenario", "sudden", "--trials", "1", "--workers", "1",
                    "--policy", "blind", "--ray-address", f"127.0.0.1:{port}", "--out", str(out),
                    *SMALL], timeout=180)  # fmt: skip
        assert res.returncode == 0, res.stderr[-2000:]
        recs = io.read_jsonl(out / "trials.jsonl")
        assert [(r["scenario"], r["index"]) for r in recs] == [("sudden", 0)]
        assert not math.isnan(recs[0]["time"])
    finally:
        # Stop only the head started here: its own process group, by id.
        for sig, wait in ((signal.SIGTERM, 5), (signal.SIGKILL, 30)):
            try:
                os.killpg(head.pid, sig)
            except ProcessLookupError:
                break
            try:
                head.wait(timeout=wait)
            except subprocess.TimeoutExpired:
                pass
        log.close()
        shutil.rmtree(ray_tmp, ignore_errors=True)


def test_pool_worker_keeps_torch_to_one_thread():
    """Each bench worker is one process per core: torch's intra-op threads are held to one."""
    torch = pytest.importorskip("torch")
    before = torch.get_num_threads()
    try:
        torch.set_num_threads(2)
        runner._init_worker("blind", "on", 1.0, runner.SimilaritySettings())
        assert torch.get_num_threads() == 2  # the serial path runs in the caller's process
        runner._init_pool_worker("blind", "on", 1.0, runner.SimilaritySettings())
        assert torch.get_num_threads() == 1
    finally:
        torch.set_num_threads(before)
        runner._WORKER.clear()


def test_scenario_summary_counts_the_v1_outcome_parts():
    from neurocog_gym.bench.outcome import scenario_summary

    recs = [
        {"outcome": "fail", "knocked": True, "stood_on": False, "stepped_over": False},
        {"outcome": "fail", "knocked": True, "stood_on": True, "stepped_over": True},
        {"outcome": "success", "knocked": False, "stood_on": False, "stepped_over": True},
        {"outcome": "touch"},  # a record from before v1: none of them
    ]
    s = scenario_summary(recs)
    assert (s["knocked"], s["stood_on"], s["stepped_over"]) == (2, 1, 2)
    assert (s["success"], s["touch"], s["fail"]) == (1, 1, 2)


def test_trial_record_has_the_v1_fields():
    import gymnasium as gym

    from neurocog_gym.bench.runner import TrialSpec, run_trial
    from neurocog_gym.policies import make_policy

    env = gym.make("NeuroCog/StaticObstacle-v3", max_episode_steps=30)
    rec = run_trial(env, make_policy("blind"), TrialSpec("static", 0, 5))
    for key in ("outcome", "passed", "touched", "touch_events", "time_to_pass", "obstacles",
                "knocked", "stood_on", "stepped_over", "interrupt_cycles", "provision_cycles",
                "time_to_pass_from_appear"):  # fmt: skip
        assert key in rec, key
    assert rec["interrupt_cycles"] == 0 and rec["provision_cycles"] == 0  # blind
    assert rec["time_to_pass_from_appear"] is None and not rec["passed"]
    assert len(rec["obstacles"][0]["pos"]) == 3
    json.dumps(rec, allow_nan=False)
    env.close()
