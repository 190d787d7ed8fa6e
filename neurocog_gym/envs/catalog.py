"""What each registered env is: spaces, episode length, parameters (``neurocog info``)."""

from __future__ import annotations

import inspect

import gymnasium as gym


def _entry_class(env_id: str) -> type:
    from gymnasium.envs.registration import load_env_creator

    return load_env_creator(gym.spec(env_id).entry_point)


def constructor_parameters(cls: type) -> list[tuple[str, str, str]]:
    """Keyword parameters of an env class and of the bases its ``**kwargs`` reach.

    Returns:
        ``(name, default repr, defining class name)``, the most derived class first.
    """
    from neurocog_gym.envs.base import QuadrupedEnv

    seen: set[str] = set()
    rows = []
    for klass in cls.__mro__:
        if "__init__" not in klass.__dict__ or not issubclass(klass, QuadrupedEnv):
            continue
        sig = inspect.signature(klass.__init__)
        for p in sig.parameters.values():
            if p.name == "self" or p.kind in (p.VAR_KEYWORD, p.VAR_POSITIONAL) or p.name in seen:
                continue
            seen.add(p.name)
            default = "(required)" if p.default is p.empty else repr(p.default)
            rows.append((p.name, default, klass.__name__))
        if klass is QuadrupedEnv:
            break
    return rows


def _space_text(space: gym.Space) -> str:
    if isinstance(space, gym.spaces.Box):
        lo, hi = float(space.low.min()), float(space.high.max())
        return f"Box({lo:g}, {hi:g}, {space.shape}, {space.dtype})"
    return repr(space)


def describe(env_id: str) -> dict:
    """Build ``env_id`` once (no rendering) and describe it.

    Returns:
        ``id``, ``entry_point``, ``vector_entry_point`` (what ``gymnasium.make_vec`` builds by
        default), ``summary`` (first docstring line), ``max_episode_steps``,
        ``dt`` (s per step), ``episode_seconds``, ``action_space`` (text), ``observation``
        (key -> space text; a single ``"obs"`` key for non-Dict spaces) and ``parameters``
        (list of ``{name, default, defined_in}``).
    """
    from neurocog_gym.envs.base import make_env

    env = make_env(env_id)
    try:
        spec = gym.spec(env_id)
        u = env.unwrapped
        cls = _entry_class(env_id)
        obs_space = env.observation_space
        if isinstance(obs_space, gym.spaces.Dict):
            observation = {k: _space_text(s) for k, s in obs_space.spaces.items()}
        else:
            observation = {"obs": _space_text(obs_space)}
        steps = spec.max_episode_steps
        return {
            "id": env_id,
            "entry_point": spec.entry_point,
            "vector_entry_point": spec.vector_entry_point,
            "summary": (inspect.getdoc(cls) or "").splitlines()[0],
            "max_episode_steps": steps,
            "dt": float(u.dt),
            "episode_seconds": None if steps is None else round(steps * float(u.dt), 6),
            "action_space": _space_text(env.action_space),
            "observation": observation,
            "parameters": [
                {"name": n, "default": d, "defined_in": c}
                for n, d, c in constructor_parameters(cls)
            ],
        }
    finally:
        env.close()


def format_text(desc: dict) -> str:
    """``describe``'s dict as the plain-text block ``neurocog info`` prints."""
    lines = [
        f"{desc['id']}  ({desc['entry_point']})",
        f"  {desc['summary']}",
        f"  gymnasium.make_vec(id, n): {desc['vector_entry_point']} (SpinVectorEnv; "
        "vector_backend='threads' for BatchVectorEnv; vectorization_mode='sync' / 'async' for "
        "Gymnasium's own)",
        f"  episode: {desc['max_episode_steps']} steps x {desc['dt']:g} s = "
        f"{desc['episode_seconds']:g} s (truncated by the time limit)",
        f"  action: {desc['action_space']}  (12 joint interrupts, 3 walking provisions)",
        "  observation (Dict):",
    ]
    width = max(len(k) for k in desc["observation"])
    lines += [f"    {k:<{width}}  {v}" for k, v in desc["observation"].items()]
    lines.append("  parameters (gymnasium.make keyword arguments):")
    width = max(len(p["name"]) for p in desc["parameters"])
    for p in desc["parameters"]:
        lines.append(f"    {p['name']:<{width}} = {p['default']}  [{p['defined_in']}]")
    return "\n".join(lines)
