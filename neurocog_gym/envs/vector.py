"""SpinVectorEnv: a lock-step Gymnasium vector env for sub-millisecond steps on few cores.

Why it exists (measured, ``docs/generated/benchmarks_env.md``): one obstacle-env step takes about
0.5 ms here. Gymnasium's ``AsyncVectorEnv`` sends every step's command and result through a pipe to
a sleeping worker; on this 2-core machine two such workers run at 0.6-0.8 x the steps/s of one env
stepped in-process, and even a stand-in env that only busy-waits our step times gets 1.2 x. The cost
is the wake-ups and round trips, not the cores (two free env processes: 1.9-2.0 x).

What this one does instead:

* the sub-envs are split into one contiguous group per core (``processes``): the first group
  steps in the calling process, while each other group steps in a worker process at the same
  time, one env after the other (a 2-env vector env needs one worker, not two; 8 envs on 2
  cores are two groups of 4, so each lock-step turn lasts 4 env steps, and the spread of single
  step times averages out over them);
* observations go through Gymnasium's shared-memory layout
  (``gymnasium.vector.utils.create_shared_memory``), written through views made once; a Box
  action through a shared row per worker; rewards, flags and ``info`` through a per-worker
  shared buffer (pickled); no pipe, no wake-up;
* each side waits for the other by spinning on a shared counter (yielding the core on every
  turn) for up to ``spin_seconds``, then by polling with sleeps that grow with the wait (0.2 ms
  up to 20 ms, 5 % of the time waited so far), so that a worker idles cheaply (about 1 % of a
  core) while the caller trains a network or steps other envs;
* infos are batched by a cached plan into exactly what ``VectorEnv._add_info`` makes;
* a Ctrl-C (a terminal sends SIGINT to the whole process group) makes each worker leave, its
  envs closed, without answering, and the calling process raise KeyboardInterrupt where it waits
  for that answer, if its own did not come first. On a cold numba cache the KeyboardInterrupt can
  land in numba's compiler, where llvmlite's callbacks swallow it or numba raises another error
  in its place (``RuntimeError: no compiled object yet``): a worker notes the Ctrl-C before it
  raises and leaves all the same, and the calling process, whose own KeyboardInterrupt is lost
  there just as often, gets one from the worker's leaving. Where that process ignores SIGINT or
  handles it its own way (when the vector env is made), the workers ignore it.

The results are those of ``SyncVectorEnv`` on the same env factories, bit for bit (the same
seeding, the same next-step autoreset, the same info layout; ``tests/ecosystem/
test_spin_vector.py``). The lock-step still costs: each vector step lasts as long as the slower
env's step, and these steps vary (a ToF frame every 2.2 cycles, a 15 ms reset every few hundred
steps), which bounds any lock-step vector env of two such envs at about 1.7 x one env even with
free communication (``scripts/bench_env.py``); this one reaches 1.3-1.45 x with the obstacle env.

:class:`neurocog_gym.envs.sb3_vec.SpinVecEnv` puts stable-baselines3's ``VecEnv`` API on the same
workers.

The counter protocol relies on stores becoming visible in program order, which x86-64 gives;
other architectures are untested.
"""

from __future__ import annotations

import multiprocessing
import os
import pickle
import signal
import sys
import time
import traceback
from collections.abc import Callable, Sequence
from copy import deepcopy
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.vector.utils import (
    CloudpickleWrapper,
    batch_space,
    create_shared_memory,
    iterate,
    read_from_shared_memory,
    write_to_shared_memory,
)
from gymnasium.vector.vector_env import AutoresetMode, VectorEnv

_STEP, _RESET, _CALL, _SET, _CLOSE, _APPLY = 1, 2, 3, 4, 5, 6
_OK, _ERROR = 0, 1
# ctrl fields of each worker (one int64 array in shared memory)
_CMD_SEQ, _DONE_SEQ, _CMD, _NBYTES, _STATUS, _LEFT = range(6)
_SCALARS = (int, float, bool)
_yield = getattr(os, "sched_yield", lambda: None)
"""Called on every turn of a spin: lets anything else runnable have the core, and on this VM the
other env's step slows less beside a yielding spin than beside a plain one (0.49-0.50 against
0.54-0.55 ms; 0.47 alone)."""
_SLEEP = 2e-4
"""Shortest poll interval once the spin budget is spent, s."""
_SLEEP_MAX = 2e-2
"""Longest poll interval, s (an idle worker wakes at most 50 times a second)."""
_NAP_SHARE = 0.05
"""Each poll sleeps this share of the time waited so far (within the two bounds): a wait of T
ends at most ~5 % of T late, and a long-idle process costs the machine next to nothing."""


