"""The ``tactile-synth`` console script.

The CLI is thin: each package contributes its sub-commands through a
``register(subparsers)`` function in its own ``cli`` module, and every command
only parses arguments and calls library functions usable without the CLI.
Heavy imports (build123d, MuJoCo, torch) happen inside the command handlers so
``tactile-synth --help`` stays fast.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from benchmark import commands as benchmark_commands
from shapes import cli as shapes_cli
from synth import cli as synth_cli
from tactile_synth.threads import configure as configure_threads

_REGISTRARS = (shapes_cli.register, synth_cli.register, benchmark_commands.register)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="tactile-synth",
        description="Synthetic tactile data (MuJoCo) and the AFOP-ML few-shot tactile benchmark.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for register in _REGISTRARS:
        register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        if "threads" in args:  # the heavy commands: size every thread pool before the work
            configure_threads(args.threads)
        return int(args.handler(args) or 0)
    except (ValueError, FileExistsError, FileNotFoundError) as exc:
        # Bad input is the user's to fix: one line naming the problem, no traceback.
        print(f"tactile-synth {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"tactile-synth {args.command}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # Output piped into e.g. `head`: stop quietly like other command-line tools.
        sys.stderr.close()
        return 141


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
