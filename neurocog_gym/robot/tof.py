"""The four time-of-flight depth sensors (Pico Flexx) on the front of the torso (§4.1, Fig. 3).

Each sensor is a pinhole depth camera at a MuJoCo site (``TOF_SITES``, left to right). Site frame:
+x optical axis, +y left, +z up. The fan (yaws) and the downward pitch live in the model's site
orientations, so this module knows nothing of them: every sensor casts its own
``h_fov × v_fov`` frustum around its site's +x axis. Rays are cast with ``mujoco.mj_multiRay``
(no OpenGL), skipping the robot's own geoms through the geom-group mask ``RAY_GEOM_GROUPS``.

Choices (SPEC §2 leaves them open):

- **Pixel grid.** A real ToF camera is a pinhole, so the rays are evenly spaced on the image plane
  (not in angle): pixel ``(r, c)`` looks along ``(1, u_c, v_r)`` normalised, with ``u`` and ``v``
  evenly spaced from ``+tan(h_fov/2)`` to ``-tan(h_fov/2)`` and from ``+tan(v_fov/2)`` to
  ``-tan(v_fov/2)``. The outermost pixel rays lie exactly on the field-of-view edges (±22.5°
  horizontally, ±31° vertically, measured in the horizontal and vertical planes of the image).
  Row 0 is the top of the image, column 0 its left (+y) side, as in a camera image.
- **Depth** is z-depth along the optical axis (what a ToF camera's depth image reports), not the
  ray length. The range gate ``[min_range, max_range]`` applies to the ray length (distance from
  the sensor to the surface), as the datasheet's operating range does.
- **Invalid pixels** (no hit, or hit outside the range gate) have depth 0.0 and ``valid`` False,
  and give no point; ``points`` never holds NaN or inf.
- **Resolution.** Full resolution is 224 × 172 per sensor (154,112 rays a frame). The default is
  one quarter per axis, 56 × 43 (9,632 rays a frame): about 0.8° per pixel, i.e. 1.4 cm between
  samples at 1 m, so a 6 cm block still spans several rows, while a frame costs a few ms instead
  of ~50 ms with ``mj_multiRay`` (see ``docs/generated/benchmarks_tof.md``).
- **Frame rate.** Default 45 fps, the Pico Flexx's fastest mode and the spec's cap. The gate
  (``due``/``maybe_sense``) keeps a drift-free schedule ``t0 + k / fps``; with a 0.01 s control
  cycle frames come every 2 or 3 cycles, averaging exactly 45 fps.
- **Noise** (off by default): Gaussian error along the ray with standard deviation proportional
  to the distance (``noise_std_rel``; the datasheet gives ≤ 1 % of distance at 5 fps and ≤ 2 %
  at 45 fps), and random pixel dropout. Draws come from the array's own seeded generator and are
  drawn for every pixel every frame, so a seed gives the same frames whatever the scene.
- **Backends.** ``"mujoco"`` (default, SPEC §2) calls ``mj_multiRay`` once per sensor.
  ``"numba"`` is an opt-in caster written here for MuJoCo's primitive geom types (plane, sphere,
  capsule, ellipsoid, cylinder, box) that follows ``mj_multiRay``'s intersection and exclusion
  rules (geom-group mask, fully transparent geoms skipped) and is tested against it; it is several
  times faster because it culls geoms per sensor and does not visit the robot's bodies per ray.

Kinematics are read from ``data`` as they are (``site_xpos``, ``site_xmat``, ``geom_xpos``,
``geom_xmat``), i.e. as left by the last ``mj_step``/``mj_forward``/``mj_kinematics``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
from numba import njit

from neurocog_gym.robot.names import RAY_GEOM_GROUPS, TOF_SITES

FULL_WIDTH: int = 224
"""Pico Flexx image width, pixels."""
FULL_HEIGHT: int = 172
"""Pico Flexx image height, pixels."""
MAX_FPS: float = 45.0
"""Pico Flexx's fastest frame rate, frames/s (SPEC §2)."""

_BACKENDS = ("mujoco", "numba")
_TIME_EPS = 1e-9  # s; absorbs float error of sums like 3 * 0.01 against k / fps
_MINVAL = 1e-15  # MuJoCo's mjMINVAL
_PLANE, _SPHERE, _CAPSULE, _ELLIPSOID, _CYLINDER, _BOX = (
    int(mujoco.mjtGeom.mjGEOM_PLANE),
    int(mujoco.mjtGeom.mjGEOM_SPHERE),
    int(mujoco.mjtGeom.mjGEOM_CAPSULE),
    int(mujoco.mjtGeom.mjGEOM_ELLIPSOID),
    int(mujoco.mjtGeom.mjGEOM_CYLINDER),
    int(mujoco.mjtGeom.mjGEOM_BOX),
)
_PRIMITIVES = (_PLANE, _SPHERE, _CAPSULE, _ELLIPSOID, _CYLINDER, _BOX)


