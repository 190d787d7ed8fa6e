"""Affordance detection (§4.2, Eq. 1–4): hand-computed equations, segmentation, robustness."""

from __future__ import annotations

import dataclasses
import itertools
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from neurocog_gym.perception import _affordance_kernels as _k
from neurocog_gym.perception.affordance import (
    DEFAULT_PARAMS,
    AffordanceParams,
    Affordances,
    detect_affordances,
    node_normals,
    synthetic_scene_graph,
    triangulate,
)

REPO = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": str(REPO)}


def _grid(nx: int, ny: int, spacing: float = 1.0, diagonals: bool = True, z: float = 0.0):
    """Flat (nx+1) x (ny+1) lattice at height z, optionally with one diagonal per cell."""
    ids = np.arange((nx + 1) * (ny + 1)).reshape(nx + 1, ny + 1)
    xx, yy = np.meshgrid(np.arange(nx + 1), np.arange(ny + 1), indexing="ij")
    nodes = np.stack([xx.ravel() * spacing, yy.ravel() * spacing, np.full(xx.size, z)], 1)
    edges = []
    for i in range(nx + 1):
        for j in range(ny + 1):
            if i < nx:
                edges.append((ids[i, j], ids[i + 1, j]))
            if j < ny:
                edges.append((ids[i, j], ids[i, j + 1]))
            if diagonals and i < nx and j < ny:
                edges.append((ids[i, j], ids[i + 1, j + 1]))
    return nodes.astype(np.float64), np.array(edges, dtype=np.int64)


def _extrude(profile_xz, ys):
    """Lattice mesh of a polyline profile in (x, z) extruded along y, one diagonal per cell."""
    profile = np.asarray(profile_xz, dtype=np.float64)
    nodes = np.array([[x, y, z] for x, z in profile for y in ys])
    ny = len(ys)
    edges = []
    for i in range(len(profile)):
        for j in range(ny):
            k = i * ny + j
            if j + 1 < ny:
                edges.append((k, k + 1))
            if i + 1 < len(profile):
                edges.append((k, k + ny))
                if j + 1 < ny:
                    edges.append((k, k + ny + 1))
    return nodes, np.array(edges, dtype=np.int64)


# --------------------------------------------------------------------------------------------
# Eq. (1)–(4) on hand-computed cases.


def test_eq1_normal_faces_the_sensor():
    nodes = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    edges = np.array([[0, 1], [1, 2], [2, 0]])
    # (n0 - n1) x (n0 - n2) = (-1, 0, 0) x (0, -1, 0) = (0*0 - 0*(-1), 0*0 - (-1)*0, (-1)(-1) - 0)
    #                       = (0, 0, 1); the sensor above keeps it, the sensor below flips it.
    facets, normals = triangulate(nodes, edges, (0.0, 0.0, 1.0))
    assert facets.shape == (1, 3)
    np.testing.assert_allclose(normals[0], [0.0, 0.0, 1.0])
    _, normals = triangulate(nodes, edges, (0.3, 0.3, -2.0))
    np.testing.assert_allclose(normals[0], [0.0, 0.0, -1.0])


