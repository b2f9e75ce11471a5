"""Small helpers for the simulator's frozen parameter dataclasses: range checks that name
the field, and a strict dict round trip (unknown or missing keys are errors, not ignored)."""

from __future__ import annotations

import dataclasses
import math
import typing
from collections.abc import Iterable, Mapping
from numbers import Real
from typing import Any, TypeVar

T = TypeVar("T")


def _value(obj: object, name: str) -> float:
    value = getattr(obj, name)
    where = f"{type(obj).__name__}.{name}"
    if isinstance(value, bool) or not isinstance(value, Real) or not math.isfinite(value):
        raise ValueError(f"{where} must be a finite number; got {value!r}")
    return float(value)


def positive(obj: object, *names: str) -> None:
    """Each named field must be a finite number > 0."""
    for name in names:
        if _value(obj, name) <= 0:
            raise ValueError(f"{type(obj).__name__}.{name} must be > 0; got {getattr(obj, name)!r}")


def non_negative(obj: object, *names: str) -> None:
    """Each named field must be a finite number >= 0."""
    for name in names:
        if _value(obj, name) < 0:
            raise ValueError(
                f"{type(obj).__name__}.{name} must be >= 0; got {getattr(obj, name)!r}"
            )


def below(obj: object, name: str, limit: float, why: str = "") -> None:
    """Field ``name`` must be < ``limit``."""
    if _value(obj, name) >= limit:
        extra = f" ({why})" if why else ""
        raise ValueError(
            f"{type(obj).__name__}.{name} must be < {limit:g}{extra}; got {getattr(obj, name)!r}"
        )


def to_dict(obj: object) -> Any:
    """Dataclass tree -> JSON-serialisable dict (tuples become lists, mappings stay dicts)."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: to_dict(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, Mapping):
        return {str(k): to_dict(v) for k, v in obj.items()}
    if isinstance(obj, tuple | list):
        return [to_dict(v) for v in obj]
    return obj


def from_dict(cls: type[T], data: object, where: str = "") -> T:
    """Inverse of :func:`to_dict` for a dataclass ``cls``; rejects unknown and missing keys."""
    where = where or cls.__name__
    if not isinstance(data, Mapping):
        raise ValueError(f"{where} must be a mapping; got {type(data).__name__}")
    hints = typing.get_type_hints(cls)
    names = [f.name for f in dataclasses.fields(cls)]  # type: ignore[arg-type]
    unknown = sorted(set(data) - set(names))
    if unknown:
        raise ValueError(f"{where}: unknown keys {unknown}; allowed: {', '.join(names)}")
    missing = sorted(set(names) - set(data))
    if missing:
        raise ValueError(f"{where}: missing keys {missing}")
    kwargs = {name: _convert(hints[name], data[name], f"{where}.{name}") for name in names}
    return cls(**kwargs)


def _convert(hint: Any, value: object, where: str) -> Any:
    origin = typing.get_origin(hint)
    args = typing.get_args(hint)
    if dataclasses.is_dataclass(hint):
        return from_dict(hint, value, where)
    if origin is tuple:
        if not isinstance(value, Iterable) or isinstance(value, str | Mapping):
            raise ValueError(f"{where} must be a list; got {value!r}")
        inner = args[0] if args else Any
        return tuple(_convert(inner, v, f"{where}[{i}]") for i, v in enumerate(value))
    if origin in (dict, Mapping) or hint is Mapping:
        if not isinstance(value, Mapping):
            raise ValueError(f"{where} must be a mapping; got {type(value).__name__}")
        inner = args[1] if len(args) == 2 else Any
        return {str(k): _convert(inner, v, f"{where}.{k}") for k, v in value.items()}
    if hint is float:
        if isinstance(value, bool) or not isinstance(value, Real):
            raise ValueError(f"{where} must be a number; got {value!r}")
        return float(value)
    if hint is bool:
        if not isinstance(value, bool):
            raise ValueError(f"{where} must be true or false; got {value!r}")
        return value
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ValueError(f"{where} must be an integer; got {value!r}")
        return value
    if hint is str and not isinstance(value, str):
        raise ValueError(f"{where} must be a string; got {value!r}")
    return value
