"""The locomotion generator of §5 (Fig. 6): walking provision -> CPG -> motor-neuron pools.

One call of :meth:`LocomotionGenerator.step` is one 0.01 s control cycle. Inputs are the AEF's two
output groups — the walking provision (s_SAG, s_COR, s_DIR) and the 12-joint interrupt Theta —
and the proprioception; the output is the 12 servo position targets.

How the walking provision enters the CPG (§5.2 says only that the three values go to the CPG; this
is our reading, each value in [-1, 1], 0 = the gait as tuned):

* s_SAG scales the hip-flexion drive (stride length) by ``1 + sag_gain * s_SAG``, down to
  ``s_SAG = brake_from``; below that the brake: the scale falls linearly to -1 at s_SAG = -1, so
  the trot marches in place at scale 0 and walks backwards at -1 (the hips' CPG drive
  reversed). A brake command is followed within ``brake_tau`` (by default at once), not the
  slow ``provision_tau``: stopping for an obstacle that appears in front of the robot is a
  short-term adaptation.
* s_DIR turns: left hips scale by ``1 - dir_gain * s_DIR``, right hips by ``1 + dir_gain * s_DIR``
  (positive turns left, counter-clockwise seen from above), and the abduction joints steer: each
  adds ``dir_steer * s_DIR`` times the hip's (unscaled) protraction drive, with the sign of the
  front legs reversed for the hind legs. In a trot a diagonal stance pair cannot rotate the body
  by fore-aft stride differences alone (the two feet would have to slide sideways), so the stance
  feet also sweep sideways along the turning circle: front feet to the right and hind feet to the
  left for a left turn. Without the steering term s_DIR = 0.5 turned the trot by only about
  5 deg/s (measured while designing the default gait).
* s_COR steps sideways: each abduction joint adds ``cor_gain * s_COR`` times the hip's (unscaled)
  protraction drive, so a swinging foot moves to +y (left) for positive s_COR and pushes back in
  stance. Front legs get ``1 + cor_front_bias`` of it and hind legs ``1 - cor_front_bias``: with
  equal shares the hind legs' side push dominated and a side step also turned the body (about
  25 deg/s away from the step at s_COR = 0.5, measured while designing the default gait).
The provision is low-pass filtered (``provision_tau``): the CPG is a medium-term process (§5);
s_SAG uses ``brake_tau`` instead while it or its command is below ``brake_from``.

Soft start (our addition, ``start_ramp``): after :meth:`LocomotionGenerator.reset` the whole CPG
drive fades in linearly over ``start_ramp`` seconds. The CPG starts in full trot, and without the
ramp the first strides from the standing pose kicked the body by up to 15 degrees in roll and
pitch; the open-loop trot then kept whatever heading the kick left (10 seeds x 60 s: lateral drift
up to 6.6 m and heading changes up to 9 degrees without the ramp, below 0.8 m and 5.4 degrees
with a 1 s ramp), and a strong turn command right at the start could tip it over.
The provision never touches the CPG itself (Eq. 5-7) or the motor-neuron equation (Eq. 8): it
only scales and mixes the CPG drive on its way to the pools.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from neurocog_gym.locomotion._kernels import generator_cycle
from neurocog_gym.locomotion.cpg import CPGParams, MatsuokaCPG
from neurocog_gym.locomotion.gait import Gait
from neurocog_gym.locomotion.motor import MotorNeuronPools, MotorParams

# Joint j = 3 * leg + k (k: 0 abduct, 1 hip, 2 knee) is driven by neurons (flexor, extensor):
_JOINT_NEURONS = np.array(
    [[6 * leg + n for n in pair] for leg in range(4) for pair in ((4, 5), (0, 1), (2, 3))]
)
# Sign that turns "flexor active" into the joint acceleration: hip flexor protracts (angle
# decreases), knee flexor folds (increases), abduction flexor moves the foot outwards.
_SIDE = np.array([1.0, -1.0, 1.0, -1.0])  # FL, FR, HL, HR: +y is outwards for left legs
_FRONT = np.array([1.0, 1.0, -1.0, -1.0])  # FL, FR, HL, HR: +1 front, -1 hind
_JOINT_SIGN = np.array([s for leg in range(4) for s in (_SIDE[leg], -1.0, 1.0)])
HIP_JOINTS = np.array([3 * leg + 1 for leg in range(4)])
ABDUCT_JOINTS = np.array([3 * leg for leg in range(4)])


@dataclass(frozen=True)
class ProvisionParams:
    """How the walking provision modulates the CPG pattern (our reading, module docstring)."""

    sag_gain: float = 0.6
    """Fractional stride change per unit s_SAG."""
    brake_from: float = -0.5
    """s_SAG below which the brake acts (stride scale linear to -1 at s_SAG = -1)."""
    brake_tau: float = 0.01
    """Low-pass time constant of s_SAG while braking, s (one control cycle: at once; 0.02 s
    left 28-38 of 100 dev trials touching the block against 14-18,
    ``52b50df:docs/avoid_notes.md``)."""
    dir_gain: float = 0.3
    """Fractional left/right stride difference per unit s_DIR."""
    dir_steer: float = 0.2
    """Abduction steering per unit s_DIR, relative to the hip's protraction drive (front legs
    one way, hind legs the other)."""
    cor_gain: float = 0.6
    """Abduction drive per unit s_COR, relative to the hip's protraction drive."""
    cor_front_bias: float = 0.3
    """Front legs take 1 + this, hind legs 1 - this of the side step (no turn while stepping)."""
    provision_tau: float = 0.5
    """Low-pass time constant of the provision, s."""
    start_ramp: float = 1.0
    """Seconds over which the CPG drive fades in after a reset (soft start); 0 disables it."""


