"""The protocol engine: fit each method once per task, evaluate all the task's episodes.

A protocol (:class:`Protocol`) is only a generator of :class:`Task` objects from the
datasets. A task carries everything the engine needs: the trials methods are fitted on
and the trials episodes are drawn from (:class:`Pool`), its grid of N-way K-shot cells
(:class:`Cell`, each with its own episode seed), its episode budget, its fit seed and the
labels its records carry (protocol, fold, condition). :func:`run_tasks` fits every method
on a task's fit pool and adapts it to every cell's episodes in one batched
``predict_episodes`` call (:func:`benchmark.evaluate.evaluate`, which also times single
episodes when a cell asks for it); :func:`run_protocol` does this for one protocol and
returns typed records (:mod:`benchmark.results`): accuracy per cell, across-fold pooled
accuracy when the tasks have folds, across-condition accuracy when they test
force/speed conditions, and what each fit exposes (AFOP-ML's selection, a
meta-learner's validation curve).

The same episodes (same cell seeds) serve every method, and a method's fit seed is the
task's, so results do not depend on the order or subset of methods requested.

Cell rule: queries per class are :data:`N_QUERY`, fewer when the N-th most populous test
class is small (:func:`n_query_for`); episodes are drawn from the test trials of the
classes that can fill the cell (``shot + query`` trials); a cell no set of test classes
can fill is skipped. Consecutive tasks with the same ``fit_key`` share one fit (the
perturbation protocol fits once and tests on every force/speed condition).

Enrolment: a task may carry a separate ``support`` pool (:attr:`Task.support`). Its
episodes then draw their support examples from that pool and their queries from the
test pool, classes matched by name across the two datasets
(:func:`models.episodes.sample_split_episodes`): a class is enrolled in one setting
and recognised in another ("enrolled at nominal, recognised under perturbation"). A
class needs ``shot`` trials in the support pool and the cell's queries in the test pool;
the method sees one pool holding the episode trials of both.

This module imports no protocol: protocols import it.
"""

from __future__ import annotations

import json
import time
import zlib
from abc import ABC, abstractmethod
from collections.abc import Callable, Hashable, Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, replace
from typing import Any, ClassVar, NamedTuple
from typing import Protocol as TypingProtocol

import numpy as np
from tqdm.auto import tqdm

from models import registry
from models.base import FewShotMethod
from models.registry import MethodOptions
from models.stats import ci95
from synth import Dataset
from synth.presets import parse_condition
from tactile_synth.validation import check_int

from .budget import EpisodeBudget
from .episodes import EpisodeBatch, sample_episodes, sample_split_episodes
from .evaluate import evaluate
from .results import (
    AccuracyRecord,
    Record,
    accuracy_record,
    dscan_record,
    from_dict,
    meta_curve_record,
    selection_record,
)

#: Queries per class per episode (upper bound; lowered when a test pool is too small).
#: The paper does not state it; 5 keeps 36-way-5-shot episodes inside the 30 test trials
#: per class of the paper preset.
N_QUERY: int = 5


def child_seed(seed: int, *keys: int | str) -> int:
    """A 32-bit seed derived from ``seed`` and ``keys`` (strings hashed with CRC32)."""
    words = [seed] + [k if isinstance(k, int) else zlib.crc32(str(k).encode()) for k in keys]
    return int(np.random.SeedSequence(words).generate_state(1)[0])


def check_methods(methods: Sequence[str]) -> tuple[str, ...]:
    """Validate method names, plug-in names or ``module:Class`` specs (unknown names
    raise with the valid list, see :func:`models.registry.check_methods`); keep order."""
    return registry.check_methods(methods, arg="method")


def make_method(name: str, seed: int = 0, **options: object) -> FewShotMethod:
    """A new, unfitted method ``name`` built with ``seed`` and its constructor ``options``
    (:func:`models.registry.make_method`)."""
    return registry.make_method(name, seed=seed, **options)


