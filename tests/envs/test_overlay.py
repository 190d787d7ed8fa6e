"""The render overlay: facets filled with MuJoCo's right-triangle markers, coloured by kind."""

from __future__ import annotations

import os

import numpy as np
import pytest

os.environ.setdefault("MUJOCO_GL", "egl")

from neurocog_gym.envs.obstacle import triangle_markers  # noqa: E402


def _corners(marker: dict) -> np.ndarray:
    """World corners of an mjGEOM_TRIANGLE marker: (0,0,0), (size0,0,0), (0,size1,0) local."""
    mat = np.asarray(marker["mat"]).reshape(3, 3)
    s = marker["size"]
    local = np.array([[0.0, 0.0, 0.0], [s[0], 0.0, 0.0], [0.0, s[1], 0.0]])
    return marker["pos"] + local @ mat.T


def _area(t: np.ndarray) -> float:
    return 0.5 * float(np.linalg.norm(np.cross(t[1] - t[0], t[2] - t[0])))


@pytest.mark.parametrize("seed", range(5))
def test_two_right_triangles_tile_the_facet(seed):
    rng = np.random.default_rng(seed)
    a, b, c = rng.normal(size=(3, 3))
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n)
    if seed % 2:
        n = -n  # the lit side follows the given normal, whichever way the corners wind
    rgba = np.array([1.0, 0.0, 0.0, 0.5])
    ms = triangle_markers(a[None], b[None], c[None], n[None], rgba)
    assert 1 <= len(ms) <= 2
    parts = [_corners(m) for m in ms]
    # The pieces cover the facet exactly: same total area, every corner on the facet's plane,
    # and together they use the facet's three corners.
    assert sum(_area(t) for t in parts) == pytest.approx(_area(np.array([a, b, c])), rel=1e-9)
    for t, m in zip(parts, ms, strict=True):
        assert np.allclose((t - a) @ n, 0.0, atol=1e-9)
        mat = np.asarray(m["mat"]).reshape(3, 3)
        assert np.allclose(mat.T @ mat, np.eye(3), atol=1e-9)  # a rotation ...
        assert np.linalg.det(mat) == pytest.approx(1.0)  # ... right-handed
        assert mat[:, 2] @ n == pytest.approx(1.0)  # lit side towards the normal
        assert np.allclose(m["rgba"], rgba)
    used = np.concatenate(parts)
    for corner in (a, b, c):
        assert np.min(np.linalg.norm(used - corner, axis=1)) < 1e-9


def test_lift_and_degenerate_facets():
    a = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    b = np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    c = np.array([[0.0, 1.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.0, 0.0]])  # fine, collinear, a point
    n = np.tile([0.0, 0.0, 1.0], (3, 1))
    ms = triangle_markers(a, b, c, n, np.ones((3, 4)), lift=0.01)
    # Two halves of the first facet (cut at the foot of its altitude onto the hypotenuse);
    # nothing for the collinear or the point facet.
    assert len(ms) == 2
    assert sum(_area(_corners(m)) for m in ms) == pytest.approx(0.5)
    assert all(np.allclose(_corners(m)[:, 2], 0.01) for m in ms)
    assert triangle_markers(a[:0], b[:0], c[:0], n[:0], np.ones(4)) == []


def test_rgb_frame_shows_the_facets():
    import gymnasium as gym

    import neurocog_gym  # noqa: F401

    frames = {}
    for overlay in (True, False):
        env = gym.make("NeuroCog/StaticObstacle-v3", render_mode="rgb_array", width=160,
                       height=120, camera_name="overhead", draw_overlay=overlay)  # fmt: skip
        env.reset(seed=1)
        for _ in range(5):
            env.step(np.zeros(15, np.float32))
        frames[overlay] = env.render().astype(int)
        u = env.unwrapped
        n_facets = len(u.pipeline.last.facets)
        env.close()
    assert n_facets > 10
    # Terrain facets are filled green: many pixels turn greener than the plain frame's.
    greener = (frames[True][..., 1] - frames[False][..., 1]) > 25
    assert greener.sum() > 0.05 * greener.size
