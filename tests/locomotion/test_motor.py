import numpy as np
import pytest

from neurocog_gym.locomotion._kernels import force_length, force_velocity, motor_neuron_step
from neurocog_gym.locomotion.motor import MotorNeuronPools, MotorParams

C = np.log(0.05)


def test_force_length_eq9():
    # At the optimum: exp(0) = 1. At theta_R*omega away: exp(ln 0.05 * 1) = 0.05.
    assert force_length(0.3, 0.3, 1.4, C) == pytest.approx(1.0)
    assert force_length(0.3 + 1.4, 0.3, 1.4, C) == pytest.approx(0.05)
    assert force_length(0.3 - 1.4, 0.3, 1.4, C) == pytest.approx(0.05)
    # Half-way: exp(ln 0.05 * 0.125) = 0.05 ** 0.125 = 0.68766...
    assert force_length(0.3 + 0.7, 0.3, 1.4, C) == pytest.approx(0.05**0.125)


def test_force_velocity_eq10():
    vmax, K, N = 7.0, 1.0, 1.5
    assert force_velocity(0.0, vmax, K, N) == pytest.approx(1.0)
    assert force_velocity(-vmax, vmax, K, N) == pytest.approx(0.0)
    assert force_velocity(-2 * vmax, vmax, K, N) == 0.0
    # Shortening at half speed: (7 - 3.5) / (7 + 3.5) = 1/3.
    assert force_velocity(-3.5, vmax, K, N) == pytest.approx(1.0 / 3.0)
    # Lengthening at vmax: 1.5 - 0.5 * 0 / (...) = 1.5; at 3.5: 1.5 - 0.5*3.5/(26.46+7).
    assert force_velocity(vmax, vmax, K, N) == pytest.approx(1.5)
    assert force_velocity(3.5, vmax, K, N) == pytest.approx(1.5 - 0.5 * 3.5 / (7.56 * 3.5 + 7))
    # Continuous at zero from both sides.
    assert force_velocity(-1e-9, vmax, K, N) == pytest.approx(force_velocity(0.0, vmax, K, N))


def _one_step(drive, interrupt, theta, theta_dot, touch, Z, mu1=1.0, mu2=1.0, k=0.0, d=0.0):
    q = np.zeros(1)
    qd = np.zeros(1)
    acc = np.zeros(1)
    motor_neuron_step(
        q, qd, np.array([drive]), np.array([interrupt]), np.array([theta]), np.array([theta_dot]),
        np.asarray(touch, float), np.array([0.0]), mu1, mu2, np.array([100.0]), np.array([7.0]),
        np.array([1.4]), C, 1.0, 1.5, np.asarray(Z, float).reshape(1, -1), k, d,
        np.array([-3.0]), np.array([3.0]), 0.01, acc, np.zeros(1), np.array([-3.0]),
        np.array([3.0]), np.zeros(1),
    )  # fmt: skip
    return q[0], qd[0], acc[0]


def test_eq8_and_eq11_by_hand():
    # a = 1*0.3 + 1*0.2 = 0.5; F_l(0) = 1; F_v(0) = 1; S = 2*0.5 + 4*0.25 = 2.0
    # theta_dd = 0.5 * 100 + 2 = 52 rad/s^2; qd = 0.52 rad/s; q = 0.0052 rad.
    q, qd, acc = _one_step(0.3, 0.2, 0.0, 0.0, [0.5, 0.25], [2.0, 4.0])
    assert acc == pytest.approx(52.0)
    assert qd == pytest.approx(0.52)
    assert q == pytest.approx(0.0052)


def test_eq8_activation_clipped_and_shaped():
    # CPG part 1.4 -> clipped to 1, the interrupt adds on top: a = 1 + 0.5 = 1.5; joint moving
    # the way it pulls at 3.5 rad/s: F_v = (7 - 3.5) / (7 + 3.5) = 1/3.
    _, _, acc = _one_step(1.4, 0.5, 0.0, 3.5, [0.0], [0.0])
    assert acc == pytest.approx(1.5 * 100.0 / 3.0)
    # Negative activation, joint moving negative (shortening of the other muscle): also 1/3.
    _, _, acc = _one_step(-1.4, -0.5, 0.0, -3.5, [0.0], [0.0])
    assert acc == pytest.approx(-1.5 * 100.0 / 3.0)
    # The interrupt overrides a saturated CPG burst: 1 - 1.5 = -0.5, joint at rest.
    _, _, acc = _one_step(1.4, -1.5, 0.0, 0.0, [0.0], [0.0])
    assert acc == pytest.approx(-50.0)


def test_restoring_term_and_limits():
    pools = MotorNeuronPools(np.zeros(12), -np.ones(12), np.ones(12), MotorParams(), dt=0.01)
    pools.reset(np.full(12, 0.5))
    for _ in range(300):
        q = pools.step(np.zeros(12), np.zeros(12), np.zeros(12), np.zeros(12), np.zeros(4))
    assert np.all(np.abs(q) < 1e-3)  # returns to the posture without a drive
    for _ in range(300):
        q = pools.step(np.ones(12), np.ones(12), np.zeros(12), np.zeros(12), np.zeros(4))
    assert np.all(q <= 1.0) and np.all(np.abs(pools.qd_ref) <= 7.0)
