"""stable-baselines3 VecEnvs on our vector envs: :class:`SpinVecEnv` and :class:`BatchVecEnv`.

SB3 trains on its own vector-env API (``step_async`` / ``step_wait``, same-step resets with the
last observation in ``info["terminal_observation"]``, a list of infos). Its ``SubprocVecEnv``
sends every step through pipes to sleeping workers, which on this 2-core machine costs more than
the sub-millisecond obstacle-env step it parallelises
(``docs/generated/benchmarks_env.md``). :class:`SpinVecEnv`
gives SB3 the same workers as ``SpinVectorEnv`` — env 0 in the training process, the others in
processes that wait by spinning on shared memory — and :class:`BatchVecEnv` the threads of
:class:`neurocog_gym.envs.batch.BatchVectorEnv` (no process, no pickling); both give the results
of SB3's ``DummyVecEnv`` on the same env factories (``tests/ecosystem/test_spin_vector.py``,
``tests/ecosystem/test_batch_vector.py``).

    from stable_baselines3.common.env_util import make_vec_env
    from neurocog_gym.envs.sb3_vec import SpinVecEnv

    venv = make_vec_env("NeuroCog/SuddenObstacle-v3", n_envs=2, seed=0, vec_env_cls=SpinVecEnv)
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from copy import deepcopy
from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3.common.vec_env import VecEnv
from stable_baselines3.common.vec_env.patch_gym import _patch_env

from neurocog_gym.envs.batch import BatchVectorEnv
from neurocog_gym.envs.vector import SpinVectorEnv, _SameStepSlot


def _reset_env(env: gym.Env, seed, options):
    return env.reset(seed=seed, **({"options": options} if options else {}))


def _get_wrapper_attr(env: gym.Env, name: str):
    return env.get_wrapper_attr(name)


def _call_wrapper_method(env: gym.Env, name: str, args: tuple, kwargs: dict):
    return env.get_wrapper_attr(name)(*args, **kwargs)


def _is_wrapped(env: gym.Env, wrapper_class: type) -> bool:
    from stable_baselines3.common.env_util import is_wrapped

    return is_wrapped(env, wrapper_class)


def _render(env: gym.Env):
    return env.render()


class _Core(SpinVectorEnv):
    """SpinVectorEnv whose sub-envs step as SB3's (same-step reset)."""

    _slot_class = _SameStepSlot


class _BatchCore(BatchVectorEnv):
    """BatchVectorEnv whose sub-envs step as SB3's (same-step reset)."""

    _slot_class = _SameStepSlot


class _Patched:
    """An env factory that passes the env through SB3's ``_patch_env``, as its vec envs do."""

    def __init__(self, fn: Callable[[], gym.Env]):
        self.fn = fn

    def __call__(self) -> gym.Env:
        return _patch_env(self.fn())


