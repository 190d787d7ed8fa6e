"""Stepping stones over a pit: the scene built once with ``MjSpec``, the course placed at run time.

The scene is ``assets/scene.xml`` with its floor plane lowered to the pit's floor
(``z = -pit_depth``) and ``n_slots`` mocap bodies added, each one box geom in world geom group 1
(so the time-of-flight rays see it). Slot 0 is the start platform, slot 1 the end platform, the
others the stones. Every placed box's top is the walking surface, ``z = 0``; it reaches down to
``CLEARANCE`` above the pit floor (no contact with it, so no contact pair is ever formed between
two static bodies). A parked slot is a small box far away under the pit floor with contype =
conaffinity = 0.

Placing a course, without rebuilding the model, writes into the ``MjModel`` each slot's geom
half-sizes and bounding volumes (``geom_aabb``, ``geom_rbound`` and its body's BVH box
``bvh_aabb``, which the broad phase reads) and its collision bitmasks (contype 0, conaffinity 1: the
robot's contype 1 meets it, the floor and the other slots do not), and into the ``MjData`` its
``mocap_pos``. Moving stones slide along world y: :meth:`StonePool.move` sets their
``mocap_pos`` from the time (a mocap body is moved, not driven: MuJoCo gives it no velocity, so
a foot standing on a moving stone is not carried by friction; at a few cm/s the stone slides
under it by a fraction of a millimetre per physics step).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

N_STONE_SLOTS = 24
"""Mocap boxes in the scene: the two platforms and up to 22 stones."""
START, END = 0, 1
"""Slots of the start and the end platform."""
CLEARANCE = 0.005
"""m, gap between a placed box's bottom and the pit floor."""
PARK_Z = -5.0
"""m, height of a parked slot's centre."""
PLATFORM_HALF_WIDTH = 1.5
"""m, half width (world y) of the start and end platforms."""
PLATFORM_LENGTH = 3.0
"""m, length (world x) of each platform."""
STONE_RGBA = (0.55, 0.55, 0.52, 1.0)
PLATFORM_RGBA = (0.42, 0.46, 0.4, 1.0)


@dataclass(frozen=True)
class Stone:
    """One axis-aligned box whose top is the walking surface (z = 0).

    Attributes:
        x, y: centre of its top face, m, world frame (at reset; a moving stone's y changes).
        length: extent along world x, m.
        width: extent along world y, m.
        speed: m/s, sideways (world y) sliding speed; 0 for a still stone.
        amplitude: m, a moving stone slides within ±amplitude of ``y``.
        phase: m, where in its back-and-forth path it starts (0 .. 4 amplitude).
    """

    x: float
    y: float
    length: float
    width: float
    speed: float = 0.0
    amplitude: float = 0.0
    phase: float = 0.0

    def __post_init__(self):
        for name in ("length", "width"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"Stone.{name} must be a positive number, got {v}")
        if not (math.isfinite(self.speed) and self.speed >= 0):
            raise ValueError(f"Stone.speed must be a finite number >= 0, got {self.speed}")
        if not (math.isfinite(self.amplitude) and self.amplitude >= 0):
            raise ValueError(f"Stone.amplitude must be >= 0, got {self.amplitude}")

    def y_at(self, t: float) -> float:
        """Centre y at time ``t`` s: a triangle wave of ``amplitude`` at ``speed``, m."""
        if self.speed == 0.0 or self.amplitude == 0.0:
            return self.y
        a = self.amplitude
        s = (self.phase + self.speed * t) % (4.0 * a)  # distance travelled along one period
        # 0..a: y0 -> y0 + a; a..3a: back to y0 - a; 3a..4a: up to y0.
        off = s if s < a else (2.0 * a - s if s < 3.0 * a else s - 4.0 * a)
        return self.y + off

    def vy_at(self, t: float) -> float:
        """Sideways velocity at time ``t`` s, m/s (+speed, -speed or 0)."""
        if self.speed == 0.0 or self.amplitude == 0.0:
            return 0.0
        s = (self.phase + self.speed * t) % (4.0 * self.amplitude)
        return self.speed if (s < self.amplitude or s >= 3.0 * self.amplitude) else -self.speed

    def to_json(self) -> dict:
        """JSON-ready dict (trial logs)."""
        return {k: round(float(getattr(self, k)), 6) for k in
                ("x", "y", "length", "width", "speed", "amplitude", "phase")}  # fmt: skip