_PROC = os.path.isdir("/proc/self")


def _alive(pid: int) -> bool:
    """Whether process ``pid`` (the vector env's) still runs; a worker leaves once it is gone.

    Not ``os.getppid()``: under the forkserver start method a worker's parent is the server. A
    process that has exited but is not reaped yet (a zombie) counts as gone.
    """
    if _PROC:
        try:
            with open(f"/proc/{pid}/stat", "rb") as f:
                return f.read().rsplit(b")", 1)[1].split()[0] != b"Z"
        except FileNotFoundError:
            return False
    try:  # no /proc: ask the kernel whether the pid exists
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _nap(since: float) -> None:
    """Sleep once while polling, for longer the longer the wait that began at ``since`` lasts."""
    time.sleep(min(_SLEEP_MAX, max(_SLEEP, (time.perf_counter() - since) * _NAP_SHARE)))


def _start_without_ctrl_c(proc) -> None:
    """Start worker ``proc`` with SIGINT blocked, as it stays until it has its Ctrl-C handling.

    A Ctrl-C while the worker starts would otherwise raise KeyboardInterrupt in multiprocessing's
    bootstrap (a traceback); the worker sees it once it is ready, this process once the start is
    done.
    """
    if not hasattr(signal, "pthread_sigmask"):
        proc.start()
        return
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        proc.start()
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)


class _Slot:
    """One env and its next-step autoreset flag: what both this process and a worker run."""

    def __init__(self, env: gym.Env, autoreset_mode: AutoresetMode):
        self.env = env
        self.mode = autoreset_mode
        self.needs_reset = False

    def reset(self, seed, options):
        self.needs_reset = False
        return self.env.reset(seed=seed, options=options)

    def step(self, action):
        if self.needs_reset:
            obs, info = self.env.reset()
            self.needs_reset = False
            return obs, 0.0, False, False, info
        obs, reward, terminated, truncated, info = self.env.step(action)
        if self.mode == AutoresetMode.NEXT_STEP:
            self.needs_reset = bool(terminated or truncated)
        return obs, reward, terminated, truncated, info

    def call(self, name, args, kwargs):
        attr = getattr(self.env, name)
        return attr(*args, **kwargs) if callable(attr) else attr


class _SameStepSlot(_Slot):
    """stable-baselines3's VecEnv step: a finished env resets in the same step.

    Its last observation goes in ``info["terminal_observation"]``, as in SB3's DummyVecEnv and
    SubprocVecEnv.
    """

    RESET_INFO = "neurocog_spin_reset_info"
    """Key under which the reset's info travels back (the SB3 adapter takes it out again)."""

    def step(self, action):
        obs, reward, terminated, truncated, info = self.env.step(action)
        info["TimeLimit.truncated"] = truncated and not terminated
        if terminated or truncated:
            info["terminal_observation"] = deepcopy(obs)
            obs, info[self.RESET_INFO] = self.env.reset()
        return obs, reward, terminated, truncated, info


class _InfoPlan:
    """How ``VectorEnv._add_info`` batches each entry of infos with these keys and value types."""

    def __init__(self, keys: tuple, kinds: tuple):
        self.names = [(key, f"_{key}") for key in keys]
        groups: dict[type, list[int]] = {}
        self.objects: list[int] = []
        self.generic: set[int] = set()
        for j, (key, kind) in enumerate(zip(keys, kinds, strict=True)):
            if key == "final_obs" or issubclass(kind, (dict, np.ndarray)):
                self.generic.add(j)  # nested dicts, arrays, final_obs: Gymnasium's own code
            elif kind in _SCALARS or issubclass(kind, np.number):
                groups.setdefault(kind, []).append(j)
            else:
                self.objects.append(j)
        self.groups = list(groups.items())


class _ObsWriter:
    """Writes one env's observation into its row of the batched shared-memory observation.

    Gymnasium's ``write_to_shared_memory`` rebuilds a NumPy view of the shared buffer for every
    leaf on every call (16 % of a vector step with our 15-key Dict observation); this one makes
    the views once. Same casting (unsafe, to the space's dtype), same bits.
    """

    _BASE = (spaces.Box, spaces.Discrete, spaces.MultiDiscrete, spaces.MultiBinary)

    def __init__(self, space: gym.Space, shm, num_envs: int, views=None):
        self.space, self.shm = space, shm
        if views is None:
            views = read_from_shared_memory(space, shm, num_envs)
        try:
            self.leaves = list(self._leaves(space, views, ()))
        except TypeError:  # a space without array leaves: Gymnasium's own writer
            self.leaves = None
        self.flat_keys = (
            self.leaves is not None
            and isinstance(space, spaces.Dict)
            and all(len(path) == 1 for path, _ in self.leaves)
        )

    def _leaves(self, space, views, path):
        if isinstance(space, spaces.Dict):
            for key, sub in space.spaces.items():
                yield from self._leaves(sub, views[key], (*path, key))
        elif isinstance(space, spaces.Tuple):
            for i, sub in enumerate(space.spaces):
                yield from self._leaves(sub, views[i], (*path, i))
        elif isinstance(space, self._BASE):
            yield path, views
        else:
            raise TypeError(type(space).__name__)

    def write(self, index: int, obs) -> None:
        if self.leaves is None:
            if self.shm is None:
                raise TypeError(f"cannot batch observations of {self.space}")
            write_to_shared_memory(self.space, index, obs, self.shm)
            return
        for path, view in self.leaves:
            value = obs
            for key in path:
                value = value[key]
            view[index] = value


