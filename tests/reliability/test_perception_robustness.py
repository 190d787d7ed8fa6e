"""Issue 9, item 3: adversarial point clouds never crash the attention loop (DD-GNG, GNG, ML-GNG,
affordance detection) nor put a non-finite value into the graph or the env's observation."""

import math

import gymnasium as gym
import mujoco
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import neurocog_gym
from neurocog_gym.perception.affordance import detect_affordances
from neurocog_gym.perception.gng import DDGNG, GNG, MLGNG, DDGNGParams
from neurocog_gym.perception.pipeline import AttentionPipeline, PipelineParams
from neurocog_gym.robot.tof import ToFParams

OBSTACLE_IDS = [i for i in neurocog_gym.ENV_IDS if "Obstacle" in i]
KINDS = ("empty", "nan", "single", "duplicates", "plane", "vertical_plane", "line", "huge",
         "tiny", "mixed", "floor_and_box")  # fmt: skip


def cloud(kind: str, n: int, seed: int) -> np.ndarray:
    """(n, 3) adversarial clouds; every draw from ``seed``."""
    rng = np.random.default_rng(seed)
    if kind == "empty":
        return np.zeros((0, 3))
    if kind == "nan":
        return np.full((n, 3), np.nan)
    if kind == "single":
        return rng.normal(size=(1, 3))
    if kind == "duplicates":
        return np.repeat(rng.normal(size=(1, 3)), n, axis=0)
    if kind == "plane":  # exactly coplanar: z = 0
        return np.c_[rng.uniform(0, 2, (n, 2)), np.zeros(n)]
    if kind == "vertical_plane":
        return np.c_[np.full(n, 1.5), rng.uniform(-1, 1, n), rng.uniform(0, 1, n)]
    if kind == "line":
        return np.outer(rng.uniform(0, 3, n), [1.0, 0.5, 0.0]) + 0.3
    if kind == "huge":  # beyond coord_limit, at it, and inside by a lot
        return rng.choice([1e300, 9.9e3, -9.9e3, 1e5], size=(n, 3)) * rng.uniform(0.99, 1, (n, 3))
    if kind == "tiny":  # a whole frame inside a micrometre
        return rng.normal(size=(n, 3)) * 1e-7 + 0.5
    if kind == "mixed":
        pts = rng.uniform(0, 1, (n, 3))
        m = rng.random(n) < 0.5
        pts[m, rng.integers(0, 3, m.sum())] = rng.choice([np.nan, np.inf, -np.inf], m.sum())
        return pts
    # a floor with a block on it
    fl = np.c_[rng.uniform(0, 2, (n, 2)), np.zeros(n)]
    bx = np.c_[rng.uniform(1, 1.2, n // 4), rng.uniform(-0.1, 0.1, n // 4),
               rng.uniform(0, 0.1, n // 4)]  # fmt: skip
    return np.vstack([fl, bx])


def check_graph(nodes, edges, n_nodes, max_nodes):
    assert nodes.shape == (n_nodes, 3) and n_nodes <= max_nodes
    assert np.isfinite(nodes).all()
    assert edges.ndim == 2 and edges.shape[1] == 2
    if len(edges):
        assert edges.min() >= 0 and edges.max() < n_nodes
        assert (edges[:, 0] != edges[:, 1]).all(), "self loop"
        assert len(np.unique(np.sort(edges, axis=1), axis=0)) == len(edges), "duplicate edge"


def check_affordances(aff, n_nodes):
    f = len(aff.facets)
    if f:
        assert aff.facets.min() >= 0 and aff.facets.max() < n_nodes
        assert np.isfinite(aff.facet_normals).all()
        assert math.isfinite(aff.ground_z)
    for o in aff.objects:
        for v in (o.height, o.width, o.length, o.gamma, o.density, o.size):
            assert math.isfinite(v)
        assert np.isfinite(o.position).all() and np.isfinite(o.box).all()
    assert np.isfinite(aff.suspected_boxes).all()


@settings(
    max_examples=40, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)
@given(
    kinds=st.lists(st.sampled_from(KINDS), min_size=1, max_size=6),
    gng=st.sampled_from(["ddgng", "gng", "mlgng"]),
    n=st.integers(1, 400),
    seed=st.integers(0, 2**16),
    max_nodes=st.integers(2, 120),
    dtype=st.sampled_from([np.float32, np.float64]),
)
def test_attention_loop_on_adversarial_frame_sequences(kinds, gng, n, seed, max_nodes, dtype):
    """A sequence of adversarial frames through the closed loop (map, affordances, attention)."""
    pipe = AttentionPipeline(seed=seed, params=PipelineParams(gng=gng),
                             gng_params=DDGNGParams(max_nodes=max_nodes))  # fmt: skip
    origin = np.array([0.0, 0.0, 0.4])
    for t, kind in enumerate(kinds * 2):
        with np.errstate(over="ignore", invalid="ignore"):
            pts = cloud(kind, n, seed + t).astype(dtype)
        aff = pipe.step(pts, origin, 0.01 * t)
        net = pipe.net
        check_graph(net.nodes, net.edges, net.n_nodes, max_nodes)
        check_affordances(aff, net.n_nodes)
        assert np.isfinite(pipe.memory_boxes).all()
        g = net.padded()
        assert np.isfinite(g.nodes).all() and g.n_nodes == net.n_nodes


@pytest.mark.parametrize("cls", [DDGNG, GNG, MLGNG])
@pytest.mark.parametrize("kind", KINDS)
def test_each_adversarial_frame_alone(cls, kind):
    net = cls(seed=1, params=DDGNGParams(max_nodes=40))
    boxes = np.array([[[0.9, -0.2, 0.01], [1.3, 0.2, 0.2]]])
    for c in range(40):
        net.update(cloud(kind, 300, c), boxes if c % 2 else None)
        check_graph(net.nodes, net.edges, net.n_nodes, 40)
    aff = detect_affordances(net.nodes, net.edges, (0.0, 0.0, 0.4))
    check_affordances(aff, net.n_nodes)


# -- affordance detection on degenerate and extreme graphs -----------------------------------


def _grid(nx, ny, spacing, z=0.0, offset=0.0):
    xs, ys = np.meshgrid(np.arange(nx) * spacing, np.arange(ny) * spacing, indexing="ij")
    nodes = np.c_[xs.ravel(), ys.ravel(), np.full(nx * ny, z)] + offset
    idx = np.arange(nx * ny).reshape(nx, ny)
    edges = np.vstack([np.c_[idx[:-1].ravel(), idx[1:].ravel()],
                       np.c_[idx[:, :-1].ravel(), idx[:, 1:].ravel()],
                       np.c_[idx[:-1, :-1].ravel(), idx[1:, 1:].ravel()]])  # fmt: skip
    return nodes, edges


@st.composite
def extreme_graphs(draw):
    kind = draw(st.sampled_from(["grid", "collinear", "coincident", "vertical", "random"]))
    scale = draw(st.sampled_from([1e-9, 1e-4, 1.0, 1e3, 1e4]))
    offset = draw(st.sampled_from([0.0, 1e4, -1e4, 1e6]))
    seed = draw(st.integers(0, 2**16))
    rng = np.random.default_rng(seed)
    if kind == "grid":
        nodes, edges = _grid(draw(st.integers(2, 7)), draw(st.integers(2, 7)), 0.05 * scale)
    else:
        n = draw(st.integers(3, 40))
        if kind == "collinear":
            nodes = np.outer(rng.uniform(0, 1, n), rng.normal(size=3)) * scale
        elif kind == "coincident":
            nodes = np.repeat(rng.normal(size=(1, 3)), n, axis=0) * scale
        elif kind == "vertical":  # a wall: x constant
            nodes = np.c_[np.zeros(n), rng.uniform(0, 1, (n, 2))] * scale
        else:
            nodes = rng.normal(size=(n, 3)) * scale
        m = draw(st.integers(0, 4 * n))
        edges = rng.integers(0, n, (m, 2))
        edges = edges[edges[:, 0] != edges[:, 1]]
    return nodes + offset, edges.astype(np.int64)


@settings(
    max_examples=100, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)
@given(
    graph=extreme_graphs(),
    origin=st.sampled_from([(0.0, 0.0, 3.0), (1e4, 0.0, 0.0), (0.0, 0.0, 0.0), None]),
    ground=st.sampled_from([None, 0.0, 1e4]),
)
def test_affordances_of_degenerate_and_extreme_graphs_are_finite(graph, origin, ground):
    nodes, edges = graph
    aff = detect_affordances(nodes, edges, origin, ground_z=ground)
    check_affordances(aff, len(nodes))
    if len(aff.facets):
        np.testing.assert_allclose(np.linalg.norm(aff.facet_normals, axis=1), 1.0, rtol=1e-6)


# -- the obstacle envs when the sensors see nothing -----------------------------------------------


def _finite(obs):
    return all(np.all(np.isfinite(np.asarray(v, dtype=np.float64))) for v in obs.values())


@pytest.mark.parametrize("env_id", OBSTACLE_IDS)
@pytest.mark.parametrize(
    "tof",
    [
        ToFParams(backend="numba", min_range=0.1, max_range=0.11),  # every return out of range
        ToFParams(backend="numba", dropout=0.99999),  # (almost) every pixel drops out
    ],
    ids=["out_of_range", "dropout"],
)
def test_episode_with_blind_sensors_has_finite_observations(env_id, tof):
    env = gym.make(env_id, tof=tof, include_graph=True)
    obs, _ = env.reset(seed=0)
    assert _finite(obs) and env.observation_space.contains(obs)
    for _ in range(60):
        obs, r, term, trunc, info = env.step(np.zeros(15, np.float32))
        assert _finite(obs) and np.isfinite(r) and env.observation_space.contains(obs)
        if term or trunc:
            break
    if tof.max_range < 0.2:
        assert env.unwrapped.frame.points.shape == (0, 3)


@pytest.mark.parametrize("env_id", OBSTACLE_IDS)
def test_robot_pitched_to_the_sky_perceives_nothing_and_stays_finite(env_id):
    env = gym.make(env_id, include_graph=True)
    env.reset(seed=0)
    u = env.unwrapped
    q = u.data.qpos
    q[2] = 30.0  # high above everything, nose up: every ray looks at the sky
    q[3:7] = [math.cos(-math.pi / 4), 0.0, math.sin(-math.pi / 4), 0.0]
    mujoco.mj_forward(u.model, u.data)
    for _ in range(20):  # the perception loop alone, as a step runs it
        u._sense_and_perceive(force_frame=True)
        u._update_effectivity()
        obs = u._get_obs()
        assert u.frame.points.shape == (0, 3)
        assert _finite(obs) and env.observation_space.contains(obs)
    obs, r, term, trunc, info = env.step(np.zeros(15, np.float32))  # it is falling: terminated
    assert _finite(obs) and np.isfinite(r) and (term or trunc)
    obs, _ = env.reset(seed=1)
    assert _finite(obs)
