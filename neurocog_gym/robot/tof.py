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

from neurocog_gym.robot import _tof_kernels as _k
from neurocog_gym.robot.names import RAY_GEOM_GROUPS, TOF_SITES

FULL_WIDTH: int = 224
"""Pico Flexx image width, pixels."""
FULL_HEIGHT: int = 172
"""Pico Flexx image height, pixels."""
MAX_FPS: float = 45.0
"""Pico Flexx's fastest frame rate, frames/s (SPEC §2)."""

_BACKENDS = ("mujoco", "numba")
_TIME_EPS = 1e-9  # s; absorbs float error of sums like 3 * 0.01 against k / fps


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
        # mujoco backend: world-frame rays (a row per axis) and ray lengths of the whole frame;
        # the numba backend casts a tile of rows at a time in ``_tile_*`` instead.
        whole = n if p.backend == "mujoco" else 0
        self._vec = np.zeros((s, 3, whole))
        self._dist = np.zeros((s, whole))
        tile = max(1, _k.TILE_RAYS // p.width) * p.width
        self._tile_vec = np.zeros((3, tile))
        self._tile_dist = np.zeros(tile)
        self._tile_geomid = np.zeros(tile, dtype=np.int32)
        self._tile_points = np.zeros((3, tile), dtype=np.float32)
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
        self._tan_h = math.tan(math.radians(p.h_fov_deg) / 2)
        self._tan_v = math.tan(math.radians(p.v_fov_deg) / 2)
        self._table = np.zeros((len(self._cand), _k.T_LEN))
        self._table_id = np.zeros(len(self._cand), dtype=np.int32)
        if p.backend == "numba":
            bad = [g for g in self._cand if model.geom_type[g] not in _k.PRIMITIVES]
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
        if self._noisy:
            self._rng.standard_normal(out=self._gauss)
            self._rng.random(out=self._unif)
        if p.backend == "numba":
            total = _k.cast_frame(
                self._dirs_t,
                self._cone_cos,
                self._tan_h,
                self._tan_v,
                p.width,
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
                p.min_range,
                p.max_range,
                p.noise_std_rel,
                p.dropout,
                self._gauss,
                self._unif,
                self._table,
                self._table_id,
                self._tile_vec,
                self._tile_dist,
                self._tile_geomid,
                self._tile_points,
                self._depth,
                self._valid,
                self._geomid,
                self._points,
                self._origins,
                self._counts,
            )
        else:
            _k.rotate_rays(self._dirs_t, data.site_xmat, self.site_ids, self._vec)
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
            total = _k.pack_frame(
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
