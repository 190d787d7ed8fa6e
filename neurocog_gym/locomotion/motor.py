"""Motor-neuron pools, Eq. (8)-(11), §5.3: CPG pattern + interrupt -> joint angular acceleration.

Each joint's pool turns its activation (mu1 times the CPG drive, flexor minus extensor output
through the synapses m_i, plus mu2 times the AEF interrupt Theta) into a joint angular
acceleration shaped by a Hill-type force-length (Eq. 9) and force-velocity (Eq. 10) factor plus a
touch-sensor term (Eq. 11). The servos on the robot are angle-driven, so the acceleration is
integrated into the position target (see ``_kernels.motor_neuron_step`` for the one term we add:
a visco-elastic restoring force towards the posture).

Reading of Eq. (8): the paper writes the CPG input as y with two dots; SPEC §5 and §5.3's text
("signal outputs from the central pattern generator ... are used as the signal activation") make
it the CPG output itself, which is what we use.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from neurocog_gym.locomotion._kernels import motor_neuron_step, servo_targets


def _twelve(value: float) -> tuple[float, ...]:
    return (float(value),) * 12


@dataclass(frozen=True)
class MotorParams:
    """Motor-neuron pool constants (Eq. 8-11)."""

    mu1: float = 1.0
    """mu_1, gain of the CPG input, dimensionless (Eq. 8)."""
    mu2: float = 10.0
    """mu_2, gain of the interrupt Theta, dimensionless (Eq. 8; the paper leaves it free). Ten times
    the CPG's clipped authority: a lift must move the knee about 0.9 rad within 0.15 s against
    the restoring term (k_rest 0.9 rad ~ 235 rad/s^2) and reach the servo speed within two cycles,
    which needs mu_2 theta_dd_MAX F_l >~ 600 rad/s^2 with theta_dd_MAX ~ 100 (body v1's gait);
    with 3 (body v0) a full knee interrupt lifted the foot 8 cm at most
    (``scripts/bench_interrupt_lift.py``, docs/body.md)."""
    acc_max: tuple[float, ...] = field(default_factory=lambda: _twelve(120.0))
    """theta_dd_MAX per joint, rad/s^2 (Eq. 8; "chosen through preliminary testing")."""
    vel_max: tuple[float, ...] = field(default_factory=lambda: _twelve(6.6))
    """theta_dot_MAX per joint, rad/s: the servo's no-load speed, Eq. (10) (Dynamixel MX-64,
    63 rpm at 12 V)."""
    fl_width: tuple[float, ...] = field(default_factory=lambda: _twelve(2.0))
    """theta_R * omega, rad: distance from theta_opt where F_l falls to 0.05 (Eq. 9). 2.0 rad
    keeps F_l >= 0.5 over the knee's whole range from its posture (1.6 -> 2.8 rad), so an
    interrupt keeps its authority where a step-over needs the knee (body v0 used 1.4: F_l fell
    to 0.45 at 0.9 rad and capped the held lift)."""
    fl_c: float = float(np.log(0.05))
    """c = ln 0.05 (Eq. 9)."""
    fv_K: float = 1.0
    """K, curvature of the Hill force-velocity curve, dimensionless (Eq. 10)."""
    fv_N: float = 1.5
    """N, eccentric force ratio F/F_max at lengthening, dimensionless (Eq. 10)."""
    touch_weights: tuple[tuple[float, ...], ...] = field(
        default_factory=lambda: tuple((0.0,) * 4 for _ in range(12))
    )
    """z_il, (12, 4) touch-sensor to motor-neuron weights, rad/s^2 (Eq. 11); zero by default."""
    k_rest: float = 160.0
    """Restoring stiffness towards the posture, 1/s^2 (our addition; natural frequency 2 Hz)."""
    d_rest: float = 12.6
    """Restoring damping, 1/s (damping ratio 0.5 with k_rest = 160)."""


def leg_coordinates(knee_behind) -> np.ndarray:
    """(12,) coupling of the pools' leg coordinates: 1 at the hip of each knee-behind leg.

    The pools of a leg drive (hip, knee) for a knee-ahead leg and (shank pitch, knee) for a
    knee-behind one, the shank pitch being hip - knee (the knee axis is reversed, so the shank's
    pitch to the torso is the hip angle minus the fold). Both legs' feet then sit at the same
    place for the same pool angles: the foot's direction from the hip is pool_hip + knee / 2 and
    its distance 2 l cos(knee / 2) for segments of length l, so a gait and an interrupt written
    for one knee direction move the foot the same way with the other. The hip servo's target
    is pool_hip + knee (``_kernels.motor_neuron_step``). Body v2 folds every knee behind its
    foot (issue 21: a knee ahead of the foot leads the shank into a block's near edge).

    Args:
        knee_behind: (4,) bool per leg (FL, FR, HL, HR).
    """
    kb = np.asarray(knee_behind, dtype=bool)
    if kb.shape != (4,):
        raise ValueError(f"knee_behind must be 4 booleans (FL, FR, HL, HR), got shape {kb.shape}")
    c = np.zeros(12)
    c[3 * np.flatnonzero(kb) + 1] = 1.0
    return c


class MotorNeuronPools:
    """Twelve motor-neuron pools that integrate Eq. (8) into servo position targets.

    Args:
        posture: (12,) rest angles and Eq. (9) optimum angles, rad (the standing posture).
        q_lo, q_hi: (12,) joint range, rad.
        params: pool constants.
        dt: control cycle, s.
        knee_behind: (4,) bool, legs whose knee folds behind the foot (``leg_coordinates``);
            ``posture``, ``q_ref`` and the interrupt's joint group are then in leg coordinates,
            ``target`` in joint angles. Default: no leg (pool angles = joint angles).
    """

    def __init__(
        self, posture, q_lo, q_hi, params: MotorParams | None = None, dt=0.01, knee_behind=None
    ):
        self.params = p = params or MotorParams()
        self.dt = float(dt)
        self.posture = np.asarray(posture, dtype=np.float64).copy()
        self.joint_lo = np.asarray(q_lo, dtype=np.float64).copy()
        self.joint_hi = np.asarray(q_hi, dtype=np.float64).copy()
        self.coupling = leg_coordinates(np.zeros(4, bool) if knee_behind is None else knee_behind)
        # The pools' own range: every shank pitch the joint ranges reach.
        self.q_lo = self.joint_lo.copy()
        self.q_hi = self.joint_hi.copy()
        for j in np.flatnonzero(self.coupling):
            self.q_lo[j] = self.joint_lo[j] - self.joint_hi[j + 1]
            self.q_hi[j] = self.joint_hi[j] - self.joint_lo[j + 1]
        self.acc_max = np.asarray(p.acc_max, dtype=np.float64)
        self.vel_max = np.asarray(p.vel_max, dtype=np.float64)
        self.fl_width = np.asarray(p.fl_width, dtype=np.float64)
        self.Z = np.asarray(p.touch_weights, dtype=np.float64)
        if self.Z.shape != (12, 4):
            raise ValueError(f"MotorParams.touch_weights must be 12 x 4, got {self.Z.shape}")
        self.q_ref = np.zeros(12)
        self.qd_ref = np.zeros(12)
        self.acc = np.zeros(12)
        self.target = np.zeros(12)
        """(12,) servo targets in joint angles, rad (``q_ref`` in joint coordinates)."""

    def reset(self, q0: np.ndarray) -> None:
        """Start from pool angles ``q0`` (12,), at rest."""
        self.q_ref[:] = q0
        self.qd_ref[:] = 0.0
        self.acc[:] = 0.0
        servo_targets(self.q_ref, self.coupling, self.joint_lo, self.joint_hi, self.target)

    def step(self, drive, interrupt, theta, theta_dot, touch) -> np.ndarray:
        """One control cycle; returns the (12,) servo targets in joint angles (``self.target``).

        Args:
            drive: (12,) CPG drive of each joint, dimensionless.
            interrupt: (12,) Theta in [-1, 1].
            theta: (12,) measured joint angles, rad.
            theta_dot: (12,) measured joint rates, rad/s.
            touch: (4,) touch inputs.
        """
        p = self.params
        motor_neuron_step(
            self.q_ref, self.qd_ref, np.asarray(drive, dtype=np.float64),
            np.asarray(interrupt, dtype=np.float64), theta, theta_dot,
            np.asarray(touch, dtype=np.float64), self.posture, p.mu1, p.mu2, self.acc_max,
            self.vel_max, self.fl_width, p.fl_c, p.fv_K, p.fv_N, self.Z,
            p.k_rest, p.d_rest, self.q_lo, self.q_hi, self.dt, self.acc, self.coupling,
            self.joint_lo, self.joint_hi, self.target,
        )  # fmt: skip
        return self.target
