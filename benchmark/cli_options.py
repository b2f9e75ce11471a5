"""Options and messages the benchmark package's sub-commands share: the method list and
method options, and the command that continues an interrupted one."""

from __future__ import annotations

import argparse
import shlex
from collections.abc import Sequence

METHODS_HELP = (
    "methods to evaluate: the paper's methods ({builtin}), the variants beyond the paper "
    "({variants}), names of installed plug-ins (entry point group tactile_synth.methods), "
    "or module:Class / path/to/file.py:Class of a FewShotMethod subclass "
    "(docs/methods.md); default: {default}"
)
OPTION_HELP = (
    "METHOD:NAME=VALUE: build METHOD with its constructor option NAME set to VALUE (a "
    "JSON literal such as 10, 1e-3, true, or else text such as a path), e.g. "
    "CWT-ResNet-ML:weights=resnet18.pth to start CWT-ResNet-ML from a torchvision "
    "ResNet-18 state dict; repeatable (docs/methods.md)"
)


def methods_help(default: str) -> str:
    from models.registry import METHOD_NAMES, VARIANT_NAMES

    return METHODS_HELP.format(
        builtin=", ".join(METHOD_NAMES), variants=", ".join(VARIANT_NAMES), default=default
    )


def add_method_options(parser: argparse.ArgumentParser, default: str) -> None:
    """``--methods NAME ...`` (``default`` says what runs without it) and the repeatable
    ``--method-option METHOD:NAME=VALUE``, as every command that fits methods takes them."""
    parser.add_argument(
        "--methods", nargs="+", default=None, metavar="NAME", help=methods_help(default)
    )
    parser.add_argument(
        "--method-option",
        action="append",
        default=None,
        metavar="METHOD:NAME=VALUE",
        help=OPTION_HELP,
    )


def check_methods_arg(
    methods: list[str] | None, options: list[str] | None, default: Sequence[str]
) -> dict[str, dict[str, object]]:
    """Fail fast, naming --methods or --method-option, on a method that cannot be found
    or is no FewShotMethod, or an option it does not take (before any dataset is read or
    generated); returns the checked options. ``default``: the methods run without
    --methods."""
    from models.registry import check_methods, options_from_args

    chosen = default if methods is None else check_methods(methods, arg="--methods")
    return options_from_args(options, chosen)


def again_command(args: argparse.Namespace, fallback: list[str]) -> str:
    """The command line that continues an interrupted ``args``: the same one without
    --overwrite (the interrupted run marked its DIR; --overwrite would start the finished
    protocols over)."""
    argv = getattr(args, "argv", None) or fallback
    return shlex.join(a for a in argv if a != "--overwrite")
