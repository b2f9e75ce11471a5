"""``tactile-synth`` sub-commands contributed by the ``benchmark`` package
(``benchmark``, ``run``, ``diagnose``)."""

from __future__ import annotations

import argparse
import sys

from tactile_synth.interrupts import terminate_as_interrupt
from tactile_synth.threads import HELP as THREADS_HELP
from tactile_synth.validation import float_arg, int_arg

from .cli_options import add_method_options, again_command, check_methods_arg
from .stress import cli as stress_cli


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add this package's sub-commands; each sets ``handler=callable(args) -> int``."""
    _register_benchmark(subparsers)
    _register_run(subparsers)
    _register_diagnose(subparsers)
    stress_cli.register(subparsers)


def _register_benchmark(subparsers: argparse._SubParsersAction) -> None:
    """``tactile-synth benchmark PROTOCOL``: evaluate methods on existing datasets."""
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
    p.add_argument(
        "protocol",
        metavar="PROTOCOL",
        help=f"{', '.join(PROTOCOL_NAMES)} or all; or an installed plug-in protocol (entry "
        "point group tactile_synth.protocols), or module:Class / path/to/file.py:Class of a "
        "benchmark.engine.Protocol subclass (docs/protocols.md)",
    )
    p.add_argument("--data", required=True, metavar="PATH", help="nominal dataset (Zarr store)")
    p.add_argument(
        "--perturbed", metavar="PATH", help="perturbation dataset (perturbation and all)"
    )
    p.add_argument("--out", required=True, metavar="DIR", help="output directory")
    add_method_options(p, "the paper's seven methods, then the variants")
    p.add_argument("--episodes", type=int_arg, default=500, help="episodes per cell (default 500)")
    p.add_argument(
        "--seed", type=int_arg, default=0, help="seed of splits and episodes (default 0)"
    )
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the contents of a non-empty DIR even if tactile-synth did not write "
        "them, and compute every protocol again (no checkpoint of DIR is reused)",
    )
    p.add_argument(
        "--workers",
        type=int_arg,
        metavar="N",
        help="processes the fits run in, each with its share of the CPUs (default: one per "
        "usable CPU; 1: all in this process)",
    )
    p.add_argument("--threads", type=int_arg, metavar="N", help=THREADS_HELP)
    stress = p.add_argument_group(
        "benchmark stress", "the robustness suite on existing test sets (docs/stress.md)"
    )
    stress.add_argument(
        "--stress-data",
        metavar="DIR",
        help="(stress) the directory holding the suite's test sets, as `tactile-synth stress` "
        "writes them into its DIR/data/stress",
    )
    stress_cli.add_suite_options(stress, prefix="(stress) ")
    p.set_defaults(handler=_benchmark)


def _benchmark(args: argparse.Namespace) -> int:
    from models.registry import DEFAULT_METHODS, METHOD_NAMES

    from .single import benchmark_protocol

    if args.protocol == "stress":
        from .stress.command import run_stress

        if args.stress_data is None:
            raise ValueError(
                "benchmark stress needs --stress-data DIR (the test sets `tactile-synth stress` "
                "simulated); `tactile-synth stress` simulates them"
            )
        options = check_methods_arg(args.methods, args.method_option, METHOD_NAMES)
        with terminate_as_interrupt():
            run_stress(
                args.out,
                stress_data=args.stress_data,
                options=options,
                **stress_cli.suite_arguments(args),
            )
        print(f"wrote {args.out}/results.json and {args.out}/stress.md")
        return 0

    options = check_methods_arg(args.methods, args.method_option, DEFAULT_METHODS)
    try:
        with terminate_as_interrupt():
            benchmark_protocol(
                args.protocol,
                data_path=args.data,
                perturbed_path=args.perturbed,
                out=args.out,
                methods=args.methods,
                episodes=args.episodes,
                seed=args.seed,
                overwrite=args.overwrite,
                workers=args.workers,
                options=options,
            )
    except KeyboardInterrupt:
        again = again_command(args, ["benchmark", args.protocol, "--out", str(args.out)])
        print(
            f"tactile-synth benchmark: interrupted; the outputs in {args.out} are as they were "
            f"and the protocols and fits finished are kept in {args.out}/checkpoints: "
            f"`tactile-synth {again}` continues from them (only the fits that were running "
            f"start over)",
            file=sys.stderr,
        )
        return 130
    print(f"wrote {args.out}/results.json and {args.out}/report.md")
    return 0


