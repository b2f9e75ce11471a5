"""Generate a dataset into a store: plan, schedule chunk tasks on an executor, resume.

One task = one storage chunk: it simulates its trials, writes its own chunk of the shared
store and marks it done (see :mod:`synth.store`). Tasks depend only on the configuration and
their chunk index, so the bytes are the same for any worker count, executor or resume
history. Locally the tasks run in this process (two chunks at a time on threads, each
rolling out on MuJoCo threads, as many as :mod:`tactile_synth.threads` allots: one chunk's
Python sensor chain and storage overlap the other's physics) or in a process pool;
``executor=`` accepts any ``concurrent.futures.Executor``, e.g. a Dask client's.
"""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
import signal
import sys
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from shapes.validation import check_int
from tactile_synth.threads import init_worker, rollout_threads, worker_threads

from . import store
from .presets import GenerationConfig, plan, preset
from .trial import TrialSpec

#: ``simulator(specs, synth_config_dict, threads) -> float32 (len(specs), 4, T)``.
Simulator = Callable[[Sequence[TrialSpec], Mapping[str, Any], int], np.ndarray]


def mujoco_simulator(
    specs: Sequence[TrialSpec], synth: Mapping[str, Any], threads: int
) -> np.ndarray:
    """The real simulator: ``synth.simulate_batch`` stacked to float32 ``(b, 4, T)``."""
    from . import SynthConfig, simulate_batch

    trials = simulate_batch(specs, config=SynthConfig.from_dict(dict(synth)), threads=threads)
    return np.stack([t.signals for t in trials]).astype(np.float32, copy=False)


def default_synth_config() -> dict[str, Any]:
    from . import SynthConfig

    return SynthConfig().to_dict()


def validate_synth_config(synth: Mapping[str, Any]) -> None:
    from . import SynthConfig

    SynthConfig.from_dict(dict(synth))


def run_chunk(
    path: str,
    chunk: int,
    specs: Sequence[TrialSpec],
    synth: Mapping[str, Any],
    threads: int,
    simulator: Simulator | None = None,
) -> tuple[int, int, float]:
    """Simulate and store one chunk; returns ``(chunk, trials, cpu seconds)``.

    Runs in whatever process or cluster worker the executor chose; needs only the shared
    store path.
    """
    cpu = time.process_time()
    signals = (simulator or mujoco_simulator)(specs, synth, threads)
    store.write_chunk(path, chunk, np.ascontiguousarray(signals, dtype=np.float32))
    return chunk, len(specs), time.process_time() - cpu


class _StopRequests:
    """Ctrl-C during generation: the first SIGINT asks to stop at the next chunk boundary.

    A ``KeyboardInterrupt`` raised at an arbitrary bytecode can land inside a lock's
    ``with`` block of ``concurrent.futures`` or zarr's IO thread and leave the interpreter
    unable to exit; a flag checked between chunks cannot. A second Ctrl-C raises at once
    (finished chunks are on disk either way). Outside the main thread this does nothing.
    """

    def __init__(self) -> None:
        self.requested = False
        self._previous: Any = None

    def __enter__(self) -> _StopRequests:
        if threading.current_thread() is threading.main_thread():
            self._previous = signal.getsignal(signal.SIGINT)
            if self._previous is signal.default_int_handler:
                signal.signal(signal.SIGINT, self._handle)
            else:  # the caller handles SIGINT its own way: leave it alone
                self._previous = None
        return self

    def _handle(self, signum: int, frame: Any) -> None:
        if self.requested:
            raise KeyboardInterrupt
        self.requested = True
        print(
            "\ntactile-synth generate: stopping after the running chunks (Ctrl-C again: now)",
            file=sys.stderr,
            flush=True,
        )

    def check(self) -> None:
        if self.requested:
            raise KeyboardInterrupt

    def __exit__(self, *exc: object) -> None:
        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)


def _init_worker(threads: int) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides when to stop
    init_worker(threads)  # this worker's share of the CPUs, for every thread pool


def _run_chunk_on_worker(*args: Any) -> tuple[int, int, float]:
    init_worker(args[4])  # a cluster worker: its pools get this task's share first
    return run_chunk(*args)


def _resolve_config(config: GenerationConfig | str | None, out: Path, resume: bool):
    if isinstance(config, str):
        return preset(config)
    if config is None:
        if resume and store.is_store(out):
            return store.stored_config(out)
        raise ValueError("give a preset name or a GenerationConfig (or resume an existing store)")
    if not isinstance(config, GenerationConfig):
        raise ValueError(f"config must be a preset name or GenerationConfig; got {config!r}")
    return config


def _check_same(requested: GenerationConfig, stored: GenerationConfig, out: Path) -> None:
    want = requested.to_dict()
    have = stored.to_dict()
    if "synth" not in want:  # the simulator defaults were resolved when the store was made
        have.pop("synth", None)
    diff = [k for k in sorted(set(want) | set(have)) if want.get(k) != have.get(k)]
    if diff:
        raise ValueError(
            f"--resume: {out} was generated with a different configuration "
            f"({', '.join(f'{k}={have.get(k)!r} there, {want.get(k)!r} here' for k in diff)}); "
            f"resume without grid options, or use --overwrite"
        )


