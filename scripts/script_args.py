"""Argument checks shared by the benchmark scripts: a bad argument ends the script with one
line, ``SCRIPT: error: ...`` naming the argument as typed, and exit status 2 (argparse's
convention), not a traceback."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import NoReturn


def fail(parser: argparse.ArgumentParser, message: str) -> NoReturn:
    """Print ``message`` on one line after the script's name and exit with status 2."""
    print(f"{parser.prog}: error: {' '.join(message.split())}", file=sys.stderr)
    raise SystemExit(2)


def description(doc: str) -> str:
    """The first paragraph of a script's docstring, a complete sentence for ``--help``."""
    return doc.split("\n\n")[0]


def load_data(parser: argparse.ArgumentParser, path: str, arg: str = "--data"):
    """The dataset at ``path`` (``synth.load_dataset``, every check); a missing, foreign,
    incomplete or damaged dataset ends the script naming ``arg``."""
    from synth.store import DatasetError, load_dataset

    try:
        return load_dataset(path)
    except (DatasetError, OSError) as exc:
        # An incomplete dataset's advice for command lines: `generate --resume`, not the
        # Python API's allow_incomplete.
        fail(parser, f"{arg} {path}: {getattr(exc, 'cli_message', exc)}")


def check_methods(parser: argparse.ArgumentParser, methods: Sequence[str]) -> tuple[str, ...]:
    """``methods`` validated (``models.registry.check_methods``) before any work, so an
    unknown name ends the script naming ``--methods`` instead of failing after the data
    are read."""
    from models.registry import check_methods as check

    try:
        return check(methods, arg="--methods")
    except ValueError as exc:
        fail(parser, str(exc))