@contextmanager
def plugin_stage(name: str, stage: str) -> Iterator[None]:
    """Run a ``stage`` (fit, predict) of method ``name``; an exception a plug-in method
    raises there becomes a :class:`models.registry.PluginError` naming the method as given
    on --methods and the stage (its exception the cause, for --debug's traceback), so
    that the user reads it as the plug-in's failure, not tactile-synth's. Built-in methods'
    exceptions, running out of memory and interrupts pass unchanged."""
    try:
        yield
    except (MemoryError, registry.PluginError):
        raise
    except Exception as exc:
        if registry.is_builtin(name):
            raise
        raise registry.PluginError(
            f"--methods {name}: the plug-in method failed in {stage}: "
            f"{type(exc).__name__}: {exc or 'no message'}"
        ) from exc


def n_query_for(labels: np.ndarray, n_way: int, k_shot: int = 1) -> int:
    """Queries per class: :data:`N_QUERY`, fewer if the N-th most populous class of the
    pool has fewer than ``k_shot + N_QUERY`` trials. 0 means N-way is impossible."""
    counts = np.sort(np.unique(labels, return_counts=True)[1])[::-1]
    if counts.size < n_way:
        return 0
    return int(max(0, min(N_QUERY, counts[n_way - 1] - k_shot)))


class Features:
    """The raw 386-feature pool of each dataset a run uses, extracted once on first use.

    ``Features([(data, pool)])`` starts with precomputed pools (``(len(data), 386)``).
    """

    def __init__(self, known: Iterable[tuple[Dataset, np.ndarray]] = ()) -> None:
        self._pools: dict[int, tuple[Dataset, np.ndarray]] = {}
        for data, pool in known:
            pool = np.asarray(pool)
            if pool.ndim != 2 or pool.shape[0] != len(data):
                raise ValueError(
                    f"features must have shape ({len(data)}, n_features); got {pool.shape}"
                )
            self._pools[id(data)] = (data, pool)

    def of(self, data: Dataset) -> np.ndarray:
        """The feature pool ``(n, 386)`` of every trial of ``data``."""
        hit = self._pools.get(id(data))
        if hit is None:
            from models.features import extract

            hit = (data, extract(data.signals))
            self._pools[id(data)] = hit  # the dataset is kept, so its id stays its own
        return hit[1]


@dataclass(frozen=True)
class Pool:
    """Trials ``index`` (int ``(n,)``) of dataset ``data``."""

    data: Dataset
    index: np.ndarray

    def __post_init__(self) -> None:
        idx = np.asarray(self.index)
        if idx.ndim != 1 or idx.size == 0 or not np.issubdtype(idx.dtype, np.integer):
            raise ValueError(f"a pool needs a non-empty 1-D integer index; got {idx.shape}")
        object.__setattr__(self, "index", idx.astype(np.intp, copy=False))

    @property
    def labels(self) -> np.ndarray:
        return self.data.label[self.index]


@dataclass(frozen=True)
class Cell:
    """One N-way K-shot point of a task's grid: ``seed`` draws its episodes, and the first
    ``latency_episodes`` of them are also adapted one at a time (single-episode latency,
    see :mod:`benchmark.evaluate`)."""

    way: int
    shot: int
    seed: int
    latency_episodes: int = 0


@dataclass(frozen=True)
class Task:
    """One fit/test task of a protocol.

    protocol, fold, condition: the names its records carry; fit / test: the trials the
    methods are fitted on / the episodes are drawn from; grid: the cells evaluated;
    episodes: episodes per cell (per method); fit_seed: the seed each method is built
    with; fit_key: consecutive tasks with the same non-None key share the first one's fit;
    methods: the methods of this task whatever the run requests (None: the requested
    ones); fit_records: whether its fits give selection / meta-curve records; support:
    the enrolment pool the episodes' support examples are drawn from (queries from
    ``test``, classes matched by name; None: support and queries both from ``test``).
    """

    protocol: str
    fold: int | str | None
    condition: str | None
    fit: Pool
    test: Pool
    grid: tuple[Cell, ...]
    episodes: EpisodeBudget
    fit_seed: int
    fit_key: Hashable | None = None
    methods: tuple[str, ...] | None = None
    fit_records: bool = True
    support: Pool | None = None

    @property
    def name(self) -> str:
        """Fold or condition, for progress bars."""
        return str(self.fold) if self.fold is not None else str(self.condition or "")


class Scored(NamedTuple):
    """An accuracy record with the per-episode accuracies ``(E,)`` behind it."""

    record: AccuracyRecord
    accuracies: np.ndarray


