import numpy as np

from neurocog_gym.locomotion.effectivity import (
    PHASE_NONE,
    PHASE_OVER,
    PHASE_UP,
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
    assert (s.phase == PHASE_NONE).all() and not s.direction.any() and (s.hit == -1).all()


def test_foothold_inside_a_box_is_unsafe_and_beside_it_safe():
    p = EffectivityParams()
    fh = HIP[0, 0] + p.reach + V[0] * p.swing_time
    box = [[fh - 0.03, 0.08, 0.0], [fh + 0.03, 0.16, 0.07]]
    s = run([box])
    assert not s.foothold_safe[0] and s.foothold_safe[3]
    assert s.hit.tolist() == [0, -1, -1, -1]  # the box FL's foothold lies in
    beside = [[fh - 0.03, 0.30, 0.0], [fh + 0.03, 0.40, 0.07]]
    s = run([beside])
    assert s.foothold_safe.all() and s.path_safe.all()


def test_interrupt_lifts_first_then_carries_the_foot_over_the_box():
    p = EffectivityParams()
    fh = HIP[0, 0] + p.reach + V[0] * p.swing_time
    box = np.array([[fh - 0.10, 0.08, 0.0], [fh - 0.05, 0.16, 0.07]])  # short block across the path
    eff = Effectivity(p)
    eff.step(0.0, np.ones(4), FOOT, HIP, 0.0, V, np.zeros((0, 2, 3)))
    touch = np.array([0.0, 1.0, 1.0, 0.0])
    s = eff.step(0.05, touch, FOOT, HIP, 0.0, V, box[None])
    assert not s.path_safe[0] and s.hit[0] == 0
    assert s.phase[0] == PHASE_UP
    d = s.direction[0]
    assert d[2] > 0  # up
    assert d[0] + V[0] <= 0  # relative to the ground: no closer to the near face while low
    assert np.all(s.direction[1:3] == 0)  # stance legs untouched
    # Once the sole is above the (margin-grown) top, the foot moves forward over the block.
    high = FOOT.copy()
    high[0, 2] = 0.07 + p.margin + p.lift_clearance + p.foot_radius + 0.005
    s = eff.step(0.06, touch, high, HIP, 0.0, V, box[None])
    assert s.phase[0] == PHASE_OVER and s.direction[0, 0] + V[0] > 0
    # Past the far face the interrupt ends and the CPG sets the foot down.
    past = high.copy()
    past[0, 0] = box[1, 0] + p.margin + p.foot_radius + 0.01
    s = eff.step(0.07, touch, past, HIP, 0.0, V, box[None])
    assert s.phase[0] == PHASE_NONE and np.all(s.direction[0] == 0)


def test_a_foot_too_close_to_the_face_backs_off_while_rising():
    p = EffectivityParams()
    eff = Effectivity(p)
    eff.step(0.0, np.ones(4), FOOT, HIP, 0.0, V, np.zeros((0, 2, 3)))
    x = FOOT[0, 0] + p.foot_radius + 0.005  # near face 5 mm in front of the sole, before growing
    box = np.array([[[x, 0.08, 0.0], [x + 0.08, 0.16, 0.07]]])
    s = eff.step(0.05, np.array([0.0, 1, 1, 1]), FOOT, HIP, 0.0, V, box)
    assert s.phase[0] == PHASE_UP
    assert s.direction[0, 0] + V[0] < 0  # backwards over the ground


def test_obstacle_memory_keeps_a_box_out_of_view_until_the_feet_pass_it():
    p = EffectivityParams()
    eff = Effectivity(p)
    fh = HIP[0, 0] + p.reach + V[0] * p.swing_time
    box = np.array([[[fh - 0.03, 0.08, 0.0], [fh + 0.03, 0.16, 0.07]]])
    eff.step(0.0, np.ones(4), FOOT, HIP, 0.0, V, box)
    # No longer seen, but FL's next foothold still lands in the remembered box.
    s = eff.step(0.05, np.array([0.0, 1, 1, 1]), FOOT, HIP, 0.0, V, np.zeros((0, 2, 3)))
    assert len(eff.memory) == 1 and not s.foothold_safe[0]
    past = FOOT.copy()
    past[:, 0] = fh + 0.03 + p.forget_behind + 0.01
    eff.step(0.06, np.ones(4), past, HIP, 0.0, V, np.zeros((0, 2, 3)))
    assert len(eff.memory) == 0
