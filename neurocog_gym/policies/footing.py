"""FootingOracle: a scripted footing-position interrupt that reads the true stones (privileged).

The paper's second use of the interrupt (§6.4, Supplementary Video S2: "the robot will step the
green area"): the trot the CPG generates goes on, and each swing is lengthened or shortened by
a few centimetres so that the foot lands on a stone. It is the upper-bound row of
``NeuroCog/SteppingStones-v3`` (issue 26), not the paper's controller, and it needs that env's
privileged observation (``gymnasium.make(id, privileged=True)``): ``true_stones`` (the
simulator's stone boxes) besides the ordinary ``feet``, ``cpg``, ``servo_target``,
``torso_quat`` and ``touch``. Nothing else of the env is read.

Per control cycle:

* **Phase.** A leg's swing begins when its CPG hip flexor output rises above its extensor's
  (``cpg``); ``tau`` counts the cycles since. The trot is regular (period 52 cycles, landing
  ``NOMINAL_LANDING`` ahead of the torso as seen at the onset, within 4 mm; measured on the blind
  trot, flat course, seeds 0-4).
* **Plan** (at the onset): the nominal landing (``NOMINAL_LANDING[leg]`` ahead, the foot's
  current lateral place) is checked against the stones of the foot's lane (moving stones
  extrapolated to the landing). On a stone with ``margin`` from its edges: nothing to do.
  Otherwise the nearest safe point within ``[-max_shorten, +max_lengthen]`` of the nominal is
  the target; none: the swing is left alone and the walking provision brakes (below).
* **Footing-position interrupt.** A target shift ``d`` is a hip pool offset ``e`` (``d`` per
  ``lengthen_gain`` / ``shorten_gain`` m/rad) ramped in from the foot's lift-off, tracked by a
  PD law on the hip pool's reference (read from ``servo_target``) against the pool's nominal
  swing trajectory (``NOMINAL_HIP``): the interrupt is an acceleration (Eq. 8), so it is used as
  feedback, not as a pulse. The offset is dropped at touch-down (held through the stance, it
  turned the trot). A positive hip interrupt moves the foot backwards (shortens).
* **Walking provision.** At a front leg's CPG onset the brake (s_SAG, ``brake_levels``, held
  for the swing) is chosen with the shift: the lowest level at which both this leg and its
  diagonal partner can be put on a stone, counting the measured shortening each level gives
  the pair (``brake_front``, ``brake_hind``) and the swings after it (``after_brake_*``); none:
  the lowest at which this leg can. s_DIR and s_COR hold the heading along the course and the
  torso over the middle of the two rows (the open-loop trot turns by 5-9 degrees over a
  course).

Measured on ``neurocog bench --scenario stones``: 0 crossings of 200 (docs/stepping_stones.md):
the shift and brake figures are single calibrations on a flat course, the landings scatter by
2-5 cm in the trials (the first gap comes within a stride of the soft start's end, and every
brake leaves the next strides shorter), against a 3.5 cm margin.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from neurocog_gym.policies.base import ACTION_DIM

REQUIRED_KEYS = ("true_stones", "feet", "cpg", "servo_target", "torso_quat", "touch")
"""Observation keys the oracle reads (``true_stones`` only with ``privileged=True``)."""
N_FIELDS = 7
"""Columns of a ``true_stones`` row: valid, x, y, half length, half width, top, speed y."""
NOMINAL_LANDING = np.array([0.372, 0.358, -0.038, -0.053])
"""m, where each foot (FL, FR, HL, HR) lands ahead of the torso, along the heading, as seen at
its CPG swing onset (blind trot, flat course, seeds 0-4: sd 3-4 mm)."""
SWING_TIME = np.array([0.23, 0.23, 0.21, 0.21])
"""s, from the CPG hip onset to the touch-down (same trot: 23 and 21 cycles, sd 0.5); moving
stones are extrapolated by it."""
LIFT_DELAY = np.array([6, 6, 0, 0])
"""Cycles from the CPG hip onset to the foot's lift-off (front feet lift later, measured)."""
NOMINAL_HIP = np.array(
    [
        [-0.740, -0.758, -0.780, -0.804, -0.830, -0.854, -0.878, -0.900, -0.922, -0.942, -0.962,
         -0.980, -0.998, -1.014, -1.030, -1.044, -1.057, -1.069, -1.080, -1.091, -1.100, -1.109,
         -1.115, -1.117, -1.117, -1.114, -1.107, -1.097, -1.080, -1.057, -1.030, -1.002, -0.974,
         -0.946, -0.920, -0.896, -0.873, -0.852, -0.832, -0.813, -0.796, -0.780],
        [-0.556, -0.571, -0.589, -0.609, -0.630, -0.652, -0.675, -0.697, -0.718, -0.739, -0.758,
         -0.776, -0.793, -0.809, -0.825, -0.839, -0.853, -0.865, -0.876, -0.884, -0.890, -0.894,
         -0.896, -0.896, -0.893, -0.889, -0.882, -0.871, -0.857, -0.838, -0.816, -0.791, -0.765,
         -0.738, -0.709, -0.681, -0.654, -0.629, -0.607, -0.586, -0.568, -0.552],
    ]
)  # fmt: skip
"""rad, the hip pool's reference (``servo_target``) of a front (row 0) and a hind (row 1) leg,
cycles 0-41 after its CPG hip onset: the median of 116 swings of the blind trot (flat course,
seeds 0-3, after the 1 s soft start; sd <= 0.008 rad)."""


