"""The attention loop's additions: raised-node suspicion, raw-point sizes, artefact and
field-of-view checks (pipeline.py, _affordance_kernels.refine_objects_kernel)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from neurocog_gym.perception import _affordance_kernels as _k
from neurocog_gym.perception.affordance import AffordanceParams, detect_affordances
from neurocog_gym.perception.pipeline import AttentionPipeline, PipelineParams

ORIGIN = np.array([0.0, 0.0, 0.3])


def _lattice(n: int = 8, spacing: float = 0.2):
    """Flat (n+1)² lattice at z = 0 starting at x = 0.2, one diagonal per cell."""
    ids = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    xx, yy = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    nodes = np.stack(
        [0.2 + xx.ravel() * spacing, (yy.ravel() - n / 2) * spacing, np.zeros(xx.size)], 1
    )
    edges = []
    for i in range(n + 1):
        for j in range(n + 1):
            if i < n:
                edges.append((ids[i, j], ids[i + 1, j]))
            if j < n:
                edges.append((ids[i, j], ids[i, j + 1]))
            if i < n and j < n:
                edges.append((ids[i, j], ids[i + 1, j + 1]))
    return nodes, np.array(edges, dtype=np.int64), ids


def _box_cloud(lo, hi, spacing=0.01, floor=((0.2, 1.8), (-0.8, 0.8)), floor_spacing=0.02):
    """Points of a floor (z = 0) and the top and four sides of an axis-aligned box on it."""
    fx = np.arange(*floor[0], floor_spacing)
    fy = np.arange(*floor[1], floor_spacing)
    gx, gy = np.meshgrid(fx, fy, indexing="ij")
    fl = np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], 1)
    inside = (fl[:, 0] >= lo[0]) & (fl[:, 0] <= hi[0]) & (fl[:, 1] >= lo[1]) & (fl[:, 1] <= hi[1])
    xs = np.arange(lo[0], hi[0] + 1e-9, spacing)
    ys = np.arange(lo[1], hi[1] + 1e-9, spacing)
    zs = np.arange(0.0, hi[2] + 1e-9, spacing)
    top = np.array([[x, y, hi[2]] for x in xs for y in ys])
    sides = [[x, y, z] for z in zs for x in xs for y in (lo[1], hi[1])]
    sides += [[x, y, z] for z in zs for y in ys for x in (lo[0], hi[0])]
    return np.concatenate([fl[~inside], top, np.array(sides)]).astype(np.float32)


# -- raised-node suspicion (AffordanceParams.raised_node_tolerance) -------------------------------


def test_one_raised_node_on_a_sparse_floor_is_a_suspected_object():
    nodes, edges, ids = _lattice()
    nodes[ids[4, 4], 2] = 0.04  # 4 cm up: its facets tilt at most atan(4·√2/20) = 15.8° < 20°
    off = detect_affordances(
        nodes, edges, ORIGIN, AffordanceParams(raised_node_tolerance=0.0), ground_z=0.0
    )
    assert off.obstacles == []  # too flat for the tilt test alone
    on = detect_affordances(nodes, edges, ORIGIN, ground_z=0.0)
    assert len(on.obstacles) == 1
    o = on.obstacles[0]
    assert o.suspected and math.isclose(o.height, 0.04, abs_tol=1e-9)
    # Its box is the raised node's fan: the node and its six lattice neighbours.
    assert np.allclose(o.box[:, :2], [[nodes[ids[3, 3], 0], nodes[ids[3, 3], 1]],
                                      [nodes[ids[5, 5], 0], nodes[ids[5, 5], 1]]])  # fmt: skip
    assert len(on.suspected_boxes) == 1


def test_raised_nodes_below_the_tolerance_stay_terrain():
    nodes, edges, ids = _lattice()
    nodes[ids[4, 4], 2] = 0.015
    assert detect_affordances(nodes, edges, ORIGIN).obstacles == []


def test_many_raised_facets_never_overflow_the_label_table():
    # Every other node raised: each raised facet may split the floor region (the label table is
    # sized for that; an undersized one corrupted the heap).
    nodes, edges, ids = _lattice(12, 0.1)
    rng = np.random.default_rng(0)
    nodes[:, 2] = np.where(rng.random(len(nodes)) < 0.5, 0.03, 0.0)
    res = detect_affordances(nodes, edges, ORIGIN, ground_z=0.0)
    assert len(res.objects) == len(set(res.facet_labels.tolist()))
    assert res.facet_labels.max() < len(res.objects)


# -- raw-point sizes ----------------------------------------------------------------------


def _refine(points, boxes, origin=ORIGIN, fwd=(1.0, 0.0), noise=0.0):
    points = np.ascontiguousarray(points)
    origin = np.asarray(origin, dtype=np.float64)
    slope, bins, edge = _k.view_edge_kernel(points, fwd[0], fwd[1], origin, 64, 4.0)
    return _k.refine_objects_kernel(
        points, np.ascontiguousarray(boxes, dtype=np.float64), 0.0, 0.02, 0.04, fwd[0], fwd[1],
        4, 0.0, 0.9, 0.03, origin, slope, bins, edge, noise,
        np.random.default_rng(0).standard_normal((64, 512)),
    )  # fmt: skip


def test_refine_grows_a_partial_box_to_the_raw_extent():
    lo, hi = (0.5, -0.1, 0.0), (0.7, 0.05, 0.07)
    pts = _box_cloud(lo, hi)
    # The graph's nodes covered only the middle of the block.
    row = _refine(pts, [[[0.58, -0.04, 0.0], [0.62, 0.0, 0.07]]])[0]
    assert row[0] > 100
    assert math.isclose(row[1], 0.07, abs_tol=1e-6)  # 90th height percentile: the top
    assert math.isclose(row[2], 0.15, abs_tol=0.011)  # across x: y extent 0.15
    assert math.isclose(row[3], 0.20, abs_tol=0.011)  # along x
    assert row[4] == pytest.approx(0.5, abs=0.011) and row[7] == pytest.approx(0.05, abs=0.011)
    assert row[8] > 0.1  # the block's top is well inside the view


def test_refine_finds_nothing_on_a_bare_floor():
    pts = _box_cloud((0.5, -0.1, 0.0), (0.7, 0.05, 0.07))
    pts = pts[pts[:, 2] <= 0.0]
    assert np.isnan(_refine(pts, [[[0.5, -0.1, 0.0], [0.7, 0.05, 0.07]]])[0]).all()


def test_refine_drops_isolated_stray_points():
    lo, hi = (0.5, -0.1, 0.0), (0.7, 0.05, 0.07)
    pts = _box_cloud(lo, hi)
    stray = np.array([[0.76, 0.0, 0.03], [0.6, 0.12, 0.03]], np.float32)  # 6–7 cm out
    row = _refine(np.concatenate([pts, stray]), [[[0.58, -0.04, 0.0], [0.62, 0.0, 0.07]]])[0]
    assert math.isclose(row[3], 0.20, abs_tol=0.011)
    assert math.isclose(row[2], 0.15, abs_tol=0.011)


def test_refine_flags_a_surface_cut_off_by_the_top_of_the_view():
    # A wall face at x = 1.0, seen up to 6 cm: its top points have the largest elevation of
    # their azimuth (nothing behind is seen), so the gap to the view's edge is 0.
    ys = np.arange(-0.5, 0.5, 0.02)
    floor = np.array([[x, y, 0.0] for x in np.arange(0.2, 1.0, 0.02) for y in ys])
    wall = np.array([[1.0, y, z] for z in np.arange(0.0, 0.061, 0.01) for y in ys])
    pts = np.concatenate([floor, wall]).astype(np.float32)
    row = _refine(pts, [[[0.95, -0.1, 0.0], [1.0, 0.1, 0.06]]])[0]
    assert row[8] == pytest.approx(0.0, abs=1e-9)


def _radial_noise(pts, rel, seed=0, origin=ORIGIN):
    """ToF range noise: each point moved along its ray by rel × its distance (Gaussian)."""
    d = pts.astype(np.float64) - origin
    z = np.random.default_rng(seed).standard_normal((len(pts), 1))
    return (origin + d * (1.0 + rel * z)).astype(np.float32)


def test_noise_level_reads_the_range_noise_off_the_floor():
    pts = _box_cloud((0.5, -0.1, 0.0), (0.7, 0.05, 0.07))
    for rel in (0.0, 0.005, 0.01, 0.02):
        sig = _k.noise_level_kernel(_radial_noise(pts, rel), 0.0, 0.02, ORIGIN[2])
        assert sig == pytest.approx(rel, rel=0.1, abs=1e-12)
    assert _k.noise_level_kernel(pts[:10], 0.0, 0.02, ORIGIN[2]) == 0.0  # too few points


def test_refine_takes_the_noise_overshoot_out_of_a_dense_noisy_extent():
    lo, hi = (0.5, -0.1, 0.0), (0.7, 0.05, 0.07)
    clean = _box_cloud(lo, hi, spacing=0.004)
    box = [[[0.58, -0.04, 0.0], [0.62, 0.0, 0.07]]]
    errs_off, errs_on = [], []
    for seed in range(5):
        noisy = _radial_noise(clean, 0.01, seed)
        sig = _k.noise_level_kernel(noisy, 0.0, 0.02, ORIGIN[2])
        assert sig == pytest.approx(0.01, rel=0.15)
        off, on = _refine(noisy, box)[0], _refine(noisy, box, noise=sig)[0]
        assert on[9] == sig and np.array_equal(off[:2], on[:2])
        assert on[3] <= off[3] and on[2] <= off[2]  # ends only ever move inwards
        errs_off.append(off[3] - 0.20)
        errs_on.append(on[3] - 0.20)
    # The outermost of the many noisy points on the faces at both ends (this cloud has all
    # four sides) overshoot the 20 cm length by ~3.7 cm; the correction takes about half of it
    # out (a quadratic SIMEX extrapolation of a maximum under-corrects).
    assert np.median(errs_off) > 0.02
    assert 0.0 < np.median(errs_on) < 0.65 * np.median(errs_off)
    # Sparse points (2 cm apart, noise 0.5–0.7 cm along the length): the ends stay.
    sparse = _radial_noise(_box_cloud(lo, hi, spacing=0.02), 0.01)
    assert np.array_equal(_refine(sparse, box)[0, :9], _refine(sparse, box, noise=0.01)[0, :9])


def _wall_foot_cloud(wall_y=(-0.5, 0.5), seen=0.06):
    """A floor up to x = 1.0 (the top of the view there) and the foot of a wall at x = 1.0,
    seen up to ``seen`` across ``wall_y``: the view's upper edge cuts it off."""
    ys = np.arange(-0.5, 0.5, 0.02)
    floor = np.array([[x, y, 0.0] for x in np.arange(0.2, 1.0, 0.02) for y in ys])
    wy = ys[(ys >= wall_y[0]) & (ys <= wall_y[1])]
    wall = np.array([[1.0, y, z] for z in np.arange(0.0, seen + 1e-9, 0.01) for y in wy])
    return np.concatenate([floor, wall]).astype(np.float32)