class TaskResults(NamedTuple):
    """What :func:`run_tasks` returns: scored cells and the records of the fits."""

    scored: list[Scored]
    fits: list[Record]


def feature_dim(method: FewShotMethod) -> int | None:
    """Width of the embedding the method's prototypes live in, if it exposes one:
    ``feature_dim_`` when set (AFO-MLP-ML: its 32-wide projection, Direct-Prot-ML: 386),
    else ``D_`` (AFOP-ML: the top-D features)."""
    for attr in ("feature_dim_", "D_"):
        value = getattr(method, attr, None)
        if value is not None:
            return int(value)
    return None


def fit_records(task: Task, name: str, method: FewShotMethod) -> list[Record]:
    """Records of what a fitted method exposes: AFOP-ML's selection (chosen D, PVDF/SG
    shares and indices of its top-D features) and its D-scan (the validation curve D was
    chosen on) and, for any method with ``meta_curve_``, its meta-training validation
    curve (``meta_gradient`` as the method states it). The interpretability analysis
    (:func:`benchmark.interpret.analyse`) reads the closed-set fit's selection and D-scan
    from these records, so it describes the very fit the protocols evaluated."""
    out: list[Record] = []
    if name == "AFOP-ML" and getattr(method, "selected_", None) is not None:
        from models.features import FEATURE_NAMES

        from .interpret import sensor_shares

        pvdf, sg = sensor_shares(method.selected_, FEATURE_NAMES)
        out.append(
            selection_record(
                protocol=task.protocol,
                fold=task.fold,
                D=int(method.D_),
                pvdf_share=pvdf,
                sg_share=sg,
                selected=np.asarray(method.selected_).tolist(),
            )
        )
        scan = getattr(method, "dscan_", None)
        if scan is not None:
            out.append(
                dscan_record(
                    protocol=task.protocol,
                    fold=task.fold,
                    D=np.asarray(scan["D"]).tolist(),
                    mean=np.asarray(scan["mean"]).tolist(),
                    ci95=np.asarray(scan["ci95"]).tolist(),
                )
            )
    curve = getattr(method, "meta_curve_", None)
    if curve is not None:
        out.append(
            meta_curve_record(
                protocol=task.protocol,
                fold=task.fold,
                method=name,
                curve=curve,
                meta_gradient=getattr(method, "meta_gradient", None),
            )
        )
    return out


def _cell_rows(labels: np.ndarray, cell: Cell) -> tuple[int, np.ndarray | None]:
    """Queries per class of ``cell`` on a test pool with ``labels`` (0: impossible) and
    the rows of the classes that can fill it (None: every row)."""
    q = n_query_for(labels, cell.way, cell.shot)
    classes, counts = np.unique(labels, return_counts=True)
    ok = classes[counts >= cell.shot + q]
    if q < 1 or ok.size < cell.way:
        return 0, None
    if ok.size == classes.size:
        return q, None
    return q, np.flatnonzero(np.isin(labels, ok))


def _fit_groups(tasks: Sequence[Task]) -> list[list[Task]]:
    groups: list[list[Task]] = []
    for task in tasks:
        prev = groups[-1][0] if groups else None
        if prev is not None and task.fit_key is not None and task.fit_key == prev.fit_key:
            if task.fit_seed != prev.fit_seed or task.methods != prev.methods:
                raise ValueError(
                    f"tasks sharing fit_key {task.fit_key!r} differ in fit_seed or methods"
                )
            groups[-1].append(task)
        else:
            groups.append([task])
    return groups


@dataclass(frozen=True)
class Share:
    """The tasks of task set ``set_index`` that one fit serves, for each of ``methods``."""

    set_index: int
    tasks: tuple[Task, ...]
    methods: tuple[str, ...]


@dataclass(frozen=True)
class FitGroup:
    """Tasks, of one or several task sets, that one fit of each of ``methods`` serves
    (each share's tasks for the share's own methods, a subset of ``methods``)."""

    shares: tuple[Share, ...]
    methods: tuple[str, ...]

    @property
    def first(self) -> Task:
        return self.shares[0].tasks[0]

    def cells_of(self, name: str) -> int:
        """The cells the fit of method ``name`` is evaluated on."""
        return sum(
            len(t.grid) for share in self.shares if name in share.methods for t in share.tasks
        )