@dataclass(frozen=True)
class ToFParams:
    """Parameters of the ToF sensor array (Pico Flexx, §4.1; SPEC §2).

    Override with ``dataclasses.replace``; ``ToFParams.at_scale(1.0)`` is full resolution.
    """

    width: int = FULL_WIDTH // 4
    """W, image width, pixels per sensor (full resolution 224, Pico Flexx; default 1/4)."""
    height: int = FULL_HEIGHT // 4
    """H, image height, pixels per sensor (full resolution 172, Pico Flexx; default 1/4)."""
    h_fov_deg: float = 45.0
    """Horizontal field of view of one sensor, degrees (§4.1)."""
    v_fov_deg: float = 62.0
    """Vertical field of view of one sensor, degrees (§4.1)."""
    min_range: float = 0.1
    """Nearest valid return, metres, along the ray (Pico Flexx datasheet; SPEC §2)."""
    max_range: float = 4.0
    """Farthest valid return, metres, along the ray (Pico Flexx datasheet; SPEC §2)."""
    fps: float = MAX_FPS
    """Frame rate, frames/s, at most 45 (Pico Flexx's fastest mode; SPEC §2)."""
    noise_std_rel: float = 0.0
    """σ_d / d, Gaussian range noise per metre of distance, 1 (datasheet ≤ 0.01–0.02; 0 = off)."""
    dropout: float = 0.0
    """Probability that a valid pixel returns nothing, 1 (0 = off; our choice)."""
    site_names: tuple[str, ...] = TOF_SITES
    """Sensor sites in the model, left to right (``names.TOF_SITES``)."""
    backend: str = "mujoco"
    """Ray caster: ``"mujoco"`` (mj_multiRay, SPEC §2) or ``"numba"`` (primitives only)."""

    def __post_init__(self) -> None:
        for name in ("width", "height"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise ValueError(f"ToFParams.{name} must be a positive integer, got {value!r}")
        for name in ("h_fov_deg", "v_fov_deg"):
            value = getattr(self, name)
            if not 0.0 < value < 180.0:
                raise ValueError(f"ToFParams.{name} must be in (0, 180) degrees, got {value!r}")
        if not 0.0 <= self.min_range < self.max_range or not math.isfinite(self.max_range):
            raise ValueError(
                "ToFParams needs 0 <= min_range < max_range < inf, got "
                f"min_range={self.min_range!r}, max_range={self.max_range!r}"
            )
        if not 0.0 < self.fps <= MAX_FPS:
            raise ValueError(
                f"ToFParams.fps must be in (0, {MAX_FPS:g}] frames/s, got {self.fps!r}"
            )
        if not (self.noise_std_rel >= 0.0 and math.isfinite(self.noise_std_rel)):
            raise ValueError(f"ToFParams.noise_std_rel must be >= 0, got {self.noise_std_rel!r}")
        if not 0.0 <= self.dropout < 1.0:
            raise ValueError(f"ToFParams.dropout must be in [0, 1), got {self.dropout!r}")
        if len(self.site_names) == 0 or len(set(self.site_names)) != len(self.site_names):
            raise ValueError(
                f"ToFParams.site_names must be non-empty and unique, got {self.site_names!r}"
            )
        if self.backend not in _BACKENDS:
            raise ValueError(f"ToFParams.backend must be one of {_BACKENDS}, got {self.backend!r}")

    @classmethod
    def at_scale(cls, scale: float, **overrides) -> ToFParams:
        """Parameters at ``scale`` times the full 224 × 172 resolution per axis.

        Args:
            scale: resolution factor per axis, > 0 (1.0 = full, 0.25 = the default 56 × 43).
            **overrides: any other field.

        Returns:
            ToFParams with ``width = round(224 * scale)``, ``height = round(172 * scale)``.
        """
        if not scale > 0.0:
            raise ValueError(f"resolution scale must be > 0, got {scale!r}")
        width = max(1, round(FULL_WIDTH * scale))
        height = max(1, round(FULL_HEIGHT * scale))
        return cls(width=width, height=height, **overrides)

    @property
    def n_sensors(self) -> int:
        """Number of sensors S."""
        return len(self.site_names)

    @property
    def n_rays(self) -> int:
        """Rays a frame, S × H × W (154,112 at full resolution)."""
        return self.n_sensors * self.width * self.height

    @property
    def period(self) -> float:
        """Time between frames, seconds."""
        return 1.0 / self.fps


@dataclass(frozen=True, eq=False)
class ToFFrame:
    """One frame of the sensor array (S sensors of H × W pixels).

    Attributes:
        points: (N, 3) float32, metres, world frame. Valid returns only, sensor by sensor, each
            in row-major pixel order; never NaN or inf.
        depth: (S, H, W) float32, metres, z-depth along each sensor's optical axis; 0.0 where
            invalid.
        valid: (S, H, W) bool, True where the pixel has a return within the range gate.
        geom: (S, H, W) int32, id of the geom each valid pixel sees, -1 where invalid (ground truth
            for tests and labels; a real sensor has no such channel).
        origins: (S, 3) float64, metres, world position of each sensor (its site).
        counts: (S,) int64, number of points from each sensor; ``counts.sum() == N``.
        time: simulation time of the frame, seconds (``data.time``).
    """

    points: np.ndarray
    depth: np.ndarray
    valid: np.ndarray
    geom: np.ndarray
    origins: np.ndarray
    counts: np.ndarray
    time: float


class ToFArray:
    """The ToF sensor array: precomputed rays, preallocated buffers, a frame-rate gate.

    Example:
        >>> tof = ToFArray(model, ToFParams(), seed=0)
        >>> frame = tof.maybe_sense(data)  # None unless a frame is due at data.time
    """

    def __init__(
        self, model: mujoco.MjModel, params: ToFParams | None = None, seed: int | None = None
    ) -> None:
        """Build the array for ``model``.

        Args:
            model: compiled model holding the sites ``params.site_names``.
            params: sensor parameters; ``ToFParams()`` if None.
            seed: seed of the noise generator (only used when noise or dropout is on).

        Raises:
            ValueError: a site is missing from the model, or the numba backend meets a
                ray-visible geom that is not a primitive.
        """
        self.params = params if params is not None else ToFParams()
        self.model = model
        p = self.params

        names = [model.site(i).name for i in range(model.nsite)]
        missing = [s for s in p.site_names if s not in names]
        if missing:
            raise ValueError(f"ToF site(s) {missing} not found in the model; it has sites {names}")
        self.site_ids = np.array(
            [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, s) for s in p.site_names],
            dtype=np.int64,
        )
        self._geomgroup = np.array(RAY_GEOM_GROUPS, dtype=np.uint8)

        # Per-pixel unit rays in the site frame (pinhole, see module docstring).
        u = np.linspace(
            math.tan(math.radians(p.h_fov_deg) / 2),
            -math.tan(math.radians(p.h_fov_deg) / 2),
            p.width,
        )
        v = np.linspace(
            math.tan(math.radians(p.v_fov_deg) / 2),
            -math.tan(math.radians(p.v_fov_deg) / 2),
            p.height,
        )
        vv, uu = np.meshgrid(v, u, indexing="ij")
        dirs = np.stack([np.ones_like(uu), uu, vv], axis=-1).reshape(-1, 3)
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        self._dirs = np.ascontiguousarray(dirs)
        self._dirs.flags.writeable = False
        self._cos_axis = np.ascontiguousarray(self._dirs[:, 0])
        # The same rays as three rows (x, y, z), for loops that LLVM vectorises.
        self._dirs_t = np.ascontiguousarray(self._dirs.T)
        self._dirs_t.flags.writeable = False

        s, n = p.n_sensors, p.width * p.height
        self._n = n
        self._vec = np.zeros((s, 3, n))  # world-frame rays, a row per axis
        self._dist = np.zeros((s, n))
        self._geomid = np.zeros((s, n), dtype=np.int32)
        self._gauss = np.zeros((s, n))
        self._unif = np.ones((s, n))
        self._depth = np.zeros((s, n), dtype=np.float32)
        self._valid = np.zeros((s, n), dtype=np.bool_)
        self._points = np.zeros((s * n, 3), dtype=np.float32)
        self._origins = np.zeros((s, 3))
        self._counts = np.zeros(s, dtype=np.int64)
        self._views: tuple[np.ndarray, ...] | None = None  # read-only views (``sense``)
        self._noisy = p.noise_std_rel > 0.0 or p.dropout > 0.0

        # numba backend: the ray-visible geoms (geom groups are read here, once; alphas, sizes
        # and poses every frame), and the half-angle of the cone around the
        # optical axis that holds every ray (the corner rays) for per-sensor culling.
        group = np.clip(model.geom_group, 0, len(self._geomgroup) - 1)
        self._cand = np.flatnonzero(self._geomgroup[group] != 0).astype(np.int64)
        self._cone_cos = float(self._cos_axis.min())
        self._table = np.zeros((len(self._cand), _T_LEN))
        self._table_id = np.zeros(len(self._cand), dtype=np.int32)
        if p.backend == "numba":
            bad = [g for g in self._cand if model.geom_type[g] not in _PRIMITIVES]
            if bad:
                g = int(bad[0])
                kind = mujoco.mjtGeom(int(model.geom_type[g])).name
                raise ValueError(
                    f"the numba ToF backend casts only primitive geoms; geom {g} "
                    f"({model.geom(g).name!r}, {kind}) is ray-visible: use backend='mujoco'"
                )

        self._rng = np.random.default_rng(seed)
        self._next_time: float | None = None
        self._last_time = -math.inf

    @property
    def directions(self) -> np.ndarray:
        """(H·W, 3) float64, unit ray directions in the site frame, row-major pixels (read-only)."""
        return self._dirs

    @property
    def n_rays(self) -> int:
        """Rays a frame, S × H × W."""
        return self.params.n_rays

    def __getstate__(self) -> dict:
        # The shared views belong to this object's buffers: a pickled or deep-copied array
        # makes its own at its first ``sense(copy=False)`` (a copied view would not change).
        state = self.__dict__.copy()
        state["_views"] = None
        return state

    def reset(self, seed: int | None = None) -> None:
        """Restart the frame schedule (next call of ``maybe_sense`` senses); reseed if given."""
        if seed is not None:
            self._rng = np.random.default_rng(seed)
        self._next_time = None
        self._last_time = -math.inf

    def due(self, t: float) -> bool:
        """Whether a frame is due at simulation time ``t`` (seconds).

        True on the first call after construction or ``reset``, when time went backwards (an
        episode restarted), and from each scheduled frame time ``t0 + k / fps`` on.
        """
        return self._next_time is None or t < self._last_time or t >= self._next_time - _TIME_EPS

    def maybe_sense(self, data: mujoco.MjData, copy: bool = True) -> ToFFrame | None:
        """Sense if a frame is due at ``data.time``, else return None.

        Args:
            data: simulation state with current kinematics.
            copy: as in ``sense``.

        Returns:
            The frame, or None when the sensors are between frames.
        """
        t = float(data.time)
        if not self.due(t):
            return None
        frame = self.sense(data, copy=copy)
        period = self.params.period
        if self._next_time is None or t < self._last_time or t >= self._next_time + period:
            self._next_time = t + period  # (re)anchor; never burst to catch up
        else:
            self._next_time += period
        self._last_time = t
        return frame

    def sense(self, data: mujoco.MjData, copy: bool = True) -> ToFFrame:
        """Cast all rays now, whatever the frame schedule (which it leaves alone).

        Args:
            data: simulation state with current kinematics.
            copy: if True the frame owns its arrays; if False they are read-only views into
                buffers that the next ``sense`` overwrites (no allocation beyond the frame
                object).

        Returns:
            The frame.
        """
        p = self.params
        m = self.model
        if p.backend == "mujoco":
            _rotate_rays(self._dirs_t, data.site_xmat, self.site_ids, self._vec)
            for i, sid in enumerate(self.site_ids):
                mujoco.mj_multiRay(
                    m,
                    data,
                    data.site_xpos[sid],
                    self._vec[i].T.reshape(-1),  # (n, 3) rows, as mj_multiRay reads them
                    self._geomgroup,
                    1,
                    -1,
                    self._geomid[i],
                    self._dist[i],
                    None,
                    self._n,
                    p.max_range,
                )
        else:
            _cast_primitives(
                self._dirs_t,
                self._cone_cos,
                data.site_xpos,
                data.site_xmat,
                self.site_ids,
                self._cand,
                m.geom_type,
                m.geom_size,
                m.geom_rgba,
                m.geom_matid,
                m.mat_rgba,
                data.geom_xpos,
                data.geom_xmat,
                p.max_range,
                self._table,
                self._table_id,
                self._vec,
                self._dist,
                self._geomid,
            )
        if self._noisy:
            self._rng.standard_normal(out=self._gauss)
            self._rng.random(out=self._unif)
        total = _pack(
            self._vec,
            self._cos_axis,
            data.site_xpos,
            self.site_ids,
            self._dist,
            self._geomid,
            p.min_range,
            p.max_range,
            p.noise_std_rel,
            p.dropout,
            self._gauss,
            self._unif,
            self._depth,
            self._valid,
            self._points,
            self._origins,
            self._counts,
        )
        if copy:
            shape = (p.n_sensors, p.height, p.width)
            arrays = (
                self._points[:total],
                self._depth.reshape(shape),
                self._valid.reshape(shape),
                self._geomid.reshape(shape),
                self._origins,
                self._counts,
            )
            return ToFFrame(*(a.copy() for a in arrays), time=float(data.time))
        # Views of the buffers: read-only, so that only the next frame changes them. The
        # buffers never move, so the fixed-size views are made once and shared by the frames.
        points = self._points[:total]
        points.flags.writeable = False
        if self._views is None:
            shape = (p.n_sensors, p.height, p.width)
            views = (
                self._depth.reshape(shape), self._valid.reshape(shape),
                self._geomid.reshape(shape), self._origins.view(), self._counts.view(),
            )  # fmt: skip
            for a in views:
                a.flags.writeable = False
            self._views = views
        return ToFFrame(points, *self._views, time=float(data.time))