def _view_walls(pts, min_width=0.3):
    slope, bins, edge = _k.view_edge_kernel(pts, 1.0, 0.0, ORIGIN, 64, 4.0)
    return _k.view_walls_kernel(pts, 0.0, 0.02, 1.0, 0.0, slope, bins, edge, 0.02, min_width, 8)


def test_view_walls_finds_a_wide_strip_cut_off_by_the_top_of_the_view():
    runs = _view_walls(_wall_foot_cloud())
    assert runs.shape == (1, 11)
    n, top, x0, y0, x1, y1 = runs[0, :6]
    assert n >= 8 and top == pytest.approx(0.06, abs=1e-6)
    assert x0 == pytest.approx(1.0, abs=1e-6) and x1 == pytest.approx(1.0, abs=1e-6)
    assert y0 <= -0.45 and y1 >= 0.45 and runs[0, 9] >= 0.9


def test_view_walls_ignores_floors_boxes_in_sight_and_narrow_cut_surfaces():
    floor = _wall_foot_cloud(seen=0.0)
    assert _view_walls(floor[floor[:, 2] <= 0.0]).shape == (0, 11)
    # A box whose top is in sight: the floor behind it is higher in the view.
    assert _view_walls(_box_cloud((0.5, -0.1, 0.0), (0.7, 0.05, 0.07))).shape == (0, 11)
    # A 20 cm wide surface cut off by the view (a box at the far edge): narrower than a run.
    narrow = _wall_foot_cloud(wall_y=(-0.1, 0.1))
    assert _view_walls(narrow).shape == (0, 11)
    assert _view_walls(narrow, min_width=0.1).shape[0] == 1


