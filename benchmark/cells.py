"""A task's cells: the feature pools of its datasets, the episodes of each cell, and the
evaluation of a fitted method on them (one batched ``predict_episodes`` call per cell,
:func:`benchmark.evaluate.evaluate`).

Cell rule: queries per class are :data:`benchmark.tasks.N_QUERY`, fewer when the N-th
most populous test class is small (:func:`benchmark.tasks.n_query_for`); episodes are
drawn from the test trials of the classes that can fill the cell (``shot + query``
trials); a cell no set of test classes can fill is skipped.

Enrolment (a task with a ``support`` pool): the episodes' support examples come from
that pool and their queries from the test pool, classes matched by name
(:func:`models.episodes.sample_split_episodes`). A class needs ``shot`` trials in the
support pool and the cell's queries in the test pool; the method sees one pool holding
the episode trials of both.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from .episodes import EpisodeBatch, sample_episodes, sample_split_episodes
from .evaluate import evaluate
from .methods import feature_dim, plugin_stage
from .results import AccuracyRecord, Record, accuracy_record
from .tasks import Cell, Task, n_query_for

if TYPE_CHECKING:
    from tqdm.auto import tqdm

    from models.base import FewShotMethod
    from synth import Dataset


class Features:
    """The raw 386-feature pool of each dataset a run uses, extracted once on first use.

    Parameters
    ----------
    known : iterable of (synth.Dataset, numpy.ndarray)
        Precomputed pools, each ``(len(data), 386)``.

    Examples
    --------
    >>> from tests.synthetic_data import make_dataset
    >>> data = make_dataset(trials_per_class=1, n_samples=200)
    >>> Features().of(data).shape
    (36, 386)
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


class Scored(NamedTuple):
    """An accuracy record with the per-episode accuracies ``(E,)`` behind it."""

    record: AccuracyRecord
    accuracies: np.ndarray


class TaskResults(NamedTuple):
    """What the engine gives for tasks: scored cells and the records of the fits."""

    scored: list[Scored]
    fits: list[Record]


class CellEpisodes(NamedTuple):
    """The episodes of one cell and the pool they index: its trials' signals, labels and
    feature rows; ``query`` is the queries per class."""

    signals: np.ndarray
    features: np.ndarray
    batch: EpisodeBatch
    query: int


def cell_rows(labels: np.ndarray, cell: Cell) -> tuple[int, np.ndarray | None]:
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


def draw_test_episodes(
    task: Task, cell: Cell, episodes: int, features: Features
) -> CellEpisodes | None:
    """The cell's episodes on the test pool (None when no set of classes can fill it)."""
    test = task.test
    labels = test.labels
    q, rows = cell_rows(labels, cell)
    if q < 1:
        return None
    index = test.index if rows is None else test.index[rows]
    lab = labels if rows is None else labels[rows]
    batch = sample_episodes(
        lab, n_way=cell.way, k_shot=cell.shot, n_query=q, episodes=episodes, seed=cell.seed
    )
    return CellEpisodes(test.data.signals[index], features.of(test.data)[index], batch, q)


def draw_enrolment_episodes(
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


def evaluate_task(
    task: Task,
    name: str,
    method: FewShotMethod,
    pretrain_s: float,
    features: Features,
    bar: tqdm | None,
) -> list[Scored]:
    """The scored cells of ``task`` for the fitted ``method`` (named ``name`` in the
    records; ``pretrain_s`` its fit's seconds), in grid order; cells no set of test
    classes can fill are skipped. ``bar`` advances by one per cell."""
    n_ep = task.episodes.of(name)
    draw = draw_test_episodes if task.support is None else draw_enrolment_episodes
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
