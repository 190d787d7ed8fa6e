"""Fast gait evaluation for the NSGA-II tuner (§6.3, Table 3): one chromosome, one rollout.

The evaluator steps the MuJoCo model with the :class:`LocomotionGenerator`'s state and kernels
directly (one fused numba call per cycle, ``_eval_kernels.py``) — no perception, no Gymnasium
wrappers — and reproduces ``NeuroCog/Walk-v3`` with an all-zero action step for step: same scene,
same reset (the ``home`` keyframe plus uniform joint noise, then the CPG's trot-phase start with
its own noise, both drawn from ``numpy.random.default_rng(seed)`` in the env's order), same fall
and physics-fault tests. The one difference: a diverging CPG ends the rollout (below), where the
env would go on. A rollout is deterministic per ``(genes, seed)`` and independent of which
process runs it. About 90 % of its time is ``mj_step`` (``scripts/bench_nsga.py``).

Measures (our reading of §6.3, which names the objectives but not their formulas):

* speed ``v``: forward (world +x) displacement over the measuring window divided by its length;
  the window starts after ``warmup`` seconds (the CPG's start-up transient) and ends at the end
  of the rollout or at the fall (if the rollout is shorter than ``2 * warmup``, the window is its
  second half);
* objective 1, speed error ``|v - v*|``, v* = 0.5 m/s;
* objective 2, cost of transport ``E / (m g d)``: E is the mechanical energy
  ``sum_t sum_joints |tau * omega| * dt`` over the window, sampled once per control cycle exactly
  as the env's ``info["power"]``; m the robot's mass; d the forward distance of the window,
  floored at ``min_speed * window`` so a robot that stands or walks backwards gets a large but
  finite value;
* constraint ``G = 1 - t_fall / T`` when the robot falls (torso tilted over 60 degrees or lower
  than 0.12 m, the env's test), the physics faults, or the CPG diverges (an inner state
  beyond ``cpg_bound`` or not finite: Eq. 5 is unbounded when excitatory loops win, and the
  pools' clipped activation would hide it as a bang-bang drive) at ``t_fall``; ``G = 0`` when it
  walks the whole ``T`` seconds. ``G <= 0`` is feasible, and among falling gaits the one that
  stays up longer has the smaller violation.

Not objectives in Table 3, but measured over the same window (the optional ``--max-drift``
constraint of the tuner uses the first): lateral drift, the torso's sideways (world y)
displacement, also per 10 m forward (``10 |dy| / max(dx, min_speed * window)``), and heading
change, the torso yaw at the end of the window minus at its start (unwrapped), rad.
"""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass

import mujoco
import numpy as np

from neurocog_gym.locomotion.gait import Gait, default_gait
from neurocog_gym.locomotion.generator import _JOINT_NEURONS, _SIDE, LocomotionGenerator
from neurocog_gym.robot.model import FAULT_WARNINGS, GRAVITY, RobotIndex, load_model
from neurocog_gym.train._eval_kernels import after_step, generator_cycle

_FAULT_INDEX = np.array([int(w) for w in FAULT_WARNINGS], dtype=np.int64)


@dataclass(frozen=True)
class EvalParams:
    """How one chromosome is evaluated (Table 3 and the module docstring)."""

    seconds: float = 10.0
    """T, simulated seconds per evaluation, s (Table 3)."""
    dt: float = 0.01
    """Control cycle, s (Table 3); a multiple of the model's 2 ms physics step."""
    target_speed: float = 0.5
    """v*, desired forward speed, m/s (§6.3)."""
    warmup: float = 1.0
    """Start-up transient excluded from speed and energy, s (our choice)."""
    min_speed: float = 0.01
    """Floor on distance / window in the cost of transport, m/s (our choice)."""
    reset_noise_scale: float = 0.02
    """Uniform joint-angle noise at reset, rad (the env's default)."""
    cpg_noise: float = 0.05
    """Uniform noise on the CPG's initial inner states (the env's value)."""
    cpg_bound: float = 1e3
    """|x_i| beyond which the CPG counts as diverged, dimensionless (our choice; a working
    Matsuoka network with u0 = 1 stays within a few units)."""
    body: str = "v2"
    """The robot body of the rollout (``robot.model.BODIES``; the envs' default)."""

    def __post_init__(self):
        for name in ("seconds", "dt", "target_speed", "min_speed"):
            if not getattr(self, name) > 0:
                raise ValueError(f"EvalParams.{name} must be positive, got {getattr(self, name)}")
        for name in ("warmup", "reset_noise_scale", "cpg_noise"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"EvalParams.{name} must be >= 0, got {getattr(self, name)}")
        for name in ("seconds", "dt", "warmup"):
            if not np.isfinite(getattr(self, name)):
                raise ValueError(f"EvalParams.{name} must be finite, got {getattr(self, name)}")
        if self.seconds < self.dt:
            raise ValueError(f"evaluation of {self.seconds} s is shorter than one cycle {self.dt}")


