"""Surface similarity between the attention structure and a reference surface (§6.5.3, Eq. 12–16).

The paper measures how well the DD-GNG nodes that attend an obstacle describe it: each attention
node is matched to a reference node, the position and orientation errors are averaged, and
Eq. (16) maps them to a similarity μ ∈ [0, 1]. In simulation the reference is the obstacle's
true surface, sampled with outward normals (:func:`box_surface_reference`); the attention nodes
are the DD-GNG nodes near the obstacle, with normals from their incident facets
(:func:`neurocog_gym.perception.affordance.node_normals`).

Our reading of the printed equations:

- Eq. (12), ``l = |Q_j - A_i|``: the matching range. Only reference nodes within
  ``match_radius`` of an attention node are candidates; a node without one is skipped ("if the
  module cannot locate it inside the specified range, the node will be skipped").
- Eq. (13) prints ``v = Q̂_j + Â_i``, a sum of unit normals; we read it as their difference, the
  angle between the normals. Candidates must face the same way (angle below
  ``max_normal_angle``); among them the attention node takes the closest in the normalised 6-D
  sense ``(l / e_max^p)² + (angle / e_max^t)²`` ("the closest location and normal vector").
- Eq. (14), ``ṡ = 1/N_d Σ ((Q - A)·Â) Â``, is a vector: signed offsets on opposite faces
  would cancel. We average the lengths, ``|(Q - A)·Â|``, the point-to-plane distance along the
  attention normal.
- Eq. (15) averages a "3-D Euler angle" difference. A surface normal has no roll about itself,
  so its orientation difference is one rotation about the axis ``Q̂ × Â`` by the angle between
  the normals; we average that angle (radians).
- Eq. (16) as printed, ``μ = ½ (e_p - min(ṡ, e_p)) / e_p + ½ (e_t - min(θ̇, e_t)) / e_t``.
  No matched node gives μ = 0.

Table 5 quantities (:class:`SimilarityTrace`): the best similarity reached, the time to reach it
(the first sample within ``tolerance`` = 0.01 of the best, since a noisy trace creeps up to its
maximum), and the similarity at 0.5 s (the last sample at or before 0.5 s after the obstacle
appeared), plus the best within 0.5 s (the Table 5 row reads "achieved in 0.5 s").
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from neurocog_gym.perception import _affordance_kernels as _k


@dataclass(frozen=True)
class SimilarityParams:
    """Parameters of the surface matching (§6.5.3). Override with ``dataclasses.replace``."""

    match_radius: float = 0.05
    """m: range of Eq. (12); an attention node farther from every reference node is skipped."""
    max_normal_angle: float = math.pi / 2
    """rad: reference normals more than this from the attention normal never match (Eq. 13)."""
    e_max_p: float = 0.02
    """e_max^p, m: position error of Eq. (16) at which the position half scores 0."""
    e_max_t: float = math.pi / 4
    """e_max^t, rad: angle error of Eq. (16) at which the orientation half scores 0."""


DEFAULT_SIMILARITY_PARAMS = SimilarityParams()


@dataclass(frozen=True)
class SurfaceMatch:
    """Result of :func:`surface_match`.

    Attributes:
        similarity: μ of Eq. (16), in [0, 1]; 0 when no node matched.
        position_error: ṡ of Eq. (14), metres: mean point-to-plane distance (NaN if none).
        angle_error: θ̇ of Eq. (15), radians: mean angle between matched normals (NaN if none).
        n_matched: attention nodes with a reference node in range.
        n_attention: attention nodes given.
    """

    similarity: float
    position_error: float
    angle_error: float
    n_matched: int
    n_attention: int


def _points(a: np.ndarray, name: str) -> np.ndarray:
    a = np.ascontiguousarray(a, dtype=np.float64)
    if a.size == 0:
        return np.zeros((0, 3))
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{name} must have shape (N, 3), got {a.shape}")
    return a


def surface_match(
    att_nodes: np.ndarray,
    att_normals: np.ndarray,
    ref_points: np.ndarray,
    ref_normals: np.ndarray,
    params: SimilarityParams | None = None,
) -> SurfaceMatch:
    """Match attention nodes to a reference surface, Eq. (12)–(16), with the error terms.

    Args:
        att_nodes: (N, 3) float, metres: attention (DD-GNG) node positions.
        att_normals: (N, 3) float: their normals (any length; zero or non-finite rows skipped).
        ref_points: (M, 3) float, metres: reference surface samples.
        ref_normals: (M, 3) float: their normals, pointing out of the obstacle.
        params: matching parameters; None for :data:`DEFAULT_SIMILARITY_PARAMS`.

    Returns:
        The similarity and its parts.

    Raises:
        ValueError: on wrong shapes or non-positive parameters.
    """
    p = DEFAULT_SIMILARITY_PARAMS if params is None else params
    if not (p.match_radius > 0 and p.e_max_p > 0 and p.e_max_t > 0):
        raise ValueError("match_radius, e_max_p and e_max_t must be positive")
    a_p = _points(att_nodes, "att_nodes")
    a_n = _points(att_normals, "att_normals")
    r_p = _points(ref_points, "ref_points")
    r_n = _points(ref_normals, "ref_normals")
    if a_p.shape != a_n.shape or r_p.shape != r_n.shape:
        raise ValueError("nodes and normals must have the same shape")
    n_att = a_p.shape[0]
    if n_att == 0 or r_p.shape[0] == 0:
        return SurfaceMatch(0.0, math.nan, math.nan, 0, n_att)
    s_dot, theta_dot, n_matched = _k.match_surface_kernel(
        a_p, a_n, r_p, r_n, p.match_radius, math.cos(p.max_normal_angle), p.e_max_p, p.e_max_t
    )
    if n_matched == 0:
        return SurfaceMatch(0.0, math.nan, math.nan, 0, n_att)
    # Eq. (16).
    mu = (
        0.5 * (p.e_max_p - min(s_dot, p.e_max_p)) / p.e_max_p
        + 0.5 * (p.e_max_t - min(theta_dot, p.e_max_t)) / p.e_max_t
    )
    return SurfaceMatch(float(mu), float(s_dot), float(theta_dot), int(n_matched), n_att)


def surface_similarity(
    att_nodes: np.ndarray,
    att_normals: np.ndarray,
    ref_points: np.ndarray,
    ref_normals: np.ndarray,
    params: SimilarityParams | None = None,
) -> float:
    """Similarity μ ∈ [0, 1] of attention nodes to a reference surface (§6.5.3, Eq. 12–16).

    Args:
        att_nodes: (N, 3) float, metres: attention (DD-GNG) node positions.
        att_normals: (N, 3) float: their normals.
        ref_points: (M, 3) float, metres: reference surface samples.
        ref_normals: (M, 3) float: their outward normals.
        params: matching parameters; None for the defaults.

    Returns:
        μ; 0 when no attention node has a reference node in range.
    """
    return surface_match(att_nodes, att_normals, ref_points, ref_normals, params).similarity


def box_surface_reference(
    box_min: Sequence[float] | np.ndarray,
    box_max: Sequence[float] | np.ndarray,
    spacing: float = 0.01,
    *,
    yaw: float = 0.0,
    viewpoint: Sequence[float] | np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Sample the true surface of a box obstacle standing on the ground, with outward normals.

    The top and the four sides are sampled on grids of at most ``spacing`` (edges included, so
    a point on an edge appears once per face, with that face's normal); the bottom lies on the
    ground and is never seen. With ``viewpoint`` only the faces that face it are kept (what a
    depth sensor there can see).

    Args:
        box_min: (3,) float, metres: min corner of the box in its own frame (before ``yaw``).
        box_max: (3,) float, metres: max corner.
        spacing: sample spacing, metres.
        yaw: rotation about the vertical axis through the box centre, radians.
        viewpoint: (3,) float, metres, or None for top and all four sides.

    Returns:
        ``(points, normals)``: (P, 3) float64 metres and (P, 3) float64 unit outward normals.

    Raises:
        ValueError: if the box is empty or ``spacing`` is not positive.
    """
    lo = np.asarray(box_min, dtype=np.float64).reshape(3)
    hi = np.asarray(box_max, dtype=np.float64).reshape(3)
    if not np.all(hi > lo) or not spacing > 0:
        raise ValueError("need box_max > box_min in every axis and spacing > 0")
    centre = 0.5 * (lo + hi)

    def grid(a: float, b: float) -> np.ndarray:
        return np.linspace(a, b, max(1, math.ceil((b - a) / spacing - 1e-9)) + 1)

    xs, ys, zs = grid(lo[0], hi[0]), grid(lo[1], hi[1]), grid(lo[2], hi[2])
    faces: list[tuple[np.ndarray, np.ndarray]] = []

    def face(u: np.ndarray, v: np.ndarray, make, normal) -> None:
        uu, vv = np.meshgrid(u, v, indexing="ij")
        pts = make(uu.ravel(), vv.ravel())
        faces.append((pts, np.tile(np.asarray(normal, dtype=np.float64), (len(pts), 1))))

    face(xs, ys, lambda x, y: np.stack([x, y, np.full_like(x, hi[2])], 1), (0, 0, 1))
    face(ys, zs, lambda y, z: np.stack([np.full_like(y, lo[0]), y, z], 1), (-1, 0, 0))
    face(ys, zs, lambda y, z: np.stack([np.full_like(y, hi[0]), y, z], 1), (1, 0, 0))
    face(xs, zs, lambda x, z: np.stack([x, np.full_like(x, lo[1]), z], 1), (0, -1, 0))
    face(xs, zs, lambda x, z: np.stack([x, np.full_like(x, hi[1]), z], 1), (0, 1, 0))

    c, s = math.cos(yaw), math.sin(yaw)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    points, normals = [], []
    for pts, nrm in faces:
        pts = (pts - centre) @ rot.T + centre
        nrm = nrm @ rot.T
        if viewpoint is not None:
            view = np.asarray(viewpoint, dtype=np.float64).reshape(3)
            face_centre = pts.mean(axis=0)
            if float(np.dot(nrm[0], view - face_centre)) <= 0.0:
                continue
        points.append(pts)
        normals.append(nrm)
    if not points:
        return np.zeros((0, 3)), np.zeros((0, 3))
    return np.concatenate(points), np.concatenate(normals)


