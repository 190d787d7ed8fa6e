"""scripts/train_ppo.py end to end on a tiny budget, resumed, then evaluated by neurocog bench."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
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
    r = _run(str(SCRIPT), "--env-kwargs", "[1, 2]")
    assert r.returncode == 2 and "--env-kwargs" in r.stderr
    r = _run(str(SCRIPT), "--env-kwargs", "{touch_cost: 5}")
    assert r.returncode == 2 and "--env-kwargs" in r.stderr
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
    # with a behaviour-cloning warm start through VecNormalize (raw observations to the AEF)
    r = _run(str(SCRIPT), "--total-steps", "128", "--out", str(out), "--vec", "subproc",
             "--no-tensorboard", "--bc-steps", "64", "--bc-epochs", "2",
             "--env-kwargs", '{"touch_cost": 50}', *TINY)  # fmt: skip
    assert r.returncode == 0, r.stderr
    s = json.loads((out / "train_summary.json").read_text())
    assert s["total_steps"] == 128 and s["n_envs"] == 2 and s["vec"] == "subproc"
    assert (out / "model.zip").is_file()
    bc = json.loads((out / "bc_summary.json").read_text())
    assert bc == s["behaviour_cloning"] and bc["steps"] == 64 and bc["epochs"] == 2
    assert (out / "checkpoints" / "ppo_0_steps.zip").is_file()
    assert (out / "checkpoints" / "ppo_vecnormalize_0_steps.pkl").is_file()
    r = _run(str(SCRIPT), "--out", str(out), "--resume", "--bc-steps", "64")
    assert r.returncode == 2 and "--bc-steps" in r.stderr


def _module():
    import importlib.util

    spec = importlib.util.spec_from_file_location("train_ppo", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


# A standing robot in its heading frame (x ahead, y left, z above the floor) and a remembered
# block 0.6 m ahead across the left of its path: the AEF's fit walks round it (provision).
_HIPS = np.array([[0.19, 0.07, 0.3], [0.19, -0.07, 0.3], [-0.19, 0.07, 0.3], [-0.19, -0.07, 0.3]])
_THIGHS = _HIPS + [[0, 0.05, 0], [0, -0.05, 0], [0, 0.05, 0], [0, -0.05, 0]]
_FEET = _THIGHS * [1, 1, 0] + [0, 0, 0.018]
_LEGS = np.stack([_HIPS, _THIGHS, _THIGHS + [0.02, 0, -0.12]], 1)
_BLOCK = [1.0, 0.85, 0.15, 0.0, 0.05, 0.1, 0.07]


class _ScriptedVec:
    """A stand-in SB3 VecEnv: observations drawn from the obstacle env's space, with a standing
    robot and a block far ahead to walk round (the AEF in provision mode), reward 1 every step,
    every env's episode ending every 4th step."""

    def __init__(self, space, n=2, seed=0):
        self.space, self.num_envs, self.t = space, n, 0
        self.rng = np.random.default_rng(seed)

    def _obs(self):
        rows = []
        for _ in range(self.num_envs):
            o = {k: np.asarray(s.sample()) for k, s in self.space.spaces.items()}
            o["aef_input"] = self.rng.uniform(-1, 1, o["aef_input"].shape).astype(np.float32)
            o["aef_input"][3:15] = o["interrupt_direction"] = np.zeros(12, np.float32)
            o["torso_quat"] = np.array([1, 0, 0, 0], np.float32)
            o["torso_lin_vel"] = np.zeros(3, np.float32)
            o["block_met"] = np.full(4, -1, np.float32)
            o["remembered_blocks"] = np.zeros(56, np.float32)
            o["remembered_blocks"][:7] = _BLOCK
            o["feet"] = _FEET.astype(np.float32).ravel()
            o["leg_joints"] = _LEGS.astype(np.float32).ravel()
            rows.append(o)
        return {k: np.stack([r[k] for r in rows]) for k in rows[0]}

    def reset(self):
        return self._obs()

    def step(self, actions):
        self.t += 1
        done = np.full(self.num_envs, self.t % 4 == 0)
        info = [{"outcome": "success", "passed": True} if d else {} for d in done]
        return self._obs(), np.ones(self.num_envs, np.float32), done, info


