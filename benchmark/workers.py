"""The engine's fits in worker processes: each (fit group, method) is one job, and the
jobs of every protocol of a run share one queue, so a process that finishes early takes
the next job, whatever protocol it belongs to. :class:`ProcessPool` is the executor a
caller gives the engine (:func:`benchmark.engine.run_task_sets`) for this.

Why processes: a fit and its episodes are mostly many small tensor operations from one
Python thread. Two processes of one thread each keep both cores of a 2-core machine busy
where one process with two threads leaves them partly idle.

- Workers are spawned (never forked: torch's and MuJoCo's threads in this process must
  not be copied) and size their thread pools to their share of the CPUs before any work
  (:func:`tactile_synth.threads.init_worker`).
- Datasets and their feature pools reach the workers as ``.npy`` files in a temporary
  directory, memory-mapped read-only (``np.load(mmap_mode="r", allow_pickle=False)``):
  written once, shared through the page cache, nothing pickled.
- A job is a JSON text naming the tasks (their trials as indices into those datasets)
  and the method; its results come back as JSON text (the records as results.json
  holds them, and the per-episode accuracies), so a job's records are exactly what the
  same fit gives in this process with the same thread count.
- A job that fails stops the run with its error; on an interrupt (Ctrl-C) the workers are
  terminated at once.
- The temporary directory is named after the process that made it
  (``tactile-synth-fits-<pid>-...``): a run killed outright (SIGKILL) cannot remove it,
  so the next run removes those whose process is gone (:func:`remove_stale`).
"""

from __future__ import annotations

import concurrent.futures as cf
import json
import multiprocessing
import os
import re
import shutil
import tempfile
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from models.registry import MethodOptions
from synth import Dataset
from tactile_synth.threads import init_worker, worker_threads
from tactile_synth.validation import check_int

from .budget import EpisodeBudget
from .cells import Features
from .fit_groups import FitGroup, Share
from .fits import FitResult, run_fit
from .tasks import Cell, Pool, Task

_ARRAYS = ("signals", "shape", "material", "label", "force_n", "speed_mm_s", "seed")


# -- datasets on disk ----------------------------------------------------------------------
def _save(data: Dataset, pool: np.ndarray, directory: Path) -> None:
    directory.mkdir()
    for name in _ARRAYS:
        arr = getattr(data, name)
        if arr.dtype == object:  # labels as fixed-width text: no pickle in the file
            arr = arr.astype(str)
        np.save(directory / f"{name}.npy", np.ascontiguousarray(arr), allow_pickle=False)
    np.save(directory / "features.npy", np.ascontiguousarray(pool), allow_pickle=False)
    meta = {"classes": list(data.classes), "attrs": data.attrs}
    (directory / "meta.json").write_text(json.dumps(meta, default=str))


def _open(directory: Path) -> tuple[Dataset, np.ndarray]:
    arrays = {
        name: np.load(directory / f"{name}.npy", mmap_mode="r", allow_pickle=False)
        for name in _ARRAYS
    }
    meta = json.loads((directory / "meta.json").read_text())
    data = Dataset(**arrays, classes=tuple(meta["classes"]), attrs=meta["attrs"])
    return data, np.load(directory / "features.npy", mmap_mode="r", allow_pickle=False)


# -- jobs as JSON ---------------------------------------------------------------------------
def _pool_json(pool: Pool, refs: dict[int, str]) -> dict[str, Any]:
    return {"data": refs[id(pool.data)], "index": pool.index.tolist()}


def _task_json(task: Task, refs: dict[int, str]) -> dict[str, Any]:
    return {
        "protocol": task.protocol,
        "fold": task.fold,
        "condition": task.condition,
        "fit": _pool_json(task.fit, refs),
        "test": _pool_json(task.test, refs),
        "grid": [[c.way, c.shot, c.seed, c.latency_episodes] for c in task.grid],
        "episodes": [task.episodes.default, dict(task.episodes.per_method)],
        "fit_seed": task.fit_seed,
        "methods": None if task.methods is None else list(task.methods),
        "fit_records": task.fit_records,
        "support": None if task.support is None else _pool_json(task.support, refs),
    }


def _task(d: dict[str, Any], datasets: dict[str, Dataset]) -> Task:
    default, per_method = d["episodes"]
    return Task(
        protocol=d["protocol"],
        fold=d["fold"],
        condition=d["condition"],
        fit=Pool(datasets[d["fit"]["data"]], np.asarray(d["fit"]["index"], dtype=np.intp)),
        test=Pool(datasets[d["test"]["data"]], np.asarray(d["test"]["index"], dtype=np.intp)),
        grid=tuple(Cell(*c) for c in d["grid"]),
        episodes=EpisodeBudget(default, per_method),
        fit_seed=d["fit_seed"],
        methods=None if d["methods"] is None else tuple(d["methods"]),
        fit_records=d["fit_records"],
        support=None
        if d["support"] is None
        else Pool(datasets[d["support"]["data"]], np.asarray(d["support"]["index"], dtype=np.intp)),
    )


def _job_json(
    group: FitGroup, name: str, refs: dict[int, str], options: Mapping[str, object] | None
) -> str:
    shares = [
        {
            "set": s.set_index,
            "tasks": [_task_json(t, refs) for t in s.tasks],
            "methods": list(s.methods),
        }
        for s in group.shares
    ]
    return json.dumps(
        {
            "method": name,
            "methods": list(group.methods),
            "shares": shares,
            "options": dict(options or {}),
        }
    )


# -- the worker side ------------------------------------------------------------------------
_directory: Path | None = None
_opened: dict[str, tuple[Dataset, np.ndarray]] = {}