@dataclass(frozen=True)
class GaitScore:
    """Result of one evaluation (all floats finite)."""

    speed: float
    """Forward speed over the measuring window, m/s."""
    speed_error: float
    """Objective 1, |speed - v*|, m/s."""
    cost_of_transport: float
    """Objective 2, mechanical energy / (m g distance), dimensionless."""
    energy: float
    """Mechanical energy over the window, J."""
    distance: float
    """Forward distance over the window, m (may be negative)."""
    seconds: float
    """Simulated time until the end or the fall, s."""
    fell: bool
    """True if the robot fell or the physics faulted before ``EvalParams.seconds``."""
    constraint: float
    """G, the fall constraint: 1 - t_fall / T, or 0 (feasible) if it never fell."""
    lateral_drift: float = 0.0
    """Sideways (world y) displacement of the torso over the window, m (+ is left)."""
    drift_per_10m: float = 0.0
    """|lateral drift| per 10 m forward, m (the forward distance floored as in the CoT)."""
    heading_change: float = 0.0
    """Torso yaw at the end of the window minus at its start, rad (+ is a left turn)."""

    @property
    def objectives(self) -> tuple[float, float]:
        """(speed error, cost of transport), the two NSGA-II objectives."""
        return (self.speed_error, self.cost_of_transport)

    @property
    def feasible(self) -> bool:
        """Whether the constraint holds (G <= 0)."""
        return self.constraint <= 0.0


