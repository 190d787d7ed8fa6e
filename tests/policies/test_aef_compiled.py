"""AEFPolicy's compiled cycle (policies/_aef_kernel.py) against the readable NumPy path.

Issue 22 moved the policy's odometry, frame changes and the fit's decision (``Fit.decide`` with
the stop / side-step / pass teacher) into one numba call. ``Reference`` below is the policy's
``__call__`` as it was before, on the readable pieces (``Odometry``, ``to_frame``,
``boxes_in_frame``, ``Fit``, ``AEFWeights.forward``); the compiled policy must give the same
actions, bit for bit, on every cycle.
"""

import math

import gymnasium as gym
import numpy as np
import pytest

import neurocog_gym  # noqa: F401  (registers the ids)
from neurocog_gym import paths
from neurocog_gym.locomotion.aef import AEFWeights
from neurocog_gym.locomotion.avoidance import PASS, REVERSE, SIDE, WALK, AvoidanceParams
from neurocog_gym.locomotion.fit import (
    MODE_INTERRUPT,
    MODE_NONE,
    MODE_PROVISION,
    Fit,
    FitParams,
)
from neurocog_gym.policies import AEFPolicy, start_episode
from neurocog_gym.policies.aef import Odometry, boxes_in_frame, to_frame
from tests.policies.stance import FEET, HIPS, KNEES, THIGHS  # a standing robot


class Reference:
    """``AEFPolicy.__call__`` before the compiled cycle: NumPy glue round ``Fit.decide``."""

    def __init__(self, interrupt_gain=1.0, fit=None, dt=0.01):
        self.weights = AEFWeights.load(paths.asset(paths.AEF_WEIGHTS))
        self.interrupt_gain, self.dt = interrupt_gain, dt
        self.fit = Fit(fit)
        self.odo, self.cycles = Odometry(), 0

    def __call__(self, obs):
        yaw, origin = self.odo.update(obs["torso_quat"], obs["torso_lin_vel"], self.dt)
        t = self.cycles * self.dt
        self.cycles += 1
        legs = to_frame(np.asarray(obs["leg_joints"]).reshape(12, 3), yaw, origin).reshape(4, 3, 3)
        feet = to_frame(np.asarray(obs["feet"]).reshape(4, 3), yaw, origin)
        boxes = boxes_in_frame(obs["remembered_blocks"], yaw, origin)
        hit = np.rint(np.asarray(obs["block_met"], dtype=np.float64)).astype(np.int64)
        hit[hit >= len(boxes)] = -1
        direction = np.asarray(obs["interrupt_direction"], dtype=np.float64).reshape(4, 3)
        d = self.fit.decide(
            t, yaw, direction, hit, feet, legs[:, 0], legs[:, 1], legs[:, 2], boxes
        )  # fmt: skip
        self.decision = d
        action = np.zeros(15, dtype=np.float32)
        if d.mode == MODE_NONE:
            return action
        x = np.asarray(obs["aef_input"], dtype=np.float64).copy()
        x[3:15] = d.slots.astype(np.float32).ravel()
        interrupt, provision = self.weights.forward(x)
        if d.mode == MODE_INTERRUPT:
            mask = np.repeat(np.abs(d.slots).sum(axis=1) > 0, 3)
            action[:12] = np.clip(self.interrupt_gain * interrupt * mask, -1.0, 1.0)
        elif d.mode == MODE_PROVISION:
            action[12:] = provision
        return action


