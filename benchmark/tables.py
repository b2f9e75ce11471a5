"""Markdown tables of results, the closed-set one laid out like the paper's Table I."""

from __future__ import annotations

from collections.abc import Callable, Sequence

from models.registry import paper_first

from .paper_reference import TABLE_ONE_COLUMNS
from .results import select

#: The heading of the rows of methods that are not the paper's (variants, plug-ins).
BEYOND_THE_PAPER = "Beyond the paper"


def markdown_table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    """A Markdown table as lines: header, separator, one line per row."""
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(row) + " |" for row in rows]
    return out


def method_rows(
    methods: Sequence[str], row: Callable[[str], Sequence[str] | None], width: int
) -> list[list[str]]:
    """Table rows of ``methods``: the paper's methods first in Table I's order, then, under
    a row headed :data:`BEYOND_THE_PAPER` (``width`` cells), the variants and any other
    methods (:func:`models.registry.paper_first`); ``row(method)`` gives a method's
    cells (None: no row)."""
    paper, beyond = paper_first(methods)
    rows = [list(r) for r in map(row, paper) if r is not None]
    others = [list(r) for r in map(row, beyond) if r is not None]
    if others:
        rows.append([f"**{BEYOND_THE_PAPER}**", *[""] * (width - 1)])
        rows += others
    return rows


def pct(record: dict | None) -> str:
    """``"87.20 ± 2.91"``: an accuracy record's mean and 95 % CI in %; ``-`` for None."""
    if record is None:
        return "-"
    return f"{100 * record['accuracy']:.2f} ± {100 * record['ci95']:.2f}"


def ms(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f}"


def episodes_note(records: Sequence[dict]) -> str:
    """The records' episode counts, ``"100"`` or ``"100/500"``; ``-`` when none."""
    eps = sorted({r["episodes"] for r in records})
    return "/".join(str(e) for e in eps) if eps else "-"


def table_one_lines(records: Sequence[dict], *, timing: bool = True) -> list[str]:
    """The closed-set table (records with ``condition=None``): accuracy (%, mean ± 95 % CI)
    per method and K-shot N-way column (Table I's columns first, then any others), then
    with ``timing`` the pretrain time (s) and, as Table I's "Adapt/episode", the
    single-episode latency of a 5-way-5-shot episode (ms, one episode at a time, features
    precomputed) and the same including the feature extraction, and last the episodes.
    The paper's methods come first in Table I's order, then the others under a "Beyond the
    paper" row (:func:`method_rows`). The batched throughput is not shown: it is a
    different measure (see the report's timing section). No lines when there are no
    closed-set records."""
    rs = select(records, "accuracy", protocol="closed-set", condition=None)
    if not rs:
        return []
    present = {(r["shot"], r["way"]) for r in rs}
    cols = [c for c in TABLE_ONE_COLUMNS if c in present]
    cols += sorted(present - set(cols))
    header = ["method", *[f"{k}-shot {n}-way" for k, n in cols]]
    if timing:
        header += ["pretrain (s)", "latency/episode 5w5s (ms)", "latency incl. features (ms)"]
    header.append("episodes")

    def row(m: str) -> list[str]:
        mine = [r for r in rs if r["method"] == m]
        cell = {(r["shot"], r["way"]): r for r in reversed(mine)}  # the first record wins
        out = [m, *[pct(cell.get(c)) for c in cols]]
        if timing:
            five = cell.get((5, 5))
            out += [
                f"{mine[0]['pretrain_s']:.2f}",
                ms(None if five is None else five.get("latency_ms_per_episode")),
                ms(None if five is None else five.get("latency_with_features_ms_per_episode")),
            ]
        return [*out, episodes_note(mine)]

    methods = list(dict.fromkeys(r["method"] for r in rs))
    return markdown_table(header, method_rows(methods, row, len(header)))


def table_one(records: Sequence[dict]) -> str:
    """``table1.md``: :func:`table_one_lines` with the timing columns, as text."""
    return "\n".join(table_one_lines(records)) + "\n"
