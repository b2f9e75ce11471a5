"""The protocol engine: fit each method once per task, evaluate all the task's episodes.

A protocol (:class:`benchmark.tasks.Protocol`) turns the datasets into tasks
(:class:`benchmark.tasks.Task`); :func:`run_tasks` fits every method on a task's fit
pool and adapts it to every cell's episodes in one batched ``predict_episodes`` call
(:mod:`benchmark.cells`); :func:`run_protocol` does this for one protocol and returns
typed records (:mod:`benchmark.results`): accuracy per cell, across-fold pooled accuracy
when the tasks have folds, across-condition accuracy when they test force/speed
conditions (:mod:`benchmark.pooling`), and what each fit exposes (:mod:`benchmark.fits`).

The same episodes (same cell seeds) serve every method, and a method's fit seed is the
task's, so results do not depend on the order or subset of methods requested. Fits are
shared between tasks as :mod:`benchmark.fit_groups` plans them.

Where the fits run is the caller's choice: by default in this process, in order; or an
executor (:class:`FitExecutor`) runs them elsewhere, such as the worker processes of
:class:`benchmark.workers.ProcessPool`. This module imports neither an executor nor a
protocol: protocols and executors import it.

Examples
--------
>>> from benchmark.protocols import get
>>> from tests.synthetic_data import make_dataset
>>> data = make_dataset(trials_per_class=4, n_samples=200, noise=0.2)
>>> records = run_protocol(get("cross-material"), data, methods=["Direct-Prot-ML"],
...                        episodes=5, seed=0)
>>> sorted({r["fold"] for r in records if r["record"] == "accuracy"}, key=str)
[None, 'aluminum', 'resin', 'wood']
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from typing import TYPE_CHECKING, NamedTuple
from typing import Protocol as TypingProtocol

from tqdm.auto import tqdm

from tactile_synth.validation import check_int

from .budget import EpisodeBudget
from .cells import Features, Scored, TaskResults
from .fit_groups import FitGroup, plan_fits
from .fits import FitCache, FitResult, run_fit
from .labels import READING_SEPARATOR, WITHIN_CONDITION, condition_reading
from .methods import check_methods
from .pooling import pool_conditions, pool_folds, protocol_records
from .results import Record
from .tasks import N_QUERY, Cell, Pool, Protocol, Task, child_seed, n_query_for

if TYPE_CHECKING:
    from models.base import FewShotMethod
    from models.registry import MethodOptions
    from synth import Dataset

__all__ = [
    "N_QUERY",
    "READING_SEPARATOR",
    "WITHIN_CONDITION",
    "Cell",
    "Features",
    "FitCache",
    "FitExecutor",
    "FitGroup",
    "FitResult",
    "Pool",
    "Protocol",
    "Scored",
    "SetResults",
    "Task",
    "TaskResults",
    "check_methods",
    "child_seed",
    "condition_reading",
    "n_query_for",
    "plan_fits",
    "pool_conditions",
    "pool_folds",
    "protocol_records",
    "protocol_tasks",
    "run_fit",
    "run_protocol",
    "run_task_sets",
    "run_tasks",
]


class FitExecutor(TypingProtocol):
    """Where :func:`run_task_sets` runs the fits it has to run, when not in this process
    (:class:`benchmark.workers.ProcessPool` runs them in worker processes)."""

    def processes(self, fits: int) -> int:
        """The processes ``fits`` fits would run in (1: this process, in order)."""
        ...

    def run(
        self,
        groups: Sequence[FitGroup],
        jobs: Sequence[tuple[int, str]],
        features: Features,
        *,
        options: MethodOptions,
    ) -> Iterator[tuple[tuple[int, str], FitResult]]:
        """Run ``jobs`` (group index, method name), each method built with its
        ``options``; yield each job's result as it finishes."""
        ...


class SetResults(NamedTuple):
    """What :func:`run_task_sets` returns: each set's results, and the processes its fits
    ran in (1: this process; 0: there was nothing to fit)."""

    sets: list[TaskResults]
    processes: int


def run_task_sets(
    task_sets: Sequence[Sequence[Task]],
    methods: Sequence[str],
    *,
    features: Features | None = None,
    progress: bool = False,
    on_fit: Callable[[Task, str, FewShotMethod], None] | None = None,
    executor: FitExecutor | None = None,
    on_done: Callable[[int, TaskResults], None] | None = None,
    fit_cache: FitCache | None = None,
    options: MethodOptions | None = None,
) -> SetResults:
    """Run several sets of tasks (a protocol's each) through one queue of fits: every
    method fitted once per fit group (:func:`benchmark.fit_groups.plan_fits`), every
    cell of every task evaluated. Returns each set's results in task-set order, and calls
    ``on_done(i, results)`` as soon as set ``i`` is complete (a run checkpoints it there).

    executor: where the fits run (None: this process, in order; see
    :class:`benchmark.workers.ProcessPool`). A set's results, and their order (task,
    method, cell), do not depend on the executor; their bits depend on the threads each
    fit ran with. on_fit(task, method name, fitted): called after each fit (one process
    only). fit_cache: each fit's results are saved there as soon as it finishes, and a
    fit found there is not run again (nor passed to ``on_fit``): an interrupted run loses
    only the fits that were running. options: constructor options per method name
    (``--method-option``; :func:`models.registry.check_method_options` checks them).
    """
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

    if not todo:
        processes = 0
    else:
        processes = 1 if executor is None else executor.processes(len(todo))
    try:
        if processes <= 1:
            for g, name in todo:
                result = run_fit(
                    groups[g], name, features, bar=bar, on_fit=on_fit, options=options.get(name)
                )
                keep((g, name), result)
        else:
            assert executor is not None
            if on_fit is not None:
                raise ValueError("on_fit needs the fits in this process: use workers=1")
            for (g, name), result in executor.run(groups, todo, features, options=options):
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
    executor: FitExecutor | None = None,
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
        executor=executor,
        options=options,
    ).sets[0]


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
    executor: FitExecutor | None = None,
    options: MethodOptions | None = None,
) -> list[Record]:
    """All records of ``protocol`` on the datasets.

    Parameters
    ----------
    protocol : benchmark.tasks.Protocol
        The protocol instance (:func:`benchmark.protocols.get` makes one by name).
    data, perturbed : synth.Dataset; synth.Dataset or None
        The nominal dataset, and the perturbation dataset when the protocol needs it.
    methods : sequence of str
        Method names, plug-in names or ``module:Class`` specs.
    episodes : int or benchmark.budget.EpisodeBudget
        Episodes per cell (per method).
    seed : int, default 0
        The run's seed: the same seed gives the same records.
    progress : bool, default False
        Show a progress bar on a terminal.
    features : benchmark.cells.Features or None
        Precomputed 386-feature pools (extracted on first use when not given).
    on_fit : callable or None
        ``on_fit(task, method name, fitted method)`` after each fit (fits in this process).
    executor : FitExecutor or None
        Where the fits run (None: this process, in order;
        :class:`benchmark.workers.ProcessPool` for worker processes).
    options : mapping or None
        Constructor options per method name (``--method-option``).

    Returns
    -------
    list of records
        :func:`benchmark.pooling.protocol_records` of the protocol's tasks.
    """
    methods = check_methods(methods)
    tasks = protocol_tasks(protocol, data, perturbed, episodes=episodes, seed=seed)
    done = run_tasks(
        tasks,
        methods,
        features=features,
        progress=progress,
        on_fit=on_fit,
        executor=executor,
        options=options,
    )
    return protocol_records(tasks, done)
