"""Every thread pool of the project, sized in one place so that a run never
oversubscribes the CPUs it may use.

The thread *budget* of a process is, in order of precedence:

1. ``--threads N`` of ``tactile-synth generate / benchmark / run`` (``configure(threads=N)``);
2. ``TACTILE_SYNTH_THREADS=N`` in the environment;
3. ``OMP_NUM_THREADS=N`` in the environment;
4. otherwise the CPUs this process may use (its CPU affinity and the cgroup CPU quota of
   a container or CI job, not the machine's core count: :func:`available_cpus`), divided
   among the worker processes the run starts.

The budget sizes torch's intra-op pool, the OpenMP runtimes (torch's, scikit-learn's),
the BLAS libraries (numpy's and scipy's OpenBLAS, torch's MKL) and the MuJoCo rollout
threads. ``OPENBLAS_NUM_THREADS`` / ``MKL_NUM_THREADS`` set by the user cap the BLAS pools
alone (unless ``--threads`` is given). torch's inter-op pool gets one thread: nothing here
runs inter-op parallel work. A process pool (``generate --workers N``) or a cluster worker
gets one share: ``N`` workers split the budget, each sizes its own pools in its
initializer. The chosen counts are exported as ``OMP_NUM_THREADS``,
``OPENBLAS_NUM_THREADS`` and ``MKL_NUM_THREADS``, so libraries loaded later and child
processes start within the budget.

Idle pool threads wait passively. By default GNU OpenMP lets an idle thread spin for
about 300,000 iterations (and OpenBLAS for 2^28 cycles) before it sleeps, so that the
next parallel region starts a few microseconds sooner. On an idle machine that costs
nothing; beside another job the spinning threads take the CPU from the threads doing the
work, and a run slows down by far more than its fair share. Importing this module sets
``OMP_WAIT_POLICY=PASSIVE`` (GNU and Intel OpenMP: sleep at once) and
``OPENBLAS_THREAD_TIMEOUT=4`` (OpenBLAS: sleep after 2^4 cycles) unless the user set them
or ``GOMP_SPINCOUNT`` / ``KMP_BLOCKTIME``. Each runtime reads these once, when its
library loads, which is why every tactile-synth package imports this module before numpy
or torch; this module itself imports only the standard library.

Thread counts never change generated data (every trial is simulated alone from its own
seed). Benchmark results are bit-identical for the same seed and thread settings;
:func:`describe` states the settings in the report.
"""

from __future__ import annotations

import math
import os
import sys
import threading
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

#: Environment variable equivalent to ``--threads``.
THREADS_ENV = "TACTILE_SYNTH_THREADS"
_OMP = "OMP_NUM_THREADS"
_BLAS_VARS = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")

