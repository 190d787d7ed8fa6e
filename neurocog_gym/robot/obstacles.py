"""The pool of wooden-block obstacles: loose free bodies of wood placed at run time.

The scene (``assets/scene.xml``) holds ``N_SLOTS`` free bodies ``obstacle_0..``, each with one box
geom in world geom group 1 (seen by the time-of-flight rays). A parked block hangs still below
the floor, far from everything: contype = conaffinity = 0 (no collision pair is ever formed with
it) and gravity compensation 1 (it does not fall). Placing a block, without rebuilding the
model, writes into the ``MjModel`` its geom's half-sizes and bounding volumes, its mass and
inertia from wood's density (:data:`WOOD_DENSITY`), the constants MuJoCo derives from them
(see :meth:`ObstaclePool._set`), the placed bitmasks (:data:`PLACED_CONTYPE`,
:data:`PLACED_CONAFFINITY`: it collides with the floor, the robot and the other blocks) and no
gravity compensation; and into the ``MjData`` its free joint's pose, resting on the floor
(centre at z = h / 2), with zero velocity. A kicked block slides, tips or turns over.

The pool keeps the pose each block was placed with (:attr:`ObstaclePool.placed_pos`,
:attr:`ObstaclePool.placed_quat`); :meth:`ObstaclePool.boxes` gives their current bounds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
from numba import njit

N_SLOTS = 4
"""Block slots in the scene: static scenes place up to 3 blocks, the sudden task adds up to 2.
Each parked free body still costs MuJoCo about 1.5 us a physics step (6 dofs), so no more."""
PARK_Z = -1.0
"""m, height of a parked block's centre (below the floor)."""
WOOD_DENSITY = 500.0
"""kg/m^3, the blocks' density (a softwood such as pine; SPEC §8: about 500)."""
PLACED_CONTYPE = 1
"""contype of a placed block: the floor's conaffinity 1 and the other blocks' take it."""
PLACED_CONAFFINITY = 1
"""conaffinity of a placed block: the floor's and the robot's contype 1 meet it."""
#: The paper's wooden blocks are 6, 7 and 8 cm high (§6.4).
PAPER_HEIGHTS = (0.06, 0.07, 0.08)


