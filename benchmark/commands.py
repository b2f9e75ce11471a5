"""``tactile-synth`` sub-commands contributed by the ``benchmark`` package
(``benchmark``, ``run``)."""

from __future__ import annotations

import argparse

from tactile_synth.threads import HELP as THREADS_HELP


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add this package's sub-commands; each sets ``handler=callable(args) -> int``."""
    _register_benchmark(subparsers)
    _register_run(subparsers)


def _register_benchmark(subparsers: argparse._SubParsersAction) -> None:
    """``tactile-synth benchmark PROTOCOL``: evaluate methods on existing datasets."""
    from models.registry import METHOD_NAMES

    from .protocols import PROTOCOL_NAMES

    p = subparsers.add_parser(
        "benchmark",
        help="run an evaluation protocol (or all) on generated datasets",
        description=(
            "Fit the methods on the protocol's training part of --data and evaluate "
            "N-way K-shot episodes; writes DIR/results.json, DIR/report.md and PNG figures "
            "('all' also runs the interpretability analysis)."
        ),
    )
    p.add_argument("protocol", choices=(*PROTOCOL_NAMES, "all"))
    p.add_argument("--data", required=True, metavar="PATH", help="nominal dataset (Zarr store)")
    p.add_argument(
        "--perturbed", metavar="PATH", help="perturbation dataset (perturbation and all)"
    )
    p.add_argument("--out", required=True, metavar="DIR", help="output directory")
    p.add_argument(
        "--methods",
        nargs="+",
        default=None,
        metavar="NAME",
        help=f"methods (default: all): {', '.join(METHOD_NAMES)}",
    )
    p.add_argument("--episodes", type=int, default=500, help="episodes per cell (default 500)")
    p.add_argument("--seed", type=int, default=0, help="seed of splits and episodes (default 0)")
    p.add_argument("--threads", type=int, metavar="N", help=THREADS_HELP)
    p.set_defaults(handler=_benchmark)


def _benchmark(args: argparse.Namespace) -> int:
    from .single import benchmark_protocol

    benchmark_protocol(
        args.protocol,
        data_path=args.data,
        perturbed_path=args.perturbed,
        out=args.out,
        methods=args.methods,
        episodes=args.episodes,
        seed=args.seed,
    )
    print(f"wrote {args.out}/results.json and {args.out}/report.md")
    return 0


def _register_run(subparsers: argparse._SubParsersAction) -> None:
    """``tactile-synth run``: the whole study from nothing (owner: protocols/report)."""
    p = subparsers.add_parser(
        "run",
        help="generate the datasets and run the whole benchmark (the main job)",
        description=(
            "From nothing: generate the 'paper' and 'perturbation' datasets into "
            "DIR/data (small ones with --quick), then run 'benchmark all' into DIR "
            "(results.json, report.md, PNG figures). Re-running on the same DIR reuses "
            "finished datasets and protocols."
        ),
    )
    p.add_argument("--out", required=True, metavar="DIR", help="output directory")
    p.add_argument("--quick", action="store_true", help="small datasets, fewer episodes (<5 min)")
    p.add_argument("--seed", type=int, default=0, help="seed of data and episodes (default 0)")
    p.add_argument(
        "--workers", type=int, help="generation processes (default 1; N > 1 share the CPUs)"
    )
    p.add_argument("--threads", type=int, metavar="N", help=THREADS_HELP)
    p.set_defaults(handler=_run)


def _run(args: argparse.Namespace) -> int:
    from .run import run

    run(args.out, quick=args.quick, seed=args.seed, workers=args.workers, progress=True)
    print(f"report: {args.out}/report.md")
    return 0