#: Idle-wait settings: variable -> (value, user variables that leave it alone when set).
PASSIVE_WAIT: dict[str, tuple[str, tuple[str, ...]]] = {
    "OMP_WAIT_POLICY": ("PASSIVE", ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT", "KMP_BLOCKTIME")),
    "OPENBLAS_THREAD_TIMEOUT": ("4", ("OPENBLAS_THREAD_TIMEOUT", "GOTO_THREAD_TIMEOUT")),
}

#: What ``--threads`` does, for the CLI's help.
HELP = (
    "threads per process for every pool: MuJoCo rollout, BLAS/OpenMP, torch "
    f"(default: ${THREADS_ENV}, else $OMP_NUM_THREADS, else the CPUs this process may use "
    "(affinity, cgroup quota) divided among its worker processes); idle threads sleep"
)

# The thread variables as the user set them, before this module exports its own.
_USER_ENV: dict[str, str] = {
    k: os.environ[k] for k in (THREADS_ENV, _OMP, *_BLAS_VARS) if os.environ.get(k, "").strip()
}


@dataclass(frozen=True)
class ThreadSettings:
    """The thread counts of this process and where they come from.

    Attributes
    ----------
    cpus: CPUs this process may use (:func:`available_cpus`).
    workers: processes the automatic budget is divided among (1 unless a pool shares it).
    threads: the budget. source: what chose it: ``"--threads"`` (or ``configure(threads=N)``),
    ``"TACTILE_SYNTH_THREADS"`` or ``"OMP_NUM_THREADS"`` (the environment), or ``"auto"``
    (``cpus`` divided by ``workers``).
    torch_intra_op, torch_inter_op, blas, openmp, rollout: each pool's thread count
    (``rollout``: MuJoCo rollout threads of one simulation task).
    wait_policy: ``OMP_WAIT_POLICY`` in effect (``PASSIVE`` unless the user chose).
    """

    cpus: int
    workers: int
    threads: int
    source: str
    torch_intra_op: int
    torch_inter_op: int
    blas: int
    openmp: int
    rollout: int
    wait_policy: str


_lock = threading.RLock()
_current: ThreadSettings | None = None


# -- the CPUs this process may use ---------------------------------------------------------
def _read(path: Path) -> str | None:
    try:
        return path.read_text().strip()
    except OSError:
        return None


def _ratio(quota: str | None, period: str | None) -> float | None:
    """quota / period in CPUs; ``None`` for no limit ("max", -1) or an unreadable file."""
    try:
        q, p = int(quota or ""), int(period or "")
    except ValueError:
        return None
    return q / p if q > 0 and p > 0 else None


def _quota_v2(directory: Path) -> float | None:
    parts = (_read(directory / "cpu.max") or "").split()  # "max 100000", "<quota> <period>"
    return _ratio(*parts) if len(parts) == 2 else None


def _quota_v1(directory: Path) -> float | None:
    return _ratio(_read(directory / "cpu.cfs_quota_us"), _read(directory / "cpu.cfs_period_us"))


def cgroup_cpu_limit(
    cgroup_file: str | Path = "/proc/self/cgroup",
    mountinfo_file: str | Path = "/proc/self/mountinfo",
) -> float | None:
    """The CPU bandwidth the cgroups of this process allow, in CPUs (``None``: no limit).

    Reads cgroup v2 ``cpu.max`` or v1 ``cpu.cfs_quota_us / cpu.cfs_period_us`` of this
    process's cgroup and of every ancestor up to the mount point (a limit set on a parent,
    e.g. a systemd slice or a CI job's container, binds its children too); the smallest
    wins. Linux only; elsewhere (no ``/proc``) returns ``None``.
    """
    cgroups = _read(Path(cgroup_file))
    mounts = _read(Path(mountinfo_file))
    if not cgroups or not mounts:
        return None
    limits: list[float] = []
    for line in cgroups.splitlines():
        hier, _, rest = line.partition(":")
        controllers, _, path = rest.partition(":")
        v2 = hier == "0" and controllers == ""
        if not v2 and "cpu" not in controllers.split(","):
            continue
        for mount in mounts.splitlines():
            fields = mount.split()
            if " - " not in mount or len(fields) < 5:
                continue
            post = mount.split(" - ", 1)[1].split()
            fstype, options = post[0], post[2].split(",") if len(post) > 2 else []
            if (v2 and fstype != "cgroup2") or (
                not v2 and (fstype != "cgroup" or "cpu" not in options)
            ):
                continue
            root, mount_point = fields[3], Path(fields[4])
            relative = path[len(root) :] if path.startswith(root) and root != "/" else path
            directory = mount_point / relative.lstrip("/")
            read = _quota_v2 if v2 else _quota_v1
            while True:
                limit = read(directory)
                if limit is not None:
                    limits.append(limit)
                if directory == mount_point or mount_point not in directory.parents:
                    break
                directory = directory.parent
            break
    return min(limits) if limits else None


def available_cpus() -> int:
    """CPUs this process may use: its affinity mask, capped by the cgroup CPU quota
    (rounded down: a fractional CPU gives no extra thread its time), at least 1."""
    try:
        cpus = len(os.sched_getaffinity(0))
    except AttributeError:  # no affinity API (macOS, Windows)
        cpus = os.cpu_count() or 1
    quota = cgroup_cpu_limit()
    if quota is not None:
        cpus = min(cpus, math.floor(quota))
    return max(1, cpus)


# -- choosing and applying the counts ------------------------------------------------------
def _check_count(arg: str, value: object) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ValueError(f"{arg} must be an integer >= 1; got {value!r}")
    return value


def _env_count(name: str) -> int | None:
    """A thread-count variable of the user's environment (OpenMP's ``4,2`` nested form:
    the first level), or ``None`` when unset."""
    text = _USER_ENV.get(name)
    if text is None:
        return None
    first = text.split(",")[0].strip()
    if not first.isdigit() or int(first) < 1:
        raise ValueError(f"environment variable {name} must be an integer >= 1; got {text!r}")
    return int(first)


def _resolve(threads: int | None, workers: int) -> ThreadSettings:
    cpus = available_cpus()
    blas_user = [n for n in (_env_count(v) for v in _BLAS_VARS) if n is not None]
    env = None
    if threads is not None:
        budget, source, blas = threads, "--threads", threads
    else:
        env = next(((v, n) for v in (THREADS_ENV, _OMP) if (n := _env_count(v)) is not None), None)
        if env is not None:
            budget, source = env[1], env[0]
        else:
            budget = max(1, cpus // workers)
            source = "auto"
        blas = min(blas_user) if blas_user else budget
    return ThreadSettings(
        cpus=cpus,
        workers=workers,
        threads=budget,
        source=source,
        torch_intra_op=budget,
        torch_inter_op=1,
        blas=blas,
        openmp=budget,
        rollout=budget,
        wait_policy=os.environ.get("OMP_WAIT_POLICY", "default"),
    )


def _set_passive_wait() -> None:
    for name, (value, user_vars) in PASSIVE_WAIT.items():
        if not any(os.environ.get(v, "").strip() for v in user_vars):
            os.environ[name] = value


def _export(s: ThreadSettings) -> None:
    """The counts as environment variables: libraries loaded later (torch reads
    ``OMP_NUM_THREADS`` at its first parallel region) and child processes start with them."""
    os.environ[_OMP] = str(s.openmp)
    for name in _BLAS_VARS:
        os.environ[name] = str(s.blas)


def _apply_loaded(s: ThreadSettings) -> ThreadSettings:
    """Set the pools of the libraries already loaded; returns the settings as applied."""
    if any(m in sys.modules for m in ("numpy", "scipy", "sklearn", "torch")):
        import threadpoolctl

        # threadpoolctl (>= 3.8) lets only one Python thread, the first to set it, size a
        # pthreads OpenBLAS (its pool is process-wide) and silently ignores the others. A
        # cluster worker imports this module, and so sets the pool, in its main thread,
        # then runs tasks in a thread of its own: the task's share would be ignored. The
        # budget is this process's, whichever thread sets it, so control is taken for the
        # call and released after it.
        release = getattr(threadpoolctl.OpenBLASController, "clear_controlling_thread", None)
        if release is not None:
            release(force=True)
        controller = threadpoolctl.ThreadpoolController()
        controller.limit(limits=s.blas, user_api="blas")
        controller.limit(limits=s.openmp, user_api="openmp")
        if release is not None:
            release()
    torch = sys.modules.get("torch")
    if torch is not None and hasattr(torch, "set_num_threads"):
        torch.set_num_threads(s.torch_intra_op)
        if torch.get_num_interop_threads() != s.torch_inter_op:
            try:
                torch.set_num_interop_threads(s.torch_inter_op)
            except RuntimeError:  # only possible before inter-op work started: keep it
                pass
        s = replace(s, torch_inter_op=torch.get_num_interop_threads())
    return s


def configure(threads: int | None = None, *, workers: int = 1) -> ThreadSettings:
    """Size every thread pool of this process; returns the settings.

    threads: the budget of this process (``--threads``); ``None``: from the environment,
    else :func:`available_cpus` divided by ``workers`` (the processes sharing this
    machine's CPUs in this run). Call it again at any time: pools of libraries already
    loaded are resized, libraries loaded later start at the new size.
    """
    global _current
    if threads is not None:
        _check_count("threads (--threads)", threads)
    _check_count("workers", workers)
    with _lock:
        s = _resolve(threads, workers)
        _export(s)
        _current = _apply_loaded(s)
        return _current


def settings() -> ThreadSettings:
    """The settings in effect (torch's pools re-applied if torch loaded since)."""
    global _current
    with _lock:
        if _current is None:
            return configure()
        _current = _apply_loaded(_current)
        return _current


def thread_settings() -> dict[str, Any]:
    """:func:`settings` as a plain dict (for results and reports)."""
    return asdict(settings())


def describe(workers: int | None = None) -> str:
    """One line for a report: every pool's thread count and how it was chosen; with
    ``workers``, those of each of the ``workers`` processes this process starts (see
    :func:`worker_threads`)."""
    s = settings()
    if workers is not None and workers > 1:
        explicit = s.threads if s.source == "--threads" else None
        s = replace(_resolve(explicit, workers), torch_inter_op=s.torch_inter_op)
    if s.source == "auto":
        how = f"{s.cpus} usable CPUs / {s.workers} worker{'s' * (s.workers > 1)}"
    else:
        how = "set by --threads" if s.source == "--threads" else f"from ${s.source}"
    return (
        f"{s.threads} per process ({how}): torch intra-op {s.torch_intra_op}, "
        f"inter-op {s.torch_inter_op}; BLAS {s.blas}; OpenMP {s.openmp}; "
        f"MuJoCo rollout {s.rollout}; OMP_WAIT_POLICY={s.wait_policy}"
    )


def rollout_threads() -> int:
    """MuJoCo rollout threads for a simulation task running in this process."""
    return settings().rollout


def worker_threads(workers: int) -> int:
    """The budget of each of ``workers`` processes this process starts: ``--threads`` or
    the environment's count if set, else :func:`available_cpus` divided among them."""
    _check_count("workers", workers)
    s = settings()
    return max(1, s.cpus // workers) if s.source == "auto" else s.threads


def init_worker(threads: int) -> None:
    """Process-pool initializer: this worker's pools get its share, ``threads``."""
    configure(threads)


_set_passive_wait()
try:
    configure()
except ValueError:  # a malformed variable: reported by the first explicit configure()
    pass
