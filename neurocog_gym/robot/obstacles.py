"""The pool of wooden-block obstacles: mocap box bodies moved into place at run time.

The scene (``assets/scene.xml``) holds ``N_SLOTS`` mocap bodies ``obstacle_0..``, each with one box
geom in world geom group 1 (seen by the time-of-flight rays, colliding with the robot). A parked
block sits below the floor, out of sight and out of reach. Placing a block rewrites its geom's
half-sizes and bounding volumes in the ``MjModel`` and its mocap pose in the ``MjData``, so no
model is rebuilt per episode. Mocap blocks do not move when pushed: a block the robot cannot
pass stays in its way, as a heavy wooden block on a high-friction floor would.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from numba import njit

N_SLOTS = 6
PARK_Z = -1.0
#: The paper's wooden blocks are 6, 7 and 8 cm high (§6.4).
PAPER_HEIGHTS = (0.06, 0.07, 0.08)


@dataclass(frozen=True)
class Block:
    """One wooden block resting on the floor.

    Attributes:
        x, y: centre of its footprint, metres, world frame.
        length: extent along world x before the yaw, metres.
        width: extent along world y before the yaw, metres.
        height: metres.
        yaw: rotation about world z, radians.
    """

    x: float
    y: float
    length: float
    width: float
    height: float
    yaw: float = 0.0

    def __post_init__(self):
        for name in ("length", "width", "height"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"Block.{name} must be a positive number, got {v}")

    @property
    def half_size(self) -> np.ndarray:
        """(3,) half extents, metres."""
        return np.array([self.length, self.width, self.height]) / 2.0

    @property
    def center(self) -> np.ndarray:
        """(3,) centre, metres (the block rests on z = 0)."""
        return np.array([self.x, self.y, self.height / 2.0])

    def corners_xy(self) -> np.ndarray:
        """(4, 2) footprint corners, metres."""
        c, s = np.cos(self.yaw), np.sin(self.yaw)
        hx, hy = self.length / 2, self.width / 2
        local = np.array([[hx, hy], [-hx, hy], [-hx, -hy], [hx, -hy]])
        return local @ np.array([[c, s], [-s, c]]) + np.array([self.x, self.y])

    def aabb(self) -> np.ndarray:
        """(2, 3) axis-aligned min/max corners, metres."""
        xy = self.corners_xy()
        return np.array([[*xy.min(axis=0), 0.0], [*xy.max(axis=0), self.height]], dtype=np.float64)

    def to_json(self) -> dict:
        """JSON-ready dict (for trial logs)."""
        return {k: float(getattr(self, k)) for k in ("x", "y", "length", "width", "height", "yaw")}


class ObstaclePool:
    """Places and parks the scene's obstacle blocks.

    Args:
        model: the compiled scene; must contain bodies ``obstacle_0 .. obstacle_{N-1}``.
    """

    def __init__(self, model: mujoco.MjModel):
        self.bodies: list[int] = []
        self.geoms: list[int] = []
        self.mocap: list[int] = []
        for i in range(N_SLOTS):
            try:
                body = model.body(f"obstacle_{i}").id
            except KeyError:
                break
            self.bodies.append(body)
            self.mocap.append(int(model.body_mocapid[body]))
            self.geoms.append(int(np.flatnonzero(model.geom_bodyid == body)[0]))
        if not self.bodies:
            raise ValueError("the scene has no obstacle bodies (obstacle_0, ...)")
        self.geom_ids = np.array(self.geoms)
        self._ngeom = int(model.ngeom)
        self._slot_of = np.full(self._ngeom, -1, dtype=np.int64)
        self._slot_of[self.geom_ids] = np.arange(len(self.geoms))
        self._robot_ref = None
        self._is_robot = np.zeros(self._ngeom, dtype=bool)
        self._boxes = np.zeros((0, 2, 3))
        self._json: list[dict] | None = None
        self.blocks: list[Block] = []

    @property
    def capacity(self) -> int:
        """Number of block slots in the scene."""
        return len(self.bodies)

    def clear(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Park every block below the floor."""
        for slot in range(self.capacity):
            data.mocap_pos[self.mocap[slot]] = (0.0, 3.0 * slot, PARK_Z)
            data.mocap_quat[self.mocap[slot]] = (1.0, 0.0, 0.0, 0.0)
        self.blocks = []
        self._json = None
        self._boxes = np.zeros((0, 2, 3))

    def place(self, model: mujoco.MjModel, data: mujoco.MjData, blocks: list[Block]) -> None:
        """Park all blocks, then put ``blocks`` in place (in slot order)."""
        if len(blocks) > self.capacity:
            raise ValueError(f"at most {self.capacity} blocks fit the scene, got {len(blocks)}")
        self.clear(model, data)
        for slot, block in enumerate(blocks):
            self._set(model, data, slot, block)
        self.blocks = list(blocks)
        self._json = None
        self._boxes = np.stack([b.aabb() for b in self.blocks]) if blocks else np.zeros((0, 2, 3))
        mujoco.mj_kinematics(model, data)

    def add(self, model: mujoco.MjModel, data: mujoco.MjData, block: Block) -> None:
        """Put one more block in the next free slot (a sudden obstacle)."""
        slot = len(self.blocks)
        if slot >= self.capacity:
            raise ValueError(f"all {self.capacity} obstacle slots are in use")
        self._set(model, data, slot, block)
        self.blocks.append(block)
        self._json = None
        self._boxes = np.stack([b.aabb() for b in self.blocks])
        mujoco.mj_kinematics(model, data)

    def _set(self, model, data, slot: int, block: Block) -> None:
        g = self.geoms[slot]
        half = block.half_size
        model.geom_size[g] = half
        model.geom_rbound[g] = float(np.linalg.norm(half))
        model.geom_aabb[g] = (0.0, 0.0, 0.0, *half)
        data.mocap_pos[self.mocap[slot]] = block.center
        data.mocap_quat[self.mocap[slot]] = (np.cos(block.yaw / 2), 0.0, 0.0, np.sin(block.yaw / 2))

    def blocks_json(self) -> list[dict]:
        """The placed blocks as JSON-ready dicts (fresh copies; for trial logs and ``info``)."""
        if self._json is None:
            self._json = [b.to_json() for b in self.blocks]
        return [dict(d) for d in self._json]

    def boxes(self) -> np.ndarray:
        """(K, 2, 3) axis-aligned bounds of the placed blocks, metres (a copy)."""
        return self._boxes.copy()

    def touching(self, data: mujoco.MjData, robot_geoms: np.ndarray) -> np.ndarray:
        """(K,) bool: which placed blocks are in contact with a robot geom now."""
        hit = np.zeros(len(self.blocks), dtype=bool)
        self._touching(data, robot_geoms, hit)
        return hit

    def touching_any(self, data: mujoco.MjData, robot_geoms: np.ndarray) -> bool:
        """Whether any placed block is in contact with a robot geom now."""
        return self._touching(data, robot_geoms, np.zeros(len(self.blocks), dtype=bool))

    def _touching(self, data: mujoco.MjData, robot_geoms: np.ndarray, hit: np.ndarray) -> bool:
        n = data.ncon
        if n == 0 or not self.blocks:
            return False
        if self._robot_ref is not robot_geoms:
            # Lookup tables by geom id: is it the robot's, and which block slot is it.
            self._is_robot = np.zeros(self._ngeom, dtype=bool)
            self._is_robot[np.asarray(robot_geoms)] = True
            self._robot_ref = robot_geoms
        # (n, 2) geom ids of each contact
        return _touching_kernel(data.contact.geom[:n], self._slot_of, self._is_robot, len(hit), hit)