def test_eq1_tilted_facet_and_eq3_gamma():
    nodes = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 1.0]])
    edges = np.array([[0, 1], [1, 2], [2, 0]])
    # (n0 - n1) x (n0 - n2) = (-1, 0, 0) x (0, -1, -1) = (0*(-1) - 0*(-1), 0*0 - (-1)(-1), 1 - 0)
    #                       = (0, -1, 1), unit (0, -1, 1)/sqrt(2). The sensor at (0, 0, 5) sees the
    # centroid (1/3, 1/3, 1/3) along (-1/3, -1/3, 14/3): dot = (1/3 + 14/3)/sqrt(2) > 0, kept.
    facets, normals = triangulate(nodes, edges, (0.0, 0.0, 5.0))
    s = 1.0 / math.sqrt(2.0)
    np.testing.assert_allclose(normals[0], [0.0, -s, s], atol=1e-12)
    # Eq. (3): gamma = arccos(N . (0, 0, 1)) = arccos(1/sqrt(2)) = pi/4. The lone facet is one
    # object (tilted 45 deg, its top 1 m above the given ground).
    res = detect_affordances(nodes, edges, (0.0, 0.0, 5.0), ground_z=0.0)
    (obj,) = res.objects
    assert obj.kind == "object"
    assert obj.gamma == pytest.approx(math.pi / 4)
    assert obj.height == pytest.approx(1.0)
    np.testing.assert_allclose(obj.normal, [0.0, -s, s], atol=1e-12)
    # Ob^(pos) is the facet centre (1/3, 1/3, 1/3); the box spans the three nodes.
    np.testing.assert_allclose(obj.position, [1 / 3, 1 / 3, 1 / 3])
    np.testing.assert_allclose(obj.box, [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]])


@pytest.mark.parametrize(
    ("apex", "expected"),
    [
        # Facet A = (0,0,0), (1,0,0), (0,1,0): normal (0, 0, 1). Facet B = (0,0,0), (1,0,0), apex.
        # apex (0, 0, 1): B lies in y = 0, normal (0, 1, 0) to the sensor; w = arccos(0) = pi/2.
        ((0.0, 0.0, 1.0), math.pi / 2),
        # apex (0, -1, 1): (1,0,0) x (0,-1,1) = (0, -1, -1), flipped to face the sensor:
        # (0, 1, 1)/sqrt(2); w = arccos(1/sqrt(2)) = pi/4.
        ((0.0, -1.0, 1.0), math.pi / 4),
        # apex (0, -1, 0): coplanar, w = arccos(1) = 0.
        ((0.0, -1.0, 0.0), 0.0),
    ],
)
def test_eq2_weight_between_facets_sharing_an_edge(apex, expected):
    nodes = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], apex])
    edges = np.array([[0, 1], [1, 2], [2, 0], [0, 3], [1, 3]], dtype=np.int64)
    facets, normals, nbr, w = _k.facet_weights_kernel(
        nodes, edges, np.array([0.2, 0.2, 5.0]), False, 64, 1e-3
    )
    assert facets.shape == (2, 3)
    # Each facet has exactly one neighbour (across edge 0-1), with the same weight both ways.
    for f in range(2):
        links = [(int(nbr[f, e]), w[f, e]) for e in range(3) if nbr[f, e] >= 0]
        assert len(links) == 1
        assert links[0][0] == 1 - f
        assert links[0][1] == pytest.approx(expected, abs=1e-7)


def test_eq4_density_of_a_unit_square_and_a_strip():
    # Unit square, two facets: 4 nodes / 1 m^2 = 4 nodes/m^2.
    nodes, edges = _grid(1, 1)
    res = detect_affordances(nodes, edges, (0.5, 0.5, 2.0), ground_z=0.0)
    (obj,) = res.objects
    assert obj.kind == "terrain"
    assert obj.n_nodes == 4
    assert obj.size == pytest.approx(1.0)
    assert obj.density == pytest.approx(4.0)
    # 2 m x 1 m strip of four facets: 6 nodes / 2 m^2 = 3 nodes/m^2; extents 2 m along +x, 1 m
    # across; a flat floor has gamma 0 and height 0.
    nodes, edges = _grid(2, 1)
    (obj,) = detect_affordances(nodes, edges, (0.5, 0.5, 2.0), ground_z=0.0).objects
    assert obj.density == pytest.approx(3.0)
    assert (obj.length, obj.width, obj.height, obj.gamma) == pytest.approx((2.0, 1.0, 0.0, 0.0))


