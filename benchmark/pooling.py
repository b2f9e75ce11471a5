"""A protocol's records from its scored cells: accuracy per (task, method, cell), then
the summaries across folds and across force/speed conditions, then the fits' records."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import replace

import numpy as np

from models.stats import ci95

from .cells import Scored, TaskResults
from .labels import WITHIN_CONDITION, condition_reading
from .results import AccuracyRecord, Record
from .tasks import Task


def pool_folds(scored: Iterable[Scored]) -> list[AccuracyRecord]:
    """Across-fold summary records (``fold=None``), one per (protocol, condition, method,
    way, shot): mean and ``ci95 = 1.96 * std / sqrt(E)`` over the per-episode accuracies of
    all folds together. Timing fields are the mean over folds (latencies over the folds
    that measured them), ``feature_dim`` the median, ``query`` the smallest."""
    groups: dict[tuple, list[Scored]] = {}
    for s in scored:
        r = s.record
        groups.setdefault((r.protocol, r.condition, r.method, r.way, r.shot), []).append(s)
    return [_pooled(ss, fold=None) for ss in groups.values()]


def pool_conditions(scored: Iterable[Scored]) -> list[AccuracyRecord]:
    """Across-condition summary records, one per (protocol, fold, method, way, shot) and
    reading: the episodes of every force/speed condition together, summarised as
    :func:`pool_folds` summarises folds (with equal budgets, the mean of the conditions'
    accuracies). Plain per-condition records (each episode within one condition) give
    ``condition=WITHIN_CONDITION``; records of a named reading (``"enrolled:<condition>"``,
    :func:`benchmark.labels.condition_reading`) give ``condition=<reading>``."""
    groups: dict[tuple, list[Scored]] = {}
    for s in scored:
        r = s.record
        reading = condition_reading(r.condition)[0]
        groups.setdefault((r.protocol, r.fold, r.method, r.way, r.shot, reading), []).append(s)
    return [
        _pooled(ss, condition=WITHIN_CONDITION if key[-1] is None else key[-1])
        for key, ss in groups.items()
    ]


def _pooled(ss: Sequence[Scored], **labels: object) -> AccuracyRecord:
    """One summary record of ``ss`` (the first record's fields, with ``labels`` set)."""
    rs = [s.record for s in ss]
    acc = np.concatenate([s.accuracies for s in ss]).astype(np.float64)
    return replace(
        rs[0],
        **labels,
        episodes=int(acc.size),
        accuracy=float(acc.mean()),
        ci95=ci95(acc),
        query=int(min(r.query for r in rs)),
        pretrain_s=float(np.mean([r.pretrain_s for r in rs])),
        adapt_ms_per_episode=float(np.mean([r.adapt_ms_per_episode for r in rs])),
        latency_ms_per_episode=_mean_or_none([r.latency_ms_per_episode for r in rs]),
        latency_with_features_ms_per_episode=_mean_or_none(
            [r.latency_with_features_ms_per_episode for r in rs]
        ),
        latency_episodes=int(sum(r.latency_episodes for r in rs)),
        feature_dim=_median_or_none([r.feature_dim for r in rs]),
    )


def _mean_or_none(values: Sequence[float | None]) -> float | None:
    v = [x for x in values if x is not None]
    return float(np.mean(v)) if v else None


def _median_or_none(values: Sequence[int | None]) -> int | None:
    v = [x for x in values if x is not None]
    return int(np.median(v)) if v else None


def protocol_records(tasks: Sequence[Task], done: TaskResults) -> list[Record]:
    """The records of a protocol's tasks: accuracy per (task, method, cell), across-fold
    pooled accuracy when the tasks have folds (:func:`pool_folds`), across-condition
    accuracy when they test force/speed conditions, per reading (:func:`pool_conditions`;
    with one condition, the same figures as its own records), and the fits' records."""
    records: list[Record] = [s.record for s in done.scored]
    if any(t.fold is not None for t in tasks):
        records += pool_folds(s for s in done.scored if s.record.fold is not None)
    by_condition = [
        s
        for s in done.scored
        if s.record.fold is None and condition_reading(s.record.condition)[1] is not None
    ]
    if by_condition:
        records += pool_conditions(by_condition)
    return records + done.fits
