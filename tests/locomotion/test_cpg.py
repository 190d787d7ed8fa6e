import numpy as np
import pytest

from neurocog_gym.locomotion._kernels import matsuoka_step
from neurocog_gym.locomotion.cpg import CPGParams, MatsuokaCPG
from neurocog_gym.locomotion.gait import default_gait
from neurocog_gym.locomotion.generator import LocomotionGenerator


def test_matsuoka_one_euler_step_by_hand():
    # Two neurons, w12 = w21 = 2, x = (0.5, 0), v = (0.1, 0), u0 = 1, b = 2.5, tau = 1.2, T = 12,
    # tau_f = 1, dt = 0.1 (one sub-step). y = (0.5, 0).
    # dx1 = (1 - 0.5 - 2*0 + 0 - 2.5*0.1) / 1.2 = 0.25 / 1.2 = 0.208333
    # dx2 = (1 - 0 - 2*0.5 + 0 - 0) / 1.2 = 0
    # dv1 = (0.5 - 0.1) / 12 = 0.033333; dv2 = 0
    x = np.array([0.5, 0.0])
    v = np.array([0.1, 0.0])
    W = np.array([[0.0, 2.0], [2.0, 0.0]])
    y = matsuoka_step(x, v, W, np.zeros((2, 1)), np.zeros(1), 1.0, 2.5, 1.2, 12.0, 1.0, 0.1, 1)
    assert x == pytest.approx([0.5 + 0.1 * 0.25 / 1.2, 0.0])
    assert v == pytest.approx([0.1 + 0.1 * 0.4 / 12.0, 0.0])
    assert y == pytest.approx(np.maximum(x, 0))


def test_sensor_input_eq5():
    # V s enters with a plus sign: one neuron, no weights, s = 2, V = 0.5 -> dx = (1 + 1)/1.2.
    x = np.zeros(1)
    v = np.zeros(1)
    matsuoka_step(x, v, np.zeros((1, 1)), np.array([[0.5]]), np.array([2.0]),
                  1.0, 2.5, 1.2, 12.0, 1.0, 0.1, 1)  # fmt: skip
    assert x[0] == pytest.approx(0.1 * 2.0 / 1.2)


def _hip_signals(seconds=12.0, tau_f=None):
    gait = default_gait()
    gen = LocomotionGenerator(gait, -3 * np.ones(12), 3 * np.ones(12))
    if tau_f is not None:
        from dataclasses import replace

        gen.cpg.params = replace(gen.cpg.params, tau_f=tau_f)
    gen.reset(np.random.default_rng(0))
    ys = []
    for _ in range(int(seconds / 0.01)):
        ys.append(gen.cpg.step(np.zeros(4)).copy())
    ys = np.array(ys)[len(ys) // 3 :]
    return ys[:, [0, 6, 12, 18]] - ys[:, [1, 7, 13, 19]]


def _frequency(signal, dt=0.01):
    s = np.signbit(signal)
    ups = np.flatnonzero(s[:-1] & ~s[1:])
    return 1.0 / (np.mean(np.diff(ups)) * dt)


def test_default_cpg_trots_at_documented_frequency():
    hip = _hip_signals()
    f = _frequency(hip[:, 0])
    # The default gait's CPG (tau_f from assets/default_gait.json) runs at 1.5-2.5 Hz.
    assert 1.5 <= f <= 2.5, f
    # Trot: diagonal pairs (FL, HR) and (FR, HL) in phase, the pairs in anti-phase.
    c = np.corrcoef(hip.T)
    assert c[0, 3] > 0.95 and c[1, 2] > 0.95
    assert c[0, 1] < -0.95 and c[0, 2] < -0.95


def test_tau_f_scales_frequency():
    f1 = _frequency(_hip_signals(tau_f=1.0)[:, 0])
    f2 = _frequency(_hip_signals(tau_f=2.0)[:, 0])
    assert f2 / f1 == pytest.approx(2.0, rel=0.05)


def test_isolated_pair_with_table3_constants_oscillates():
    # tau = 1.2, T = 12 (swapped print), 30 ms units, w = 2: about 1.4 Hz.
    genes = np.zeros(77)
    genes[1] = 2.0
    cpg = MatsuokaCPG(genes, CPGParams())
    x0 = np.zeros(24)
    x0[0] = 0.5
    cpg.reset(x0)
    ys = np.array([cpg.step(np.zeros(4)).copy() for _ in range(1500)])
    f = _frequency((ys[:, 0] - ys[:, 1])[500:])
    assert 1.2 < f < 1.6, f


def test_bad_params_raise():
    with pytest.raises(ValueError):
        CPGParams(tau=0.0)