class _BatchedInfos:
    """``_merge_infos`` for a ``VectorEnv`` with ``num_envs`` and an ``_info_plans`` dict."""

    def _merge_infos(self, infos: list[dict]) -> dict:
        """The vector info of one ``info`` per sub-env, as ``VectorEnv._add_info`` makes it.

        When every sub-env reports the same keys with the same value types (the usual case), a
        cached plan builds all scalar entries of one type from one array and every ``_key`` mask
        from one all-True array (the entries are rows of those arrays; values, dtypes, shapes and
        key order are Gymnasium's); anything else goes through Gymnasium's ``_add_info``.
        """
        keys = tuple(infos[0])
        kinds = tuple(map(type, infos[0].values()))
        if any(tuple(info) != keys or tuple(map(type, info.values())) != kinds for info in infos):
            out: dict[str, Any] = {}
            for i, info in enumerate(infos):
                out = self._add_info(out, info, i)
            return out
        plan = self._info_plans.get((keys, kinds))
        if plan is None:
            plan = self._info_plans[(keys, kinds)] = _InfoPlan(keys, kinds)
        values = [list(info.values()) for info in infos]
        entries: list[Any] = [None] * len(keys)
        for kind, columns in plan.groups:
            block = np.array([[row[j] for row in values] for j in columns], dtype=kind)
            for r, j in enumerate(columns):
                entries[j] = block[r]
        for j in plan.objects:
            column = np.full(self.num_envs, fill_value=None, dtype=object)
            for i, row in enumerate(values):
                column[i] = row[j]
            entries[j] = column
        masks = np.ones((len(keys), self.num_envs), dtype=np.bool_)
        out = {}
        for j, (key, mask_key) in enumerate(plan.names):
            if j in plan.generic:
                part: dict[str, Any] = {}
                for i, row in enumerate(values):
                    part = self._add_info(part, {key: row[j]}, i)
                out.update(part)
            else:
                out[key] = entries[j]
                out[mask_key] = masks[j]
        return out


def _action_view(raw, space: gym.Space, k: int) -> np.ndarray | None:
    """The shared action rows of a worker's ``k`` envs (Box / discrete spaces), or None."""
    if raw is None:
        return None
    return np.frombuffer(raw, dtype=space.dtype).reshape((k, *space.shape))


def _shared_action_raw(ctx, space: gym.Space, k: int):
    """A shared buffer for ``k`` actions of ``space``, or None where actions go pickled."""
    if not isinstance(space, _ObsWriter._BASE) or space.shape is None:
        return None
    n = k * int(np.prod(space.shape, dtype=np.int64)) * np.dtype(space.dtype).itemsize
    return ctx.RawArray("B", max(n, 1))


def _put(buf: np.ndarray, ctrl: np.ndarray, obj) -> None:
    data = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
    if len(data) > len(buf):
        raise ValueError(
            f"a message of {len(data)} bytes does not fit the shared buffer of {len(buf)} bytes; "
            "pass a larger payload_bytes to SpinVectorEnv"
        )
    buf[: len(data)] = np.frombuffer(data, dtype=np.uint8)
    ctrl[_NBYTES] = len(data)


def _get(buf: np.ndarray, ctrl: np.ndarray):
    return pickle.loads(buf[: int(ctrl[_NBYTES])].tobytes())


