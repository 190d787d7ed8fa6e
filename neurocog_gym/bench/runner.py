"""The benchmark of §6.5 (Table 4): sudden- and static-obstacle trials, in parallel, resumable.

A run is ``trials`` trials of each chosen scenario with one policy and one attention setting.
Trial ``i`` of scenario ``s`` resets its env with :func:`trial_seed` ``(seed, s, i)``, so every
trial's outcome depends only on that triple (and the code), never on which worker ran it or in
which order.

Files in the run folder ``out``:

* ``trials.jsonl``: one JSON line per finished trial (:func:`run_trial` gives its fields),
  appended and fsynced as each trial finishes. A crash or a kill loses at most the trials that
  were running; ``resume=True`` reads the file (a torn last line is dropped) and runs only the
  missing ``(scenario, index)`` pairs.
* ``summary.json``: the outcome tally per scenario with 95 % Wilson intervals and the Table 5
  failure analysis (:func:`neurocog_gym.bench.outcome.scenario_summary`), plus ``config``;
  rewritten atomically after every trial.
* ``report.md`` and its plots (:mod:`neurocog_gym.bench.report`), written at the end.

Similarity curve (§6.5.3, Table 5): every ``similarity_every`` (0.05 s) from the moment the
obstacle appears (sudden) or first comes into view (static: the first sample with at least
``min_nodes`` attention nodes near it), for ``similarity_window`` seconds, the DD-GNG nodes
inside the placed blocks' boxes grown by ``grow`` (3 cm) and above ``min_z`` (1 cm: the floor
is not the obstacle's surface) are matched, with their facet normals, to the true surface of
every placed block (:func:`~neurocog_gym.perception.similarity.box_surface_reference`, 1 cm
samples, top and four sides) by :func:`~neurocog_gym.perception.similarity.surface_match`.

Latency chain (§6.2, Fig. 10), sudden trials only (:class:`LatencyProbe`): seconds from the
block's appearance to the first non-homogeneous nodes, to the first accurate affordance and to
the first control cycle with a non-zero interrupt group, each None when it never happened
before the trial ended. The definitions are those of ``scripts/bench_affordance_map.py``.
"""

from __future__ import annotations

import hashlib
import math
import multiprocessing
import os
import socket
import sys
import time
from collections.abc import Iterator
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from neurocog_gym import io
from neurocog_gym.bench.outcome import PAPER_TABLE4, SCENARIOS, STONE_SCENARIOS, scenario_summary
from neurocog_gym.bench.records import load_trials
from neurocog_gym.bench.report import write_report
from neurocog_gym.robot.model import BODIES

ENV_IDS: dict[str, str] = {
    "sudden": "NeuroCog/SuddenObstacle-v3",
    "static": "NeuroCog/StaticObstacle-v3",
    "stones": "NeuroCog/SteppingStones-v3",
    "stones-moving": "NeuroCog/SteppingStones-v3",
}
SCENARIO_KWARGS: dict[str, dict] = {"stones-moving": {"moving": True}}
"""``gymnasium.make`` arguments of a scenario beyond its id."""
STONE_RECORD_KEYS: tuple[str, ...] = ("crossed", "in_pit", "pit_leg", "pit_at", "course")
"""Fields of a stepping-stones trial's last ``info`` copied into its record."""
CONTROL_DT = 0.01
"""s, the envs' control cycle (SPEC §9)."""
GNG_OF_ATTENTION: dict[str, str] = {"on": "ddgng", "off": "gng", "mlgng": "mlgng"}
"""``--attention`` value -> ``PipelineParams.gng``: DD-GNG, plain GNG (the ablation), or the
multi-layer GNG baseline of §7.1 (no attention either)."""
AFFORDANCE_SOURCES: tuple[str, ...] = ("points", "map")
"""``--affordance-source`` values (the obstacle envs' ``affordance_source`` keyword)."""
ACCURATE_HEIGHT = 0.01
"""m: an affordance is accurate when its height is within this of the block's (issue 23)."""
ACCURATE_LENGTH = 0.02
"""m: ... and its length (along the robot's heading) within this of the block's."""
PAPER_TRIALS = 50
"""Trials per scenario in the paper (§6.5.1, §6.5.2)."""


@dataclass(frozen=True)
class SimilaritySettings:
    """How the similarity curve of each trial is sampled (§6.5.3, Table 5)."""

    every: float = 0.05
    """s between two samples of μ."""
    window: float = 2.0
    """s after the obstacle appeared (or came into view) during which μ is sampled."""
    grow: float = 0.03
    """m: the blocks' boxes are grown by this on every side to select the attention nodes."""
    min_z: float = 0.01
    """m: nodes at or below this height are floor, not obstacle, and are left out."""
    min_nodes: int = 3
    """Attention nodes near the obstacle for a static obstacle to count as in view."""
    spacing: float = 0.01
    """m: sample spacing of the obstacles' true surface."""


