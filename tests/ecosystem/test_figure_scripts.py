"""Figure and diagnostic scripts end to end on seeded sudden episodes (Fig. 18, strip, contacts)."""

import ast
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


def test_stones_strip_runs_to_the_episodes_end(tmp_path):
    import imageio.v3 as iio

    out = tmp_path / "stones.png"
    r = _run([SCRIPTS / "render_strip.py", "--env", "stones", "--policy", "blind", "--seed", "3",
              "--width", "160", "--height", "120", "--out", out])  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert iio.imread(out).shape == (120, 640, 3)
    # seed 3: the blind trot's foot goes into the pit; the last frame is that cycle's
    assert re.search(r"frames at t = 0\.01, .*, 2\.24 s \(outcome fail, a foot in the pit at "
                     r"2\.24 s\)", r.stdout)  # fmt: skip


def test_trial_contacts_lists_each_trials_first_block_contacts():
    r = _run([SCRIPTS / "trial_contacts.py", "--policy", "blind", "--trials", "2"])
    assert r.returncode == 0, r.stderr
    rows = re.findall(r"^\s+(\d) (success|touch|fail)\s.*block L 0\.\d{3} W 0\.\d{3} H 0\.0\d{2}",
                      r.stdout, re.M)  # fmt: skip
    assert [int(i) for i, _ in rows] == [0, 1]
    counted = re.search(r"^outcomes: (\{.*\}) of 2$", r.stdout, re.M)
    assert counted and sum(ast.literal_eval(counted.group(1)).values()) == 2
    # the blind trot walks into every sudden block: each trial names the geom it met first
    assert re.search(r"^first contact in 2 of 2 trials; within 0.15 s of the appearance: [012];",
                     r.stdout, re.M)  # fmt: skip
    bad = _run([SCRIPTS / "trial_contacts.py", "--trials", "0"])
    assert bad.returncode != 0 and "--trials must be at least 1" in bad.stderr