def _same_fit(a: Task, b: Task) -> bool:
    """Whether tasks of different sets may share a fit: the same non-None ``fit_key`` and
    fit seed, and the very same fit trials."""
    return (
        a.fit_key is not None
        and a.fit_key == b.fit_key
        and a.fit_seed == b.fit_seed
        and a.fit.data is b.fit.data
        and np.array_equal(a.fit.index, b.fit.index)
    )


def plan_fits(
    task_sets: Sequence[Sequence[Task]], methods: Sequence[str]
) -> tuple[list[FitGroup], list[list[int]]]:
    """The fits that ``task_sets`` need: ``(groups, order)``, where ``order[i]`` lists the
    groups serving set ``i`` in that set's own order.

    Within a set, consecutive tasks with the same ``fit_key`` share a fit; across sets,
    groups with the same ``fit_key``, fit seed and fit trials share one too, each method
    fitted once for every set that asks for it (the perturbation protocol tests the
    closed-set fit on every force/speed condition, the closed-set reference curve is the
    closed-set AFOP-ML fit's).
    """
    methods = check_methods(methods)
    groups: list[FitGroup] = []
    order: list[list[int]] = []
    for i, tasks in enumerate(task_sets):
        order.append([])
        for members in _fit_groups(tasks):
            head = members[0]
            chosen = methods if head.methods is None else check_methods(head.methods)
            share = Share(i, tuple(members), chosen)
            for g, group in enumerate(groups):
                if _same_fit(group.first, head):
                    union = (*group.methods, *(m for m in chosen if m not in group.methods))
                    groups[g] = FitGroup((*group.shares, share), union)
                    order[i].append(g)
                    break
            else:
                groups.append(FitGroup((share,), chosen))
                order[i].append(len(groups) - 1)
    return groups, order


class SetResults(NamedTuple):
    """What :func:`run_task_sets` returns: each set's results, and the processes its fits
    ran in (1: this process; 0: there was nothing to fit)."""

    sets: list[TaskResults]
    processes: int


def fit_processes(workers: int, fits: int) -> int:
    """Processes ``fits`` fits run in when ``workers`` are allowed: no more than there
    are fits (1: this process)."""
    return max(1, min(workers, fits))


class FitResult(NamedTuple):
    """One method's fit on a :class:`FitGroup`: the results of each of its shares, in
    the group's order."""

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
    """Where :func:`run_task_sets` keeps each finished fit (one method on one
    :class:`FitGroup`) and finds it again after an interruption."""

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
        method.fit(fit.data.signals[fit.index], fit.labels, features=pool)
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
            scored += _evaluate_task(task, name, method, pretrain_s, features, bar)
        out.append(TaskResults(scored, fits))
    return FitResult(out)


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