def test_behaviour_cloning_fits_the_aef_actions_and_the_returns():
    import gymnasium as gym
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv

    import neurocog_gym  # noqa: F401  (registers the ids)

    mod = _module()
    real = DummyVecEnv([lambda: gym.make("NeuroCog/SuddenObstacle-v3")])
    space = real.observation_space
    fake = _ScriptedVec(space, n=2)
    # The recorded returns, by hand: reward 1, episodes of 4 steps, gamma 0.5 -> 1.875, 1.75,
    # 1.5, 1 within each episode; the 2 steps after the last episode end are dropped (NaN).
    obs, act, ret, counts = mod._demonstrations(fake, 20, 0.5, False)
    assert act.shape == (20, 15) and obs["aef_input"].shape == (20, 31)
    assert counts == {"success": 4, "touch": 0, "fail": 0}
    per_step = ret.reshape(10, 2)[:, 0]
    np.testing.assert_allclose(per_step[:8], [1.875, 1.75, 1.5, 1.0] * 2)
    assert np.isnan(per_step[8:]).all()
    # The AEF's provision mode gives non-zero walking provisions to imitate.
    assert np.abs(act[:, 12:]).mean() > 0.05 and not act[:, :12].any()

    model = PPO("MultiInputPolicy", real, seed=0, device="cpu", n_steps=64, batch_size=64,
                policy_kwargs={"log_std_init": -2.0})  # fmt: skip
    args = mod.Args(bc_steps=256, bc_epochs=40, batch_size=64, seed=0, gamma=0.5)
    bc = mod._clone(model, _ScriptedVec(space, n=2, seed=1), args)
    assert bc["steps"] == 256 and bc["aef_outcomes"]["success"] == 64
    # Fitted: the policy's mean is far nearer the AEF's actions than the untrained all-zeros.
    assert bc["action_mse"] < 0.3 * bc["action_mse_of_zeros"]
    assert bc["loss_last_epoch"] < bc["loss_first_epoch"]
    real.close()


def test_obs_mode_arguments_exit_2():
    r = _run(str(SCRIPT), "--obs-mode", "rgb")
    assert r.returncode == 2 and "--obs-mode" in r.stderr
    r = _run(str(SCRIPT), "--obs-mode", "depth_only", "--bc-steps", "64")
    assert r.returncode == 2 and "--bc-steps" in r.stderr
    r = _run(str(SCRIPT), "--env-kwargs", '{"observation_mode": "depth"}')
    assert r.returncode == 2 and "--obs-mode" in r.stderr


@pytest.mark.slow
def test_train_from_depth_and_bench_in_the_models_mode(tmp_path):
    """--obs-mode depth_only: a CNN on the depth image, left out of VecNormalize; the bench
    builds its envs in the mode the saved model's observation space asks for."""
    import pickle

    from neurocog_gym.policies import make_policy

    out = tmp_path / "ppo_depth"
    r = _run(str(SCRIPT), "--total-steps", "128", "--out", str(out), "--obs-mode", "depth_only",
             "--no-tensorboard", *TINY)  # fmt: skip
    assert r.returncode == 0, r.stderr
    s = json.loads((out / "train_summary.json").read_text())
    assert s["obs_mode"] == "depth_only" and s["total_steps"] == 128
    stats = pickle.loads((out / "vecnormalize.pkl").read_bytes())
    assert "depth" not in stats.norm_obs_keys and "joint_pos" in stats.norm_obs_keys
    policy = make_policy(str(out / "model.zip"))
    assert policy.env_kwargs == {"observation_mode": "depth_only"}
    assert type(policy.model.policy.features_extractor.extractors["depth"]).__name__ == "NatureCNN"

    bench = tmp_path / "bench"
    r = _run("-m", "neurocog_gym.cli", "bench", "--policy", str(out / "model.zip"), "--trials",
             "1", "--workers", "1", "--max-seconds", "1", "--scenario", "sudden", "--out",
             str(bench))  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert json.loads((bench / "summary.json").read_text())["sudden"]["trials"] == 1


def test_resume_takes_the_model_with_most_steps(tmp_path):
    """--resume continues from model.zip when it holds more steps than the last checkpoint."""
    import importlib.util
    import json
    import zipfile

    spec = importlib.util.spec_from_file_location("train_ppo", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)

    def save(path, steps):
        path.parent.mkdir(parents=True, exist_ok=True)
        with zipfile.ZipFile(path, "w") as z:
            z.writestr("data", json.dumps({"num_timesteps": steps}))

    assert mod._latest_checkpoint(tmp_path) is None
    save(tmp_path / "checkpoints" / "ppo_20000_steps.zip", 20_000)
    save(tmp_path / "checkpoints" / "ppo_700000_steps.zip", 700_000)
    assert mod._latest_checkpoint(tmp_path).name == "ppo_700000_steps.zip"
    save(tmp_path / "model.zip", 720_928)  # the run's end, after its last checkpoint
    assert mod._latest_checkpoint(tmp_path).name == "model.zip"
    save(tmp_path / "model.zip", 10_000)  # an old final model, checkpoints of a longer run
    assert mod._latest_checkpoint(tmp_path).name == "ppo_700000_steps.zip"
