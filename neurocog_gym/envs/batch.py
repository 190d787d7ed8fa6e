"""BatchVectorEnv: a Gymnasium vector env that steps its sub-envs on threads of this process.

No worker process, no pickling, no pipe: the sub-envs live in this process, split into
``num_threads`` contiguous groups; the calling thread steps the first group while one worker
thread per other group steps its own, each writing observations, rewards and flags straight into
the batched arrays. Threads run Python one at a time (CPython's GIL), so the groups overlap only
where a step releases the GIL: inside ``mujoco.mj_step`` and in numba kernels compiled with
``nogil=True``. How much that gives depends on the share of a step spent there
(``scripts/bench_vec.py``, ``docs/performance.md``).

The results are those of ``SyncVectorEnv`` on the same env factories, bit for bit: each sub-env
is made in order in the calling thread, seeded as ``SyncVectorEnv`` seeds it, and stepped with
the same autoreset rule (``NextStep``, ``SameStep`` or ``Disabled``); the infos are batched in
sub-env order into exactly what ``VectorEnv._add_info`` makes. A sub-env's error is raised as it
was raised, for the lowest failing index, after every group has finished its step.

``call``, ``get_attr``, ``set_attr`` and ``render`` run in the calling thread, one sub-env after
the other (an OpenGL context belongs to the thread that made it). With ``render_mode="human"``
the sub-envs render inside ``step``, so they are stepped in the calling thread too.

:class:`neurocog_gym.envs.sb3_vec.BatchVecEnv` puts stable-baselines3's ``VecEnv`` API on it.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Sequence
from copy import deepcopy
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector.utils import batch_space, create_empty_array, iterate
from gymnasium.vector.vector_env import AutoresetMode, VectorEnv

from neurocog_gym.envs.vector import _BatchedInfos, _ObsWriter, _Slot


def _cpus() -> int:
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0)) or 1
    return os.cpu_count() or 1


class _Group:
    """A worker thread that runs one job on its sub-envs each time it is started.

    Two locks hand the turn over: ``_go`` is released to start a job, ``_done`` when it has
    finished. A thread blocked on a lock waits in the kernel without holding the GIL.
    """

    def __init__(self, indices: range, name: str):
        self.indices = indices
        self._go = threading.Lock()
        self._go.acquire()
        self._done = threading.Lock()
        self._done.acquire()
        self._job: Callable[[range], None] | None = None
        self.error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while True:
            self._go.acquire()
            job = self._job
            if job is None:
                self._done.release()
                return
            try:
                job(self.indices)
            except BaseException as e:  # handed to the calling thread by wait()
                self.error = e
            self._done.release()

    def start(self, job: Callable[[range], None]) -> None:
        self.error = None
        self._job = job
        self._go.release()

    def wait(self) -> None:
        self._done.acquire()

    def stop(self) -> None:
        if not self._thread.is_alive():  # at interpreter exit daemon threads may be gone
            return
        self._job = None
        self._go.release()
        if self._done.acquire(timeout=5.0):
            self._thread.join(timeout=5.0)


class _IndexedError(Exception):
    """Carries a sub-env's error with its index out of a group's job."""

    def __init__(self, index: int, error: BaseException):
        super().__init__(index, error)
        self.index, self.error = index, error


class BatchVectorEnv(_BatchedInfos, VectorEnv):
    """``num_envs`` sub-envs in this process, stepped on ``num_threads`` threads.

    Args:
        env_fns: callables that each make one env, called in order in this thread.
        num_threads: threads that step the sub-envs, the calling one included (None: one per
            CPU this process may run on, at most ``num_envs``; 1: all in the calling thread).
        copy: return copies of the batched observation (True) or the arrays themselves, which
            the next step overwrites (False).
        autoreset_mode: ``"NextStep"`` (Gymnasium's default), ``"SameStep"`` or ``"Disabled"``,
            as in ``SyncVectorEnv``.
    """

    _slot_class = _Slot

    def __init__(
        self,
        env_fns: Sequence[Callable[[], gym.Env]],
        num_threads: int | None = None,
        copy: bool = True,
        autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP,
    ):
        super().__init__()
        env_fns = list(env_fns)
        if not env_fns:
            raise ValueError("BatchVectorEnv needs at least one env factory")
        if num_threads is not None and (
            not isinstance(num_threads, int) or isinstance(num_threads, bool) or num_threads < 1
        ):
            raise ValueError(f"num_threads must be a positive integer or None, got {num_threads!r}")
        self.autoreset_mode = AutoresetMode(autoreset_mode)
        self.num_envs = len(env_fns)
        self.copy = bool(copy)
        self._groups: list[_Group] = []
        self._closed = False
        same_step = self.autoreset_mode == AutoresetMode.SAME_STEP
        # SameStep: the slots step without autoreset; step() resets them as SyncVectorEnv does.
        slot_mode = AutoresetMode.DISABLED if same_step else self.autoreset_mode
        self._slots = [self._slot_class(fn(), slot_mode) for fn in env_fns]
        self.envs = [slot.env for slot in self._slots]
        env = self.envs[0]
        self.metadata = dict(env.metadata)
        self.metadata["autoreset_mode"] = self.autoreset_mode
        self.render_mode = env.render_mode
        self.single_observation_space = env.observation_space
        self.single_action_space = env.action_space
        for i, other in enumerate(self.envs[1:], start=1):
            if other.observation_space != self.single_observation_space:
                self._close_envs()
                raise RuntimeError(
                    f"env {i} has another observation space than env 0; BatchVectorEnv batches "
                    "identical spaces only"
                )
            if other.action_space != self.single_action_space:
                self._close_envs()
                raise RuntimeError(f"env {i} has another action space than env 0")
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._obs = create_empty_array(self.single_observation_space, self.num_envs, fn=np.zeros)
        self._writer = _ObsWriter(self.single_observation_space, None, self.num_envs, self._obs)
        if self._writer.leaves is None:
            self._close_envs()
            raise TypeError(
                f"BatchVectorEnv batches Box, Discrete, MultiDiscrete and MultiBinary "
                f"observations (in Dict and Tuple spaces), not {self.single_observation_space}"
            )
        self._rewards = np.zeros(self.num_envs, dtype=np.float64)
        self._terminations = np.zeros(self.num_envs, dtype=np.bool_)
        self._truncations = np.zeros(self.num_envs, dtype=np.bool_)
        self._infos: list[dict] = [{} for _ in range(self.num_envs)]
        self._finals: list[tuple | None] = [None] * self.num_envs
        self._info_plans: dict = {}

        threads = min(self.num_envs, _cpus() if num_threads is None else num_threads)
        if self.render_mode == "human":
            threads = 1  # rendering happens inside step, and a GL context keeps to its thread
        self.num_threads = threads
        bounds = np.linspace(0, self.num_envs, threads + 1).round().astype(int)
        ranges = [range(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
        self._own = ranges[0]
        self._groups = [_Group(r, f"BatchVectorEnv-{k}") for k, r in enumerate(ranges[1:], start=1)]

    # -- running jobs on the groups -------------------------------------------------------------

    def _run(self, job: Callable[[range], None]) -> None:
        """``job(indices)`` for every group at once (the first in this thread); then its errors."""
        if self._closed:
            raise RuntimeError("BatchVectorEnv is closed")
        for group in self._groups:
            group.start(job)
        first: BaseException | None = None
        try:
            job(self._own)
        except BaseException as e:
            first = e
        errors = [first]
        for group in self._groups:
            group.wait()
            errors.append(group.error)
        errors = [e for e in errors if e is not None]
        if not errors:
            return
        indexed = [e for e in errors if isinstance(e, _IndexedError)]
        if len(indexed) < len(errors):  # KeyboardInterrupt and the like come first
            raise next(e for e in errors if not isinstance(e, _IndexedError))
        error = min(indexed, key=lambda e: e.index).error
        raise error.with_traceback(error.__traceback__)

    # -- Gymnasium's VectorEnv API ---------------------------------------------------------------

    def reset(self, *, seed: int | list[int | None] | None = None, options: dict | None = None):
        """Reset the sub-envs (all, or those in ``options["reset_mask"]``), as SyncVectorEnv."""
        if seed is None:
            seed = [None] * self.num_envs
        elif isinstance(seed, int):
            seed = [seed + i for i in range(self.num_envs)]
        if len(seed) != self.num_envs:
            raise ValueError(
                f"If seeds are passed as a list the length must match num_envs={self.num_envs} "
                f"but got length={len(seed)}."
            )
        mask = np.ones(self.num_envs, dtype=np.bool_)
        if options is not None and "reset_mask" in options:
            options = dict(options)
            mask = options.pop("reset_mask")
            if (
                not isinstance(mask, np.ndarray)
                or mask.shape != (self.num_envs,)
                or mask.dtype != np.bool_
                or not mask.any()
            ):
                raise ValueError(
                    f"options['reset_mask'] must be a bool array of shape ({self.num_envs},) "
                    f"with at least one True value, got {mask!r}"
                )
        infos = self._infos

        def job(indices: range) -> None:
            for i in indices:
                if not mask[i]:
                    continue
                try:
                    obs, infos[i] = self._slots[i].reset(seed[i], options)
                except Exception as e:
                    raise _IndexedError(i, e) from e
                self._writer.write(i, obs)

        self._run(job)
        out: dict[str, Any] = {}
        for i in np.flatnonzero(mask):
            out = self._add_info(out, infos[i], int(i))
        self._terminations[mask] = False
        self._truncations[mask] = False
        return self._copy_obs(), out

    def step(self, actions):
        """Step every sub-env with its action (autoreset as SyncVectorEnv)."""
        if self.autoreset_mode == AutoresetMode.DISABLED and (
            self._terminations.any() or self._truncations.any()
        ):
            done = np.flatnonzero(self._terminations | self._truncations)
            raise RuntimeError(
                f"autoreset_mode is 'Disabled' and envs {done.tolist()} ended: reset them with "
                "options={'reset_mask': ...} before stepping"
            )
        obs, infos = self._step_each(actions)
        if self.autoreset_mode == AutoresetMode.SAME_STEP and any(self._finals):
            merged: dict[str, Any] = {}
            for i, info in enumerate(infos):
                if self._finals[i] is not None:
                    final_obs, final_info = self._finals[i]
                    merged = self._add_info(
                        merged, {"final_obs": final_obs, "final_info": final_info}, i
                    )
                merged = self._add_info(merged, info, i)
        else:
            merged = self._merge_infos(infos)
        return (
            obs,
            np.copy(self._rewards),
            np.copy(self._terminations),
            np.copy(self._truncations),
            merged,
        )

    def _step_each(self, actions) -> tuple[Any, list[dict]]:
        """Step every sub-env; the batched observation (see ``copy``) and each sub-env's info.

        Rewards and flags are left in ``self._rewards``, ``_terminations``, ``_truncations``.
        """
        actions = list(iterate(self.action_space, actions))
        if len(actions) != self.num_envs:
            raise ValueError(f"expected actions for {self.num_envs} envs, got {len(actions)}")
        slots, infos, finals = self._slots, self._infos, self._finals
        rewards, terms, truncs = self._rewards, self._terminations, self._truncations
        write = self._writer.write
        same_step = self.autoreset_mode == AutoresetMode.SAME_STEP

        def job(indices: range) -> None:
            for i in indices:
                try:
                    obs, rewards[i], terms[i], truncs[i], infos[i] = slots[i].step(actions[i])
                    finals[i] = None
                    if same_step and (terms[i] or truncs[i]):
                        finals[i] = (obs, infos[i])
                        obs, infos[i] = slots[i].env.reset()
                except Exception as e:
                    raise _IndexedError(i, e) from e
                write(i, obs)

        self._run(job)
        return self._copy_obs(), list(infos)

    def _apply(self, fn: Callable, indices: Sequence[int], *args, **kwargs) -> list:
        """``fn(env, *args, **kwargs)`` for the sub-envs ``indices``, in order, in this thread."""
        for i in indices:
            if not 0 <= int(i) < self.num_envs:
                raise IndexError(f"env index {i} out of range for {self.num_envs} envs")
        return [fn(self.envs[int(i)], *args, **kwargs) for i in indices]

    def _apply_each(self, fn: Callable, calls: dict[int, tuple], kwargs: dict | None = None):
        """``fn(env_i, *calls[i], **kwargs)`` for each ``i`` in ``calls``, on the threads."""
        kwargs = kwargs or {}
        for i in calls:
            if not 0 <= i < self.num_envs:
                raise IndexError(f"env index {i} out of range for {self.num_envs} envs")
        results: dict[int, Any] = {}

        def job(indices: range) -> None:
            for i in indices:
                if i in calls:
                    try:
                        results[i] = fn(self.envs[i], *calls[i], **kwargs)
                    except Exception as e:
                        raise _IndexedError(i, e) from e

        self._run(job)
        return {i: results[i] for i in calls}

    def _copy_obs(self):
        """The batched observation: a copy (``copy=True``) or the arrays themselves."""
        if not self.copy:
            return self._obs
        if self._writer.flat_keys:
            return {key: view.copy() for key, view in self._obs.items()}
        return deepcopy(self._obs)

    def call(self, name: str, *args, **kwargs) -> tuple:
        """Call method ``name`` (or read attribute ``name``) of every sub-env, in this thread."""
        self._check_open()
        return tuple(slot.call(name, args, kwargs) for slot in self._slots)

    def get_attr(self, name: str) -> tuple:
        """Attribute ``name`` of every sub-env."""
        return self.call(name)

    def set_attr(self, name: str, values) -> None:
        """Set attribute ``name`` of every sub-env (one value for all, or a list of them)."""
        self._check_open()
        if not isinstance(values, (list, tuple)):
            values = [values] * self.num_envs
        if len(values) != self.num_envs:
            raise ValueError(f"set_attr needs {self.num_envs} values, got {len(values)}")
        for env, value in zip(self.envs, values, strict=True):
            setattr(env, name, value)

    def render(self):
        """Each sub-env's ``render()`` (a tuple), or None without a render mode."""
        if self.render_mode is None:
            return None
        return self.call("render")

    def _check_open(self) -> None:
        if self._closed:
            raise RuntimeError("BatchVectorEnv is closed")

    def _close_envs(self) -> None:
        self._closed = True
        for slot in getattr(self, "_slots", []):
            slot.env.close()

    def close_extras(self, **kwargs) -> None:
        """Stop the worker threads and close the sub-envs."""
        if self._closed:
            return
        for group in self._groups:
            group.stop()
        self._groups = []
        self._close_envs()

    def __del__(self):
        if not getattr(self, "_closed", True):
            self.close()


def make_batch_vector(
    env_id: str, num_envs: int = 1, num_threads: int | None = None, **env_kwargs
) -> BatchVectorEnv:
    """``num_envs`` copies of ``gymnasium.make(env_id, **env_kwargs)`` in a :class:`BatchVectorEnv`.

    The same sub-envs as ``gymnasium.make_vec(env_id, num_envs, vectorization_mode="sync")``
    (the registered wrappers and time limit included), stepped on ``num_threads`` threads.
    """
    if not isinstance(num_envs, int) or isinstance(num_envs, bool) or num_envs < 1:
        raise ValueError(f"num_envs must be a positive integer, got {num_envs!r}")

    def make_one() -> gym.Env:
        return gym.make(env_id, **env_kwargs)

    return BatchVectorEnv([make_one] * num_envs, num_threads=num_threads)
