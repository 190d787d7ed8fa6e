"""The stop / side-step / pass teacher of the fit (locomotion/avoidance.py)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from neurocog_gym.locomotion.avoidance import (
    PASS,
    REVERSE,
    SIDE,
    WALK,
    AvoidanceParams,
    SuddenAvoidance,
    _reach,
)
from neurocog_gym.locomotion.effectivity import Effectivity
from neurocog_gym.locomotion.fit import MODE_INTERRUPT, MODE_PROVISION, Fit, FitParams
from tests.locomotion.stance import FOOT, KNEE, THIGH  # a standing robot heading +x


def box(x0, x1, y0, y1, h=0.07):
    return np.array([[[x0, y0, 0.0], [x1, y1, h]]])


def legs(dx=0.0, dy=0.0):
    d = np.array([dx, dy, 0.0])
    return FOOT + d, THIGH + d, KNEE + d


def test_reach_is_the_knee_below_a_block_top_above_the_knee_and_the_sole_below_it():
    # Top 0.07 m: the thigh (lowest point 0.11 - 0.017) is above it; the shank's capsule reaches
    # its most forward point at the knee end that is still below the top: the sample at s = 0.2
    # of knee -> foot is at z = 0.11 - 0.2 * 0.092 = 0.0916 (too high), s = 0.4: 0.0732 - 0.012
    # = 0.0612 <= 0.07, x = 0.15 + 0.02 * 0.6 + 0.012 = 0.174.
    assert _reach(FOOT, THIGH, KNEE, 0.07)[0] == pytest.approx(0.174)
    # A low block: only the sole counts, 0.15 + 0.018.
    assert _reach(FOOT, THIGH, KNEE, 0.02)[0] == pytest.approx(0.168)


def test_a_block_appearing_in_a_front_lane_reverses_the_trot():
    av = SuddenAvoidance()
    f, t, k = legs()
    out = av.update(0.0, 0.0, f, t, k, box(0.25, 0.33, 0.05, 0.25))
    assert av.state == REVERSE
    assert out.tolist() == [-1.0, 0.0, 0.0]
    # The lanes: left legs between y 0.12 and 0.12 -> +- 0.048; the block (0.05..0.25) overlaps
    # the left lanes; shifting right needs 0.12 + 0.048 - 0.05 = 0.118 < shifting left 0.25 +
    # 0.048 + 0.12 = 0.418: the side step goes right.
    assert av.direction == -1.0


def test_blocks_beside_the_lanes_far_ahead_or_low_do_not_engage():
    f, t, k = legs()
    for b in (
        box(0.25, 0.33, 0.30, 0.50),  # left of every lane
        box(0.80, 0.90, -0.1, 0.1),  # first seen 0.65 m ahead of the leading foot: not sudden
        box(0.25, 0.33, -0.1, 0.1, h=0.015),  # lower than min_height
    ):
        av = SuddenAvoidance()
        assert av.update(0.0, 0.0, f, t, k, b) is None
        assert av.state == WALK


def test_a_far_block_stays_with_the_walk_around_even_when_the_robot_comes_close():
    av = SuddenAvoidance()
    b = box(0.80, 0.90, -0.1, 0.1)
    f, t, k = legs()
    av.update(0.0, 0.0, f, t, k, b)  # seen first from afar
    f, t, k = legs(dx=0.55)
    assert av.update(1.0, 0.0, f, t, k, b) is None


def test_back_off_then_side_step_then_pass_then_walk():
    p = AvoidanceParams()
    av = SuddenAvoidance(p)
    b = box(0.25, 0.33, 0.05, 0.25)
    f, t, k = legs()
    av.update(0.0, 0.0, f, t, k, b)
    assert av.state == REVERSE
    # Backed off: every in-lane leg's reach 0.174 - dx is >= backoff behind 0.25 once dx >= 0.006,
    # but not before t_rev.
    f, t, k = legs(dx=-0.01)
    av.update(0.1, 0.0, f, t, k, b)
    assert av.state == REVERSE
    out = av.update(p.t_rev, 0.0, f, t, k, b)
    assert av.state == SIDE
    # Side step to the right (direction -1), the hips cancelled by k = 0.75 + 10 (0.07 - gap)
    # with gap = 0.25 - 0.164 = 0.086 -> 0.59, clipped to k_min = 0.7: stride 0.3 ahead, s_SAG
    # = -1 + 1.3 * 0.5 / 1.7 (below brake_from: stride -1 at s_SAG -1, 0.7 at -0.5).
    assert out[1] == -1.0
    assert out[0] == pytest.approx(-1.0 + 1.3 * 0.5 / 1.7)
    # No heading error: s_DIR leans left against the right step's turn, +0.5; with an error of
    # 0.1 rad: 0.5 - 2 * 0.1.
    assert out[2] == pytest.approx(0.5)
    out = av.update(p.t_rev + 0.01, 0.1, f, t, k, b)
    assert out[2] == pytest.approx(0.3)
    # A leg 3 cm from the near face (reach 0.174 + 0.046 = 0.22): k = 0.75 + 10 * 0.04 = 1.15,
    # stride -0.15: the hips step back. s_SAG = -1 + 0.85 * 0.5 / 1.7.
    f2, t2, k2 = legs(dx=0.046)
    out = av.update(p.t_rev + 0.015, 0.0, f2, t2, k2, b)
    assert av.state == SIDE
    assert out[0] == pytest.approx(-1.0 + 0.85 * 0.5 / 1.7)
    # Shifted right by 0.2 m: the left lanes end at 0.12 - 0.2 + 0.058 < 0.05: clear -> pass.
    f, t, k = legs(dx=-0.01, dy=-0.2)
    out = av.update(p.t_rev + 0.02, 0.0, f, t, k, b)
    assert av.state == PASS
    assert out[0] == 0.0
    # Every foot past the block's far face (+ 3 cm): walk, not engaged.
    f, t, k = legs(dx=0.55, dy=-0.2)
    assert av.update(p.t_rev + 2.0, 0.0, f, t, k, b) is None
    assert av.state == WALK


def test_disabled_never_engages():
    av = SuddenAvoidance(AvoidanceParams(enabled=False))
    f, t, k = legs()
    assert av.update(0.0, 0.0, f, t, k, box(0.25, 0.33, 0.05, 0.25)) is None


def _fit_cycle(eff, fit, t, touch, feet, thighs, knees, hip, boxes):
    """One cycle as env and policy split it: the effectivity predicts, the fit decides."""
    s = eff.step(t, touch, feet, hip, 0.0, np.array([0.5, 0.0, 0.0]), boxes)
    return s, fit.decide(t, 0.0, s.direction, s.hit, feet, hip, thighs, knees, eff.memory)


def test_the_fit_hands_the_teacher_to_the_provision_group():
    f, t, k = legs()
    hip = THIGH.copy()
    touch = np.array([0.0, 1.0, 1.0, 0.0])  # FL swings
    b = box(0.25, 0.33, 0.05, 0.25)
    eff, fit = Effectivity(), Fit()
    _fit_cycle(eff, fit, 0.0, np.ones(4), f, t, k, hip, np.zeros((0, 2, 3)))
    s, d = _fit_cycle(eff, fit, 0.05, touch, f, t, k, hip, b)
    # The swinging FL meets the block: the effectivity gives it an interrupt direction, and the
    # fit answers with the teacher's stop instead (a block that appeared within reach).
    assert s.phase[0] != 0 and s.direction[0].any()
    assert d.mode == MODE_PROVISION
    assert d.provision.tolist() == [-1.0, 0.0, 0.0]
    assert d.slots.tolist() == [[-1.0, 0.0, 0.0]] * 4
    # With the teacher off, the fit's rules alone: the interrupt acts on FL's direction.
    eff, fit = Effectivity(), Fit(FitParams(avoidance=AvoidanceParams(enabled=False)))
    _fit_cycle(eff, fit, 0.0, np.ones(4), f, t, k, hip, np.zeros((0, 2, 3)))
    s, d = _fit_cycle(eff, fit, 0.05, touch, f, t, k, hip, b)
    assert d.mode == MODE_INTERRUPT
    np.testing.assert_array_equal(d.slots, s.direction)


def test_a_tall_box_a_swing_meets_is_adopted_however_far_it_was_first_seen():
    av = SuddenAvoidance()
    b = box(0.80, 0.90, -0.1, 0.1)
    f, t, k = legs()
    assert av.update(0.0, 0.0, f, t, k, b) is None  # first seen 0.65 m ahead: not sudden
    f, t, k = legs(dx=0.55)  # now 10 cm before the lead foot: the walk-around failed
    assert av.update(1.0, 0.0, f, t, k, b) is None
    assert av.adopt(b[0], f)
    assert av.update(1.01, 0.0, f, t, k, b).tolist() == [-1.0, 0.0, 0.0]
    assert av.state == REVERSE


def test_low_boxes_and_boxes_behind_the_lead_foot_are_not_adopted():
    f, t, k = legs()
    av = SuddenAvoidance()
    # 3 cm: below the 4 cm step_over_height, a swing clears it.
    assert not av.adopt(box(0.25, 0.33, -0.1, 0.1, h=0.03)[0], f)
    # Near face 5 cm behind the lead foot (0.15): under the body, the hind legs' business.
    assert not av.adopt(box(0.10, 0.20, -0.1, 0.1)[0], f)
    assert av.adopt(box(0.14, 0.20, -0.1, 0.1)[0], f)  # 1 cm behind: still taken


def test_the_fit_adopts_the_box_an_interrupt_would_step_over():
    eff, fit = Effectivity(), Fit()
    f, t, k = legs()
    hip = THIGH.copy()
    far = box(0.80, 0.90, 0.05, 0.25)
    _, d = _fit_cycle(eff, fit, 0.0, np.ones(4), f, t, k, hip, far)  # seen from afar
    assert fit.avoidance.state == WALK and d.mode == MODE_PROVISION  # walk round it
    assert d.provision[0] == 0.0 and d.provision[1] != 0.0
    f2, t2, k2 = legs(dx=0.55)
    touch = np.array([0.0, 1.0, 1.0, 0.0])
    _, d = _fit_cycle(eff, fit, 0.05, touch, f2, t2, k2, hip + [0.55, 0, 0], far)
    assert d.mode == MODE_PROVISION
    assert d.provision[0] == -1.0
    assert fit.avoidance.state == REVERSE


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.floats(-1.0, 1.5),
            st.floats(-0.6, 0.6),
            st.floats(0.0, 0.3),
            st.floats(0.0, 0.3),
            st.floats(0.0, 0.12),
        ),  # fmt: skip
        max_size=5,
    ),
    st.floats(-0.3, 1.0),
    st.floats(-0.3, 0.3),
    st.floats(-3.0, 3.0),
)
def test_any_scene_gives_a_bounded_provision_or_none(boxes, dx, dy, yaw):
    av = SuddenAvoidance()
    f, t, k = legs()
    arr = np.array(
        [[[x, y, 0.0], [x + ln, y + w, h]] for x, y, ln, w, h in boxes], dtype=float
    ).reshape(-1, 2, 3)
    av.update(0.0, 0.0, f, t, k, arr)
    for i in range(1, 20):
        f, t, k = legs(dx=dx * i / 20, dy=dy * i / 20)
        out = av.update(0.01 * i, yaw * i / 20, f, t, k, arr)
        assert out is None or (out.shape == (3,) and np.all(np.abs(out) <= 1.0))
        assert (out is None) == (av.state == WALK)
        for b in arr:
            av.adopt(b, f)
