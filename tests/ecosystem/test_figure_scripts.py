"""The AEF figure scripts end to end on one seeded sudden episode (Fig. 18 and the strip)."""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPTS = Path(__file__).resolve().parents[2] / "scripts"


def _run(args):
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    return subprocess.run([sys.executable, *map(str, args)], capture_output=True, text=True,
                          timeout=600, env=env)  # fmt: skip


def test_fig18_plots_the_aef_and_reports_its_outcome(tmp_path):
    out = tmp_path / "fig18.png"
    r = _run([SCRIPTS / "plot_foot_height.py", "--policies", "aef", "--out", out])
    assert r.returncode == 0, r.stderr
    assert out.stat().st_size > 10_000
    # The outcome of seed 0, trial 0 is reported, whatever it is. On v0 the AEF stopped for the
    # block and passed clean; on v1 the block appears 0.1 s into the swing, over the foothold,
    # and the AEF (which does not step over until issue 22) touches it.
    assert re.search(r"^aef: (success|touch|fail), peak front sole \d+\.\d cm$", r.stdout, re.M)


@pytest.mark.slow
def test_strip_picks_four_frames_around_the_stop(tmp_path):
    import imageio.v3 as iio

    out = tmp_path / "strip.png"
    r = _run([SCRIPTS / "render_strip.py", "--policy", "aef", "--seed", "1", "--width", "160",
              "--height", "120", "--out", out])  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert iio.imread(out).shape == (120, 640, 3)
