"""The walking provision's stride map and its brake (locomotion/generator.py, _kernels.py)."""

import numpy as np
import pytest

from neurocog_gym.locomotion._kernels import drive_kernel, vestibular_step
from neurocog_gym.locomotion.avoidance import sag_for_stride
from neurocog_gym.locomotion.gait import default_gait
from neurocog_gym.locomotion.generator import (
    _FRONT,
    _JOINT_NEURONS,
    _SIDE,
    ABDUCT_JOINTS,
    HIP_JOINTS,
    LocomotionGenerator,
    ProvisionParams,
)


def _hip_drives(s_sag, sag_gain=0.6, brake_from=-0.5):
    """Hip drives for CPG outputs whose flexor-minus-extensor is 1 on every joint."""
    y = np.zeros(24)
    y[_JOINT_NEURONS[:, 0]] = 1.0
    drive = np.zeros(12)
    drive_kernel(
        y, _JOINT_NEURONS, np.ones(12), np.ones(12), np.array([s_sag, 0.0, 0.0]), sag_gain,
        brake_from, 0.3, 0.2, 0.6, 0.3, _SIDE, _FRONT, HIP_JOINTS, ABDUCT_JOINTS, drive,
        np.zeros(4),
    )  # fmt: skip
    return drive[HIP_JOINTS]


@pytest.mark.parametrize("s_sag", [-0.5, -0.3, 0.0, 0.2, 1.0])
def test_stride_above_the_brake_is_the_linear_map(s_sag):
    # 1 + 0.6 s: -0.5 -> 0.7, -0.3 -> 0.82, 0 -> 1, 0.2 -> 1.12, 1 -> 1.6 (same arithmetic).
    assert _hip_drives(s_sag).tolist() == [1.0 + 0.6 * s_sag] * 4


def test_brake_reverses_the_trot_at_minus_one_and_marches_in_place_between():
    # Below -0.5 the scale runs linearly from 0.7 to -1: slope 1.7 / 0.5 = 3.4 per unit s_SAG.
    assert _hip_drives(-1.0) == pytest.approx([-1.0] * 4)
    assert _hip_drives(-0.75) == pytest.approx([0.7 - 3.4 * 0.25] * 4)  # -0.15
    s0 = -0.5 - 0.7 / 3.4  # the s_SAG of stride 0
    assert _hip_drives(s0) == pytest.approx([0.0] * 4, abs=1e-12)


@pytest.mark.parametrize("scale", [-1.0, -0.4, 0.0, 0.5, 0.7, 1.0, 1.3])
def test_sag_for_stride_inverts_the_map(scale):
    assert _hip_drives(sag_for_stride(scale))[0] == pytest.approx(scale)


def test_a_brake_command_is_followed_fast_and_a_slow_down_slowly():
    gait = default_gait()
    gen = LocomotionGenerator(gait, -3 * np.ones(12), 3 * np.ones(12))
    gen.reset(np.random.default_rng(0))
    theta = np.asarray(gait.posture, dtype=np.float64)
    zeros = np.zeros(12)
    p = ProvisionParams()
    # Brake: a = dt / brake_tau = 1, the command is taken at once.
    gen.step(np.array([-1.0, 0.0, 0.0]), zeros, theta, zeros, np.ones(4), np.zeros(3))
    assert gen.provision[0] == -1.0
    # Released: the brake's filter follows until s_SAG is back above brake_from (-1 -> 0.0 at
    # once), then the medium-term one.
    gen.step(np.array([0.0, 0.0, 0.0]), zeros, theta, zeros, np.ones(4), np.zeros(3))
    assert gen.provision[0] == 0.0
    # A slow-down above brake_from keeps the medium-term filter: a = dt / provision_tau = 0.02.
    gen.reset(np.random.default_rng(0))
    gen.step(np.array([-0.3, 0.0, 0.0]), zeros, theta, zeros, np.ones(4), np.zeros(3))
    assert gen.provision[0] == pytest.approx(-0.3 * 0.01 / p.provision_tau)


def test_the_compiled_cycle_is_the_separate_steps_bit_for_bit():
    """``LocomotionGenerator.step`` (one call) against the CPG, drive, reflex and pool steps in
    turn (the shipped gait has the roll reflex, v3)."""
    gait = default_gait()
    assert gait.vestibular_gain > 0.0
    lo, hi = np.full(12, -2.5), np.full(12, 2.5)
    kb = np.array([True, False, True, False])
    fused = LocomotionGenerator(gait, lo, hi, dt=0.01, knee_behind=kb)
    ref = LocomotionGenerator(gait, lo, hi, dt=0.01, knee_behind=kb)
    rng = np.random.default_rng(3)
    fused.reset(np.random.default_rng(0))
    ref.reset(np.random.default_rng(0))
    for i in range(300):  # through the 1 s soft start and past it
        provision = rng.uniform(-1, 1, 3) if i % 3 else np.array([-0.9, 0.2, 0.0])
        interrupt = rng.uniform(-1, 1, 12) * (i % 5 == 0)
        theta, theta_dot = rng.normal(size=12), rng.normal(size=12)
        touch = rng.uniform(0, 2, 4)
        gyro = rng.normal(size=3)
        out = fused.step(provision, interrupt, theta, theta_dot, touch, gyro).copy()
        # The separate steps, as LocomotionGenerator.step ran them before the fused kernel.
        p = ref.prov
        command = np.asarray(provision, dtype=np.float64)
        braking = command[0] < p.brake_from or ref.provision[0] < p.brake_from
        before = ref.provision[0]
        a = ref.dt / max(p.provision_tau, ref.dt)
        ref.provision += a * (command - ref.provision)
        if braking:
            ref.provision[0] = before + ref.dt / max(p.brake_tau, ref.dt) * (command[0] - before)
        y = ref.cpg.step(touch)
        drive_kernel(
            y, _JOINT_NEURONS, ref.g_flex, ref.g_ext, ref.provision, p.sag_gain, p.brake_from,
            p.dir_gain, p.dir_steer, p.cor_gain, p.cor_front_bias, _SIDE, _FRONT, HIP_JOINTS,
            ABDUCT_JOINTS, ref.drive, ref.hip_drive,
        )  # fmt: skip
        ref.elapsed += ref.dt
        if ref.elapsed < p.start_ramp:
            ref.drive *= ref.elapsed / p.start_ramp
        vestibular_step(ref.pools.qd_ref, gyro, gait.vestibular_gain, _SIDE, ref.dt)
        expect = ref.pools.step(ref.drive, interrupt, theta, theta_dot, touch)
        assert out.tobytes() == expect.tobytes()
        for name in ("provision", "drive", "hip_drive"):
            assert getattr(fused, name).tobytes() == getattr(ref, name).tobytes()
        assert fused.cpg.x.tobytes() == ref.cpg.x.tobytes()
        assert fused.pools.qd_ref.tobytes() == ref.pools.qd_ref.tobytes()