@dataclass(frozen=True)
class FootingParams:
    """Thresholds and gains of the scripted footing (metres, radians, control cycles)."""

    margin: float = 0.035
    """m, a landing sole's centre stays this far inside a stone's edges along the course (sole
    radius 1.8 cm plus 1.7 cm for the prediction's scatter)."""
    side_margin: float = 0.022
    """m, ... and this far inside its side edges (sole radius plus 4 mm)."""
    max_lengthen: tuple[float, float] = (0.05, 0.04)
    """m, longest lengthening of a front and of a hind swing (front: hip offset -0.30 rad,
    +4.7-5.3 cm over 10 FL and FR swings; hind: -0.15 rad, +4.1-4.4 cm, -0.3 rad fell)."""
    max_shorten: tuple[float, float] = (0.025, 0.035)
    """m, longest shortening of a front and a hind swing (front +0.12 rad: FL -2.0 to -2.4 cm
    but FR -2.7 to -16.5 cm, +0.2 rad landed 4-17 cm short and turned the trot by up to 16
    degrees; hind +0.12 rad: -3.3 to -3.7 cm)."""
    lengthen_gain: tuple[float, float] = (0.17, 0.29)
    """m of landing shift per rad of hip offset when lengthening, front and hind legs."""
    shorten_gain: tuple[float, float] = (0.2, 0.29)
    """m per rad when shortening, front and hind legs."""
    ramp: int = 8
    """Cycles over which the offset is ramped in from the lift-off (smoothstep)."""
    pool_gain: float = 600.0
    """rad/s^2 of hip pool acceleration per unit interrupt assumed by the PD law (mu_2
    theta_dd_MAX ~1,100 times F_l F_v)."""
    bandwidth: float = 30.0
    """rad/s, the PD law's closed-loop natural frequency."""
    damping: float = 0.9
    """The PD law's damping ratio."""
    k_rest: float | None = None
    """1/s^2, the pools' restoring stiffness, cancelled while tracking; None: the shipped gait's
    (``assets/default_gait.json``, 275 1/s^2; the oracle knows the plant's design, as it knows
    ``NOMINAL_HIP``)."""
    d_rest: float | None = None
    """1/s, the pools' restoring damping; None: the shipped gait's (25 1/s)."""
    brake_levels: tuple[float, ...] = (0.0, -0.55, -0.62, -0.7)
    """s_SAG levels of the brake (0: none; -0.55, -0.62, -0.7: stride scale 0.53, 0.29, 0.02),
    held from a front leg's CPG onset for its swing."""
    brake_front: tuple[float, ...] = (0.0, -0.056, -0.108, -0.162)
    """m, how much shorter the braking front leg's swing lands at each level (FL, one swing
    each, flat course: -5.6, -10.8, -16.2 cm)."""
    brake_hind: tuple[float, ...] = (0.0, -0.018, -0.040, -0.079)
    """m, ... its diagonal partner's (HR in the same swings)."""
    after_brake_front: tuple[float, ...] = (0.0, -0.025, -0.024, -0.050)
    """m, how much shorter the next front swing lands after a brake of each level (FR)."""
    after_brake_hind: tuple[float, ...] = (0.0, -0.017, -0.044, -0.073)
    """m, ... the next hind swing (HL)."""
    after_brake_window: int = 12
    """Cycles after a brake's end within which a swing's onset gets the after-brake terms."""
    yaw_gain: float = 3.0
    """s_DIR per rad of heading error."""
    side_gain: float = 4.0
    """s_COR per m of the torso's lateral error."""
    side_target: float = 0.015
    """m, the torso's lateral place that centres the feet on the rows (the feet stand 1.5 cm
    to the right of the torso's centre)."""
    touch_off: float = 0.05
    """Touch input below which a foot is in the air."""
    lift_height: float = 0.03
    """m, a foot site above this has left the ground (standing: 0.018)."""
    dt: float = 0.01
    """s, control cycle."""


