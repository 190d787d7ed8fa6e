"""The soak and NSGA-candidate scripts end to end on tiny budgets (subprocess)."""

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _script(name, *args, timeout=300):
    res = subprocess.run([sys.executable, str(ROOT / "scripts" / name), *map(str, args)],
                         capture_output=True, text=True, timeout=timeout, cwd=ROOT)  # fmt: skip
    assert res.returncode == 0, res.stderr[-2000:]
    return res


def test_soak_script_and_report(tmp_path):
    js = tmp_path / "walk.json"
    _script("soak.py", "--env", "NeuroCog/Walk-v1", "--steps", "1500", "--warmup", "500",
            "--sample-every", "250", "--episode-steps", "400", "--json", js)  # fmt: skip
    r = json.loads(js.read_text())
    assert r["steps"] == 1500 and r["episodes"] >= 4 and r["nonfinite_obs_steps"] == 0
    assert len(r["samples"]) == 6 and r["rss_warm_mib"] > 0
    md = tmp_path / "soak.md"
    _script("soak.py", "--report", js, "--out", md)
    text = md.read_text()
    assert "| NeuroCog/Walk-v1 | 1,500 (1,500) |" in text and "growth" in text


def test_nsga_candidates_script(tmp_path):
    from neurocog_gym.train.evaluate import EvalParams
    from neurocog_gym.train.nsga import NSGAConfig, tune_cpg

    run = tmp_path / "run"
    cfg = NSGAConfig(pop_size=4, generations=1, seed=0, eval=EvalParams(seconds=0.3))
    tune_cpg(run, cfg, workers=1, plots=False, progress=False)
    _script("nsga_candidates.py", run, "--seconds", "2.5", "--seeds", "0", "1",
            "--env-check", "1")  # fmt: skip
    c = json.loads((run / "candidates.json").read_text())
    assert c["n_solutions"] >= 1 and len(c["table"]) == c["n_solutions"]
    assert c["reference_env"] and all("drift_per_10m" in r for r in c["reference_env"])
    # A candidate is written only when one meets every rule; never over the shipped default.
    assert (run / "candidate_gait.json").exists() == (c["winner"] is not None)


def test_recheck_trials_finds_a_changed_record(tmp_path):
    from neurocog_gym.bench.runner import BenchConfig, run_benchmark

    run = tmp_path / "run"
    run_benchmark(BenchConfig(scenarios=("static",), trials=2, policy="blind", max_seconds=0.3,
                              workers=1, out=run, progress=False))  # fmt: skip
    res = _script("recheck_trials.py", run, "--scenario", "static", "--every", "1")
    assert "2 of 2 re-run trials identical" in res.stdout
    # A record that the code does not reproduce is reported, with a failing exit status.
    trials = run / "trials.jsonl"
    rows = [json.loads(line) for line in trials.read_text().splitlines()]
    rows[1]["steps"] += 1
    trials.write_text("".join(json.dumps(r) + "\n" for r in rows))
    res = subprocess.run([sys.executable, str(ROOT / "scripts" / "recheck_trials.py"), str(run),
                          "--every", "1"], capture_output=True, text=True, cwd=ROOT)  # fmt: skip
    assert res.returncode == 1
    assert "DIFF" in res.stdout and "'steps'" in res.stdout and "1 of 2 re-run" in res.stdout


def test_search_gait_script_scores_and_writes_only_improvements(tmp_path):
    out = tmp_path / "best.json"
    res = _script(
        "search_gait.py", "--iters", "1", "--seeds", "1", "--seconds", "2.5", "--out", out
    )
    assert res.stdout.startswith("start: cost ")
    # The file appears only when a candidate beat the start.
    assert out.exists() == (res.stdout.count("cost") > 1)


def test_body_figures_script_writes_the_body_page(tmp_path):
    out = tmp_path / "body.md"
    _script("body_figures.py", "--seeds", "1", "--swings", "1", "--phases", "2", "--out", out)
    text = out.read_text()
    assert "| thigh, shank | 0.200 m, 0.200 m" in text and "reached 11 cm" in text