# ---------------------------------------------------------------------------------------------
# Kernels: pure functions over arrays; the class above owns the buffers. Site and geom poses are
# copied into local scalars before the per-ray loops: numba cannot prove that the output buffers
# do not alias them, and would reload them for every ray otherwise.


@njit(cache=True)
def _rotate_rays(dirs_t, site_xmat, site_ids, out):  # pragma: no cover - compiled
    """Rotate site-frame rays into the world: ``out[s, :, k] = R_s @ dirs_t[:, k]``.

    Rays are stored a row per axis (x, y, z), so that this loop and the casts' loops over the
    rays vectorise (strided rows of three keep them scalar).

    Args:
        dirs_t: (3, n) float64, unit rays in the site frame, a row per axis.
        site_xmat: (nsite, 9) float64, row-major site orientations (``data.site_xmat``).
        site_ids: (S,) int64, the sensors' site ids.
        out: (S, 3, n) float64, written.
    """
    for s in range(site_ids.shape[0]):
        i = site_ids[s]
        r0, r1, r2 = site_xmat[i, 0], site_xmat[i, 1], site_xmat[i, 2]
        r3, r4, r5 = site_xmat[i, 3], site_xmat[i, 4], site_xmat[i, 5]
        r6, r7, r8 = site_xmat[i, 6], site_xmat[i, 7], site_xmat[i, 8]
        for k in range(dirs_t.shape[1]):
            d0, d1, d2 = dirs_t[0, k], dirs_t[1, k], dirs_t[2, k]
            out[s, 0, k] = r0 * d0 + r1 * d1 + r2 * d2
            out[s, 1, k] = r3 * d0 + r4 * d1 + r5 * d2
            out[s, 2, k] = r6 * d0 + r7 * d1 + r8 * d2