def test_quads_are_closed_so_a_floor_stays_whole():
    # A 6 x 4 lattice without diagonals: 24 quads, each closed by one diagonal into 2 facets.
    nodes, edges = _grid(6, 4, spacing=0.05, diagonals=False)
    facets, normals = triangulate(nodes, edges, (0.1, 0.1, 1.0))
    assert facets.shape[0] == 48
    res = detect_affordances(nodes, edges, (0.1, 0.1, 1.0))
    (obj,) = res.objects
    assert obj.kind == "terrain"
    assert obj.size == pytest.approx(0.3 * 0.2)
    assert obj.n_nodes == 35


def test_triangles_match_a_brute_force_oracle():
    # Fully triangulated lattice with jitter: facets are exactly the 3-cycles of the edge graph.
    rng = np.random.default_rng(3)
    nodes, edges = _grid(5, 5, spacing=0.1)
    nodes[:, :2] += rng.uniform(-0.02, 0.02, size=(len(nodes), 2))
    adj = {i: set() for i in range(len(nodes))}
    for a, b in edges:
        adj[a].add(b)
        adj[b].add(a)
    oracle = {
        (a, b, c)
        for a, b, c in itertools.combinations(range(len(nodes)), 3)
        if b in adj[a] and c in adj[a] and c in adj[b]
    }
    facets, normals = triangulate(nodes, edges, (0.2, 0.2, 1.0))
    assert {tuple(sorted(f)) for f in facets.tolist()} == oracle
    # Eq. (1) oracle in NumPy, oriented to the sensor.
    p = nodes[facets]
    cross = np.cross(p[:, 0] - p[:, 1], p[:, 0] - p[:, 2])
    unit = cross / np.linalg.norm(cross, axis=1, keepdims=True)
    np.testing.assert_allclose(np.abs(np.sum(unit * normals, axis=1)), 1.0)
    np.testing.assert_allclose(normals, np.broadcast_to([0.0, 0.0, 1.0], normals.shape), atol=1e-12)


def _unit_cube():
    nodes = np.array(list(itertools.product([0.0, 1.0], repeat=3)))
    edges = [
        (i, j)
        for i, j in itertools.combinations(range(8), 2)
        if np.sum(np.abs(nodes[i] - nodes[j])) == 1.0
    ]
    return nodes, np.array(edges, dtype=np.int64)


def test_unit_cube_gives_six_faces_with_outward_normals():
    nodes, edges = _unit_cube()
    assert len(edges) == 12
    # sensor_origin=None orients facets away from the node centroid: outward on a closed shape.
    facets, normals = triangulate(nodes, edges, None)
    assert facets.shape == (12, 3)
    centroids = nodes[facets].mean(axis=1)
    faces = {}
    for c, n in zip(centroids, normals, strict=True):
        axis = int(np.argmax(np.abs(n)))
        np.testing.assert_allclose(np.abs(n[axis]), 1.0, atol=1e-12)
        # Outward: the normal points from the cube centre towards the facet.
        assert np.dot(n, c - 0.5) > 0
        faces.setdefault((axis, float(np.sign(n[axis]))), []).append(c)
    assert sorted(faces) == [(a, s) for a in range(3) for s in (-1.0, 1.0)]
    assert all(len(v) == 2 for v in faces.values())
    # The six faces are six regions of the Eq. (2) segmentation (each pair of facets coplanar).
    res = detect_affordances(nodes, edges, None, ground_z=-1.0)
    assert len(res.facets) == 12
    # Every facet's neighbour across the cube edges is at pi/2, so no two faces merge before
    # classification; the side faces and the bottom are merged into one object afterwards.
    _, _, nbr, w = _k.facet_weights_kernel(nodes, edges, np.zeros(3), True, 64, 1e-3)
    assert sorted(np.round(w.ravel(), 9).tolist()) == sorted(
        [0.0] * 12 + [round(math.pi / 2, 9)] * 24
    )


def test_cube_seen_from_outside_orients_every_facet_towards_the_sensor():
    nodes, edges = _unit_cube()
    sensor = np.array([3.0, 2.5, 4.0])
    facets, normals = triangulate(nodes, edges, sensor)
    centroids = nodes[facets].mean(axis=1)
    assert np.all(np.sum(normals * (sensor - centroids), axis=1) > 0)


