"""AEFPolicy: the paper's controller, the Affordance–Effectivity Fit network (§5.2, Fig. 7).

Every control cycle the policy decides, from the observation alone, which of the AEF's two
output groups acts (the fit, ``locomotion/fit.py``): the interrupt group on the legs whose
predicted swing met a block (the effectivity's interrupt directions v^l are non-zero), the
walking-provision group to walk round an obstacle ahead or to stop, side-step and pass a block
that appeared within reach (the stop / side-step / pass teacher, ``locomotion/avoidance.py``),
or neither (zero action: the CPG walks alone). The network — the shipped (or given) weights,
NumPy forward pass — then maps its 31 inputs (``aef_input``, with the per-leg direction slots
the decision chose) to the acting group's values.

What it reads of the obstacle envs' observation (``AEFPolicy.obs_keys``), nothing else of the
env: ``aef_input``, ``interrupt_direction``, ``block_met``, ``remembered_blocks``, ``feet``,
``leg_joints``, ``torso_quat`` and ``torso_lin_vel``. The remembered blocks and the legs are
observed relative to the torso in its heading frame; the fit compares them across cycles (the
boxes it has seen, how far the feet are past a block), so the policy carries them into one
frame that stays put over the episode by odometry: the heading from ``torso_quat``, the position
by integrating the torso's velocity (trapezoidal rule over the 0.01 s control cycles; its drift
is a few millimetres over an episode, well inside the fit's 3-15 cm distances).

The policy keeps state across an episode (the fit's, the odometry, the cycle clock): call
:meth:`AEFPolicy.reset` (or :func:`neurocog_gym.policies.start_episode`) after every
``env.reset``, call it once per env step, and use one instance per env.

With ``interrupt_gain=0`` only the walking provision acts: the ``aef-provision`` ablation
(``make_policy("aef-provision")``).

A cycle is one compiled call (``_aef_kernel.policy_step``: odometry, frames, the fit's decision
as ``_fit_kernel.decide_kernel``, the network's normalised input, over buffers the policy owns),
then the NumPy forward pass of the acting head only (issue 22: a cycle within 5 % of a step).
The pieces below (:class:`Odometry`, :func:`to_frame`, :func:`boxes_in_frame`) with
``locomotion.fit.Fit`` are the readable form of the same cycle;
``tests/policies/test_aef_compiled.py`` checks the two give the same actions bit for bit.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from neurocog_gym import paths
from neurocog_gym.locomotion import _fit_kernel as _fk
from neurocog_gym.locomotion._avoidance_kernel import KNOWN_CAPACITY, N_OUT
from neurocog_gym.locomotion.aef import N_INPUTS, AEFWeights
from neurocog_gym.locomotion.fit import (
    MODE_INTERRUPT,
    MODE_PROVISION,
    FitDecision,
    FitParams,
    kernel_params,
)
from neurocog_gym.policies import _aef_kernel as _k
from neurocog_gym.policies.base import ACTION_DIM
from neurocog_gym.robot.names import FRONT_LEGS


class AEFPolicy:
    """The fit and the AEF network with the shipped (or given) weights (module docstring).

    Args:
        weights: path of an ``.npz`` written by ``neurocog train-aef``; None uses
            ``assets/aef_weights.npz``.
        interrupt_gain: scales the interrupt group's output before clipping to [-1, 1].
        fit: the fit's parameters; None for the defaults.
        dt: the env's control cycle, s (the clock and the odometry step).

    Attributes:
        mode: the last decision's mode (``locomotion.fit.MODE_NONE``, ``MODE_INTERRUPT``,
            ``MODE_PROVISION``).
        decision: the last :class:`~neurocog_gym.locomotion.fit.FitDecision` (None before the
            first call).
    """

    name = "aef"
    obs_keys = (
        "aef_input",
        "interrupt_direction",
        "block_met",
        "remembered_blocks",
        "feet",
        "leg_joints",
        "torso_quat",
        "torso_lin_vel",
    )
    """The observation keys the policy reads (the obstacle envs have them all; flat arrays)."""

    def __init__(
        self,
        weights: str | os.PathLike | None = None,
        interrupt_gain: float = 1.0,
        fit: FitParams | None = None,
        dt: float = 0.01,
    ):
        path = Path(weights) if weights is not None else paths.asset(paths.AEF_WEIGHTS)
        self.weights = AEFWeights.load(path)
        self.interrupt_gain = float(interrupt_gain)
        if not dt > 0:
            raise ValueError(f"dt must be positive, got {dt}")
        self.dt = float(dt)
        self.fit_params = fit or FitParams()
        self._par = kernel_params(self.fit_params)
        self._front = np.array(FRONT_LEGS, dtype=np.int64)
        w = self.weights
        self._in_norm = np.ascontiguousarray(np.stack([w.in_mean, w.in_std]), dtype=np.float64)
        # The forward pass stays NumPy: its tanh is not libm's (it differs in the last bit for a
        # third of the values), so a compiled one would not give the same actions bit for bit.
        self._x = np.zeros(N_INPUTS)
        self._trunk = tuple(_Layer(W, b) for W, b in w.layers)
        self._head_interrupt = _Layer(*w.head_interrupt)
        self._head_provision = _Layer(*w.head_provision)
        self._sf = np.zeros(_k.SF_TEACHER + _fk.N_TF)
        self._si = np.zeros(_k.SI_TEACHER + _fk.N_TI, dtype=np.int64)
        self._known = np.zeros((KNOWN_CAPACITY, 2))
        self._known_sudden = np.zeros(KNOWN_CAPACITY, dtype=np.bool_)
        self._inlane = np.zeros(4, dtype=np.bool_)
        self._geometry = np.zeros(4 + N_OUT)
        self._rows3 = np.zeros((_k.N_ROWS, 3))
        self._boxes = np.zeros((8, 2, 3))
        self.reset()

    def reset(self, env=None) -> None:
        """Start a new episode: forget the fit's state, the odometry and the clock.

        ``env`` is ignored (the hook's signature, :func:`~neurocog_gym.policies.start_episode`).
        """
        self._sf[:] = 0.0
        self._si[:] = 0
        _fk.teacher_reset(
            self._sf[_k.SF_TEACHER :], self._si[_k.SI_TEACHER :], self._known, self._known_sudden
        )

    @property
    def mode(self) -> int:
        """The last cycle's mode (``MODE_NONE`` before the first call of the episode)."""
        return int(self._si[_k.SI_MODE])

    @property
    def teacher_state(self) -> int:
        """The walk-round teacher's state after the last cycle (``avoidance.STATE_NAMES``)."""
        return int(self._si[_k.SI_TEACHER + _fk.TI_STATE])

    @property
    def decision(self) -> FitDecision | None:
        """The last cycle's decision (copies), None before the first call of the episode."""
        if self._si[_k.SI_CYCLES] == 0:
            return None
        r = self._rows3
        return FitDecision(
            mode=self.mode,
            provision=r[_k.R_PROVISION].copy(),
            slots=r[_k.R_SLOTS : _k.R_PROVISION].copy(),
            target=int(self._si[_k.SI_TARGET]),
        )

    def __call__(self, obs) -> np.ndarray:
        """Map one observation of an obstacle env to the 15-value action."""
        mode = _k.policy_step(
            obs["torso_quat"], obs["torso_lin_vel"], obs["leg_joints"], obs["feet"],
            obs["remembered_blocks"], obs["block_met"], obs["interrupt_direction"],
            obs["aef_input"], self.dt, self._par, self._front, self._in_norm, self._sf, self._si,
            self._known, self._known_sudden, self._inlane, self._geometry, self._rows3,
            self._boxes, self._x,
        )  # fmt: skip
        if mode < 0:
            self._grow_or_raise(obs, mode)
            return self(obs)
        action = np.zeros(ACTION_DIM, dtype=np.float32)
        if mode == MODE_PROVISION:
            action[12:] = self._forward(self._head_provision)
        elif mode == MODE_INTERRUPT:
            interrupt = self._forward(self._head_interrupt)
            slots = self._rows3[_k.R_SLOTS : _k.R_PROVISION]
            mask = np.repeat(np.abs(slots).sum(axis=1) > 0, 3)
            action[:12] = np.clip(self.interrupt_gain * interrupt * mask, -1.0, 1.0)
        return action

    def _forward(self, head: _Layer) -> np.ndarray:
        """``AEFWeights.forward`` of the input ``policy_step`` wrote, for one head (a buffer)."""
        h = self._x
        for layer in self._trunk:
            h = layer(h)
        return head(h)

    def _grow_or_raise(self, obs, code: int) -> None:
        if code == _k.SMALL_BUFFER:
            self._boxes = np.zeros((np.size(obs["remembered_blocks"]) // 7, 2, 3))
            return
        sizes = {k: np.shape(obs[k]) for k in self.obs_keys}
        raise ValueError(f"AEFPolicy: observation arrays of unexpected sizes: {sizes}")


class _Layer:
    """One tanh layer of the network over its own buffers: tanh(h @ W.T + b), as NumPy does it."""

    def __init__(self, W: np.ndarray, b: np.ndarray):
        self.W_T = np.asarray(W, dtype=np.float64).T
        self.b = np.asarray(b, dtype=np.float64)
        self.z = np.empty(len(self.b))
        self.out = np.empty(len(self.b))

    def __call__(self, h: np.ndarray) -> np.ndarray:
        np.dot(h, self.W_T, out=self.z)
        np.add(self.z, self.b, out=self.z)
        return np.tanh(self.z, out=self.out)


class Odometry:
    """The torso's heading and horizontal position in the episode's start frame.

    From the observed orientation and velocity; the position by the trapezoidal rule from 0.
    """

    def __init__(self):
        self.position = np.zeros(2)
        self._v = np.zeros(2)
        self._started = False

    def update(self, quat, lin_vel, dt: float) -> tuple[float, np.ndarray]:
        """One cycle: (yaw, rad; (2,) position, m) from ``torso_quat`` and ``torso_lin_vel``."""
        yaw = _k.odometry_step(
            np.asarray(quat), np.asarray(lin_vel), float(dt), self._v, self._started,
            self.position,
        )  # fmt: skip
        self._started = True
        return float(yaw), self.position


def to_frame(points: np.ndarray, yaw: float, origin: np.ndarray) -> np.ndarray:
    """(N, 3) points observed in the torso's heading frame, in the odometry frame (float64)."""
    p = np.asarray(points).reshape(-1, 3)
    out = np.empty((len(p), 3))
    c, s = np.cos(yaw), np.sin(yaw)
    _k.points_to_frame(p.reshape(-1), c, s, float(origin[0]), float(origin[1]), out)
    return out


def boxes_in_frame(rows, yaw: float, origin: np.ndarray) -> np.ndarray:
    """(K, 2, 3) the valid ``remembered_blocks`` rows as min/max corners in the odometry frame.

    A remembered box is axis-aligned in the world; its four footprint corners, turned into the
    odometry frame, bound it again (the frame differs from the world by a shift only). Its bottom
    is the floor.
    """
    rows = np.asarray(rows).reshape(-1, 7)
    out = np.empty((len(rows), 2, 3))
    c, s = np.cos(yaw), np.sin(yaw)
    k = _k.rows_to_boxes(rows.reshape(-1), c, s, float(origin[0]), float(origin[1]), out)
    return out[:k]
