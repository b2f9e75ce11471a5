"""Input checks shared by every package (shapes is the leftmost package, so all may import it).

Errors name the argument, what is allowed and what was received, and unknown
names get a "did you mean" hint.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Iterable
from numbers import Integral, Real


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
    suffix = f" {unit}" if unit else ""
    if isinstance(value, bool) or not isinstance(value, Real) or not math.isfinite(value):
        raise ValueError(f"{arg} must be a finite number > 0{suffix}; got {value!r}")
    if value <= 0:
        raise ValueError(f"{arg} must be > 0{suffix}; got {value!r}")
    return float(value)


def check_int(arg: str, value: object, *, minimum: int | None = None) -> int:
    """Return ``value`` if it is an integer (>= ``minimum``); else raise ``ValueError``."""
    if isinstance(value, bool) or not isinstance(value, Integral):
        raise ValueError(f"{arg} must be an integer; got {value!r}")
    if minimum is not None and value < minimum:
        raise ValueError(f"{arg} must be >= {minimum}; got {value!r}")
    return int(value)
