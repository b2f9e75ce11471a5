"""Input checks shared by every package (this package is imported by all of them).

Errors name the argument, what is allowed and what was received, and unknown
names get a "did you mean" hint.
"""

from __future__ import annotations

import difflib
import math
import os
import tomllib
from collections.abc import Iterable
from numbers import Integral, Real
from typing import Any


def check_choice(arg: str, value: object, choices: Iterable[str]) -> str:
    """Return ``value`` if it is one of ``choices``; else raise ``ValueError``."""
    options = tuple(choices)
    if isinstance(value, str) and value in options:
        return value
    hint = ""
    if isinstance(value, str):
        close = difflib.get_close_matches(value, options, n=1)
        if close:
            hint = f" (did you mean {close[0]!r}?)"
    raise ValueError(f"{arg} must be one of {', '.join(options)}; got {value!r}{hint}")


def check_positive(arg: str, value: object, *, unit: str = "") -> float:
    """Return ``value`` as float if it is a finite number > 0; else raise ``ValueError``."""
    return _check_real(arg, value, zero_allowed=False, unit=unit)


def check_non_negative(arg: str, value: object) -> float:
    """Return ``value`` as float if it is a finite number >= 0; else raise ``ValueError``."""
    return _check_real(arg, value, zero_allowed=True, unit="")


def _check_real(arg: str, value: object, *, zero_allowed: bool, unit: str) -> float:
    bound = ">= 0" if zero_allowed else "> 0"
    suffix = f" {unit}" if unit else ""
    if isinstance(value, bool) or not isinstance(value, Real) or not math.isfinite(value):
        raise ValueError(f"{arg} must be a finite number {bound}{suffix}; got {value!r}")
    if value < 0 or (value == 0 and not zero_allowed):
        raise ValueError(f"{arg} must be {bound}{suffix}; got {value!r}")
    return float(value)


def check_int(arg: str, value: object, *, minimum: int | None = None) -> int:
    """Return ``value`` if it is an integer (>= ``minimum``); else raise ``ValueError``."""
    if isinstance(value, bool) or not isinstance(value, Integral):
        raise ValueError(f"{arg} must be an integer; got {value!r}")
    if minimum is not None and value < minimum:
        raise ValueError(f"{arg} must be >= {minimum}; got {value!r}")
    return int(value)


def parse_number(text: str, kind: type[int] | type[float] = float) -> Any:
    """``kind(text)`` (``int`` or ``float``) for a number as a person types it, with
    Python's digit-group underscores refused: ``int("1_000")`` and ``float("1_000")``
    accept them, but in a typed option or a CSV cell ``1_000`` is more likely a slip
    than a grouping. ``ValueError`` ``"'TEXT' is not a number"`` (``a whole number``
    for ``int``), saying what to write instead of an underscore; callers put the
    argument or column in front."""
    noun = "whole number" if kind is int else "number"
    if "_" in text:
        raise ValueError(
            f"{text!r} is not a {noun} (underscores are not accepted: write "
            f"{text.replace('_', '')!r} if that is the number meant)"
        )
    try:
        return kind(text)
    except ValueError:
        raise ValueError(f"{text!r} is not a {noun}") from None


def float_arg(text: str) -> float:
    """An argparse ``type=`` for a float option: :func:`parse_number`, whose refusal
    argparse reports naming the option."""
    return _arg(text, float)


def int_arg(text: str) -> int:
    """An argparse ``type=`` for an integer option (see :func:`float_arg`)."""
    return _arg(text, int)


def _arg(text: str, kind: type[int] | type[float]) -> Any:
    import argparse

    try:
        return parse_number(text, kind)
    except ValueError as exc:
        if "_" not in text:  # argparse's own wording for type=int / type=float
            raise argparse.ArgumentTypeError(f"invalid {kind.__name__} value: {text!r}") from None
        raise argparse.ArgumentTypeError(str(exc)) from None


def read_toml(path: str | os.PathLike, kind: str) -> dict[str, Any]:
    """The parsed TOML file at ``path``; a one-line ``ValueError`` naming the file if it is
    missing, unreadable or not TOML (``kind``, e.g. ``"an experiment file"``, says what a
    directory given in its place is not)."""
    file = str(path)
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise ValueError(f"{file}: no such file") from None
    except IsADirectoryError:
        raise ValueError(f"{file}: is a directory, not {kind}") from None
    except OSError as exc:
        raise ValueError(f"{file}: cannot be read ({exc.strerror})") from None
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{file}: not valid TOML: {' '.join(str(exc).split())}") from None
    except UnicodeDecodeError:
        raise ValueError(f"{file}: not valid TOML: not UTF-8 text") from None