@dataclass(frozen=True)
class BenchConfig:
    """One benchmark run (the arguments of ``neurocog bench``)."""

    out: Path
    """Run folder."""
    scenarios: tuple[str, ...] = SCENARIOS
    """Scenarios to run, a subset of ("sudden", "static", "stones", "stones-moving")."""
    trials: int = PAPER_TRIALS
    """Trials per scenario (the paper: 50)."""
    seed: int = 0
    """Run seed S; trial seeds derive from (S, scenario, index)."""
    policy: str = "aef"
    """"aef", "aef-provision", "blind", "oracle", "ppo" (the shipped PPO policy), AEF weights
    (.npz) or a saved stable-baselines3 model."""
    attention: str = "on"
    """"on": DD-GNG attention; "off": plain GNG (the ablation); "mlgng": ML-GNG (§7.1)."""
    affordance_source: str | None = None
    """The envs' ``affordance_source``: "points", "map", or None for the env's default."""
    body: str = "v2"
    """The robot body the envs are built with (``robot.model.BODIES``; the -v2 and -v3 envs' v2)."""
    max_seconds: float | None = None
    """Simulated seconds per trial; None: the registration's limit (sudden 7 s, static 10 s)."""
    workers: int | None = None
    """Parallel trials; None: every local core (or every Ray CPU)."""
    ray_address: str | None = None
    """Run on this existing Ray cluster instead of local processes."""
    resume: bool = False
    """Continue the run in ``out``: only missing trials are run."""
    progress: bool = True
    """Show a tqdm bar (hidden anyway when stderr is not a terminal)."""
    report: bool = True
    """Write ``report.md`` and its plots at the end."""
    similarity: SimilaritySettings = field(default_factory=SimilaritySettings)
    """Sampling of the similarity curve."""

    def __post_init__(self):
        known = SCENARIOS + STONE_SCENARIOS
        if not self.scenarios or any(s not in known for s in self.scenarios):
            raise ValueError(
                f"scenarios must be a non-empty subset of {known}, got {self.scenarios}"
            )
        if len(set(self.scenarios)) != len(self.scenarios):
            raise ValueError(f"scenarios repeat: {self.scenarios}")
        if isinstance(self.trials, bool) or not isinstance(self.trials, int) or self.trials < 1:
            raise ValueError(f"trials must be a positive integer, got {self.trials}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise ValueError(f"seed must be a non-negative integer, got {self.seed}")
        if self.attention not in GNG_OF_ATTENTION:
            raise ValueError(
                f"attention must be one of {tuple(GNG_OF_ATTENTION)}, got {self.attention!r}"
            )
        if self.affordance_source is not None and self.affordance_source not in (
            AFFORDANCE_SOURCES
        ):
            raise ValueError(
                f"affordance_source must be one of {AFFORDANCE_SOURCES} or None, "
                f"got {self.affordance_source!r}"
            )
        if self.body not in BODIES:
            raise ValueError(f"body must be one of {BODIES}, got {self.body!r}")
        if self.max_seconds is not None and not (
            math.isfinite(self.max_seconds) and self.max_seconds >= CONTROL_DT
        ):
            raise ValueError(f"max_seconds must be at least {CONTROL_DT} s, got {self.max_seconds}")
        if self.workers is not None and self.workers < 1:
            raise ValueError(f"workers must be at least 1, got {self.workers}")
        object.__setattr__(self, "out", Path(self.out))

    def identity(self) -> dict:
        """The settings every trial of a run must share (checked on resume)."""
        return {
            "policy": self.policy,
            "attention": self.attention,
            "run_seed": self.seed,
            "max_seconds": self.max_seconds,
            "affordance_source": self.affordance_source,
            "body": self.body,
        }


@dataclass(frozen=True)
class TrialSpec:
    """One trial to run: sent to a worker, so only plain values."""

    scenario: str
    index: int
    seed: int


def trial_seed(seed: int, scenario: str, index: int) -> int:
    """Env seed of trial ``index`` of ``scenario`` in a run with seed ``seed``.

    The first four bytes of ``sha256("neurocog-bench/{seed}/{scenario}/{index}")`` as a
    big-endian integer, masked to 31 bits: stable across Python and NumPy versions and machines,
    independent of worker scheduling, and unrelated between neighbouring indices.
    """
    digest = hashlib.sha256(f"neurocog-bench/{seed}/{scenario}/{index}".encode()).digest()
    return int.from_bytes(digest[:4], "big") & 0x7FFFFFFF


def trial_specs(config: BenchConfig) -> list[TrialSpec]:
    """Every trial of the run, scenario by scenario, index by index."""
    return [
        TrialSpec(s, i, trial_seed(config.seed, s, i))
        for s in config.scenarios
        for i in range(config.trials)
    ]


# -- one trial ---------------------------------------------------------------------------------


class SimilarityProbe:
    """Samples μ between the attention nodes near the placed blocks and their true surface.

    Args:
        settings: sampling settings.
        t0: s, when the obstacle appeared; None to start at the first sample where it is in
            view (at least ``settings.min_nodes`` attention nodes near it).
    """

    def __init__(self, settings: SimilaritySettings, t0: float | None):
        from neurocog_gym.perception.similarity import SimilarityTrace

        self.s = settings
        self.t0 = t0
        self.trace = SimilarityTrace(t0=t0 if t0 is not None else 0.0)
        self.n_matched: list[int] = []
        self.n_attention: list[int] = []
        self._next = t0 if t0 is not None else 0.0
        self._n_blocks = 0
        self._ref: tuple[np.ndarray, np.ndarray] | None = None
        self._boxes = np.zeros((0, 2, 3))

    def _reference(self, blocks) -> None:
        from neurocog_gym.perception.similarity import box_surface_reference

        pts, nrm = [], []
        for b in blocks:
            lo = (b.x - b.length / 2, b.y - b.width / 2, 0.0)
            hi = (b.x + b.length / 2, b.y + b.width / 2, b.height)
            p, n = box_surface_reference(lo, hi, self.s.spacing, yaw=b.yaw)
            pts.append(p)
            nrm.append(n)
        self._ref = (np.concatenate(pts), np.concatenate(nrm))
        g = self.s.grow
        self._boxes = np.stack([b.aabb() for b in blocks]) + np.array([[-g, -g, -g], [g, g, g]])
        self._n_blocks = len(blocks)

    def sample(self, env) -> None:
        """Called after every control cycle with the unwrapped env; samples when one is due."""
        t = float(env.data.time)
        if t + 1e-9 < self._next:
            return
        if self.t0 is not None and t > self.t0 + self.s.window + 1e-9:
            return
        blocks = env.pool.blocks
        if not blocks:
            return
        if len(blocks) != self._n_blocks:
            self._reference(blocks)
        self._next = t + self.s.every - 1e-9
        nodes, normals = self._attention_nodes(env)
        if self.t0 is None:
            if len(nodes) < self.s.min_nodes:
                return
            self.t0 = t
            self.trace.t0 = t
        from neurocog_gym.perception.similarity import surface_match

        m = surface_match(nodes, normals, *self._ref)
        self.trace.append(t, m.similarity)
        self.n_matched.append(m.n_matched)
        self.n_attention.append(m.n_attention)

    def _attention_nodes(self, env) -> tuple[np.ndarray, np.ndarray]:
        from neurocog_gym.perception.affordance import node_normals

        nodes = np.asarray(env.pipeline.net.nodes, dtype=np.float64)
        if len(nodes) == 0:
            return np.zeros((0, 3)), np.zeros((0, 3))
        lo, hi = self._boxes[:, 0], self._boxes[:, 1]
        inside = np.all((nodes[:, None, :] >= lo) & (nodes[:, None, :] <= hi), axis=2).any(axis=1)
        inside &= nodes[:, 2] > self.s.min_z
        if not inside.any():
            return np.zeros((0, 3)), np.zeros((0, 3))
        aff = env.pipeline.last
        if aff is None or len(aff.facets) == 0:
            normals = np.zeros_like(nodes)
        else:
            normals = node_normals(nodes, aff.facets, aff.facet_normals)
        return nodes[inside], normals[inside]

    def result(self) -> dict:
        """The curve and its Table 5 measures, JSON-ready (None for missing values)."""
        summ = self.trace.summary(0.5)
        return {
            "t0": _num(self.t0),
            "t": [round(x, 4) for x in self.trace.times],
            "mu": [round(x, 4) for x in self.trace.values],
            "n_matched": self.n_matched,
            "n_attention": self.n_attention,
            "best": _num(summ.best),
            "time_to_best": _num(summ.time_to_best),
            "at_0_5": _num(summ.at_half_second),
            "best_within_0_5": _num(summ.best_within_half_second),
        }


class LatencyProbe:
    """The §6.2 chain of one sudden trial (Fig. 10), timed from the block's appearance.

    The block is the one placed over the swinging leg's foothold (the first block of the pool;
    a second block side by side is not timed). Definitions, as in
    ``scripts/bench_affordance_map.py``:

    * *first non-homogeneous nodes* (§6.2): the first perception step whose graph has a node
      on a facet tilted more than ``max_tilt`` (``AffordanceParams.terrain_max_tilt``, 20°)
      from the vertical within ``margin`` (5 cm) of the block's footprint
      (:func:`~neurocog_gym.bench.perception_scenes.nonhomogeneous_on`). Until issue 23's
      second round it was a node over the footprint 2 cm above the ground, which the first
      learning cycle on the first frame showing the block gives (0–0.02 s in every trial,
      with every map): it timed the frame's arrival, not the map;
    * *first frame* (``first_frame_s``): the first perception step whose sensor frame has a
      pixel on the block (the frame the map learns from; frames come at 45 fps, one per 2.2
      control cycles), so that ``first_nonhomogeneous_s - first_frame_s`` is the map's own
      share of the delay;
    * *accurate affordance*: the first perception step whose object on the block (the object
      overlapping its footprint with the most nodes,
      :func:`~neurocog_gym.bench.perception_scenes.object_on`) has its height within
      :data:`ACCURATE_HEIGHT` and its length along the robot's heading within
      :data:`ACCURATE_LENGTH` of the block's;
    * *first interrupt*: the start of the first control cycle at or after the appearance whose
      clipped action had a non-zero interrupt group (the env's ``interrupt_cycles`` count went
      up). The cycle that starts at the appearance acts on the first observation that shows
      the block, so 0 is the earliest possible.

    Perception steps are timed at the end of their control cycle (the env perceives after the
    physics step). ``compared`` keeps what the accuracy test compared: at the accurate step, or,
    if there was none, at the nearest miss (the smallest of max(|dh| / 1 cm, |dl| / 2 cm)).

    Args:
        t0: s, when the block appeared.
        block: the timed block (:class:`~neurocog_gym.robot.obstacles.Block`, as placed).
        max_tilt: rad, the facet tilt of a non-homogeneous node.
        n_blocks: blocks placed at the appearance.
        margin: m, how far round the footprint a non-homogeneous node counts.
    """

    def __init__(
        self, t0: float, block, max_tilt: float, n_blocks: int = 1, margin: float | None = None
    ):
        from neurocog_gym.bench.perception_scenes import NONHOMOGENEOUS_MARGIN

        self.t0 = float(t0)
        self.block = block
        self.max_tilt = float(max_tilt)
        self.margin = NONHOMOGENEOUS_MARGIN if margin is None else float(margin)
        self.n_blocks = int(n_blocks)
        self.first_frame: float | None = None
        self.first_nonhomogeneous: float | None = None
        self.first_object: float | None = None
        self.accurate: float | None = None
        self.first_interrupt: float | None = None
        self.compared: dict | None = None
        self._miss = math.inf

    def perceived(self, t: float, pipeline, forward_xy, sees_block: bool = False) -> None:
        """After the perception step of a control cycle that ended at ``t`` s.

        Args:
            t: s, simulated time of the step.
            pipeline: the env's :class:`~neurocog_gym.perception.pipeline.AttentionPipeline`
                (its ``net.nodes``, (n, 3) metres, and ``last`` affordances are read).
            forward_xy: (2,) the heading the pipeline measured lengths along.
            sees_block: the step's sensor frame has a pixel on the block.
        """
        from neurocog_gym.bench.perception_scenes import extents, nonhomogeneous_on, object_on

        dt = t - self.t0
        if dt < -1e-9:
            return
        dt = max(dt, 0.0)
        b = self.block
        aff = pipeline.last
        if self.first_frame is None and sees_block:
            self.first_frame = dt
        if self.first_nonhomogeneous is None and nonhomogeneous_on(
            b, pipeline.net.nodes, aff, self.max_tilt, self.margin
        ):
            self.first_nonhomogeneous = dt
        if self.accurate is not None:
            return
        o = object_on(aff, b)
        if o is None:
            return
        if self.first_object is None:
            self.first_object = dt
        _, true_length = extents(b, forward_xy)
        dh, dl = o.height - b.height, o.length - true_length
        ok = abs(dh) <= ACCURATE_HEIGHT and abs(dl) <= ACCURATE_LENGTH
        miss = max(abs(dh) / ACCURATE_HEIGHT, abs(dl) / ACCURATE_LENGTH)
        if ok or miss < self._miss:
            self._miss = miss
            self.compared = {
                "at_s": round(dt, 4),
                "accurate": bool(ok),
                "height": round(float(o.height), 5),
                "length": round(float(o.length), 5),
                "width": round(float(o.width), 5),
                "true_height": round(float(b.height), 5),
                "true_length": round(float(true_length), 5),
                "n_nodes": int(o.n_nodes),
            }
        if ok:
            self.accurate = dt

    def control(self, t_start: float, interrupted: bool) -> None:
        """After a control cycle that started at ``t_start`` s.

        Args:
            t_start: s, simulated time at the start of the cycle.
            interrupted: the cycle's clipped action had a non-zero interrupt group.
        """
        if self.first_interrupt is None and interrupted and t_start >= self.t0 - 1e-9:
            self.first_interrupt = max(t_start - self.t0, 0.0)

    def result(self) -> dict:
        """The ``latency`` field of the trial record (s after the appearance; None: never)."""
        return {
            "first_frame_s": _num(self.first_frame, 4),
            "first_nonhomogeneous_s": _num(self.first_nonhomogeneous, 4),
            "first_object_s": _num(self.first_object, 4),
            "accurate_s": _num(self.accurate, 4),
            "first_interrupt_s": _num(self.first_interrupt, 4),
            "n_blocks": self.n_blocks,
            "compared": self.compared,
        }


NO_LATENCY = {
    "first_frame_s": None,
    "first_nonhomogeneous_s": None,
    "first_object_s": None,
    "accurate_s": None,
    "first_interrupt_s": None,
    "n_blocks": 0,
    "compared": None,
}
"""The ``latency`` of a sudden trial that ended before its block appeared."""


def _heading_xy(qpos: np.ndarray) -> np.ndarray:
    """(2,) unit heading of the torso (its yaw, as the obstacle envs compute it)."""
    w, x, y, z = (float(v) for v in qpos[3:7])
    yaw = float(np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)))
    return np.array([np.cos(yaw), np.sin(yaw)])