# nogil: the two kernels of a frame that run long enough (0.02-0.4 ms) for another thread to
# use the GIL meanwhile (BatchVectorEnv steps sub-envs on threads); the short ones keep it, a
# GIL hand-over costs tens of microseconds.
@njit(cache=True, nogil=True)
def _pack(
    vec,
    cos_axis,
    site_xpos,
    site_ids,
    dist,
    geomid,
    min_range,
    max_range,
    noise_std_rel,
    dropout,
    gauss,
    unif,
    depth,
    valid,
    points,
    origins,
    counts,
):  # pragma: no cover - compiled
    """Apply noise and the range gate, write depth, validity and packed world points.

    Args:
        vec: (S, 3, n) float64, unit rays in the world frame (:func:`_rotate_rays`).
        cos_axis: (n,) float64, cosine of each ray to the optical axis (z-depth = d · cos).
        site_xpos: (nsite, 3) float64, metres, site positions (``data.site_xpos``).
        site_ids: (S,) int64, the sensors' site ids.
        dist: (S, n) float64, metres, ray length to the hit, < 0 for none.
        geomid: (S, n) int32, geom hit; set to -1 where the pixel ends up invalid.
        min_range: metres, nearest valid ray length.
        max_range: metres, farthest valid ray length.
        noise_std_rel: σ_d / d, 1.
        dropout: probability a valid pixel is dropped, 1.
        gauss: (S, n) float64, standard normal draws (read only if noise_std_rel > 0).
        unif: (S, n) float64, uniform [0, 1) draws (read only if dropout > 0).
        depth: (S, n) float32, metres, written (0 where invalid).
        valid: (S, n) bool, written.
        points: (S·n, 3) float32, metres, world frame; the first ``total`` rows are written.
        origins: (S, 3) float64, metres, written with the sensor positions.
        counts: (S,) int64, written with points per sensor.

    Returns:
        total, the number of points written.
    """
    noisy = noise_std_rel > 0.0
    drop = dropout > 0.0
    total = 0
    for s in range(site_ids.shape[0]):
        i = site_ids[s]
        o0, o1, o2 = site_xpos[i, 0], site_xpos[i, 1], site_xpos[i, 2]
        origins[s, 0], origins[s, 1], origins[s, 2] = o0, o1, o2
        start = total
        for k in range(vec.shape[2]):
            d = dist[s, k]
            ok = d >= 0.0
            if ok and noisy:
                d = d * (1.0 + noise_std_rel * gauss[s, k])
            if ok and drop and unif[s, k] < dropout:
                ok = False
            if ok and (d < min_range or d > max_range):
                ok = False
            valid[s, k] = ok
            if not ok:
                depth[s, k] = 0.0
                geomid[s, k] = -1
                continue
            depth[s, k] = d * cos_axis[k]
            points[total, 0] = o0 + d * vec[s, 0, k]
            points[total, 1] = o1 + d * vec[s, 1, k]
            points[total, 2] = o2 + d * vec[s, 2, k]
            total += 1
        counts[s] = total - start
    return total