def gait_motor_params(gait: Gait, base: MotorParams | None = None) -> MotorParams:
    """The pools' constants with the gait's theta_dd_MAX, theta_dot_MAX and restoring term."""
    return replace(
        base or MotorParams(),
        acc_max=(gait.acc_max,) * 12,
        vel_max=(gait.vel_max,) * 12,
        k_rest=gait.k_rest,
        d_rest=gait.d_rest,
    )


class LocomotionGenerator:
    """CPG + motor-neuron pools for one robot (Fig. 6), with touch feedback.

    Args:
        gait: the gait (chromosome, synapses, posture).
        q_lo, q_hi: (12,) joint ranges, rad.
        dt: control cycle, s.
        cpg_params, motor_params, provision_params: component constants.
        knee_behind: (4,) bool, legs whose knee folds behind the foot (``RobotIndex``); the
            gait's posture and the interrupt are then in leg coordinates
            (``motor.leg_coordinates``). Default: none.
    """

    def __init__(
        self,
        gait: Gait,
        q_lo: np.ndarray,
        q_hi: np.ndarray,
        dt: float = 0.01,
        cpg_params: CPGParams | None = None,
        motor_params: MotorParams | None = None,
        provision_params: ProvisionParams | None = None,
        knee_behind: np.ndarray | None = None,
    ):
        self.gait = gait
        self.dt = dt
        cpg_params = replace(cpg_params or CPGParams(), tau_f=gait.tau_f)
        self.cpg = MatsuokaCPG(gait.genes_array, cpg_params, dt)
        self.posture = np.asarray(gait.posture, dtype=np.float64)
        self.g_flex = np.asarray(gait.flexor_gain, dtype=np.float64) * _JOINT_SIGN
        self.g_ext = np.asarray(gait.extensor_gain, dtype=np.float64) * _JOINT_SIGN
        motor_params = gait_motor_params(gait, motor_params)
        self.pools = MotorNeuronPools(
            self.posture, q_lo, q_hi, motor_params, dt, knee_behind=knee_behind
        )
        self.prov = provision_params or ProvisionParams()
        self.provision = np.zeros(3)
        self.drive = np.zeros(12)
        self.hip_drive = np.zeros(4)
        self.elapsed = 0.0
        self._cycle_key = None
        self._no_gyro = np.zeros(3)

    def reset(self, rng: np.random.Generator | None = None, noise: float = 0.05) -> None:
        """Reset to the standing posture with the CPG started in a trot phase.

        The inner states start from a fixed pattern (diagonal pairs FL+HR flexing, FR+HL
        extending) plus uniform noise of size ``noise`` drawn from ``rng``.
        """
        x0 = np.zeros(24)
        x0[[0, 18]] = 0.5  # FL and HR hip flexors
        x0[[7, 13]] = 0.5  # FR and HL hip extensors
        if rng is not None and noise > 0:
            x0 += rng.uniform(-noise, noise, size=24)
        self.cpg.reset(x0)
        self.provision[:] = 0.0
        self.drive[:] = 0.0
        self.elapsed = 0.0
        self.pools.reset(self.posture)

    def step(self, provision, interrupt, theta, theta_dot, touch, gyro=None) -> np.ndarray:
        """One control cycle (one compiled call, ``_kernels.generator_cycle``).

        Args:
            provision: (3,) walking provision (s_SAG, s_COR, s_DIR) in [-1, 1].
            interrupt: (12,) interrupt Theta in [-1, 1].
            theta: (12,) measured joint angles, rad.
            theta_dot: (12,) measured joint rates, rad/s.
            touch: (4,) normalised touch inputs (1 ~ a quarter of the body weight).
            gyro: (3,) torso angular velocity in the torso's frame, rad/s, for the roll reflex
                (``Gait.vestibular_gain``); required when the gait's gain is non-zero.

        Returns:
            (12,) servo position targets, rad (``pools.target``).
        """
        p = self.prov
        self.elapsed += self.dt
        ramp = self.elapsed / p.start_ramp if self.elapsed < p.start_ramp else 1.0
        cpg, pools = self.cpg, self.pools
        key = self._cycle_key
        if (
            key is None or key[0] is not p or key[1] is not cpg or key[2] is not pools
            or key[3] is not cpg.params or key[4] is not pools.params
        ):  # fmt: skip
            self._cycle_key = (p, cpg, pools, cpg.params, pools.params)
            self._cycle_args = self._constant_args()
        first, second, third = self._cycle_args
        gain = self.gait.vestibular_gain
        if gyro is None:
            if gain != 0.0:
                raise ValueError(
                    f"gait {self.gait.name!r} has a roll reflex (vestibular_gain {gain}): "
                    "step() needs the torso's angular velocity, gyro"
                )
            gyro = self._no_gyro
        generator_cycle(
            np.asarray(provision, dtype=np.float64), self.provision, *first,
            np.asarray(touch, dtype=np.float64), *second, ramp, pools.q_ref, pools.qd_ref,
            np.asarray(interrupt, dtype=np.float64), theta, theta_dot, *third,
            np.asarray(gyro, dtype=np.float64), gain,
        )  # fmt: skip
        return pools.target

    def _constant_args(self) -> tuple[tuple, tuple, tuple]:
        """``generator_cycle``'s arguments that stay between cycles (parameters, buffers).

        Rebuilt when a parameter set, the CPG or the pools are replaced; their buffers are only
        ever written in place.
        """
        p, cpg, pools = self.prov, self.cpg, self.pools
        cp, mp = cpg.params, pools.params
        first = (
            self.dt / max(p.provision_tau, self.dt), self.dt / max(p.brake_tau, self.dt),
            p.brake_from, cpg.x, cpg.v, cpg.W, cpg.V,
        )  # fmt: skip
        second = (
            cp.u0, cp.b, cp.tau, cp.T, cp.tau_f, cpg.dt / cp.time_unit / cp.substeps,
            cp.substeps, cpg.y, _JOINT_NEURONS, self.g_flex, self.g_ext, p.sag_gain,
            p.dir_gain, p.dir_steer, p.cor_gain, p.cor_front_bias, _SIDE, _FRONT, HIP_JOINTS,
            ABDUCT_JOINTS, self.drive, self.hip_drive,
        )  # fmt: skip
        third = (
            pools.posture, mp.mu1, mp.mu2, pools.acc_max, pools.vel_max, pools.fl_width,
            mp.fl_c, mp.fv_K, mp.fv_N, pools.Z, mp.k_rest, mp.d_rest, pools.q_lo, pools.q_hi,
            pools.dt, pools.acc, pools.coupling, pools.joint_lo, pools.joint_hi, pools.target,
        )  # fmt: skip
        return first, second, third

    @property
    def swinging(self) -> np.ndarray:
        """(4,) bool, legs whose hip flexor (protractor) currently dominates: the swing phase."""
        return self.hip_drive > 0.0
