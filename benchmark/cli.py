"""The ``tactile-synth`` console script.

The CLI is thin: each package contributes its sub-commands through a
``register(subparsers)`` function in its own ``cli`` module, and every command
only parses arguments and calls library functions usable without the CLI.
Heavy imports (build123d, MuJoCo, torch) happen inside the command handlers so
``tactile-synth --help`` stays fast.

This module is also the error boundary: whatever a command raises reaches the user as
one line naming the argument or path at fault (``--debug`` shows the traceback).
"""

from __future__ import annotations

import argparse
import sys
import traceback
from collections.abc import Sequence

from benchmark import commands as benchmark_commands
from benchmark.twin import cli as twin_cli
from shapes import cli as shapes_cli
from synth import cli as synth_cli
from tactile_synth.threads import configure as configure_threads

_REGISTRARS = (
    shapes_cli.register,
    synth_cli.register,
    benchmark_commands.register,
    twin_cli.register,
)


def version_text() -> str:
    """``tactile-synth X (MuJoCo Y, zarr Z, Python P)``: what decides a dataset's bytes."""
    import platform

    from synth.store import versions

    v = versions()
    return (
        f"tactile-synth {v['package_version']} (MuJoCo {v['mujoco_version']}, "
        f"zarr {v['zarr_version']}, numpy {v['numpy_version']}, "
        f"Python {platform.python_version()})"
    )


class _VersionAction(argparse.Action):
    """``--version``: computed only when asked (it imports MuJoCo)."""

    def __init__(self, option_strings: Sequence[str], dest: str, **kw) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kw)

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        print(version_text())
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="tactile-synth",
        description="Synthetic tactile data (MuJoCo) and the AFOP-ML few-shot tactile benchmark.",
    )
    parser.add_argument(
        "--version", action=_VersionAction, help="print the tactile-synth and MuJoCo versions"
    )
    parser.add_argument(
        "--debug",
        action="store_true",
        help="show the full traceback when a command fails (accepted anywhere on the line)",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for register in _REGISTRARS:
        register(sub)
    return parser


def describe_error(exc: BaseException) -> tuple[str, int]:
    """``(one-line message, exit status)`` for an exception that ends a command.

    2: the input is at fault (a bad argument or path, a damaged or locked dataset);
    1: the work failed (physics, disk, memory, a plug-in's own code) or a bug (the
    message says to use --debug).
    """
    from models.registry import PluginError
    from synth import SimulationError
    from synth.store import DatasetIncomplete

    if isinstance(exc, DatasetIncomplete):  # the CLI's way to finish it, not the API's
        return exc.cli_message, 2
    if isinstance(exc, SimulationError):
        return f"the physics failed: {exc}", 1
    if isinstance(exc, PluginError):
        return f"{exc}; rerun with --debug for its traceback", 1
    if isinstance(exc, OSError) and exc.filename is not None and exc.strerror:
        where = f"{exc.filename}" + (f" -> {exc.filename2}" if exc.filename2 else "")
        return f"{exc.strerror}: {where}", 2 if _is_path_error(exc) else 1
    if isinstance(exc, ValueError | FileExistsError | FileNotFoundError | NotADirectoryError):
        return str(exc), 2
    if isinstance(exc, MemoryError):
        return f"out of memory ({exc or 'the allocation failed'}); ask for less", 1
    if isinstance(exc, OSError):
        return f"{exc.strerror or exc}", 1
    text = str(exc) or "no message"
    return (
        f"internal error ({type(exc).__name__}: {text}); rerun with --debug for the "
        "traceback and report it",
        1,
    )


def _is_path_error(exc: OSError) -> bool:
    return isinstance(
        exc,
        PermissionError
        | FileNotFoundError
        | FileExistsError
        | NotADirectoryError
        | IsADirectoryError,
    )


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    argv = [a for a in argv if a != "--debug"]
    args = parser.parse_args(argv)
    args.debug = debug
    args.argv = argv  # lets a command repeat itself in advice
    try:
        if "threads" in args:  # the heavy commands: size every thread pool before the work
            configure_threads(args.threads)
        return int(args.handler(args) or 0)
    except KeyboardInterrupt:
        print(f"tactile-synth {args.command}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # Output piped into e.g. `head`: stop quietly like other command-line tools.
        sys.stderr.close()
        return 141
    except Exception as exc:
        if args.debug:
            traceback.print_exc()
        message, status = describe_error(exc)
        message = " ".join(message.split())  # one line, whatever the message held
        print(f"tactile-synth {args.command}: error: {message}", file=sys.stderr)
        return status


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