def _num(x, digits: int = 6) -> float | None:
    """JSON-ready float rounded to ``digits``: None for None, NaN or infinity."""
    if x is None:
        return None
    x = float(x)
    return round(x, digits) if math.isfinite(x) else None


def make_env(
    scenario: str,
    attention: str,
    max_seconds: float | None,
    privileged: bool = False,
    affordance_source: str | None = None,
    env_kwargs: dict | None = None,
    body: str = "v2",
):
    """The scenario's env with the attention setting and the trial time limit.

    ``attention`` picks the topological map (:data:`GNG_OF_ATTENTION`); ``privileged`` adds
    the simulator's truth to the observation (``true_blocks``, ``feet``), for the privileged
    oracle (:class:`neurocog_gym.policies.oracle.OraclePolicy`); ``affordance_source`` is the
    envs' keyword ("points", "map"; None: the env's default); ``env_kwargs`` are further
    ``gymnasium.make`` arguments a policy needs (``SB3Policy.env_kwargs``: the observation mode
    of a model trained on the depth image); ``body`` the robot body (``robot.model.BODIES``).
    """
    import gymnasium as gym

    import neurocog_gym  # noqa: F401  (registers the ids)
    from neurocog_gym.perception.pipeline import PipelineParams

    kwargs = {"perception": PipelineParams(gng=GNG_OF_ATTENTION[attention])}
    if affordance_source is not None:
        kwargs["affordance_source"] = affordance_source
    if body != "v2":
        kwargs["body"] = body
    if max_seconds is not None:
        kwargs["max_episode_steps"] = max(1, int(round(max_seconds / CONTROL_DT)))
    if privileged:
        kwargs["privileged"] = True
    kwargs.update(SCENARIO_KWARGS.get(scenario, {}))
    kwargs.update(env_kwargs or {})
    return gym.make(ENV_IDS[scenario], **kwargs)


