import json
import os
import pickle
import shutil
import signal
import subprocess
import sys
import tempfile
import time

import gymnasium as gym
import numpy as np
import pytest

import neurocog_gym  # noqa: F401
from neurocog_gym.locomotion.chromosome import GENE_LOWER, GENE_UPPER, N_GENES
from neurocog_gym.locomotion.gait import Gait, default_gait
from neurocog_gym.train.evaluate import EvalParams, GaitEvaluator
from neurocog_gym.train.nsga import (
    BaseGaitSampling,
    CPGProblem,
    NSGAConfig,
    choose_gait,
    read_history,
    tune_cpg,
)

TINY = ["--pop-size", "8", "--generations", "2", "--eval-seconds", "0.5", "--seed", "1"]


def neurocog(*args, timeout=240):
    """Run the CLI in a subprocess (non-TTY: no progress bar)."""
    return subprocess.run(
        [sys.executable, "-m", "neurocog_gym.cli", *map(str, args)],
        capture_output=True, text=True, timeout=timeout,
    )  # fmt: skip


def assert_one_line_error(proc, *words):
    assert proc.returncode != 0
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert "Traceback" not in proc.stderr
    for w in words:
        assert w in lines[0], lines[0]


def serial_run(out, generations, seconds, seed, pop_size=8):
    """A run in this process on one worker, no plots."""
    config = NSGAConfig(pop_size=pop_size, generations=generations, seed=seed,
                        eval=EvalParams(seconds=seconds))  # fmt: skip
    return tune_cpg(out, config, workers=1, plots=False, progress=False)


def walk_env_speed_and_energy(seed, seconds, warmup):
    """Forward speed and sum |tau omega| dt after ``warmup`` in NeuroCog/Walk-v3, zero action."""
    env = gym.make("NeuroCog/Walk-v3", max_episode_steps=None)
    env.reset(seed=seed)
    base = env.unwrapped
    n, w = int(round(seconds / base.dt)), int(round(warmup / base.dt))
    xs, power = [float(base.data.qpos[0])], []
    for _ in range(n):
        _, _, terminated, truncated, info = env.step(np.zeros(15, np.float32))
        assert not (terminated or truncated)
        xs.append(info["x_position"])
        power.append(info["power"])
    env.close()
    return (xs[n] - xs[w]) / ((n - w) * base.dt), sum(power[w:]) * base.dt


# -- the evaluator and the problem -------------------------------------------------------------


def test_default_genes_match_a_walk_env_rollout():
    params = EvalParams(seconds=3.0, warmup=1.0)
    score = GaitEvaluator(params=params).evaluate(default_gait().genes_array, seed=7)
    speed, energy = walk_env_speed_and_energy(seed=7, seconds=3.0, warmup=1.0)
    assert score.feasible and not score.fell
    # Same reset draws, same generator arithmetic: the same trajectory up to round-off.
    assert score.speed == pytest.approx(speed, abs=1e-6)
    assert score.energy == pytest.approx(energy, rel=1e-6)
    assert score.speed_error == pytest.approx(abs(speed - 0.5), abs=1e-6)
    mass = GaitEvaluator(params=params).robot.mass
    assert score.cost_of_transport == pytest.approx(
        energy / (mass * 9.81 * max(score.distance, 0.01 * 2.0)), rel=1e-6
    )


def test_zero_chromosome_does_not_walk():
    # No weights: each neuron settles at u0 / (1 + b), flexor = extensor, no drive, no motion.
    score = GaitEvaluator(params=EvalParams(seconds=2.0)).evaluate(np.zeros(N_GENES), seed=0)
    assert score.feasible
    assert abs(score.speed) < 0.02
    assert score.speed_error == pytest.approx(0.5, abs=0.02)


def test_diverging_cpg_counts_as_a_fall():
    # C1 = -3: each hip flexor/extensor pair excites itself with loop gain 3 > 1 (the leak), so
    # x grows like exp(2 t / tau) past the bound within a few tenths of a second.
    genes = np.zeros(N_GENES)
    genes[1] = -3.0
    score = GaitEvaluator(params=EvalParams(seconds=2.0)).evaluate(genes, seed=0)
    assert score.fell and not score.feasible
    assert score.seconds < 0.5
    assert score.constraint == pytest.approx(1.0 - score.seconds / 2.0)
    assert np.isfinite([score.speed_error, score.cost_of_transport]).all()


def test_evaluation_is_deterministic_per_genes_and_seed():
    ev = GaitEvaluator(params=EvalParams(seconds=1.0))
    g = default_gait().genes_array
    a, b, c = ev.evaluate(g, 3), ev.evaluate(g, 3), ev.evaluate(g, 4)
    assert a == b
    assert a != c
    assert GaitEvaluator(params=EvalParams(seconds=1.0)).evaluate(g, 3) == a


