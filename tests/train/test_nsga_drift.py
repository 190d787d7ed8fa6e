"""The optional lateral-drift constraint of the NSGA-II problem (issue 6) and the drift and
heading measures of the evaluator."""

import json
import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest

import neurocog_gym  # noqa: F401
from neurocog_gym.locomotion.gait import default_gait
from neurocog_gym.train.evaluate import EvalParams, GaitEvaluator, score_row
from neurocog_gym.train.nsga import CPGProblem, NSGAConfig, choose_gait, read_history, tune_cpg


def _env_drift_and_heading(seed, seconds, warmup):
    env = gym.make("NeuroCog/Walk-v3", max_episode_steps=None)
    env.reset(seed=seed)
    u = env.unwrapped
    n, w = int(round(seconds / u.dt)), int(round(warmup / u.dt))
    ys, yaws, xs = [], [], []
    for _ in range(n):
        env.step(np.zeros(15, np.float32))
        qw, qx, qy, qz = u.data.qpos[3:7]
        ys.append(u.data.qpos[1])
        xs.append(u.data.qpos[0])
        yaws.append(np.arctan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz)))
    yaws = np.unwrap(yaws)
    # the window runs from the state after cycle w to the state after cycle n
    return ys[n - 1] - ys[w - 1], yaws[n - 1] - yaws[w - 1], xs[n - 1] - xs[w - 1]


def test_drift_and_heading_match_a_walk_env_rollout():
    score = GaitEvaluator(params=EvalParams(seconds=4.0)).evaluate(default_gait().genes_array, 3)
    dy, dyaw, dx = _env_drift_and_heading(seed=3, seconds=4.0, warmup=1.0)
    assert score.distance == pytest.approx(dx, abs=1e-6)
    assert score.lateral_drift == pytest.approx(dy, abs=1e-6)
    assert score.heading_change == pytest.approx(dyaw, abs=1e-6)
    assert score.drift_per_10m == pytest.approx(10 * abs(dy) / dx, rel=1e-6)
    assert score_row(score) == (score.speed_error, score.cost_of_transport, score.constraint,
                                score.drift_per_10m)  # fmt: skip


def test_drift_of_a_robot_that_does_not_walk_is_finite():
    score = GaitEvaluator(params=EvalParams(seconds=1.0)).evaluate(np.zeros(77), 0)
    assert np.isfinite(score.drift_per_10m) and np.isfinite(score.heading_change)


def _rows(drifts):
    # speed error, CoT, fall G, drift per 10 m
    return [(0.01, 0.5, 0.0, d) for d in drifts]


@pytest.mark.parametrize("max_drift", [0.0, 0.5])
def test_problem_adds_the_drift_constraint_only_when_asked(max_drift):
    drifts = [0.1, 0.5, 2.0]
    prob = CPGProblem(default_gait(), EvalParams(seconds=0.5), 0,
                      mapper=lambda rows: _rows(drifts), max_drift=max_drift)  # fmt: skip
    out = {}
    prob._evaluate(np.zeros((3, 77)), out)
    if max_drift == 0:
        assert prob.n_ieq_constr == 1
        np.testing.assert_array_equal(out["G"], np.zeros((3, 1)))
    else:
        assert prob.n_ieq_constr == 2
        np.testing.assert_allclose(out["G"], [[0, -0.4], [0, 0.0], [0, 1.5]])
        # the drifting one is infeasible, so the chosen gait is another
        F = np.array([[0.05, 0.5], [0.03, 0.5], [0.0, 0.1]])
        assert choose_gait(F, out["G"]) == 1


def test_config_rejects_a_negative_max_drift():
    with pytest.raises(ValueError, match="max-drift"):
        NSGAConfig(pop_size=4, max_drift=-0.1)


def test_tiny_run_with_the_constraint_records_two_constraints(tmp_path):
    cfg = NSGAConfig(pop_size=4, generations=2, seed=2, max_drift=0.3,
                     eval=EvalParams(seconds=1.5))  # fmt: skip
    tune_cpg(tmp_path / "r", cfg, workers=1, plots=False, progress=False)
    hist = read_history(tmp_path / "r")
    assert [len(g) for g in hist[-1]["G"]] == [2] * 4
    run = json.loads((tmp_path / "r" / "run.json").read_text())
    assert run["config"]["max_drift"] == 0.3
    best = json.loads((tmp_path / "r" / "best_gait.json").read_text())
    assert best["notes"]["max_drift"] == 0.3 and "drift_per_10m" in best["notes"]
    pareto = json.loads((tmp_path / "r" / "pareto.json").read_text())
    assert "G2 = drift per 10 m" in pareto["constraint"]


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "neurocog_gym.cli", *map(str, args)],
                          capture_output=True, text=True, timeout=240)  # fmt: skip


def test_cli_max_drift_flag(tmp_path):
    bad = _cli("tune-cpg", "--max-drift", "-1", "--out", tmp_path / "x")
    assert bad.returncode != 0 and "Traceback" not in bad.stderr and "--max-drift" in bad.stderr
    out = tmp_path / "r"
    ok = _cli("tune-cpg", "--pop-size", "4", "--generations", "1", "--eval-seconds", "0.3",
              "--workers", "1", "--max-drift", "0.4", "--out", out)  # fmt: skip
    assert ok.returncode == 0, ok.stderr
    assert json.loads((out / "run.json").read_text())["config"]["max_drift"] == 0.4
    again = _cli("tune-cpg", "--out", out, "--resume", "--max-drift", "0.2")
    assert again.returncode == 2 and "--max-drift 0.2 differs" in again.stderr