def prepare(
    config: GenerationConfig | str | None,
    out: str | Path,
    *,
    resume: bool = False,
    overwrite: bool = False,
) -> GenerationConfig:
    """Create (or check, for ``resume``) the store at ``out``; returns the resolved config.

    Nothing on disk is touched before every check has passed.
    """
    out = Path(out)
    if resume and overwrite:
        raise ValueError("--resume and --overwrite exclude each other; pick one")
    config = _resolve_config(config, out, resume)
    if out.exists() and not out.is_dir():
        raise FileExistsError(f"--out {out} is a file; choose a directory path for the dataset")
    occupied = out.exists() and any(out.iterdir())
    if occupied and resume:
        stored = store.stored_config(out)  # checks it is a compatible tactile-synth store
        _check_same(config, stored, out)
        store.remove_partial_files(out)
        return stored
    if occupied and not overwrite:
        raise FileExistsError(
            f"--out {out} exists and is not empty; pass --resume to complete it, "
            f"--overwrite to replace it, or choose another path"
        )
    synth = dict(config.synth) if config.synth is not None else default_synth_config()
    validate_synth_config(synth)
    config = config.replace(synth=synth)
    if occupied:
        store.remove(out)  # refuses anything that is not a Zarr store
    store.create(out, config)
    return config


def generate(
    config: GenerationConfig | str | None,
    out: str | Path,
    *,
    workers: int | None = None,
    threads: int | None = None,
    executor: cf.Executor | None = None,
    resume: bool = False,
    overwrite: bool = False,
    progress: bool = True,
    simulator: Simulator | None = None,
) -> Path:
    """Generate ``config`` (a :class:`GenerationConfig` or preset name) into the store ``out``.

    workers: local processes (default 1: this process, two chunk tasks at a time, the
    fastest on one machine; N > 1: a pool of N processes). threads: MuJoCo rollout threads
    per task (default: ``tactile_synth.threads.rollout_threads()`` in this process; in a
    pool, each process's share of the CPUs; 1 on an executor); in a pool or on an executor
    it sizes the worker's BLAS/OpenMP pools too. executor: any
    ``concurrent.futures.Executor`` (e.g. a Dask client's ``get_executor()``); its workers
    must see ``out``. resume: complete an interrupted
    store without recomputing its finished chunks. Returns ``out``.
    """
    out = Path(out)
    workers = 1 if workers is None else check_int("workers", workers, minimum=1)
    if threads is not None:
        check_int("threads", threads, minimum=1)
    config = prepare(config, out, resume=resume, overwrite=overwrite)
    group, _ = store.open_store(out)
    todo = [int(k) for k in np.flatnonzero(~store.done_mask(group))]
    trials = plan(config)
    c = config.chunk_trials
    done_trials = len(trials) - sum(min(c, len(trials) - k * c) for k in todo)

    owned: cf.Executor | None = None
    task = run_chunk
    if executor is None:
        workers = max(min(workers, len(todo)), 1)  # no idle processes for a small run
        if workers == 1:
            # Two tasks overlap: while one runs its sensor chain and writes (Python, GIL),
            # the other's rollout keeps the cores busy (measured: 100% of the raw rate).
            owned = executor = cf.ThreadPoolExecutor(max_workers=2, thread_name_prefix="chunk")
            threads = threads or rollout_threads()
        else:
            # spawn: MuJoCo/zarr threads in this process must not be forked, and spawned
            # workers are our own children (their CPU time and RSS show in getrusage).
            ctx = multiprocessing.get_context("spawn")
            threads = threads or worker_threads(workers)
            owned = executor = cf.ProcessPoolExecutor(
                max_workers=workers, mp_context=ctx, initializer=_init_worker, initargs=(threads,)
            )
        in_flight = 2 * workers
    else:
        threads = threads or 1
        task = _run_chunk_on_worker
        in_flight = 2 * max(workers, 1)

    from tqdm import tqdm

    bar = tqdm(
        total=len(trials),
        initial=done_trials,
        unit="trial",
        desc=f"generate {config.preset}",
        disable=None if progress else True,  # None: quiet when stderr is not a TTY
        smoothing=0.1,
    )
    pending: set[cf.Future] = set()
    queue = iter(todo)
    stop = _StopRequests()
    try:
        with stop:
            while True:
                # Bounded submission keeps memory flat and lets Ctrl-C stop quickly.
                for k in queue:
                    args = (str(out), k, trials.specs(k * c, (k + 1) * c), config.synth, threads)
                    pending.add(executor.submit(task, *args, simulator))
                    stop.check()
                    if len(pending) >= in_flight:
                        break
                if not pending:
                    break
                # A timeout so that a stop request is seen while workers are busy.
                finished, pending = cf.wait(pending, timeout=0.2, return_when=cf.FIRST_COMPLETED)
                for fut in finished:
                    _, n, _ = fut.result()
                    bar.update(n)
                stop.check()
    except BaseException:
        for fut in pending:
            fut.cancel()
        if owned is not None:
            # Let running tasks finish their chunk (seconds) so nothing writes after we return.
            owned.shutdown(wait=True, cancel_futures=True)
            owned = None
        raise
    finally:
        bar.close()
        if owned is not None:
            owned.shutdown(wait=True)
    done = store.done_mask(store.open_store(out)[0])
    if not done.all():  # pragma: no cover - every task either finished or raised
        raise RuntimeError(f"{out}: {int((~done).sum())} chunks still missing after the run")
    return out
