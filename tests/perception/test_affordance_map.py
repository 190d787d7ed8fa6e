"""The "map" affordance source: sizes from the DD-GNG nodes and facets alone (issue 23).

pipeline.AttentionPipeline._detect_map, _affordance_kernels.map_step_kernel and
map_objects_kernel, the ``affordance_source`` keyword (pipeline and env) and
scripts/bench_affordance_map.py.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from neurocog_gym.perception import _affordance_kernels as _k
from neurocog_gym.perception.affordance import AffordanceObject, Affordances, detect_affordances
from neurocog_gym.perception.pipeline import AttentionPipeline, PipelineParams

ROOT = Path(__file__).resolve().parents[2]
ORIGIN = np.array([0.0, 0.0, 0.3])


def _top_grid():
    """A 3 × 3 grid of nodes 5 cm apart at z = 6 cm (x 0.60–0.70, y -0.05–0.05), one floor
    node at (0.5, 0, 0); the 8 triangles of the grid (one diagonal per cell)."""
    xs, ys = (0.60, 0.65, 0.70), (-0.05, 0.0, 0.05)
    nodes = [[x, y, 0.06] for x in xs for y in ys] + [[0.5, 0.0, 0.0]]
    ids = np.arange(9).reshape(3, 3)
    edges, facets = [], []
    for i in range(3):
        for j in range(3):
            if i < 2:
                edges.append((ids[i, j], ids[i + 1, j]))
            if j < 2:
                edges.append((ids[i, j], ids[i, j + 1]))
            if i < 2 and j < 2:
                edges.append((ids[i, j], ids[i + 1, j + 1]))
                facets.append((ids[i, j], ids[i + 1, j], ids[i + 1, j + 1]))
                facets.append((ids[i, j], ids[i + 1, j + 1], ids[i, j + 1]))
    edges.append((9, ids[0, 1]))  # the floor node, not on any facet of the group
    return (
        np.array(nodes, dtype=np.float64),
        np.array(edges, dtype=np.int64),
        np.array(facets, dtype=np.int64),
    )


def test_map_objects_kernel_hand_computed_measures():
    nodes, edges, facets = _top_grid()
    slope, bins, edge = _k.view_edge_kernel(nodes, 1.0, 0.0, ORIGIN, 16, 4.0)
    res = _k.map_objects_kernel(
        nodes, edges, facets, np.zeros(len(facets), np.int64), 1, 0.0, 0.02, 1.0, 0.0,
        slope, bins, edge,
    )  # fmt: skip
    r = res[0]
    assert r[_k.M_NNODES] == 9 and r[_k.M_NHIGH] == 9  # the floor node is on no facet
    assert r[_k.M_HEIGHT] == pytest.approx(0.06)
    # along x (forward) 0.70 - 0.60, across 0.05 - (-0.05)
    assert r[_k.M_F1] - r[_k.M_F0] == pytest.approx(0.10)
    assert r[_k.M_L1] - r[_k.M_L0] == pytest.approx(0.10)
    # 12 grid edges of 0.05 m and 4 diagonals of 0.0707 m: the median is 0.05
    assert r[_k.M_SPACING] == pytest.approx(0.05)
    np.testing.assert_allclose(r[_k.M_BOX : _k.M_BOX + 6], [0.6, -0.05, 0.06, 0.7, 0.05, 0.06])
    # all nine are high: the high nodes' box is the same in the ground plane
    np.testing.assert_allclose(r[_k.M_HBOX : _k.M_HBOX + 4], [0.6, -0.05, 0.7, 0.05])
    # The floor node (slope (0 - 0.3) / 0.5 = -0.6) shares the central bin with the grid;
    # the grid's nearest row (slope (0.06 - 0.3) / 0.6 = -0.4) is the highest there: margin 0.
    assert r[_k.M_VIEW] == pytest.approx(0.0)


def test_map_objects_kernel_beyond_62_groups_measures_the_same():
    # Above 62 groups the edge pass runs once per group instead of on bit masks: the grid as
    # group 0 of 63 (groups 1..62 with no facet) has the same measures as alone.
    nodes, edges, facets = _top_grid()
    slope, bins, edge = _k.view_edge_kernel(nodes, 1.0, 0.0, ORIGIN, 16, 4.0)
    fgroup = np.zeros(len(facets), np.int64)
    one, many = (
        _k.map_objects_kernel(
            nodes, edges, facets, fgroup, g, 0.0, 0.02, 1.0, 0.0, slope, bins, edge
        )
        for g in (1, 63)
    )
    np.testing.assert_array_equal(many[0], one[0])
    assert many[0, _k.M_SPACING] == pytest.approx(0.05)
    assert (many[1:, _k.M_NNODES] == 0).all() and (many[1:, _k.M_SPACING] == 0).all()


def test_map_objects_kernel_without_high_nodes_gives_nan_extents():
    nodes, edges, facets = _top_grid()
    nodes = nodes.copy()
    nodes[:, 2] = 0.0
    slope, bins, edge = _k.view_edge_kernel(nodes, 1.0, 0.0, ORIGIN, 16, 4.0)
    res = _k.map_objects_kernel(
        nodes, edges, facets, np.zeros(len(facets), np.int64), 1, 0.0, 0.02, 1.0, 0.0,
        slope, bins, edge,
    )  # fmt: skip
    assert res[0, _k.M_NNODES] == 9 and res[0, _k.M_NHIGH] == 0
    assert math.isnan(res[0, _k.M_HEIGHT]) and math.isnan(res[0, _k.M_F0])
    assert res[0, _k.M_SPACING] == 0.0


def test_floor_level_is_the_median_of_the_terrain_facets_nodes():
    # Terrain facets (label 0) over nodes at z 0, 0, 0.01, 0.002 (node 3 on two facets, counted
    # once) and an object facet (label 1) over nodes at 0.06: median of (0, 0, 0.002, 0.01)
    # = (0 + 0.002) / 2 = 0.001. Without terrain the given level comes back.
    nodes = np.array(
        [[0, 0, 0], [1, 0, 0], [0, 1, 0.01], [1, 1, 0.002], [2, 2, 0.06], [2, 3, 0.06]], float
    )
    facets = np.array([[0, 1, 3], [0, 3, 2], [3, 4, 5]], np.int64)
    lab = np.zeros((2, _k.N_LABEL_COLS))
    lab[0, _k.L_KIND], lab[1, _k.L_KIND] = _k.KIND_TERRAIN, _k.KIND_OBJECT
    flabels = np.array([0, 0, 1], np.int64)
    assert _k.floor_level(nodes, facets, flabels, lab, 0.5) == pytest.approx(0.001)
    assert _k.floor_level(nodes, facets, np.array([1, 1, 1], np.int64), lab, 0.5) == 0.5


def _two_labels():
    """Map-step inputs by hand: label 0, the 3 × 3 grid of :func:`_top_grid` (a block top
    6 cm up, x 0.60–0.70) with the floor node on one more facet; label 1, the same grid moved
    to x 1.00–1.10 (the graph's farthest nodes: a wall's foot at the view edge). Their boxes
    overlap in the ground plane (label 1's box is given wide, as a wall foot's is)."""
    top, edges0, facets0 = _top_grid()
    far = top[:9] + np.array([0.4, 0.0, 0.0])
    nodes = np.vstack([top, far])
    edges = np.vstack([edges0, edges0[:-1] + 10])
    facets = np.vstack([facets0, [[9, 0, 1]], facets0 + 10])
    flabels = np.array([0] * 9 + [1] * 8, np.int64)
    lab = np.zeros((2, _k.N_LABEL_COLS))
    lab[:, _k.L_KIND] = _k.KIND_OBJECT
    lab[:, _k.L_SIZE] = 0.01
    box = np.array([[[0.5, -0.05, 0.0], [0.7, 0.05, 0.06]], [[0.55, -1.0, 0.0], [1.1, 1.0, 0.06]]])
    return nodes, edges, facets, flabels, lab, box


def _map_step(params, inputs):
    nodes, edges, facets, flabels, lab, box = inputs
    pipe = AttentionPipeline(params=params)
    ap = pipe.affordance_params
    return _k.map_step_kernel(
        nodes, edges, ORIGIN, 1.0, 0.0, 0.0, facets, flabels, lab, np.zeros((2, 3)),
        np.zeros((2, 3)), box, ap.packed, pipe.params.map_packed,
    )  # fmt: skip


def test_map_view_first_keeps_a_block_out_of_the_wall_foot_in_its_box():
    inputs = _two_labels()
    olab, *_ = _map_step(PipelineParams(affordance_source="map", map_view_first=True), inputs)
    # the block stays an object, the far strip is relabelled wall
    assert olab[:, _k.L_KIND].tolist() == [_k.KIND_OBJECT, _k.KIND_WALL]
    olab, *_ = _map_step(PipelineParams(affordance_source="map", map_view_first=False), inputs)
    # merged first (the boxes overlap), the pair reaches the view edge: one wall
    assert olab[:, _k.L_KIND].tolist() == [_k.KIND_WALL]


def test_map_box_from_high_is_algorithm_3s_box_on_the_block():
    # Label 0: high nodes x 0.60–0.70, y ±0.05, spacing 0.05, the floor node at x 0.5 on one
    # facet. Correction 1.5 × 0.05 = 0.075, half of it 0.0375 on each side.
    inputs = _two_labels()
    p = PipelineParams(affordance_source="map", map_box_from_high=True)
    _, _, _, obox, *_ = _map_step(p, inputs)
    np.testing.assert_allclose(obox[0, :, :2], [[0.5625, -0.0875], [0.7375, 0.0875]])
    assert obox[0, 0, 2] == 0.0  # the floor node keeps the box's foot
    p = PipelineParams(affordance_source="map", map_box_from_high=False)
    _, _, _, obox, *_ = _map_step(p, inputs)
    # all the label's nodes: the floor node at x 0.5 widens it
    np.testing.assert_allclose(obox[0, :, :2], [[0.4625, -0.0875], [0.7375, 0.0875]])


def test_affordance_source_is_validated():
    with pytest.raises(ValueError, match="affordance_source"):
        PipelineParams(affordance_source="raw")
    with pytest.raises(ValueError, match="affordance_source"):
        AttentionPipeline(affordance_source="graph")
    with pytest.raises(ValueError, match="map_edge_correction"):
        PipelineParams(map_edge_correction=-1.0)
    with pytest.raises(ValueError, match="map_view_bins"):
        PipelineParams(map_view_bins=0)
    assert PipelineParams().affordance_source == "points"  # today's behaviour by default
    assert AttentionPipeline(affordance_source="map").params.affordance_source == "map"


def _box_frame(rng):
    """A floor (z = 0, x 0.2–1.4, y ±0.6) and a 20 × 20 × 7 cm box at x 0.6–0.8, y ±0.1."""
    fl = np.column_stack(
        [rng.uniform(0.2, 1.4, 6000), rng.uniform(-0.6, 0.6, 6000), np.zeros(6000)]
    )
    fl = fl[~((fl[:, 0] > 0.6) & (fl[:, 0] < 0.8) & (np.abs(fl[:, 1]) < 0.1))]
    top = np.column_stack(
        [rng.uniform(0.6, 0.8, 1500), rng.uniform(-0.1, 0.1, 1500), np.full(1500, 0.07)]
    )
    front = np.column_stack(
        [np.full(500, 0.6), rng.uniform(-0.1, 0.1, 500), rng.uniform(0.0, 0.07, 500)]
    )
    return np.concatenate([fl, top, front])


def _run(source, monkeypatch=None, cycles=300, params=None):
    rng = np.random.default_rng(0)
    pipe = AttentionPipeline(seed=3, affordance_source=source, params=params)
    pts = _box_frame(rng)
    aff = None
    for c in range(cycles):
        aff = pipe.step(pts, ORIGIN, 0.01 * c)
    return pipe, aff


def test_map_mode_reads_no_raw_points(monkeypatch):
    def boom(*_a, **_k):
        raise AssertionError("a raw-point kernel ran in map mode")

    for name in ("refine_objects_kernel", "noise_level_kernel", "view_walls_kernel"):
        monkeypatch.setattr(_k, name, boom)
    pipe, aff = _run("map")
    assert aff.obstacles, "the box is found on the map"
    assert pipe.timings["refine"] >= 0.0


def test_map_mode_sizes_are_the_high_nodes_extents_plus_the_spacing_correction():
    pipe, aff = _run("map", params=PipelineParams(map_rect=False))
    nodes, edges = pipe.net.nodes, pipe.net.edges
    tol = pipe.affordance_params.ground_tolerance
    c = pipe.params.map_edge_correction
    checked = 0
    for k, o in enumerate(aff.objects):
        if o.kind != "object":
            continue
        ids = np.unique(aff.facets[aff.facet_labels == k])
        hi = ids[nodes[ids, 2] > aff.ground_z + tol]
        if len(hi) < 2:
            continue
        both = np.isin(edges[:, 0], hi) & np.isin(edges[:, 1], hi)
        d = nodes[edges[both, 0], :2] - nodes[edges[both, 1], :2]
        s = float(np.median(np.hypot(d[:, 0], d[:, 1]))) if both.any() else 0.0
        # forward is +x: length along x, width along y
        assert o.length == pytest.approx(np.ptp(nodes[hi, 0]) + c * s, abs=1e-9)
        assert o.width == pytest.approx(np.ptp(nodes[hi, 1]) + c * s, abs=1e-9)
        assert o.height == pytest.approx(nodes[hi, 2].max() - aff.ground_z, abs=1e-9)
        assert o.n_nodes == len(ids)
        assert o.density == pytest.approx(len(ids) / o.size)
        assert o.suspected == (o.density < pipe.affordance_params.density_threshold)
        checked += 1
    assert checked >= 1
    # every facet keeps a valid label after the merge
    assert aff.facet_labels.min() >= 0 and aff.facet_labels.max() < len(aff.objects)
    assert aff.label_kinds == tuple(o.kind for o in aff.objects)


def _same(a, b):
    """Two Affordances with the same objects, facets and labels (arrays exactly equal)."""
    assert a.label_kinds == b.label_kinds and len(a.objects) == len(b.objects)
    for x, y in zip(a.objects, b.objects, strict=True):
        for f in x._fields:
            np.testing.assert_array_equal(getattr(x, f), getattr(y, f), err_msg=f)
    np.testing.assert_array_equal(a.facets, b.facets)
    np.testing.assert_array_equal(a.facet_labels, b.facet_labels)
    np.testing.assert_array_equal(a.suspected_boxes, b.suspected_boxes)


def test_detect_repeats_the_steps_affordances_on_the_same_graph():
    # map mode: the graph alone; points mode: the same frame's raw points
    for source in ("map", "points"):
        pipe, aff = _run(source, cycles=150)
        memory = pipe.memory_boxes.copy()
        pts = _box_frame(np.random.default_rng(0))
        again = pipe.detect(ORIGIN, points=None if source == "map" else pts)
        _same(again, aff)
        assert any(o.kind == "object" for o in again.objects)
        assert pipe.last is aff and pipe.n_steps == 150  # nothing learned or remembered
        np.testing.assert_array_equal(pipe.memory_boxes, memory)
    # points mode without the frame keeps the graph's measures: the map's own node extents
    pipe, aff = _run("points", cycles=150)
    raw = pipe.detect(ORIGIN)
    assert [o.kind for o in raw.objects] == [o.kind for o in aff.objects]
    assert any(
        o.kind == "object" and (r.length != o.length or r.width != o.width)
        for r, o in zip(raw.objects, aff.objects, strict=True)
    ), "the refinement changed the sizes on the step, not on detect without points"


class _Frozen:
    """A graph standing in for a pipeline's net."""

    def __init__(self, nodes, edges):
        self.nodes, self.edges = nodes, edges