def run_task_sets(
    task_sets: Sequence[Sequence[Task]],
    methods: Sequence[str],
    *,
    features: Features | None = None,
    progress: bool = False,
    on_fit: Callable[[Task, str, FewShotMethod], None] | None = None,
    workers: int = 1,
    threads: int | None = None,
    on_done: Callable[[int, TaskResults], None] | None = None,
    fit_cache: FitCache | None = None,
    options: MethodOptions | None = None,
) -> SetResults:
    """Run several sets of tasks (a protocol's each) through one queue of fits: every
    method fitted once per fit group (:func:`plan_fits`), every cell of every task
    evaluated. Returns each set's results in task-set order, and calls ``on_done(i,
    results)`` as soon as set ``i`` is complete (a run checkpoints it there).

    workers: processes the fits may run in (:func:`fit_processes`; 1: this process, in
    order; more: see :mod:`benchmark.workers`, each with ``threads`` threads, by default
    its share of the CPUs). A set's results, and their order (task, method, cell), do not
    depend on ``workers``; their bits depend on the threads each fit ran with.
    on_fit(task, method name, fitted): called after each fit (one process only).
    fit_cache: each fit's results are saved there as soon as it finishes, and a fit
    found there is not run again (nor passed to ``on_fit``): an interrupted run loses
    only the fits that were running. options: constructor options per method name
    (``--method-option``; :func:`models.registry.check_method_options` checks them).
    """
    check_int("workers", workers, minimum=1)
    options = dict(options or {})
    features = features or Features()
    groups, order = plan_fits(task_sets, methods)
    jobs = [(g, name) for g, group in enumerate(groups) for name in group.methods]

    def share_of(g: int, i: int) -> int:
        return next(k for k, share in enumerate(groups[g].shares) if share.set_index == i)

    left = [
        sum(len(groups[g].shares[share_of(g, i)].methods) for g in set_order)
        for i, set_order in enumerate(order)
    ]
    done: dict[tuple[int, str], FitResult] = {}
    results: list[TaskResults | None] = [None] * len(task_sets)

    def assemble(i: int) -> TaskResults:
        scored: list[Scored] = []
        fits: list[Record] = []
        for g in order[i]:
            at = share_of(g, i)
            for name in groups[g].shares[at].methods:
                part = done[(g, name)].shares[at]
                scored += part.scored
                fits += part.fits
        return TaskResults(scored, fits)

    def finished(job: tuple[int, str], result: FitResult) -> None:
        done[job] = result
        for share in groups[job[0]].shares:
            if job[1] not in share.methods:
                continue
            i = share.set_index
            left[i] -= 1
            if left[i] == 0:
                results[i] = assemble(i)
                if on_done is not None:
                    on_done(i, results[i])

    for i, n in enumerate(left):  # a set without tasks is done at once
        if n == 0:
            results[i] = TaskResults([], [])
            if on_done is not None:
                on_done(i, results[i])

    total = sum(groups[g].cells_of(name) for g, name in jobs)
    desc = task_sets[0][0].protocol if len(task_sets) == 1 and task_sets[0] else "benchmark"
    # disable=None: quiet when stderr is not a TTY.
    bar = tqdm(total=total, desc=desc, disable=None if progress else True, leave=False)
    todo = []
    for g, name in jobs:
        cached = None if fit_cache is None else fit_cache.load(groups[g], name)
        if cached is None:
            todo.append((g, name))
        else:
            finished((g, name), cached)
            bar.update(groups[g].cells_of(name))

    def keep(job: tuple[int, str], result: FitResult) -> None:
        if fit_cache is not None:
            fit_cache.save(groups[job[0]], job[1], result)
        finished(job, result)

    processes = fit_processes(workers, len(todo)) if todo else 0
    if processes > 1:
        # The costliest jobs first, so that the last ones to finish are short (a worker
        # idles once the queue is empty); the order changes no result.
        todo.sort(key=lambda job: -job_cost(groups[job[0]], job[1]))
    try:
        if processes <= 1:
            for g, name in todo:
                result = run_fit(
                    groups[g], name, features, bar=bar, on_fit=on_fit, options=options.get(name)
                )
                keep((g, name), result)
        else:
            if on_fit is not None:
                raise ValueError("on_fit needs the fits in this process: use workers=1")
            from .workers import run_fits

            for (g, name), result in run_fits(
                groups, todo, features, workers=processes, threads=threads, options=options
            ):
                keep((g, name), result)
                bar.set_postfix_str(f"{name} {groups[g].first.protocol} {groups[g].first.name}")
                bar.update(groups[g].cells_of(name))
    finally:
        bar.close()
    return SetResults(results, processes)  # type: ignore[arg-type]  # every set is complete


def run_tasks(
    tasks: Sequence[Task],
    methods: Sequence[str],
    *,
    features: Features | None = None,
    progress: bool = False,
    on_fit: Callable[[Task, str, FewShotMethod], None] | None = None,
    workers: int = 1,
    threads: int | None = None,
    options: MethodOptions | None = None,
) -> TaskResults:
    """Fit every method once per task (or fit group) and evaluate every cell of its grid
    (:func:`run_task_sets` for one set of tasks).

    features: the feature pools (extracted on first use when not given); on_fit(task,
    method name, fitted): called after each fit. Results come in task, method, cell order.
    """
    return run_task_sets(
        [tasks],
        methods,
        features=features,
        progress=progress,
        on_fit=on_fit,
        workers=workers,
        threads=threads,
        options=options,
    ).sets[0]


