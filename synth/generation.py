"""Generate a dataset into a store: check, plan, schedule chunk tasks on an executor,
resume, repair, replace.

One task = one storage chunk: it simulates its trials, writes its own chunk of the shared
store and marks it done (see :mod:`synth.store`). Tasks depend only on the configuration and
their chunk index, so the bytes are the same for any worker count, executor, resume or
repair history. Locally the tasks run in this process (two chunks at a time on threads, each
rolling out on half of the MuJoCo threads :mod:`tactile_synth.threads` allots: one chunk's
Python sensor chain and storage overlap the other's physics) or in a process pool;
``executor=`` accepts any ``concurrent.futures.Executor``, e.g. a Dask client's.

A writer holds the store's lock (:func:`synth.store.locked`) from its first check to its
last write. Every check runs before anything on disk changes. A new store is built beside
its path (``.<name>.tactile-synth-new``) and renamed into place once its skeleton is
complete (a fresh store) or once every chunk is done (``overwrite``), so an interrupted
overwrite leaves the old dataset whole, and ``resume`` continues whichever is unfinished.
"""

from __future__ import annotations

import concurrent.futures as cf
import dataclasses
import multiprocessing
import os
import shutil
import signal
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from tactile_synth import atomic
from tactile_synth.interrupts import StopRequests
from tactile_synth.threads import available_cpus, init_worker, rollout_threads, worker_threads
from tactile_synth.validation import check_int

from . import config as config_mod
from . import store
from .presets import GenerationConfig, plan, preset
from .progress import progress as show_progress
from .summary import counted
from .trial import TrialSpec

#: ``simulator(specs, synth_config_dict, threads) -> float32 (len(specs), 4, T)``.
Simulator = Callable[[Sequence[TrialSpec], Mapping[str, Any], int], np.ndarray]


def mujoco_simulator(
    specs: Sequence[TrialSpec], synth: Mapping[str, Any], threads: int
) -> np.ndarray:
    """The real simulator: ``synth.simulate_batch`` stacked to float32 ``(b, 4, T)``."""
    from . import SynthConfig

    trials = simulate_trials(specs, SynthConfig.from_dict(dict(synth)), threads)
    return np.stack([t.signals for t in trials]).astype(np.float32, copy=False)


def quiet_mujoco_warnings() -> None:
    """Keep MuJoCo's warning text out of stderr and out of a ``MUJOCO_LOG.TXT`` in the
    working directory (its default handler writes both). The simulator reads the warning
    counters, which MuJoCo keeps either way, and raises a ``SimulationError`` naming the
    warning and the trial."""
    import mujoco

    if mujoco.get_mju_user_warning() is None:
        mujoco.set_mju_user_warning(_drop_warning)


def _drop_warning(message: str) -> None:
    """A MuJoCo warning handler that drops the text (the counters report the warning)."""


def simulate_trials(specs: Sequence[TrialSpec], config: Any, threads: int) -> list[Any]:
    """``synth.simulate_batch``, with a saturated ADC reported as the physics failure it is:
    a :class:`synth.SimulationError` naming the trial's shape, material, force, speed and
    seed (the sensor chain only knows the trial's place in its batch)."""
    from .sensors import SaturationError
    from .simulator import SaturatedTrialError, simulate_batch

    quiet_mujoco_warnings()
    try:
        return simulate_batch(specs, config=config, threads=threads)
    except SaturationError as exc:
        culprit = specs[0]
        if len(specs) > 1:  # find the trial: each one's signals do not depend on the batch
            for spec in specs:
                try:
                    simulate_batch([spec], config=config, threads=threads)
                except SaturationError:
                    culprit = spec
                    break
        reason = str(exc).split(" in trial ")[0]
        raise SaturatedTrialError(
            f"{reason} while simulating shape={culprit.shape!r}, material={culprit.material!r}, "
            f"force_n={culprit.force_n}, speed_mm_s={culprit.speed_mm_s}, seed={culprit.seed}"
        ) from None


def validate_grid(config: GenerationConfig) -> None:
    """Plan a trial of every shape at every condition with the MuJoCo simulator: a grid
    whose slides would leave the plate is refused before anything is written."""
    from . import SynthConfig
    from .simulator import check_grid

    synth = SynthConfig.from_dict(dict(config.synth or {})) if config.synth else None
    check_grid(config.shapes, config.conditions, config.materials[0], synth)