@dataclass(frozen=True)
class Course:
    """A drawn course: platforms and stones, all tops at z = 0.

    Attributes:
        start_edge: m, world x of the start platform's far edge (it reaches back from there).
        end_edge: m, world x of the end platform's near edge (the course ends there).
        stones: the stones, each row's in x order, the left row first.
    """

    start_edge: float
    end_edge: float
    stones: tuple[Stone, ...]

    def to_json(self) -> dict:
        """JSON-ready dict (trial logs)."""
        return {
            "start_edge": round(self.start_edge, 6),
            "end_edge": round(self.end_edge, 6),
            "stones": [s.to_json() for s in self.stones],
        }


@dataclass(frozen=True)
class CourseParams:
    """How a course is drawn (:func:`draw_course`); every range uniform, bounds inclusive.

    The robot's feet stand on two tracks about 24 cm apart (home pose: y = ±0.12 m) and a foot
    lands every ~25 cm along its track in the nominal trot (measured on Walk-v2: 0.44 m/s, each
    foot's touchdowns 0.24-0.26 m apart, a hind foot 3-4 cm behind the front foot's print). Issue
    26 gives the stones' size (12-25 cm across); the rest is designed from the gait: one row of
    stones under each track; gaps from a sole's width and a half (a foot can drop into it) to
    15 cm (shorter than the stride less a sole, so a step of nominal length from one stone can
    reach the next); the courses's length a few strides.
    """

    stone_size: tuple[float, float] = (0.12, 0.25)
    """m, each stone's length and width (issue 26: 12-25 cm across)."""
    gap: tuple[float, float] = (0.05, 0.15)
    """m, gap along x between a stone and the next one of its row (and the platforms)."""
    first_gap: tuple[float, float] = (0.25, 0.5)
    """m, from the home pose's front feet to the start platform's far edge."""
    course_length: tuple[float, float] = (1.0, 1.5)
    """m, stones are added to each row while they start less than this past the start edge."""
    track: float = 0.24
    """m, distance between the two rows' centre lines (the home pose's feet: ±0.12 m)."""
    lateral: float = 0.04
    """m, each stone's centre lies within ±lateral of its row's centre line."""
    move_speed: tuple[float, float] = (0.02, 0.05)
    """m/s, a moving stone's sliding speed (Video S3: a few cm/s)."""
    move_amplitude: float = 0.05
    """m, a moving stone slides within ±this of where it was placed."""

    def __post_init__(self):
        for name in ("stone_size", "gap", "first_gap", "course_length", "move_speed"):
            lo, hi = getattr(self, name)
            if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo <= hi):
                raise ValueError(
                    f"CourseParams.{name} must be (lo, hi) with 0 <= lo <= hi, got {(lo, hi)}"
                )
        if self.stone_size[0] <= 0:
            raise ValueError(f"CourseParams.stone_size must be positive, got {self.stone_size}")
        for name in ("track", "lateral", "move_amplitude"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"CourseParams.{name} must be a finite number >= 0, got {v}")


def draw_course(
    rng: np.random.Generator, params: CourseParams, front_x: float, moving: bool = False
) -> Course:
    """A random course ahead of front feet at world x = ``front_x``.

    Each row (left at y = +track/2, then right) starts ``gap`` past the start platform's edge
    and adds stones (``stone_size`` long and wide, ``lateral`` off its line, ``gap`` after the
    previous one) while the next would start within ``course_length`` of the start edge. The
    end platform starts ``gap`` after the row that ends last. With ``moving``, each stone gets a
    speed from ``move_speed``, a random direction phase and ``move_amplitude``.
    """
    p = params
    start = float(front_x + rng.uniform(*p.first_gap))
    length = float(rng.uniform(*p.course_length))
    stones: list[Stone] = []
    row_end = []
    for side in (1.0, -1.0):
        x = start + float(rng.uniform(*p.gap))
        while x < start + length:
            ln = float(rng.uniform(*p.stone_size))
            wd = float(rng.uniform(*p.stone_size))
            y = side * p.track / 2 + float(rng.uniform(-p.lateral, p.lateral))
            speed = amp = phase = 0.0
            if moving:
                speed = float(rng.uniform(*p.move_speed))
                amp = p.move_amplitude
                phase = float(rng.uniform(0.0, 4.0 * amp))
            stones.append(Stone(x + ln / 2, y, ln, wd, speed, amp, phase))
            x += ln + float(rng.uniform(*p.gap))
        row_end.append(stones[-1].x + stones[-1].length / 2 if stones else start)
    end = max(row_end) + float(rng.uniform(*p.gap))
    if len(stones) > N_STONE_SLOTS - 2:
        raise ValueError(
            f"the course needs {len(stones)} stones, the scene has {N_STONE_SLOTS - 2} slots: "
            "shorten course_length or lengthen the stones"
        )
    return Course(start, end, tuple(stones))


