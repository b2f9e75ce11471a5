"""Compare the accuracy cells of two results.json files and print those that moved outside
their 95 % confidence interval.

    python3 scripts/compare_results.py A/results.json B/results.json

A is the reference. A cell is one ``accuracy`` record (protocol, fold, condition, method,
way, shot) or one ``stress`` record (protocol, family, severity, reading, method, way,
shot). It moved when B's accuracy lies outside A's 95 % interval, ``|acc_B - acc_A| >
ci95_A``. Where A's record carries no usable interval (null, or 0 because every episode
scored the same) the binomial interval of its queries stands in for it:
``1.96 * sqrt(p (1 - p) / n)`` with ``n = episodes * way * query`` queries and ``p`` the
accuracy pulled towards one half by one success and one failure
(``(acc * n + 1) / (n + 2)``), so that a perfect cell still has an interval. A cell present
in one file only is listed too. Exit status: 0 when no cell moved and both files hold the
same cells, 1 otherwise, 2 on a bad argument.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

from script_args import description, fail

from benchmark.results import read_results

#: Fields that name a cell, per record kind compared.
KEYS: dict[str, tuple[str, ...]] = {
    "accuracy": ("protocol", "fold", "condition", "method", "way", "shot"),
    "stress": ("protocol", "family", "severity", "reading", "method", "way", "shot"),
}


class Moved(NamedTuple):
    """A cell whose accuracy left the reference's interval: ``a``, ``b`` its accuracies
    (fractions), ``ci`` the reference's 95 % half-width used."""

    key: tuple[Any, ...]
    a: float
    b: float
    ci: float


def cell_key(record: Mapping[str, Any]) -> tuple[Any, ...]:
    """The cell a record scores: its kind, then the fields of :data:`KEYS`."""
    kind = record["record"]
    return (kind, *(record.get(k) for k in KEYS[kind]))


def interval(record: Mapping[str, Any]) -> float:
    """The 95 % half-width of a record's accuracy: its ``ci95`` when positive, else the
    binomial half-width of its queries (module docstring)."""
    ci = record.get("ci95")
    if ci is not None and math.isfinite(ci) and ci > 0:
        return float(ci)
    n = int(record["episodes"]) * int(record["way"]) * int(record["query"])
    if n < 1:
        return 0.0
    p = (float(record["accuracy"]) * n + 1) / (n + 2)
    return 1.96 * math.sqrt(p * (1 - p) / n)


def cells(records: Sequence[Mapping[str, Any]], path: str) -> dict[tuple[Any, ...], Mapping]:
    """The compared records of a file by cell; ValueError naming ``path`` for a cell that
    appears twice."""
    out: dict[tuple[Any, ...], Mapping] = {}
    for r in records:
        if r.get("record") not in KEYS or r.get("accuracy") is None:
            continue
        key = cell_key(r)
        if key in out:
            raise ValueError(f"{path} holds the cell {key} twice")
        out[key] = r
    return out


def compare(
    a: Sequence[Mapping[str, Any]], b: Sequence[Mapping[str, Any]], *, a_name="A", b_name="B"
) -> tuple[list[Moved], list[tuple[Any, ...]], list[tuple[Any, ...]]]:
    """(cells that moved, cells only in ``a``, cells only in ``b``), each sorted."""
    ca, cb = cells(a, a_name), cells(b, b_name)
    moved = []
    for key in sorted(ca.keys() & cb.keys(), key=repr):
        acc_a, acc_b = float(ca[key]["accuracy"]), float(cb[key]["accuracy"])
        ci = interval(ca[key])
        if abs(acc_b - acc_a) > ci:
            moved.append(Moved(key, acc_a, acc_b, ci))
    only_a = sorted(ca.keys() - cb.keys(), key=repr)
    only_b = sorted(cb.keys() - ca.keys(), key=repr)
    return moved, only_a, only_b


def _name(key: tuple[Any, ...]) -> str:
    kind, *values = key
    return " ".join(f"{k}={v}" for k, v in zip(KEYS[kind], values, strict=True) if v is not None)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=description(__doc__))
    parser.add_argument("a", metavar="A", help="the reference results.json")
    parser.add_argument("b", metavar="B", help="the results.json compared with it")
    args = parser.parse_args(argv)
    loaded = []
    for arg, path in (("A", args.a), ("B", args.b)):
        try:
            loaded.append(read_results(path))
        except (OSError, ValueError) as exc:
            fail(parser, f"{arg} {path}: {exc}")
    try:
        moved, only_a, only_b = compare(*loaded, a_name=args.a, b_name=args.b)
    except ValueError as exc:
        fail(parser, str(exc))
    shared = len(cells(loaded[0], args.a).keys() & cells(loaded[1], args.b).keys())
    for m in moved:
        print(
            f"moved: {_name(m.key)}: {100 * m.a:.2f} % -> {100 * m.b:.2f} % "
            f"({100 * (m.b - m.a):+.2f} pp, A's 95 % CI +-{100 * m.ci:.2f} pp)"
        )
    for key in only_a:
        print(f"only in A: {_name(key)}")
    for key in only_b:
        print(f"only in B: {_name(key)}")
    print(
        f"{shared} cells in both files, {len(moved)} moved outside A's 95 % CI; "
        f"{len(only_a)} only in A, {len(only_b)} only in B"
    )
    return 1 if moved or only_a or only_b else 0


if __name__ == "__main__":
    sys.exit(main())
