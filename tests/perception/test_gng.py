"""Tests of DD-GNG, GNG and ML-GNG (neurocog_gym.perception.gng) against the NumPy oracle."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from neurocog_gym.perception import _gng_kernels as K
from neurocog_gym.perception.gng import DDGNG, GNG, MLGNG, DDGNGParams
from neurocog_gym.perception.gng_oracle import DDGNGOracle

# ---------------------------------------------------------------------------------------------
# synthetic clouds
# ---------------------------------------------------------------------------------------------
BOX_LO = np.array([1.4, -0.1, 0.0])
BOX_SIZE = 0.2
# attention box: the obstacle plus 2 cm, starting 1 cm above the floor so no floor point is in it
ATT_BOX = np.array([[[1.38, -0.12, 0.01], [1.62, 0.12, 0.22]]])


def floor_and_box(n: int, seed: int) -> np.ndarray:
    """(n, 3) float64: a 3 m x 2 m floor (z ~ 0) and the 5 visible faces of a 0.2 m cube.

    Points are uniform per area (floor 5.96 m², cube 0.2 m²), in random order.
    """
    rng = np.random.default_rng(seed)
    a_floor, a_box = 6.0 - BOX_SIZE**2, 5 * BOX_SIZE**2
    nb = int(round(n * a_box / (a_floor + a_box)))
    nf = n - nb
    fl = np.c_[rng.uniform(0, 3, 2 * nf), rng.uniform(-1, 1, 2 * nf), rng.normal(0, 0.002, 2 * nf)]
    on_box = (
        (fl[:, 0] > BOX_LO[0]) & (fl[:, 0] < BOX_LO[0] + BOX_SIZE)
        & (fl[:, 1] > BOX_LO[1]) & (fl[:, 1] < BOX_LO[1] + BOX_SIZE)
    )  # fmt: skip
    fl = fl[~on_box][:nf]
    face = rng.integers(0, 5, nb)
    u, v = rng.uniform(0, BOX_SIZE, (2, nb))
    s = BOX_SIZE
    corners = [
        (u, v, np.full(nb, s)),  # top
        (np.zeros(nb), u, v),  # -x side
        (np.full(nb, s), u, v),  # +x side
        (u, np.zeros(nb), v),  # -y side
        (u, np.full(nb, s), v),  # +y side
    ]
    bx = np.empty((nb, 3))
    for f, (x, y, z) in enumerate(corners):
        m = face == f
        bx[m] = np.c_[x[m], y[m], z[m]] + BOX_LO
    pts = np.vstack([fl, bx])
    rng.shuffle(pts)
    return pts


def small_cloud(seed: int = 0, n: int = 2000) -> np.ndarray:
    rng = np.random.default_rng(seed)
    pts = np.c_[rng.uniform(0, 1, n), rng.uniform(0, 1, n), rng.normal(0, 0.01, n)]
    box = np.c_[rng.uniform(0.4, 0.6, 300), rng.uniform(0.4, 0.6, 300), rng.uniform(0, 0.2, 300)]
    out = np.vstack([pts, box])
    rng.shuffle(out)
    return out


SMALL_BOXES = np.array(
    [[[0.38, 0.38, 0.02], [0.62, 0.62, 0.25]], [[0.5, 0.3, -0.1], [0.7, 0.7, 0.1]]]
)


# ---------------------------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------------------------
def check_graph(net, max_nodes: int) -> None:
    """Public-graph invariants: finite, bounded, edges unique i<j in range, no isolated node."""
    nodes, edges, strength = net.nodes, net.edges, net.strength
    n = nodes.shape[0]
    assert nodes.shape == (n, 3) and nodes.dtype == np.float64
    assert strength.shape == (n,)
    assert edges.ndim == 2 and edges.shape[1] == 2 and edges.dtype == np.int64
    assert n <= max_nodes and n == net.n_nodes
    assert np.isfinite(nodes).all() and np.isfinite(strength).all()
    assert (strength >= 1).all()
    if len(edges):
        assert (edges[:, 0] < edges[:, 1]).all()
        assert edges.min() >= 0 and edges.max() < n
        assert len(np.unique(edges, axis=0)) == len(edges)
        assert (np.diff(edges[:, 0]) >= 0).all()
    if n >= 2:
        assert set(np.unique(edges)) == set(range(n)), "isolated node kept"


def check_internal(net: DDGNG) -> None:
    """Kernel-state invariants: neighbour lists symmetric with consistent twins and ages,
    alive list, lazy-decay scales, and every live node in the grid bucket of its cell."""
    s = net._net
    inode, adj, ibuf, fsc, isc = s.inode, s.adj, s.ibuf, s.fsc, s.isc
    alive = np.flatnonzero(inode[K.N_ALIVE])
    n = int(isc[K.I_NALIVE])
    assert len(alive) == n
    assert sorted(inode[K.N_LIST, :n]) == sorted(alive)
    for q in range(n):
        assert inode[K.N_LPOS, inode[K.N_LIST, q]] == q
    for i in alive:
        dg = inode[K.N_DEG, i]
        assert 0 <= dg <= adj.shape[2]
        nb = adj[K.A_NBR, i, :dg]
        assert len(set(nb)) == dg and i not in nb
        for k in range(dg):
            j, tw = adj[K.A_NBR, i, k], adj[K.A_TWIN, i, k]
            assert inode[K.N_ALIVE, j]
            assert adj[K.A_NBR, j, tw] == i and adj[K.A_TWIN, j, tw] == k
            assert adj[K.A_AGE, j, tw] == adj[K.A_AGE, i, k] <= net.params.g_max
    assert np.isfinite(fsc[K.F_SE]) and fsc[K.F_SE] > 0 and fsc[K.F_SU] > 0
    if n:
        mask = int(isc[K.I_NBUCKET]) - 1
        inv_h = 1.0 / fsc[K.F_H]
        seen = []
        for b in range(mask + 1):
            i = ibuf[b]
            while i >= 0:
                seen.append(i)
                i = inode[K.N_NXT, i]
        assert sorted(seen) == sorted(alive)
        for i in alive:
            c = np.floor(s.pos[i] * inv_h + 0.5).astype(np.int64)
            assert (c == inode[K.N_CX : K.N_CZ + 1, i]).all()


def strength_of(nodes: np.ndarray, boxes) -> np.ndarray:
    if boxes is None:
        return np.ones(len(nodes))
    b = np.asarray(boxes)
    inside = (nodes[:, None, :] > b[None, :, 0]) & (nodes[:, None, :] < b[None, :, 1])
    return 1.0 + inside.all(axis=2).sum(axis=1)


# ---------------------------------------------------------------------------------------------
# kernels against the oracle
# ---------------------------------------------------------------------------------------------
ORACLE_PARAMS = [
    pytest.param(DDGNGParams(max_nodes=25), id="table2"),
    pytest.param(
        DDGNGParams(
            max_nodes=40, grid_min_nodes=3, g_max=8, k=20.0, max_degree=3, lam=100, kappa=3
        ),
        id="stress-evict-age-remove",
    ),
    pytest.param(
        DDGNGParams(
            max_nodes=30, grid_min_nodes=3, g_max=15, k=5.0, max_degree=4, lam=60,
            strength_power=2.0, box_reservoir=7, box_refresh=3, box_window=4, box_min_points=2,
        ),
        id="stress-reservoir-power",
    ),
]  # fmt: skip


@pytest.mark.parametrize("params", ORACLE_PARAMS)
@pytest.mark.parametrize("cls", [DDGNG, GNG])
def test_kernels_equal_oracle(cls, params):
    # Same seed, same frames: the numba net and the NumPy oracle agree bit for bit on the
    # graph (error and utility to rounding, the kernel decays them lazily) over 40 cycles
    # that include a jump of the cloud (utility removals), float32 frames and toggled boxes.
    a = cls(seed=11, params=params)
    o = DDGNGOracle(seed=11, params=params, attention=cls is DDGNG)
    near, far = small_cloud(1), small_cloud(2) + np.array([0.7, 0.0, 0.0])
    for c in range(40):
        pts = (near if c < 20 else far).astype(np.float32 if c % 3 == 0 else np.float64)
        boxes = SMALL_BOXES if c % 5 else None
        assert a.update(pts, boxes) == o.update(pts, boxes)
        np.testing.assert_array_equal(a.nodes, o.nodes)
        np.testing.assert_array_equal(a.edges, o.edges)
        np.testing.assert_array_equal(a.strength, o.strength)
        np.testing.assert_allclose(a.error, o.error, rtol=1e-9, atol=1e-300)
        np.testing.assert_allclose(a.utility, o.utility, rtol=1e-9, atol=1e-300)
    check_internal(a)


def test_oracle_run_exercises_removal_and_grid():
    # guard that the stress parameters really reach the rare paths the oracle test covers
    params = ORACLE_PARAMS[1].values[0]
    a = DDGNG(seed=11, params=params)
    near, far = small_cloud(1), small_cloud(2) + np.array([0.7, 0.0, 0.0])
    for c in range(40):
        a.update(near if c < 20 else far, SMALL_BOXES)
    isc = a._net.isc
    assert isc[K.I_NREMOVED] > 10 and isc[K.I_NINSERTED] == 40
    assert isc[K.I_NBRUTE] < isc[K.I_T] // 2  # most searches went through the grid


# ---------------------------------------------------------------------------------------------
# graph invariants (hypothesis)
# ---------------------------------------------------------------------------------------------
@st.composite
def clouds(draw):
    kind = draw(st.sampled_from(["uniform", "plane", "line", "clusters", "duplicates", "scaled"]))
    n = draw(st.integers(1, 400))
    seed = draw(st.integers(0, 2**16))
    rng = np.random.default_rng(seed)
    if kind == "uniform":
        pts = rng.uniform(-1, 1, (n, 3))
    elif kind == "plane":
        pts = np.c_[rng.uniform(0, 2, (n, 2)), np.zeros(n)]
    elif kind == "line":
        pts = np.outer(rng.uniform(0, 1, n), rng.normal(size=3))
    elif kind == "clusters":
        c = rng.normal(size=(3, 3)) * 5
        pts = c[rng.integers(0, 3, n)] + rng.normal(scale=1e-3, size=(n, 3))
    elif kind == "duplicates":
        pts = np.repeat(rng.normal(size=(n // 50 + 1, 3)), 50, axis=0)[:n]
    else:
        pts = rng.normal(size=(n, 3)) * draw(st.sampled_from([1e-7, 1e-3, 1e3]))
    bad = draw(st.sampled_from([0.0, 0.1, 0.9]))
    m = rng.random(n) < bad
    pts[m, rng.integers(0, 3, m.sum())] = rng.choice([np.nan, np.inf, -np.inf, 1e300], m.sum())
    dtype = draw(st.sampled_from([np.float32, np.float64]))
    with np.errstate(over="ignore"):
        return pts.astype(dtype)


@st.composite
def small_params(draw):
    return DDGNGParams(
        lam=draw(st.integers(1, 300)),
        kappa=draw(st.integers(1, 12)),
        g_max=draw(st.integers(1, 100)),
        k=draw(st.sampled_from([1.0, 30.0, 1000.0])),
        max_nodes=draw(st.integers(2, 60)),
        max_degree=draw(st.integers(2, 16)),
        grid_min_nodes=draw(st.integers(2, 30)),
        grid_cell_factor=draw(st.sampled_from([0.3, 1.0, 2.0, 5.0])),
    )


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(pts=clouds(), params=small_params(), cycles=st.integers(1, 30), seed=st.integers(0, 99))
def test_invariants_random_clouds(pts, params, cycles, seed):
    for cls in (DDGNG, GNG):
        net = cls(seed=seed, params=params)
        good = pts[(np.abs(pts.astype(np.float64)) <= 1e4).all(axis=1)]
        boxes = np.stack([good.min(axis=0), good.min(axis=0) + 0.5])[None] if len(good) else None
        for _ in range(cycles):
            net.update(pts, boxes)
        check_graph(net, params.max_nodes)
        check_internal(net)
        if cls is DDGNG:
            np.testing.assert_array_equal(net.strength, strength_of(net.nodes, boxes))


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**16), cycles=st.integers(50, 200))
def test_invariants_adversarial_table2(seed, cycles):
    # Table 2 parameters on a cloud that teleports, collapses onto a point and explodes in
    # scale, so that edges age out, nodes starve and the utility test removes them.
    rng = np.random.default_rng(seed)
    net = DDGNG(seed=seed, params=DDGNGParams(max_nodes=80))
    for c in range(cycles):
        phase = (c // 25) % 4
        if phase == 0:
            pts = rng.uniform(0, 1, (500, 3))
        elif phase == 1:
            pts = rng.uniform(0, 1, (500, 3)) + 50.0
        elif phase == 2:
            pts = np.full((500, 3), 3.0)
        else:
            pts = rng.normal(size=(500, 3)) * 1e3
        net.update(pts, ATT_BOX if c % 2 else None)
    check_graph(net, 80)
    check_internal(net)


# ---------------------------------------------------------------------------------------------
# degenerate frames and errors
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("cls", [DDGNG, GNG, MLGNG])
def test_empty_frame(cls):
    net = cls(seed=0)
    assert net.update(np.zeros((0, 3))) == 0
    assert net.n_nodes == 0 and net.nodes.shape == (0, 3) and net.edges.shape == (0, 2)
    pg = net.padded(10, 20)
    assert pg.n_nodes == 0 and (pg.edges == -1).all()


@pytest.mark.parametrize("cls", [DDGNG, GNG, MLGNG])
def test_single_point_and_identical_points(cls):
    net = cls(seed=0, params=DDGNGParams(max_nodes=20))
    p = np.array([[0.3, -0.2, 1.5]])
    for _ in range(5):
        net.update(p, ATT_BOX)
    assert net.n_nodes >= 2
    np.testing.assert_array_equal(net.nodes, np.repeat(p, net.n_nodes, axis=0))
    for _ in range(60):
        net.update(np.repeat(p, 1000, axis=0).astype(np.float32), ATT_BOX)
    assert net.n_nodes <= 20 and np.isfinite(net.nodes).all()
    check_graph(net, 20)


@pytest.mark.parametrize("cls", [DDGNG, GNG, MLGNG])
def test_nonfinite_and_far_rows_are_never_learned(cls):
    rng = np.random.default_rng(0)
    pts = rng.uniform(0, 1, (5000, 3))
    pts[::3, 0] = np.nan
    pts[1::7, 2] = np.inf
    pts[2::11, 1] = -np.inf
    pts[5::13] = 1e12  # far beyond coord_limit
    net = cls(seed=0, params=DDGNGParams(max_nodes=50))
    for _ in range(50):
        net.update(pts, ATT_BOX)
    assert net.n_nodes > 2
    assert np.isfinite(net.nodes).all()
    assert (net.nodes >= 0).all() and (net.nodes <= 1).all()


def test_all_invalid_frame_learns_nothing():
    net = DDGNG(seed=0)
    net.update(np.random.default_rng(0).uniform(0, 1, (100, 3)))
    before = net.nodes.copy()
    assert net.update(np.full((1000, 3), np.nan), ATT_BOX) == 0
    np.testing.assert_array_equal(net.nodes, before)


def test_far_but_valid_points_stay_finite():
    rng = np.random.default_rng(1)
    pts = np.vstack([rng.normal(size=(500, 3)) * 9e3, rng.normal(size=(500, 3)) * 1e-6])
    net = DDGNG(seed=0, params=DDGNGParams(max_nodes=50))
    for _ in range(100):
        net.update(pts)
    check_graph(net, 50)
    assert np.isfinite(net.error).all() and np.isfinite(net.utility).all()


@pytest.mark.parametrize("cls", [DDGNG, GNG, MLGNG])
@pytest.mark.parametrize(
    "bad",
    [
        np.zeros((10, 2)),
        np.zeros(3),
        np.zeros((10, 3, 1)),
        np.zeros((10, 3), dtype=np.int64),
        np.zeros((10, 3), dtype=np.complex128),
        np.zeros((10, 3), dtype=np.float16),
        [["a", "b", "c"]],
    ],
    ids=["Nx2", "flat", "3d", "int", "complex", "float16", "strings"],
)
def test_bad_points_raise(cls, bad):
    with pytest.raises(ValueError, match="points"):
        cls(seed=0).update(bad)


@pytest.mark.parametrize(
    "boxes",
    [
        np.zeros((2, 3)),
        np.zeros((1, 3, 2)),
        np.full((1, 2, 3), np.nan),
        np.array([[[1, 1, 1], [0, 0, 0]]]),
    ],
    ids=["2x3", "1x3x2", "nan", "inverted"],
)
@pytest.mark.parametrize("cls", [DDGNG, GNG, MLGNG])
def test_bad_boxes_raise(cls, boxes):
    with pytest.raises(ValueError, match="attention_boxes"):
        cls(seed=0).update(np.zeros((10, 3)), boxes)


def test_non_contiguous_and_big_endian_points_accepted():
    pts = small_cloud(0)
    a, b, c = DDGNG(seed=3), DDGNG(seed=3), DDGNG(seed=3)
    wide = np.zeros((len(pts), 6))
    wide[:, ::2] = pts
    for _ in range(10):
        a.update(pts)
        b.update(wide[:, ::2])
        c.update(pts.astype(">f8"))
    np.testing.assert_array_equal(a.nodes, b.nodes)
    np.testing.assert_array_equal(a.nodes, c.nodes)


def test_params_validation():
    with pytest.raises(ValueError, match="max_nodes"):
        DDGNGParams(max_nodes=1)
    with pytest.raises(ValueError, match="g_max"):
        DDGNGParams(g_max=0)
    with pytest.raises(ValueError, match="eta1"):
        DDGNGParams(eta1=1.5)
    with pytest.raises(ValueError, match="params"):
        DDGNG(params={"lam": 3})
    p = DDGNGParams()
    assert (p.lam, p.kappa, p.eta1, p.eta2, p.g_max) == (300, 10, 0.08, 0.008, 100)
    assert (p.alpha, p.beta, p.chi, p.mu, p.k) == (0.5, 0.005, 0.005, 0.5, 1000.0)


# ---------------------------------------------------------------------------------------------
# determinism, pickling, read-out
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("cls", [DDGNG, GNG, MLGNG])
def test_determinism(cls):
    pts = small_cloud(0)

    def run(seed):
        net = cls(seed=seed, params=DDGNGParams(max_nodes=50))
        for _ in range(30):
            net.update(pts, SMALL_BOXES)
        return net.nodes.copy(), net.edges.copy()

    n1, e1 = run(5)
    n2, e2 = run(5)
    n3, _ = run(6)
    np.testing.assert_array_equal(n1, n2)
    np.testing.assert_array_equal(e1, e2)
    assert n1.shape != n3.shape or not np.array_equal(n1, n3)


def test_reset_and_pickle_roundtrip():
    pts = small_cloud(0)
    net = DDGNG(seed=4, params=DDGNGParams(max_nodes=40))
    for _ in range(20):
        net.update(pts, SMALL_BOXES)
    clone = pickle.loads(pickle.dumps(net))
    for _ in range(10):
        net.update(pts, SMALL_BOXES)
        clone.update(pts, SMALL_BOXES)
    np.testing.assert_array_equal(net.nodes, clone.nodes)
    np.testing.assert_array_equal(net.edges, clone.edges)
    fresh = DDGNG(seed=4, params=DDGNGParams(max_nodes=40))
    net.reset()
    for _ in range(5):
        net.update(pts)
        fresh.update(pts)
    np.testing.assert_array_equal(net.nodes, fresh.nodes)


def test_readout_is_readonly_and_padded_matches():
    pts = small_cloud(0)
    net = DDGNG(seed=0, params=DDGNGParams(max_nodes=40))
    for _ in range(40):
        net.update(pts, SMALL_BOXES)
    with pytest.raises(ValueError):
        net.nodes[0, 0] = 1.0
    pg = net.padded()
    n, m = net.n_nodes, len(net.edges)
    assert pg.nodes.shape == (40, 3) and pg.edges.shape == (40 * 16 // 2, 2)
    assert (pg.n_nodes, pg.n_edges) == (n, m) == (n, net.n_edges)
    np.testing.assert_array_equal(pg.nodes[:n], net.nodes)
    np.testing.assert_array_equal(pg.edges[:m], net.edges)
    np.testing.assert_array_equal(pg.strength[:n], net.strength)
    assert (pg.nodes[n:] == 0).all() and (pg.edges[m:] == -1).all() and (pg.strength[n:] == 0).all()
    small = net.padded(10, 5)
    assert small.n_nodes == 10 and small.n_edges <= 5
    assert small.edges[: small.n_edges].max() < 10


def test_mlgng_layers():
    pts = small_cloud(0)
    net = MLGNG(seed=0, params=DDGNGParams(max_nodes=40), n_layers=3)
    for _ in range(80):
        net.update(pts, SMALL_BOXES)
    sizes = [net.layer(i)[0].shape[0] for i in range(3)]
    assert sizes[0] <= 10 and sizes[1] <= 20 and sizes[2] <= 40
    assert sizes[2] == net.n_nodes and sizes[0] < sizes[2]
    assert [net.layer_params(i).k for i in range(3)] == [10.0, 100.0, 1000.0]
    np.testing.assert_array_equal(net.layer(-1)[0], net.nodes)
    assert (net.strength == 1).all()
    check_graph(net, 40)


# ---------------------------------------------------------------------------------------------
# attention (DD-GNG's point): density rises in the attended box only
# ---------------------------------------------------------------------------------------------
def box_and_floor_counts(nodes: np.ndarray) -> tuple[int, int]:
    inside = ((nodes > ATT_BOX[0, 0]) & (nodes < ATT_BOX[0, 1])).all(axis=1)
    return int(inside.sum()), int((~inside).sum())


def test_attention_raises_density_in_box_only():
    frames = [floor_and_box(40_000, s) for s in range(4)]
    params = DDGNGParams(max_nodes=150)
    dd, gng = DDGNG(seed=0, params=params), GNG(seed=0, params=params)
    for c in range(700):
        dd.update(frames[c % 4], ATT_BOX)
        gng.update(frames[c % 4], ATT_BOX)
    b_dd, f_dd = box_and_floor_counts(dd.nodes)
    b_gng, _ = box_and_floor_counts(gng.nodes)
    area_box, area_floor = 5 * BOX_SIZE**2, 6.0 - BOX_SIZE**2
    ratio = (b_dd / area_box) / (f_dd / area_floor)
    assert ratio >= 5.0, (b_dd, f_dd, ratio)
    assert b_dd >= 3 * b_gng, (b_dd, b_gng)
    # strong nodes are exactly the attended ones
    np.testing.assert_array_equal(dd.strength > 1, strength_of(dd.nodes, ATT_BOX) > 1)
    # attention withdrawn: density on the box relaxes towards GNG's
    for c in range(1500):
        dd.update(frames[c % 4], None)
    assert box_and_floor_counts(dd.nodes)[0] < b_dd / 2