def test_problem_evaluates_a_population_with_pymoo_shapes():
    problem = CPGProblem(default_gait(), EvalParams(seconds=0.5), seed=0)
    X = np.stack([default_gait().genes_array, np.zeros(N_GENES)])
    out = problem.evaluate(X, return_as_dictionary=True)
    assert out["F"].shape == (2, 2) and out["G"].shape == (2, 1)
    assert np.all(np.isfinite(out["F"])) and np.all(out["G"] <= 0)
    assert problem.n_var == 77 and np.array_equal(problem.xl, GENE_LOWER)
    assert np.array_equal(problem.xu, GENE_UPPER)
    # The mapper (a process pool) is never pickled with the problem.
    problem.mapper = lambda rows: [(0.0, 0.0, 0.0)] * len(rows)
    assert pickle.loads(pickle.dumps(problem)).mapper is None


def test_initial_sampling_starts_from_the_base_chromosome():
    problem = CPGProblem(default_gait(), EvalParams(seconds=0.5), seed=0)
    base = default_gait().genes_array
    X = BaseGaitSampling(base, 0.25, 0.05)._do(problem, 16, random_state=np.random.default_rng(0))
    assert X.shape == (16, 77)
    assert np.array_equal(X[0], np.clip(base, GENE_LOWER, GENE_UPPER))
    assert np.all(X >= GENE_LOWER) and np.all(X <= GENE_UPPER)


def test_choose_gait_rule():
    F = np.array([[0.004, 2.0], [0.010, 1.0], [0.030, 0.5], [0.001, 9.0], [0.0, 0.1]])
    G = np.array([[0.0], [0.0], [0.0], [0.0], [0.3]])
    # Best feasible error 0.001; within 0.01 of it are rows 0, 1, 3 -> lowest CoT is row 1.
    assert choose_gait(F, G, speed_tol=0.01) == 1
    assert choose_gait(F, G, speed_tol=0.0) == 3
    # Nothing feasible: the smallest violation.
    assert choose_gait(F, np.array([[0.5], [0.2], [0.9], [0.4], [0.3]])) == 1


def test_config_rejects_a_tiny_population():
    with pytest.raises(ValueError, match="at least 4"):
        NSGAConfig(pop_size=3)


# -- runs --------------------------------------------------------------------------------------


def test_tiny_run_end_to_end_through_the_cli(tmp_path):
    out = tmp_path / "run"
    proc = neurocog("tune-cpg", *TINY, "--workers", "2", "--out", out)
    assert proc.returncode == 0, proc.stderr
    history = read_history(out)
    assert [r["generation"] for r in history] == [1, 2]
    for r in history:
        assert np.asarray(r["X"]).shape == (8, 77)
        assert np.asarray(r["F"]).shape == (8, 2) and np.asarray(r["G"]).shape == (8, 1)
        assert r["evals"] > 0 and r["wall_s"] > 0
    assert history[-1]["n_evals"] == sum(r["evals"] for r in history)
    pareto = json.loads((out / "pareto.json").read_text())
    assert len(pareto["F"]) == len(pareto["X"]) >= 1
    gait = Gait.load(out / "best_gait.json")
    assert gait.notes["feasible"] is True
    assert gait.flexor_gain == default_gait().flexor_gain  # only the genes were searched
    for png in ("fitness.png", "cpg.png"):
        assert (out / png).stat().st_size > 10_000
    # The chosen gait is the rule's pick from the last population.
    F, G = np.asarray(history[-1]["F"]), np.asarray(history[-1]["G"])
    i = choose_gait(F, G)
    assert np.allclose(gait.genes_array, history[-1]["X"][i])
    # Same seed, one worker in this process: the same run.
    same = serial_run(tmp_path / "serial", generations=2, seconds=0.5, seed=1)
    assert same.best_F == pytest.approx(tuple(F[i]), abs=0)
    assert read_history(tmp_path / "serial")[-1]["X"] == history[-1]["X"]