# --------------------------------------------------------------------------------------------
# Degenerate and malformed input.


@pytest.mark.parametrize(
    ("nodes", "edges"),
    [
        (np.zeros((0, 3)), np.zeros((0, 2), np.int64)),
        (np.random.default_rng(0).random((10, 3)), np.zeros((0, 2), np.int64)),
        (np.random.default_rng(0).random((2, 3)), np.array([[0, 1]])),
        # Collinear nodes, all connected: one sliver, no facet.
        (np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]]), np.array([[0, 1], [1, 2], [2, 0]])),
        # Duplicate nodes.
        (np.ones((3, 3)), np.array([[0, 1], [1, 2], [2, 0]])),
        # NaN nodes.
        (np.full((3, 3), np.nan), np.array([[0, 1], [1, 2], [2, 0]])),
        # Self-loops and a path: no triangle.
        (np.eye(3), np.array([[0, 0], [1, 1], [0, 1], [1, 2]])),
        # A 4-cycle of collinear nodes: the diagonal gives slivers only.
        (
            np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]]),
            np.array([[0, 1], [1, 2], [2, 3], [3, 0]]),
        ),
    ],
)
def test_degenerate_graphs_give_an_empty_result(nodes, edges):
    res = detect_affordances(nodes, edges, (0.0, 0.0, 1.0))
    assert isinstance(res, Affordances)
    assert res.objects == []
    assert res.facets.shape == (0, 3)
    assert res.facet_normals.shape == (0, 3)
    assert res.facet_labels.shape == (0,)
    assert res.suspected_boxes.shape == (0, 2, 3)
    assert res.label_kinds == ()


def test_nan_nodes_and_duplicate_edges_are_dropped():
    nodes, edges = _grid(3, 3, spacing=0.1)
    ref = detect_affordances(nodes, edges, (0.1, 0.1, 1.0), ground_z=0.0)
    # Extra NaN node wired into the floor, every edge twice (once reversed), self-loops.
    nodes2 = np.vstack([nodes, [np.nan, 0.0, 0.0]])
    nan = len(nodes)
    extra = np.array([[nan, 0], [nan, 1], [0, nan], [3, 3]])
    edges2 = np.vstack([edges, edges[:, ::-1], extra])
    res = detect_affordances(nodes2, edges2, (0.1, 0.1, 1.0), ground_z=0.0)
    assert len(res.facets) == len(ref.facets)
    (a,), (b,) = ref.objects, res.objects
    assert (a.kind, a.n_nodes, a.size) == (b.kind, b.n_nodes, pytest.approx(b.size))


def test_malformed_input_raises():
    nodes, edges = _grid(1, 1)
    with pytest.raises(ValueError, match="nodes"):
        detect_affordances(nodes[:, :2], edges, (0, 0, 1))
    with pytest.raises(ValueError, match="integer"):
        detect_affordances(nodes, edges.astype(float), (0, 0, 1))
    with pytest.raises(ValueError, match="outside"):
        detect_affordances(nodes, np.vstack([edges, [[0, 99]]]), (0, 0, 1))
    with pytest.raises(ValueError, match="sensor_origin"):
        detect_affordances(nodes, edges, (0, np.nan, 1))
    with pytest.raises(ValueError, match="horizontal"):
        detect_affordances(nodes, edges, (0, 0, 1), forward=(0, 0, 1))


# --------------------------------------------------------------------------------------------
# Segmentation of synthetic scenes.


@pytest.fixture(scope="module")
def scene():
    return synthetic_scene_graph(0.04, seed=1)


