"""Surface similarity (§6.5.3, Eq. 12–16) and the Table 5 measures."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from neurocog_gym.perception.affordance import (
    detect_affordances,
    node_normals,
    synthetic_scene_graph,
)
from neurocog_gym.perception.similarity import (
    DEFAULT_SIMILARITY_PARAMS,
    SimilarityParams,
    SimilarityTrace,
    box_surface_reference,
    surface_match,
    surface_similarity,
)

UP = [0.0, 0.0, 1.0]
BOX = ((0.6, -0.1, 0.0), (0.8, 0.1, 0.07))


def _one(att_p, att_n, ref_p, ref_n, params=None):
    return surface_match(
        np.array([att_p], float),
        np.array([att_n], float),
        np.array(ref_p, float).reshape(-1, 3),
        np.array(ref_n, float).reshape(-1, 3),
        params,
    )


def test_identical_surfaces_score_one_and_far_ones_zero():
    p, n = box_surface_reference(*BOX, spacing=0.01)
    assert surface_similarity(p, n, p, n) == pytest.approx(1.0)
    assert surface_similarity(p + [0.0, 0.0, 1.0], n, p, n) == 0.0
    m = surface_match(p + [3.0, 0.0, 0.0], n, p, n)
    assert (m.similarity, m.n_matched, m.n_attention) == (0.0, 0, len(p))
    assert math.isnan(m.position_error) and math.isnan(m.angle_error)


def test_eq14_position_error_along_the_attention_normal():
    # Attention node 1 cm above a reference node, both normals up: s = |(0,0,-0.01).(0,0,1)|
    # = 0.01 m; theta = 0. Eq. (16): 0.5 (0.02 - 0.01)/0.02 + 0.5 (pi/4 - 0)/(pi/4) = 0.75.
    m = _one([0, 0, 0.01], UP, [0, 0, 0], UP)
    assert m.position_error == pytest.approx(0.01)
    assert m.angle_error == pytest.approx(0.0)
    assert m.similarity == pytest.approx(0.75)
    # A tangential offset is no error along the normal: (-0.01, 0, 0).(0, 0, 1) = 0 -> mu = 1.
    assert _one([0.01, 0, 0], UP, [0, 0, 0], UP).similarity == pytest.approx(1.0)
    # 3 cm off is beyond e_max^p = 2 cm: the position half scores 0, mu = 0 + 0.5 = 0.5.
    assert _one([0, 0, 0.03], UP, [0, 0, 0], UP).similarity == pytest.approx(0.5)


def test_eq15_angle_between_normals():
    # Attention normal tilted 30 deg: theta = pi/6; s = 0. Eq. (16):
    # 0.5 + 0.5 (pi/4 - pi/6)/(pi/4) = 0.5 + 0.5 * (1/3) = 2/3.
    tilted = [math.sin(math.pi / 6), 0.0, math.cos(math.pi / 6)]
    m = _one([0, 0, 0], tilted, [0, 0, 0], UP)
    assert m.angle_error == pytest.approx(math.pi / 6)
    assert m.similarity == pytest.approx(2 / 3)
    # Normal length does not matter.
    assert _one([0, 0, 0], [0, 0, 7.0], [0, 0, 0], UP).similarity == pytest.approx(1.0)


def test_eq16_means_over_matched_nodes():
    # Two nodes: errors 0 and 0.02 m -> s = 0.01 m -> mu = 0.25 + 0.5 = 0.75. A third node
    # far away is skipped (Eq. 12 range), not counted as an error.
    att = np.array([[0.0, 0, 0], [1.0, 0, 0.02], [9.0, 9, 9]])
    ref = np.array([[0.0, 0, 0], [1.0, 0, 0]])
    m = surface_match(att, np.tile(UP, (3, 1)), ref, np.tile(UP, (2, 1)))
    assert (m.n_matched, m.n_attention) == (2, 3)
    assert m.position_error == pytest.approx(0.01)
    assert m.similarity == pytest.approx(0.75)


def test_eq12_13_matching_takes_the_aligned_reference_in_range():
    # Two references in range: the nearer one faces away (outside the normal gate), the farther
    # one is aligned: the aligned one is taken, error along the normal 0.03 -> clipped.
    m = _one([0, 0, 0], UP, [[0, 0, 0.005], [0, 0, -0.03]], [[0, 0, -1], UP])
    assert m.n_matched == 1
    assert m.position_error == pytest.approx(0.03)
    assert m.angle_error == pytest.approx(0.0)
    # Outside the range: skipped.
    small = dataclasses.replace(DEFAULT_SIMILARITY_PARAMS, match_radius=0.01)
    assert _one([0, 0, 0], UP, [0, 0, -0.03], UP, small).n_matched == 0
    # The 6-D cost: a slightly farther but aligned node beats a nearer one tilted by 40 deg.
    t = math.radians(40)
    m = _one(
        [0, 0, 0], UP, [[0.002, 0, 0], [0.0, 0.0, -0.004]], [[math.sin(t), 0, math.cos(t)], UP]
    )
    assert m.angle_error == pytest.approx(0.0)
    assert m.position_error == pytest.approx(0.004)


def test_box_reference_samples_top_and_sides_with_outward_normals():
    lo, hi = np.array(BOX[0]), np.array(BOX[1])
    p, n = box_surface_reference(lo, hi, spacing=0.02)
    centre = 0.5 * (lo + hi)
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0)
    assert np.all(np.sum(n * (p - centre), axis=1) > 0)
    assert not np.any(n[:, 2] < -0.5)  # no bottom face
    assert np.all((p >= lo - 1e-12) & (p <= hi + 1e-12))
    directions = {tuple(np.round(v).astype(int)) for v in n}
    assert directions == {(0, 0, 1), (1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0)}
    # Top: 11 x 11 samples at 2 cm; sides x: 11 x 5 (0.07 m in ceil(3.5) = 4 steps), sides y same.
    assert len(p) == 11 * 11 + 4 * 11 * 5
    # Seen from the sensor ahead of it (on the x axis, above): top and front face only.
    p2, n2 = box_surface_reference(lo, hi, spacing=0.02, viewpoint=(0.0, 0.0, 0.35))
    assert {tuple(np.round(v).astype(int)) for v in n2} == {(0, 0, 1), (-1, 0, 0)}


def test_box_reference_yaw_rotates_points_and_normals():
    lo, hi = np.array(BOX[0]), np.array(BOX[1])
    p, n = box_surface_reference(lo, hi, 0.02, yaw=math.pi / 2)
    centre = 0.5 * (lo + hi)
    # Rotated by 90 deg about z through the centre: x extent becomes the y extent.
    np.testing.assert_allclose(p.min(0), [centre[0] - 0.1, centre[1] - 0.1, 0.0], atol=1e-12)
    assert np.all(np.sum(n * (p - centre), axis=1) > 0)
    with pytest.raises(ValueError):
        box_surface_reference(hi, lo, 0.02)


def test_gng_like_nodes_on_the_visible_block_are_similar():
    # Nodes of a dense synthetic mesh on the block's top and front face, normals from their
    # facets, against the true visible surface: mostly small errors, similarity well above 0.5;
    # the same nodes shifted 3 cm up score lower.
    scene = synthetic_scene_graph(0.02, seed=0, noise=0.0)
    res = detect_affordances(scene.nodes, scene.edges, scene.sensor_origin)
    nn = node_normals(scene.nodes, res.facets, res.facet_normals)
    lo, hi = scene.box_min, scene.box_max
    x, y, z = scene.nodes.T
    inside = (x >= lo[0] - 1e-6) & (x <= hi[0] - 0.01) & (np.abs(y) <= hi[1] - 0.01)
    sel = inside & (z > 0.01)
    ref_p, ref_n = box_surface_reference(lo, hi, 0.005, viewpoint=scene.sensor_origin)
    mu = surface_similarity(scene.nodes[sel], nn[sel], ref_p, ref_n)
    assert mu > 0.8
    assert surface_similarity(scene.nodes[sel] + [0, 0, 0.03], nn[sel], ref_p, ref_n) < mu


@settings(max_examples=100, deadline=None)
@given(
    att=st.lists(st.tuples(*[st.floats(-0.2, 0.2)] * 6), max_size=20),
    ref=st.lists(st.tuples(*[st.floats(-0.2, 0.2)] * 6), max_size=20),
)
def test_similarity_is_always_in_unit_interval(att, ref):
    a = np.array(att, float).reshape(-1, 6)
    r = np.array(ref, float).reshape(-1, 6)
    m = surface_match(a[:, :3], a[:, 3:], r[:, :3], r[:, 3:])
    assert 0.0 <= m.similarity <= 1.0
    assert m.n_matched <= m.n_attention == len(a)


def test_params_must_be_positive():
    p = SimilarityParams(e_max_p=0.0)
    with pytest.raises(ValueError):
        surface_similarity(np.zeros((1, 3)), np.ones((1, 3)), np.zeros((1, 3)), np.ones((1, 3)), p)


def test_trace_gives_the_table5_measures():
    # Success-like trace: rises to 0.92 at 0.45 s and stays. Failure-like: 0.48 at 0.5 s and
    # 0.89 only at 0.75 s (Table 5). Obstacle appears at t0 = 2.0 s; samples every 0.05 s.
    ts = np.round(np.arange(0.0, 1.0001, 0.05), 2)
    succ = SimilarityTrace(t0=2.0)
    fail = SimilarityTrace(t0=2.0)
    succ.append(1.9, 0.99)  # before the obstacle: ignored
    for t in ts:
        succ.append(2.0 + t, min(0.92, 0.2 + 1.6 * t) if t < 0.45 else 0.92 - 0.005 * (t > 0.6))
        fail.append(2.0 + t, 0.48 if 0.3 <= t <= 0.5 else (0.3 if t < 0.3 else min(0.89, t)))
    s = succ.summary()
    assert s.best == pytest.approx(0.92)
    # First sample within 0.01 of the best: 0.2 + 1.6 * 0.45 = 0.92 -> at 0.45 s (0.40 gives 0.84).
    assert s.time_to_best == pytest.approx(0.45)
    assert s.at_half_second == pytest.approx(0.92)
    assert s.n_samples == len(ts)
    f = fail.summary()
    assert f.best == pytest.approx(0.89)
    # First sample >= 0.89 - 0.01: 0.85 s gives min(0.89, 0.85) = 0.85, 0.9 s gives 0.89.
    assert f.time_to_best == pytest.approx(0.9)
    assert f.at_half_second == pytest.approx(0.48)
    assert f.best_within_half_second == pytest.approx(0.48)
    assert fail.value_at(0.52) == pytest.approx(0.48)
    empty = SimilarityTrace().summary()
    assert math.isnan(empty.best) and math.isnan(empty.time_to_best) and empty.n_samples == 0