def build_model(pit_depth: float, n_slots: int = N_STONE_SLOTS, body: str = "v1") -> mujoco.MjModel:
    """The scene with its floor lowered to ``-pit_depth`` m and ``n_slots`` parked mocap boxes.

    ``body``: the robot body (``robot.model.BODIES``).
    """
    from neurocog_gym.robot.model import scene_spec

    spec = scene_spec(body)
    floor = spec.geom("floor")
    floor.pos = [0.0, 0.0, -float(pit_depth)]
    for k in range(n_slots):
        body = spec.worldbody.add_body(name=f"stone_{k}", mocap=True, pos=[0.0, 20.0 + k, PARK_Z])
        rgba = PLATFORM_RGBA if k in (START, END) else STONE_RGBA
        body.add_geom(name=f"stone_{k}", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.05, 0.05, 0.05],
                      group=1, contype=0, conaffinity=1, rgba=list(rgba),
                      friction=[1.0, 0.02, 0.01])  # fmt: skip
    return spec.compile()


class StonePool:
    """Places the course's boxes into the scene's mocap slots (``stone_0 ..``).

    Args:
        model: a model from :func:`build_model`.
        pit_depth: m, the pit floor's depth below the walking surface (as built).

    Attributes:
        course: the placed course (None before the first :meth:`place`).
        geom_ids: (N,) int64 geom of each slot.
        half_sizes: (N, 3) half extents of each slot's box as placed, m (0 for parked slots).
    """

    def __init__(self, model: mujoco.MjModel, pit_depth: float):
        bodies, geoms = [], []
        k = 0
        while True:
            try:
                b = model.body(f"stone_{k}").id
            except KeyError:
                break
            if model.body_mocapid[b] < 0:
                raise ValueError(f"stone_{k} must be a mocap body")
            bodies.append(b)
            geoms.append(int(np.flatnonzero(model.geom_bodyid == b)[0]))
            k += 1
        if k < 3:
            raise ValueError("the scene needs at least 3 stone slots (stone_0, ...)")
        self.body_ids = np.array(bodies, dtype=np.int64)
        self.geom_ids = np.array(geoms, dtype=np.int64)
        self.mocap_ids = np.array([model.body_mocapid[b] for b in bodies], dtype=np.int64)
        if np.any(model.body_bvhnum[self.body_ids] != 1):
            raise ValueError("each stone slot must be compiled with one colliding geom")
        self.bvh_ids = np.array([model.body_bvhadr[b] for b in bodies], dtype=np.int64)
        self.pit_depth = float(pit_depth)
        self.half_sizes = np.zeros((k, 3))
        self.course: Course | None = None
        self._moving: list[tuple[int, Stone]] = []
        self._slot_of = np.full(model.ngeom, -1, dtype=np.int64)
        self._slot_of[self.geom_ids] = np.arange(k)

    @property
    def capacity(self) -> int:
        """Slots in the scene (platforms included)."""
        return len(self.body_ids)

    @property
    def slot_of(self) -> np.ndarray:
        """(ngeom,) slot of each geom of the model, -1 for the rest (read-only)."""
        return self._slot_of

    def place(self, model: mujoco.MjModel, data: mujoco.MjData, course: Course) -> None:
        """Park every slot, then put the platforms and ``course.stones`` in place."""
        if len(course.stones) + 2 > self.capacity:
            raise ValueError(
                f"at most {self.capacity - 2} stones fit the scene, got {len(course.stones)}"
            )
        for slot in range(self.capacity):
            self._park(model, data, slot)
        half_z = 0.5 * (self.pit_depth - CLEARANCE)
        back = 0.5 * PLATFORM_LENGTH
        self._set(model, data, START, course.start_edge - back, 0.0, back, PLATFORM_HALF_WIDTH,
                  half_z)  # fmt: skip
        self._set(model, data, END, course.end_edge + back, 0.0, back, PLATFORM_HALF_WIDTH,
                  half_z)  # fmt: skip
        self._moving = []
        for k, s in enumerate(course.stones):
            slot = k + 2
            self._set(model, data, slot, s.x, s.y_at(0.0), s.length / 2, s.width / 2, half_z)
            if s.speed > 0 and s.amplitude > 0:
                self._moving.append((slot, s))
        self.course = course

    def _park(self, model, data, slot: int) -> None:
        g, b = self.geom_ids[slot], self.body_ids[slot]
        # The body's masks (the OR of its geoms', read by the broad phase) with the geom's.
        model.geom_contype[g] = model.geom_conaffinity[g] = 0
        model.body_contype[b] = model.body_conaffinity[b] = 0
        model.geom_size[g] = (0.05, 0.05, 0.05)
        model.geom_rbound[g] = float(np.linalg.norm(model.geom_size[g]))
        model.geom_aabb[g] = model.bvh_aabb[self.bvh_ids[slot]] = (0, 0, 0, 0.05, 0.05, 0.05)
        data.mocap_pos[self.mocap_ids[slot]] = (0.0, 20.0 + slot, PARK_Z)
        data.mocap_quat[self.mocap_ids[slot]] = (1.0, 0.0, 0.0, 0.0)
        self.half_sizes[slot] = 0.0

    def _set(self, model, data, slot, x, y, hx, hy, hz) -> None:
        g = self.geom_ids[slot]
        model.geom_size[g] = (hx, hy, hz)
        model.geom_rbound[g] = math.sqrt(hx * hx + hy * hy + hz * hz)
        # The broad phase bounds a body by its BVH root's box (compiled from the geom's size),
        # not by geom_aabb: a box grown at run time needs both, or its contacts are missed.
        model.geom_aabb[g] = model.bvh_aabb[self.bvh_ids[slot]] = (0.0, 0.0, 0.0, hx, hy, hz)
        # contype 0, conaffinity 1: the robot (contype 1) collides with it; the floor and the
        # other slots (contype 0 here) do not, so no contact pair between static boxes.
        b = self.body_ids[slot]
        model.geom_contype[g] = model.body_contype[b] = 0
        model.geom_conaffinity[g] = model.body_conaffinity[b] = 1
        data.mocap_pos[self.mocap_ids[slot]] = (x, y, -hz)
        self.half_sizes[slot] = (hx, hy, hz)

    @property
    def moving(self) -> bool:
        """Whether the placed course has moving stones."""
        return bool(self._moving)

    def move(self, data: mujoco.MjData, t: float) -> None:
        """Put every moving stone where it is at time ``t`` s."""
        for slot, s in self._moving:
            data.mocap_pos[self.mocap_ids[slot], 1] = s.y_at(t)

    def boxes(self, data: mujoco.MjData) -> np.ndarray:
        """(K, 2, 3) current min/max corners of the placed slots (platforms first), m."""
        k = 2 + (len(self.course.stones) if self.course is not None else 0)
        c = data.mocap_pos[self.mocap_ids[:k]]
        h = self.half_sizes[:k]
        return np.stack([c - h, c + h], axis=1)

    def support_at(self, data: mujoco.MjData, xy: np.ndarray) -> np.ndarray:
        """(N,) bool: which points ``xy`` ((N, 2), m) lie over a placed box's top (truth)."""
        b = self.boxes(data)
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        inside = (xy[:, None, 0] >= b[None, :, 0, 0]) & (xy[:, None, 0] <= b[None, :, 1, 0])
        inside &= (xy[:, None, 1] >= b[None, :, 0, 1]) & (xy[:, None, 1] <= b[None, :, 1, 1])
        return inside.any(axis=1)
