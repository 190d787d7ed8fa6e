"""The roll reflex (locomotion/_kernels.py vestibular_step, Gait.vestibular_gain)."""

import json
from dataclasses import replace

import numpy as np
import pytest

from neurocog_gym.locomotion._kernels import vestibular_step
from neurocog_gym.locomotion.gait import Gait, default_gait
from neurocog_gym.locomotion.generator import _SIDE, LocomotionGenerator


def test_the_sinking_side_extends_and_the_rising_side_folds():
    # Right side sinking (roll rate +2 rad/s), gain 15, one 0.01 s cycle: e = 15 * 2 = 30 rad/s^2
    # on the right legs (side -1), -30 on the left: right knees -0.3 rad/s, right hips +0.15.
    qd = np.zeros(12)
    vestibular_step(qd, np.array([2.0, 0.0, 0.0]), 15.0, _SIDE, 0.01)
    hips, knees = qd[1::3], qd[2::3]
    assert knees == pytest.approx([0.3, -0.3, 0.3, -0.3])  # FL, FR, HL, HR
    assert hips == pytest.approx([-0.15, 0.15, -0.15, 0.15])
    assert np.all(qd[0::3] == 0.0)  # abduction untouched


def test_pitch_and_yaw_rates_do_nothing():
    qd = np.zeros(12)
    vestibular_step(qd, np.array([0.0, 3.0, -2.0]), 15.0, _SIDE, 0.01)
    assert np.all(qd == 0.0)


def _run(gait, gyro, cycles=30):
    gen = LocomotionGenerator(gait, -3 * np.ones(12), 3 * np.ones(12))
    gen.reset(np.random.default_rng(0))
    theta = np.asarray(gait.posture, dtype=np.float64)
    zeros = np.zeros(12)
    for _ in range(cycles):
        out = gen.step(zeros[:3], zeros, theta, zeros, np.ones(4), gyro).copy()
    return out


def test_the_shipped_gait_has_the_reflex():
    assert default_gait().vestibular_gain == 20.0  # env v3 (CHANGELOG)


def test_a_zero_gain_leaves_the_cycle_bit_for_bit():
    gait = replace(default_gait(), vestibular_gain=0.0)
    spin = np.array([5.0, -1.0, 0.5])
    assert np.array_equal(_run(gait, spin), _run(gait, None))


def test_a_gain_bends_the_targets_the_reflex_way():
    gait = replace(default_gait(), vestibular_gain=0.0)
    roll = np.array([1.0, 0.0, 0.0])  # right side sinking throughout
    base = _run(gait, roll)
    bent = _run(replace(gait, vestibular_gain=15.0), roll)
    d_knee = (bent - base)[2::3]
    # Knee-ahead legs (no coupling): the left knees fold further, the right ones unfold.
    assert d_knee[0] > 0.01 and d_knee[2] > 0.01
    assert d_knee[1] < -0.01 and d_knee[3] < -0.01


def test_a_reflex_gait_without_the_rate_is_refused():
    gait = replace(default_gait(), vestibular_gain=10.0)
    gen = LocomotionGenerator(gait, -3 * np.ones(12), 3 * np.ones(12))
    gen.reset(np.random.default_rng(0))
    with pytest.raises(ValueError, match="gyro"):
        gen.step(np.zeros(3), np.zeros(12), np.zeros(12), np.zeros(12), np.ones(4))


@pytest.mark.parametrize("bad", [-1.0, float("nan"), float("inf")])
def test_a_bad_gain_is_refused(bad):
    with pytest.raises(ValueError, match="vestibular_gain"):
        replace(default_gait(), vestibular_gain=bad)


def test_the_gain_round_trips_through_the_file_and_old_files_read_as_zero(tmp_path):
    gait = replace(default_gait(), vestibular_gain=15.0)
    gait.save(tmp_path / "g.json")
    assert Gait.load(tmp_path / "g.json").vestibular_gain == 15.0
    raw = json.loads((tmp_path / "g.json").read_text())
    del raw["vestibular_gain"]
    (tmp_path / "old.json").write_text(json.dumps(raw))
    assert Gait.load(tmp_path / "old.json").vestibular_gain == 0.0


def test_the_nsga_rollout_carries_the_reflex():
    """The compiled rollout runs the reflex as the env does (tests/train/test_nsga.py checks the
    shipped reflex gait against a Walk env rollout): with the gain at 0 the walk differs."""
    from neurocog_gym.train.evaluate import EvalParams, GaitEvaluator

    params = EvalParams(seconds=3.0, warmup=1.0)
    genes = default_gait().genes_array
    without = replace(default_gait(), vestibular_gain=0.0)
    on = GaitEvaluator(default_gait(), params).evaluate(genes, seed=3)
    off = GaitEvaluator(without, params).evaluate(genes, seed=3)
    assert on.energy != off.energy and on.distance != off.distance