class GaitEvaluator:
    """Roll out chromosomes on flat ground, reusing one compiled model.

    Only the chromosome changes between evaluations; everything else of the gait (synapse gains,
    posture, tau_f, motor-neuron constants) comes from ``base_gait``.

    Args:
        base_gait: the gait whose genes are replaced; None is the shipped default (read now).
        params: evaluation settings.
    """

    def __init__(self, base_gait: Gait | None = None, params: EvalParams | None = None):
        self.base_gait = base_gait if base_gait is not None else default_gait()
        self.params = p = params or EvalParams()
        self.model = load_model(body=p.body)
        self.data = mujoco.MjData(self.model)
        self.robot = RobotIndex.build(self.model)
        frame_skip = p.dt / self.model.opt.timestep
        self.frame_skip = int(round(frame_skip))
        if self.frame_skip < 1 or abs(frame_skip - self.frame_skip) > 1e-9:
            raise ValueError(
                f"control cycle {p.dt} s is not a multiple of the physics step "
                f"{self.model.opt.timestep} s"
            )
        self.dt = self.frame_skip * float(self.model.opt.timestep)
        self.n_steps = int(round(p.seconds / self.dt))
        self._weight_per_leg = self.robot.mass * GRAVITY / 4.0

    def _reset(self, genes: np.ndarray, seed: int) -> LocomotionGenerator:
        """The env's ``reset(seed=seed)`` (``QuadrupedEnv.reset_model``), for these genes."""
        m, d, r, p = self.model, self.data, self.robot, self.params
        gen = LocomotionGenerator(
            self.base_gait.with_genes(genes),
            r.joint_lo,
            r.joint_hi,
            self.dt,
            knee_behind=r.knee_behind,
        )
        rng = np.random.default_rng(seed)
        mujoco.mj_resetData(m, d)
        qpos = r.home_qpos.copy()
        qpos[r.qpos_adr] += rng.uniform(-p.reset_noise_scale, p.reset_noise_scale, size=12)
        d.qpos[:] = qpos
        d.qvel[:] = 0.0
        mujoco.mj_forward(m, d)
        gen.reset(rng, noise=p.cpg_noise)
        d.ctrl[r.actuator] = gen.pools.target
        return gen

    def evaluate(self, genes: np.ndarray, seed: int = 0) -> GaitScore:
        """Score one chromosome.

        Args:
            genes: (77,) chromosome (``chromosome.py``).
            seed: reset-noise seed; the result is a pure function of ``(genes, seed)``.
        """
        return self._rollout(genes, seed, None)

    def trace(self, genes: np.ndarray, seed: int = 0) -> tuple[GaitScore, dict[str, np.ndarray]]:
        """Score one chromosome and record it (Fig. 14).

        Returns:
            The score and a dict of ``t`` (n,) s, ``cpg`` (n, 24) the neuron outputs y_i (Eq. 7),
            ``x`` (n,) torso forward position, m, ``touch`` (n, 4).
        """
        log: dict[str, list] = {"t": [], "cpg": [], "x": [], "touch": []}
        score = self._rollout(genes, seed, log)
        return score, {k: np.asarray(v) for k, v in log.items()}

    def _rollout(self, genes, seed: int, log: dict | None) -> GaitScore:
        m, d, r, p = self.model, self.data, self.robot, self.params
        gen = self._reset(np.asarray(genes, dtype=np.float64), int(seed))
        cpg, pools = gen.cpg, gen.pools
        cp, mp = cpg.params, pools.params
        cpg_consts = np.array(
            [cp.u0, cp.b, cp.tau, cp.T, cp.tau_f * 1.0, cpg.dt / cp.time_unit / cp.substeps]
        )
        motor_consts = np.array([mp.mu1, mp.mu2, mp.fl_c, mp.fv_K, mp.fv_N, mp.k_rest, mp.d_rest])
        cycle_args = (
            d.qpos, d.qvel, d.sensordata, d.ctrl, r.qpos_adr, r.dof_adr, r.touch_adr, r.actuator,
            self._weight_per_leg, cpg.x, cpg.v, cpg.W, cpg.V, cpg_consts, cp.substeps,
            _JOINT_NEURONS, gen.g_flex, gen.g_ext, pools.q_ref, pools.qd_ref, pools.posture,
            motor_consts, pools.acc_max, pools.vel_max, pools.fl_width, pools.Z, pools.q_lo,
            pools.q_hi, pools.dt, np.zeros(12), cpg.y, p.cpg_bound, pools.coupling, pools.joint_lo,
            pools.joint_hi, pools.target,
        )  # fmt: skip
        warn = d.warning.number
        n_warn = int(sum(warn[w] for w in FAULT_WARNINGS))
        check_args = (d.qpos, d.qvel, d.actuator_force, d.xmat, warn, _FAULT_INDEX)
        check_tail = (r.actuator, r.dof_adr, r.torso_body)
        dt, nstep = self.dt, self.frame_skip
        warm_steps = int(round(p.warmup / dt))
        xs = np.empty(self.n_steps + 1)
        xs[0] = d.qpos[0]
        # y and the quaternion per cycle for the drift and heading measures (a copy costs ~1 us).
        ys = np.empty(self.n_steps + 1)
        ys[0] = d.qpos[1]
        quats = np.empty((self.n_steps + 1, 4))
        quats[0] = d.qpos[3:7]
        power = np.zeros(self.n_steps)
        fell_at = None
        k = 0
        elapsed, ramp = 0.0, gen.prov.start_ramp
        vest_gain = float(self.base_gait.vestibular_gain)
        for k in range(self.n_steps):
            elapsed += gen.dt  # accumulated exactly as LocomotionGenerator.step does
            gain = elapsed / ramp if elapsed < ramp else 1.0
            if generator_cycle(*cycle_args, gain, vest_gain, _SIDE):
                mujoco.mj_step(m, d, nstep=nstep)
                status, power[k], n_warn = after_step(*check_args, n_warn, *check_tail)
            else:
                status = 1  # the CPG diverged: the controller failed, as bad as a fall
            if status == 1:
                fell_at = k * dt  # the faulty cycle counts as lost, like the env's truncation
                xs[k + 1], ys[k + 1], quats[k + 1] = xs[k], ys[k], quats[k]
                break
            xs[k + 1] = d.qpos[0]
            ys[k + 1] = d.qpos[1]
            quats[k + 1] = d.qpos[3:7]
            if log is not None:
                log["t"].append((k + 1) * dt)
                log["cpg"].append(cpg.y.copy())
                log["x"].append(float(d.qpos[0]))
                log["touch"].append(d.sensordata[r.touch_adr] / self._weight_per_leg)
            if status == 2:
                fell_at = (k + 1) * dt
                break
        n_done = k + 1 if fell_at is None else max(int(round(fell_at / dt)), 1)
        start = warm_steps if n_done >= 2 * warm_steps else n_done // 2
        window = (n_done - start) * dt
        distance = float(xs[n_done] - xs[start])
        energy = float(power[start:n_done].sum() * dt)
        speed = distance / window
        cot = energy / (r.mass * GRAVITY * max(distance, p.min_speed * window))
        lost = 0.0 if fell_at is None else 1.0 - fell_at / (self.n_steps * dt)
        lateral = float(ys[n_done] - ys[start])
        drift10 = 10.0 * abs(lateral) / max(distance, p.min_speed * window)
        w, qx, qy, qz = quats[start : n_done + 1].T
        yaw = np.unwrap(np.arctan2(2.0 * (w * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz)))
        heading = float(yaw[-1] - yaw[0]) if np.isfinite(yaw).all() else 0.0
        return GaitScore(
            speed=speed,
            speed_error=abs(speed - p.target_speed),
            cost_of_transport=cot,
            energy=energy,
            distance=distance,
            seconds=n_done * dt if fell_at is None else fell_at,
            fell=fell_at is not None,
            constraint=max(lost, 1e-9) if fell_at is not None else 0.0,
            lateral_drift=lateral if np.isfinite(lateral) else 0.0,
            drift_per_10m=float(drift10) if np.isfinite(drift10) else 1e6,
            heading_change=heading,
        )


