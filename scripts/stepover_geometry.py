"""Can a two-segment leg step cleanly over a block? A planar study (docs/stepover_geometry.md).

The reason body v2's knees fold behind the feet (``neurocog_gym/robot/variants.py``). A front
leg of two 0.20 m segments (thigh capsule radius 1.8 cm, shank 1.2 cm, foot ball 1.8 cm; body
v1's figures) lifts off with its foot ``--foot0`` ahead of its hip (behind it when negative) and
a block ``gap`` ahead of the sole. The hip moves on at ``--speed`` while the foot follows a
box-shaped path: straight up for the first 30 % of the swing to ``apex`` above the block's top,
forwards over it for 40 %, straight down for the last 30 % to land ``land`` beyond the far face;
then the foot stands while the hip walks on until the foot is as far behind the hip as it was
at lift-off. At every instant the knee follows from the foot by inverse kinematics (the knee
ahead of or behind the hip-foot line). Clearance: the least distance between the leg's capsules
and the block's side profile over swing and stance (negative: they meet; a pose out of reach
counts as failed). For each knee direction, hip height and block (gap 2/4/6 cm, length 5/8/12 cm,
height 6/8 cm: the sudden scenario's ranges) the best of the paths (apex 1/2/4 cm,
landing 1-15 cm past, swing 0.2/0.3/0.4 s) is kept, and a case counts as clean
with at least 5 mm of clearance.

It is planar and kinematic: no dynamics, no torso pitch, the leg in its sagittal plane, the block's
width ignored. It says where a clean step-over is geometrically possible, not that a controller
achieves it (``scripts/stepover_probe.py`` tries that in the simulator).

    python scripts/stepover_geometry.py [--out docs/stepover_geometry.md]
"""

from __future__ import annotations

import argparse
import itertools
import platform
import sys
from dataclasses import dataclass, fields

import numpy as np

L, R_THIGH, R_SHANK, R_FOOT = 0.20, 0.018, 0.012, 0.018


@dataclass(frozen=True)
class Args:
    """Command-line arguments."""

    speed: float = 0.43
    """Forward speed of the hip, m/s (body v1's trot)."""
    foot0: float = -0.02
    """Foot position relative to the hip at lift-off, m (+ ahead)."""
    out: str = ""
    """Markdown file to write the table to ('' = print only)."""


def knee_point(dx: float, dz: float, behind: bool) -> np.ndarray | None:
    """Knee relative to the hip for a foot at (dx, dz) from it; None when out of reach."""
    d = float(np.hypot(dx, dz))
    if d > 2 * L - 1e-4:
        return None
    towards_foot = np.arctan2(dx, -dz)  # angle of the hip-foot line from straight down, + ahead
    half = np.arccos(d / (2 * L))
    thigh = towards_foot - half if behind else towards_foot + half
    return np.array([L * np.sin(thigh), -L * np.cos(thigh)])


def _segment_to_block(p, q, x0, x1, top, n=25) -> float:
    """Least distance from segment p-q to the block [x0, x1] x [0, top] (-1 when inside)."""
    pts = p[None] + np.linspace(0.0, 1.0, n)[:, None] * (q - p)[None]
    cx, cz = np.clip(pts[:, 0], x0, x1), np.clip(pts[:, 1], 0.0, top)
    d = np.hypot(pts[:, 0] - cx, pts[:, 1] - cz)
    d[(pts[:, 0] > x0) & (pts[:, 0] < x1) & (pts[:, 1] < top)] = -1.0
    return float(d.min())


def _pose_clearance(hip, foot, behind, near, far, top) -> float:
    k = knee_point(foot[0] - hip[0], foot[1] - hip[1], behind)
    if k is None:
        return -1.0
    knee = hip + k
    return min(
        _segment_to_block(hip, knee, near, far, top) - R_THIGH,
        _segment_to_block(knee, foot, near, far, top) - R_SHANK,
        _segment_to_block(foot, foot, near, far, top) - R_FOOT,
    )