def _graphs():
    """Graphs of a map-mode run on the box frame (every 7th cycle of 300), each with forward
    +x and a slanted one, and one with two overlapping pieces forced to merge."""
    rng = np.random.default_rng(0)
    pipe = AttentionPipeline(seed=3, affordance_source="map")
    pts = _box_frame(rng)
    out = []
    for c in range(300):
        pipe.step(pts, ORIGIN, 0.01 * c)
        if c % 7 == 0:
            out.append((pipe.net.nodes.copy(), pipe.net.edges.copy()))
    return out


@pytest.mark.parametrize(
    "merge, new_steps", [(True, True), (False, True), (True, False), (False, False)]
)
def test_compiled_map_steps_equal_the_numpy_oracle(merge, new_steps):
    params = PipelineParams(
        affordance_source="map", map_merge=merge, map_view_first=new_steps,
        map_box_from_high=new_steps, map_floor_plane=new_steps, map_rect=False,
    )  # fmt: skip
    pipe = AttentionPipeline(affordance_source="map", params=params)
    checked = merged = 0
    for nodes, edges in _graphs():
        pipe.net = _Frozen(nodes, edges)
        for fwd in ((1.0, 0.0, 0.0), (0.6, 0.8, 0.0)):
            got = pipe.detect(ORIGIN, fwd)
            aff = detect_affordances(nodes, edges, ORIGIN, pipe.affordance_params, forward=fwd)
            if not (aff.obstacles and math.isfinite(aff.ground_z)):
                continue
            want = _map_objects_oracle(pipe, aff, ORIGIN, fwd)
            _same(got, want)
            assert got.ground_z == want.ground_z and got.truncated == want.truncated
            checked += 1
            merged += len(got.objects) < len(aff.objects)  # two labels became one
    assert checked >= 40
    if merge:
        assert merged > 0, "no graph merged two pieces: the merge path went untested"