@njit(cache=True, inline="always")
def _quad_roots(a, b, c):  # pragma: no cover - compiled
    """Roots of a·x² + 2b·x + c = 0 as MuJoCo's ray_quad; (-1, -1) if none."""
    det = b * b - a * c
    if det < _MINVAL:
        return -1.0, -1.0
    det = math.sqrt(det)
    return (-b - det) / a, (-b + det) / a


@njit(cache=True, inline="always")
def _first_root(a, b, c):  # pragma: no cover - compiled
    """Nearest non-negative root of a·x² + 2b·x + c = 0, -1 if none (MuJoCo's ray_quad)."""
    x0, x1 = _quad_roots(a, b, c)
    if x0 >= 0.0:
        return x0
    if x1 >= 0.0:
        return x1
    return -1.0


@njit(cache=True, inline="always")
def _take(x, sol):  # pragma: no cover - compiled
    """The nearer of two ray lengths, -1 meaning none."""
    if sol >= 0.0 and (x < 0.0 or sol < x):
        return sol
    return x


@njit(cache=True, inline="always")
def _ray_box_face(x, lpi, lvi, si, lpj, lvj, sj, lpk, lvk, sk):  # pragma: no cover - compiled
    """Nearer of ``x`` and the hits on the two box faces normal to local axis i."""
    if abs(lvi) > _MINVAL:
        for side in (-1.0, 1.0):
            sol = (side * si - lpi) / lvi
            if sol >= 0.0 and abs(lpj + sol * lvj) <= sj and abs(lpk + sol * lvk) <= sk:
                x = _take(x, sol)
    return x