def _register_run(subparsers: argparse._SubParsersAction) -> None:
    """``tactile-synth run``: the whole study from nothing."""
    p = subparsers.add_parser(
        "run",
        help="generate the datasets and run the whole benchmark (the main job)",
        description=(
            "From nothing: generate the 'paper' and 'perturbation' datasets into "
            "DIR/data (small ones with --quick), then run 'benchmark all' into DIR "
            "(results.json, report.md, PNG figures). Re-running on the same DIR reuses "
            "finished datasets and protocols and replaces the outputs at once."
        ),
    )
    p.add_argument("--out", required=True, metavar="DIR", help="output directory")
    p.add_argument("--quick", action="store_true", help="small datasets, fewer episodes (<5 min)")
    p.add_argument("--seed", type=int_arg, default=0, help="seed of data and episodes (default 0)")
    p.add_argument(
        "--workers",
        type=int_arg,
        metavar="N",
        help="processes for generation and for the benchmark's fits, sharing the CPUs "
        "(default: generation in this process, fits in one process per usable CPU)",
    )
    add_method_options(
        p, "the paper's seven, then the variants, or three with --quick; must include AFOP-ML"
    )
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the contents of a non-empty DIR even if tactile-synth did not write "
        "them, and compute every protocol again (no checkpoint of DIR is reused; the "
        "datasets in DIR/data are kept)",
    )
    p.add_argument(
        "--data",
        metavar="PATH",
        help="use this dataset store (generated or imported) as the nominal dataset "
        "instead of generating the paper preset; without --perturbed the perturbation "
        "dataset is simulated for its classes",
    )
    p.add_argument(
        "--perturbed",
        metavar="PATH",
        help="use this dataset store as the perturbation dataset instead of generating it",
    )
    p.add_argument("--threads", type=int_arg, metavar="N", help=THREADS_HELP)
    p.set_defaults(handler=_run)


def _run(args: argparse.Namespace) -> int:
    from models.registry import DEFAULT_METHODS

    from .plan import QUICK_METHODS
    from .run import run

    default = QUICK_METHODS if args.quick else DEFAULT_METHODS
    options = check_methods_arg(args.methods, args.method_option, default)
    try:
        with terminate_as_interrupt():
            run(
                args.out,
                methods=args.methods,
                quick=args.quick,
                seed=args.seed,
                workers=args.workers,
                progress=True,
                overwrite=args.overwrite,
                data=args.data,
                perturbed=args.perturbed,
                options=options,
            )
    except KeyboardInterrupt:
        again = again_command(args, ["run", "--out", str(args.out)])
        print(
            f"tactile-synth run: interrupted; the finished datasets, protocols and fits in "
            f"{args.out} are kept: `tactile-synth {again}` continues from them (only the fits "
            f"that were running start over)",
            file=sys.stderr,
        )
        return 130
    print(f"report: {args.out}/report.md")
    return 0


_DIAGNOSE_EPILOG = """\
What the numbers mean (details: docs/diagnose.md):
  Leave-one-out 1-nearest-neighbour (1-NN) accuracy on the z-scored 386-feature pool:
  every trial gets the label of its nearest other trial (Euclidean distance), and the
  accuracy is the share of trials labelled right. 1.0: every trial's closest trial has
  its label; "chance" is what a random other trial gives.
    class      shape and material both right (the benchmark's classes)
    shape      shape right, whatever the material
    material   material right, whatever the shape
    condition  force/speed condition right (only with several conditions)
  Rows restrict the distance to one channel group: all features, strain gauges only
  (SG, the static channels), PVDF only (the dynamic channels). A label held by a single
  trial cannot be scored and is left out; a target with one value in the dataset (e.g.
  one material) is n/a. Per shape / per material: the shape (material) accuracy of that
  shape's (material's) trials. Confused pairs: the class pairs whose trials most often
  have their nearest neighbour in the other class.
"""


def _register_diagnose(subparsers: argparse._SubParsersAction) -> None:
    """``tactile-synth diagnose DATA``: what a dataset's classes differ by."""
    p = subparsers.add_parser(
        "diagnose",
        help="what a dataset's classes differ by (leave-one-out 1-NN per channel group)",
        description=(
            "Leave-one-out 1-NN accuracy of class, shape, material (and condition) per channel "
            "group, per-shape and per-material accuracy, the most confused class pairs, PVDF "
            "spectra per material and strain-gauge mean traces per shape. Prints a summary; "
            "with --out also writes DIR/diagnose.md, diagnose.json, diagnose.npz and PNG figures."
        ),
        epilog=_DIAGNOSE_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("data", metavar="DATA", help="dataset (Zarr store from tactile-synth generate)")
    p.add_argument("--out", metavar="DIR", help="write diagnose.md, JSON, curves and figures here")
    p.add_argument(
        "--allow-incomplete",
        action="store_true",
        help="diagnose the finished trials of an interrupted generation",
    )
    p.add_argument(
        "--edge-gap-s",
        type=float_arg,
        default=0.3,
        metavar="S",
        help="steady-sliding stretches keep this far from every wall crossing the films "
        "show (seconds, 0 to 0.9; default 0.3)",
    )
    p.set_defaults(handler=_diagnose)


def _diagnose(args: argparse.Namespace) -> int:
    import sys
    import time

    from .diagnose import MARKDOWN_NAME, run_diagnose, summary_table
    from .diagnose.steady import check_edge_gap
    from .diagnose.text import friction_lines

    check_edge_gap(args.edge_gap_s, "--edge-gap-s")
    start = time.perf_counter()
    diag = run_diagnose(
        args.data,
        out=args.out,
        allow_incomplete=args.allow_incomplete,
        edge_gap_s=args.edge_gap_s,
        progress=lambda msg: print(
            f"[diagnose {time.perf_counter() - start:5.1f} s] {msg}", file=sys.stderr, flush=True
        ),
    )
    print(summary_table(diag))
    for line in friction_lines(args.data):
        print(line)
    seconds = time.perf_counter() - start
    if args.out:
        print(f"wrote {args.out}/{MARKDOWN_NAME}, JSON, curves and figures in {seconds:.1f} s")
    else:
        print(f"diagnosed in {seconds:.1f} s (add --out DIR for diagnose.md and figures)")
    return 0
