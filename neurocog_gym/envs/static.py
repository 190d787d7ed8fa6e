"""NeuroCog/StaticObstacle-v3: wooden blocks lie across the robot's path (§6.5.2)."""

from __future__ import annotations

from neurocog_gym.envs.sudden import SuddenObstacleEnv
from neurocog_gym.robot.obstacles import N_SLOTS, Block, random_block


class StaticObstacleEnv(SuddenObstacleEnv):
    """The robot walks; one to three blocks lie across its path from the start (§6.5.2).

    The first block's near face is ``first_distance`` (uniform) ahead of the front feet, centred
    within ±``lateral`` of the path; each further block follows 0.5-0.9 m after the previous one,
    with the same lateral spread. Heights are the paper's 6, 7, 8 cm (±5 mm), lengths 5-12 cm,
    widths 10-30 cm, yaw within ±0.3 rad. Spaces, rewards and outcome as
    ``NeuroCog/SuddenObstacle-v3``; truncated at 1000 steps (10 s) by the registration.

    Arguments: as ``SuddenObstacleEnv`` (its sudden-obstacle arguments are unused) plus
    ``n_blocks`` ((1, 3), inclusive range), ``first_distance`` ((0.7, 1.2) m) and
    ``lateral`` (0.1 m).
    """

    def __init__(
        self,
        n_blocks: tuple[int, int] = (1, 3),
        first_distance: tuple[float, float] = (0.7, 1.2),
        lateral: float = 0.1,
        **kwargs,
    ):
        if not (1 <= n_blocks[0] <= n_blocks[1] <= N_SLOTS):
            raise ValueError(
                f"n_blocks must be (lo, hi) with 1 <= lo <= hi <= {N_SLOTS} (the scene's block "
                f"slots), got {n_blocks}"
            )
        self.n_blocks = (int(n_blocks[0]), int(n_blocks[1]))
        self.first_distance = (float(first_distance[0]), float(first_distance[1]))
        self.lateral = float(lateral)
        super().__init__(**kwargs)
        from gymnasium.utils import EzPickle

        EzPickle.__init__(
            self, n_blocks=n_blocks, first_distance=first_distance, lateral=lateral,
            **self._ezpickle_kwargs,
        )  # fmt: skip

    def _place_initial_obstacles(self) -> None:
        super()._place_initial_obstacles()
        self.appeared_at = 0.0  # nothing appears later
        rng = self.np_random
        n = int(rng.integers(self.n_blocks[0], self.n_blocks[1] + 1))
        front = float(self.robot.home_qpos[0]) + 0.25
        x = front + float(rng.uniform(*self.first_distance))
        blocks = []
        for _ in range(n):
            b = random_block(rng, 0.0, 0.0)
            y = float(rng.uniform(-self.lateral, self.lateral))
            blocks.append(Block(x + b.length / 2, y, b.length, b.width, b.height, b.yaw))
            x += b.length + float(rng.uniform(0.5, 0.9))
        self.pool.place(self.model, self.data, blocks)

    def _task_event(self) -> None:
        return None


__all__ = ["StaticObstacleEnv"]