@njit(cache=True)
def _touching_kernel(geom, slot_of, is_robot, n_blocks, hit):  # pragma: no cover - compiled
    """Mark ``hit[k]`` for each block slot k < ``n_blocks`` with a contact against a robot geom.

    Args:
        geom: (n, 2) int geom ids of each contact.
        slot_of: (ngeom,) int64 block slot of each geom, -1 for the rest.
        is_robot: (ngeom,) bool, whether each geom is the robot's.
        n_blocks: number of placed blocks.
        hit: (K,) bool, written.

    Returns:
        Whether any block is hit.
    """
    anyhit = False
    for c in range(geom.shape[0]):
        g0, g1 = geom[c, 0], geom[c, 1]
        s0, s1 = slot_of[g0], slot_of[g1]
        # A block touches the robot when the other geom of one of its contacts is the robot's.
        if 0 <= s0 < n_blocks and is_robot[g1]:
            hit[s0] = anyhit = True
        if 0 <= s1 < n_blocks and is_robot[g0]:
            hit[s1] = anyhit = True
    return anyhit


def random_block(
    rng: np.random.Generator,
    x: float,
    y: float,
    height_jitter: float = 0.005,
    length_range: tuple[float, float] = (0.05, 0.12),
    width_range: tuple[float, float] = (0.10, 0.30),
    yaw_range: float = 0.3,
) -> Block:
    """A wooden block around one of the paper's heights (6, 7 or 8 cm), random size and yaw."""
    h = float(rng.choice(PAPER_HEIGHTS)) + float(rng.uniform(-height_jitter, height_jitter))
    return Block(
        x=float(x),
        y=float(y),
        length=float(rng.uniform(*length_range)),
        width=float(rng.uniform(*width_range)),
        height=h,
        yaw=float(rng.uniform(-yaw_range, yaw_range)),
    )
