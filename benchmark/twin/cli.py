"""``tactile-synth calibrate``: the command line of :mod:`benchmark.twin.calibrate`."""

from __future__ import annotations

import argparse
import sys
import time

from synth.dataset_cli import SCHEDULER_HELP
from tactile_synth.validation import int_arg

from .calibrate import DEFAULT_BUDGET, DEFAULT_PARAMETERS, DEFAULT_TRIALS_PER_CLASS


def register(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "calibrate",
        help="fit the twin's global physical parameters to your recordings (writes a finger file)",
        description=(
            "Fit the twin's global physical parameters (never a per-class knob) to a dataset "
            "store of recordings by simulation-based inference (neural posterior "
            "estimation, sbi): simulates the store's classes and conditions over each "
            "parameter's cited range, and writes OUT/finger.toml (posterior medians, for "
            "`generate --finger`), OUT/report.md (posterior, figures, what the data do not "
            "pin down) and OUT/calibration.json. See docs/calibrate.md."
        ),
    )
    p.add_argument(
        "--recordings", metavar="STORE", help="the dataset store to fit (import or generate)"
    )
    p.add_argument("--out", metavar="DIR", help="output directory (new, or with --resume)")
    p.add_argument(
        "--parameters",
        nargs="+",
        metavar="NAME[=LOW:HIGH]",
        help=f"parameters to fit, optionally over a part of their cited range (default: "
        f"{' '.join(DEFAULT_PARAMETERS)}); --list-parameters lists them",
    )
    p.add_argument(
        "--budget",
        type=int_arg,
        default=DEFAULT_BUDGET,
        metavar="N",
        help=f"simulations (default {DEFAULT_BUDGET})",
    )
    p.add_argument(
        "--trials-per-class",
        type=int_arg,
        metavar="N",
        help=f"trials per class and condition in each simulation (default "
        f"{DEFAULT_TRIALS_PER_CLASS}, at least 2; --sweep and --whatif: {SWEEP_TRIALS})",
    )
    p.add_argument("--seed", type=int_arg, default=0, help="seed of the draws, trials and training")
    p.add_argument(
        "--workers", type=int_arg, default=1, help="local processes simulating (default 1)"
    )
    p.add_argument("--scheduler", metavar="ADDRESS", help=SCHEDULER_HELP)
    p.add_argument(
        "--resume", action="store_true", help="continue the interrupted calibration in --out"
    )
    mode = p.add_mutually_exclusive_group()
    mode.add_argument(
        "--sweep",
        action="store_true",
        help="not a fit: measure each global parameter over its cited range, one at a time, "
        "into --out's calibration.md (docs/calibrate.md)",
    )
    mode.add_argument(
        "--whatif",
        action="store_true",
        help="not a fit: measure one --set configuration, inside or outside the cited ranges",
    )
    sweep = p.add_argument_group("--sweep and --whatif")
    sweep.add_argument(
        "--set",
        action="append",
        metavar="SECTION.FIELD=VALUE",
        help="the configuration measured (--whatif) or swept from (--sweep) (repeatable)",
    )
    sweep.add_argument(
        "--seeds", type=int_arg, default=1, help="dataset seeds per configuration (0..N-1)"
    )
    sweep.add_argument(
        "--only", action="append", metavar="SECTION.FIELD", help="sweep only this parameter"
    )
    sweep.add_argument(
        "--base",
        action="append",
        metavar="SECTION.FIELD=VALUE",
        help="hold a swept parameter at this value and sweep the others (repeatable)",
    )
    sweep.add_argument(
        "--closed-set",
        type=int_arg,
        default=0,
        metavar="EPISODES",
        help="--whatif: also AFOP-ML's closed-set 1-shot row over this many episodes",
    )
    sweep.add_argument(
        "--closed-set-seeds",
        type=int_arg,
        default=1,
        metavar="N",
        help="--whatif: the closed-set row on paper-preset datasets of seeds 0..N-1",
    )
    sweep.add_argument(
        "--keep", metavar="DIR", help="--whatif: keep the dataset of seed 0 in this new directory"
    )
    p.add_argument(
        "--list-parameters",
        action="store_true",
        help="print every parameter that can be fitted, with its cited range, and exit",
    )
    p.set_defaults(handler=_handler)


#: Trials per class of a sweep's or what-if's datasets by default.
SWEEP_TRIALS = 20


def main(argv: list[str]) -> int:
    """``tactile-synth calibrate ARGV`` with a refusal or failure raised as ``SystemExit``
    of its one-line message (for scripts and tests; the console command prints it)."""
    parser = argparse.ArgumentParser(prog="tactile-synth calibrate")
    sub = parser.add_subparsers(dest="command", required=True)
    register(sub)
    args = parser.parse_args(["calibrate", *argv])
    return run(args)