def test_pipeline_adds_a_wall_the_graph_misses_and_keeps_its_labels():
    nodes, edges, _ = _lattice(4, 0.2)  # a flat floor graph up to x = 1.0: all terrain
    aff = detect_affordances(nodes, edges, ORIGIN, ground_z=0.0)
    assert set(aff.label_kinds) == {"terrain"}
    pts = _wall_foot_cloud()
    out = AttentionPipeline()._view_walls(aff, pts, (1.0, 0.0, 0.0), ORIGIN)
    assert out.objects[: len(aff.objects)] == aff.objects
    (wall,) = out.walls
    assert out.label_kinds == tuple(o.kind for o in out.objects)
    assert wall.n_nodes == 0 and not wall.suspected and wall.gamma == pytest.approx(math.pi / 2)
    assert wall.height == pytest.approx(0.06, abs=1e-6) and wall.width >= 0.9
    assert wall.box[0, 0] == pytest.approx(1.0, abs=1e-6) and wall.box[0, 2] == 0.0
    assert wall.normal == pytest.approx([-1.0, 0.0, 0.0], abs=0.02)
    assert out.facet_labels is aff.facet_labels and out.obstacles == []
    # A wall label already overlapping it is not doubled; the rule can be switched off.
    again = AttentionPipeline()._view_walls(out, pts, (1.0, 0.0, 0.0), ORIGIN)
    assert len(again.walls) == 1
    off = AttentionPipeline(params=PipelineParams(view_wall_width=0.0))
    for k in range(3):
        off.step(pts, ORIGIN, 0.01 * k)
        assert off.last.walls == []


