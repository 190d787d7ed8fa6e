"""OraclePolicy: a scripted step-over that reads the true block boxes (privileged).

It shows what body v1 and its motor-neuron pools can do when perception and learning are taken
out: the upper-bound row of the benchmark, not the paper's controller. It needs the obstacle
env's privileged observation keys (``gymnasium.make(id, privileged=True)``): ``true_blocks``
(the simulator's block boxes) and ``feet`` (the soles' positions). Nothing else of the env is
read; the decision is the policy's.

Per leg, a three-state script on the interrupt group:

1. **idle** until the leg swings (its touch input below ``touch_off``, the other leg of its pair
   FL-FR / HL-HR standing) and a block lies in its lane ahead (the foot's lateral position, in
   the block's frame, within the block's half-width plus ``lane_margin``; the near face less
   than ``trigger`` ahead of the sole);
2. **up**: the foot is driven to a waypoint ``approach`` before the near face and
   ``clearance`` above the block's top;
3. **over**: then to a waypoint ``beyond`` past the far face at the same height; once the
   sole is past the far face the interrupt is released and the CPG puts the foot down.

Each waypoint is turned into hip and knee angles by the leg's two-link inverse kinematics
(thigh and shank lengths read from the model file) in the torso's frame, and the interrupt is
a PD law on the measured joint angles, Theta = clip(kp (q* - q) - kd q_dot, -1, 1): with mu_2 = 10
it overrides the CPG's clipped drive tenfold. Abduction stays 0. A leg is released after
``max_hold`` seconds whatever its state; while any leg steps over, the stride is shortened
(``s_SAG = slow_sag``, our choice). A leg starts only while its pair partner stands: lifting both
front legs at once dropped the torso onto the block.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

ACTION_DIM = 15
IDLE, LIFT, CARRY, SHORT = 0, 1, 2, 3


@dataclass(frozen=True)
class OracleParams:
    """Thresholds and gains of the scripted step-over (metres, seconds, radians)."""

    foot_radius: float = 0.018
    """Sole sphere radius, m (assets/quadruped.xml)."""
    touch_off: float = 0.05
    """Touch input below which a foot is in the air."""
    lane_margin: float = 0.03
    """Lateral margin beyond the block's half-width (plus the foot radius) of a leg's lane, m."""
    trigger: float = 0.03
    """A swinging foot reacts to a near face less than this beyond its predicted foothold, m."""
    approach: float = 0.03
    """The "up" waypoint's distance before the near face (sole to face), m."""
    clearance: float = 0.035
    """Sole height above the block's top at both waypoints, m."""
    beyond: float = 0.04
    """The "over" waypoint's distance past the far face (sole to face), m; the leg is released
    once the sole is half of it past the face."""
    kp: float = 8.0
    """Interrupt per radian of joint error."""
    kd: float = 0.05
    """Interrupt per rad/s of joint rate."""
    max_over: float = 0.17
    """Farthest far face (from the sole, along the block) a swing is carried over, m: the lift and
    carry keep the sole above 9 cm from 3 cm behind to 20 cm ahead of where it started."""
    max_hold: float = 0.35
    """Longest a leg is held, s."""
    carry_knee: float = 0.5
    """Knee entry while carrying the foot over (measured on body v1: with 0.5 the sole stays
    above 9 cm over 23 cm of forward travel; 0 or -0.5 drop it within 3-10 cm; 1 stalls it)."""
    slow_sag: float = 0.0
    """s_SAG while a leg lifts (-0.5: the trot marches in place, ``generator.py``)."""
    lift_hip: float = 0.3
    """Hip entry of the lift (``neurocog_gym.bench.body.LIFT_HIP``)."""
    dt: float = 0.01
    """Control cycle, s."""