def _map_objects_oracle(self, aff, sensor_origin, forward):
    """NumPy oracle of the map-mode steps: the Python code they were before they were compiled
    (``AttentionPipeline._detect_map``, ``map_step_kernel``), on ``detect_affordances``'s
    result; ``self`` is the pipeline."""
    p = self.params
    ap = self.affordance_params
    objs = [k for k, o in enumerate(aff.objects) if o.kind == "object"]
    nodes, edges = self.net.nodes, self.net.edges
    fwd = np.asarray(forward, dtype=np.float64).reshape(-1)
    h = math.hypot(float(fwd[0]), float(fwd[1]))
    origin = np.asarray(sensor_origin, dtype=np.float64).reshape(-1)
    if h < 1e-9 or origin.shape != (3,) or len(nodes) == 0:
        return aff
    fx, fy = float(fwd[0]) / h, float(fwd[1]) / h
    ground = float(aff.ground_z)
    if p.map_floor_plane:
        terrain = [k for k, o in enumerate(aff.objects) if o.kind == "terrain"]
        ids = np.unique(aff.facets[np.isin(aff.facet_labels, terrain)])
        if len(ids):
            ground = float(np.median(nodes[ids, 2]))
    slope, bins, edge = _k.view_edge_kernel(nodes, fx, fy, origin, p.map_view_bins, 4.0)
    # The view edge of each object label alone: a label there is merged with none.
    at_edge = [False] * len(objs)
    if p.map_view_first and p.map_merge and p.map_view_cut >= 0.0:
        single = np.full(len(aff.objects), -1, np.int64)
        single[objs] = np.arange(len(objs))
        one = _k.map_objects_kernel(
            nodes, edges, aff.facets, single[aff.facet_labels], len(objs), ground,
            ap.ground_tolerance, fx, fy, slope, bins, edge,
        )  # fmt: skip
        at_edge = [bool(r[_k.M_NHIGH] > 0 and r[_k.M_VIEW] <= p.map_view_cut) for r in one]
    # Union of overlapping object boxes (a handful of objects: plain loops).
    root = list(range(len(objs)))

    def find(a):
        while root[a] != a:
            a = root[a]
        return a

    if p.map_merge:
        for a in range(len(objs)):
            ba = aff.objects[objs[a]].box
            for b in range(a + 1, len(objs)):
                bb = aff.objects[objs[b]].box
                if at_edge[a] or at_edge[b]:
                    continue
                if (ba[0, 0] <= bb[1, 0] and bb[0, 0] <= ba[1, 0]
                        and ba[0, 1] <= bb[1, 1] and bb[0, 1] <= ba[1, 1]):  # fmt: skip
                    root[find(b)] = find(a)
    gids: dict[int, int] = {}
    members: list[list[int]] = []
    label_group = np.full(len(aff.objects), -1, np.int64)
    for a, k in enumerate(objs):
        r = find(a)
        if r not in gids:
            gids[r] = len(members)
            members.append([])
        label_group[k] = gids[r]
        members[gids[r]].append(k)
    fgroup = label_group[aff.facet_labels]
    res = _k.map_objects_kernel(
        nodes, edges, aff.facets, fgroup, len(members), ground,
        ap.ground_tolerance, fx, fy, slope, bins, edge,
    )  # fmt: skip
    counts = np.bincount(aff.facet_labels, minlength=len(aff.objects))
    new_of = np.full(len(aff.objects), -1, np.int64)
    objects: list[AffordanceObject] = []
    for k, o in enumerate(aff.objects):
        gi = int(label_group[k])
        if gi < 0:
            new_of[k] = len(objects)
            objects.append(o)
            continue
        ks = members[gi]
        if k != ks[0]:
            continue  # merged into the group's first label
        for q in ks:
            new_of[q] = len(objects)
        row = res[gi]
        if len(ks) > 1:
            wsum = float(counts[ks].sum())
            pos = sum(aff.objects[q].position * counts[q] for q in ks) / wsum
            nsum = sum(aff.objects[q].normal * counts[q] for q in ks)
            nn = float(np.linalg.norm(nsum))
            normal = nsum / nn if nn > 1e-12 else np.zeros(3)
            gamma = math.acos(min(1.0, max(-1.0, float(normal[2])))) if nn > 1e-12 else 0.0
            size = float(sum(aff.objects[q].size for q in ks))
            o = o._replace(position=pos, normal=normal, gamma=gamma, size=size)
        n_nodes = int(row[_k.M_NNODES])
        if n_nodes == 0:
            objects.append(o)
            continue
        density = n_nodes / o.size if o.size > 0 else 0.0
        box = row[_k.M_BOX : _k.M_BOX + 6].reshape(2, 3).copy()
        if row[_k.M_NHIGH] > 0:
            c = p.map_edge_correction * float(row[_k.M_SPACING])
            if p.map_box_from_high:
                box[:, :2] = row[_k.M_HBOX : _k.M_HBOX + 4].reshape(2, 2)
            box[0, :2] -= 0.5 * c
            box[1, :2] += 0.5 * c
            o = o._replace(
                height=float(row[_k.M_HEIGHT]),
                width=float(row[_k.M_L1] - row[_k.M_L0]) + c,
                length=float(row[_k.M_F1] - row[_k.M_F0]) + c,
            )
        o = o._replace(
            n_nodes=n_nodes,
            density=density,
            box=box,
            suspected=density < ap.density_threshold,
        )
        if p.map_view_cut >= 0.0 and row[_k.M_VIEW] <= p.map_view_cut and o.height >= p.min_height:
            o = o._replace(kind="wall", suspected=False)
        objects.append(o)
    pad = ap.suspect_padding
    sboxes = np.array(
        [
            o.box + np.array([[-pad] * 3, [pad] * 3])
            for o in objects
            if o.kind == "object" and o.suspected
        ]  # fmt: skip
    ).reshape(-1, 2, 3)
    return Affordances(
        objects, sboxes, aff.facets, aff.facet_normals, new_of[aff.facet_labels],
        tuple(o.kind for o in objects), ground, aff.truncated,
    )  # fmt: skip