def run_chunk(
    path: str,
    chunk: int,
    specs: Sequence[TrialSpec],
    synth: Mapping[str, Any],
    threads: int,
    simulator: Simulator | None = None,
    store_id: str = "",
) -> tuple[int, int, float]:
    """Simulate and store one chunk; returns ``(chunk, trials, cpu seconds)``.

    Runs in whatever process or cluster worker the executor chose; needs only the shared
    store path and the id of the store it was planned for.
    """
    cpu = time.process_time()
    signals = (simulator or mujoco_simulator)(specs, synth, threads)
    signals = np.ascontiguousarray(signals, dtype=np.float32)
    store.write_chunk(path, chunk, signals, specs, store_id)
    return chunk, len(specs), time.process_time() - cpu


def _init_worker(threads: int) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent decides when to stop
    init_worker(threads)  # this worker's share of the CPUs, for every thread pool


def _run_chunk_on_worker(*args: Any) -> tuple[int, int, float]:
    init_worker(args[4])  # a cluster worker: its pools get this task's share first
    return run_chunk(*args)


# -- checks ---------------------------------------------------------------------------------
#: Disk bytes per trial assumed when checking free space: half the raw float32 signals
#: (Blosc-zstd with byte shuffle stores noisy sensor signals in a third to a half).
_DISK_FRACTION = 0.5
#: Memory per trial of the plan while it is built and checked (six per-trial arrays plus
#: temporaries).
_PLAN_BYTES_PER_TRIAL = 128
#: Rough resident memory of one spawned worker process (Python, numpy, MuJoCo, zarr).
_WORKER_BYTES = 300e6
#: More processes or rollout threads than this many per core only compete for the cores.
_PER_CORE = 8


def _fmt_bytes(n: float) -> str:
    for unit in ("B", "kB", "MB", "GB", "TB", "PB"):
        if n < 1000 or unit == "PB":
            return f"{n:,.0f} {unit}" if unit == "B" else f"{n:,.1f} {unit}"
        n /= 1000
    return f"{n:,.1f} PB"  # pragma: no cover


