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
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from neurocog_gym import paths
from neurocog_gym.locomotion.aef import AEFWeights
from neurocog_gym.locomotion.fit import (
    MODE_INTERRUPT,
    MODE_NONE,
    MODE_PROVISION,
    Fit,
    FitDecision,
    FitParams,
)
from neurocog_gym.policies import _aef_kernel as _k
from neurocog_gym.policies.base import ACTION_DIM


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
    """The observation keys the policy reads (the obstacle envs have them all)."""

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
        self.fit = Fit(fit)
        self.reset()

    def reset(self, env=None) -> None:
        """Start a new episode: forget the fit's state, the odometry and the clock.

        ``env`` is ignored (the hook's signature, :func:`~neurocog_gym.policies.start_episode`).
        """
        self.fit.reset()
        self._cycles = 0
        self._odo = Odometry()
        self.mode = MODE_NONE
        self.decision: FitDecision | None = None

    def __call__(self, obs) -> np.ndarray:
        """Map one observation of an obstacle env to the 15-value action."""
        yaw, origin = self._odo.update(obs["torso_quat"], obs["torso_lin_vel"], self.dt)
        t = self._cycles * self.dt
        self._cycles += 1
        legs = to_frame(np.asarray(obs["leg_joints"]).reshape(12, 3), yaw, origin).reshape(4, 3, 3)
        feet = to_frame(np.asarray(obs["feet"]).reshape(4, 3), yaw, origin)
        boxes = boxes_in_frame(obs["remembered_blocks"], yaw, origin)
        hit = np.rint(np.asarray(obs["block_met"], dtype=np.float64)).astype(np.int64)
        hit[hit >= len(boxes)] = -1
        direction = np.asarray(obs["interrupt_direction"], dtype=np.float64).reshape(4, 3)
        d = self.fit.decide(
            t, yaw, direction, hit, feet, legs[:, 0], legs[:, 1], legs[:, 2], boxes
        )  # fmt: skip
        self.decision, self.mode = d, d.mode
        action = np.zeros(ACTION_DIM, dtype=np.float32)
        if d.mode == MODE_NONE:
            return action
        x = np.asarray(obs["aef_input"], dtype=np.float64).copy()
        # The slots at the observation's precision, as the env handed them to the network.
        x[3:15] = d.slots.astype(np.float32).ravel()
        interrupt, provision = self.weights.forward(x)
        if d.mode == MODE_INTERRUPT:
            mask = np.repeat(np.abs(d.slots).sum(axis=1) > 0, 3)
            action[:12] = np.clip(self.interrupt_gain * interrupt * mask, -1.0, 1.0)
        elif d.mode == MODE_PROVISION:
            action[12:] = provision
        return action


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
    _k.points_to_frame(p, np.cos(yaw), np.sin(yaw), float(origin[0]), float(origin[1]), out)
    return out


def boxes_in_frame(rows, yaw: float, origin: np.ndarray) -> np.ndarray:
    """(K, 2, 3) the valid ``remembered_blocks`` rows as min/max corners in the odometry frame.

    A remembered box is axis-aligned in the world; its four footprint corners, turned into the
    odometry frame, bound it again (the frame differs from the world by a shift only). Its bottom
    is the floor.
    """
    rows = np.asarray(rows).reshape(-1, 7)
    out = np.empty((len(rows), 2, 3))
    k = _k.rows_to_boxes(rows, np.cos(yaw), np.sin(yaw), float(origin[0]), float(origin[1]), out)
    return out[:k]