def test_floor_box_wall_scene_is_segmented(scene):
    res = detect_affordances(scene.nodes, scene.edges, scene.sensor_origin)
    kinds = sorted(o.kind for o in res.objects)
    assert kinds == ["object", "terrain", "wall"]
    assert res.ground_z == pytest.approx(0.0, abs=0.005)
    (obj,) = res.obstacles
    size = scene.box_max - scene.box_min
    assert obj.height == pytest.approx(size[2], abs=0.01)
    assert obj.length == pytest.approx(size[0], abs=0.02)
    assert obj.width == pytest.approx(size[1], abs=0.02)
    np.testing.assert_allclose(
        obj.position[:2], 0.5 * (scene.box_min + scene.box_max)[:2], atol=0.02
    )
    assert not obj.suspected
    assert obj.density > DEFAULT_PARAMS.density_threshold
    assert res.suspected_boxes.shape == (0, 2, 3)
    (wall,) = res.walls
    assert wall.gamma == pytest.approx(math.pi / 2, abs=0.1)
    assert wall.height == pytest.approx(0.4, abs=0.01)
    assert wall.width == pytest.approx(1.0, abs=0.02)
    (floor,) = res.terrain
    assert floor.gamma < 0.05
    # Facet arrays are consistent with the labels.
    assert res.facet_labels.shape == (len(res.facets),)
    assert set(res.facet_labels.tolist()) == set(range(len(res.objects)))
    assert res.label_kinds == tuple(o.kind for o in res.objects)


def test_label_statistics_match_a_numpy_oracle(scene):
    res = detect_affordances(scene.nodes, scene.edges, scene.sensor_origin)
    p = scene.nodes[res.facets]
    areas = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    centres = p.mean(axis=1)
    for k, obj in enumerate(res.objects):
        sel = res.facet_labels == k
        ids = np.unique(res.facets[sel])
        assert obj.n_nodes == len(ids)
        assert obj.size == pytest.approx(areas[sel].sum())
        assert obj.density == pytest.approx(len(ids) / areas[sel].sum())
        np.testing.assert_allclose(obj.position, centres[sel].mean(axis=0))
        mean = res.facet_normals[sel].mean(axis=0)
        np.testing.assert_allclose(obj.normal, mean / np.linalg.norm(mean), atol=1e-12)
        assert obj.gamma == pytest.approx(math.acos(mean[2] / np.linalg.norm(mean)))
        np.testing.assert_allclose(obj.box, [scene.nodes[ids].min(0), scene.nodes[ids].max(0)])
        assert obj.height == pytest.approx(scene.nodes[ids, 2].max() - res.ground_z)


def test_coarse_object_is_suspected_and_its_box_goes_back_to_attention():
    scene = synthetic_scene_graph(0.1, seed=2)
    res = detect_affordances(scene.nodes, scene.edges, scene.sensor_origin)
    (obj,) = res.obstacles
    assert obj.suspected
    assert obj.density < DEFAULT_PARAMS.density_threshold
    (box,) = res.suspected_boxes
    pad = DEFAULT_PARAMS.suspect_padding
    np.testing.assert_allclose(box, obj.box + np.array([[-pad] * 3, [pad] * 3]))
    # The attention box contains the whole true block.
    assert np.all(box[0] <= scene.box_min) and np.all(box[1] >= scene.box_max)
    # A lower threshold confirms the same object.
    low = dataclasses.replace(DEFAULT_PARAMS, density_threshold=0.5 * obj.density)
    res2 = detect_affordances(scene.nodes, scene.edges, scene.sensor_origin, low)
    assert not res2.obstacles[0].suspected
    assert res2.suspected_boxes.shape == (0, 2, 3)


@pytest.mark.parametrize(("spacing", "seed"), [(0.04, 0), (0.06, 1), (0.1, 2), (0.05, 3)])
def test_bare_floor_reports_no_object(spacing, seed):
    scene = synthetic_scene_graph(spacing, box_min=None, box_max=None, wall_x=None, seed=seed)
    res = detect_affordances(scene.nodes, scene.edges, scene.sensor_origin)
    assert [o.kind for o in res.objects] == ["terrain"]
    assert res.suspected_boxes.shape == (0, 2, 3)


