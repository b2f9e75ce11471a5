"""Enrolment tasks: the support examples come from the task's support pool, the queries
from its test pool, classes matched by name; the perturbation protocol's three readings
(within one condition, pooled, enrolled at nominal) side by side."""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import pytest

from benchmark.budget import EpisodeBudget
from benchmark.engine import (
    Cell,
    Pool,
    Task,
    condition_reading,
    protocol_records,
    run_tasks,
)
from benchmark.protocols.perturbation import ENROLLED, POOLED, Perturbation
from benchmark.results import select
from benchmark.splits import split_halves
from models.base import FewShotMethod
from models.episodes import sample_split_episodes
from tests.synthetic_data import make_dataset
from tests.test_run import _perturbed


class Spy(FewShotMethod):
    """Labels every query as episode class 0 and records what it was given: for each
    episode, the signals' first sample of its support and query trials (the synthetic
    trials' first samples are distinct, so they identify the trials)."""

    name = "spy"
    seen: ClassVar[list] = []

    def _fit(self, signals, labels, features):
        pass

    def _predict(self, signals, support, query, features):
        Spy.seen.append((signals[support, 0, 0], signals[query, 0, 0]))
        return np.zeros(query.shape, dtype=np.int64)


def test_split_episodes_draw_support_and_queries_from_their_pools():
    ys = np.repeat(np.arange(6), 3)  # 6 classes x 3 support-pool trials
    yq = np.repeat([0, 1, 2, 3, 4, 9], 4)  # the query pool lacks class 5, has class 9
    batch = sample_split_episodes(ys, yq, n_way=4, k_shot=2, n_query=3, episodes=50, seed=1)
    assert batch.support.shape == (50, 4, 2) and batch.query.shape == (50, 12)
    assert batch.support.max() < ys.size and batch.query.min() >= ys.size
    for e in range(50):
        assert set(batch.classes[e]) <= {0, 1, 2, 3, 4}
        for n in range(4):
            assert set(ys[batch.support[e, n]]) == {batch.classes[e, n]}
        labels = yq[batch.query[e] - ys.size]
        np.testing.assert_array_equal(labels, batch.classes[e][batch.query_labels[e]])
    again = sample_split_episodes(ys, yq, n_way=4, k_shot=2, n_query=3, episodes=50, seed=1)
    np.testing.assert_array_equal(again.query, batch.query)
    with pytest.raises(ValueError, match="n_way=6 needs 6 classes"):
        sample_split_episodes(ys, yq, n_way=6, k_shot=2, n_query=3, episodes=1, seed=1)


def test_an_enrolment_task_takes_support_from_its_support_pool(monkeypatch):
    from models import registry

    monkeypatch.setitem(registry._VARIANTS, "spy", ("tests.test_enrolment:Spy", "a spy"))
    monkeypatch.setitem(registry._BUILTINS, "spy", "tests.test_enrolment:Spy")
    nominal = make_dataset(trials_per_class=6, n_samples=200, noise=0.1)
    other = make_dataset(trials_per_class=4, n_samples=200, noise=0.1, seed=7)
    # Trials are told apart by their first sample: the nominal ones >= 1000, the others < 0.
    nominal.signals[:, 0, 0] = 1000.0 + np.arange(len(nominal))
    other.signals[:, 0, 0] = -1.0 - np.arange(len(other))
    # The other dataset lists its classes in reverse order: matching is by name.
    order = np.arange(len(other.classes))[::-1]
    other = type(other)(
        **{**vars(other), "label": order[other.label], "classes": tuple(other.classes[::-1])}
    )
    support_index = np.flatnonzero(np.arange(len(nominal)) % 6 >= 3)
    task = Task(
        protocol="enrol",
        fold=None,
        condition="enrolled:force=1N,speed=6mm/s",
        fit=Pool(nominal, np.flatnonzero(np.arange(len(nominal)) % 6 < 3)),
        test=Pool(other, np.arange(len(other))),
        grid=(Cell(3, 2, seed=5),),
        episodes=EpisodeBudget(40),
        fit_seed=0,
        support=Pool(nominal, support_index),
    )
    spy = registry.method_class("spy")  # the class the engine builds (pytest may import
    spy.seen.clear()  # this file under another module name)
    done = run_tasks([task], ["spy"])
    # Queries: all 4 test-pool trials of a class (its support comes from the other pool).
    assert len(done.scored) == 1 and done.scored[0].record.query == 4
    (sup, qry), *_ = spy.seen
    name_of_nominal = {1000.0 + i: nominal.classes[nominal.label[i]] for i in range(len(nominal))}
    name_of_other = {-1.0 - i: other.classes[other.label[i]] for i in range(len(other))}
    for e in range(40):
        assert set(sup[e].ravel()) <= {1000.0 + i for i in support_index}
        assert set(qry[e]) <= set(name_of_other)
        names = [{name_of_nominal[v] for v in sup[e, n]} for n in range(3)]
        assert all(len(s) == 1 for s in names)
        enrolled = {next(iter(s)) for s in names}
        assert {name_of_other[v] for v in qry[e]} == enrolled  # the same classes
    # The summary across conditions of a named reading carries the reading's name.
    records = protocol_records([task], done)
    assert {r["condition"] for r in records} == {task.condition, ENROLLED}


def test_condition_reading():
    assert condition_reading("force=1.4N,speed=6mm/s") == (None, (1.4, 6.0))
    assert condition_reading("enrolled:force=1.4N,speed=6mm/s") == ("enrolled", (1.4, 6.0))
    assert condition_reading("pooled") == (None, None)
    assert condition_reading(None) == (None, None)


@pytest.mark.slow
def test_perturbation_protocol_runs_three_readings_on_one_fit():
    data = make_dataset(trials_per_class=6, n_samples=400, noise=0.2)
    pert = _perturbed()
    tasks = Perturbation().tasks(data, pert, seed=0, episodes=EpisodeBudget(5))
    enrolled = [t for t in tasks if t.support is not None]
    plain = [t for t in tasks if t.support is None]
    assert len(enrolled) == len(plain) - 1  # one per condition; the pooled task has none
    assert {t.fit_key for t in tasks} == {tasks[0].fit_key}
    nominal_test = split_halves(data.label, seed=0)[1]
    for t in enrolled:
        assert t.support.data is data and np.array_equal(t.support.index, nominal_test)
        reading, fs = condition_reading(t.condition)
        twin = next(p for p in plain if p.condition == t.condition.split(":", 1)[1])
        assert reading == ENROLLED and fs is not None
        assert np.array_equal(t.test.index, twin.test.index)
    # Every task's cells have their own episode seeds.
    seeds = [c.seed for t in tasks for c in t.grid]
    assert len(set(seeds)) == len(seeds)
    done = run_tasks(tasks, ["AFOP-ML"])
    records = protocol_records(tasks, done)
    summaries = {r["condition"] for r in select(records, "accuracy") if r["way"] == 2}
    assert {"within-condition", POOLED, ENROLLED} <= summaries