def clearance(behind, hip_h, gap, length, top, apex, land, swing, a: Args) -> float:
    """Least clearance of one step-over (module docstring)."""
    x0 = a.foot0
    near = x0 + R_FOOT + gap
    far = near + length
    x_land = far + R_FOOT + land
    z_apex = top + R_FOOT + apex
    worst = np.inf
    for s in np.linspace(0.0, 1.0, 41):
        if s < 0.3:
            foot = (x0, R_FOOT + (z_apex - R_FOOT) * s / 0.3)
        elif s < 0.7:
            foot = (x0 + (x_land - x0) * (s - 0.3) / 0.4, z_apex)
        else:
            foot = (x_land, z_apex - (z_apex - R_FOOT) * (s - 0.7) / 0.3)
        hip = np.array([a.speed * swing * s, hip_h])
        worst = min(worst, _pose_clearance(hip, np.array(foot), behind, near, far, top))
    for xh in np.linspace(a.speed * swing, x_land - a.foot0, 30):
        foot = np.array([x_land, R_FOOT])
        worst = min(worst, _pose_clearance(np.array([xh, hip_h]), foot, behind, near, far, top))
    return float(worst)


def study(a: Args) -> list[dict]:
    """One row per knee direction and hip height: clean cases and the worst block."""
    blocks = list(itertools.product((0.02, 0.04, 0.06), (0.05, 0.08, 0.12), (0.06, 0.08)))
    paths = list(itertools.product((0.01, 0.02, 0.04), (0.01, 0.03, 0.06, 0.10, 0.15),
                                   (0.2, 0.3, 0.4)))  # fmt: skip
    rows = []
    for behind, hip_h in itertools.product((False, True), (0.28, 0.30, 0.32, 0.34)):
        best = []
        for gap, length, top in blocks:
            c = max(clearance(behind, hip_h, gap, length, top, *p, a) for p in paths)
            best.append((c, gap, length, top))
        worst = min(best)
        rows.append({
            "knee": "behind the foot" if behind else "ahead of the foot", "hip_h": hip_h,
            "clean": sum(c >= 0.005 for c, *_ in best), "n": len(best),
            "median": float(np.median([max(c, 0.0) for c, *_ in best])), "worst": worst,
        })  # fmt: skip
    return rows


def table(rows: list[dict]) -> str:
    lines = [
        "| knee | hip height, m | clean step-overs (>= 5 mm) | "
        "median best clearance, cm (0: meets) | "
        "worst block (gap, length, height, cm): clearance, cm |",
        "|---|---:|---:|---:|---|",
    ]
    for r in rows:
        c, g, ln, t = r["worst"]
        lines.append(
            f"| {r['knee']} | {r['hip_h']:.2f} | {r['clean']} / {r['n']} | "
            f"{r['median'] * 100:.1f} | {g * 100:.0f}, {ln * 100:.0f}, {t * 100:.0f}: "
            + (f"{c * 100:.1f} |" if c >= 0 else "meets it |")
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for f in fields(Args):
        parser.add_argument(f"--{f.name}", type=type(f.default), default=f.default)
    a = Args(**vars(parser.parse_args(argv)))
    if not a.speed >= 0:
        parser.error("--speed must be >= 0")
    text = table(study(a))
    print(text)
    if a.out:
        from neurocog_gym import io as nio

        cmd = "python scripts/stepover_geometry.py " + " ".join(
            sys.argv[1:] if argv is None else argv
        )
        doc = (
            "# Stepping over a block: where the two-segment leg can do it cleanly\n\n"
            f"Command: `{cmd.strip()}`  \nMachine: {platform.processor() or platform.machine()}, "
            f"Python {platform.python_version()} (a kinematic study: the numbers do not depend on "
            "the machine).\n\nThe model and its limits are in the script's docstring. Blocks: "
            "gap 2/4/6 cm, length 5/8/12 cm, height 6/8 cm (18 cases); best of 45 foot paths each."
            "\n\n" + text + "\n"
        )
        nio.atomic_write_text(a.out, doc)
        print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