def test_points_mode_is_the_default_and_unchanged():
    a_pipe, a = _run(None, cycles=120)
    b_pipe, b = _run("points", cycles=120)
    np.testing.assert_array_equal(a_pipe.net.nodes, b_pipe.net.nodes)
    assert [(o.kind, o.height, o.width, o.length) for o in a.objects] == [
        (o.kind, o.height, o.width, o.length) for o in b.objects
    ]


def test_map_mode_relabels_a_surface_at_the_top_of_the_graphs_view_as_wall():
    # A strip of nodes 1.0 m ahead, 5 cm up, beyond the floor: the farthest (highest-elevation)
    # nodes of the graph in their azimuth, so the foot of something out of sight.
    pipe, aff = _run("map", cycles=1)
    assert pipe.params.map_view_cut == 0.02  # tan, ≈ 1.1° below the view edge
    nodes, edges, facets = _top_grid()
    nodes = nodes + np.array([0.4, 0.0, 0.0])  # x 1.0–1.1: the farthest nodes
    slope, bins, edge = _k.view_edge_kernel(nodes, 1.0, 0.0, ORIGIN, 16, 4.0)
    res = _k.map_objects_kernel(
        nodes, edges, facets, np.zeros(len(facets), np.int64), 1, 0.0, 0.02, 1.0, 0.0,
        slope, bins, edge,
    )  # fmt: skip
    assert res[0, _k.M_VIEW] <= pipe.params.map_view_cut