def _init(threads: int, directory: str) -> None:
    global _directory
    init_worker(threads)
    _directory = Path(directory)


def _run_job(payload: str) -> str:
    job = json.loads(payload)
    keys = {
        t[p]["data"]
        for s in job["shares"]
        for t in s["tasks"]
        for p in ("fit", "test", "support")
        if t[p] is not None
    }
    for key in keys - _opened.keys():
        _opened[key] = _open(_directory / key)
    datasets = {key: data for key, (data, _) in _opened.items()}
    features = Features(_opened.values())
    group = FitGroup(
        tuple(
            Share(s["set"], tuple(_task(t, datasets) for t in s["tasks"]), tuple(s["methods"]))
            for s in job["shares"]
        ),
        tuple(job["methods"]),
    )
    return run_fit(group, job["method"], features, options=job["options"]).to_json()


# -- the run's side -------------------------------------------------------------------------
def _terminate(executor: cf.ProcessPoolExecutor) -> None:
    """Stop the workers now (``terminate_workers`` from Python 3.14 on)."""
    stop = getattr(executor, "terminate_workers", None)
    if stop is not None:
        stop()
        return
    for process in list(getattr(executor, "_processes", {}).values()):
        process.terminate()
    executor.shutdown(wait=True, cancel_futures=True)


#: The temporary directories of :func:`run_fits`: ``PREFIX<pid>-<random>``.
PREFIX = "tactile-synth-fits-"


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


def remove_stale(directory: str | os.PathLike[str] | None = None) -> list[Path]:
    """Remove the temporary directories that :func:`run_fits` left in ``directory``
    (default: the system's temporary directory) when its process was killed outright:
    those named after a process that no longer exists. Returns what was removed."""
    root = Path(directory if directory is not None else tempfile.gettempdir())
    removed = []
    pattern = re.compile(re.escape(PREFIX) + r"(\d+)-")
    try:
        entries = list(root.iterdir())
    except OSError:
        return removed
    for path in entries:
        match = pattern.match(path.name)
        if match is None or not path.is_dir() or path.is_symlink():
            continue
        if not _alive(int(match.group(1))):
            shutil.rmtree(path, ignore_errors=True)
            removed.append(path)
    return removed


def run_fits(
    groups: Sequence[FitGroup],
    jobs: Sequence[tuple[int, str]],
    features: Features,
    *,
    workers: int,
    threads: int | None = None,
    options: MethodOptions | None = None,
) -> Iterator[tuple[tuple[int, str], FitResult]]:
    """Run ``jobs`` (group index, method name) in ``workers`` processes of ``threads``
    threads each (default: their share of the CPUs), each method built with its
    ``options`` (JSON values); yields each job's result as it finishes."""
    options = options or {}
    threads = threads or worker_threads(workers)
    remove_stale()
    with tempfile.TemporaryDirectory(prefix=f"{PREFIX}{os.getpid()}-") as tmp:
        refs: dict[int, str] = {}
        for group in groups:
            for share in group.shares:
                for task in share.tasks:
                    for pool in (task.fit, task.test, task.support):
                        if pool is not None and id(pool.data) not in refs:
                            refs[id(pool.data)] = key = f"data{len(refs)}"
                            _save(pool.data, features.of(pool.data), Path(tmp) / key)
        executor = cf.ProcessPoolExecutor(
            max_workers=workers,
            mp_context=multiprocessing.get_context("spawn"),
            initializer=_init,
            initargs=(threads, tmp),
        )
        futures = {
            executor.submit(_run_job, _job_json(groups[g], name, refs, options.get(name))): (
                g,
                name,
            )
            for g, name in jobs
        }
        pending = set(futures)
        try:
            while pending:
                # A timeout, so that Ctrl-C is seen at once while the workers are busy.
                finished, pending = cf.wait(pending, timeout=0.5, return_when=cf.FIRST_COMPLETED)
                for future in finished:
                    yield futures[future], FitResult.from_json(future.result())
        except BaseException:
            for future in futures:
                future.cancel()
            _terminate(executor)
            raise
        executor.shutdown(wait=True)


class ProcessPool:
    """Run the engine's fits in up to ``workers`` spawned processes of ``threads``
    threads each (default: their share of the CPUs); an executor for
    :func:`benchmark.engine.run_task_sets` (:class:`benchmark.engine.FitExecutor`).

    Parameters
    ----------
    workers : int
        The most processes the fits run in. No more processes start than there are fits
        to run; with one (or one fit) the fits run in the calling process, in order.
    threads : int or None, default None
        Threads per worker process (None: :func:`tactile_synth.threads.worker_threads`).

    Examples
    --------
    >>> ProcessPool(2).processes(5), ProcessPool(2).processes(1), ProcessPool(1).processes(9)
    (2, 1, 1)
    """

    def __init__(self, workers: int, *, threads: int | None = None) -> None:
        self.workers = check_int("workers", workers, minimum=1)
        self.threads = None if threads is None else check_int("threads", threads, minimum=1)

    def __repr__(self) -> str:
        return f"ProcessPool({self.workers}, threads={self.threads})"

    def processes(self, fits: int) -> int:
        """Processes ``fits`` fits run in: no more than there are fits (1: this process)."""
        return max(1, min(self.workers, fits))

    def run(
        self,
        groups: Sequence[FitGroup],
        jobs: Sequence[tuple[int, str]],
        features: Features,
        *,
        options: MethodOptions,
    ) -> Iterator[tuple[tuple[int, str], FitResult]]:
        """:func:`run_fits` of ``jobs`` in :meth:`processes` processes."""
        return run_fits(
            groups,
            jobs,
            features,
            workers=self.processes(len(jobs)),
            threads=self.threads,
            options=options,
        )