def test_width_and_length_follow_the_walking_direction():
    scene = synthetic_scene_graph(
        0.03, box_min=(0.6, -0.05, 0.0), box_max=(0.9, 0.1, 0.08), wall_x=None, seed=4
    )
    args = (scene.nodes, scene.edges, scene.sensor_origin)
    (obj,) = detect_affordances(*args).obstacles
    assert (obj.length, obj.width) == pytest.approx((0.30, 0.15), abs=0.02)
    (obj,) = detect_affordances(*args, forward=(0.0, 2.0, 0.3)).obstacles
    assert (obj.length, obj.width) == pytest.approx((0.15, 0.30), abs=0.02)
    assert obj.height == pytest.approx(0.08, abs=0.01)


def test_given_ground_matches_the_estimate(scene):
    a = detect_affordances(scene.nodes, scene.edges, scene.sensor_origin)
    b = detect_affordances(scene.nodes, scene.edges, scene.sensor_origin, ground_z=0.0)
    assert b.ground_z == 0.0
    assert [o.kind for o in a.objects] == [o.kind for o in b.objects]
    assert a.obstacles[0].height == pytest.approx(b.obstacles[0].height, abs=0.005)


def test_bevel_at_the_foot_of_a_wall_belongs_to_the_wall():
    # Floor to x = 1.0, a 45-degree bevel up to (1.03, 0.03) (as a GNG rounds the corner), then
    # a wall up to 0.48 m. The bevel is neither terrain (tilted) nor low (3 cm > 2 cm tolerance),
    # but it touches the wall: it is part of it, not an object.
    profile = [(x, 0.0) for x in np.arange(0.2, 1.0001, 0.05)]
    profile += [(1.03, 0.03)] + [(1.03, z) for z in np.arange(0.08, 0.5001, 0.05)]
    nodes, edges = _extrude(profile, np.arange(-0.5, 0.5001, 0.05))
    res = detect_affordances(nodes, edges, (0.0, 0.0, 0.4))
    assert sorted(o.kind for o in res.objects) == ["terrain", "wall"]
    (wall,) = res.walls
    assert wall.height == pytest.approx(0.48)


def test_ground_is_the_floor_even_when_a_block_top_is_larger():
    # Block top 0.8 x 0.9 m = 0.72 m^2; the visible floor is about 0.28 m^2, more than a quarter
    # of it: the lower of the two is the ground, and the block an object 7 cm high.
    scene = synthetic_scene_graph(
        0.05, box_min=(0.3, -0.45, 0.0), box_max=(1.1, 0.45, 0.07), wall_x=None, seed=5
    )
    res = detect_affordances(scene.nodes, scene.edges, scene.sensor_origin)
    assert res.ground_z == pytest.approx(0.0, abs=0.005)
    (obj,) = res.obstacles
    assert obj.height == pytest.approx(0.07, abs=0.01)
    assert res.terrain[0].position[2] == pytest.approx(0.0, abs=0.005)


def test_facet_capacity_truncates_without_error(scene):
    small = dataclasses.replace(DEFAULT_PARAMS, max_facets=50)
    res = detect_affordances(scene.nodes, scene.edges, scene.sensor_origin, small)
    assert res.truncated
    assert 0 < len(res.facets) <= 50
    assert not detect_affordances(scene.nodes, scene.edges, scene.sensor_origin).truncated


def test_params_are_frozen_and_packed_once():
    p = AffordanceParams()
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.density_threshold = 1.0  # type: ignore[misc]
    assert p.packed is p.packed
    assert p.packed[_k.P_COS_GROW] == pytest.approx(math.cos(p.grow_angle))


def test_node_normals_of_a_floor_point_up():
    nodes, edges = _grid(3, 3, spacing=0.1)
    nodes = np.vstack([nodes, [5.0, 5.0, 5.0]])  # isolated node: zero normal
    res = detect_affordances(nodes, edges, (0.1, 0.1, 1.0))
    nn = node_normals(nodes, res.facets, res.facet_normals)
    np.testing.assert_allclose(nn[:-1], np.broadcast_to([0.0, 0.0, 1.0], (16, 3)), atol=1e-12)
    np.testing.assert_array_equal(nn[-1], 0.0)