def test_env_passes_affordance_source_through_gymnasium_make():
    import gymnasium as gym

    import neurocog_gym  # noqa: F401

    env = gym.make("NeuroCog/SuddenObstacle-v3", affordance_source="map")
    try:
        assert env.unwrapped.pipeline.params.affordance_source == "map"
    finally:
        env.close()
    env = gym.make("NeuroCog/SuddenObstacle-v3")
    try:
        assert env.unwrapped.pipeline.params.affordance_source == "points"
    finally:
        env.close()
    with pytest.raises(ValueError, match="affordance_source"):
        gym.make("NeuroCog/SuddenObstacle-v3", affordance_source="raw")


@pytest.mark.slow
def test_bench_affordance_map_runs_end_to_end(tmp_path):
    out = tmp_path / "table.md"
    r = subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "bench_affordance_map.py"), "--scenes", "1",
         "--pipelines", "DD-GNG, map", "GNG, map", "--out", str(out)],
        capture_output=True, text=True, cwd=ROOT, timeout=300,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    text = out.read_text()
    assert "| DD-GNG, map |" in text and "| GNG, map |" in text and "Machine:" in text


def test_min_area_rect_hand_computed():
    # A 0.2 × 0.1 m rectangle turned 30° from the walking direction, its four corners and
    # two points inside: the rectangle itself, a = 0.2, b = 0.1, |cos 30°|, |sin 30°|.
    c, s = math.cos(math.radians(30.0)), math.sin(math.radians(30.0))
    local = np.array(
        [[0.1, 0.05], [-0.1, 0.05], [-0.1, -0.05], [0.1, -0.05], [0.0, 0.0], [0.05, 0.02]]
    )
    pf = 0.6 + local[:, 0] * c - local[:, 1] * s
    pl = 0.1 + local[:, 0] * s + local[:, 1] * c
    a, b, rc, rs = _k.min_area_rect(pf, pl, len(pf), np.empty(3 * len(pf) + 2, np.int64))
    assert (a, b) == (pytest.approx(0.2), pytest.approx(0.1))
    assert (rc, rs) == (pytest.approx(c), pytest.approx(s))
    # Its extents on the walking axes: 0.2 cos 30° + 0.1 sin 30° = 0.2232 along,
    # 0.2 sin 30° + 0.1 cos 30° = 0.1866 across, the same as the corners' own extents.
    assert a * rc + b * rs == pytest.approx(np.ptp(pf)) == pytest.approx(0.22321, abs=1e-5)
    assert a * rs + b * rc == pytest.approx(np.ptp(pl)) == pytest.approx(0.18660, abs=1e-5)
    hull = np.empty(8, np.int64)  # 3k + 2 for k = 2
    # one point: no rectangle; two: the segment (0.3, 0.4 → 0.5 long, 0 wide, cos 0.6)
    assert _k.min_area_rect(np.array([0.5]), np.array([0.1]), 1, hull) == (0.0, 0.0, 1.0, 0.0)
    a, b, rc, rs = _k.min_area_rect(np.array([0.0, 0.3]), np.array([0.0, 0.4]), 2, hull)
    assert (a, b) == (pytest.approx(0.5), pytest.approx(0.0))
    assert (rc, rs) == (pytest.approx(0.6), pytest.approx(0.8))
    # three collinear points and a repeated one: still the segment
    a, b, _, _ = _k.min_area_rect(
        np.array([0.0, 0.1, 0.2, 0.2]), np.array([0.0, 0.0, 0.0, 0.0]), 4, np.empty(14, np.int64)
    )
    assert (a, b) == (pytest.approx(0.2), pytest.approx(0.0))