def walk(seed, policy, reference, n=300):
    """Drive ``policy`` and ``reference`` with one made-up observation stream; yield each cycle.

    A kinematic robot (no physics) walks at 0.3 m/s, its speed and side step following the
    reference's provision (s_SAG -1 walks it back, s_COR sideways), its legs swinging about the
    stance; one to three blocks of random size and height lie ahead and are remembered from a
    random cycle on; now and then a leg gets an interrupt direction and a block met. Made to
    reach every branch of the decision (each mode, each teacher state), not to be physical.

    Yields:
        (the policy's action, the reference's action) of each cycle.
    """
    rng = np.random.default_rng(seed)
    blocks = []
    for _ in range(rng.integers(1, 4)):
        x0, y0 = rng.uniform(0.3, 1.2), rng.uniform(-0.35, 0.2)
        blocks.append((x0, y0, rng.uniform(0.04, 0.15), rng.uniform(0.05, 0.3)))
    tops = rng.uniform(0.01, 0.1, len(blocks))
    seen = rng.integers(0, 60, len(blocks))
    pos, yaw, v = np.zeros(2), rng.uniform(-0.3, 0.3), np.zeros(2)
    for i in range(n):
        yaw += rng.normal(0.0, 0.005)
        c, s = math.cos(yaw), math.sin(yaw)
        rows = np.zeros((8, 7), np.float32)
        for m, ((x0, y0, length, width), top) in enumerate(zip(blocks, tops, strict=True)):
            if i >= seen[m]:
                dx, dy = x0 + length / 2 - pos[0], y0 + width / 2 - pos[1]
                rel = (c * dx + s * dy, -s * dx + c * dy)
                rows[m] = (1.0, *rel, -yaw, length / 2, width / 2, top)
        swing = 0.05 * np.sin(0.3 * i + np.array([0.0, np.pi, np.pi, 0.0]))
        lift = np.array([0.0, 0.06, 0.0, 0.0]) * (rng.random() < 0.5)
        feet = FEET + np.c_[swing, np.zeros(4), lift]
        knees = KNEES + np.c_[swing / 2, np.zeros(4), lift / 2]
        direction = np.zeros((4, 3), np.float32)
        met = np.full(4, -1.0, np.float32)
        if rng.random() < 0.15:
            leg = rng.integers(4)
            direction[leg] = rng.normal(0.0, 0.5, 3)
            met[leg] = rng.integers(-1, len(blocks) + 1)
        aef = rng.normal(0.0, 1.0, 31).astype(np.float32)
        aef[3:15] = direction.ravel()
        obs = {
            "torso_quat": np.array([math.cos(yaw / 2), 0, 0, math.sin(yaw / 2)], np.float32),
            "torso_lin_vel": np.array([v[0], v[1], 0.0], np.float32),
            "aef_input": aef,
            "interrupt_direction": direction.ravel(),
            "block_met": met,
            "remembered_blocks": rows.ravel(),
            "feet": feet.astype(np.float32).ravel(),
            "leg_joints": np.stack([HIPS, THIGHS, knees], 1).astype(np.float32).ravel(),
        }
        yield policy(obs), reference(obs)
        sag, cor = 0.0, 0.0
        if reference.decision.mode == MODE_PROVISION:
            sag, cor = reference.decision.provision[:2]
        v = np.array([0.3 * min(max(1.0 + 2.0 * sag, -1.0), 1.0), 0.15 * cor])
        pos += 0.01 * np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def assert_same_bits(a, b):
    assert a.dtype == b.dtype == np.float32
    np.testing.assert_array_equal(a.view(np.uint32), b.view(np.uint32))  # signed zeros too


@pytest.mark.parametrize(
    ("gain", "fit"),
    [
        (1.0, None),
        (0.0, None),  # the aef-provision ablation
        (1.0, FitParams(avoidance=AvoidanceParams(enabled=False))),
        (0.7, FitParams(lookahead=0.8, corridor=0.2, avoidance=AvoidanceParams(trigger=0.45))),
    ],
)
def test_the_compiled_cycle_gives_the_readable_paths_actions_bit_for_bit(gain, fit):
    modes, states = set(), set()
    for seed in range(12):
        policy = AEFPolicy(interrupt_gain=gain, fit=fit)
        reference = Reference(interrupt_gain=gain, fit=fit)
        for a, b in walk(seed, policy, reference):
            assert_same_bits(a, b)
            d, e = policy.decision, reference.decision
            assert (d.mode, d.target) == (e.mode, e.target) == (policy.mode, e.target)
            np.testing.assert_array_equal(d.provision, e.provision)
            np.testing.assert_array_equal(d.slots, e.slots)
            modes.add(d.mode)
            states.add(reference.fit.avoidance.state)
    assert modes == {MODE_NONE, MODE_INTERRUPT, MODE_PROVISION}  # the stream reached them all
    if fit is None or fit.avoidance.enabled:
        assert states == {WALK, REVERSE, SIDE, PASS}


def test_on_an_episode_of_the_env_too():
    env = gym.make("NeuroCog/SuddenObstacle-v3")
    policy, reference = AEFPolicy(), Reference()
    obs, _ = env.reset(seed=4)
    start_episode(policy, env)
    for _ in range(300):
        a = policy(obs)
        assert_same_bits(a, reference(obs))
        obs, _, term, trunc, _ = env.step(a)
        if term or trunc:
            break
    env.close()


def test_a_reset_forgets_everything_the_compiled_cycle_keeps():
    policy = AEFPolicy()
    first = [a for a, _ in walk(0, policy, Reference())]
    policy.reset()
    assert policy.decision is None and policy.mode == MODE_NONE
    again = [a for a, _ in walk(0, policy, Reference())]
    for a, b in zip(first, again, strict=True):
        assert_same_bits(a, b)


def test_more_remembered_rows_than_the_buffer_and_wrong_sizes():
    policy, reference = AEFPolicy(), Reference()
    obs = next(iter(_one_obs()))
    obs["remembered_blocks"] = np.concatenate([obs["remembered_blocks"], np.zeros(7 * 4)])
    assert_same_bits(policy(obs), reference(obs))  # 12 rows: the policy's buffer grows
    obs["feet"] = obs["feet"][:9]
    with pytest.raises(ValueError, match="unexpected sizes"):
        policy(obs)


def _one_obs():
    class Capture:
        def __call__(self, obs):
            self.obs = obs
            return np.zeros(15, np.float32)

    capture, reference = Capture(), Reference()
    for _ in walk(0, capture, reference, n=1):
        yield {k: v.copy() for k, v in capture.obs.items()}
