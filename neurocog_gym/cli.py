"""The ``neurocog`` command: thin argument parsing over the library.

Errors in arguments or files exit non-zero with one line on stderr that says what is wrong.
"""

from __future__ import annotations

import argparse
import math
import os
import sys


class _Parser(argparse.ArgumentParser):
    """An argument error is one line on stderr (no usage block), with where to look."""

    def error(self, message: str):
        """Print ``prog: error: message; see prog --help`` and exit 2."""
        self.exit(2, f"{self.prog}: error: {message}; see '{self.prog} --help'\n")


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (value > 0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(f"must be a positive finite number, got {text}")
    return value


def _nonneg_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (value >= 0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(f"must be a finite number >= 0, got {text}")
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
    fell = f", FELL at {summary['fell_at_s']:.2f} s" if summary["fell_at_s"] else ""
    print(
        f"walked {summary['distance_m']:.2f} m in {summary['seconds']:.1f} s: "
        f"{summary['speed_m_per_s']:.3f} m/s, cost of transport "
        f"{summary['cost_of_transport']:.2f}{fell}"
    )
    for key in ("video", "plot"):
        if key in summary:
            print(f"{key}: {summary[key]}")
    if args.trials > 0:
        from pathlib import Path

        from neurocog_gym.demo import bench_demo

        policies = tuple(p.strip() for p in args.policies.split(",") if p.strip())
        report, table = bench_demo(
            Path(args.out) / "bench", trials=args.trials, policies=policies, seed=args.seed,
            workers=args.workers,
        )  # fmt: skip
        print(f"\nObstacle benchmark, {args.trials} trials per scenario and policy "
              f"(the README has the 200-trial results):")  # fmt: skip
        print("\n".join(table))
        print(f"report: {report}")
    return 0


def _cmd_tune_cpg(args) -> int:
    from neurocog_gym.train.nsga import tune_cpg_cli

    res = tune_cpg_cli(
        args.out, pop_size=args.pop_size, generations=args.generations,
        eval_seconds=args.eval_seconds, seed=args.seed, workers=args.workers,
        ray_address=args.ray_address, resume=args.resume, base_gait=args.base_gait,
        max_drift=args.max_drift,
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
        from pathlib import Path

        from neurocog_gym import io as nio
        from neurocog_gym import paths

        weights = Path(args.out) / "aef_weights.npz"
        nio.atomic_write_bytes(paths.assets_dir() / paths.AEF_WEIGHTS, weights.read_bytes())
        print(f"exported to {paths.assets_dir() / paths.AEF_WEIGHTS}")
    return 0


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {text}")
    return value


def _cmd_bench(args) -> int:
    from neurocog_gym.bench.runner import BenchConfig, run_benchmark

    scenarios = ("sudden", "static") if args.scenario == "all" else (args.scenario,)
    cfg = BenchConfig(
        out=args.out, scenarios=scenarios, trials=args.trials, seed=args.seed, policy=args.policy,
        attention=args.attention, max_seconds=args.max_seconds, workers=args.workers,
        ray_address=args.ray_address, resume=args.resume,
        affordance_source=args.affordance_source, body=args.body,
    )  # fmt: skip
    res = run_benchmark(cfg)
    for s in scenarios:
        c = res.summary[s]
        if c["paper"] is None:  # stepping stones: success = crossed, no paper count
            lo, hi = c["wilson95"]["success"]
            print(f"{s}: {c['success']} crossed / {c['fail']} fail of {c['trials']} "
                  f"({100 * lo:.0f}-{100 * hi:.0f} % crossed, 95 % Wilson)")  # fmt: skip
            continue
        print(f"{s}: {c['success']} success / {c['touch']} touch / {c['fail']} fail of "
              f"{c['trials']} (paper {c['paper']['success']}/{c['paper']['touch']}/"
              f"{c['paper']['fail']} of {c['paper']['trials']})")  # fmt: skip
    rate = 60.0 * res.ran / res.elapsed_s if res.ran else 0.0
    print(f"ran {res.ran} trials ({res.skipped} already done) on {res.workers} worker(s) in "
          f"{res.elapsed_s:.0f} s: {rate:.1f} trials/min")  # fmt: skip
    written = [n for n in ("trials.jsonl", "summary.json", "report.md") if (cfg.out / n).exists()]
    print(f"results in {cfg.out}: {', '.join(written)}")
    return 0


def _cmd_bench_report(args) -> int:
    from neurocog_gym.bench.report import write_report

    print(f"report: {write_report(args.runs, args.out)}")
    return 0


def _cmd_record_video(args) -> int:
    from neurocog_gym.video import record_video

    s = record_video(
        args.env, policy=args.policy, out=args.out, seconds=args.seconds, seed=args.seed,
        camera=args.camera, width=args.width, height=args.height, fps=args.fps,
        progress=not args.quiet,
    )  # fmt: skip
    tail = f", outcome {s['outcome']}" if "outcome" in s else ""
    print(f"{s['frames']} frames ({s['seconds']:.2f} s simulated, {s['fps']} fps), "
          f"{s['distance_m']:.2f} m walked{tail}: {s['out']}")  # fmt: skip
    return 0


def _cmd_info(args) -> int:
    import json

    import neurocog_gym
    from neurocog_gym.envs.catalog import describe, format_text

    ids = [args.env] if args.env else list(neurocog_gym.ENV_IDS)
    descs = [describe(i) for i in ids]
    if args.json:
        print(json.dumps(descs, indent=2))
    else:
        print(f"neurocog_gym {neurocog_gym.__version__}: {len(descs)} environment(s)\n")
        print("\n\n".join(format_text(d) for d in descs))
    return 0


def _even_pixels(text: str) -> int:
    value = _positive_int(text)
    if value < 16 or value % 2:
        raise argparse.ArgumentTypeError(f"must be an even number >= 16, got {text}")
    return value


def _fps(text: str) -> int:
    value = _positive_int(text)
    if value > 100:
        raise argparse.ArgumentTypeError(f"must be at most 100 (the control rate), got {text}")
    return value


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of every subcommand."""
    parser = _Parser(
        prog="neurocog",
        description="Neuro-cognitive quadruped locomotion with DD-GNG attention "
        "(Gymnasium/MuJoCo).",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("demo", help="walk (video, gait plot), then a short obstacle benchmark",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)  # fmt: skip
    p.add_argument("--out", default="runs/demo", help="output folder")
    p.add_argument(
        "--seconds", type=_positive_float, default=20.0, help="simulated seconds of walking"
    )
    p.add_argument("--seed", type=_nonneg_int, default=0, help="episode seed")
    p.add_argument("--no-video", action="store_true", help="skip the video (faster)")
    p.add_argument("--trials", type=_nonneg_int, default=4,
                   help="obstacle trials per scenario and policy (0: walk only)")  # fmt: skip
    p.add_argument("--policies", default="oracle,aef,aef-provision,blind",
                   help="comma-separated policies of the short benchmark")  # fmt: skip
    p.add_argument("--workers", type=_positive_int, default=None,
                   help="parallel trials (None: all local cores)")  # fmt: skip
    p.set_defaults(func=_cmd_demo)

    # Defaults are written in the help: None means "Table 3's value, or the run's on --resume".
    p = sub.add_parser("tune-cpg", help="NSGA-II tuning of the CPG chromosome (Table 3)")
    p.add_argument("--pop-size", type=int, default=None, help="population (default 128, Table 3)")
    p.add_argument("--generations", type=int, default=None,
                   help="generations, first included (default 100; --resume may add)")  # fmt: skip
    p.add_argument("--eval-seconds", type=_positive_float, default=None,
                   help="simulated seconds per evaluation (default 10)")  # fmt: skip
    p.add_argument("--workers", type=int, default=None,
                   help="parallel evaluations (default: all local cores / Ray CPUs)")  # fmt: skip
    p.add_argument("--seed", type=_nonneg_int, default=None, help="run seed (default 0)")
    p.add_argument("--out", default="runs/nsga", help="run folder (default runs/nsga)")
    p.add_argument("--ray-address", default=None,
                   help="running Ray cluster: host:port, ray://host:port or auto")  # fmt: skip
    p.add_argument("--resume", action="store_true", help="continue the run in --out")
    p.add_argument("--base-gait", default=None,
                   help="gait JSON whose genes are tuned (default: the shipped gait)")  # fmt: skip
    p.add_argument("--max-drift", type=_nonneg_float, default=None,
                   help="constraint: most lateral drift in m per 10 m forward (default 0 = off, "
                   "Table 3's problem)")  # fmt: skip
    p.set_defaults(func=_cmd_tune_cpg)

    p = sub.add_parser("train-aef", help="motor babbling + backpropagation of the AEF network",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)  # fmt: skip
    p.add_argument("--samples", type=_nonneg_int, default=40000,
                   help="babbling control cycles to record (reused from OUT if "
                        "present)")  # fmt: skip
    p.add_argument("--epochs", type=_nonneg_int, default=60, help="most training epochs")
    p.add_argument("--seed", type=_nonneg_int, default=0, help="seed of babbling and training")
    p.add_argument("--out", default="runs/aef", help="output folder (resumes a killed run)")
    p.add_argument("--export", action="store_true",
                   help="copy the trained weights over the shipped "
                        "assets/aef_weights.npz")  # fmt: skip
    p.set_defaults(func=_cmd_train_aef)

    p = sub.add_parser("bench", help="sudden- and static-obstacle trials beside Table 4 (§6.5)",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)  # fmt: skip
    p.add_argument("--scenario",
                   choices=("sudden", "static", "all", "stones", "stones-moving"),
                   default="all",
                   help="which task (all: sudden and static; stones, stones-moving: "
                        "NeuroCog/SteppingStones-v3 still and moving)")  # fmt: skip
    p.add_argument("--trials", type=_positive_int, default=50,
                   help="per scenario (paper: 50)")  # fmt: skip
    p.add_argument("--seed", type=_nonneg_int, default=0,
                   help="run seed (trial seeds derive from seed, scenario, i)")  # fmt: skip
    p.add_argument("--policy", default="aef",
                   help="aef, aef-provision (interrupts off), blind, oracle (privileged "
                        "step-over script), ppo (the shipped PPO policy: "
                        "trained on v0, refused until retrained on v3), AEF weights (.npz) or "
                        "a stable-baselines3 model (.zip)")  # fmt: skip
    p.add_argument("--attention", choices=("on", "off", "mlgng"), default="on",
                   help="off: plain GNG instead of DD-GNG attention (the ablation); mlgng: "
                        "the multi-layer GNG baseline of §7.1")  # fmt: skip
    p.add_argument("--affordance-source", choices=("points", "map"), default=None,
                   help="the envs' affordance_source: map (sizes from the graph alone, the "
                        "paper's) or points (the raw-point refinement); None: the env's "
                        "default (points)")  # fmt: skip
    p.add_argument("--body", choices=("v1", "v2"), default="v2",
                   help="the robot body of the envs: v2 (bent shanks, the -v2 and -v3 "
                        "envs' default; docs/body_v2.md) or v1 (straight shanks, the -v1 "
                        "envs')")  # fmt: skip
    p.add_argument("--max-seconds", type=_positive_float, default=None,
                   help="simulated seconds per trial (None: 7 s sudden, 10 s static)")  # fmt: skip
    p.add_argument("--workers", type=_positive_int, default=None,
                   help="parallel trials (None: all local cores / Ray CPUs)")  # fmt: skip
    p.add_argument("--ray-address", default=None,
                   help="running Ray cluster: host:port, ray://host:port or auto")  # fmt: skip
    p.add_argument("--out", default="runs/bench", help="run folder")
    p.add_argument("--resume", action="store_true", help="run only the trials missing in --out")
    p.set_defaults(func=_cmd_bench)

    p = sub.add_parser("bench-report", help="one report over several bench runs (ablations)",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)  # fmt: skip
    p.add_argument("runs", nargs="+", help="bench run folders, shown side by side")
    p.add_argument("--out", default="runs/bench_report", help="folder of report.md and plots")
    p.set_defaults(func=_cmd_bench_report)

    p = sub.add_parser("record-video",
                       help="an episode to MP4 with the attention graph, facets and footholds",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)  # fmt: skip
    p.add_argument("--env", default="NeuroCog/SuddenObstacle-v3",
                   help="registered env id (see neurocog info)")  # fmt: skip
    p.add_argument("--policy", default="aef",
                   help="aef, aef-provision (interrupts off), blind, ppo (the shipped "
                        "PPO policy: trained on v0, refused until retrained on v3), AEF "
                        "weights (.npz) or a stable-baselines3 model (.zip); "
                        "Walk-v3 takes blind or a model trained on it")  # fmt: skip
    p.add_argument("--seconds", type=_positive_float, default=7.0,
                   help="simulated seconds (the episode may end sooner: fell or passed)",
                   )  # fmt: skip
    p.add_argument("--seed", type=_nonneg_int, default=0, help="episode seed")
    p.add_argument("--camera", default="follow", help="scene camera: follow, side or overhead")
    p.add_argument("--width", type=_even_pixels, default=640, help="frame width, pixels")
    p.add_argument("--height", type=_even_pixels, default=480, help="frame height, pixels")
    p.add_argument("--fps", type=_fps, default=50, help="video frames per second (real time)")
    p.add_argument("--out", default="runs/video.mp4", help="MP4 file to write")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_record_video)

    p = sub.add_parser("info", help="the registered envs: spaces, episode length, parameters",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)  # fmt: skip
    p.add_argument("--env", default=None, help="one env id (default: every registered id)")
    p.add_argument("--json", action="store_true", help="machine-readable JSON instead of text")
    p.set_defaults(func=_cmd_info)
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
        if isinstance(e, OSError) and e.filename and e.strerror:
            msg = f"cannot use {e.filename}: {e.strerror}"
        else:
            msg = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        print(f"neurocog {args.command}: error: {msg}", file=sys.stderr)
        return 2
    except Exception as e:  # a bug, not a user error: still one line unless asked for more
        if os.environ.get("NEUROCOG_DEBUG"):
            raise
        text = str(e).strip().splitlines()[0] if str(e).strip() else ""
        print(f"neurocog {args.command}: internal error: {type(e).__name__}: {text} (set "
              "NEUROCOG_DEBUG=1 for the traceback and please report it)",
              file=sys.stderr)  # fmt: skip
        return 3


if __name__ == "__main__":
    sys.exit(main())
