"""Figure: affordance facets coloured by kind over the GNG-like graph of a floor + block + wall.

One 3-D panel per lattice spacing: terrain green, wall blue-grey, confirmed object orange,
suspected object red with its padded attention box (dashed) — at a coarse spacing the block is
suspected (density below v), at a fine one confirmed.

    .venv/bin/python scripts/plot_facets.py [--spacing 0.1 0.04] [--out PATH.png]
"""

from __future__ import annotations

import argparse
import itertools
from dataclasses import dataclass, field
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection  # noqa: E402

from neurocog_gym.perception.affordance import (  # noqa: E402
    detect_affordances,
    synthetic_scene_graph,
)

COLOURS = {"terrain": "#4caf50", "wall": "#8fa3b8", "object": "#ff9800", "suspected": "#e53935"}


@dataclass
class Args:
    spacing: list[float] = field(default_factory=lambda: [0.1, 0.04])
    seed: int = 0
    out: Path = Path("docs/img/affordance_facets.png")


def parse(argv: list[str] | None = None) -> Args:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--spacing", type=float, nargs="+", default=[0.1, 0.04], help="metres")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", type=Path, default=Path("docs/img/affordance_facets.png"))
    a = p.parse_args(argv)
    if min(a.spacing) <= 0.005:
        p.error("--spacing must be above 5 mm")
    return Args(spacing=a.spacing, seed=a.seed, out=a.out)


def box_edges(box: np.ndarray) -> list[np.ndarray]:
    """The 12 edges of an axis-aligned box given as (2, 3) min/max corners."""
    corners = np.array(list(itertools.product(*box.T)))
    return [
        corners[[i, j]]
        for i, j in itertools.combinations(range(8), 2)
        if np.count_nonzero(corners[i] != corners[j]) == 1
    ]


def panel(ax, spacing: float, seed: int) -> None:
    scene = synthetic_scene_graph(spacing, seed=seed)
    res = detect_affordances(scene.nodes, scene.edges, scene.sensor_origin)
    colours = []
    for k in res.facet_labels:
        obj = res.objects[k]
        colours.append(COLOURS["suspected" if obj.suspected else obj.kind])
    # Draw order fixed (facets, graph, attention boxes) rather than mplot3d's depth sort, which
    # hides the attention box inside the block.
    ax.computed_zorder = False
    polys = Poly3DCollection(
        scene.nodes[res.facets], facecolors=colours, edgecolors="none", alpha=0.85, zorder=1
    )
    ax.add_collection3d(polys)
    ax.add_collection3d(
        Line3DCollection(scene.nodes[scene.edges], colors="k", linewidths=0.3, alpha=0.6, zorder=2)
    )
    ax.scatter(*scene.nodes.T, s=1.5, c="k", depthshade=False, zorder=2)
    for box in res.suspected_boxes:
        ax.add_collection3d(
            Line3DCollection(
                box_edges(box), colors="#b71c1c", linestyles="--", linewidths=1.4, zorder=3
            )
        )
    lo, hi = scene.nodes.min(0), scene.nodes.max(0)
    ax.set(xlim=(lo[0], hi[0]), ylim=(lo[1], hi[1]), zlim=(lo[2], hi[2]))
    ax.set_box_aspect(hi - lo)
    ax.view_init(elev=28, azim=-150)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    lines = [f"spacing {spacing * 100:.0f} cm: {len(scene.nodes)} nodes, {len(res.facets)} facets"]
    for o in res.obstacles:
        state = "suspected" if o.suspected else "confirmed"
        lines.append(
            f"object ({state}): h {o.height * 100:.1f} w {o.width * 100:.1f} "
            f"l {o.length * 100:.1f} cm, d {o.density:.0f} /m²"
        )
    ax.set_title("\n".join(lines), fontsize=8)


def main(argv: list[str] | None = None) -> None:
    args = parse(argv)
    fig = plt.figure(figsize=(6 * len(args.spacing), 5.5))
    for i, spacing in enumerate(args.spacing):
        panel(fig.add_subplot(1, len(args.spacing), i + 1, projection="3d"), spacing, args.seed)
    handles = [plt.Rectangle((0, 0), 1, 1, color=c) for c in COLOURS.values()]
    fig.legend(handles, list(COLOURS), loc="lower center", ncol=4, frameon=False)
    fig.suptitle("Affordance facets on a GNG-like graph (floor, 7 cm block, wall)")
    fig.tight_layout(rect=(0, 0.05, 1, 0.97))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    from neurocog_gym.io import atomic_savefig

    atomic_savefig(fig, args.out, dpi=130)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