def test_group_rect_leaves_out_the_low_high_nodes():
    # The 3 × 3 grid at 6 cm plus a bevel node 2.5 cm up, 5 cm beyond the grid's +x edge,
    # on a facet with the grid's corner nodes: high (2.5 cm > 2 cm tolerance) but below half
    # of A_h = 6 cm, so the extents take it (0.75 - 0.60 = 0.15 along) and the rectangle at
    # half the height does not (the grid's 0.10 × 0.10, axis-aligned).
    nodes, edges, facets = _top_grid()
    nodes = np.vstack([nodes, [[0.75, 0.0, 0.025]]])
    edges = np.vstack([edges, [[6, 10], [7, 10]]])
    facets = np.vstack([facets, [[6, 10, 7]]])
    slope, bins, edge = _k.view_edge_kernel(nodes, 1.0, 0.0, ORIGIN, 16, 4.0)
    fgroup = np.zeros(len(facets), np.int64)
    res, hstart, hnode = _k.map_objects_lists(
        nodes, edges, facets, fgroup, 1, 0.0, 0.02, 1.0, 0.0, slope, bins, edge
    )  # fmt: skip
    r = res[0]
    assert r[_k.M_NHIGH] == 10 and r[_k.M_F1] - r[_k.M_F0] == pytest.approx(0.15)
    # the group's high nodes, each once: the grid's nine and the bevel node
    assert hstart.tolist() == [0, 10] and sorted(hnode[:10].tolist()) == [*range(9), 10]
    n = len(nodes)

    def rect(zmin):
        return _k.group_rect(
            nodes, hnode, 0, 10, 0.0, zmin, 1.0, 0.0, np.empty(n), np.empty(n),
            np.empty(3 * n + 2, np.int64),
        )  # fmt: skip

    a, b, c, s = rect(0.5 * 0.06)
    assert (a, b) == (pytest.approx(0.10), pytest.approx(0.10))
    assert a * c + b * s == pytest.approx(0.10)
    # zmin 0: the bevel node is in; the hull (0.6..0.75 along, ±0.05 across, a pentagon)
    # has its least-area rectangle on the grid's sides: 0.15 × 0.10.
    a, b, c, s = rect(0.0)
    assert a * c + b * s == pytest.approx(0.15)
    assert a * s + b * c == pytest.approx(0.10)