def run(args: argparse.Namespace) -> int:
    from synth.calibration.settings import CalibrationError

    try:
        return _dispatch(args)
    except CalibrationError as exc:
        raise SystemExit(str(exc)) from None
    except synth_error() as exc:
        mode = " --sweep" if args.sweep else " --whatif" if args.whatif else ""
        raise SystemExit(f"calibrate{mode}: {exc}") from None


def synth_error() -> type[Exception]:
    import synth

    return synth.SimulationError


def _sweep_checks(args: argparse.Namespace) -> None:
    from synth.calibration.settings import CalibrationError

    if args.trials_per_class < 2:
        raise CalibrationError(
            "--trials-per-class must be at least 2 (leave-one-out needs a neighbour)"
        )
    if args.seeds < 1:
        raise CalibrationError("--seeds must be at least 1")
    if args.closed_set < 0:
        raise CalibrationError("--closed-set must be 0 (off) or a number of episodes")
    if args.closed_set_seeds < 1:
        raise CalibrationError("--closed-set-seeds must be at least 1")
    if args.closed_set_seeds > 1 and not args.closed_set:
        raise CalibrationError(
            "--closed-set-seeds needs --closed-set EPISODES (the row it repeats)"
        )
    if args.sweep and (args.closed_set or args.keep):
        raise CalibrationError("--closed-set and --keep go with --whatif, not --sweep")
    if args.whatif and (args.only or args.base or args.out or args.resume):
        raise CalibrationError("--only, --base, --out and --resume go with --sweep, not --whatif")


def _handler(args: argparse.Namespace) -> int:
    """The console command: a ``SystemExit`` message becomes the CLI's one-line error."""
    try:
        return run(args)
    except SystemExit as exc:
        if isinstance(exc.code, str):
            print(f"tactile-synth calibrate: error: {' '.join(exc.code.split())}", file=sys.stderr)
            return 1 if exc.code.startswith("calibrate") else 2
        raise


def list_parameters() -> str:
    from synth.calibration.parameters import PARAMETERS

    lines = []
    for p in PARAMETERS.values():
        scale = " (log)" if p.log else ""
        lines.append(f"{p.name}  {p.low:g}..{p.high:g}{scale}\n    {p.why}")
    return "\n".join(lines)


def _dispatch(args: argparse.Namespace) -> int:
    from synth.calibration.parameters import parse_parameters
    from synth.calibration.settings import CalibrationError

    from .calibrate import calibrate, default_parameters

    if args.list_parameters:
        print(list_parameters())
        return 0
    if args.sweep or args.whatif:
        from . import sweep

        if args.trials_per_class is None:
            args.trials_per_class = SWEEP_TRIALS
        _sweep_checks(args)
        return sweep.cmd_sweep(args) if args.sweep else sweep.cmd_whatif(args)
    if args.trials_per_class is None:
        args.trials_per_class = DEFAULT_TRIALS_PER_CLASS
    for opt in ("recordings", "out"):
        if not getattr(args, opt):
            raise CalibrationError(f"--{opt} is required")
    if args.budget < 1:
        raise CalibrationError(f"--budget must be at least 1 simulation; got {args.budget}")
    parameters = parse_parameters(args.parameters) if args.parameters else default_parameters()
    client = executor = None
    if args.scheduler:
        from synth.dataset_cli import connect_scheduler

        client, executor, _ = connect_scheduler(args.scheduler)
    start = time.perf_counter()
    try:
        result = calibrate(
            args.recordings,
            args.out,
            parameters=parameters,
            budget=args.budget,
            trials_per_class=args.trials_per_class,
            seed=args.seed,
            workers=args.workers,
            executor=executor,
            resume=args.resume,
        )
    except KeyboardInterrupt:
        print(
            "tactile-synth calibrate: interrupted; the finished simulations are saved: "
            f"continue with `tactile-synth calibrate --recordings {args.recordings} --out "
            f"{args.out} --resume` (and the same options)",
            file=sys.stderr,
        )
        return 130
    finally:
        if client is not None:
            client.close()
    width = max(len(e.name) for e in result.estimates)
    for e in result.estimates:
        note = "  (not pinned down: flat posterior)" if e.flat else ""
        print(f"{e.name:<{width}}  {e.median:.4g}  [90 %: {e.low:.4g} .. {e.high:.4g}]{note}")
    print(
        f"wrote {result.out}/finger.toml and report.md: {result.n_simulations} simulations "
        f"in {time.perf_counter() - start:.1f} s"
    )
    return 0
