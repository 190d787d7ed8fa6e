import numpy as np

from neurocog_gym.locomotion.effectivity import (
    MODE_INTERRUPT,
    MODE_NONE,
    MODE_PROVISION,
    Effectivity,
    EffectivityParams,
)

HIP = np.array([[0.15, 0.12, 0.23], [0.15, -0.12, 0.23], [-0.15, 0.12, 0.23], [-0.15, -0.12, 0.23]])
FOOT = HIP.copy()
FOOT[:, 2] = 0.02
V = np.array([0.5, 0.0, 0.0])


def run(boxes, touch=(0.0, 1.0, 1.0, 0.0), t=0.05, params=None):
    eff = Effectivity(params or EffectivityParams())
    eff.step(0.0, np.ones(4), FOOT, HIP, 0.0, V, np.zeros((0, 2, 3)))  # all down at t = 0
    return eff.step(t, np.asarray(touch), FOOT, HIP, 0.0, V, np.asarray(boxes).reshape(-1, 2, 3))


def test_foothold_prediction_for_a_swinging_leg():
    p = EffectivityParams()
    s = run(np.zeros((0, 2, 3)))
    # FL lifted at t = 0.05; t_left = swing_time - 0.05 + ... (lift recorded at 0.05).
    expect = HIP[0, 0] + p.reach + V[0] * p.swing_time
    assert s.swinging.tolist() == [True, False, False, True]
    assert s.foothold[0, 0] == np.float64(expect)
    assert s.foothold[1].tolist() == FOOT[1].tolist()  # a stance leg stays where it stands
    assert s.mode == MODE_NONE


def test_foothold_inside_a_box_is_unsafe_and_beside_it_safe():
    p = EffectivityParams()
    fh = HIP[0, 0] + p.reach + V[0] * p.swing_time
    box = [[fh - 0.03, 0.08, 0.0], [fh + 0.03, 0.16, 0.07]]
    s = run([box])
    assert not s.foothold_safe[0] and s.foothold_safe[3]
    beside = [[fh - 0.03, 0.30, 0.0], [fh + 0.03, 0.40, 0.07]]
    s = run([beside])
    assert s.foothold_safe.all() and s.path_safe.all()


def test_interrupt_directions_point_up_and_over_the_box():
    p = EffectivityParams()
    fh = HIP[0, 0] + p.reach + V[0] * p.swing_time
    box = [[fh - 0.10, 0.08, 0.0], [fh - 0.05, 0.16, 0.07]]  # short block across the path
    s = run([box])
    assert not s.path_safe[0]
    assert s.mode == MODE_INTERRUPT
    d = s.direction[0]
    assert d[2] > 0 and d[0] > 0  # up and forward, away from the block's near face
    assert np.all(s.direction[1:3] == 0)  # stance legs untouched


def test_long_block_under_the_foothold_shortens_the_step():
    p = EffectivityParams()
    fh = HIP[0, 0] + p.reach + V[0] * p.swing_time
    box = [[fh - 0.05, 0.05, 0.0], [fh + 0.25, 0.2, 0.07]]
    s = run([box])
    assert s.direction[0, 0] < 0 and s.direction[0, 2] > 0


def test_object_ahead_changes_the_walking_provision():
    box = [[0.8, -0.05, 0.0], [0.9, 0.08, 0.07]]  # ahead, in the corridor, not in a swing
    s = run([box], touch=(1, 1, 1, 1))
    assert s.mode == MODE_PROVISION
    assert abs(s.provision[1]) > 0.3  # side step
    s = run([[[0.8, 0.6, 0.0], [0.9, 0.7, 0.07]]], touch=(1, 1, 1, 1))  # off the corridor
    assert s.mode == MODE_NONE