def _worker(
    indices,
    env_fns,
    ctrl_raw,
    buf_raw,
    act_raw,
    act_space,
    shm,
    space,
    num_envs,
    mode,
    spin_seconds,
    parent,
    slot_class=_Slot,
    leave_on_ctrl_c=True,
):
    """A worker process: makes the sub-envs ``indices`` and steps them, one after the other.

    With ``leave_on_ctrl_c``, a Ctrl-C makes it leave without answering and set its ``_LEFT``
    flag, even where numba swallowed the KeyboardInterrupt or raised another error in its place;
    without, it ignores SIGINT (see the module docstring).
    """
    ctrl = np.frombuffer(ctrl_raw, dtype=np.int64)
    interrupted: list[int] = []

    def on_ctrl_c(signum, frame):
        interrupted.append(signum)
        raise KeyboardInterrupt

    report_unraisable = sys.unraisablehook

    def quiet_once_interrupted(unraisable):
        # after a Ctrl-C, llvmlite's callbacks and finalizers report the KeyboardInterrupt they
        # could not raise and the objects it left half made: the worker is leaving, not failing
        if not interrupted:
            report_unraisable(unraisable)

    if leave_on_ctrl_c:
        sys.unraisablehook = quiet_once_interrupted
    slots: list[_Slot] = []
    try:
        try:
            # SIGINT was blocked across the start (_start_without_ctrl_c): one sent before this
            # is raised here at the earliest, inside this try
            signal.signal(signal.SIGINT, on_ctrl_c if leave_on_ctrl_c else signal.SIG_IGN)
            if hasattr(signal, "pthread_sigmask"):
                signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
            _serve(indices, env_fns, ctrl, buf_raw, act_raw, act_space, shm, space, num_envs,
                   mode, spin_seconds, parent, slot_class, slots, interrupted)  # fmt: skip
        finally:
            for slot in slots:
                slot.env.close()
    except KeyboardInterrupt:
        pass
    if interrupted:
        ctrl[_LEFT] = 1


def _serve(
    indices,
    env_fns,
    ctrl,
    buf_raw,
    act_raw,
    act_space,
    shm,
    space,
    num_envs,
    mode,
    spin_seconds,
    parent,
    slot_class,
    slots,
    interrupted,
):
    """The worker's life: makes its sub-envs into ``slots``, then answers commands.

    It returns when told to close, when the parent is gone, or once a Ctrl-C is noted in
    ``interrupted`` (the caller closes whatever is left in ``slots``).
    """
    writer = _ObsWriter(space, shm, num_envs)
    act = _action_view(act_raw, act_space, len(indices))
    buf = np.frombuffer(buf_raw, dtype=np.uint8)
    # the parent may send its first command before this process gets here: the count starts at 0
    seen = 0
    # fork and spawn: the vector env's process is this one's parent (reparented when it dies);
    # forkserver: the server is, and the vector env's process is asked by pid
    direct = os.getppid() == parent

    def parent_alive() -> bool:
        return os.getppid() == parent if direct else _alive(parent)

    current = indices[0]
    try:
        for i, fn in zip(indices, env_fns.fn, strict=True):
            current = i
            slots.append(slot_class(fn(), mode))
    except Exception as e:  # a factory failed: report it on the first command
        if interrupted:  # numba's error in place of a Ctrl-C's KeyboardInterrupt
            return
        message = (
            f"creating env {current} failed: {type(e).__name__}: {e}\n{traceback.format_exc()}"
        )
        while parent_alive() and not interrupted:
            if ctrl[_CMD_SEQ] != seen:
                seen = int(ctrl[_CMD_SEQ])
                _put(buf, ctrl, (None, message))
                ctrl[_STATUS] = _ERROR
                ctrl[_DONE_SEQ] = seen
                if int(ctrl[_CMD]) == _CLOSE:
                    return
            time.sleep(_SLEEP)
        return
    while not interrupted:  # (a KeyboardInterrupt that numba swallowed left only the note)
        # wait for the next command: spin, then poll (and leave if the parent is gone)
        if ctrl[_CMD_SEQ] == seen:
            since = time.perf_counter()
            deadline = since + spin_seconds
            n = 0
            while ctrl[_CMD_SEQ] == seen:  # spin, yielding the core each turn
                _yield()
                n += 1
                if n & 15 == 0 and time.perf_counter() > deadline:
                    break
            while ctrl[_CMD_SEQ] == seen:  # then poll
                _nap(since)
                if not parent_alive():
                    return
        seen = int(ctrl[_CMD_SEQ])
        cmd = int(ctrl[_CMD])
        current = indices[0]
        try:
            if cmd == _STEP:
                actions = _get(buf, ctrl) if act is None else act.copy()
                answers = []
                for j, i in enumerate(indices):
                    current = i
                    obs, reward, terminated, truncated, info = slots[j].step(actions[j])
                    writer.write(i, obs)
                    answers.append((reward, terminated, truncated, info))
                _put(buf, ctrl, answers)
            elif cmd == _RESET:
                seeds, options, mask = _get(buf, ctrl)
                infos = []
                for j, i in enumerate(indices):
                    current = i
                    if mask[j]:
                        obs, info = slots[j].reset(seeds[j], options)
                        writer.write(i, obs)
                        infos.append(info)
                    else:
                        infos.append(None)
                _put(buf, ctrl, infos)
            elif cmd == _CALL:
                name, args, kwargs = _get(buf, ctrl)
                results = []
                for j, i in enumerate(indices):
                    current = i
                    results.append(slots[j].call(name, args, kwargs))
                _put(buf, ctrl, results)
            elif cmd == _APPLY:
                fn, calls, kwargs = _get(buf, ctrl)
                results = {}
                for i, args in calls.items():
                    current = i
                    results[i] = fn(slots[i - indices[0]].env, *args, **kwargs)
                _put(buf, ctrl, results)
            elif cmd == _SET:
                name, values = _get(buf, ctrl)
                for j, i in enumerate(indices):
                    current = i
                    setattr(slots[j].env, name, values[j])
                _put(buf, ctrl, None)
            elif cmd == _CLOSE:
                for slot in slots:
                    slot.env.close()
                slots.clear()
                _put(buf, ctrl, None)
            ctrl[_STATUS] = _OK
        except Exception as e:
            if interrupted:  # numba's error in place of a Ctrl-C's KeyboardInterrupt
                return
            message = f"{type(e).__name__}: {e}\n{traceback.format_exc()}"
            _put(buf, ctrl, (current, message))
            ctrl[_STATUS] = _ERROR
        if interrupted and cmd != _CLOSE:
            return
        ctrl[_DONE_SEQ] = seen
        if cmd == _CLOSE:
            return


