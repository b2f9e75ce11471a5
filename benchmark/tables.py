"""Markdown tables of results laid out like the paper's Table I."""

from __future__ import annotations

from collections.abc import Sequence

from .paper_reference import TABLE_ONE_COLUMNS
from .results import select


def table_one(records: Sequence[dict]) -> str:
    """Closed-set accuracy (%, mean ± 95% CI) per method and (shot, way) column, then the
    pretrain time (s) and, as Table I's "Adapt/episode", the single-episode latency of a
    5-way-5-shot episode (ms, one episode at a time, features precomputed), and the same
    including the feature extraction. The batched throughput is not shown here: it is a
    different measure (see the report's timing section)."""
    rs = select(records, "accuracy", protocol="closed-set", condition=None)
    methods = list(dict.fromkeys(r["method"] for r in rs))
    cols = [c for c in TABLE_ONE_COLUMNS if any((r["shot"], r["way"]) == c for r in rs)]
    header = [
        "method",
        *[f"{k}-shot {n}-way" for k, n in cols],
        "pretrain (s)",
        "latency/episode 5w5s (ms)",
        "latency incl. features (ms)",
        "episodes",
    ]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for m in methods:
        mine = [r for r in rs if r["method"] == m]
        cells = []
        for k, n in cols:
            r = next((x for x in mine if (x["shot"], x["way"]) == (k, n)), None)
            cells.append("-" if r is None else f"{100 * r['accuracy']:.2f} ± {100 * r['ci95']:.2f}")
        five = next((x for x in mine if (x["shot"], x["way"]) == (5, 5)), None)
        pretrain = f"{mine[0]['pretrain_s']:.2f}" if mine else "-"
        lat = _ms(None if five is None else five.get("latency_ms_per_episode"))
        lat_f = _ms(None if five is None else five.get("latency_with_features_ms_per_episode"))
        episodes = "/".join(str(e) for e in sorted({x["episodes"] for x in mine}))
        lines.append("| " + " | ".join([m, *cells, pretrain, lat, lat_f, episodes]) + " |")
    return "\n".join(lines) + "\n"


def _ms(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f}"
