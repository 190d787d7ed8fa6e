"""The fit (locomotion/fit.py): which output group acts, and the walk-round rule's provision."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from neurocog_gym.locomotion import _fit_kernel
from neurocog_gym.locomotion.avoidance import AvoidanceParams
from neurocog_gym.locomotion.fit import (
    MODE_INTERRUPT,
    MODE_NONE,
    MODE_PROVISION,
    Fit,
    FitParams,
)
from neurocog_gym.robot.names import FRONT_LEGS
from tests.locomotion.stance import FOOT, KNEE
from tests.locomotion.stance import THIGH as HIP  # a standing robot heading +x

NO_TEACHER = FitParams(avoidance=AvoidanceParams(enabled=False))


def walk_round_reference(hip, feet, yaw, boxes):
    """The walk-round rule in plain NumPy: (box index or -1, (3,) provision)."""
    p = FitParams()
    heading = np.array([np.cos(yaw), np.sin(yaw)])
    left = np.array([-np.sin(yaw), np.cos(yaw)])
    front = hip[list(FRONT_LEGS), :2].mean(axis=0)
    rear = ((feet[:, :2] - front) @ heading).min()
    lo, hi, best, best_d, best_left = -np.inf, np.inf, -1, np.inf, True
    for k, b in enumerate(boxes):
        corners = np.array([[b[i, 0], b[j, 1]] for i in (0, 1) for j in (0, 1)]) - front
        ahead, side = corners @ heading, corners @ left
        if ahead.max() < rear - 0.03 or ahead.min() > p.lookahead:
            continue
        if side.min() > p.corridor + p.beside or side.max() < -p.corridor - p.beside:
            continue
        need_left, need_right = side.max() + p.corridor, p.corridor - side.min()
        go_left = need_left < need_right
        if go_left:
            lo = max(lo, need_left)
        else:
            hi = min(hi, -need_right)
        if ahead.min() < best_d:
            best, best_d, best_left = k, ahead.min(), go_left
    if best < 0:
        return -1, np.zeros(3)
    if lo > 0 and hi < 0:
        shift = lo if best_left else hi
    else:
        shift = lo if lo > 0 else (hi if hi < 0 else 0.0)
    cor = np.sign(shift) * min(1.0, p.cor_min + p.cor_gain * abs(shift)) if shift else 0.0
    return best, np.array([0.0, cor, 0.0])


def decide(fit, boxes, direction=None, hit=(-1, -1, -1, -1), t=0.0, dx=0.0):
    d = np.array([dx, 0.0, 0.0])
    direction = np.zeros((4, 3)) if direction is None else np.asarray(direction, float)
    return fit.decide(t, 0.0, direction, np.array(hit), FOOT + d, HIP + d, HIP + d, KNEE + d,
                      np.asarray(boxes, float).reshape(-1, 2, 3))  # fmt: skip


def test_walk_round_a_box_in_the_corridor_by_hand():
    # Front hips' mid-point (0.15, 0); box 0.5..0.6 ahead of it, y 0.05..0.25: it overlaps the
    # corridor (+-0.22). Going right needs 0.22 - 0.05 = 0.17 of step, going left 0.25 + 0.22 =
    # 0.47: right, s_COR = -min(1, 0.4 + 2.5 * 0.17) = -0.825; s_SAG and s_DIR 0.
    d = decide(Fit(NO_TEACHER), [[[0.65, 0.05, 0.0], [0.75, 0.25, 0.07]]])
    assert d.mode == MODE_PROVISION and d.target == 0
    np.testing.assert_allclose(d.provision, [0.0, -0.825, 0.0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(d.slots, [[0.0, -0.825, 0.0]] * 4, rtol=0, atol=1e-12)


def test_a_box_alongside_is_kept_clear_until_every_foot_is_past():
    # A box beside the front legs (x 0.1..0.2), y 0.20..0.30: the corridor (+-0.22) overlaps it
    # by 0.02, so the lane is kept clear: s_COR = -(0.4 + 2.5 * 0.02) = -0.45.
    d = decide(Fit(NO_TEACHER), [[[0.10, 0.20, 0.0], [0.20, 0.30, 0.07]]])
    assert d.mode == MODE_PROVISION and d.target == 0
    np.testing.assert_allclose(d.provision, [0.0, -0.45, 0.0], rtol=0, atol=1e-12)
    # y 0.25..0.35: clear by 0.03, within ``beside``: the provision group holds the walk, no step.
    d = decide(Fit(NO_TEACHER), [[[0.10, 0.25, 0.0], [0.20, 0.35, 0.07]]])
    assert d.mode == MODE_PROVISION and not d.provision.any()
    # Beside the hind feet (x -0.15): still counts; 3 cm more behind them: no longer.
    d = decide(Fit(NO_TEACHER), [[[-0.25, 0.20, 0.0], [-0.16, 0.30, 0.07]]])
    assert d.mode == MODE_PROVISION and d.provision[1] == pytest.approx(-0.45)
    d = decide(Fit(NO_TEACHER), [[[-0.30, 0.20, 0.0], [-0.19, 0.30, 0.07]]])
    assert d.mode == MODE_NONE


def test_the_box_alongside_decides_when_the_next_one_wants_the_other_side():
    # Box 0 alongside on the right (y -0.30..-0.15: left needs 0.07, right 0.52), box 1 ahead
    # (y 0.0..0.3: right needs 0.22, left 0.52). No room between them: the nearest, box 0,
    # decides: left by 0.07, s_COR = 0.4 + 2.5 * 0.07 = 0.575.
    boxes = [[[0.05, -0.30, 0.0], [0.15, -0.15, 0.07]], [[0.75, 0.0, 0.0], [0.85, 0.3, 0.07]]]
    d = decide(Fit(NO_TEACHER), boxes)
    assert d.target == 0
    np.testing.assert_allclose(d.provision, [0.0, 0.575, 0.0], rtol=0, atol=1e-12)


def test_the_walk_round_keeps_to_the_paths_heading_not_the_torsos():
    # The first cycle's heading (0) is the path's: a torso turned 0.2 rad later sees the same
    # corridor, so the same step (with the torso's heading the box would move 0.14 m across).
    box = [[[0.65, 0.05, 0.0], [0.75, 0.25, 0.07]]]
    fit = Fit(NO_TEACHER)
    first = decide(fit, box)
    later = fit.decide(0.01, 0.2, np.zeros((4, 3)), np.full(4, -1), FOOT, HIP, HIP, KNEE,
                       np.asarray(box, float))  # fmt: skip
    np.testing.assert_array_equal(later.provision, first.provision)
    assert fit.avoidance.yaw0 == 0.0


@pytest.mark.parametrize(
    "box",
    [
        [[0.65, 0.33, 0.0], [0.75, 0.50, 0.07]],  # beside the corridor and the band
        [[1.50, -0.1, 0.0], [1.60, 0.10, 0.07]],  # beyond the lookahead
        [[-0.4, -0.1, 0.0], [-0.3, 0.10, 0.07]],  # behind every foot
    ],
)
def test_nothing_to_do_gives_mode_none_and_zero_slots(box):
    d = decide(Fit(NO_TEACHER), [box])
    assert d.mode == MODE_NONE and d.target == -1
    assert not d.provision.any() and not d.slots.any()


def test_no_box_no_mode():
    d = decide(Fit(), np.zeros((0, 2, 3)))
    assert d.mode == MODE_NONE and not d.slots.any()


def test_an_interrupt_direction_chooses_the_interrupt_group_and_its_box():
    boxes = [[[0.65, 0.05, 0.0], [0.75, 0.25, 0.07]], [[0.20, 0.05, 0.0], [0.26, 0.25, 0.07]]]
    v = np.zeros((4, 3))
    v[0] = (-0.5, 0.0, 0.8)  # FL: up
    d = decide(Fit(NO_TEACHER), boxes, v, hit=(1, -1, -1, -1))
    assert d.mode == MODE_INTERRUPT and d.target == 1
    np.testing.assert_array_equal(d.slots, v)  # v^l goes to the network as observed
    assert not d.provision.any()
    # A leg that meets a box but has no interrupt direction does not name the target; with no
    # interrupted leg meeting one, the box nearest the feet's mean is taken: feet mean x = 0,
    # box 1's centre (0.23, 0.15) is nearer than box 0's (0.7, 0.15).
    d = decide(Fit(NO_TEACHER), boxes, v, hit=(-1, 0, -1, -1))
    assert d.mode == MODE_INTERRUPT and d.target == 1


def test_the_teacher_takes_a_tall_box_an_interrupt_is_for():
    # Box 0 first seen far ahead (not sudden); the robot is now 0.55 m on and FL's swing meets
    # it: 7 cm is taller than a swing clears, so the fit stops for it instead of interrupting.
    far = [[[0.80, -0.1, 0.0], [0.90, 0.1, 0.07]]]
    fit = Fit()
    assert decide(fit, far).mode == MODE_PROVISION  # walk round it, from afar
    v = np.zeros((4, 3))
    v[0] = (-0.5, 0.0, 0.8)
    d = decide(fit, far, v, hit=(0, -1, -1, -1), t=1.0, dx=0.55)
    assert d.mode == MODE_PROVISION and d.provision.tolist() == [-1.0, 0.0, 0.0]
    # A 3 cm box is stepped over: the interrupt acts.
    low = [[[0.80, -0.1, 0.0], [0.90, 0.1, 0.03]]]
    fit = Fit()
    decide(fit, low)
    assert decide(fit, low, v, hit=(0, -1, -1, -1), t=1.0, dx=0.55).mode == MODE_INTERRUPT


def test_reset_forgets_the_teacher():
    fit = Fit()
    sudden = [[[0.25, 0.05, 0.0], [0.33, 0.25, 0.07]]]
    assert decide(fit, sudden).provision.tolist() == [-1.0, 0.0, 0.0]
    fit.reset()
    assert fit.avoidance.state_name == "walk"


@settings(max_examples=200, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.floats(-1.0, 2.0),
            st.floats(-0.6, 0.6),
            st.floats(0.01, 0.3),
            st.floats(0.01, 0.3),
        ),
        max_size=5,
    ),
    st.floats(-np.pi, np.pi),
    st.floats(-0.5, 0.5),
)
def test_walk_round_kernel_matches_the_reference(boxes, yaw, shift):
    arr = np.array(
        [[[x, y, 0.0], [x + ln, y + w, 0.07]] for x, y, ln, w in boxes], dtype=float
    ).reshape(-1, 2, 3)
    hip = HIP + [shift, -shift, 0.0]
    feet = FOOT + [shift, -shift, 0.0]
    out = np.empty(3)
    p = FitParams()
    k = _fit_kernel.walk_around_kernel(
        hip, feet, np.array(FRONT_LEGS, dtype=np.int64), np.cos(yaw), np.sin(yaw), arr,
        p.lookahead, p.corridor, p.beside, p.cor_min, p.cor_gain, out,
    )  # fmt: skip
    k_ref, out_ref = walk_round_reference(hip, feet, yaw, arr)
    assert k == k_ref
    np.testing.assert_allclose(out, out_ref, rtol=0, atol=1e-12)