def box_mass_inertia(
    half_size: np.ndarray, density: float = WOOD_DENSITY
) -> tuple[float, np.ndarray]:
    """Mass and principal inertia of a solid box.

    Args:
        half_size: (3,) half extents (a, b, c), metres.
        density: kg/m^3.

    Returns:
        ``(mass, inertia)``: kg, and (3,) kg m^2 about the box's own axes:
        m = rho * 8abc, I_x = m (b^2 + c^2) / 3 (and cyclically; the usual m (B^2 + C^2) / 12
        with full extents B = 2b, C = 2c).
    """
    a, b, c = (float(v) for v in half_size)
    mass = density * 8.0 * a * b * c
    inertia = mass / 3.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])
    return mass, inertia


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
    """Places and parks the scene's loose wooden blocks.

    Args:
        model: the compiled scene; must contain free bodies ``obstacle_0 .. obstacle_{N-1}``.

    Attributes:
        blocks: the placed blocks as placed (slot order).
        placed_pos: (K, 3) each placed block's centre when it was placed, m (a view).
        placed_quat: (K, 4) its orientation then, (w, x, y, z) (a view).
        serial: (N_SLOTS,) int64, incremented each time a slot gets a block: a change tells a
            caller that tracks per-block state that the slot holds another block.
    """

    def __init__(self, model: mujoco.MjModel):
        self.bodies: list[int] = []
        self.geoms: list[int] = []
        qadr, dadr = [], []
        for i in range(N_SLOTS):
            try:
                body = model.body(f"obstacle_{i}").id
            except KeyError:
                break
            jnt = int(model.body_jntadr[body])
            if model.body_jntnum[body] != 1 or model.jnt_type[jnt] != mujoco.mjtJoint.mjJNT_FREE:
                raise ValueError(f"obstacle_{i} must be a free body (one freejoint)")
            self.bodies.append(body)
            qadr.append(int(model.jnt_qposadr[jnt]))
            dadr.append(int(model.jnt_dofadr[jnt]))
            self.geoms.append(int(np.flatnonzero(model.geom_bodyid == body)[0]))
        if not self.bodies:
            raise ValueError("the scene has no obstacle bodies (obstacle_0, ...)")
        self.body_ids = np.array(self.bodies, dtype=np.int64)
        # First body of the slots when they are consecutive bodies (read as a slice), else -1.
        run = bool((np.diff(self.body_ids) == 1).all())
        self._first_body = int(self.body_ids[0]) if run else -1
        self.geom_ids = np.array(self.geoms)
        self.qpos_adr = np.array(qadr, dtype=np.int64)
        self.dof_adr = np.array(dadr, dtype=np.int64)
        self._ngeom = int(model.ngeom)
        self._slot_of = np.full(self._ngeom, -1, dtype=np.int64)
        self._slot_of[self.geom_ids] = np.arange(len(self.geoms))
        self._robot_ref = None
        self._is_robot = np.zeros(self._ngeom, dtype=bool)
        n = len(self.bodies)
        self.half_sizes = np.zeros((n, 3))
        self._placed_pos = np.zeros((n, 3))
        self._placed_quat = np.zeros((n, 4))
        self.serial = np.zeros(n, dtype=np.int64)
        self.placements = 0
        """Blocks placed so far (the sum of ``serial``): unchanged means no slot changed."""
        self._data: mujoco.MjData | None = None
        self._json: list[dict] | None = None
        self.blocks: list[Block] = []

    @property
    def capacity(self) -> int:
        """Number of block slots in the scene."""
        return len(self.bodies)

    @property
    def placed_pos(self) -> np.ndarray:
        """(K, 3) centres of the placed blocks when placed, m."""
        return self._placed_pos[: len(self.blocks)]

    @property
    def placed_quat(self) -> np.ndarray:
        """(K, 4) orientations of the placed blocks when placed, (w, x, y, z)."""
        return self._placed_quat[: len(self.blocks)]

    def clear(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Park every block: below the floor, apart, collision-free, gravity-compensated."""
        self._data = data
        for slot in range(self.capacity):
            self._park(model, data, slot)
        self.blocks = []
        self._json = None

    def _park(self, model, data, slot: int) -> None:
        g, b, q, v = self.geoms[slot], self.bodies[slot], self.qpos_adr[slot], self.dof_adr[slot]
        # The body's masks (the OR of its geoms', read by the broad phase) with the geom's.
        model.geom_contype[g] = model.body_contype[b] = 0
        model.geom_conaffinity[g] = model.body_conaffinity[b] = 0
        # model.ngravcomp (read-only) keeps its compiled count; MuJoCo reads body_gravcomp.
        model.body_gravcomp[b] = 1.0
        data.qpos[q : q + 7] = (0.0, 3.0 * slot, PARK_Z, 1.0, 0.0, 0.0, 0.0)
        data.qvel[v : v + 6] = 0.0
        data.qacc_warmstart[v : v + 6] = 0.0

    def place(self, model: mujoco.MjModel, data: mujoco.MjData, blocks: list[Block]) -> None:
        """Park all blocks, then put ``blocks`` in place (in slot order)."""
        if len(blocks) > self.capacity:
            raise ValueError(f"at most {self.capacity} blocks fit the scene, got {len(blocks)}")
        self.clear(model, data)
        for slot, block in enumerate(blocks):
            self._set(model, data, slot, block)
        self.blocks = list(blocks)
        self._json = None
        mujoco.mj_kinematics(model, data)

    def add(self, model: mujoco.MjModel, data: mujoco.MjData, block: Block) -> None:
        """Put one more block in the next free slot (a sudden obstacle)."""
        slot = len(self.blocks)
        if slot >= self.capacity:
            raise ValueError(f"all {self.capacity} obstacle slots are in use")
        self._data = data
        self._set(model, data, slot, block)
        self.blocks.append(block)
        self._json = None
        mujoco.mj_kinematics(model, data)

    def _set(self, model, data, slot: int, block: Block) -> None:
        """Size, mass, bitmasks and pose of one block; and what MuJoCo derives from its mass.

        ``mj_setConst`` would recompute those derived constants too, but it runs the whole model
        at ``qpos0`` in the ``MjData`` it is given and also rewrites ``stat`` (its centre,
        extent, mean inertia: the solver's scale and the free camera), which would make the
        robot's physics depend on the blocks' sizes. For a free body whose inertial frame is
        its body frame (the scene's ``<inertial>``), they are, as ``mj_setConst`` computes them:
        ``body_subtreemass`` (the body's own mass; the world's, every body's), ``dof_M0``
        (diagonal of the mass matrix at ``qpos0``: m, m, m, I_x, I_y, I_z), ``body_invweight0``
        (1/m and the mean of 1/I) and ``dof_invweight0`` (the same per dof), which scale the
        contacts' constraint regularisation. The tests compare them with ``mj_setConst``.
        """
        g, b, q, v = self.geoms[slot], self.bodies[slot], self.qpos_adr[slot], self.dof_adr[slot]
        half = block.half_size
        mass, inertia = box_mass_inertia(half)
        model.geom_size[g] = half
        model.geom_rbound[g] = float(np.linalg.norm(half))
        model.geom_aabb[g] = (0.0, 0.0, 0.0, *half)
        model.body_mass[b] = mass
        model.body_inertia[b] = inertia
        model.body_subtreemass[b] = mass
        model.body_subtreemass[0] = float(model.body_mass.sum())
        arm = model.dof_armature[v : v + 6]
        model.dof_M0[v : v + 6] = np.concatenate([np.full(3, mass), inertia]) + arm
        inv_rot = float(np.mean(1.0 / inertia))
        model.body_invweight0[b] = (1.0 / mass, inv_rot)
        model.dof_invweight0[v : v + 6] = (*(3 * [1.0 / mass]), *(3 * [inv_rot]))
        model.geom_contype[g] = model.body_contype[b] = PLACED_CONTYPE
        model.geom_conaffinity[g] = model.body_conaffinity[b] = PLACED_CONAFFINITY
        model.body_gravcomp[b] = 0.0
        quat = (np.cos(block.yaw / 2), 0.0, 0.0, np.sin(block.yaw / 2))
        # Resting on the floor exactly (centre at h / 2): the contacts start at zero depth, so
        # the block settles by the contact's equilibrium depth (about a millimetre) and no more.
        data.qpos[q : q + 3] = block.center
        data.qpos[q + 3 : q + 7] = quat
        data.qvel[v : v + 6] = 0.0
        data.qacc_warmstart[v : v + 6] = 0.0
        self.half_sizes[slot] = half
        self._placed_pos[slot] = block.center
        self._placed_quat[slot] = quat
        self.serial[slot] += 1
        self.placements += 1

    def poses(self, data: mujoco.MjData | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Current poses of the placed blocks.

        Args:
            data: the simulation state; None for the one the pool last placed into.

        Returns:
            ``(pos, quat)``: (K, 3) centres, m, and (K, 4) orientations (w, x, y, z), copies.
        """
        d = self._data if data is None else data
        ids = self.body_ids[: len(self.blocks)]
        if d is None or not len(ids):
            return np.zeros((0, 3)), np.zeros((0, 4))
        return d.xpos[ids], d.xquat[ids]

    def blocks_json(self, data: mujoco.MjData | None = None) -> list[dict]:
        """The placed blocks as JSON-ready dicts, fresh copies (for trial logs and ``info``).

        Each holds the block as placed (``x``, ``y``, ``length``, ``width``, ``height`` in m,
        ``yaw`` in rad) and where it is now: ``pos`` (3 floats, m) and ``quat`` (w, x, y, z).
        """
        if self._json is None:
            self._json = [b.to_json() for b in self.blocks]
        k, b0 = len(self.blocks), self._first_body
        state = self._data if data is None else data
        if b0 >= 0 and state is not None:
            pos, quat = state.xpos[b0 : b0 + k], state.xquat[b0 : b0 + k]  # views: no copies
        else:
            pos, quat = self.poses(data)
        # Rounded to 6 digits (1 um), None when not finite (a faulted simulation).
        fin = math.isfinite
        return [
            {
                **d,
                "pos": [round(x, 6) if fin(x) else None for x in p],
                "quat": [round(x, 6) if fin(x) else None for x in q],
            }
            for d, p, q in zip(self._json, pos.tolist(), quat.tolist(), strict=True)
        ]

    def boxes(self, data: mujoco.MjData | None = None) -> np.ndarray:
        """(K, 2, 3) current axis-aligned min/max bounds of the placed blocks, metres (new).

        From each block's current pose (a kicked block moves): centre -/+ |R| half-sizes.
        ``data``: None for the state the pool last placed into.
        """
        d = self._data if data is None else data
        k = len(self.blocks)
        if d is None or not k:
            return np.zeros((0, 2, 3))
        ids = self.body_ids[:k]
        rot = np.abs(d.xmat[ids].reshape(k, 3, 3))
        ext = np.einsum("kij,kj->ki", rot, self.half_sizes[:k])
        c = d.xpos[ids]
        return np.stack([c - ext, c + ext], axis=1)

    @property
    def slot_of(self) -> np.ndarray:
        """(ngeom,) int64 block slot of each geom of the model, -1 for the rest (read-only)."""
        return self._slot_of

    def robot_mask(self, robot_geoms: np.ndarray) -> np.ndarray:
        """(ngeom,) bool, whether each geom is one of ``robot_geoms`` (cached per array)."""
        if self._robot_ref is not robot_geoms:
            # Lookup table by geom id, rebuilt only when another array of robot geoms comes.
            self._is_robot = np.zeros(self._ngeom, dtype=bool)
            self._is_robot[np.asarray(robot_geoms)] = True
            self._robot_ref = robot_geoms
        return self._is_robot

    def touching(self, data: mujoco.MjData, robot_geoms: np.ndarray) -> np.ndarray:
        """(K,) bool: which placed blocks are in contact with a robot geom now."""
        hit = np.zeros(len(self.blocks), dtype=bool)
        self._touching(data, robot_geoms, hit)
        return hit

    def _touching(self, data: mujoco.MjData, robot_geoms: np.ndarray, hit: np.ndarray) -> bool:
        n = data.ncon
        if n == 0 or not self.blocks:
            return False
        is_robot = self.robot_mask(robot_geoms)
        # (n, 2) geom ids of each contact
        return _touching_kernel(data.contact.geom[:n], self._slot_of, is_robot, len(hit), hit)


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