def run_trial(
    env,
    policy,
    spec: TrialSpec,
    similarity: SimilaritySettings | None = None,
) -> dict:
    """Run one trial to its end and return its record.

    Args:
        env: a ``gymnasium.make`` env of ``spec.scenario`` (reused across trials: ``reset``
            with the trial seed makes the trial independent of what ran before).
        policy: ``policy(obs) -> action``.
        spec: scenario, index and env seed.
        similarity: sampling of the similarity curve; None for the defaults.

    Returns:
        The ``trials.jsonl`` record: ``scenario``, ``index``, ``seed``, ``outcome`` (success,
        touch, fail: the v1 outcome of :mod:`neurocog_gym.envs.obstacle`), ``passed``,
        ``touched``, ``knocked``, ``stood_on``, ``stepped_over`` (every block crossed above it by
        a front and a hind foot), ``interrupt_cycles`` and ``provision_cycles`` (control cycles
        whose action had a non-zero interrupt / provision group), ``touch_events``, ``fell``,
        ``sim_unstable``, ``truncated``, ``obstacles`` (block dicts: x, y, length, width, height
        in m, yaw in rad as placed; ``pos``, ``quat`` at the end; ``knocked``, ``stood_on``,
        ``moved`` m, ``turned_deg``, ``feet_over``, ``stepped_over``), ``appeared_at`` (s),
        ``time`` (simulated s at the end), ``time_to_pass`` (s from the obstacle's appearance to
        the end of a passed trial, None if not passed), ``time_to_pass_from_appear`` (s from the
        appearance to the cycle the env first saw the pass, static: from t = 0; None if not
        passed), ``contacts`` (``steps`` in
        contact, ``first_at`` s, ``events``), ``distance`` (m along x), ``steps``,
        ``aef_mode_steps`` (cycles whose action the AEF policy's fit chose in mode 0 none,
        1 interrupt, 2 provision; None for a policy without a ``mode``), ``perception_ms``
        (``mean``, ``max``, ``gng_mean``, ``affordance_mean`` per control cycle), ``wall_s``
        ``similarity`` (:meth:`SimilarityProbe.result`), ``latency`` (sudden trials:
        :meth:`LatencyProbe.result`, all None if the block never appeared; static: None) and
        ``perception`` (the env's ``gng`` and ``affordance_source``). The caller adds the
        run's policy, attention and affordance source.
    """
    from neurocog_gym.policies import start_episode

    settings = similarity or SimilaritySettings()
    u = env.unwrapped
    wall0 = time.perf_counter()
    obs, info = env.reset(seed=spec.seed)
    start_episode(policy, env)
    x0 = float(u.data.qpos[0])
    probe = None
    latency = None
    sudden = spec.scenario == "sudden"
    max_tilt = float(u.pipeline.affordance_params.terrain_max_tilt)
    perception, gng_ms, aff_ms = [], [], []
    modes = [0, 0, 0] if hasattr(policy, "mode") else None
    contact_steps, first_touch = 0, None
    steps, terminated, truncated = 0, False, False
    while not (terminated or truncated):
        action = policy(obs)
        if modes is not None:
            modes[int(policy.mode)] += 1
        t_start, interrupts = float(u.data.time), u.interrupt_cycles
        obs, _, terminated, truncated, info = env.step(action)
        steps += 1
        if info.get("sim_unstable"):
            break
        if sudden and latency is None and getattr(u, "appeared_at", None) is not None:
            blocks = u.pool.blocks
            latency = LatencyProbe(float(u.appeared_at), blocks[0], max_tilt, len(blocks))
        if latency is not None:
            latency.control(t_start, u.interrupt_cycles > interrupts)
            frame = u.frame
            sees = (  # read until the first frame on the block
                latency.first_frame is None
                and frame is not None
                and bool((frame.geom == u.pool.geoms[0]).any())
            )
            latency.perceived(float(u.data.time), u.pipeline, _heading_xy(u.data.qpos), sees)
        # The pipeline's wall times of this cycle (the env's info may carry the total too).
        timings = u.pipeline.timings
        perception.append(1e3 * float(timings["total"]))
        gng_ms.append(1e3 * float(timings.get("gng", math.nan)))
        aff_ms.append(1e3 * float(timings.get("affordance", math.nan)))
        if u.pool.blocks and u.pool.touching(u.data, u.robot.robot_geoms).any():
            contact_steps += 1
            if first_touch is None:
                first_touch = round(float(u.data.time), 4)
        if probe is None and u.pool.blocks:
            appeared = getattr(u, "appeared_at", None)
            probe = SimilarityProbe(
                settings, float(appeared) if sudden and appeared is not None else None
            )
        if probe is not None:
            probe.sample(u)
    t_end = float(u.data.time)
    appeared_at = info.get("appeared_at", getattr(u, "appeared_at", None))
    passed = bool(info.get("passed", False))
    unstable = bool(info.get("sim_unstable", False))
    outcome = "fail" if unstable else info["outcome"]
    if outcome != "fail" and not passed:  # the env's outcome is provisional until the end
        outcome = "fail"
    t_from = appeared_at if appeared_at is not None else 0.0
    return {
        "scenario": spec.scenario,
        "index": spec.index,
        "seed": spec.seed,
        "outcome": outcome,
        "passed": passed and not unstable,
        "touched": bool(info.get("touched", u.touched)),
        "knocked": bool(info.get("knocked", u.knocked)),
        "stood_on": bool(info.get("stood_on", u.stood_on)),
        "stepped_over": bool(info.get("stepped_over", False)),
        "interrupt_cycles": int(info.get("interrupt_cycles", u.interrupt_cycles)),
        "provision_cycles": int(info.get("provision_cycles", u.provision_cycles)),
        "touch_events": int(info.get("touch_events", u.touch_events)),
        "fell": bool(info.get("fell", False)),
        "sim_unstable": unstable,
        "truncated": bool(truncated) and not unstable,
        "obstacles": info.get("obstacles") or [b.to_json() for b in u.pool.blocks],
        "appeared_at": _num(appeared_at),
        "appear_leg": info.get("appear_leg", getattr(u, "appear_leg", None)),
        "appear_forced": bool(info.get("appear_forced", getattr(u, "appear_forced", False))),
        "time": round(t_end, 4),
        "time_to_pass": round(t_end - t_from, 4) if passed and not unstable else None,
        "time_to_pass_from_appear": (
            _num(info.get("time_to_pass_from_appear"), 4) if passed and not unstable else None
        ),
        "contacts": {
            "steps": contact_steps,
            "first_at": first_touch,
            "events": int(info.get("touch_events", u.touch_events)),
        },  # fmt: skip
        "distance": round(float(u.data.qpos[0]) - x0, 4),
        "steps": steps,
        "aef_mode_steps": modes,
        "perception_ms": {
            "mean": _num(np.mean(perception)) if perception else None,
            "max": _num(np.max(perception)) if perception else None,
            "gng_mean": _num(np.mean(gng_ms)) if gng_ms else None,
            "affordance_mean": _num(np.mean(aff_ms)) if aff_ms else None,
        },
        "wall_s": round(time.perf_counter() - wall0, 3),
        "similarity": probe.result() if probe is not None else None,
        "latency": (latency.result() if latency is not None else dict(NO_LATENCY))
        if sudden
        else None,
        "perception": {
            "gng": u.pipeline.params.gng,
            "affordance_source": u.pipeline.params.affordance_source,
        },
        **{k: info[k] for k in STONE_RECORD_KEYS if k in info},
    }


