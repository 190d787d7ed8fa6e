"""Body v1's figures and the interrupt-lift sweep (issue 21), written to ``docs/body.md``.

Prints and writes: segment lengths, masses, hip height, servo model (from the compiled model),
and the sweep of ``neurocog_gym.bench.body.interrupt_lift_sweep``: the lift interrupt (knee +1,
hip +0.3) applied at phases 0 .. 0.5 of front swings on ``NeuroCog/Walk-v3``; per phase the
lowest peak sole height within 0.15 s and the slowest time to 11 cm, over every swing tested.

    python scripts/body_figures.py [--seeds 3] [--swings 2] [--out docs/body.md]
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np

from neurocog_gym.bench.body import (
    LIFT_HIP,
    LIFT_KNEE,
    body_figures,
    interrupt_lift_sweep,
)
from neurocog_gym.bench.machine import machine
from neurocog_gym.locomotion.motor import MotorParams


@dataclasses.dataclass(frozen=True)
class Args:
    """Command-line arguments."""

    seeds: int = 3
    """Env seeds (0 .. seeds-1)."""
    swings: int = 2
    """Swings per seed and front leg."""
    phases: int = 6
    """Onsets from 0 to 0.5 of the swing, evenly spaced."""
    out: str = "docs/body.md"
    """Markdown report ('' to skip)."""


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for f in dataclasses.fields(Args):
        parser.add_argument(f"--{f.name}", type=type(f.default), default=f.default)
    args = Args(**vars(parser.parse_args(argv)))
    if args.seeds < 1 or args.swings < 1 or args.phases < 2:
        parser.error("--seeds and --swings must be >= 1, --phases >= 2")
    fig = body_figures()
    mp = MotorParams()
    lines = [
        "# Body v1: figures and the authority of a swing interrupt",
        "",
        f"`python scripts/body_figures.py --seeds {args.seeds} --swings {args.swings}` on "
        f"{machine('mujoco')}.",
        "",
        "## The body (assets/quadruped.xml)",
        "",
        "| figure | value |",
        "|---|---|",
        f"| thigh, shank | {fig['thigh_m']:.3f} m, {fig['shank_m']:.3f} m (foot sphere radius "
        f"{fig['foot_radius_m'] * 100:.1f} cm) |",
        f"| mass | {fig['mass_kg']:.2f} kg (torso {fig['torso_mass_kg']:.2f} kg, one leg "
        f"{fig['leg_mass_kg']:.2f} kg) |",
        f"| hip height, home pose after 1 s standing | {fig['hip_height_m']:.3f} m |",
        f"| stance width, hip spacing | {fig['stance_width_m']:.3f} m, "
        f"{fig['hip_spacing_m']:.3f} m |",
        f"| servo (Dynamixel MX-64, 12 V) | stall {fig['servo']['stall_torque_nm']:.1f} N m, "
        f"kp {fig['servo']['kp_nm_per_rad']:.0f} N m/rad, kv "
        f"{fig['servo']['kv_nms_per_rad']:.2f} N m s/rad (= stall / no-load speed), armature "
        f"{fig['servo']['armature_kgm2']:.3f} kg m^2 |",
        f"| no-load speed (pool target-rate cap) | {mp.vel_max[0]:.1f} rad/s |",
        f"| joint ranges | abduct {fig['joint_range']['abduct']}, hip "
        f"{fig['joint_range']['hip']}, knee {fig['joint_range']['knee']} rad |",
        f"| motor-neuron pools | mu2 {mp.mu2:g}, F_l width {mp.fl_width[0]:g} rad |",
        "",
        f"## Lift interrupt (knee {LIFT_KNEE:+g}, hip {LIFT_HIP:+g}) at phases of front swings",
        "",
        "Onset = lift-off + phase x that swing's duration; sole = the foot sphere's lowest point "
        "above the floor; window 0.15 s.",
        "",
        "| phase | swings | sole at onset (median) | lowest peak | median peak | slowest time "
        "to 11 cm | reached 11 cm |",
        "|---|---|---|---|---|---|---|",
    ]
    phases = np.linspace(0.0, 0.5, args.phases)
    rows = interrupt_lift_sweep(phases, seeds=tuple(range(args.seeds)), swings=args.swings)
    worst_peak, worst_time, all_reached = np.inf, 0.0, True
    for ph in phases:
        sel = [r for r in rows if abs(r.phase - ph) < 1e-9]
        peaks = np.array([r.peak for r in sel])
        times = [r.time_to_lift for r in sel]
        reached = [t for t in times if t is not None]
        slow = f"{max(reached):.2f} s" if reached else "-"
        lines.append(
            f"| {ph:.1f} | {len(sel)} | {np.median([r.start_height for r in sel]) * 100:.1f} cm "
            f"| {peaks.min() * 100:.1f} cm | {np.median(peaks) * 100:.1f} cm | {slow} "
            f"| {len(reached)} / {len(sel)} |"
        )
        worst_peak = min(worst_peak, float(peaks.min()))
        if reached:
            worst_time = max(worst_time, max(reached))
        all_reached &= len(reached) == len(sel)
    swing = np.median([r.swing_time for r in rows])
    lines += [
        "",
        f"Median swing duration of the tested swings: {swing:.2f} s. Over every phase and swing: "
        f"lowest peak {worst_peak * 100:.1f} cm, slowest time to 11 cm {worst_time:.2f} s; "
        f"every interrupt reached 11 cm within 0.15 s: {'yes' if all_reached else 'no'} "
        "(target: yes).",
        "",
    ]
    text = "\n".join(lines)
    print(text)
    if args.out:
        from neurocog_gym import io as nio

        nio.atomic_write_text(args.out, text)


if __name__ == "__main__":
    main()