class _OverVectorEnv(VecEnv):
    """SB3's ``VecEnv`` over one of our vector envs built with ``_SameStepSlot`` sub-envs."""

    def __init__(self, vec):
        self._vec = vec
        self._actions: np.ndarray | None = None
        super().__init__(vec.num_envs, vec.single_observation_space, vec.single_action_space)

    def _indices(self, indices) -> list[int]:
        if indices is None:
            return list(range(self.num_envs))
        if isinstance(indices, (int, np.integer)):
            return [int(indices)]
        return [int(i) for i in indices]

    def reset(self):
        """Reset every sub-env with the seeds and options set by ``seed`` / ``set_options``."""
        calls = {i: (self._seeds[i], self._options[i]) for i in range(self.num_envs)}
        results = self._vec._apply_each(_reset_env, calls)
        for i in range(self.num_envs):
            obs, self.reset_infos[i] = results[i]
            self._vec._writer.write(i, obs)
        self._reset_seeds()
        self._reset_options()
        return self._vec._copy_obs()

    def step_async(self, actions: np.ndarray) -> None:
        """Hand over the actions; ``step_wait`` steps the sub-envs."""
        self._actions = actions

    def step_wait(self):
        """Step every sub-env; a finished one resets in the same step (SB3's convention)."""
        if self._actions is None:
            raise RuntimeError("step_wait called without step_async")
        actions, self._actions = self._actions, None
        obs, infos = self._vec._step_each(np.asarray(actions))
        infos = self._own_infos(infos)
        dones = self._vec._terminations | self._vec._truncations
        for i, info in enumerate(infos):
            if _SameStepSlot.RESET_INFO in info:
                self.reset_infos[i] = info.pop(_SameStepSlot.RESET_INFO)
        return obs, np.copy(self._vec._rewards).astype(np.float32), dones, infos

    def _own_infos(self, infos: list[dict]) -> list[dict]:
        """Infos the sub-envs keep no reference to (``DummyVecEnv`` returns deep copies)."""
        return deepcopy(infos)

    def close(self) -> None:
        """Close the sub-envs and stop the workers."""
        self._vec.close()

    def get_attr(self, attr_name: str, indices=None) -> list[Any]:
        """``env.get_wrapper_attr(attr_name)`` of the sub-envs ``indices`` (all by default)."""
        return self._vec._apply(_get_wrapper_attr, self._indices(indices), attr_name)

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        """``setattr(env, attr_name, value)`` on the sub-envs ``indices`` (all by default)."""
        self._vec._apply(setattr, self._indices(indices), attr_name, value)

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs) -> list:
        """Call ``method_name`` of the sub-envs ``indices`` (all by default)."""
        return self._vec._apply(
            _call_wrapper_method, self._indices(indices), method_name, method_args, method_kwargs
        )

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices=None) -> list[bool]:
        """Whether each sub-env ``indices`` is wrapped by ``wrapper_class``."""
        return self._vec._apply(_is_wrapped, self._indices(indices), wrapper_class)

    def get_images(self) -> Sequence[np.ndarray | None]:
        """Each sub-env's ``render()`` (rgb_array mode)."""
        return self._vec._apply(_render, range(self.num_envs))


class SpinVecEnv(_OverVectorEnv):
    """stable-baselines3 ``VecEnv`` whose sub-envs step in parallel, as :class:`SpinVectorEnv`.

    Args:
        env_fns: callables that each make one env (the first is called in this process).
        spin_seconds: see :class:`SpinVectorEnv` (None: 2 ms when every env has a core).
        payload_bytes: see :class:`SpinVectorEnv` (each message carries a step's info, and the
            last observation of a finished episode).
        context: multiprocessing start method (None: the platform's default).
    """

    def __init__(
        self,
        env_fns: Sequence[Callable[[], gym.Env]],
        spin_seconds: float | None = None,
        payload_bytes: int = 1 << 20,
        context: str | None = None,
    ):
        vec = _Core(
            [_Patched(fn) for fn in env_fns],
            copy=True,
            autoreset_mode="Disabled",
            spin_seconds=spin_seconds,
            payload_bytes=payload_bytes,
            context=context,
        )
        super().__init__(vec)

    def _own_infos(self, infos: list[dict]) -> list[dict]:
        infos[0] = deepcopy(infos[0])  # the workers' infos arrive as fresh copies already
        return infos

    @property
    def spin_seconds(self) -> float:
        """The spin budget in use, s."""
        return self._vec.spin_seconds


class BatchVecEnv(_OverVectorEnv):
    """stable-baselines3 ``VecEnv`` whose sub-envs step on threads, as :class:`BatchVectorEnv`.

    Args:
        env_fns: callables that each make one env (called in order in this thread).
        num_threads: see :class:`neurocog_gym.envs.batch.BatchVectorEnv` (None: one per CPU).
    """

    def __init__(self, env_fns: Sequence[Callable[[], gym.Env]], num_threads: int | None = None):
        super().__init__(
            _BatchCore(
                [_Patched(fn) for fn in env_fns],
                num_threads=num_threads,
                copy=True,
                autoreset_mode="Disabled",
            )
        )


__all__ = ["BatchVecEnv", "SpinVecEnv"]
