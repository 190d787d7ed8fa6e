"""The ``neurocog`` command: thin argument parsing over the library.

Errors in arguments or files exit non-zero with one line on stderr that says what is wrong.
"""

from __future__ import annotations

import argparse
import sys


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be positive, got {text}")
    return value


def _nonneg_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {text}")
    return value


def _cmd_demo(args) -> int:
    from neurocog_gym.demo import walk_demo

    summary = walk_demo(args.out, seconds=args.seconds, seed=args.seed, video=not args.no_video)
    print(f"walked {summary['distance_m']:.2f} m in {summary['seconds']:.1f} s: "
          f"{summary['speed_m_per_s']:.3f} m/s, cost of transport "
          f"{summary['cost_of_transport']:.2f}" + (
              f", FELL at {summary['fell_at_s']:.2f} s" if summary["fell_at_s"] else ""))  # fmt: skip
    for key in ("video", "plot"):
        if key in summary:
            print(f"{key}: {summary[key]}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of every subcommand."""
    parser = argparse.ArgumentParser(
        prog="neurocog",
        description="Neuro-cognitive quadruped locomotion with DD-GNG attention (Gymnasium/MuJoCo).",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("demo", help="walk the robot and write a video and a gait plot",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)  # fmt: skip
    p.add_argument("--out", default="runs/demo", help="output folder")
    p.add_argument("--seconds", type=_positive_float, default=20.0, help="simulated seconds")
    p.add_argument("--seed", type=_nonneg_int, default=0, help="episode seed")
    p.add_argument("--no-video", action="store_true", help="skip the video (faster)")
    p.set_defaults(func=_cmd_demo)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``neurocog`` command."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        print("neurocog: interrupted", file=sys.stderr)
        return 130
    except (ValueError, FileNotFoundError, KeyError, OSError, RuntimeError) as e:
        msg = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        print(f"neurocog {args.command}: error: {msg}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