def _rect_oracle(xy):
    """Least-area rectangle by brute force over every pair's direction: (a, b, |cos|, |sin|)."""
    best = (np.inf, 0.0, 0.0, 1.0, 0.0)
    for i in range(len(xy)):
        for j in range(len(xy)):
            d = xy[j] - xy[i]
            n = math.hypot(*d)
            if i == j or n == 0.0:
                continue
            u = d / n
            pa, pb = xy @ u, xy @ np.array([-u[1], u[0]])
            a, b = np.ptp(pa), np.ptp(pb)
            if a * b < best[0] - 1e-15:
                best = (a * b, a, b, abs(u[0]), abs(u[1]))
    return best[1:]


def test_min_area_rect_equals_a_brute_force_search_on_random_points():
    # The hull and calipers against every pair's direction (_rect_oracle), on random point
    # sets, some on a 1 cm lattice (repeated, collinear and tied points); the points are
    # passed in random order, as the groups' high-node lists come.
    rng = np.random.default_rng(23)
    for trial in range(150):
        k = int(rng.integers(3, 40))
        xy = rng.uniform(-0.15, 0.15, (k, 2)) + rng.uniform(0.3, 1.0, 2)
        if trial % 3 == 0:
            xy = np.round(xy, 2)
        a, b, c, s = _k.min_area_rect(
            xy[:, 0].copy(), xy[:, 1].copy(), k, np.empty(3 * k + 2, np.int64)
        )  # fmt: skip
        oa, ob, _, _ = _rect_oracle(xy)
        assert a * b == pytest.approx(oa * ob, abs=1e-12)
        # the same rectangle whatever the order of the points
        p = rng.permutation(k)
        again = _k.min_area_rect(
            xy[p, 0].copy(), xy[p, 1].copy(), k, np.empty(3 * k + 2, np.int64)
        )  # fmt: skip
        assert again == (a, b, c, s)


