"""Fits in worker processes (``benchmark.workers``) and one queue of fits for several
protocols (``benchmark.engine.run_task_sets``): the same records as one process with the
same threads per fit, one fit shared by the closed-set and perturbation protocols, a
failing fit stopping the run with its error, and an interrupt stopping the workers."""

from __future__ import annotations

import multiprocessing
import os
import signal
import threading
import time

import pytest

from benchmark import engine, fits
from benchmark.protocols.closed_set import ClosedSet, Reference
from benchmark.protocols.perturbation import Perturbation
from benchmark.results import TIMING_FIELDS, to_json
from benchmark.workers import ProcessPool
from models.base import FewShotMethod
from models.cnn import CNNBaseline
from models.registry import PluginError
from tactile_synth import threads
from tests.synthetic_data import make_dataset
from tests.test_run import _perturbed

SPEC = "tests.test_workers:{}"


class Counting(FewShotMethod):
    """Nearest class mean of the channel means; counts its fits."""

    name = "counting"
    fits = 0

    def _fit(self, signals, labels, features):
        Counting.fits += 1

    def _predict(self, signals, support, query, features):
        x = signals.mean(axis=2)
        protos = x[support].mean(axis=2)
        d = ((x[query][:, :, None, :] - protos[:, None, :, :]) ** 2).sum(-1)
        return d.argmin(axis=2)


class FixedCNN(CNNBaseline):
    """The CNN baseline with its training schedule given, so its fit validates nothing:
    the test is about where fits run, and CNN's schedule selection is tested with it."""

    def __init__(self, *, seed: int = 0):
        super().__init__(seed=seed, steps=20, lr=1e-2)


class Failing(Counting):
    name = "failing"

    def _fit(self, signals, labels, features):
        raise ValueError("this fit fails on purpose")


class Sleeping(Counting):
    name = "sleeping"

    def _fit(self, signals, labels, features):
        time.sleep(120)


@pytest.fixture(scope="module")
def datasets():
    return make_dataset(trials_per_class=6, n_samples=400, noise=0.2), _perturbed()


def _sets(datasets, episodes=6, reference=False):
    data, pert = datasets
    budget = engine.EpisodeBudget(episodes)
    sets = [
        list(ClosedSet().tasks(data, None, seed=3, episodes=budget)),
        list(Perturbation().tasks(data, pert, seed=3, episodes=budget)),
    ]
    if reference:
        sets.append(list(Reference().tasks(data, None, seed=3, episodes=budget)))
    return sets


def _comparable(done: list[engine.TaskResults]) -> list:
    out = []
    for part in done:
        records = to_json([s.record for s in part.scored] + part.fits)
        out.append([{k: v for k, v in r.items() if k not in TIMING_FIELDS} for r in records])
        out.append([s.accuracies.tolist() for s in part.scored])
    return out


def test_closed_set_and_perturbation_share_one_fit(datasets, monkeypatch):
    sets = _sets(datasets)
    groups, order = engine.plan_fits(sets, ["AFOP-ML"])
    # One fit group serves the closed-set task and every perturbation condition.
    assert len(groups) == 1 and order == [[0], [0]]
    assert [len(s.tasks) for s in groups[0].shares] == [1, len(sets[1])]
    Counting.fits = 0
    monkeypatch.setattr(fits, "make_method", lambda name, seed=0: Counting(seed=seed))
    done = engine.run_task_sets(sets, ["AFOP-ML"]).sets
    assert Counting.fits == 1
    assert {s.record.protocol for s in done[0].scored} == {"closed-set"}
    assert {s.record.protocol for s in done[1].scored} == {"perturbation"}
    # The pooled perturbation task is there too, each task with its own cells.
    conditions = {s.record.condition for s in done[1].scored}
    assert "pooled" in conditions and len(conditions) == len(sets[1])


def test_the_reference_curve_is_evaluated_on_the_closed_set_fit(datasets, monkeypatch):
    """The reference curve's set asks for AFOP-ML only and shares the closed-set group:
    each method is fitted once, and the reference set gets AFOP-ML's records only."""
    sets = _sets(datasets, reference=True)
    counting = SPEC.format("Counting")
    groups, order = engine.plan_fits(sets, [counting, "AFOP-ML"])
    assert len(groups) == 1 and order == [[0], [0], [0]]
    assert groups[0].methods == (counting, "AFOP-ML")
    assert [s.methods for s in groups[0].shares] == [(counting, "AFOP-ML")] * 2 + [("AFOP-ML",)]
    Counting.fits = 0
    monkeypatch.setattr(fits, "make_method", lambda name, seed=0: Counting(seed=seed))
    finished: list[int] = []
    done = engine.run_task_sets(
        sets, [counting, "AFOP-ML"], on_done=lambda i, _: finished.append(i)
    ).sets
    assert Counting.fits == 2 and sorted(finished) == [0, 1, 2]
    assert {(s.record.method, s.record.condition) for s in done[2].scored} == {
        ("AFOP-ML", "reference")
    }
    assert [s.record.way for s in done[2].scored] == list(range(2, 13))
    assert {s.record.method for s in done[0].scored} == {counting, "AFOP-ML"}