class FootingOracle:
    """Privileged scripted footing on the stepping stones (module docstring).

    Callable ``policy(obs) -> action``; keeps per-episode state: call :meth:`reset` at every
    ``env.reset`` (the benchmark's ``start_episode`` does).

    Args:
        params: thresholds and gains; None: the defaults.
    """

    name = "oracle"
    needs_privileged = True

    def __init__(self, params: FootingParams | None = None):
        p = params or FootingParams()
        if p.k_rest is None or p.d_rest is None:
            from dataclasses import replace

            from neurocog_gym import paths
            from neurocog_gym.locomotion.gait import Gait

            gait = Gait.load(paths.asset(paths.DEFAULT_GAIT))
            p = replace(p, k_rest=p.k_rest if p.k_rest is not None else gait.k_rest,
                        d_rest=p.d_rest if p.d_rest is not None else gait.d_rest)  # fmt: skip
        self.p = p
        self.reset()

    def reset(self, env=None) -> None:
        """Forget the legs' phases and offsets (a new episode). ``env`` is ignored."""
        self.tau = np.full(4, -1, dtype=np.int64)
        self.prev_swing = np.ones(4, dtype=bool)
        self.q_prev: np.ndarray | None = None
        self.offset = np.zeros(4)
        """rad, each leg's target hip offset for this swing (0: none)."""
        self.active = np.zeros(4, dtype=bool)
        self.lifted = np.zeros(4, dtype=bool)
        self.brake_level = 0
        self.brake_end = -(10**6)
        self.t = 0
        self.plans: list[tuple[int, int, float, float]] = []
        """(cycle, leg, nominal landing x, planned shift) of every plan, for diagnosis."""

    # -- the plan -------------------------------------------------------------------------------

    def safe_intervals(self, stones: np.ndarray, foot_y: float, t_left: float) -> np.ndarray:
        """(K, 2) x-intervals (heading frame, from the torso) where the foot may land.

        Args:
            stones: (N, 7) ``true_stones`` rows.
            foot_y: m, the foot's lateral place at the landing, heading frame.
            t_left: s to the landing (moving stones are extrapolated by it).
        """
        p = self.p
        valid = stones[:, 0] > 0.5
        s = stones[valid]
        y = s[:, 2] + s[:, 6] * t_left
        in_lane = np.abs(foot_y - y) <= s[:, 4] - p.side_margin
        s = s[in_lane]
        lo = s[:, 1] - s[:, 3] + p.margin
        hi = s[:, 1] + s[:, 3] - p.margin
        keep = hi >= lo
        return np.stack([lo[keep], hi[keep]], axis=1)

    def plan_shift(self, x_nominal: float, intervals: np.ndarray, leg: int = 0) -> float | None:
        """The landing shift (m) that puts ``x_nominal`` on the nearest safe interval.

        0 when it already lies on one; None when no interval is within
        ``[-max_shorten, +max_lengthen]`` of it.
        """
        p = self.p
        row = 0 if leg < 2 else 1
        best = None
        for lo, hi in intervals:
            if lo <= x_nominal <= hi:
                return 0.0
            d = lo - x_nominal if x_nominal < lo else hi - x_nominal
            reachable = -p.max_shorten[row] <= d <= p.max_lengthen[row]
            if reachable and (best is None or abs(d) < abs(best)):
                best = d
        return best

    def offset_for(self, shift: float, leg: int = 0) -> float:
        """rad, the hip pool offset that moves ``leg``'s landing by ``shift`` m (+: further)."""
        p = self.p
        row = 0 if leg < 2 else 1
        gain = p.lengthen_gain[row] if shift > 0 else p.shorten_gain[row]
        return -shift / gain

    # -- the controller ------------------------------------------------------------------------

    def __call__(self, obs) -> np.ndarray:
        """The action for one observation of ``NeuroCog/SteppingStones-v3`` (privileged)."""
        for key in REQUIRED_KEYS:
            if key not in obs:
                raise KeyError(
                    f"FootingOracle needs the observation key {key!r}: make "
                    "NeuroCog/SteppingStones-v3 with privileged=True (it reads the true stones)"
                )
        p = self.p
        stones = np.asarray(obs["true_stones"], dtype=np.float64).reshape(-1, N_FIELDS)
        feet = np.asarray(obs["feet"], dtype=np.float64).reshape(4, 3)
        touch = np.asarray(obs["touch"], dtype=np.float64)
        y = np.asarray(obs["cpg"], dtype=np.float64).reshape(4, 6)
        q = np.asarray(obs["servo_target"], dtype=np.float64).reshape(4, 3)[:, 1]
        if self.q_prev is None:
            self.q_prev = q.copy()
        qd = (q - self.q_prev) / p.dt
        self.q_prev = q.copy()

        swing = y[:, 0] > y[:, 1]
        onset = swing & ~self.prev_swing
        self.prev_swing = swing
        self.tau = np.where(onset, 0, np.where(self.tau >= 0, self.tau + 1, -1))

        action = np.zeros(ACTION_DIM, dtype=np.float32)
        if stones[:, 0].max(initial=0.0) < 0.5:
            return action
        for leg in range(4):
            if onset[leg]:
                self._plan(leg, stones, feet)
            if self.active[leg]:
                if feet[leg, 2] > p.lift_height:
                    self.lifted[leg] = True
                if self.lifted[leg] and touch[leg] >= p.touch_off:
                    self.active[leg] = False  # dropped at touch-down (module docstring)
            if self.active[leg]:
                action[3 * leg + 1] = self._track(leg, q[leg], qd[leg])
        level = self._braking_level()
        if level > 0:
            action[12] = p.brake_levels[level]
        action[13], action[14] = self._steer(obs, stones)
        self.t += 1
        return action

    def _nominal(self, leg: int) -> float:
        """m, the leg's nominal landing ahead of the torso, planned at its CPG onset now."""
        p = self.p
        x_n = float(NOMINAL_LANDING[leg])
        if 0 <= self.t - self.brake_end <= p.after_brake_window:
            # The swing after a brake lands shorter than the steady trot's (measured).
            x_n += (p.after_brake_front if leg < 2 else p.after_brake_hind)[self.brake_level]
        return x_n

    def _plan(self, leg: int, stones: np.ndarray, feet: np.ndarray) -> None:
        """Plan ``leg``'s swing at its CPG onset: the shift, and for a front leg the brake."""
        p = self.p
        self.active[leg] = False
        self.lifted[leg] = False
        t_left = float(SWING_TIME[leg])
        x_n = self._nominal(leg)
        intervals = self.safe_intervals(stones, float(feet[leg, 1]), t_left)
        if leg >= 2:
            shift = self.plan_shift(x_n + p.brake_hind[self._braking_level()], intervals, leg)
        else:
            # The brake acts on the diagonal pair: the lowest level at which both this leg and
            # its partner land on a stone, else the lowest at which this one does.
            partner = 3 - leg
            x_p = self._nominal(partner)
            iv_p = self.safe_intervals(stones, float(feet[partner, 1]), float(SWING_TIME[partner]))
            shifts = [self.plan_shift(x_n + e, intervals, leg) for e in p.brake_front]
            both = [
                k
                for k, e in enumerate(p.brake_hind)
                if shifts[k] is not None and self.plan_shift(x_p + e, iv_p, partner) is not None
            ]
            alone = [k for k, sh in enumerate(shifts) if sh is not None]
            level = both[0] if both else (alone[0] if alone else 0)
            shift = shifts[level]
            if level > 0:
                self.brake_level = level
                self.brake_end = self.t + int(round(t_left / p.dt))
                if 0 <= self.tau[partner] <= 2:
                    self._plan(partner, stones, feet)
        self.plans.append((self.t, leg, x_n, np.nan if shift is None else shift))
        if shift is not None and shift != 0.0:
            self.offset[leg] = self.offset_for(shift, leg)
            self.active[leg] = True

    def _braking_level(self) -> int:
        """Index in ``brake_levels`` of the brake on now (0: none)."""
        return self.brake_level if self.t < self.brake_end else 0

    def _track(self, leg: int, q: float, qd: float) -> float:
        """Hip interrupt of the PD law holding the pool on its nominal swing plus the offset."""
        p = self.p
        t = int(self.tau[leg])
        table = NOMINAL_HIP[0 if leg < 2 else 1]
        if t < 1 or t + 1 >= len(table):
            return 0.0
        e = q - table[t]
        ed = qd - (table[t] - table[t - 1]) / p.dt
        u = (t + 1 - LIFT_DELAY[leg]) / p.ramp
        u = min(max(u, 0.0), 1.0)
        e_cmd = self.offset[leg] * u * u * (3.0 - 2.0 * u)
        kp = p.bandwidth**2
        kd = 2.0 * p.damping * p.bandwidth
        acc = kp * (e_cmd - e) - kd * ed + p.k_rest * e + p.d_rest * ed
        return float(np.clip(acc / p.pool_gain, -1.0, 1.0))

    def _steer(self, obs, stones: np.ndarray) -> tuple[float, float]:
        """(s_COR, s_DIR): keep the heading along world x and the torso between the rows."""
        p = self.p
        w, x, yq, z = (float(v) for v in obs["torso_quat"])
        yaw = math.atan2(2.0 * (w * z + x * yq), 1.0 - 2.0 * (yq * yq + z * z))
        # Both platforms are centred on world y = 0: the torso's world y from the end platform.
        xr, yr = stones[1, 1], stones[1, 2]
        torso_y = -(math.sin(yaw) * xr + math.cos(yaw) * yr)
        s_dir = float(np.clip(-p.yaw_gain * yaw, -1.0, 1.0))
        s_cor = float(np.clip(-p.side_gain * (torso_y - p.side_target), -1.0, 1.0))
        return s_cor, s_dir


__all__ = ["NOMINAL_HIP", "NOMINAL_LANDING", "FootingOracle", "FootingParams"]