def test_map_objects_lists_high_nodes_and_median():
    # Each group's list holds its distinct high nodes, and the spacing is np.median's value
    # (odd and even edge counts), on random graphs split into random groups.
    rng = np.random.default_rng(7)
    for _ in range(20):
        n = 60
        nodes = np.column_stack([rng.uniform(0.4, 1.0, n), rng.uniform(-0.3, 0.3, n),
                                 rng.choice([0.0, 0.05, 0.08], n)])  # fmt: skip
        facets = np.array([rng.choice(n, 3, replace=False) for _ in range(80)], np.int64)
        edges = np.unique(np.sort(np.vstack([facets[:, [0, 1]], facets[:, [1, 2]],
                                             facets[:, [0, 2]]]), axis=1), axis=0)  # fmt: skip
        ng = 4
        fgroup = rng.integers(-1, ng, len(facets))
        slope, bins, edge = _k.view_edge_kernel(nodes, 1.0, 0.0, ORIGIN, 16, 4.0)
        res, hstart, hnode = _k.map_objects_lists(
            nodes, edges, facets, fgroup, ng, 0.0, 0.02, 1.0, 0.0, slope, bins, edge
        )  # fmt: skip
        for g in range(ng):
            ids = np.unique(facets[fgroup == g])
            hi = ids[nodes[ids, 2] > 0.02]
            listed = hnode[hstart[g] : hstart[g + 1]]
            assert len(listed) == len(set(listed.tolist())) and set(listed.tolist()) == set(
                hi.tolist()
            )
            both = np.isin(edges[:, 0], hi) & np.isin(edges[:, 1], hi)
            d = nodes[edges[both, 0], :2] - nodes[edges[both, 1], :2]
            lens = np.sqrt(d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1])
            assert res[g, _k.M_SPACING] == (np.median(lens) if len(lens) else 0.0)


def test_map_mode_sizes_are_the_rectangle_of_the_upper_high_nodes():
    pipe, aff = _run("map")
    p = pipe.params
    assert p.map_rect
    nodes, edges = pipe.net.nodes, pipe.net.edges
    tol = pipe.affordance_params.ground_tolerance
    checked = 0
    for k, o in enumerate(aff.objects):
        if o.kind != "object":
            continue
        ids = np.unique(aff.facets[aff.facet_labels == k])
        hi = ids[nodes[ids, 2] > aff.ground_z + tol]
        if len(hi) < 3:
            continue
        both = np.isin(edges[:, 0], hi) & np.isin(edges[:, 1], hi)
        d = nodes[edges[both, 0], :2] - nodes[edges[both, 1], :2]
        s = float(np.median(np.hypot(d[:, 0], d[:, 1]))) if both.any() else 0.0
        up = hi[nodes[hi, 2] - aff.ground_z >= p.map_rect_height * o.height]
        a, b, c, sn = _rect_oracle(nodes[up, :2])  # forward is +x
        e = p.map_rect_correction * s
        assert o.length == pytest.approx((a + e) * c + (b + e) * sn, abs=1e-9)
        assert o.width == pytest.approx((a + e) * sn + (b + e) * c, abs=1e-9)
        checked += 1
    assert checked >= 1


def test_map_attend_above_lifts_the_attention_box_to_the_objects_high_part():
    for attend_above in (True, False):
        pipe, aff = _run("map", params=PipelineParams(map_attend_above=attend_above))
        assert len(pipe.memory_boxes)
        pad = pipe.affordance_params.suspect_padding
        floor = aff.ground_z + pipe.affordance_params.ground_tolerance
        lows = {round(float(o.box[0, 2]) - pad, 12) for o in aff.obstacles}
        for box in pipe.memory_boxes:
            if attend_above:
                # the lower face at ground + tolerance (or the box's top if lower still)
                assert box[0, 2] == pytest.approx(min(floor, box[1, 2]))
            else:
                assert box[0, 2] < floor
        if not attend_above:
            assert any(round(float(b[0, 2]), 12) in lows for b in pipe.memory_boxes)
    # "points" mode keeps the padded box whatever the flag
    pipe, aff = _run("points", params=PipelineParams(map_attend_above=True))
    assert all(b[0, 2] < aff.ground_z for b in pipe.memory_boxes)
