"""Body v1's figures and the lift interrupt's authority (neurocog_gym/bench/body.py)."""

import numpy as np
import pytest

from neurocog_gym.bench.body import body_figures, interrupt_lift_sweep


def test_body_figures_are_within_the_real_robot_anchors():
    fig = body_figures()
    # Issue 21 anchors: hip height 0.27-0.32 m, segments about 0.20 m (A1, Go1), MX-64 servo.
    assert 0.27 <= fig["hip_height_m"] <= 0.32
    assert fig["thigh_m"] == pytest.approx(0.20) and fig["shank_m"] == pytest.approx(0.20)
    assert 3.0 <= fig["mass_kg"] <= 6.0
    assert fig["servo"]["stall_torque_nm"] == pytest.approx(6.0)
    # kv is the torque-speed slope: stall torque over the no-load speed, 6.0 / 6.6.
    assert fig["servo"]["kv_nms_per_rad"] == pytest.approx(6.0 / 6.6, abs=0.01)


def test_a_full_lift_interrupt_at_lift_off_and_mid_swing_reaches_11_cm_within_0_15_s():
    rows = interrupt_lift_sweep(np.array([0.0, 0.5]), seeds=(0,), legs=(0,), swings=1)
    assert len(rows) == 2
    for r in rows:
        assert r.peak >= 0.11
        assert r.time_to_lift is not None and r.time_to_lift <= 0.15 + 1e-9