@pytest.mark.slow
def test_kill_and_resume(tmp_path):
    args = ["--pop-size", "8", "--generations", "4", "--eval-seconds", "0.5", "--seed", "2"]
    out = tmp_path / "run"
    proc = subprocess.Popen(
        [sys.executable, "-m", "neurocog_gym.cli", "tune-cpg", *args, "--workers", "2",
         "--out", str(out)],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    try:
        deadline = time.time() + 180
        while time.time() < deadline and len(read_history(out)) < 1 and proc.poll() is None:
            time.sleep(0.02)
        assert 1 <= len(read_history(out)) < 4, "the kill must land inside the run"
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert not (out / "pareto.json").exists()
    resumed = neurocog("tune-cpg", "--out", out, "--resume", "--workers", "2")
    assert resumed.returncode == 0, resumed.stderr
    gens = [r["generation"] for r in read_history(out)]
    assert gens == [1, 2, 3, 4]
    assert (out / "pareto.json").exists() and (out / "best_gait.json").exists()
    # An uninterrupted run with the same seed gives the same history.
    ref = serial_run(tmp_path / "ref", generations=4, seconds=0.5, seed=2)
    assert [r["X"] for r in read_history(out)] == [r["X"] for r in read_history(ref.out)]
    assert (
        json.loads((out / "pareto.json").read_text())["F"]
        == json.loads((ref.out / "pareto.json").read_text())["F"]
    )
    # Resuming a finished run only rewrites the results; extending it adds generations.
    again = neurocog("tune-cpg", "--out", out, "--resume", "--workers", "1",
                     "--generations", "5")  # fmt: skip
    assert again.returncode == 0, again.stderr
    assert [r["generation"] for r in read_history(out)] == [1, 2, 3, 4, 5]


def test_resume_of_a_run_killed_in_its_first_generation(tmp_path):
    # Killed before any checkpoint: run.json is there, nothing else; a torn history line too.
    out = tmp_path / "run"
    serial_run(out, generations=2, seconds=0.2, seed=0, pop_size=4)
    first = read_history(out)
    (out / "checkpoint.pkl").unlink()
    (out / "history.jsonl").write_text('{"generation": 1, "F": [[0.1')
    tune_cpg(out, resume=True, workers=1, plots=False, progress=False)
    assert read_history(out) == [
        {**r, "wall_s": h["wall_s"], "elapsed_s": h["elapsed_s"]}
        for r, h in zip(first, read_history(out), strict=True)
    ]


def test_resume_warns_when_the_robot_model_changed(tmp_path, capsys):
    out = tmp_path / "run"
    serial_run(out, generations=1, seconds=0.2, seed=0, pop_size=4)
    run = json.loads((out / "run.json").read_text())
    assert len(run["model_sha256"]) == 64
    tune_cpg(out, resume=True, workers=1, plots=False, progress=False)
    assert "warning" not in capsys.readouterr().err
    (out / "run.json").write_text(json.dumps({**run, "model_sha256": "0" * 64}))
    tune_cpg(out, resume=True, workers=1, plots=False, progress=False)
    assert "robot MJCF changed" in capsys.readouterr().err


@pytest.mark.slow
def test_ray_cluster_gives_the_same_run(tmp_path):
    ray = pytest.importorskip("ray")
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    # A short temp dir: Ray's socket paths must stay under 107 characters.
    temp = tempfile.mkdtemp(prefix="ray", dir="/tmp")
    ctx = ray.init(num_cpus=1, include_dashboard=False, logging_level="ERROR", _temp_dir=temp)
    try:
        address = ctx.address_info["gcs_address"]
        proc = neurocog("tune-cpg", *TINY, "--ray-address", address, "--out", tmp_path / "r")
        assert proc.returncode == 0, proc.stderr
    finally:
        ray.shutdown()
        shutil.rmtree(temp, ignore_errors=True)
    local = serial_run(tmp_path / "l", generations=2, seconds=0.5, seed=1)
    assert read_history(tmp_path / "r") == [
        {**r, "wall_s": h["wall_s"], "elapsed_s": h["elapsed_s"]}
        for r, h in zip(read_history(local.out), read_history(tmp_path / "r"), strict=True)
    ]


# -- bad arguments -------------------------------------------------------------------------------


def test_population_below_four_is_one_line_error(tmp_path):
    proc = neurocog("tune-cpg", "--pop-size", "3", "--out", tmp_path / "r")
    assert_one_line_error(proc, "pop-size", "at least 4")
    assert not (tmp_path / "r").exists()


def test_unknown_ray_address_is_one_line_error(tmp_path):
    proc = neurocog("tune-cpg", *TINY, "--ray-address", "127.0.0.1:9", "--out", tmp_path / "r")
    assert_one_line_error(proc, "Ray", "127.0.0.1:9")
    assert not (tmp_path / "r").exists()  # nothing half-made: the same --out works afterwards


def test_bad_resume_is_one_line_error(tmp_path):
    proc = neurocog("tune-cpg", "--out", tmp_path / "empty", "--resume")
    assert_one_line_error(proc, "no run to resume")
    out = tmp_path / "run"
    serial_run(out, generations=1, seconds=0.2, seed=0, pop_size=4)
    (out / "checkpoint.pkl").write_bytes(b"\x80\x05 this is not a pickle")
    proc = neurocog("tune-cpg", "--out", out, "--resume", "--workers", "1")
    assert_one_line_error(proc, "checkpoint", "corrupt")
    (out / "checkpoint.pkl").write_bytes(pickle.dumps({"something": "else"}))
    assert_one_line_error(neurocog("tune-cpg", "--out", out, "--resume"), "checkpoint")
    proc = neurocog("tune-cpg", "--out", out, "--resume", "--pop-size", "16")
    assert_one_line_error(proc, "--pop-size 16 differs")
    # Starting a new run over an existing one is refused, not silently mixed.
    assert_one_line_error(neurocog("tune-cpg", *TINY, "--out", out), "already holds a run")
