"""``tactile-synth stress``: the robustness suite from the command line (``docs/stress.md``),
and the options ``tactile-synth benchmark stress`` adds to ``benchmark``."""

from __future__ import annotations

import argparse
import sys

from synth.dataset_cli import SCHEDULER_HELP, connect_scheduler
from tactile_synth.interrupts import terminate_as_interrupt
from tactile_synth.threads import HELP as THREADS_HELP
from tactile_synth.validation import int_arg

from ..cli_options import add_method_options, again_command, check_methods_arg
from .families import FAMILY_NAMES, QUICK_FAMILIES

FAMILIES_HELP = (
    f"families to run: {', '.join(FAMILY_NAMES)}, installed plug-ins (entry point group "
    "tactile_synth.stress_families) or module:Class / path/to/file.py:Class of a "
    "StressFamily subclass (docs/stress.md); default: all, or "
    f"{', '.join(QUICK_FAMILIES)} with --quick"
)


def suite_arguments(args: argparse.Namespace) -> dict[str, object]:
    """The :func:`~benchmark.stress.command.run_stress` arguments ``stress`` and
    ``benchmark stress`` both take from their command line."""
    names = ("data", "methods", "families", "severities", "episodes", "reference", "way")
    names += ("shot", "seed", "workers", "overwrite")
    return {name: getattr(args, name) for name in names}


def add_suite_options(p: argparse.ArgumentParser, *, prefix: str = "") -> None:
    """The suite's own options (families, severities, cell, reference), for ``stress``
    and ``benchmark stress``; ``prefix`` marks them as the latter's in the help."""
    p.add_argument("--families", nargs="+", metavar="NAME", help=prefix + FAMILIES_HELP)
    p.add_argument(
        "--severities",
        metavar="LIST",
        help=prefix + "severities to run, e.g. 1,3,5 (default: 1-5, or 3,5 with --quick)",
    )
    p.add_argument(
        "--reference",
        metavar="METHOD",
        help=prefix + "the method the corruption errors are relative to (default "
        "Direct-Prot-ML when run, else the first method)",
    )
    p.add_argument("--way", type=int_arg, default=5, help=prefix + "N of the cell (default 5)")
    p.add_argument("--shot", type=int_arg, default=1, help=prefix + "K of the cell (default 1)")


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``tactile-synth stress``."""
    p = subparsers.add_parser(
        "stress",
        help="robustness suite: physical perturbations and sensor faults at graded severities",
        description=(
            "Fit every method once on the nominal dataset's closed-set training half, "
            "simulate a test set for every physical family and severity (into DIR/data, "
            "resumable), apply the sensor faults to the clean test set, and evaluate two "
            "readings of each (enrolled at nominal; all perturbed). Writes DIR/results.json, "
            "DIR/stress.md and PNG figures (docs/stress.md)."
        ),
    )
    p.add_argument("--out", required=True, metavar="DIR", help="output directory")
    p.add_argument(
        "--data",
        metavar="NOMINAL",
        help="the nominal dataset store (default: the paper preset, generated into DIR/data)",
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help="four families, two severities, small datasets, three methods (a few minutes)",
    )
    add_method_options(p, "the paper's seven, or three with --quick")
    add_suite_options(p)
    p.add_argument(
        "--episodes",
        type=int_arg,
        metavar="N",
        help="episodes per method and condition (default 200, 100 with --quick)",
    )
    p.add_argument("--seed", type=int_arg, default=0, help="seed of data and episodes (default 0)")
    p.add_argument(
        "--workers",
        type=int_arg,
        metavar="N",
        help="processes for generation and for the fits (default: generation in this "
        "process, fits in one process per usable CPU)",
    )
    p.add_argument("--threads", type=int_arg, metavar="N", help=THREADS_HELP)
    p.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="simulate the test sets on this Dask scheduler's workers, e.g. tcp://host:8786 "
        "(the fits stay local); " + SCHEDULER_HELP.split("; ", 1)[1],
    )
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="replace a non-empty DIR tactile-synth did not write, and evaluate again (the "
        "datasets in DIR/data are kept)",
    )
    p.set_defaults(handler=_stress)


def _stress(args: argparse.Namespace) -> int:
    from models.registry import METHOD_NAMES

    from ..plan import QUICK_METHODS
    from .command import run_stress

    default = QUICK_METHODS if args.quick else METHOD_NAMES
    options = check_methods_arg(args.methods, args.method_option, default)
    client, executor = None, None
    if args.scheduler:
        client, executor, _ = connect_scheduler(args.scheduler)
    try:
        with terminate_as_interrupt():
            run_stress(
                args.out,
                quick=args.quick,
                executor=executor,
                options=options,
                **suite_arguments(args),
            )
    except KeyboardInterrupt:
        again = again_command(args, ["stress", "--out", str(args.out)])
        print(
            f"tactile-synth stress: interrupted; the finished test sets and fits in {args.out} "
            f"are kept: `tactile-synth {again}` continues from them",
            file=sys.stderr,
        )
        return 130
    finally:
        if client is not None:
            client.close()
    print(f"report: {args.out}/stress.md")
    return 0