@njit(cache=True, inline="always")
def _ray_geom(gtype, s0, s1, s2, lp0, lp1, lp2, lv0, lv1, lv2):  # pragma: no cover - compiled
    """Ray length to a primitive geom in its own frame, -1 if none (MuJoCo's engine_ray.c).

    Args:
        gtype: mjtGeom of the geom (a primitive).
        s0: ``geom_size[0]``, metres.
        s1: ``geom_size[1]``, metres.
        s2: ``geom_size[2]``, metres.
        lp0: ray origin x in the geom frame, metres.
        lp1: ray origin y in the geom frame, metres.
        lp2: ray origin z in the geom frame, metres.
        lv0: ray direction x in the geom frame (unit vector).
        lv1: ray direction y in the geom frame.
        lv2: ray direction z in the geom frame.
    """
    if gtype == _PLANE:
        if lv2 > -_MINVAL:
            return -1.0
        x = -lp2 / lv2
        if x < 0.0:
            return -1.0
        if (s0 <= 0.0 or abs(lp0 + x * lv0) <= s0) and (s1 <= 0.0 or abs(lp1 + x * lv1) <= s1):
            return x
        return -1.0
    if gtype == _BOX:
        x = _ray_box_face(-1.0, lp0, lv0, s0, lp1, lv1, s1, lp2, lv2, s2)
        x = _ray_box_face(x, lp1, lv1, s1, lp0, lv0, s0, lp2, lv2, s2)
        return _ray_box_face(x, lp2, lv2, s2, lp0, lv0, s0, lp1, lv1, s1)
    if gtype == _SPHERE:
        b = lv0 * lp0 + lv1 * lp1 + lv2 * lp2
        c = lp0 * lp0 + lp1 * lp1 + lp2 * lp2 - s0 * s0
        return _first_root(lv0 * lv0 + lv1 * lv1 + lv2 * lv2, b, c)
    if gtype == _ELLIPSOID:
        i0 = 1.0 / (s0 * s0)
        i1 = 1.0 / (s1 * s1)
        i2 = 1.0 / (s2 * s2)
        a = i0 * lv0 * lv0 + i1 * lv1 * lv1 + i2 * lv2 * lv2
        b = i0 * lv0 * lp0 + i1 * lv1 * lp1 + i2 * lv2 * lp2
        c = i0 * lp0 * lp0 + i1 * lp1 * lp1 + i2 * lp2 * lp2 - 1.0
        return _first_root(a, b, c)
    if gtype == _CYLINDER:
        x = -1.0
        if abs(lv2) > _MINVAL:
            for side in (-1.0, 1.0):
                sol = (side * s1 - lp2) / lv2
                if sol >= 0.0:
                    p0 = lp0 + sol * lv0
                    p1 = lp1 + sol * lv1
                    if p0 * p0 + p1 * p1 <= s0 * s0:
                        x = _take(x, sol)
        a = lv0 * lv0 + lv1 * lv1
        b = lv0 * lp0 + lv1 * lp1
        c = lp0 * lp0 + lp1 * lp1 - s0 * s0
        sol = _first_root(a, b, c)
        if sol >= 0.0 and abs(lp2 + sol * lv2) <= s1:
            x = _take(x, sol)
        return x
    if gtype == _CAPSULE:
        x = -1.0
        a = lv0 * lv0 + lv1 * lv1
        b = lv0 * lp0 + lv1 * lp1
        c = lp0 * lp0 + lp1 * lp1 - s0 * s0
        sol = _first_root(a, b, c)
        if sol >= 0.0 and abs(lp2 + sol * lv2) <= s1:
            x = _take(x, sol)
        a = lv0 * lv0 + lv1 * lv1 + lv2 * lv2
        for side in (-1.0, 1.0):
            dz = lp2 - side * s1
            b = lv0 * lp0 + lv1 * lp1 + lv2 * dz
            c = lp0 * lp0 + lp1 * lp1 + dz * dz - s0 * s0
            x0, x1 = _quad_roots(a, b, c)
            # each cap's hemisphere only (MuJoCo accepts z >= s1 at the top, z <= -s1 below)
            if x0 >= 0.0 and side * (lp2 + x0 * lv2) >= s1:
                x = _take(x, x0)
            if x1 >= 0.0 and side * (lp2 + x1 * lv2) >= s1:
                x = _take(x, x1)
        return x
    return -1.0