# -- workers -----------------------------------------------------------------------------------

_WORKER: dict = {}


def _init_worker(
    policy: str,
    attention: str,
    max_seconds,
    similarity: SimilaritySettings,
    affordance_source: str | None = None,
    body: str = "v2",
) -> None:
    """Build the policy once per worker; envs are built on first use, one per scenario."""
    from neurocog_gym.policies import make_policy

    _WORKER.clear()
    _WORKER.update(policy=make_policy(policy), attention=attention, max_seconds=max_seconds,
                   similarity=similarity, affordance_source=affordance_source, body=body,
                   envs={})  # fmt: skip


def _init_pool_worker(*initargs) -> None:
    """:func:`_init_worker` in a pool process (local or Ray), with torch held to one thread.

    A pool runs one process per core: torch's own intra-op threads (one per core by default)
    would make the workers' policy calls fight over the cores. A stable-baselines3 policy
    benched 4.3 x slower on two workers with them (1.2 ms a call alone). The serial path
    (one worker, in the caller's process) leaves the caller's torch settings alone.
    """
    _init_worker(*initargs)
    torch = sys.modules.get("torch")
    if torch is not None:
        torch.set_num_threads(1)


def _worker_run(spec: TrialSpec) -> dict:
    """Run one trial in a worker (after :func:`_init_worker`)."""
    envs = _WORKER["envs"]
    if spec.scenario not in envs:
        privileged = bool(getattr(_WORKER["policy"], "needs_privileged", False))
        envs[spec.scenario] = make_env(
            spec.scenario, _WORKER["attention"], _WORKER["max_seconds"], privileged,
            _WORKER["affordance_source"], getattr(_WORKER["policy"], "env_kwargs", None),
            _WORKER["body"],
        )  # fmt: skip
    try:
        return run_trial(envs[spec.scenario], _WORKER["policy"], spec, _WORKER["similarity"])
    except Exception as e:
        # Keep the cause in one picklable line: the trial's identity and the error.
        raise RuntimeError(
            f"trial {spec.scenario} #{spec.index} (seed {spec.seed}) raised "
            f"{type(e).__name__}: {_first_line(e)}"
        ) from None