# --------------------------------------------------------------------------------------------
# Property tests: random graphs never raise and give finite, consistent output.


@st.composite
def random_graphs(draw):
    n = draw(st.integers(0, 30))
    coords = draw(
        st.lists(
            st.tuples(*[st.floats(-1.0, 1.0, allow_nan=False, width=32)] * 3),
            min_size=n,
            max_size=n,
        )
    )
    nodes = np.array(coords, dtype=np.float64).reshape(n, 3)
    if n and draw(st.booleans()):
        nodes[draw(st.integers(0, n - 1))] = np.nan
    if n >= 2 and draw(st.booleans()):
        nodes[1] = nodes[0]  # a duplicate node
    m = draw(st.integers(0, 4 * n)) if n else 0
    edges = draw(
        st.lists(st.tuples(st.integers(0, n - 1), st.integers(0, n - 1)), min_size=m, max_size=m)
        if n
        else st.just([])
    )
    return nodes, np.array(edges, dtype=np.int64).reshape(-1, 2)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    graph=random_graphs(),
    origin=st.sampled_from([(0.0, 0.0, 3.0), (2.0, -1.0, 0.5), None]),
    ground=st.sampled_from([None, 0.0, -0.5]),
)
def test_random_graphs_never_raise(graph, origin, ground):
    nodes, edges = graph
    res = detect_affordances(nodes, edges, origin, ground_z=ground)
    f = len(res.facets)
    assert res.facets.shape == (f, 3) and res.facet_normals.shape == (f, 3)
    if f:
        assert res.facets.min() >= 0 and res.facets.max() < len(nodes)
        np.testing.assert_allclose(np.linalg.norm(res.facet_normals, axis=1), 1.0)
        assert np.isfinite(res.ground_z)
    assert np.all((res.facet_labels >= 0) & (res.facet_labels < len(res.objects)))
    for o in res.objects:
        values = [o.height, o.width, o.length, o.gamma, o.density, o.size]
        assert all(math.isfinite(v) for v in values)
        assert np.all(np.isfinite(o.position)) and np.all(np.isfinite(o.box))
        assert o.density > 0 and o.size > 0 and o.n_nodes >= 3
        assert 0.0 <= o.gamma <= math.pi
        assert o.width >= 0 and o.length >= 0
    assert res.suspected_boxes.shape == (sum(o.suspected for o in res.objects), 2, 3)
    assert np.all(np.isfinite(res.suspected_boxes))


# --------------------------------------------------------------------------------------------
# Scripts, end to end on tiny budgets.


def test_bench_script_runs(tmp_path):
    out = tmp_path / "bench.md"
    cmd = [sys.executable, "scripts/bench_affordance.py", "--sizes", "150", "--repeats", "20"]
    cmd += ["--graphs", "1", "--map-scenes", "1", "--map-repeats", "20", "--out", str(out)]
    subprocess.run(cmd, cwd=REPO, env=ENV, check=True, capture_output=True, timeout=180)
    text = out.read_text()
    assert "| 150 |" in text and "median" in text
    # the map-mode table: one DD-GNG graph of a floor + box + wall scene, near 300 nodes
    row = next(r for r in text.splitlines() if r.startswith("| `AttentionPipeline.detect`"))
    lo, hi = (int(x) for x in row.split("|")[2].split("–"))
    assert 280 <= lo <= hi <= 300


def test_plot_script_runs(tmp_path):
    out = tmp_path / "facets.png"
    cmd = [sys.executable, "scripts/plot_facets.py", "--out", str(out), "--spacing", "0.08"]
    subprocess.run(cmd, cwd=REPO, env=ENV, check=True, capture_output=True, timeout=120)
    assert out.stat().st_size > 10_000