@njit(cache=True, inline="always")
def _bound_radius(gtype, s0, s1, s2):  # pragma: no cover - compiled
    """Radius of a sphere about the geom's centre that holds it, metres (inf for planes)."""
    if gtype == _PLANE:
        return math.inf
    if gtype == _SPHERE:
        return s0
    if gtype == _CAPSULE:
        return s0 + s1
    if gtype == _CYLINDER:
        return math.sqrt(s0 * s0 + s1 * s1)
    if gtype == _ELLIPSOID:
        return max(s0, max(s1, s2))
    return math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)


# Columns of the geom table: type, bounding radius, size, sensor minus geom position e, mat, the
# ray origin in the geom frame (mat^T e) and the bounding-sphere term e·e - rb² (both the same
# for every ray of a sensor, so computed once per sensor and geom).
_T_TYPE, _T_RB, _T_SIZE, _T_E, _T_MAT, _T_LP, _T_C, _T_LEN = 0, 1, 2, 5, 8, 17, 20, 21


@njit(cache=True, error_model="numpy")
def _cast_plane(vec, s, g, s0, s1, lp0, lp1, lp2, x, dist, geomid):  # pragma: no cover - compiled
    """Take the hits of sensor ``s``'s rays on plane geom ``g`` where they are the nearest yet.

    The plane branch of :func:`_ray_geom` for every ray of one sensor, written without early
    returns and with NumPy's error model (no zero-divisor check), so that LLVM vectorises it.

    Args:
        vec: (S, 3, n) float64, unit rays in the world frame, a row per axis.
        s: sensor index.
        g: geom id.
        s0: ``geom_size[g, 0]``, metres (half size along x; <= 0 is infinite).
        s1: ``geom_size[g, 1]``, metres (half size along y; <= 0 is infinite).
        lp0: sensor position x in the geom frame, metres.
        lp1: sensor position y in the geom frame, metres.
        lp2: sensor position z in the geom frame, metres.
        x: (9,) float64, the geom's orientation (``geom_xmat[g]``).
        dist: (S, n) float64, metres, ray lengths to the nearest hit so far (-1: none); updated.
        geomid: (S, n) int32, geom of that hit (-1: none); updated.
    """
    x0, x1, x2, x3, x4, x5, x6, x7, x8 = x[0], x[1], x[2], x[3], x[4], x[5], x[6], x[7], x[8]
    for k in range(vec.shape[2]):
        vx = vec[s, 0, k]
        vy = vec[s, 1, k]
        vz = vec[s, 2, k]
        lv0 = x0 * vx + x3 * vy + x6 * vz
        lv1 = x1 * vx + x4 * vy + x7 * vz
        lv2 = x2 * vx + x5 * vy + x8 * vz
        t = -lp2 / lv2
        best = dist[s, k]
        if (
            not (lv2 > -_MINVAL)
            and t >= 0.0
            and (s0 <= 0.0 or abs(lp0 + t * lv0) <= s0)
            and (s1 <= 0.0 or abs(lp1 + t * lv1) <= s1)
            and (best < 0.0 or t < best)
        ):
            dist[s, k] = t
            geomid[s, k] = g