class SpinVectorEnv(_BatchedInfos, VectorEnv):
    """Lock-step vector env: the sub-envs in groups, one in this process, the others in workers.

    A drop-in for ``gymnasium.vector.AsyncVectorEnv`` / ``SyncVectorEnv`` when single steps are
    sub-millisecond and cores are few (see the module docstring for why and how).

    Args:
        env_fns: callables that each make one env (those of the first group are called in this
            process, the others in the workers).
        copy: return copies of the observations (True) or views of the shared buffers that the
            next ``step`` or ``reset`` overwrites (False).
        autoreset_mode: ``"NextStep"`` (Gymnasium's default) or ``"Disabled"``.
        spin_seconds: how long either side busy-waits for the other before it polls with short
            sleeps, s. None: 2 ms when every process has a core of its own (``processes`` ≤ the
            CPUs this process may use), else 0 (spinning processes would take turns on a core).
        payload_bytes: size of each worker's shared message buffer (actions, ``info``), bytes.
        context: multiprocessing start method (None: the platform's default).
        processes: processes that step the sub-envs, this one included, each a contiguous
            group of them (None: one per CPU this process may use, at most ``num_envs``).

    Attributes:
        spin_seconds: the spin budget in use.
        groups: the sub-env indices of each process, this one's first.
    """

    _slot_class: type[_Slot] = _Slot

    def __init__(
        self,
        env_fns: Sequence[Callable[[], gym.Env]],
        copy: bool = True,
        autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP,
        spin_seconds: float | None = None,
        payload_bytes: int = 1 << 20,
        context: str | None = None,
        processes: int | None = None,
    ):
        super().__init__()
        env_fns = list(env_fns)
        if not env_fns:
            raise ValueError("SpinVectorEnv needs at least one env factory")
        mode = AutoresetMode(autoreset_mode)
        if mode == AutoresetMode.SAME_STEP:
            raise ValueError(
                "SpinVectorEnv supports autoreset_mode 'NextStep' and 'Disabled', not 'SameStep'"
            )
        if payload_bytes < 1024:
            raise ValueError(f"payload_bytes must be at least 1024, got {payload_bytes}")
        if processes is not None and (
            not isinstance(processes, int) or isinstance(processes, bool) or processes < 1
        ):
            raise ValueError(f"processes must be a positive integer or None, got {processes!r}")
        self.num_envs = len(env_fns)
        self.copy = copy
        self.autoreset_mode = mode
        cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None
        cpus = cpus or os.cpu_count() or 1
        processes = min(self.num_envs, cpus if processes is None else processes)
        bounds = np.linspace(0, self.num_envs, processes + 1).round().astype(int)
        self.groups = [range(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
        if spin_seconds is None:
            spin_seconds = 2e-3 if processes <= cpus else 0.0
        if spin_seconds < 0:
            raise ValueError(f"spin_seconds must be >= 0, got {spin_seconds}")
        self.spin_seconds = float(spin_seconds)
        self._closed = True
        self._procs: list = []
        self._slots: list[_Slot] = []

        for fn in env_fns[: len(self.groups[0])]:
            self._slots.append(self._slot_class(fn(), mode))
        env = self._slots[0].env
        self.metadata = dict(env.metadata)
        self.metadata["autoreset_mode"] = mode
        self.render_mode = env.render_mode
        self.single_observation_space = env.observation_space
        self.single_action_space = env.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)

        ctx = multiprocessing.get_context(context)
        self._shm = create_shared_memory(self.single_observation_space, self.num_envs, ctx=ctx)
        self._obs = read_from_shared_memory(self.single_observation_space, self._shm, self.num_envs)
        self._writer = _ObsWriter(self.single_observation_space, self._shm, self.num_envs)
        self._ctrl, self._buf, self._act = [], [], []
        self._closed = False
        self._interrupted = False
        # the workers follow this process's Ctrl-C as it stands now (see the module docstring)
        leave_on_ctrl_c = signal.getsignal(signal.SIGINT) is signal.default_int_handler
        for k, group in enumerate(self.groups[1:], start=1):
            ctrl_raw = ctx.RawArray("q", 6)
            buf_raw = ctx.RawArray("B", int(payload_bytes))
            act_raw = _shared_action_raw(ctx, self.single_action_space, len(group))
            self._ctrl.append(np.frombuffer(ctrl_raw, dtype=np.int64))
            self._buf.append(np.frombuffer(buf_raw, dtype=np.uint8))
            self._act.append(_action_view(act_raw, self.single_action_space, len(group)))
            proc = ctx.Process(
                target=_worker,
                name=f"SpinVectorEnv-{k}",
                args=(
                    group,
                    CloudpickleWrapper([env_fns[i] for i in group]),
                    ctrl_raw,
                    buf_raw,
                    act_raw,
                    self.single_action_space,
                    self._shm,
                    self.single_observation_space,
                    self.num_envs,
                    mode,
                    self.spin_seconds,
                    os.getpid(),
                    self._slot_class,
                    leave_on_ctrl_c,
                ),
                daemon=True,
            )
            _start_without_ctrl_c(proc)
            self._procs.append(proc)
        self._info_plans: dict[tuple, _InfoPlan] = {}
        self._rewards = np.zeros(self.num_envs, dtype=np.float64)
        self._terminations = np.zeros(self.num_envs, dtype=np.bool_)
        self._truncations = np.zeros(self.num_envs, dtype=np.bool_)
        try:
            self._check_spaces()
        except BaseException:
            self.close()
            raise

    @property
    def _workers(self) -> range:
        return range(len(self._procs))

    def _check_spaces(self) -> None:
        """Every env was made (its errors surface here) with env 0's spaces."""
        for k in self._workers:
            self._send(k, _CALL, ("observation_space", (), {}))
        found = [slot.env.observation_space for slot in self._slots]
        for answer in self._gather(self._workers).values():
            found += answer
        for i, space in enumerate(found):
            if space != self.single_observation_space:
                raise RuntimeError(
                    f"env {i} has another observation space than env 0; SpinVectorEnv "
                    "batches identical spaces only"
                )
        for k in self._workers:
            self._send(k, _CALL, ("action_space", (), {}))
        found = [slot.env.action_space for slot in self._slots]
        for answer in self._gather(self._workers).values():
            found += answer
        for i, space in enumerate(found):
            if space != self.single_action_space:
                raise RuntimeError(f"env {i} has another action space than env 0")

    # -- the worker protocol ----------------------------------------------------------------------

    def _send(self, k: int, cmd: int, payload) -> None:
        ctrl = self._ctrl[k]
        _put(self._buf[k], ctrl, payload)
        ctrl[_CMD] = cmd
        ctrl[_CMD_SEQ] += 1

    def _group_name(self, k: int) -> str:
        group = self.groups[k + 1]
        return f"env {group[0]}" if len(group) == 1 else f"envs {group[0]}-{group[-1]}"

    def _receive(self, k: int):
        ctrl, proc = self._ctrl[k], self._procs[k]
        target = ctrl[_CMD_SEQ]
        if ctrl[_DONE_SEQ] != target:
            since = time.perf_counter()
            deadline = since + self.spin_seconds
            n = 0
            while ctrl[_DONE_SEQ] != target:  # spin, yielding the core each turn
                _yield()
                n += 1
                if n & 15 == 0 and time.perf_counter() > deadline:
                    break
            while ctrl[_DONE_SEQ] != target:  # then poll
                _nap(since)
                if ctrl[_LEFT]:  # on a Ctrl-C, which this process may not have seen (numba)
                    self._interrupted = True
                    raise KeyboardInterrupt
                if not proc.is_alive() and ctrl[_DONE_SEQ] != target:
                    self._closed = True
                    raise RuntimeError(
                        f"SpinVectorEnv worker for {self._group_name(k)} exited "
                        f"(exit code {proc.exitcode}) without answering"
                    )
        result = _get(self._buf[k], ctrl)
        if ctrl[_STATUS] == _ERROR:
            index, message = result
            if index is None:  # making an env failed; the message names it
                raise RuntimeError(f"SpinVectorEnv {message}")
            raise RuntimeError(f"SpinVectorEnv env {index} raised: {message}")
        return result

    def _gather(self, ks) -> dict:
        """Receive the answers of workers ``ks``, then raise the first error if there was one.

        All of them are received even after an error, so that no answer is left in a buffer that
        the next command overwrites.
        """
        results, error = {}, None
        for k in ks:
            try:
                results[k] = self._receive(k)
            except RuntimeError as e:
                error = error or e
        if error is not None:
            raise error
        return results

    def _local(self, ks, fn, *args):
        """``fn(*args)`` in this process while workers ``ks`` work.

        If it raises, the workers' answers are collected (and dropped) before the error goes on;
        a KeyboardInterrupt instead if a worker left on a Ctrl-C (the error is then numba's, whose
        compiler turns a KeyboardInterrupt into another error or none).
        """
        try:
            return fn(*args)
        except BaseException as e:
            for k in ks:
                try:
                    self._receive(k)
                except (RuntimeError, KeyboardInterrupt):
                    pass
            # a worker may have answered before its Ctrl-C came, and left while waiting
            self._interrupted |= any(self._ctrl[k][_LEFT] for k in self._workers)
            if self._interrupted and not isinstance(e, KeyboardInterrupt):
                raise KeyboardInterrupt from e
            raise

    def _check_open(self) -> None:
        if self._closed:
            raise RuntimeError("SpinVectorEnv is closed")
        if self._interrupted:
            raise RuntimeError("SpinVectorEnv's workers left on a Ctrl-C: close it")

    # -- Gymnasium's VectorEnv API -----------------------------------------------------------------

    def reset(self, *, seed: int | list[int | None] | None = None, options: dict | None = None):
        """Reset the sub-envs (all, or those in ``options["reset_mask"]``), as SyncVectorEnv."""
        self._check_open()
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
        ks = [k for k in self._workers if mask[self.groups[k + 1]].any()]
        for k in ks:
            group = self.groups[k + 1]
            self._send(k, _RESET, ([seed[i] for i in group], options, mask[group].tolist()))

        def local() -> list:
            infos = []
            for i, slot in zip(self.groups[0], self._slots, strict=True):
                if mask[i]:
                    obs, info = slot.reset(seed[i], options)
                    self._writer.write(i, obs)
                    infos.append(info)
                else:
                    infos.append(None)
            return infos

        answers = {-1: self._local(ks, local)}
        answers.update(self._gather(ks))
        infos: dict[str, Any] = {}
        for k in sorted(answers):
            for i, info in zip(self.groups[k + 1], answers[k], strict=True):
                if info is not None:
                    infos = self._add_info(infos, info, i)
        self._terminations[mask] = False
        self._truncations[mask] = False
        return self._copy_obs(), infos

    def step(self, actions):
        """Step every sub-env with its action (next-step autoreset as SyncVectorEnv)."""
        self._check_open()
        if self.autoreset_mode == AutoresetMode.DISABLED and (
            self._terminations.any() or self._truncations.any()
        ):
            done = np.flatnonzero(self._terminations | self._truncations)
            raise RuntimeError(
                f"autoreset_mode is 'Disabled' and envs {done.tolist()} ended: reset them with "
                "options={'reset_mask': ...} before stepping"
            )
        obs, infos = self._step_each(actions)
        return (
            obs,
            np.copy(self._rewards),
            np.copy(self._terminations),
            np.copy(self._truncations),
            self._merge_infos(infos),
        )

    def _step_each(self, actions) -> tuple[Any, list[dict]]:
        """Step every sub-env; the batched observation (see ``copy``) and each sub-env's info.

        Rewards and flags are left in ``self._rewards``, ``_terminations``, ``_truncations``.
        """
        actions = list(iterate(self.action_space, actions))
        for k in self._workers:
            group, act = self.groups[k + 1], self._act[k]
            if act is None:
                self._send(k, _STEP, [actions[i] for i in group])
            else:
                for j, i in enumerate(group):
                    act[j] = actions[i]
                ctrl = self._ctrl[k]
                ctrl[_CMD] = _STEP
                ctrl[_CMD_SEQ] += 1

        def local() -> list:
            answers = []
            for i, slot in zip(self.groups[0], self._slots, strict=True):
                obs, reward, terminated, truncated, info = slot.step(actions[i])
                self._writer.write(i, obs)
                answers.append((reward, terminated, truncated, info))
            return answers

        answers = {-1: self._local(self._workers, local)}
        answers.update(self._gather(self._workers))
        infos = []
        for k in range(-1, len(self._procs)):
            for i, (reward, terminated, truncated, info) in zip(
                self.groups[k + 1], answers[k], strict=True
            ):
                self._rewards[i] = reward
                self._terminations[i] = terminated
                self._truncations[i] = truncated
                infos.append(info)
        return self._copy_obs(), infos

    def _apply(self, fn: Callable, indices: Sequence[int], *args, **kwargs) -> list:
        """``fn(env, *args, **kwargs)`` for the sub-envs ``indices``, in order (``fn`` pickles)."""
        unique = list(dict.fromkeys(int(i) for i in indices))
        done = self._apply_each(fn, {i: args for i in unique}, kwargs)
        return [done[int(i)] for i in indices]

    def _apply_each(self, fn: Callable, calls: dict[int, tuple], kwargs: dict | None = None):
        """``fn(env_i, *calls[i], **kwargs)`` for each sub-env ``i`` in ``calls``, in parallel."""
        self._check_open()
        kwargs = kwargs or {}
        for i in calls:
            if not 0 <= i < self.num_envs:
                raise IndexError(f"env index {i} out of range for {self.num_envs} envs")
        ks = []
        for k in self._workers:
            mine = {i: args for i, args in calls.items() if i in self.groups[k + 1]}
            if mine:
                self._send(k, _APPLY, (fn, mine, kwargs))
                ks.append(k)

        def local() -> dict:
            return {
                i: fn(self._slots[i].env, *args, **kwargs)
                for i, args in calls.items()
                if i in self.groups[0]
            }

        results = self._local(ks, local)
        for value in self._gather(ks).values():
            results.update(value)
        return {i: results[i] for i in calls}

    def _copy_obs(self):
        """The batched observation: a copy (``copy=True``) or the shared views themselves."""
        if not self.copy:
            return self._obs
        if self._writer.flat_keys:
            return {key: view.copy() for key, view in self._obs.items()}
        return deepcopy(self._obs)

    def call(self, name: str, *args, **kwargs) -> tuple:
        """Call method ``name`` (or read attribute ``name``) of every sub-env."""
        self._check_open()
        for k in self._workers:
            self._send(k, _CALL, (name, args, kwargs))

        def local() -> list:
            return [slot.call(name, args, kwargs) for slot in self._slots]

        first = self._local(self._workers, local)
        answers = self._gather(self._workers)
        return tuple(first + [x for k in self._workers for x in answers[k]])

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
        for k in self._workers:
            self._send(k, _SET, (name, [values[i] for i in self.groups[k + 1]]))

        def local() -> None:
            for i, slot in zip(self.groups[0], self._slots, strict=True):
                setattr(slot.env, name, values[i])

        self._local(self._workers, local)
        self._gather(self._workers)

    def render(self):
        """Each sub-env's ``render()`` (a tuple), or None without a render mode."""
        if self.render_mode is None:
            return None
        return self.call("render")

    def close_extras(self, **kwargs) -> None:
        """Close the sub-envs and stop the workers."""
        if not getattr(self, "_slots", None):
            return
        if not self._closed:
            for k, proc in enumerate(self._procs):
                if proc.is_alive():
                    self._send(k, _CLOSE, None)
            for proc in self._procs:
                proc.join(timeout=5.0)
        for proc in self._procs:
            if proc.is_alive():
                proc.terminate()
                proc.join(timeout=1.0)
        self._closed = True
        for slot in self._slots:
            slot.env.close()
        self._slots = []

    def __del__(self):
        if not getattr(self, "closed", True):
            self.close()


# -- gymnasium.make_vec's vector entry points (one per registered id) ------------------------------


def make_spin_vector(env_id: str, num_envs: int = 1, **env_kwargs) -> SpinVectorEnv:
    """``num_envs`` copies of ``gymnasium.make(env_id, **env_kwargs)`` in a :class:`SpinVectorEnv`.

    The same sub-envs as ``gymnasium.make_vec(env_id, num_envs, vectorization_mode="sync")``
    (the registered wrappers and time limit included), stepped in parallel.
    """
    if not isinstance(num_envs, int) or isinstance(num_envs, bool) or num_envs < 1:
        raise ValueError(f"num_envs must be a positive integer, got {num_envs!r}")

    def make_one() -> gym.Env:
        return gym.make(env_id, **env_kwargs)

    return SpinVectorEnv([make_one] * num_envs)