# -- process-pool workers (local processes or Ray actors) --------------------------------------

_WORKER: dict = {}


def _die_with_parent() -> None:
    """Linux: have the kernel stop this worker when the process that started it dies.

    A run killed with SIGKILL would otherwise leave its idle pool workers behind.
    """
    if not sys.platform.startswith("linux"):
        return
    import ctypes
    import signal

    parent = os.getppid()
    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        return
    if os.getppid() != parent:  # the parent died before prctl took effect
        os._exit(0)


def _worker_init(base_gait: Gait, params: EvalParams, seed: int, local: bool = False) -> None:
    """Pool initializer: build one evaluator per worker process (model compiled once).

    ``local`` marks a worker of a local process pool, which then dies with its parent.
    """
    if local:
        _die_with_parent()
    _WORKER["evaluator"] = GaitEvaluator(base_gait, params)
    _WORKER["seed"] = int(seed)


def _worker_evaluate(genes: np.ndarray) -> tuple[float, float, float, float]:
    """Pool task: ``(speed error, cost of transport, G, drift per 10 m)`` of one chromosome."""
    if "evaluator" not in _WORKER:
        raise RuntimeError("evaluation worker was not initialised")
    s = _WORKER["evaluator"].evaluate(genes, _WORKER["seed"])
    return score_row(s)


def score_row(s: GaitScore) -> tuple[float, float, float, float]:
    """What a pool returns per chromosome: speed error, CoT, fall G, drift per 10 m."""
    return (s.speed_error, s.cost_of_transport, s.constraint, s.drift_per_10m)
