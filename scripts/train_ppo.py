"""PPO (stable-baselines3) on NeuroCog/SuddenObstacle-v3: vectorised envs, TensorBoard, checkpoints.

The agent acts where the paper's AEF acts (15 values: 12 joint interrupts, 3 walking
provisions); the CPG keeps walking underneath, so the policy starts near "all zeros" (a small
initial action spread, ``log_std_init``) and learns corrections. Observations are the env's
``Dict`` (``MultiInputPolicy``); ``Box`` observation envs such as Gymnasium's ``Ant-v5`` get
``MlpPolicy`` (used by ``scripts/bench_env.py --ppo`` for the throughput comparison).

Files in ``--out``: ``args.json``, ``checkpoints/ppo_<steps>_steps.zip`` (every
``--checkpoint-every`` env steps), ``tb/`` (TensorBoard: ``tensorboard --logdir OUT/tb``; besides
SB3's losses it logs ``outcome/success``, ``outcome/touch``, ``outcome/fail`` over finished
episodes), ``model.zip`` (the final model) and ``train_summary.json`` (steps, wall time,
steps/s, outcome counts, fails split into fell / stuck). ``--resume`` continues from the saved
model with the most env steps (the newest checkpoint or ``model.zip``) up to ``--total-steps``.
Observations are normalised by SB3's
``VecNormalize`` (``--no-normalize-obs`` turns it off): its running statistics are saved as
``vecnormalize.pkl`` beside ``model.zip`` and ``ppo_vecnormalize_<steps>_steps.pkl`` beside each
checkpoint (written before the zip, both atomically), restored on ``--resume``, and loaded by
``neurocog_gym.policies.SB3Policy``, so ``neurocog bench --policy OUT/model.zip`` evaluates the
policy as it was trained. ``--obs-mode depth_only`` (or ``depth``) trains end to end from the
four ToF depth images (the env's ``observation_mode``: a (4, 43, 56) uint8 image key, to which
``MultiInputPolicy`` gives SB3's NatureCNN; VecNormalize leaves it alone); the bench reads the
mode off the saved model's observation space. The defaults (small action spread, learning
rate 3e-5, 2048-step rollouts, ``target_kl`` 0.02) come from short diagnostic trainings on v0;
the reasons are in ``docs/training.md`` (PPO).

    python scripts/train_ppo.py --total-steps 200000 --n-envs 2 --out runs/ppo
    python scripts/train_ppo.py --out runs/ppo --resume            # after a kill
    neurocog bench --policy runs/ppo/model.zip --trials 10
    python scripts/train_ppo.py --obs-mode depth_only --out runs/ppo_depth   # from depth
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import importlib
import json
import re
import sys
import time
from pathlib import Path

import numpy as np

from neurocog_gym.bench.machine import field_doc


@dataclasses.dataclass(frozen=True)
class Args:
    """Command-line arguments (``--name-with-dashes``)."""

    env_id: str = "NeuroCog/SuddenObstacle-v3"
    """Gymnasium id to train on."""
    total_steps: int = 200_000
    """Env steps in all (over every env), resumed runs included."""
    env_kwargs: str = ""
    """JSON object of keyword arguments for gymnasium.make, e.g. '{"touch_cost": 50}' (the
    training envs only; neurocog bench evaluates on the registered env)."""
    obs_mode: str = "default"
    """The env's observation_mode: default (the perception's keys), depth (those plus the ToF
    depth image) or depth_only (proprioception and the depth image, no attention pipeline:
    end-to-end learning from depth). neurocog bench builds its envs in the model's mode."""
    n_envs: int = 2
    """Parallel envs."""
    vec: str = "spin"
    """spin (env 0 in this process, the others in spinning shared-memory workers:
    neurocog_gym.envs.sb3_vec.SpinVecEnv; 1.64x SubprocVecEnv's PPO steps/s here on v0,
    docs/generated/benchmarks_ppo.md), subproc (one process per env, SB3's SubprocVecEnv) or
    dummy (all in this process)."""
    seed: int = 0
    """Seed of the envs (env i gets seed + i), the policy initialisation and the sampling."""
    n_steps: int = 2048
    """Rollout length per env and update."""
    batch_size: int = 512
    """Minibatch size."""
    n_epochs: int = 10
    """Epochs over each rollout."""
    learning_rate: float = 3e-5
    """Adam step size (small: an interrupt of 0.1 is 30 % of the CPG's authority over a joint,
    and larger steps moved the policy's mean off the CPG walk faster than it learned)."""
    gamma: float = 0.99
    """Discount."""
    gae_lambda: float = 0.95
    """GAE lambda."""
    clip_range: float = 0.2
    """PPO clip range."""
    ent_coef: float = 0.0
    """Entropy bonus."""
    target_kl: float = 0.02
    """Stop an update's epochs early once the approximate KL to the rollout policy exceeds
    1.5 x this (SB3's target_kl); 0 for no limit."""
    log_std_init: float = -2.0
    """Initial log std of the Gaussian actions (-2: spread 0.135 around zero = CPG walking;
    with -1, spread 0.37, the zero-mean policy passed 1 sudden block in 20; -3.5, spread 0.03,
    around a --bc-steps clone)."""
    normalize_obs: bool = True
    """Normalise the observations with VecNormalize (running mean / std of every Box key);
    its statistics are saved as OUT/vecnormalize.pkl beside model.zip (and with every
    checkpoint), where ``neurocog bench --policy OUT/model.zip`` finds them."""
    normalize_reward: bool = False
    """Scale the rewards by VecNormalize's running std of the discounted return (training only)."""
    bc_steps: int = 0
    """Behaviour-cloning warm start: env steps (over every env) of the paper's AEF controller
    (``neurocog_gym.policies.AEFPolicy``, shipped weights) recorded before PPO; the policy's
    action mean is fitted to its actions and the value net to the recorded discounted returns
    (0: off, the policy starts at all zeros). A new run only (not with --resume); the cloned
    policy is saved as OUT/checkpoints/ppo_0_steps.zip before PPO starts. Pair it with a small
    action spread: with --log-std-init -3.5 and --env-kwargs '{"touch_cost": 50}', 35 min of PPO
    from the clone beat the AEF on v0 (docs/training.md); with the default -2 the clone failed
    two thirds of its training episodes and PPO drifted off."""
    bc_epochs: int = 30
    """Epochs over the recorded steps of the behaviour-cloning fit."""
    net_arch: str = "128,128"
    """Hidden layer widths of the policy and value networks."""
    checkpoint_every: int = 20_000
    """Env steps (over every env) between checkpoints."""
    max_minutes: float = 0.0
    """Stop (and save) after this many wall-clock minutes of training; 0 for no limit."""
    torch_threads: int = 1
    """torch.set_num_threads (the envs want the other cores)."""
    out: str = "runs/ppo"
    """Run folder."""
    resume: bool = False
    """Continue the run in --out from its newest checkpoint."""
    tensorboard: bool = True
    """Write TensorBoard logs to OUT/tb."""
    progress: bool = False
    """Show SB3's progress bar."""