@pytest.mark.slow
def test_sets_complete_in_their_own_order_of_records(datasets):
    """A set's records come in task, method, cell order, whatever set shares its fit."""
    sets = _sets(datasets)
    methods = ["AFOP-ML", SPEC.format("Counting")]
    together = engine.run_task_sets(sets, methods).sets
    alone = [engine.run_tasks(tasks, methods) for tasks in sets]
    assert _comparable(together) == _comparable(alone)


@pytest.mark.slow
def test_worker_processes_give_the_records_of_one_process(datasets):
    sets = _sets(datasets, episodes=8, reference=True)
    methods = ["AFOP-ML", SPEC.format("FixedCNN"), SPEC.format("Counting")]
    finished: list[int] = []
    threads.configure(1)  # the same threads per fit in this process as in each worker
    try:
        here = engine.run_task_sets(sets, methods, executor=ProcessPool(1))
        there = engine.run_task_sets(
            sets,
            methods,
            executor=ProcessPool(2, threads=1),
            on_done=lambda i, _: finished.append(i),
        )
    finally:
        threads.configure()
    assert (here.processes, there.processes) == (1, 2)
    assert _comparable(there.sets) == _comparable(here.sets)
    assert sorted(finished) == [0, 1, 2]
    assert multiprocessing.active_children() == []


@pytest.mark.slow
def test_a_failing_fit_stops_the_run_with_its_error(datasets):
    sets = _sets(datasets)
    with pytest.raises(PluginError, match="failed in fit: ValueError: this fit fails on purpose"):
        engine.run_task_sets(
            sets, [SPEC.format("Counting"), SPEC.format("Failing")], executor=ProcessPool(2)
        )
    deadline = time.monotonic() + 10
    while multiprocessing.active_children() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert multiprocessing.active_children() == []


@pytest.mark.slow
def test_an_interrupt_stops_the_workers_at_once(datasets):
    sets = _sets(datasets)
    # Ctrl-C (SIGINT to this process) while both workers sleep in their fits. A shell
    # starts a background job (`cmd &`, as a CI runner may) with SIGINT ignored, and
    # Python then installs no handler: give this process the one a foreground run has.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(8.0, os.kill, (os.getpid(), signal.SIGINT))
    start = time.monotonic()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            engine.run_task_sets(
                sets,
                [SPEC.format("Sleeping"), "AFOP-ML", SPEC.format("Sleeping")],
                executor=ProcessPool(2),
            )
    finally:
        timer.cancel()
        signal.signal(signal.SIGINT, previous)
    assert time.monotonic() - start < 60  # far less than the sleeping fits' 120 s
    assert multiprocessing.active_children() == []


def test_workers_must_be_a_positive_integer():
    with pytest.raises(ValueError, match="workers must be >= 1"):
        ProcessPool(0)
    with pytest.raises(ValueError, match="threads must be >= 1"):
        ProcessPool(2, threads=0)


def test_a_pool_runs_no_more_processes_than_fits_and_one_fit_here():
    pool = ProcessPool(3)
    assert [pool.processes(n) for n in (1, 2, 3, 7)] == [1, 2, 3, 3]
    assert ProcessPool(1).processes(10) == 1


def test_a_killed_runs_temporary_datasets_are_removed_by_the_next(tmp_path):
    """run_fits' temporary directory carries its process id; the directories of processes
    that are gone (a run killed with SIGKILL) are removed, those of live ones are kept,
    and other names are never touched."""
    import subprocess
    import sys

    from benchmark.workers import PREFIX, remove_stale

    gone = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        capture_output=True,
        text=True,
        check=True,
    )
    dead = tmp_path / f"{PREFIX}{int(gone.stdout)}-abc"
    live = tmp_path / f"{PREFIX}{os.getpid()}-def"
    other = tmp_path / f"{PREFIX}old-ghi"
    for d in (dead, live, other):
        (d / "data0").mkdir(parents=True)
        (d / "data0" / "signals.npy").write_bytes(b"x")
    assert remove_stale(tmp_path) == [dead]
    assert not dead.exists() and live.is_dir() and other.is_dir()
