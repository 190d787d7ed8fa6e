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


def _cmd_tune_cpg(args) -> int:
    from neurocog_gym.train.nsga import tune_cpg_cli

    res = tune_cpg_cli(
        args.out, pop_size=args.pop_size, generations=args.generations,
        eval_seconds=args.eval_seconds, seed=args.seed, workers=args.workers,
        ray_address=args.ray_address, resume=args.resume, base_gait=args.base_gait,
    )  # fmt: skip
    print(f"{res.generations} generations, {res.n_evals} evaluations in {res.elapsed_s:.0f} s; "
          f"chosen gait: speed error {res.best_F[0]:.3f} m/s, cost of transport "
          f"{res.best_F[1]:.2f}" + ("" if res.feasible else " (INFEASIBLE: it falls)"))  # fmt: skip
    print(f"best gait: {res.out / 'best_gait.json'}")
    return 0


def _cmd_train_aef(args) -> int:
    from neurocog_gym.train.aef import AEFTrainConfig, train_aef

    cfg = AEFTrainConfig(samples=args.samples, epochs=args.epochs, seed=args.seed)
    m = train_aef(cfg, args.out)
    print(f"val_loss {m['val_loss']:.4f} vs mean predictor {m['baseline_val_loss']:.4f} "
          f"(ratio {m['ratio']:.2f}); weights: {args.out}/aef_weights.npz")  # fmt: skip
    if args.export:
        import shutil

        from neurocog_gym import paths

        shutil.copyfile(f"{args.out}/aef_weights.npz", paths.assets_dir() / paths.AEF_WEIGHTS)
        print(f"exported to {paths.assets_dir() / paths.AEF_WEIGHTS}")
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

    p = sub.add_parser("tune-cpg", help="NSGA-II tuning of the CPG chromosome (Table 3)",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)  # fmt: skip
    p.add_argument("--pop-size", type=int, default=None, help="population (None: 128, Table 3)")
    p.add_argument("--generations", type=int, default=None,
                   help="generations incl. the initial one (None: 100; on --resume may extend)")  # fmt: skip
    p.add_argument("--eval-seconds", type=_positive_float, default=None,
                   help="simulated seconds per evaluation (None: 10)")  # fmt: skip
    p.add_argument("--workers", type=int, default=None,
                   help="parallel evaluations (None: every local core / every Ray CPU)")  # fmt: skip
    p.add_argument("--seed", type=_nonneg_int, default=None, help="run seed (None: 0)")
    p.add_argument("--out", default="runs/nsga", help="run folder")
    p.add_argument("--ray-address", default=None,
                   help="evaluate on this running Ray cluster (host:port, ray://host:port, auto)")  # fmt: skip
    p.add_argument("--resume", action="store_true", help="continue the run in --out")
    p.add_argument("--base-gait", default=None,
                   help="gait JSON whose genes are tuned (None: the shipped default)")  # fmt: skip
    p.set_defaults(func=_cmd_tune_cpg)

    p = sub.add_parser("train-aef", help="motor babbling + backpropagation of the AEF network",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)  # fmt: skip
    p.add_argument("--samples", type=_nonneg_int, default=40000,
                   help="babbling control cycles to record (reused from OUT if present)")  # fmt: skip
    p.add_argument("--epochs", type=_nonneg_int, default=60, help="most training epochs")
    p.add_argument("--seed", type=_nonneg_int, default=0, help="seed of babbling and training")
    p.add_argument("--out", default="runs/aef", help="output folder (resumes a killed run)")
    p.add_argument("--export", action="store_true",
                   help="copy the trained weights over the shipped assets/aef_weights.npz")  # fmt: skip
    p.set_defaults(func=_cmd_train_aef)
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