class CellEpisodes(NamedTuple):
    """The episodes of one cell and the pool they index: its trials' signals, labels and
    feature rows; ``query`` is the queries per class."""

    signals: np.ndarray
    features: np.ndarray
    batch: EpisodeBatch
    query: int


def _test_episodes(
    task: Task, cell: Cell, episodes: int, features: Features
) -> CellEpisodes | None:
    """The cell's episodes on the test pool (None when no set of classes can fill it)."""
    test = task.test
    labels = test.labels
    q, rows = _cell_rows(labels, cell)
    if q < 1:
        return None
    index = test.index if rows is None else test.index[rows]
    lab = labels if rows is None else labels[rows]
    batch = sample_episodes(
        lab, n_way=cell.way, k_shot=cell.shot, n_query=q, episodes=episodes, seed=cell.seed
    )
    return CellEpisodes(test.data.signals[index], features.of(test.data)[index], batch, q)


def _enrolment_episodes(
    task: Task, cell: Cell, episodes: int, features: Features
) -> CellEpisodes | None:
    """The cell's episodes with their support from ``task.support`` and their queries
    from ``task.test`` (classes matched by name): indices into one pool that holds the
    eligible classes' support-pool trials, then their test-pool trials. None when fewer
    than ``way`` classes have ``shot`` support-pool trials and a query."""
    sup, test = task.support, task.test
    assert sup is not None
    names_s = np.asarray(sup.data.classes)[sup.labels]
    names_t = np.asarray(test.data.classes)[test.labels]
    shared = np.intersect1d(names_s, names_t)
    classes_s, counts_s = np.unique(names_s, return_counts=True)
    enrolled = np.intersect1d(shared, classes_s[counts_s >= cell.shot])
    in_t = np.isin(names_t, enrolled)
    q = n_query_for(names_t[in_t], cell.way, 0) if in_t.any() else 0
    if q < 1:
        return None
    classes_t, counts_t = np.unique(names_t[in_t], return_counts=True)
    usable = classes_t[counts_t >= q]
    rows_s = np.flatnonzero(np.isin(names_s, usable))
    rows_t = np.flatnonzero(np.isin(names_t, usable))
    ids = {name: i for i, name in enumerate(usable)}
    batch = sample_split_episodes(
        np.array([ids[n] for n in names_s[rows_s]]),
        np.array([ids[n] for n in names_t[rows_t]]),
        n_way=cell.way,
        k_shot=cell.shot,
        n_query=q,
        episodes=episodes,
        seed=cell.seed,
    )
    index_s, index_t = sup.index[rows_s], test.index[rows_t]
    signals = np.concatenate([sup.data.signals[index_s], test.data.signals[index_t]])
    feats = np.concatenate([features.of(sup.data)[index_s], features.of(test.data)[index_t]])
    return CellEpisodes(signals, feats, batch, q)


def _evaluate_task(
    task: Task,
    name: str,
    method: FewShotMethod,
    pretrain_s: float,
    features: Features,
    bar: tqdm | None,
) -> list[Scored]:
    n_ep = task.episodes.of(name)
    draw = _test_episodes if task.support is None else _enrolment_episodes
    out: list[Scored] = []
    for cell in task.grid:
        if bar is not None:
            bar.set_postfix_str(f"{name} {task.name} {cell.shot}-shot {cell.way}-way")
        cell_episodes = draw(task, cell, n_ep, features)
        if cell_episodes is None:
            if bar is not None:
                bar.update(1)
            continue
        sig, f, batch, q = cell_episodes
        with plugin_stage(name, "predict"):
            result = evaluate(
                method, sig, batch, features=f, latency_episodes=cell.latency_episodes
            )
        rec = accuracy_record(
            protocol=task.protocol,
            fold=task.fold,
            condition=task.condition,
            method=name,
            way=cell.way,
            shot=cell.shot,
            query=q,
            result=result,
            pretrain_s=pretrain_s,
            feature_dim=feature_dim(method),
        )
        out.append(Scored(rec, np.asarray(result.accuracies)))
        if bar is not None:
            bar.update(1)
    return out


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


