"""One fit: a method fitted once on a fit group's trials, evaluated on every cell of the
tasks it serves, and the records of what the fit exposes; its results as JSON (what a
worker process answers, and what a checkpoint holds).

The records of a fit come from the method's own hook,
:meth:`models.base.FewShotMethod.fit_details` (:func:`fit_records`): a method that
selects features reports them (a ``selection`` record with its PVDF/SG shares, and the
``dscan`` curve its size was chosen on), a meta-learner its validation curve (a
``meta_curve`` record). Plug-in methods report theirs the same way.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any, NamedTuple
from typing import Protocol as TypingProtocol

import numpy as np

from models import registry

from .cells import Features, Scored, TaskResults, evaluate_task
from .fit_groups import FitGroup
from .methods import make_method, plugin_stage
from .results import Record, dscan_record, from_dict, meta_curve_record, selection_record
from .tasks import Task

if TYPE_CHECKING:
    from tqdm.auto import tqdm

    from models.base import FewShotMethod


def fit_records(task: Task, name: str, method: FewShotMethod) -> list[Record]:
    """The records of what the fitted ``method`` (named ``name``) exposes
    (:meth:`models.base.FewShotMethod.fit_details`): its feature selection (D, PVDF/SG
    shares and indices of the selected features) and the D-scan D was chosen on, then its
    meta-training validation curve (``meta_gradient`` as the method states it). The
    interpretability analysis (:func:`benchmark.interpret.analyse`) reads the closed-set
    fit's selection and D-scan from these records, so it describes the very fit the
    protocols evaluated."""
    details = method.fit_details()
    out: list[Record] = []
    if details.selected is not None:
        from models.features import FEATURE_NAMES, sensor_shares

        pvdf, sg = sensor_shares(details.selected, FEATURE_NAMES)
        out.append(
            selection_record(
                protocol=task.protocol,
                fold=task.fold,
                D=len(details.selected),
                pvdf_share=pvdf,
                sg_share=sg,
                selected=list(details.selected),
            )
        )
    if details.dscan is not None:
        out.append(
            dscan_record(
                protocol=task.protocol,
                fold=task.fold,
                D=list(details.dscan.sizes),
                mean=list(details.dscan.mean),
                ci95=list(details.dscan.ci95),
            )
        )
    if details.meta_curve is not None:
        out.append(
            meta_curve_record(
                protocol=task.protocol,
                fold=task.fold,
                method=name,
                curve=details.meta_curve,
                meta_gradient=details.meta_gradient,
            )
        )
    return out


class FitResult(NamedTuple):
    """One method's fit on a :class:`benchmark.fit_groups.FitGroup`: the results of each
    of its shares, in the group's order."""

    shares: list[TaskResults]

    def to_obj(self) -> list[dict[str, Any]]:
        """The results as JSON-serialisable objects: the records as results.json holds
        them and the per-episode accuracies (floats written exactly), so
        :meth:`from_obj` gives back the very same figures."""
        return [
            {
                "scored": [
                    {"record": s.record.to_dict(), "accuracies": np.asarray(s.accuracies).tolist()}
                    for s in part.scored
                ],
                "fits": [r.to_dict() for r in part.fits],
            }
            for part in self.shares
        ]

    @classmethod
    def from_obj(cls, parts: list[dict[str, Any]]) -> FitResult:
        """The results :meth:`to_obj` gave (typed records)."""
        return cls(
            [
                TaskResults(
                    [
                        Scored(
                            from_dict(s["record"]),
                            np.asarray(s["accuracies"], dtype=np.float64),
                        )
                        for s in part["scored"]
                    ],
                    [from_dict(r) for r in part["fits"]],
                )
                for part in parts
            ]
        )

    def to_json(self) -> str:
        """:meth:`to_obj` as JSON text (a worker's answer)."""
        return json.dumps(self.to_obj())

    @classmethod
    def from_json(cls, text: str) -> FitResult:
        """The results :meth:`to_json` wrote."""
        return cls.from_obj(json.loads(text))


class FitCache(TypingProtocol):
    """Where :func:`benchmark.engine.run_task_sets` keeps each finished fit (one method on
    one :class:`benchmark.fit_groups.FitGroup`) and finds it again after an interruption."""

    def load(self, group: FitGroup, name: str) -> FitResult | None: ...

    def save(self, group: FitGroup, name: str, result: FitResult) -> None: ...


def run_fit(
    group: FitGroup,
    name: str,
    features: Features,
    *,
    bar: tqdm | None = None,
    on_fit: Callable[[Task, str, FewShotMethod], None] | None = None,
    options: Mapping[str, object] | None = None,
) -> FitResult:
    """Fit ``name`` once on the group's fit pool and evaluate every cell of the tasks of
    the shares that ask for ``name`` (the other shares get empty results); ``options``:
    the method's constructor options (``--method-option``)."""
    first = group.first
    fit = first.fit
    pool = features.of(fit.data)[fit.index]
    with plugin_stage(name, "fit"):
        method = make_method(name, seed=first.fit_seed, **(options or {}))
        t0 = time.perf_counter()
        method.fit(
            fit.data.signals[fit.index], fit.labels, features=pool, cells=tested_cells(group, name)
        )
        pretrain_s = time.perf_counter() - t0
    if on_fit is not None:
        on_fit(first, name, method)
    out = []
    for share in group.shares:
        if name not in share.methods:
            out.append(TaskResults([], []))
            continue
        head = share.tasks[0]
        fits = fit_records(head, name, method) if head.fit_records else []
        scored: list[Scored] = []
        for task in share.tasks:
            scored += evaluate_task(task, name, method, pretrain_s, features, bar)
        out.append(TaskResults(scored, fits))
    return FitResult(out)


def tested_cells(group: FitGroup, name: str) -> list[tuple[int, int]]:
    """The ``(way, shot)`` cells the fit of ``name`` on ``group`` is evaluated on, sorted:
    what the method is told of the protocol's design before it fits."""
    return sorted(
        {
            (cell.way, cell.shot)
            for share in group.shares
            if name in share.methods
            for task in share.tasks
            for cell in task.grid
        }
    )


def job_cost(group: FitGroup, name: str) -> float:
    """Rough CPU seconds of fitting ``name`` on ``group`` and evaluating its cells: the
    method class's ``cost_hint`` (fit seconds, seconds per 1000 cell-episodes) applied to
    the group's episodes; only used to order the queue of fits."""
    fit_s, eval_s = getattr(registry.method_class(name), "cost_hint", (1.0, 1.0))
    episodes = sum(
        len(task.grid) * task.episodes.of(name)
        for share in group.shares
        if name in share.methods
        for task in share.tasks
    )
    return float(fit_s) + float(eval_s) * episodes / 1000