class OraclePolicy:
    """Privileged scripted step-over (module docstring); callable ``policy(obs) -> action``.

    Keeps per-episode state: call :meth:`reset` at every ``env.reset`` (the benchmark's
    ``start_episode`` does).
    """

    name = "oracle"
    needs_privileged = True

    def __init__(self, params: OracleParams | None = None):
        from neurocog_gym.robot.model import RobotIndex, load_model

        self.p = params or OracleParams()
        m = load_model()
        r = RobotIndex.build(m)
        # Body constants from the model file: thigh origin in the torso frame, segment lengths.
        self.hip_offset = np.array(
            [m.body_pos[r.hip_body[k]] + m.body_pos[r.thigh_body[k]] for k in range(4)]
        )
        self.l1 = float(np.linalg.norm(m.body_pos[r.shank_body[0]]))
        self.l2 = float(np.linalg.norm(m.geom_pos[r.foot_geom[0]]))
        self.reset()

    def reset(self, env=None) -> None:
        """Forget the legs' states (a new episode). ``env`` is ignored."""
        self.state = np.zeros(4, dtype=np.int64)
        self.held = np.zeros(4)
        self.block = np.full(4, -1, dtype=np.int64)
        self.hold = np.zeros(4)

    def __call__(self, obs) -> np.ndarray:
        """The action for one observation of an obstacle env made with ``privileged=True``."""
        if "true_blocks" not in obs:
            raise KeyError(
                "OraclePolicy needs the privileged observation: make the env with "
                "privileged=True (it reads the true block boxes)"
            )
        p = self.p
        blocks = np.asarray(obs["true_blocks"], dtype=np.float64).reshape(-1, 7)
        feet = np.asarray(obs["feet"], dtype=np.float64).reshape(4, 3)
        touch = np.asarray(obs["touch"], dtype=np.float64)
        q = np.asarray(obs["joint_pos"], dtype=np.float64)
        qd = np.asarray(obs["joint_vel"], dtype=np.float64)
        rot = _yaw_frame_rotation(np.asarray(obs["torso_quat"], dtype=np.float64))
        height = float(np.asarray(obs["torso_height"])[0])
        action = np.zeros(ACTION_DIM, dtype=np.float32)
        for leg in range(4):
            sole = feet[leg, 2] - p.foot_radius
            st = self.state[leg]
            if st != IDLE:
                self.held[leg] += p.dt
                b = blocks[self.block[leg]]
                lx, _ = _in_block(feet[leg, :2], b)
                if self.held[leg] > p.max_hold or b[0] == 0.0:
                    st = IDLE
                elif st == LIFT and sole > b[6] + 0.5 * p.clearance:
                    st = CARRY
                if st == CARRY and lx - p.foot_radius > b[4] + 0.5 * p.beyond:
                    st = IDLE
                if st == SHORT and touch[leg] >= p.touch_off:
                    st = IDLE
                if st == IDLE:
                    self.held[leg] = 0.0
                    self.block[leg] = -1
            partner = leg ^ 1  # FL <-> FR, HL <-> HR
            partner_down = touch[partner] >= p.touch_off and self.state[partner] == IDLE
            if st == IDLE and touch[leg] < p.touch_off and partner_down:
                foothold = np.asarray(obs["foothold"], dtype=np.float64).reshape(4, 3)[leg, :2]
                k, far = self._block_ahead(feet[leg, :2], foothold, blocks)
                if k >= 0:
                    # Over it if this swing can reach past its far face, else land short of it
                    # and step over on the next swing.
                    st = LIFT if far <= p.max_over else SHORT
                    self.block[leg], self.held[leg] = k, 0.0
                    self.hold[leg] = q[3 * leg + 1]
            self.state[leg] = st
            if st == IDLE:
                continue
            b = blocks[self.block[leg]]
            c, s = np.cos(b[3]), np.sin(b[3])
            if st == LIFT:
                along = -b[4] - p.foot_radius - p.approach
            else:
                along = b[4] + p.foot_radius + p.beyond
            # The waypoint in the yaw frame relative to the torso (x, y) and above the floor (z).
            lx, ly = _in_block(feet[leg, :2], b)
            wx = b[1] + c * along - s * ly
            wy = b[2] + s * along + c * ly
            wz = b[6] + p.clearance + p.foot_radius
            target = np.array([wx, wy, wz - height])
            body = rot.T @ target - self.hip_offset[leg]  # torso frame, from the hip joint
            hip, knee = self._ik(body[0], body[2])
            j = 3 * leg
            action[j + 1] = np.clip(p.kp * (hip - q[j + 1]) - p.kd * qd[j + 1], -1.0, 1.0)
            action[j + 2] = np.clip(p.kp * (knee - q[j + 2]) - p.kd * qd[j + 2], -1.0, 1.0)
            # Below the waypoint's height the knee folds at full authority, and over the block
            # the hip protracts at full authority: the whole step-over must fit in about one
            # swing (the next diagonal pair lifts half a CPG period after this one).
            if st == SHORT:
                # Land short: hold the hip where it was (no further protraction), knee free.
                action[j + 1] = np.clip(
                    p.kp * (self.hold[leg] - q[j + 1]) - p.kd * qd[j + 1], -1.0, 1.0
                )
                continue
            if st == LIFT:
                # Rise where the foot is: the lift interrupt (hip slightly back, knee folding).
                action[j + 1] = p.lift_hip
                action[j + 2] = 1.0
            else:
                # Carry: the hip protracts at full authority while the knee holds part of its
                # fold (``carry_knee``), folding fully whenever the sole sinks towards the top.
                action[j + 1] = -1.0
                action[j + 2] = 1.0 if sole < b[6] + 0.5 * p.clearance else p.carry_knee
        if (self.state == LIFT).any():
            action[12] = p.slow_sag
        return action

    def _ik(self, x: float, z: float) -> tuple[float, float]:
        """Hip and knee angles that put the foot centre at (x, z) from the hip joint (sagittal).

        Knee folded backwards (positive), as the robot's legs bend; out-of-reach points are
        pulled onto the reachable annulus.
        """
        l1, l2 = self.l1, self.l2
        d = float(np.clip(np.hypot(x, z), abs(l1 - l2) + 0.02, l1 + l2 - 0.005))
        knee = np.pi - np.arccos(np.clip((l1 * l1 + l2 * l2 - d * d) / (2 * l1 * l2), -1, 1))
        phi = np.arctan2(x, -z)
        alpha = np.arccos(np.clip((l1 * l1 + d * d - l2 * l2) / (2 * l1 * d), -1, 1))
        return float(-(phi + alpha)), float(knee)

    def _block_ahead(
        self, foot_xy: np.ndarray, foothold: np.ndarray, blocks: np.ndarray
    ) -> tuple[int, float]:
        """Index of the nearest block in this foot's lane that this swing would meet.

        It meets a block whose near face lies before the predicted foothold (``foothold``,
        the env's effectivity prediction) plus ``trigger``, and whose far face is ahead of
        the sole. Returns the index (-1: none) and the sole's distance to that far face, m.
        """
        p = self.p
        best, best_gap, best_far = -1, np.inf, np.inf
        for k, b in enumerate(blocks):
            if b[0] == 0.0:
                continue
            lx, ly = _in_block(foot_xy, b)
            if abs(ly) > b[5] + p.foot_radius + p.lane_margin:
                continue
            gap = -b[4] - lx - p.foot_radius  # sole to near face, along the block's length axis
            far = b[4] - lx + p.foot_radius
            reach = _in_block(foothold, b)[0] - lx  # how far this swing goes, along the block
            if far > 0.0 and gap < reach + p.trigger and gap < best_gap:
                best, best_gap, best_far = k, gap, far
        return best, best_far


def _yaw_frame_rotation(quat: np.ndarray) -> np.ndarray:
    """(3, 3) the torso's orientation seen from its yaw frame (roll and pitch only)."""
    w, x, y, z = quat
    full = np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])  # fmt: skip
    yaw = np.arctan2(full[1, 0], full[0, 0])
    c, s = np.cos(yaw), np.sin(yaw)
    to_yaw = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    return to_yaw @ full


def _in_block(foot_xy: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """The foot's (x, y) in block ``b``'s frame (x along its length axis, the robot's way)."""
    c, s = np.cos(b[3]), np.sin(b[3])
    dx, dy = foot_xy[0] - b[1], foot_xy[1] - b[2]
    return c * dx + s * dy, -s * dx + c * dy
