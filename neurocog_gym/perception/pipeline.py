"""The attention loop as one object (§4, Fig. 1, Algorithm 1):

    point cloud -> DD-GNG -> affordance detection -> suspected boxes -> DD-GNG (next cycle)

One :meth:`AttentionPipeline.step` is one control cycle: one DD-GNG learning cycle on the latest
frame (λ samples), then affordance detection on the graph. Per-stage wall times of the last step
are in :attr:`AttentionPipeline.timings`.

Attention memory (our choice, the paper leaves it open): an object box found by the affordance
detector keeps attracting attention for ``hold`` seconds after it was last reported, suspected
(density below v) or confirmed. Without the memory a confirmed object would drop out of the
attention as soon as its density crossed v, its nodes would lose their strength, the density
would fall below v again, and the attention would flicker. Boxes that overlap are merged into
the newest one. The same memory is the robot's short-term knowledge of obstacles it can no
longer see (under its body), which the effectivity uses for the hind legs.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from neurocog_gym.perception.affordance import AffordanceParams, Affordances, detect_affordances
from neurocog_gym.perception.gng import DDGNG, GNG, MLGNG, DDGNGParams

GNG_KINDS = {"ddgng": DDGNG, "gng": GNG, "mlgng": MLGNG}


@dataclass(frozen=True)
class PipelineParams:
    """Attention-loop settings."""

    gng: str = "ddgng"
    """Topological map: "ddgng" (attention on), "gng" (attention off), "mlgng" (baseline)."""
    hold: float = 1.5
    """s: how long an object box stays in the attention memory after it was last detected."""
    max_boxes: int = 8
    """Most boxes kept in memory (oldest dropped first)."""
    min_height: float = 0.025
    """m: objects lower than this are ignored (GNG ripples on a flat floor)."""

    def __post_init__(self):
        if self.gng not in GNG_KINDS:
            raise ValueError(
                f"PipelineParams.gng must be one of {sorted(GNG_KINDS)}, got {self.gng!r}"
            )
        if not self.hold >= 0:
            raise ValueError(f"PipelineParams.hold must be >= 0, got {self.hold}")


def _overlap(a: np.ndarray, b: np.ndarray) -> bool:
    return bool(np.all(a[0] <= b[1]) and np.all(b[0] <= a[1]))


class AttentionPipeline:
    """DD-GNG + affordance detection with the attention loop closed.

    Args:
        seed: seed of the topological map's random stream.
        params: loop settings.
        gng_params: DD-GNG parameters (Table 2 defaults).
        affordance_params: affordance-detection parameters.
    """

    def __init__(
        self,
        seed: int = 0,
        params: PipelineParams | None = None,
        gng_params: DDGNGParams | None = None,
        affordance_params: AffordanceParams | None = None,
    ):
        self.params = params or PipelineParams()
        self.affordance_params = affordance_params or AffordanceParams()
        self.net = GNG_KINDS[self.params.gng](seed=seed, params=gng_params)
        self.memory_boxes = np.zeros((0, 2, 3))
        self.memory_time = np.zeros(0)
        self.last: Affordances | None = None
        self.timings = {"gng": 0.0, "affordance": 0.0, "total": 0.0}
        self.n_steps = 0

    def reset(self, seed: int | None = None) -> None:
        """Forget the graph and the attention memory."""
        self.net.reset(seed)
        self.memory_boxes = np.zeros((0, 2, 3))
        self.memory_time = np.zeros(0)
        self.last = None
        self.n_steps = 0

    @property
    def attention_boxes(self) -> np.ndarray:
        """(K, 2, 3) boxes the DD-GNG attends to in the next cycle, metres."""
        return self.memory_boxes

    def step(
        self,
        points: np.ndarray,
        sensor_origin: np.ndarray,
        t: float,
        forward=(1.0, 0.0, 0.0),
        ground_z: float | None = None,
    ) -> Affordances:
        """One control cycle of the attention loop.

        Args:
            points: (N, 3) float, metres, world frame: the latest point-cloud frame.
            sensor_origin: (3,) metres, where the sensors are (facet normals face it).
            t: simulated time, s (ages the attention memory).
            forward: (3,) walking direction (width is across it, length along it).
            ground_z: metres, known ground level, or None to estimate it from the graph.

        Returns:
            The affordances detected on this cycle's graph.
        """
        t0 = time.perf_counter()
        boxes = self.memory_boxes if len(self.memory_boxes) else None
        self.net.update(points, boxes)
        t1 = time.perf_counter()
        aff = detect_affordances(
            self.net.nodes, self.net.edges, sensor_origin, self.affordance_params,
            forward=forward, ground_z=ground_z,
        )  # fmt: skip
        t2 = time.perf_counter()
        self._remember(aff, t)
        self.last = aff
        self.n_steps += 1
        self.timings = {"gng": t1 - t0, "affordance": t2 - t1, "total": time.perf_counter() - t0}
        return aff

    def _remember(self, aff: Affordances, t: float) -> None:
        pad = self.affordance_params.suspect_padding
        found = [
            o.box + np.array([[-pad, -pad, -pad], [pad, pad, pad]])
            for o in aff.obstacles
            if o.height >= self.params.min_height
        ]
        boxes = list(self.memory_boxes)
        times = list(self.memory_time)
        for box in found:
            keep = [i for i, b in enumerate(boxes) if not _overlap(b, box)]
            boxes = [boxes[i] for i in keep] + [box]
            times = [times[i] for i in keep] + [t]
        alive = [i for i, tm in enumerate(times) if t - tm <= self.params.hold]
        alive = alive[-self.params.max_boxes :]
        self.memory_boxes = np.array([boxes[i] for i in alive]).reshape(-1, 2, 3)
        self.memory_time = np.array([times[i] for i in alive], dtype=np.float64)
