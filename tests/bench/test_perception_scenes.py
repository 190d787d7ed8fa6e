"""The MuJoCo scenes of the perception figures and benchmarks (bench/perception_scenes.py,
scripts/bench_affordance_accuracy.py) and the scripts end to end on tiny budgets."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "scripts"))

import bench_affordance_accuracy as acc  # noqa: E402

from neurocog_gym.bench.perception_scenes import (  # noqa: E402
    StaticScene,
    Variant,
    covered_area,
    extents,
    in_region,
    walking_trial,
    write_section,
)
from neurocog_gym.robot.obstacles import Block  # noqa: E402

ENV = {**os.environ, "PYTHONPATH": str(REPO), "MUJOCO_GL": "egl"}


def test_region_and_extent_geometry():
    b = Block(1.0, 0.0, length=0.2, width=0.1, height=0.07, yaw=math.pi / 2)
    # Turned 90°: 0.1 m along x, 0.2 m across.
    w, s = extents(b, np.array([1.0, 0.0]))
    assert w == pytest.approx(0.2) and s == pytest.approx(0.1)
    pts = np.array([[1.0, 0.09, 0.07], [1.0, 0.14, 0.0], [1.06, 0.0, 0.05], [1.0, 0.0, 0.11]])
    assert in_region(b, pts, 0.03).tolist() == [True, False, True, False]
    grid = np.stack(np.meshgrid(np.arange(0, 1, 0.01), np.arange(0, 1, 0.01)), -1).reshape(-1, 2)
    assert covered_area(np.c_[grid, np.zeros(len(grid))]) == pytest.approx(1.0)


def test_write_section_replaces_only_its_own_section(tmp_path):
    doc = tmp_path / "b.md"
    write_section("a", "first A", doc)
    write_section("b", "first B", doc)
    write_section("a", "second A", doc)
    text = doc.read_text()
    assert "second A" in text and "first A" not in text and "first B" in text
    assert text.index("second A") < text.index("first B")


def test_accuracy_scene_measures_an_easy_box_within_tolerance():
    scene = StaticScene(seed=0)
    try:
        x, y = scene.world(0.55, 0.0)
        box = Block(x, y, length=0.2, width=0.2, height=0.07, yaw=scene.yaw)
        r = acc.measure(acc.Args(), scene, box, None, tof_seed=1, seed=2)
    finally:
        scene.close()
    assert r.found
    assert abs(r.dh) <= 0.01 and abs(r.dw) <= 0.02 and abs(r.ds) <= 0.02


def test_bare_floor_scene_reports_no_object():
    scene = StaticScene(seed=0)
    try:
        total, clean, clean_high = acc.bare_scene(acc.Args(bare_seconds=0.5), scene, 0, 0.025)
    finally:
        scene.close()
    assert total == 50 and clean == total and clean_high == total


def test_loop_closure_raises_the_node_count_on_a_new_obstacle():
    r = walking_trial(
        7,
        {"dd": Variant("ddgng"), "gng": Variant("gng")},
        t_appear=0.5,
        after=0.3,
        warmup_cycles=100,
    )
    dd, g = r.traces["dd"].arrays(), r.traces["gng"].arrays()
    assert dd["attended"][-1]
    assert dd["n_region"][-1] >= dd["n_region"][0] + 3
    assert dd["n_region"][-1] > g["n_region"][-1]
    assert len(dd["t"]) == len(g["t"]) > 25


@pytest.mark.slow
@pytest.mark.parametrize(
    "script, args",
    [
        ("fig9_density.py", ["--trials", "1", "--after", "0.2", "--appear", "0.5"]),
        ("attention_timing.py", ["--trials", "1", "--after", "0.2"]),
        ("plot_similarity.py", ["--trials", "1", "--after", "0.2"]),
        ("plot_graph_cloud.py", ["--at", "0.1"]),
        ("bench_affordance_accuracy.py", ["--scenes", "1", "--bare", "1", "--noise", "0"]),
    ],
)
def test_scripts_run_end_to_end(tmp_path, script, args):
    extra = ["--no-write"] if script not in ("plot_graph_cloud.py",) else []
    if script in ("fig9_density.py", "plot_similarity.py", "plot_graph_cloud.py"):
        extra += ["--out", str(tmp_path / "x.png")]
    out = subprocess.run(
        [sys.executable, str(REPO / "scripts" / script), *args, *extra],
        cwd=tmp_path, env=ENV, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr[-2000:]
    if "--out" in extra:
        assert (tmp_path / "x.png").stat().st_size > 10_000


def test_the_perception_page_is_the_checkouts_docs_page():
    # The scripts write their sections into docs/generated/ of this checkout (once, after a
    # move of this module, they went to neurocog_gym/docs/ instead, and the page went stale).
    from neurocog_gym.bench import perception_scenes

    repo = Path(__file__).resolve().parents[2]
    assert perception_scenes.DOC == repo / "docs" / "generated" / "benchmarks_perception.md"
    assert perception_scenes.DOC.is_file()
