"""The faster affordance kernels (issue 23) against the kernels they replaced, bit for bit.

``affordance_oracle.py`` keeps the compiled functions as they were before the speed-ups; here
both run on the same graphs and every array, label and object field must have the same bytes:
the detection of the default "points" mode (``detect_kernel``, ``detect_affordances``), the
"map" mode's one compiled call (``detect_map_kernel`` via ``AttentionPipeline.detect``) and the
triangulation with a facet capacity small enough to truncate it.
"""

from __future__ import annotations

import numpy as np
import pytest

from neurocog_gym.perception import _affordance_kernels as _k
from neurocog_gym.perception.affordance import (
    DEFAULT_PARAMS,
    detect_affordances,
    synthetic_scene_graph,
)
from neurocog_gym.perception.pipeline import AttentionPipeline, PipelineParams
from tests.perception import affordance_oracle as oracle

ORIGIN = np.array([0.0, 0.0, 0.3])


def _box_frame(rng):
    """A floor (z = 0, x 0.2–1.4, y ±0.6) and a 20 × 20 × 7 cm box at x 0.6–0.8, y ±0.1."""
    fl = np.column_stack(
        [rng.uniform(0.2, 1.4, 6000), rng.uniform(-0.6, 0.6, 6000), np.zeros(6000)]
    )
    fl = fl[~((fl[:, 0] > 0.6) & (fl[:, 0] < 0.8) & (np.abs(fl[:, 1]) < 0.1))]
    top = np.column_stack(
        [rng.uniform(0.6, 0.8, 1500), rng.uniform(-0.1, 0.1, 1500), np.full(1500, 0.07)]
    )
    return np.concatenate([fl, top])


def _graphs():
    """(nodes, edges, sensor origin) of synthetic floor + block (+ wall) meshes, their edges
    shuffled as built and sorted as a GNG exports them, and of DD-GNG maps in "map" mode."""
    out = []
    for seed in range(4):
        for spacing in (0.04, 0.07, 0.11):
            sc = synthetic_scene_graph(spacing, seed=seed, wall_x=None if seed % 2 else 1.2)
            e = np.sort(sc.edges, axis=1)
            e = e[np.lexsort((e[:, 1], e[:, 0]))]
            out.append((sc.nodes, sc.edges, sc.sensor_origin))
            out.append((sc.nodes, np.ascontiguousarray(e), sc.sensor_origin))
    pipe = AttentionPipeline(seed=5, affordance_source="map")
    pts = _box_frame(np.random.default_rng(1))
    for c in range(240):
        pipe.step(pts, ORIGIN, 0.01 * c)
        if c % 12 == 0:
            out.append((pipe.net.nodes.copy(), pipe.net.edges.copy(), ORIGIN))
    return out


GRAPHS = _graphs()


def _same_bits(a, b, where=""):
    """Equal types and shapes, and equal bytes for arrays and floats (NaN and -0.0 included)."""
    if isinstance(a, np.ndarray):
        assert isinstance(b, np.ndarray), where
        assert a.dtype == b.dtype and a.shape == b.shape, where
        assert np.ascontiguousarray(a).tobytes() == np.ascontiguousarray(b).tobytes(), where
    elif isinstance(a, float):
        assert type(b) is float and np.float64(a).tobytes() == np.float64(b).tobytes(), where
    elif isinstance(a, tuple | list):
        assert type(a) is type(b) and len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _same_bits(x, y, f"{where}[{i}]")
    else:
        assert type(a) is type(b) and a == b, (where, a, b)


def _same_affordances(a, b):
    _same_bits(list(map(tuple, a.objects)), list(map(tuple, b.objects)), "objects")
    for name in ("suspected_boxes", "facets", "facet_normals", "facet_labels", "label_kinds"):
        _same_bits(getattr(a, name), getattr(b, name), name)
    _same_bits(a.ground_z, b.ground_z, "ground_z")
    assert a.truncated is b.truncated


@pytest.mark.parametrize("forward", [(1.0, 0.0), (0.6, 0.8)])
def test_detect_kernel_equals_the_oracle(forward):
    prm = DEFAULT_PARAMS.packed
    for nodes, edges, origin in GRAPHS:
        for mode, ground in ((0, 0.0), (_k.MODE_GROUND_KNOWN, 0.001), (_k.MODE_ORIENT_AWAY, 0.0)):
            got = _k.detect_kernel(nodes, edges, origin, *forward, ground, mode, prm)
            want = oracle.detect_kernel(nodes, edges, origin, *forward, ground, mode, prm)
            _same_bits(list(got), list(want), f"mode {mode}")


@pytest.mark.parametrize("max_facets", [40, 150, 400, 1000])
def test_truncated_triangulation_equals_the_oracle(max_facets):
    # The capacity runs out during the 3-cycles or the quads: every node with two low edges is
    # then tried as a quad's start, as before.
    truncated = 0
    for nodes, edges, origin in GRAPHS:
        got = _k.triangulate_graph(nodes, edges, origin, False, max_facets, 1e-3)
        want = oracle.triangulate_graph(nodes, edges, origin, False, max_facets, 1e-3)
        nf = got[2]
        assert nf == want[2] and got[3] == want[3] and got[4] == want[4]
        _same_bits(got[0][:nf], want[0][:nf])
        _same_bits(got[1][:nf], want[1][:nf])
        _same_bits(got[5], want[5])
        truncated += got[3]
    assert truncated > 0


# The oracle's map step predates the minimum-area rectangle (``map_rect``): it is compared
# with the extents it has (the rectangle is checked in test_affordance_map.py).
PIPELINE_PARAMS = [
    PipelineParams(affordance_source="map", map_rect=False),
    PipelineParams(affordance_source="map", map_merge=False, map_rect=False),
    PipelineParams(
        affordance_source="map",
        map_view_first=False,
        map_box_from_high=False,
        map_floor_plane=False,
        map_rect=False,
    ),  # fmt: skip
    PipelineParams(
        affordance_source="map", map_view_cut=-1.0, map_edge_correction=0.0, map_rect=False
    ),
]


class _Frozen:
    """A graph standing in for a pipeline's net."""

    def __init__(self, nodes, edges):
        self.nodes, self.edges = nodes, edges


@pytest.mark.parametrize("params", PIPELINE_PARAMS)
def test_map_mode_detect_equals_the_oracle(params):
    pipe = AttentionPipeline(params=params)
    objects = merged = 0
    for nodes, edges, origin in GRAPHS:
        pipe.net = _Frozen(nodes, edges)
        for fwd in ((1.0, 0.0, 0.0), (0.6, 0.8, 0.0)):
            for ground_z in (None, 0.001):
                got = pipe.detect(origin, fwd, ground_z)
                want = oracle.detect_map(
                    nodes, edges, origin, pipe.affordance_params, params, fwd, ground_z
                )
                _same_affordances(got, want)
                objects += len(got.obstacles)
                plain = detect_affordances(nodes, edges, origin, forward=fwd, ground_z=ground_z)
                merged += len(got.objects) < len(plain.objects)
    assert objects > 0
    if params.map_merge:
        assert merged > 0, "no graph merged two pieces: the merge path went untested"


def test_points_mode_detect_equals_the_oracle():
    ap = DEFAULT_PARAMS
    for nodes, edges, origin in GRAPHS:
        got = detect_affordances(nodes, edges, origin, ap, forward=(0.6, 0.8, 0.0))
        raw = oracle.detect_kernel(nodes, edges, origin, 0.6, 0.8, 0.0, 0, ap.packed)
        want = oracle.assemble(raw[2], *raw[1:2], *raw[3:])
        _same_affordances(got, want)
