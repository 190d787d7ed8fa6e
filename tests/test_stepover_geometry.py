"""scripts/stepover_geometry.py: the planar step-over study behind body v2's knees."""

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

_PATH = Path(__file__).resolve().parents[1] / "scripts" / "stepover_geometry.py"
_spec = importlib.util.spec_from_file_location("stepover_geometry", _PATH)
geo = importlib.util.module_from_spec(_spec)
sys.modules["stepover_geometry"] = geo  # dataclasses look their module up
_spec.loader.exec_module(geo)


@pytest.mark.parametrize("behind", [False, True])
def test_knee_point_reaches_the_foot(behind):
    for dx, dz in [(0.0, -0.3), (0.1, -0.25), (-0.08, -0.2)]:
        k = geo.knee_point(dx, dz, behind)
        assert np.hypot(*k) == pytest.approx(geo.L)
        assert np.hypot(dx - k[0], dz - k[1]) == pytest.approx(geo.L)
        # a knee behind the hip-foot line lies at smaller x than the line at the knee's height
        on_line = dx * k[1] / dz
        assert (k[0] < on_line) == behind
    assert geo.knee_point(0.0, -0.41, True) is None


def test_a_block_under_the_leg_is_met_and_a_far_one_is_not():
    a = geo.Args()
    hip = np.array([0.0, 0.30])
    foot = np.array([0.0, geo.R_FOOT])
    assert geo._pose_clearance(hip, foot, True, -0.05, 0.05, 0.06) < 0  # block round the foot
    assert geo._pose_clearance(hip, foot, True, 0.5, 0.6, 0.06) > 0.3
    # a clean step-over exists for the knee-behind leg at 0.32 m over a small block
    paths = [(ap, ld, sw) for ap in (0.02, 0.04) for ld in (0.06, 0.10) for sw in (0.3, 0.4)]
    best = max(geo.clearance(True, 0.32, 0.02, 0.05, 0.06, *p, a) for p in paths)
    assert best > 0.005


def test_writes_the_table(tmp_path):
    out = tmp_path / "geo.md"
    geo.main(["--out", str(out)])
    text = out.read_text()
    assert "behind the foot" in text and "ahead of the foot" in text
    assert text.count("\n| ") == 9  # header + 8 rows
