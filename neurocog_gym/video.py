"""Record an episode of any registered env to an MP4, with the perception overlay drawn in.

The obstacle envs' ``rgb_array`` frames carry the DD-GNG's facets filled by the kind of surface
they belong to (terrain, wall, object), its nodes and edges, the attention boxes and the
predicted footholds (green safe, red unsafe) — see ``envs.obstacle.overlay_markers``.
``NeuroCog/Walk-v3`` has no perception, so its frames are the plain scene.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

_CONTROL_DT = 0.01  # s, every registered env's control cycle (SPEC §9); sets the time limit


def camera_names(model) -> list[str]:
    """Names of the cameras of a compiled MuJoCo model."""
    return [model.camera(i).name for i in range(model.ncam)]


def _check_policy(policy, spec: str, env) -> None:
    """Fail before any frame is written if the policy cannot read this env's observation."""
    from neurocog_gym.policies import AEFPolicy

    space = env.observation_space
    missing = [k for k in AEFPolicy.obs_keys if k not in space.spaces]
    if isinstance(policy, AEFPolicy) and missing:
        raise ValueError(
            f"policy {spec!r} reads the obstacle envs' {', '.join(missing)}, which "
            f"{env.spec.id} does not observe; use --policy blind for it"
        )
    model = getattr(policy, "model", None)
    if model is not None and getattr(model, "observation_space", None) is not None:
        if model.observation_space != space:
            raise ValueError(
                f"model {spec} was trained on another observation space than {env.spec.id}'s"
            )


def record_video(
    env_id: str,
    policy: str = "aef",
    out: str | os.PathLike = "runs/video.mp4",
    seconds: float = 7.0,
    seed: int = 0,
    camera: str = "follow",
    width: int = 640,
    height: int = 480,
    fps: int = 50,
    progress: bool = False,
    env_kwargs: dict | None = None,
) -> dict:
    """Run one episode under ``policy`` and write its ``rgb_array`` frames to ``out``.

    Args:
        env_id: a registered id, e.g. ``"NeuroCog/SuddenObstacle-v3"``.
        policy: ``"aef"``, ``"blind"``, an AEF weights file (``.npz``) or a stable-baselines3
            model (``.zip``); see ``policies.make_policy``.
        out: the MP4 file to write (folders are created).
        seconds: simulated seconds to record; the registration's time limit is lifted to it, so
            the video ends earlier only if the episode terminates (fell, or passed the obstacles).
        seed: episode seed (``env.reset(seed=seed)``).
        camera: a camera of the scene (``follow``, ``side``, ``overhead``).
        width: frame width, pixels (even, >= 16).
        height: frame height, pixels (even, >= 16).
        fps: video frame rate; the frames are sampled every ``round(1 / (dt * fps))`` control
            cycles of ``dt`` = 0.01 s, so the video plays in real time for fps dividing 100.
        progress: show a progress bar on stderr.
        env_kwargs: extra keyword arguments of the env's constructor.

    Returns:
        ``out``, ``frames``, ``fps``, ``steps``, ``seconds`` (simulated), ``terminated``,
        ``distance_m`` (torso x travelled) and, for the obstacle envs, ``outcome``.

    Raises:
        ValueError: an unknown env id or camera, a bad size, or a policy that does not fit the env.
    """
    import imageio.v2 as imageio

    from neurocog_gym.envs.base import make_env
    from neurocog_gym.policies import make_policy, start_episode

    if not seconds > 0:
        raise ValueError(f"seconds must be positive, got {seconds}")
    for name, v in (("width", width), ("height", height)):
        if v < 16 or v % 2:
            raise ValueError(f"{name} must be an even number of pixels >= 16, got {v}")
    if not 1 <= fps <= 100:
        raise ValueError(f"fps must be in [1, 100], got {fps}")
    out = Path(out)
    if out.suffix.lower() != ".mp4":
        raise ValueError(f"the video file must end in .mp4, got {out}")
    pol = make_policy(policy)
    steps = max(1, int(round(seconds / _CONTROL_DT)))
    env = make_env(env_id, render_mode="rgb_array", width=width, height=height,
                   camera_name=camera, max_episode_steps=steps, **(env_kwargs or {}))  # fmt: skip
    try:
        u = env.unwrapped
        cams = camera_names(u.model)
        if camera not in cams:
            raise ValueError(f"unknown camera {camera!r}; the scene has {', '.join(cams)}")
        dt = u.dt
        _check_policy(pol, policy, env)
        stride = max(1, int(round(1.0 / (dt * fps))))
        out.parent.mkdir(parents=True, exist_ok=True)
        obs, info = env.reset(seed=seed)
        start_episode(pol, env)
        x0 = float(u.data.qpos[0])
        frames, n, terminated, truncated = 0, 0, False, False
        from tqdm import tqdm

        bar = tqdm(total=steps, desc="record", unit="step", disable=not progress)
        # Encode into a temp file beside ``out`` and rename it at the end (never half a video).
        tmp = out.with_name(f".{out.stem}.tmp{out.suffix}")
        writer = imageio.get_writer(tmp, fps=fps, codec="libx264", macro_block_size=2)
        try:
            writer.append_data(np.asarray(env.render()))
            frames += 1
            while not (terminated or truncated):
                obs, _, terminated, truncated, info = env.step(pol(obs))
                n += 1
                bar.update(1)
                if n % stride == 0:
                    writer.append_data(np.asarray(env.render()))
                    frames += 1
        finally:
            writer.close()
            bar.close()
        os.replace(tmp, out)
        summary = {
            "out": str(out),
            "frames": frames,
            "fps": fps,
            "steps": n,
            "seconds": round(n * dt, 4),
            "terminated": bool(terminated),
            "distance_m": round(float(u.data.qpos[0]) - x0, 4),
        }
        if "outcome" in info:
            passed = bool(info.get("passed"))
            summary["outcome"] = info["outcome"] if passed or info["outcome"] == "fail" else "fail"
        return summary
    finally:
        env.close()
