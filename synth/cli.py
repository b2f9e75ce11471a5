"""``tactile-synth`` sub-commands contributed by the ``synth`` package."""

from __future__ import annotations

import argparse


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add this package's sub-commands; each sets ``handler=callable(args) -> int``."""
    from . import dataset_cli  # generate / inspect / plot / export

    dataset_cli.register(subparsers)

    from . import sim_cli  # plot-trial / view

    sim_cli.register(subparsers)