def _first_line(e: BaseException) -> str:
    text = str(e).strip()
    return text.splitlines()[0] if text else type(e).__name__


def default_workers() -> int:
    """Cores this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def _serial(specs: list[TrialSpec], initargs: tuple) -> Iterator[dict]:
    _init_worker(*initargs)
    try:
        for spec in specs:
            yield _worker_run(spec)
    finally:
        for env in _WORKER.get("envs", {}).values():
            env.close()
        _WORKER.clear()


def _local(specs: list[TrialSpec], workers: int, initargs: tuple) -> Iterator[dict]:
    method = "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() else "spawn"
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context(method),
                               initializer=_init_pool_worker, initargs=initargs)  # fmt: skip
    try:
        pending = {pool.submit(_worker_run, s) for s in specs}
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for fut in done:
                try:
                    yield fut.result()
                except BrokenProcessPool:
                    raise RuntimeError(
                        "a worker process died (out of memory or killed); rerun with --resume"
                    ) from None
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def check_ray_address(address: str, timeout: float = 5.0) -> None:
    """Fail fast, with one line, when a ``host:port`` Ray address does not answer."""
    if address in ("auto", "local"):
        return
    hostport = address.split("://", 1)[-1]
    host, sep, port = hostport.rpartition(":")
    if not sep or not host or not port.isdigit():
        raise ValueError(f"Ray address {address!r} is not of the form host:port or ray://host:port")
    try:
        with socket.create_connection((host, int(port)), timeout=timeout):
            pass
    except OSError as e:
        raise ConnectionError(f"cannot reach the Ray cluster at {address}: {e}") from None


def _ray(
    specs: list[TrialSpec], address: str, workers: int | None, initargs: tuple, used: dict
) -> Iterator[dict]:
    check_ray_address(address)
    try:
        import ray
        from ray.util.multiprocessing import Pool
    except ImportError:
        raise RuntimeError(
            "--ray-address needs ray (pip install 'neurocog-gym[distributed]')"
        ) from None
    import logging

    connected_here = not ray.is_initialized()
    try:
        if connected_here:
            ray.init(address=address, logging_level=logging.ERROR, log_to_driver=False)
        if workers is None:
            workers = max(1, int(ray.cluster_resources().get("CPU", 1)))
        used["workers"] = min(workers, len(specs))
        pool = Pool(processes=used["workers"], initializer=_init_pool_worker, initargs=initargs)
    except Exception as e:  # ray raises its own types for a cluster it cannot use
        if connected_here and ray.is_initialized():
            ray.shutdown()
        raise ConnectionError(f"Ray cluster at {address}: {_first_line(e)}") from None
    try:
        yield from pool.imap_unordered(_worker_run, specs)
    except ray.exceptions.RayTaskError as e:
        raise RuntimeError(
            _first_line(e.cause) if e.cause is not None else _first_line(e)
        ) from None
    finally:
        pool.terminate()
        if connected_here:
            ray.shutdown()


# -- the run -----------------------------------------------------------------------------------


def summarize(records: list[dict], config: BenchConfig, elapsed_s: float | None = None) -> dict:
    """``summary.json``: per scenario the tally and Table 5 analysis, plus ``config``."""
    out = {}
    for s in config.scenarios:
        rs = [r for r in records if r["scenario"] == s and r["index"] < config.trials]
        summ = scenario_summary(rs)
        summ["requested"] = config.trials
        summ["complete"] = len(rs) == config.trials
        summ["paper"] = PAPER_TABLE4.get(s)  # None: no paper count (stepping stones)
        out[s] = summ
    from neurocog_gym import __version__

    out["config"] = {
        "seed": config.seed,
        **config.identity(),
        "scenarios": list(config.scenarios),
        "trials": config.trials,
        "env_ids": {s: ENV_IDS[s] for s in config.scenarios},
        "similarity": asdict(config.similarity),
        "seed_rule": "sha256('neurocog-bench/{seed}/{scenario}/{index}')[:4], big-endian, "
        "& 0x7fffffff",
        "version": __version__,
    }
    if elapsed_s is not None:
        out["config"]["last_session"] = {"elapsed_s": round(elapsed_s, 1)}
    return out


def _check_resume(config: BenchConfig, records: list[dict]) -> None:
    trials = config.out / "trials.jsonl"
    if not config.resume:
        if trials.exists() and trials.stat().st_size > 0:
            raise ValueError(
                f"{trials} exists: pass --resume to continue that run, or another --out"
            )
        return
    ident = config.identity()
    for r in records:
        # runs from before the body keyword were all on body v1
        theirs = {k: r.get(k, "v1" if k == "body" else None) for k in ident}
        if theirs != ident:
            diff = ", ".join(
                f"{k} {theirs[k]!r} != {ident[k]!r}" for k in ident if theirs[k] != ident[k]
            )
            raise ValueError(
                f"cannot resume {config.out}: its trials were run with other settings ({diff})"
            )


def _postfix(records: list[dict], scenarios) -> str:
    parts = []
    for s in scenarios:
        rs = [r for r in records if r["scenario"] == s]
        c = {o: sum(r["outcome"] == o for r in rs) for o in ("success", "touch", "fail")}
        parts.append(f"{s} {c['success']}/{c['touch']}/{c['fail']}")
    return " ".join(parts) + " (S/T/F)"


@dataclass
class BenchResult:
    """What :func:`run_benchmark` did."""

    summary: dict
    ran: int
    """Trials run in this session."""
    skipped: int
    """Trials found finished in ``trials.jsonl`` (resume)."""
    elapsed_s: float
    workers: int


def run_benchmark(config: BenchConfig) -> BenchResult:
    """Run (or resume) a benchmark; see the module docstring for the files it writes."""
    from tqdm import tqdm

    from neurocog_gym.policies import POLICY_NAMES

    policy = config.policy
    if policy not in POLICY_NAMES:
        path = Path(policy).expanduser()
        if not path.is_file():
            raise FileNotFoundError(f"policy model file {policy} does not exist")
        policy = str(path.resolve())
        config = replace(config, policy=policy)
    from neurocog_gym.policies import make_policy

    make_policy(policy)  # a bad model file fails here, in one line, before any worker starts
    if config.ray_address:
        check_ray_address(config.ray_address)
    config.out.mkdir(parents=True, exist_ok=True)
    records = load_trials(config.out) if config.resume else []
    _check_resume(config, records)
    # A torn last line is dropped from the file too, so new lines start on a clean line.
    _rewrite_if_torn(config.out / "trials.jsonl", records)
    done = {(r["scenario"], r["index"]) for r in records}
    todo = [s for s in trial_specs(config) if (s.scenario, s.index) not in done]
    skipped = len(trial_specs(config)) - len(todo)
    initargs = (policy, config.attention, config.max_seconds, config.similarity,
                config.affordance_source, config.body)  # fmt: skip
    workers = config.workers or default_workers()
    workers = max(1, min(workers, len(todo))) if todo else 0
    used = {"workers": workers}
    summary_path = config.out / "summary.json"
    t0 = time.perf_counter()
    io.atomic_write_json(summary_path, summarize(records, config))
    name = policy if len(policy) < 20 else "model"
    bar = tqdm(total=len(todo), desc=f"bench {name}", unit="trial",
               disable=None if config.progress else True, file=sys.stderr)  # fmt: skip
    ran = 0
    try:
        if not todo:
            stream = iter(())
        elif config.ray_address:
            stream = _ray(todo, config.ray_address, config.workers, initargs, used)
        elif workers == 1:
            stream = _serial(todo, initargs)
        else:
            stream = _local(todo, workers, initargs)
        for rec in stream:
            rec = {**rec, **config.identity()}
            io.append_jsonl(config.out / "trials.jsonl", rec)
            records.append(rec)
            ran += 1
            io.atomic_write_json(summary_path, summarize(records, config, time.perf_counter() - t0))
            bar.set_postfix_str(_postfix(records, config.scenarios), refresh=False)
            bar.update(1)
    finally:
        bar.close()
    elapsed = time.perf_counter() - t0
    summary = summarize(records, config, elapsed)
    io.atomic_write_json(summary_path, summary)
    if config.report and any(s in SCENARIOS for s in config.scenarios):
        write_report([config.out], config.out)  # the report's tables are the obstacle tasks'

    return BenchResult(
        summary=summary, ran=ran, skipped=skipped, elapsed_s=elapsed, workers=used["workers"]
    )


def _rewrite_if_torn(path: Path, records: list[dict]) -> None:
    if not path.exists():
        return
    text = path.read_text(encoding="utf-8")
    lines = [ln for ln in text.splitlines() if ln.strip()]
    if (text and not text.endswith("\n")) or len(lines) != len(records):
        io.atomic_write_text(path, "".join(_jsonl_line(r) for r in records))


def _jsonl_line(r: dict) -> str:
    import json

    return json.dumps(r, separators=(",", ":")) + "\n"