# -- the pipeline ----------------------------------------------------------------------


def _block_graph():
    """A dense GNG-like lattice over a 20 × 15 × 7 cm block (nodes inside its edges)."""
    from neurocog_gym.perception.affordance import synthetic_scene_graph

    return synthetic_scene_graph(
        0.04, box_min=(0.5, -0.1, 0.0), box_max=(0.7, 0.05, 0.07), wall_x=None
    )


def test_pipeline_sizes_come_from_the_raw_points():
    scene = _block_graph()
    pts = _box_cloud((0.5, -0.1, 0.0), (0.7, 0.05, 0.07))
    on = AttentionPipeline()
    a_on = on._refine(detect_affordances(scene.nodes, scene.edges, scene.sensor_origin), pts,
                      (1.0, 0.0, 0.0), scene.sensor_origin)  # fmt: skip
    a_off = detect_affordances(scene.nodes, scene.edges, scene.sensor_origin)
    o_on = max(a_on.obstacles, key=lambda o: o.n_nodes)
    o_off = max(a_off.obstacles, key=lambda o: o.n_nodes)
    assert abs(o_on.height - 0.07) <= 0.005
    assert abs(o_on.length - 0.20) <= 0.02 and abs(o_on.width - 0.15) <= 0.02
    # The graph's own sizes fall short where the lattice nodes stop inside the block's edges.
    assert o_off.length <= o_on.length


def test_pipeline_relabels_an_object_without_raw_points_as_terrain():
    scene = _block_graph()
    pts = _box_cloud((0.5, -0.1, 0.0), (0.7, 0.05, 0.07))
    floor_only = np.ascontiguousarray(pts[pts[:, 2] <= 0.0])
    pipe = AttentionPipeline()
    aff = detect_affordances(scene.nodes, scene.edges, scene.sensor_origin)
    assert aff.obstacles
    out = pipe._refine(aff, floor_only, (1.0, 0.0, 0.0), scene.sensor_origin)
    assert out.obstacles == []
    assert out.label_kinds == tuple(o.kind for o in out.objects)
    assert len(out.suspected_boxes) == 0
    kept = AttentionPipeline(params=PipelineParams(verify=False))._refine(
        aff, floor_only, (1.0, 0.0, 0.0), scene.sensor_origin
    )
    assert len(kept.obstacles) == len(aff.obstacles)


def test_pipeline_step_runs_end_to_end_and_keeps_its_public_surface():
    pts = _box_cloud((0.5, -0.1, 0.0), (0.7, 0.05, 0.07))
    pipe = AttentionPipeline(seed=1)
    for k in range(60):
        aff = pipe.step(pts, ORIGIN, 0.01 * k)
    assert set(pipe.timings) >= {"gng", "affordance", "total"}
    assert pipe.last is aff and pipe.n_steps == 60
    assert pipe.attention_boxes.shape[1:] == (2, 3)
    for o in aff.objects:
        assert o.kind in ("terrain", "wall", "object")
        assert np.all(np.isfinite(o.box))


def test_warm_up_is_the_same_as_stepping_on_the_frame_cycle_by_cycle():
    pts = _box_cloud((0.5, -0.1, 0.0), (0.7, 0.05, 0.07))
    stepped, warmed = AttentionPipeline(seed=3), AttentionPipeline(seed=3)
    for _ in range(80):
        a_step = stepped.step(pts, ORIGIN, 0.0)
    a_warm = warmed.warm_up(pts, ORIGIN, 80)
    # The raw-point steps ran (the block is refined), so the shared view was used.
    assert any(o.kind == "object" for o in a_warm.objects)
    np.testing.assert_array_equal(warmed.net.nodes, stepped.net.nodes)
    np.testing.assert_array_equal(warmed.attention_boxes, stepped.attention_boxes)
    assert [(o.kind, o.height, o.width, o.length) for o in a_warm.objects] == [
        (o.kind, o.height, o.width, o.length) for o in a_step.objects
    ]
    assert warmed.n_steps == stepped.n_steps == 80
    assert AttentionPipeline().warm_up(pts, ORIGIN, 0) is None
    with pytest.raises(ValueError, match="cycles must be >= 0"):
        AttentionPipeline().warm_up(pts, ORIGIN, -1)


@pytest.mark.parametrize("bad", [np.zeros((0, 3), np.float32), np.full((5, 3), np.nan)])
def test_pipeline_refine_tolerates_degenerate_frames(bad):
    scene = _block_graph()
    aff = detect_affordances(scene.nodes, scene.edges, scene.sensor_origin)
    out = AttentionPipeline()._refine(aff, bad, (1.0, 0.0, 0.0), scene.sensor_origin)
    assert len(out.objects) == len(aff.objects)
    assert all(np.all(np.isfinite(o.box)) for o in out.objects)
