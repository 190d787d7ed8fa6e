"""Picture: the DD-GNG and GNG graphs over the ToF point cloud, after an obstacle appeared.

The walking trial of ``fig9_density.py`` (one seed): the robot trots, a block appears ahead,
and ``--at`` s later the frame and both graphs are drawn: top views of the point cloud (grey)
with each net's edges and nodes (DD-GNG nodes with strength δ > 1, i.e. inside an attention
box, in red), the true block outline (black) and the attention boxes (dashed), and a 3-D view
of the DD-GNG graph round the block.

    MUJOCO_GL=egl .venv/bin/python scripts/plot_graph_cloud.py [--seed 3] [--at 0.5]

Writes ``docs/img/graph_over_cloud.png``.
"""

from __future__ import annotations

import argparse
import io
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import LineCollection
from mpl_toolkits.mplot3d.art3d import Line3DCollection

from neurocog_gym.bench.perception_scenes import Variant, walking_trial
from neurocog_gym.io import atomic_write_bytes

VARIANTS = {"DD-GNG": Variant("ddgng"), "GNG": Variant("gng")}


def outline(ax, block, **kw) -> None:
    xy = block.corners_xy()
    ax.plot(*np.vstack([xy, xy[:1]]).T, **kw)


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seed", type=int, default=3)
    p.add_argument("--at", type=float, default=0.5, help="s after the block appeared")
    p.add_argument("--out", type=Path, default=Path("docs/img/graph_over_cloud.png"))
    a = p.parse_args(argv)
    if not a.at > 0:
        p.error("--at must be > 0")
    r = walking_trial(a.seed, VARIANTS, after=a.at + 0.02, snapshot_at=(a.at,))
    snap = r.snapshots[f"{a.at:g}"]
    pts = snap["points"]
    rng = np.random.default_rng(a.seed)
    sub = pts[rng.choice(len(pts), size=min(len(pts), 4000), replace=False)]
    b = r.block

    fig = plt.figure(figsize=(16, 5.6))
    for col, name in enumerate(VARIANTS):
        nodes, edges, strength, aff, boxes = snap["graphs"][name]
        ax = fig.add_subplot(1, 3, col + 1)
        ax.scatter(sub[:, 0], sub[:, 1], s=0.3, c="0.75", label="ToF points (4000 of the frame)")
        ax.add_collection(LineCollection(nodes[edges][:, :, :2], colors="#1f77b4", linewidths=0.7))
        strong = strength > 1
        ax.scatter(*nodes[~strong, :2].T, s=8, c="#1f77b4", zorder=3, label="nodes")
        if strong.any():
            ax.scatter(*nodes[strong, :2].T, s=10, c="#d62728", zorder=4, label="nodes with δ > 1")
        outline(ax, b, color="k", lw=1.4, label="true block")
        if name == "DD-GNG":
            for j, box in enumerate(boxes):
                (x0, y0), (x1, y1) = box[0, :2], box[1, :2]
                ax.plot([x0, x1, x1, x0, x0], [y0, y0, y1, y1, y0], "--", color="#d62728", lw=1,
                        label="attention box" if j == 0 else None)  # fmt: skip
        n_on = int(
            (
                (np.abs(nodes[:, 0] - b.x) < 0.25)
                & (np.abs(nodes[:, 1] - b.y) < 0.25)
                & (nodes[:, 2] > 0.02)
            ).sum()
        )
        ax.set_title(f"{name}, {a.at:g} s after the block appeared\n"
                     f"{len(nodes)} nodes, {len(edges)} edges, "
                     f"{n_on} higher than 2 cm near the block", fontsize=9)  # fmt: skip
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        ax.legend(fontsize=7, loc="lower left", markerscale=2)
    nodes, edges, strength, aff, boxes = snap["graphs"]["DD-GNG"]
    ax = fig.add_subplot(1, 3, 3, projection="3d")
    near = (np.abs(pts[:, 0] - b.x) < 0.3) & (np.abs(pts[:, 1] - b.y) < 0.3)
    ax.scatter(*pts[near].T, s=0.5, c="0.7", depthshade=False)
    keep = (np.abs(nodes[:, 0] - b.x) < 0.3) & (np.abs(nodes[:, 1] - b.y) < 0.3)
    e = edges[keep[edges[:, 0]] & keep[edges[:, 1]]]
    ax.add_collection3d(Line3DCollection(nodes[e], colors="#1f77b4", linewidths=0.8))
    c = np.where(strength[keep] > 1, "#d62728", "#1f77b4")
    ax.scatter(*nodes[keep].T, s=12, c=c, depthshade=False)
    xy = b.corners_xy()
    for z in (0.0, b.height):
        ax.plot(*np.vstack([xy, xy[:1]]).T, zs=z, color="k", lw=1)
    for x, y in xy:
        ax.plot([x, x], [y, y], [0, b.height], color="k", lw=1)
    ax.set(xlim=(b.x - 0.3, b.x + 0.3), ylim=(b.y - 0.3, b.y + 0.3), zlim=(0, 0.2))
    ax.set_box_aspect((0.6, 0.6, 0.2))
    ax.view_init(elev=30, azim=-150)
    size = f"h {b.height * 100:.1f} cm, {b.length * 100:.0f} × {b.width * 100:.0f} cm"
    ax.set_title(f"DD-GNG round the block ({size})",
                 fontsize=9)  # fmt: skip
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    atomic_write_bytes(a.out, buf.getvalue())
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