def available_memory() -> int:
    """Bytes of memory a new allocation can get: Linux's MemAvailable (free memory plus
    reclaimable caches), else the total physical memory."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return int(os.sysconf("SC_PHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))


def check_resources(config: GenerationConfig, out: Path, *, workers: int, local: bool) -> None:
    """Refuse a run the machine cannot hold, before anything starts, naming the argument and
    the estimate: the store against the free disk space at ``out``, the plan and the
    chunks in flight against the available memory."""
    n = config.n_trials
    disk = n * store.TRIAL_BYTES * _DISK_FRACTION
    where = store.existing_parent(out)
    free = shutil.disk_usage(where).free
    grid = (
        f"{n:,} trials ({counted(len(config.classes), 'class', 'classes')} x "
        f"{counted(len(config.conditions), 'condition')} x {config.trials_per_class:,} "
        f"trials per class)"
    )
    if disk > free:
        raise ValueError(
            f"--trials-per-class/--force/--speed: the grid has {grid}, about "
            f"{_fmt_bytes(disk)} on disk, but {where} has {_fmt_bytes(free)} free; "
            f"make the grid smaller or choose another --out"
        )
    # As _run schedules them: two chunks per worker at a time, no more than the grid
    # has, and locally no more processes than chunks.
    if local:
        workers = min(workers, config.n_chunks)
    in_flight = min(2 * max(workers, 1), config.n_chunks)
    per_chunk = min(config.chunk_trials, n)
    memory = (
        n * _PLAN_BYTES_PER_TRIAL
        + in_flight * per_chunk * store.TRIAL_BYTES * 4
        + (workers * _WORKER_BYTES if local and workers > 1 else 0)
    )
    have = available_memory()
    if memory > have:
        raise ValueError(
            f"the run needs about {_fmt_bytes(memory)} of memory ({grid}, "
            f"{counted(in_flight, 'chunk')} of {counted(per_chunk, 'trial')} in flight, "
            f"{counted(workers, 'worker')}) but {_fmt_bytes(have)} is available; lower "
            f"--trials-per-class, --chunk-trials or --workers"
        )


def check_parallelism(workers: int, threads: int | None, *, local: bool) -> None:
    """Refuse more local processes or rollout threads than the usable CPUs can serve."""
    ncpu = available_cpus()
    if local and workers > _PER_CORE * ncpu:
        raise ValueError(
            f"--workers {workers}: this process may use {ncpu} CPUs; more than "
            f"{_PER_CORE * ncpu} processes only compete for them"
        )
    if threads is not None and local and threads > _PER_CORE * ncpu:
        raise ValueError(
            f"--threads {threads}: this process may use {ncpu} CPUs; more than "
            f"{_PER_CORE * ncpu} rollout threads only compete for them"
        )


def _resolve_config(config: GenerationConfig | str | None) -> GenerationConfig | None:
    if isinstance(config, str):
        return preset(config)
    if config is not None and not isinstance(config, GenerationConfig):
        raise ValueError(f"config must be a preset name or GenerationConfig; got {config!r}")
    return config


def _differences(have: Any, want: Any, path: str) -> list[str]:
    """``"key=THERE there, HERE here"`` for every leaf where two configurations differ,
    nested tables followed key by key (a specimen's outline or a material's texture is
    named by its path, not printed whole)."""
    if isinstance(have, Mapping) and isinstance(want, Mapping):
        out: list[str] = []
        for key in [*have, *(k for k in want if k not in have)]:
            out += _differences(have.get(key), want.get(key), f"{path}.{key}" if path else key)
        return out
    if have == want:
        return []
    if path.endswith("vertices_m"):
        return [f"{path} differ"]
    return [f"{path}={have!r} there, {want!r} here"]


def _check_same(requested: GenerationConfig, stored: GenerationConfig, where: str) -> None:
    want = requested.to_dict()
    have = stored.to_dict()
    if "synth" not in want:  # the simulator defaults were resolved when the store was made
        have.pop("synth", None)
    diff = _differences(have, want, "")
    if diff:
        shown = ", ".join(diff[:3]) + (f", and {len(diff) - 3} more" if len(diff) > 3 else "")
        raise store.DatasetError(
            f"{where} was generated with a different configuration ({shown})",
            "resume without grid options, or use --overwrite",
        )


def check_resume_target(out: Path, *, repair: bool = False) -> None:
    """A one-line :class:`synth.store.DatasetError` naming ``--out`` when ``--resume``
    (or ``--repair``) is given a directory of other files: no dataset there, and no
    interrupted replacement of one beside it, to continue."""
    out = Path(out)
    if store.is_store(out) or store.is_store(store.pending_path(out)):
        return
    if out.is_dir() and any(out.iterdir()):
        flag = "--resume --repair" if repair else "--resume"
        raise store.DatasetError(
            f"--out {out}: not a tactile-synth dataset (no zarr.json in it)",
            f"{flag} continues a dataset written by `tactile-synth generate`: give its path, "
            f"or drop {flag} and choose an empty or new --out to start one",
        )


def _has_meta(path: Path) -> bool:
    """A store whose creation finished (it has its ``tactile_synth`` attributes)."""
    try:
        store.read_meta(path)
    except (OSError, ValueError):
        return False
    return True


@dataclasses.dataclass
class Job:
    """What a generation does: write ``todo`` chunks of ``config`` into the store at
    ``target`` (id ``store_id``); ``replacing``: ``target`` is the pending replacement of
    the dataset path, renamed into place when every chunk is done."""

    config: GenerationConfig
    target: Path
    store_id: str
    todo: list[int]
    replacing: bool = False
    clear: list[int] = dataclasses.field(default_factory=list)
    rewrite: list[str] = dataclasses.field(default_factory=list)


def _resume_job(config: GenerationConfig | None, out: Path, target: Path, *, repair: bool) -> Job:
    replacing = target != out
    where = f"the interrupted replacement of {out} ({target})" if replacing else str(out)
    st = store.Store.open(target)
    if st.imported:
        # Recordings cannot be re-simulated: only the import that made them rebuilds them.
        raise store.DatasetError(
            f"{where} holds imported recordings (tactile-synth import), which --resume and "
            f"--repair cannot re-simulate",
            f"import them again with `{store.reimport_command(out, st.meta)}`",
        )
    if config is not None:
        _check_same(config, st.config, where)
    done, problems = st.status()
    plan_problems = st.check_plan()
    _, chunk_problems = st.read_chunks(np.flatnonzero(done))
    problems += plan_problems + chunk_problems
    if problems and not repair:
        raise store.DatasetDamaged(out, problems)
    bad = sorted({p.chunk for p in problems if p.chunk is not None})
    todo = sorted(set(np.flatnonzero(~done).tolist()) | set(bad))
    if todo:
        mismatch = store.writer_mismatch(st.meta)
        if mismatch:
            pv, mv = st.meta.get("package_version"), st.meta.get("mujoco_version")
            raise store.DatasetError(
                f"{where} was written by other versions ({'; '.join(mismatch)}), "
                f"and chunks simulated here would not match its {int(done.sum())} finished ones",
                f"finish it with the versions that wrote it (pip install tactile-synth=={pv} "
                f"mujoco=={mv}), or start over with --overwrite",
            )
    return Job(
        config=st.config,
        target=target,
        store_id=st.store_id or "",
        todo=[int(k) for k in todo],
        replacing=replacing,
        clear=[int(k) for k in bad if done[k]],
        rewrite=[p.what for p in plan_problems],
    )


def prepare(
    config: GenerationConfig | str | None,
    out: str | Path,
    *,
    resume: bool = False,
    overwrite: bool = False,
    repair: bool = False,
    workers: int = 1,
    local: bool = True,
    mujoco_plans: bool = True,
) -> Job:
    """Check everything, then create (or, for ``resume``, check) the store; returns the
    :class:`Job`. ``mujoco_plans``: check the grid with the MuJoCo simulator's planner
    (:func:`validate_grid`; off when another simulator is used). Call it holding the
    store's lock. Nothing on disk changes before every
    check has passed, except finishing a replacement an earlier process left half-way.
    """
    out = Path(out)
    if resume and overwrite:
        raise ValueError("--resume and --overwrite exclude each other; pick one")
    if repair and overwrite:
        raise ValueError(
            "--repair fixes an existing dataset; use it with --resume (not --overwrite)"
        )
    resume = resume or repair
    config = _resolve_config(config)
    atomic.check_out_dir(out, advice="choose a directory path for the dataset")
    store.check_not_inside_a_store(out)
    pending = store.pending_path(out)
    atomic.recover(out, complete=store.is_complete(pending))
    occupied = out.exists() and any(out.iterdir())
    if resume and _has_meta(pending):
        return _resume_job(config, out, pending, repair=repair)
    if resume:
        check_resume_target(out, repair=repair)
    if resume and occupied:
        return _resume_job(config, out, out, repair=repair)
    if resume and config is None:
        raise store.DatasetError(
            f"--resume: there is nothing to resume at {out}",
            f"start it with `tactile-synth generate --out {out}` and the grid you want "
            f"(e.g. --preset quick)",
        )
    if repair:
        raise store.DatasetError(f"--repair: there is no dataset at {out} to repair")
    if config is None:
        raise ValueError("give a preset name or a GenerationConfig (or resume an existing store)")
    # --resume and --overwrite act only on a dataset, so a directory of other files is
    # refused first, without suggesting them.
    if occupied and not store.is_store(out):
        raise FileExistsError(
            f"--out {out} exists and is not a tactile-synth dataset; refusing to overwrite "
            f"it (choose another --out or delete it yourself)"
        )
    if occupied and not overwrite:
        hint = (
            f" (an interrupted --overwrite left a replacement at {pending}: --resume finishes it)"
            if _has_meta(pending)
            else ""
        )
        raise FileExistsError(
            f"--out {out} exists and is not empty{hint}; pass --resume to complete it, "
            f"--overwrite to replace it, or choose another path"
        )
    synth = dict(config.synth) if config.synth is not None else config_mod.default_synth_config()
    config_mod.validate_synth_config(synth)
    config = config.replace(synth=synth)
    if mujoco_plans:
        validate_grid(config)
    check_resources(config, out, workers=workers, local=local)
    # Every check passed: build the new store's skeleton beside the path.
    if pending.exists():
        shutil.rmtree(pending)  # an unfinished replacement or skeleton of ours
    store_id = store.create(pending, config)
    if occupied:
        return Job(config, pending, store_id, list(range(config.n_chunks)), replacing=True)
    os.rename(pending, out)  # out is absent or an empty directory
    return Job(config, out, store_id, list(range(config.n_chunks)))


def generate(
    config: GenerationConfig | str | None,
    out: str | Path,
    *,
    workers: int | None = None,
    threads: int | None = None,
    executor: cf.Executor | None = None,
    resume: bool = False,
    overwrite: bool = False,
    repair: bool = False,
    progress: bool = True,
    simulator: Simulator | None = None,
) -> Path:
    """Simulate a dataset into the store ``out``, resumable and checked.

    Parameters
    ----------
    config : GenerationConfig or str or None
        The grid (classes, conditions, trials per class, seed, simulator settings) or a
        preset name (``"quick"``, ``"paper"``, ``"perturbation"``); None with ``resume``:
        the stored one.
    out : str or pathlib.Path
        The store's directory.
    workers : int, optional
        Local processes (default 1: this process, two chunk tasks at a time; N > 1: a
        pool of N processes, faster where many cores would make one process's Python
        the bottleneck).
    threads : int, optional
        MuJoCo rollout threads per task (default: half of
        ``tactile_synth.threads.rollout_threads()`` in this process, for each of its two
        tasks; in a pool, each process's share of the CPUs; 1 on an executor); in a pool
        or on an executor it sizes the worker's BLAS/OpenMP pools too.
    executor : concurrent.futures.Executor, optional
        Any executor (e.g. a Dask client's ``get_executor()``); its workers must see
        ``out``.
    resume : bool, default False
        Complete an interrupted store (or an interrupted overwrite) without recomputing
        its finished chunks; it refuses a store with damaged chunks unless ``repair``,
        which re-simulates exactly those.
    overwrite : bool, default False
        Build a new store beside ``out`` and put it in place when complete.
    progress : bool, default True
        Report the trials done on stderr (:func:`synth.progress.progress`: a bar on a
        terminal, plain lines elsewhere).
    simulator : callable, optional
        Replaces MuJoCo (tests of the machinery only).

    Returns
    -------
    pathlib.Path
        ``out``.

    Raises
    ------
    synth.store.DatasetLocked
        At once, if another process is writing ``out``.

    Examples
    --------
    >>> import tempfile, synth
    >>> grid = synth.PRESETS["quick"].replace(materials=("wood",), trials_per_class=1)
    >>> grid.n_trials
    12
    >>> path = synth.generate(grid, tempfile.mkdtemp() + "/ds", progress=False)
    >>> len(synth.load_dataset(path))
    12
    """
    out = Path(out)
    workers = 1 if workers is None else check_int("workers", workers, minimum=1)
    if threads is not None:
        check_int("threads", threads, minimum=1)
    local = executor is None
    check_parallelism(workers, threads, local=local)
    atomic.check_dir_path(out)
    with store.locked(out):
        job = prepare(
            config,
            out,
            resume=resume,
            overwrite=overwrite,
            repair=repair,
            workers=workers,
            local=local,
            mujoco_plans=simulator is None,
        )
        if job.todo:
            store.remove_partial_files(job.target)
        if job.clear:
            store.clear_chunks(job.target, job.clear)
        if job.rewrite:
            store.rewrite_plan(job.target, job.rewrite)
        _run(job, workers, threads, executor, progress, simulator)
        if job.replacing:
            atomic.replace_dir(job.target, out)
    return out


def _run(
    job: Job,
    workers: int,
    threads: int | None,
    executor: cf.Executor | None,
    progress: bool,
    simulator: Simulator | None,
) -> None:
    config, todo = job.config, job.todo
    trials = plan(config)
    c = config.chunk_trials
    done_trials = len(trials) - sum(min(c, len(trials) - k * c) for k in todo)
    if not todo:
        return

    owned: cf.Executor | None = None
    task = run_chunk
    if executor is None:
        workers = max(min(workers, len(todo)), 1)  # no idle processes for a small run
        if workers == 1:
            # Two tasks overlap: while one runs its sensor chain and writes (Python, GIL),
            # the other's rollout keeps the cores busy. They share this process's rollout
            # threads: the closed loop calls the rollout once per surface update, and
            # threads beyond the cores would spend each call's barrier waiting for a core.
            owned = executor = cf.ThreadPoolExecutor(max_workers=2, thread_name_prefix="chunk")
            threads = threads or max(1, rollout_threads() // 2)
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

    bar = show_progress(
        len(trials),
        desc=f"generate {config.preset}",
        initial=done_trials,
        enabled=progress,
        smoothing=0.1,
    )
    pending: set[cf.Future] = set()
    queue = iter(todo)
    # Ctrl-C (and SIGTERM, as the CLI runs it) stops at the next chunk boundary.
    stop = StopRequests(
        "tactile-synth generate: stopping after the running chunks (Ctrl-C again: now)"
    )
    target = str(job.target)
    try:
        with stop:
            while True:
                # Bounded submission keeps memory flat and lets Ctrl-C stop quickly.
                for k in queue:
                    specs = trials.specs(k * c, (k + 1) * c)
                    args = (target, k, specs, config.synth, threads, simulator, job.store_id)
                    pending.add(executor.submit(task, *args))
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
    done = store.Store.open(job.target).status()[0]
    if not done.all():  # pragma: no cover - every task either finished or raised
        raise RuntimeError(f"{job.target}: {int((~done).sum())} chunks still missing after the run")