#: ``condition`` of the across-condition summary records (:func:`pool_conditions`).
WITHIN_CONDITION = "within-condition"
#: Separates a reading's name from a force/speed condition in a record's ``condition``
#: (``"enrolled:force=1.4N,speed=6mm/s"``: the ``enrolled`` reading of that condition).
READING_SEPARATOR = ":"


def condition_reading(condition: str | None) -> tuple[str | None, tuple[float, float] | None]:
    """``(reading, (force_n, speed_mm_s))`` of a record's ``condition``: ``(None, (1.4,
    6.0))`` for ``"force=1.4N,speed=6mm/s"``, ``("enrolled", (1.4, 6.0))`` for
    ``"enrolled:force=1.4N,speed=6mm/s"``; ``(None, None)`` for any other condition."""
    text = condition or ""
    reading, sep, rest = text.rpartition(READING_SEPARATOR)
    fs = parse_condition(rest if sep else text)
    if fs is None:
        return None, None
    return (reading or None) if sep else None, fs


def pool_conditions(scored: Iterable[Scored]) -> list[AccuracyRecord]:
    """Across-condition summary records, one per (protocol, fold, method, way, shot) and
    reading: the episodes of every force/speed condition together, summarised as
    :func:`pool_folds` summarises folds (with equal budgets, the mean of the conditions'
    accuracies). Plain per-condition records (each episode within one condition) give
    ``condition=WITHIN_CONDITION``; records of a named reading (``"enrolled:<condition>"``,
    :func:`condition_reading`) give ``condition=<reading>``."""
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


class Protocol(ABC):
    """An evaluation protocol: a name and a generator of tasks from the datasets.

    Subclasses set ``name`` (the ``protocol`` field of their records and the name on the
    command line) and implement :meth:`tasks`; ``needs_perturbed`` says that the
    perturbation dataset is required, ``uses_reference`` that its curves are read
    against the closed-set reference curve (``benchmark`` then runs that too).
    """

    name: ClassVar[str]
    needs_perturbed: ClassVar[bool] = False
    uses_reference: ClassVar[bool] = False

    @abstractmethod
    def tasks(
        self, data: Dataset, perturbed: Dataset | None, *, seed: int, episodes: EpisodeBudget
    ) -> Iterable[Task]:
        """The protocol's tasks on nominal ``data`` (and ``perturbed``, when it needs it)."""


def protocol_tasks(
    protocol: Protocol,
    data: Dataset,
    perturbed: Dataset | None = None,
    *,
    episodes: EpisodeBudget | int,
    seed: int = 0,
) -> list[Task]:
    """``protocol``'s tasks on the datasets, its arguments checked."""
    if not isinstance(protocol, Protocol):
        raise ValueError(f"protocol must be a Protocol instance; got {protocol!r}")
    check_int("seed", seed, minimum=0)
    if isinstance(episodes, int):
        episodes = EpisodeBudget(check_int("episodes", episodes, minimum=1))
    if protocol.needs_perturbed and perturbed is None:
        raise ValueError(
            f"the {protocol.name} protocol needs perturbed= (the perturbation dataset)"
        )
    tasks = list(protocol.tasks(data, perturbed, seed=seed, episodes=episodes))
    if not tasks:
        raise ValueError(f"the {protocol.name} protocol made no task from these datasets")
    return tasks


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


def run_protocol(
    protocol: Protocol,
    data: Dataset,
    perturbed: Dataset | None = None,
    *,
    methods: Sequence[str],
    episodes: EpisodeBudget | int,
    seed: int = 0,
    progress: bool = False,
    features: Features | None = None,
    on_fit: Callable[[Task, str, FewShotMethod], None] | None = None,
    workers: int = 1,
    threads: int | None = None,
    options: MethodOptions | None = None,
) -> list[Record]:
    """All records of ``protocol`` (:func:`protocol_records`); ``workers``, ``threads``
    and ``options`` as in :func:`run_task_sets`."""
    methods = check_methods(methods)
    tasks = protocol_tasks(protocol, data, perturbed, episodes=episodes, seed=seed)
    done = run_tasks(
        tasks,
        methods,
        features=features,
        progress=progress,
        on_fit=on_fit,
        workers=workers,
        threads=threads,
        options=options,
    )
    return protocol_records(tasks, done)