def parse_args(argv: list[str] | None = None) -> Args:
    """Parse the command line into :class:`Args` (``--flag``/``--no-flag`` for booleans)."""
    parser = argparse.ArgumentParser(
        description=__doc__.splitlines()[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    for f in dataclasses.fields(Args):
        name = "--" + f.name.replace("_", "-")
        help_ = field_doc(__file__, f.name)
        if isinstance(f.default, bool):
            parser.add_argument(name, action=argparse.BooleanOptionalAction, default=f.default,
                                help=help_)  # fmt: skip
        else:
            parser.add_argument(name, type=type(f.default), default=f.default,
                                help=f"{help_} (default {f.default})")  # fmt: skip
    args = Args(**vars(parser.parse_args(argv)))
    if args.total_steps < 1 or args.n_envs < 1 or args.n_steps < 2 or args.batch_size < 2:
        parser.error("--total-steps, --n-envs must be >= 1; --n-steps, --batch-size >= 2")
    if args.vec not in ("subproc", "spin", "dummy"):
        parser.error(f"--vec must be subproc, spin or dummy, got {args.vec!r}")
    if args.bc_steps < 0 or args.bc_epochs < 1:
        parser.error("--bc-steps must be >= 0 and --bc-epochs >= 1")
    if args.bc_steps and args.resume:
        parser.error("--bc-steps warm-starts a new run: not with --resume")
    if args.obs_mode not in ("default", "depth", "depth_only"):
        parser.error(f"--obs-mode must be default, depth or depth_only, got {args.obs_mode!r}")
    if args.bc_steps and args.obs_mode == "depth_only":
        parser.error("--bc-steps clones the AEF, which reads the keys depth_only leaves out")
    if args.checkpoint_every < 1 or args.max_minutes < 0 or args.target_kl < 0:
        parser.error("--checkpoint-every must be >= 1, --max-minutes >= 0, --target-kl >= 0")
    try:
        kw = _env_kwargs(args.env_kwargs)
    except ValueError as e:  # json.JSONDecodeError is a ValueError
        parser.error(f"--env-kwargs must be a JSON object of gymnasium.make arguments: {e}")
    if "observation_mode" in kw:
        parser.error("give the observation mode as --obs-mode, not in --env-kwargs")
    try:
        _net_arch(args.net_arch)
    except ValueError:
        parser.error(f"--net-arch must be comma-separated positive integers, got {args.net_arch!r}")
    return args


def _net_arch(text: str) -> list[int]:
    widths = [int(w) for w in text.split(",") if w.strip()]
    if not widths or min(widths) < 1:
        raise ValueError(text)
    return widths


def _make_one(env_id: str, **kwargs):
    """Build one env; runs in each SubprocVecEnv worker, which must register the ids itself."""
    import gymnasium as gym

    importlib.import_module("neurocog_gym")  # registers the NeuroCog/* ids in this process
    return gym.make(env_id, **kwargs)


def _env_kwargs(text: str) -> dict:
    """The parsed ``--env-kwargs`` (empty: none); ValueError unless a JSON object."""
    if not text.strip():
        return {}
    kw = json.loads(text)
    if not isinstance(kw, dict):
        raise ValueError(f"not a JSON object: {text!r}")
    return kw


def _make_vec_env(args: Args):
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    from neurocog_gym.envs.sb3_vec import SpinVecEnv

    cls = {"subproc": SubprocVecEnv, "spin": SpinVecEnv}.get(args.vec, DummyVecEnv)
    if args.n_envs == 1:
        cls = DummyVecEnv
    kwargs = _env_kwargs(args.env_kwargs)
    if args.obs_mode != "default":
        kwargs["observation_mode"] = args.obs_mode
    make = functools.partial(_make_one, args.env_id, **kwargs)
    return make_vec_env(make, n_envs=args.n_envs, seed=args.seed, vec_env_cls=cls)


def _latest_checkpoint(out: Path) -> Path | None:
    """The saved model of ``out`` with the most env steps: a checkpoint or ``model.zip``.

    ``model.zip`` is written at the end of a run, after the last checkpoint, and may hold more
    steps than it (a run of 720,928 steps has its last 20,000-step checkpoint at 720,000), so
    the steps are read from each file (SB3 keeps ``num_timesteps`` in the zip's ``data``).
    """
    found = [
        (int(re.search(r"ppo_(\d+)_steps", p.name).group(1)), p)
        for p in (out / "checkpoints").glob("ppo_*_steps.zip")
    ]
    final = out / "model.zip"
    if final.exists():
        found.append((_saved_steps(final), final))
    return max(found, key=lambda sp: sp[0])[1] if found else None


def _saved_steps(model: Path) -> int:
    """``num_timesteps`` of a stable-baselines3 zip (its ``data`` entry, JSON)."""
    import zipfile

    with zipfile.ZipFile(model) as z:
        return int(json.loads(z.read("data")).get("num_timesteps", 0))


def stats_path(model: Path) -> Path:
    """Where the VecNormalize statistics of a saved model live: ``vecnormalize.pkl`` beside
    ``model.zip``, ``ppo_vecnormalize_<steps>_steps.pkl`` beside ``ppo_<steps>_steps.zip``
    (SB3's CheckpointCallback naming), where ``neurocog_gym.policies.SB3Policy`` looks."""
    from neurocog_gym.policies import vecnormalize_path

    return vecnormalize_path(model)


def _box_keys(space) -> list[str] | None:
    """The Box keys of a Dict observation space that are not images (VecNormalize normalises
    only those; SB3's CNN scales an image by 1/255 itself and wants it raw)."""
    import gymnasium as gym
    from stable_baselines3.common.preprocessing import is_image_space

    if not isinstance(space, gym.spaces.Dict):
        return None
    return [
        k
        for k, s in space.spaces.items()
        if isinstance(s, gym.spaces.Box) and not is_image_space(s)
    ]


def _normalized(env, args: Args, stats: Path | None):
    """Wrap ``env`` in VecNormalize: fresh statistics, or those saved at ``stats`` (resume)."""
    from stable_baselines3.common.vec_env import VecNormalize

    if stats is not None:
        venv = VecNormalize.load(str(stats), env)
        venv.training = True
        return venv
    return VecNormalize(
        env, norm_obs=args.normalize_obs, norm_reward=args.normalize_reward,
        norm_obs_keys=_box_keys(env.observation_space) if args.normalize_obs else None,
        gamma=args.gamma,
    )  # fmt: skip


def _save_stats(venv, path: Path) -> None:
    from neurocog_gym.io import atomic_path

    with atomic_path(path) as tmp:
        venv.save(str(tmp))


def _outcome_callback():
    from stable_baselines3.common.callbacks import BaseCallback

    class OutcomeCallback(BaseCallback):
        """Counts the outcome of every finished obstacle episode; logs the shares.

        ``fails`` splits the fails into ``fell`` (fell or physics fault) and ``stuck`` (not
        passed when the time limit ran out). ``blocks`` counts the sudden-obstacle episodes whose
        block appeared only at the env's deadline (``forced``: the policy kept the front soles
        loaded through the swings that would have triggered it) or never (``none``: the episode
        ended first) — a policy that learns to keep the block away shows up here."""

        def __init__(self):
            super().__init__()
            self.counts = {"success": 0, "touch": 0, "fail": 0}
            self.fails = {"fell": 0, "stuck": 0}
            self.blocks = {"forced": 0, "none": 0}
            self._recent: list[str] = []

        def _on_step(self) -> bool:
            for info, done in zip(self.locals["infos"], self.locals["dones"], strict=True):
                if done and "outcome" in info:
                    # A truncated, not-passed episode is a fail (the env's outcome is final here).
                    o = info["outcome"]
                    if not info.get("passed"):
                        o = "fail"
                    self.counts[o] += 1
                    if o == "fail":
                        fell = info.get("fell") or info.get("sim_unstable")
                        self.fails["fell" if fell else "stuck"] += 1
                    if info.get("appear_forced"):
                        self.blocks["forced"] += 1
                    elif "appeared_at" in info and info["appeared_at"] is None:
                        self.blocks["none"] += 1
                    self._recent = (self._recent + [o])[-100:]
            return True

        def _on_rollout_end(self) -> None:
            if self._recent:
                for o in self.counts:
                    self.logger.record(f"outcome/{o}", self._recent.count(o) / len(self._recent))
            for k, n in self.fails.items():
                self.logger.record(f"outcome/total_{k}", n)
            for k, n in self.blocks.items():
                self.logger.record(f"outcome/total_block_{k}", n)

    return OutcomeCallback()


def _time_limit_callback(minutes: float):
    from stable_baselines3.common.callbacks import BaseCallback

    class TimeLimit(BaseCallback):
        """Stops training once ``minutes`` of wall-clock time have passed."""

        def _on_training_start(self) -> None:
            self.t0 = time.perf_counter()

        def _on_step(self) -> bool:
            return minutes <= 0 or time.perf_counter() - self.t0 < 60.0 * minutes

    return TimeLimit()


def _demonstrations(venv, steps: int, gamma: float, progress: bool):
    """Run the AEF controller in ``venv`` for ``steps`` env steps (over every env).

    Returns the raw observations (a dict of (T·n, ...) arrays), the actions, the discounted
    returns (only of steps whose episode ended inside the recording; the rest are dropped) and
    the outcome counts of the finished episodes.
    """
    from tqdm import tqdm

    from neurocog_gym.policies import AEFPolicy

    n = venv.num_envs
    # One AEF per env: it keeps per-episode state (its fit), reset when the env's episode ends
    # (the VecEnv has reset that env by the time it hands back the next observation).
    aefs = [AEFPolicy() for _ in range(n)]
    raw_of = getattr(venv, "get_original_obs", None)
    obs = venv.reset()
    rows = -(-steps // n)
    keys = list(obs)
    rec_obs = {k: [] for k in keys}
    rec_act, rec_rew, rec_done = [], [], []
    counts = {"success": 0, "touch": 0, "fail": 0}
    for _ in tqdm(range(rows), desc="AEF demonstrations", unit="step", disable=not progress):
        raw = raw_of() if raw_of is not None else obs
        act = np.stack([aefs[i]({k: raw[k][i] for k in keys}) for i in range(n)])
        for k in keys:
            rec_obs[k].append(np.array(raw[k], copy=True))
        obs, rew, done, infos = venv.step(act)
        # VecNormalize hands back the raw rewards too (its reward scaling is for training).
        rew = venv.get_original_reward() if hasattr(venv, "get_original_reward") else rew
        rec_act.append(act)
        rec_rew.append(np.asarray(rew, np.float64))
        rec_done.append(np.asarray(done, bool))
        for i, (info, d) in enumerate(zip(infos, done, strict=True)):
            if d:
                aefs[i].reset()
            if d and "outcome" in info:
                counts["fail" if not info.get("passed") else info["outcome"]] += 1
    rew, done = np.array(rec_rew), np.array(rec_done)  # (T, n)
    ret = np.full(rew.shape, np.nan)
    run = np.full(n, np.nan)  # NaN until an episode end is seen (going backwards)
    for t in range(rows - 1, -1, -1):
        run = np.where(done[t], rew[t], rew[t] + gamma * run)
        ret[t] = run
    # Step-major, env within each step, as the returns' reshape below.
    flat = {k: np.concatenate(rec_obs[k]) for k in keys}
    return flat, np.concatenate(rec_act), ret.reshape(-1), counts


def _clone(model, venv, args: Args) -> dict:
    """Fit the PPO policy to the AEF controller's recorded behaviour (``--bc-steps``)."""
    import torch

    t0 = time.perf_counter()
    obs, act, ret, counts = _demonstrations(venv, args.bc_steps, args.gamma, args.progress)
    norm = getattr(venv, "normalize_obs", None)
    if norm is not None:
        obs = norm(obs)  # with the statistics gathered over the recording
    policy = model.policy
    policy.set_training_mode(True)
    opt = torch.optim.Adam(policy.parameters(), lr=1e-3)
    rng = np.random.default_rng(args.seed)
    n = len(act)
    act_t = torch.as_tensor(act, dtype=torch.float32)
    ret_t = torch.as_tensor(ret, dtype=torch.float32)
    has_ret = torch.isfinite(ret_t)
    losses = []
    for _ in range(args.bc_epochs):
        order = rng.permutation(n)
        tot = 0.0
        for lo in range(0, n, args.batch_size):
            ix = order[lo : lo + args.batch_size]
            o, _ = policy.obs_to_tensor({k: v[ix] for k, v in obs.items()})
            dist = policy.get_distribution(o)
            loss = ((dist.distribution.mean - act_t[ix]) ** 2).mean()
            m = has_ret[ix]
            if bool(m.any()):
                v = policy.predict_values(o).squeeze(-1)
                loss = loss + 0.01 * ((v[m] - ret_t[ix][m]) ** 2).mean()
            opt.zero_grad()
            loss.backward()
            opt.step()
            tot += float(loss.detach()) * len(ix)
        losses.append(tot / n)
    policy.set_training_mode(False)
    with torch.no_grad():
        o, _ = policy.obs_to_tensor(obs)
        mse = float(((policy.get_distribution(o).distribution.mean - act_t) ** 2).mean())
    return {
        "steps": int(n),
        "epochs": args.bc_epochs,
        "aef_outcomes": counts,
        "loss_first_epoch": round(losses[0], 6),
        "loss_last_epoch": round(losses[-1], 6),
        "action_mse": round(mse, 6),
        "action_mse_of_zeros": round(float((act_t**2).mean()), 6),
        "wall_s": round(time.perf_counter() - t0, 1),
    }


def train(args: Args) -> dict:
    """Train (or resume) PPO as ``args`` says; return the run summary (also written to disk)."""
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.callbacks import CallbackList, CheckpointCallback

    from neurocog_gym.io import atomic_path, atomic_write_text

    torch.set_num_threads(args.torch_threads)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    ckpt = _latest_checkpoint(out) if args.resume else None
    if args.resume and ckpt is None:
        raise FileNotFoundError(f"--resume: no checkpoint or model.zip in {out}")
    if not args.resume and (out / "model.zip").exists():
        raise FileExistsError(f"{out}/model.zip exists: pass --resume or another --out")
    stats = stats_path(ckpt) if ckpt is not None else None
    if stats is not None and not stats.exists():
        stats = None
    use_stats = args.normalize_obs or args.normalize_reward
    if ckpt is not None and (stats is not None) != use_stats:
        have, flag = ("has", "--normalize-obs") if stats else ("has no", "--no-normalize-obs")
        raise ValueError(f"--resume: {ckpt} {have} VecNormalize statistics; pass {flag}")
    if not args.resume:
        # A killed earlier run's statistics must not be taken for this model's.
        (out / "vecnormalize.pkl").unlink(missing_ok=True)
    atomic_write_text(out / "args.json", json.dumps(dataclasses.asdict(args), indent=2) + "\n")
    env = _make_vec_env(args)
    if use_stats:
        env = _normalized(env, args, stats)
    tb = str(out / "tb") if args.tensorboard else None
    if ckpt is not None:
        model = PPO.load(ckpt, env=env, device="cpu", tensorboard_log=tb)
        print(f"resuming from {ckpt} at {model.num_timesteps} steps", flush=True)
    else:
        import gymnasium as gym

        is_dict = isinstance(env.observation_space, gym.spaces.Dict)
        policy = "MultiInputPolicy" if is_dict else "MlpPolicy"
        model = PPO(
            policy, env, n_steps=args.n_steps, batch_size=args.batch_size, n_epochs=args.n_epochs,
            learning_rate=args.learning_rate, gamma=args.gamma, gae_lambda=args.gae_lambda,
            clip_range=args.clip_range, ent_coef=args.ent_coef, seed=args.seed, device="cpu",
            target_kl=args.target_kl if args.target_kl > 0 else None,
            tensorboard_log=tb, verbose=0,
            policy_kwargs={"log_std_init": args.log_std_init, "net_arch": _net_arch(args.net_arch)},
        )  # fmt: skip
    bc = None
    if args.bc_steps and ckpt is None:
        bc = _clone(model, env, args)
        # The cloned policy as the run's step-0 checkpoint (with its statistics): benchable on
        # its own, and what --resume starts from if PPO is killed before its first checkpoint.
        zip0 = out / "checkpoints" / "ppo_0_steps.zip"
        zip0.parent.mkdir(parents=True, exist_ok=True)
        if use_stats:
            _save_stats(env, stats_path(zip0))
        with atomic_path(zip0) as tmp:
            model.save(tmp)
        atomic_write_text(out / "bc_summary.json", json.dumps(bc, indent=2) + "\n")
        print(f"behaviour cloning: {bc}", flush=True)
    done_before = int(model.num_timesteps)
    remaining = args.total_steps - done_before
    outcome = _outcome_callback()

    class AtomicCheckpoint(CheckpointCallback):
        """SB3's checkpoint callback writing through a temp file and a rename (a kill during a
        save would otherwise leave a truncated zip that ``--resume`` then picks as newest)."""

        def _on_step(self) -> bool:
            if self.n_calls % self.save_freq == 0:
                zip_path = Path(self._checkpoint_path(extension="zip"))
                venv = self.model.get_vec_normalize_env()
                if venv is not None:  # the statistics first: a zip always has its own
                    _save_stats(venv, stats_path(zip_path))
                with atomic_path(zip_path) as tmp:
                    self.model.save(tmp)
            return True

    checkpoint = AtomicCheckpoint(
        save_freq=max(1, args.checkpoint_every // args.n_envs),
        save_path=str(out / "checkpoints"),
        name_prefix="ppo",
    )
    t0 = time.perf_counter()
    callbacks = CallbackList([checkpoint, outcome, _time_limit_callback(args.max_minutes)])
    if remaining > 0:
        model.learn(
            total_timesteps=remaining, callback=callbacks, reset_num_timesteps=False,
            tb_log_name="ppo", progress_bar=args.progress,
        )  # fmt: skip
    elapsed = time.perf_counter() - t0
    venv = model.get_vec_normalize_env()
    if venv is not None:
        _save_stats(venv, stats_path(out / "model.zip"))
    with atomic_path(out / "model.zip") as tmp:
        model.save(tmp)
    env.close()
    steps = int(model.num_timesteps) - done_before
    summary = {
        "env_id": args.env_id,
        "obs_mode": args.obs_mode,
        "n_envs": args.n_envs,
        "vec": args.vec,
        "total_steps": int(model.num_timesteps),
        "steps_this_session": steps,
        "wall_s": round(elapsed, 2),
        "steps_per_s": round(steps / elapsed, 1) if elapsed > 0 and steps else None,
        "outcomes_this_session": outcome.counts,
        "fails_this_session": outcome.fails,
        "sudden_blocks_this_session": outcome.blocks,
        "normalize_obs": args.normalize_obs,
        "behaviour_cloning": bc,
        "model": str(out / "model.zip"),
    }
    atomic_write_text(out / "train_summary.json", json.dumps(summary, indent=2) + "\n")
    return summary


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        s = train(args)
    except (FileNotFoundError, FileExistsError, ValueError) as e:
        print(f"train_ppo: error: {e}", file=sys.stderr)
        return 2
    print(f"{s['total_steps']} steps ({s['steps_this_session']} now) in {s['wall_s']:.0f} s "
          f"({s['steps_per_s']} steps/s); outcomes {s['outcomes_this_session']} "
          f"(fails {s['fails_this_session']}; sudden blocks {s['sudden_blocks_this_session']}); "
          f"model: {s['model']}")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
