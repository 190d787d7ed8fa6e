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


def walk_round_reference(hip, yaw, boxes):
    """The walk-round rule in plain NumPy: (box index or -1, (3,) provision)."""
    p = FitParams()
    heading = np.array([np.cos(yaw), np.sin(yaw)])
    left = np.array([-np.sin(yaw), np.cos(yaw)])
    front = hip[list(FRONT_LEGS), :2].mean(axis=0)
    best, best_d, lateral = -1, np.inf, 0.0
    for k, b in enumerate(boxes):
        corners = np.array([[b[i, 0], b[j, 1]] for i in (0, 1) for j in (0, 1)]) - front
        ahead, side = corners @ heading, corners @ left
        if ahead.max() < 0 or ahead.min() > p.lookahead:
            continue
        if side.min() > p.corridor or side.max() < -p.corridor:
            continue
        d = max(ahead.min(), 0.0)
        if d < p.near or d >= best_d:
            continue
        best, best_d = k, d
        go_left = abs(side.min() - p.corridor) > abs(side.max() + p.corridor)
        need = (side.max() + p.corridor) if go_left else (p.corridor - side.min())
        lateral = (1.0 if go_left else -1.0) * min(1.0, 0.4 + 2.5 * need)
    if best < 0:
        return -1, np.zeros(3)
    return best, np.array([-0.3 if best_d < 0.6 else 0.0, lateral, 0.0])


def decide(fit, boxes, direction=None, hit=(-1, -1, -1, -1), t=0.0, dx=0.0):
    d = np.array([dx, 0.0, 0.0])
    direction = np.zeros((4, 3)) if direction is None else np.asarray(direction, float)
    return fit.decide(t, 0.0, direction, np.array(hit), FOOT + d, HIP + d, HIP + d, KNEE + d,
                      np.asarray(boxes, float).reshape(-1, 2, 3))  # fmt: skip


def test_walk_round_a_box_in_the_corridor_by_hand():
    # Front hips' mid-point (0.15, 0); box 0.5..0.6 ahead of it, y 0.05..0.25: it overlaps the
    # corridor (+-0.16). Going right needs 0.16 - 0.05 = 0.11 of step, going left 0.25 + 0.16 =
    # 0.41: right, s_COR = -min(1, 0.4 + 2.5 * 0.11) = -0.675; 0.5 m ahead < 0.6: s_SAG = -0.3.
    d = decide(Fit(NO_TEACHER), [[[0.65, 0.05, 0.0], [0.75, 0.25, 0.07]]])
    assert d.mode == MODE_PROVISION and d.target == 0
    np.testing.assert_allclose(d.provision, [-0.3, -0.675, 0.0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(d.slots, [[-0.3, -0.675, 0.0]] * 4, rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    "box",
    [
        [[0.65, 0.20, 0.0], [0.75, 0.40, 0.07]],  # beside the corridor
        [[1.50, -0.1, 0.0], [1.60, 0.10, 0.07]],  # beyond the lookahead
        [[0.25, -0.1, 0.0], [0.30, 0.10, 0.07]],  # nearer than ``near``: the swings' business
        [[-0.4, -0.1, 0.0], [-0.3, 0.10, 0.07]],  # behind
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
    out = np.empty(3)
    k = _fit_kernel.walk_around_kernel(
        hip, np.array(FRONT_LEGS, dtype=np.int64), np.cos(yaw), np.sin(yaw), arr,
        FitParams().lookahead, FitParams().near, FitParams().corridor, out,
    )  # fmt: skip
    k_ref, out_ref = walk_round_reference(hip, yaw, arr)
    assert k == k_ref
    np.testing.assert_allclose(out, out_ref, rtol=0, atol=1e-12)