@dataclass(frozen=True)
class SimilaritySummary:
    """The failure-analysis measures of Table 5 for one trial.

    Attributes:
        best: best similarity reached (NaN without samples).
        time_to_best: s after the obstacle appeared, first sample within the tolerance of
            ``best`` (NaN without samples).
        at_half_second: similarity of the last sample at or before 0.5 s (NaN if none).
        best_within_half_second: best similarity among the samples up to 0.5 s (NaN if none).
        n_samples: number of samples.
    """

    best: float
    time_to_best: float
    at_half_second: float
    best_within_half_second: float
    n_samples: int


@dataclass
class SimilarityTrace:
    """(time, similarity) samples after an obstacle appears; the Table 5 measures.

    Append one sample per control cycle; times are absolute (simulation seconds) and measured
    from ``t0``, the moment the obstacle appeared.

    Attributes:
        t0: s, when the obstacle appeared.
        tolerance: a sample within this of the best counts as having reached it.
        times: s after ``t0`` of each sample.
        values: similarity of each sample.
    """

    t0: float = 0.0
    tolerance: float = 0.01
    times: list[float] = field(default_factory=list)
    values: list[float] = field(default_factory=list)

    def append(self, t: float, similarity: float) -> None:
        """Record the similarity at absolute time ``t`` (s); samples before ``t0`` are ignored."""
        if t >= self.t0 and math.isfinite(similarity):
            self.times.append(float(t) - self.t0)
            self.values.append(float(similarity))

    @property
    def best(self) -> float:
        """Best similarity reached (NaN without samples)."""
        return max(self.values) if self.values else math.nan

    @property
    def time_to_best(self) -> float:
        """Seconds after ``t0`` of the first sample within ``tolerance`` of the best (or NaN)."""
        if not self.values:
            return math.nan
        target = self.best - self.tolerance
        return next(t for t, v in zip(self.times, self.values, strict=True) if v >= target)

    def value_at(self, t: float) -> float:
        """Similarity of the last sample at or before ``t`` s after ``t0`` (NaN if none)."""
        last = math.nan
        for tt, v in zip(self.times, self.values, strict=True):
            if tt > t + 1e-12:
                break
            last = v
        return last

    def best_within(self, t: float) -> float:
        """Best similarity among the samples up to ``t`` s after ``t0`` (NaN if none)."""
        vals = [v for tt, v in zip(self.times, self.values, strict=True) if tt <= t + 1e-12]
        return max(vals) if vals else math.nan

    def summary(self, at: float = 0.5) -> SimilaritySummary:
        """Table 5 measures, with ``at`` (s) the time of the "similarity at 0.5 s" rows."""
        return SimilaritySummary(
            best=self.best,
            time_to_best=self.time_to_best,
            at_half_second=self.value_at(at),
            best_within_half_second=self.best_within(at),
            n_samples=len(self.values),
        )