@njit(cache=True, nogil=True)
def _cast_primitives(
    dirs_t,
    cone_cos,
    site_xpos,
    site_xmat,
    site_ids,
    cand,
    geom_type,
    geom_size,
    geom_rgba,
    geom_matid,
    mat_rgba,
    geom_xpos,
    geom_xmat,
    max_range,
    table,
    table_id,
    vec,
    dist,
    geomid,
):  # pragma: no cover - compiled
    """Cast every sensor's rays against the primitive geoms ``cand`` (the numba backend).

    Follows ``mj_multiRay`` with ``flg_static=1``, ``bodyexclude=-1``: geoms whose geom (or
    material) alpha is 0 are skipped; the geom-group mask is already applied in ``cand``.
    Geoms whose bounding sphere lies beyond ``max_range`` or outside the sensor's view cone are
    culled once per sensor; each remaining non-plane geom gets a bounding-sphere test per ray.
    Geoms are the outer loop and rays the inner one (each ray still meets the geoms in the
    same order, so ties go the same way): a plane is then one vectorised pass
    (:func:`_cast_plane`).

    Args:
        dirs_t: (3, n) float64, unit rays in the site frame, a row per axis.
        cone_cos: cosine of the half-angle of the cone around +x that holds all rays.
        site_xpos: (nsite, 3) float64, ``data.site_xpos``.
        site_xmat: (nsite, 9) float64, ``data.site_xmat``.
        site_ids: (S,) int64, the sensors' site ids.
        cand: (G,) int64, ids of the ray-visible geoms (all primitives).
        geom_type: (ngeom,) int32, ``model.geom_type``.
        geom_size: (ngeom, 3) float64, ``model.geom_size``.
        geom_rgba: (ngeom, 4) float32, ``model.geom_rgba``.
        geom_matid: (ngeom,) int32, ``model.geom_matid``.
        mat_rgba: (nmat, 4) float32, ``model.mat_rgba``.
        geom_xpos: (ngeom, 3) float64, ``data.geom_xpos``.
        geom_xmat: (ngeom, 9) float64, ``data.geom_xmat``.
        max_range: metres, cull distance.
        table: (G, 21) float64, scratch: the kept geoms' columns ``_T_*``.
        table_id: (G,) int32, scratch: their ids.
        vec: (S, 3, n) float64, written: the rays in the world frame (:func:`_rotate_rays`).
        dist: (S, n) float64, metres, written: ray length to the nearest hit, -1 if none.
        geomid: (S, n) int32, written: geom hit, -1 if none.
    """
    cone_sin = math.sqrt(max(0.0, 1.0 - cone_cos * cone_cos))
    _rotate_rays(dirs_t, site_xmat, site_ids, vec)
    for s in range(site_ids.shape[0]):
        i = site_ids[s]
        o0, o1, o2 = site_xpos[i, 0], site_xpos[i, 1], site_xpos[i, 2]
        r0, r3, r6 = site_xmat[i, 0], site_xmat[i, 3], site_xmat[i, 6]
        na = 0
        for gi in range(cand.shape[0]):
            g = cand[gi]
            m = geom_matid[g]
            if (m < 0 and geom_rgba[g, 3] == 0.0) or (m >= 0 and mat_rgba[m, 3] == 0.0):
                continue
            gt = geom_type[g]
            rb = _bound_radius(gt, geom_size[g, 0], geom_size[g, 1], geom_size[g, 2])
            if gt != _PLANE:
                c0 = geom_xpos[g, 0] - o0
                c1 = geom_xpos[g, 1] - o1
                c2 = geom_xpos[g, 2] - o2
                dc = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
                if dc - rb > max_range:
                    continue
                if dc > rb:
                    # distance of the centre from the view cone, dc·sin(θ − α), against rb
                    along = r0 * c0 + r3 * c1 + r6 * c2
                    off = math.sqrt(max(0.0, dc * dc - along * along))
                    if off * cone_cos - along * cone_sin > rb:
                        continue
            table[na, _T_TYPE] = gt
            table[na, _T_RB] = rb
            for j in range(3):
                table[na, _T_SIZE + j] = geom_size[g, j]
            e0 = o0 - geom_xpos[g, 0]
            e1 = o1 - geom_xpos[g, 1]
            e2 = o2 - geom_xpos[g, 2]
            table[na, _T_E] = e0
            table[na, _T_E + 1] = e1
            table[na, _T_E + 2] = e2
            for j in range(9):
                table[na, _T_MAT + j] = geom_xmat[g, j]
            x = geom_xmat[g]
            table[na, _T_LP] = x[0] * e0 + x[3] * e1 + x[6] * e2
            table[na, _T_LP + 1] = x[1] * e0 + x[4] * e1 + x[7] * e2
            table[na, _T_LP + 2] = x[2] * e0 + x[5] * e1 + x[8] * e2
            table[na, _T_C] = e0 * e0 + e1 * e1 + e2 * e2 - rb * rb
            table_id[na] = g
            na += 1
        for k in range(dirs_t.shape[1]):
            dist[s, k] = -1.0
            geomid[s, k] = -1
        for a in range(na):
            gt = int(table[a, _T_TYPE])
            g = table_id[a]
            s0, s1, s2 = table[a, _T_SIZE], table[a, _T_SIZE + 1], table[a, _T_SIZE + 2]
            e0, e1, e2 = table[a, _T_E], table[a, _T_E + 1], table[a, _T_E + 2]
            lp0, lp1, lp2 = table[a, _T_LP], table[a, _T_LP + 1], table[a, _T_LP + 2]
            if gt == _PLANE:
                _cast_plane(vec, s, g, s0, s1, lp0, lp1, lp2, table[a, _T_MAT:_T_LP], dist, geomid)
                continue
            c = table[a, _T_C]
            x0, x1, x2 = table[a, _T_MAT], table[a, _T_MAT + 1], table[a, _T_MAT + 2]
            x3, x4, x5 = table[a, _T_MAT + 3], table[a, _T_MAT + 4], table[a, _T_MAT + 5]
            x6, x7, x8 = table[a, _T_MAT + 6], table[a, _T_MAT + 7], table[a, _T_MAT + 8]
            for k in range(dirs_t.shape[1]):
                vx = vec[s, 0, k]
                vy = vec[s, 1, k]
                vz = vec[s, 2, k]
                best = dist[s, k]
                b = vx * e0 + vy * e1 + vz * e2
                if c > 0.0:
                    disc = b * b - c
                    if b > 0.0 or disc < 0.0:
                        continue  # misses the bounding sphere, or it lies behind
                    if best >= 0.0 and -b - math.sqrt(disc) > best:
                        continue  # bounding sphere wholly beyond the nearest hit so far
                t = _ray_geom(
                    gt, s0, s1, s2, lp0, lp1, lp2,
                    x0 * vx + x3 * vy + x6 * vz,
                    x1 * vx + x4 * vy + x7 * vz,
                    x2 * vx + x5 * vy + x8 * vz,
                )  # fmt: skip
                if t >= 0.0 and (best < 0.0 or t < best):
                    dist[s, k] = t
                    geomid[s, k] = g
