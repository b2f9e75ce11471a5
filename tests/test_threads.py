"""Thread pools sized in one place (``tactile_synth.threads``): CPUs from affinity and cgroup
quotas, precedence of --threads / environment / automatic share, passive idle waiting set
before numpy and torch load, one share per pool worker, thread counts that never change
generated data, and the report stating the settings."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import synth
from synth import load_dataset
from tactile_synth import threads
from tests.fresh_interpreter import ROOT, run_json

_THREAD_VARS = (
    "TACTILE_SYNTH_THREADS",
    "OMP_NUM_THREADS",
    "OPENBLAS_NUM_THREADS",
    "MKL_NUM_THREADS",
    "OMP_WAIT_POLICY",
    "GOMP_SPINCOUNT",
    "KMP_BLOCKTIME",
    "OPENBLAS_THREAD_TIMEOUT",
    "GOTO_THREAD_TIMEOUT",
)


def fresh(code: str, **env: str) -> dict:
    """Run ``code`` in a new interpreter whose thread variables are only ``env``; returns
    the JSON it prints last."""
    return run_json(code, _THREAD_VARS, **env)


SETTINGS = (
    "import json, os; from tactile_synth import threads as t; "
    "print(json.dumps({**t.thread_settings(), 'env': dict(os.environ)}))"
)


@pytest.fixture
def restore_threads():
    """Tests that reconfigure this process hand it back as they found it."""
    before = threads.settings()
    yield
    explicit = before.source == "--threads"
    threads.configure(before.threads if explicit else None, workers=before.workers)


# -- the CPUs this process may use ---------------------------------------------------------
def _fake_cgroups(tmp_path: Path, cgroup: str, mounts: str) -> tuple[Path, Path]:
    (tmp_path / "cgroup").write_text(cgroup)
    (tmp_path / "mountinfo").write_text(mounts)
    return tmp_path / "cgroup", tmp_path / "mountinfo"


def test_cgroup_v2_limit_is_the_tightest_on_the_path_to_the_root(tmp_path):
    fs = tmp_path / "fs"
    (fs / "ci.slice" / "job").mkdir(parents=True)
    (fs / "cpu.max").write_text("max 100000\n")
    (fs / "ci.slice" / "cpu.max").write_text("150000 100000\n")  # 1.5 CPUs for the slice
    (fs / "ci.slice" / "job" / "cpu.max").write_text("max 100000\n")
    files = _fake_cgroups(
        tmp_path,
        "0::/ci.slice/job\n",
        f"41 23 0:38 / {fs} rw,relatime - cgroup2 cgroup2 rw\n",
    )
    assert threads.cgroup_cpu_limit(*files) == pytest.approx(1.5)
    (fs / "ci.slice" / "cpu.max").write_text("max 100000\n")
    assert threads.cgroup_cpu_limit(*files) is None
    (fs / "ci.slice" / "cpu.max").write_text("unreadable\n")
    assert threads.cgroup_cpu_limit(*files) is None


def test_cgroup_v1_cfs_quota_inside_a_container_mount(tmp_path):
    fs = tmp_path / "cpu"
    fs.mkdir()
    (fs / "cpu.cfs_quota_us").write_text("300000\n")
    (fs / "cpu.cfs_period_us").write_text("100000\n")
    # Container view: the cgroup path equals the mount's root, which is mounted at fs.
    files = _fake_cgroups(
        tmp_path,
        "4:memory:/docker/abc\n3:cpu,cpuacct:/docker/abc\n0::/\n",
        f"32 31 0:29 /docker/abc {fs} rw,relatime - cgroup cgroup rw,cpu,cpuacct\n",
    )
    assert threads.cgroup_cpu_limit(*files) == pytest.approx(3.0)
    (fs / "cpu.cfs_quota_us").write_text("-1\n")
    assert threads.cgroup_cpu_limit(*files) is None


def test_no_cgroup_information_means_no_limit(tmp_path):
    assert threads.cgroup_cpu_limit(tmp_path / "missing", tmp_path / "missing") is None


def test_available_cpus_takes_affinity_and_rounds_the_quota_down(monkeypatch):
    affinity = len(os.sched_getaffinity(0))
    monkeypatch.setattr(threads, "cgroup_cpu_limit", lambda: None)
    assert threads.available_cpus() == affinity
    monkeypatch.setattr(threads, "cgroup_cpu_limit", lambda: 1.9)
    assert threads.available_cpus() == 1
    monkeypatch.setattr(threads, "cgroup_cpu_limit", lambda: 0.5)  # still one thread
    assert threads.available_cpus() == 1


# -- which count wins ----------------------------------------------------------------------
def test_automatic_budget_is_the_usable_cpus_and_idle_threads_sleep():
    s = fresh(SETTINGS)
    cpus = threads.available_cpus()
    assert s["source"] == "auto" and s["cpus"] == cpus
    assert s["threads"] == s["blas"] == s["openmp"] == s["torch_intra_op"] == s["rollout"] == cpus
    assert s["torch_inter_op"] == 1
    env = s["env"]
    assert env["OMP_WAIT_POLICY"] == "PASSIVE" and env["OPENBLAS_THREAD_TIMEOUT"] == "4"
    # exported for libraries loaded later and for child processes
    assert env["OMP_NUM_THREADS"] == env["OPENBLAS_NUM_THREADS"] == str(cpus)


def test_environment_and_explicit_counts_take_precedence():
    s = fresh(SETTINGS, OMP_NUM_THREADS="3")
    assert (s["threads"], s["blas"], s["source"]) == (3, 3, "OMP_NUM_THREADS")
    s = fresh(SETTINGS, OMP_NUM_THREADS="1", TACTILE_SYNTH_THREADS="5")
    assert (s["threads"], s["env"]["OMP_NUM_THREADS"]) == (5, "5")
    s = fresh(SETTINGS, OPENBLAS_NUM_THREADS="1")  # caps BLAS alone
    assert s["blas"] == 1 and s["threads"] == threads.available_cpus()
    explicit = SETTINGS.replace("print(", "t.configure(4); print(")  # --threads 4
    s = fresh(explicit, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    assert (s["threads"], s["blas"], s["env"]["OMP_NUM_THREADS"]) == (4, 4, "4")


def test_user_wait_policy_is_kept():
    assert fresh(SETTINGS, OMP_WAIT_POLICY="ACTIVE")["env"]["OMP_WAIT_POLICY"] == "ACTIVE"
    env = fresh(SETTINGS, GOMP_SPINCOUNT="1000")["env"]
    assert "OMP_WAIT_POLICY" not in env and env["GOMP_SPINCOUNT"] == "1000"


def test_bad_counts_name_their_source():
    with pytest.raises(ValueError, match=r"threads \(--threads\) must be an integer >= 1"):
        threads.configure(0)
    with pytest.raises(ValueError, match="workers must be"):
        threads.configure(workers=0)
    code = "from tactile_synth import threads as t\ntry:\n t.settings()\nexcept ValueError as e:\n"
    code += " import json; print(json.dumps(str(e)))"
    assert "OMP_NUM_THREADS must be an integer >= 1; got 'many'" in fresh(
        code, OMP_NUM_THREADS="many"
    )


def test_worker_share_divides_the_automatic_budget_only():
    code = "import json; from tactile_synth import threads as t; "
    code += "print(json.dumps([t.worker_threads(n) for n in (1, 2, 64)]))"
    cpus = threads.available_cpus()
    assert fresh(code) == [cpus, max(1, cpus // 2), 1]
    assert fresh(code, OMP_NUM_THREADS="2") == [2, 2, 2]  # a per-process count stays


# -- the settings reach the libraries --------------------------------------------------------
@pytest.mark.parametrize(
    "module", ["shapes", "synth", "models.features", "benchmark.report", "benchmark.cli"]
)
def test_every_package_sets_the_environment_before_numpy_loads(module):
    code = (
        f"import json, sys; import {module}; import numpy; order = list(sys.modules); "
        "print(json.dumps(order.index('tactile_synth.threads') < order.index('numpy')))"
    )
    assert fresh(code) is True


@pytest.mark.slow
def test_pools_of_torch_and_blas_follow_the_budget():
    code = (
        "import json; import models.nets, torch, threadpoolctl; from tactile_synth import "
        "threads as t; sizes = lambda: [torch.get_num_threads(), torch.get_num_interop_threads(),"
        " sorted({i['num_threads'] for i in threadpoolctl.threadpool_info()})]; "
        "first = sizes()[::2]; t.settings(); second = sizes(); t.configure(3); "
        "print(json.dumps([first, second, sizes()]))"
    )
    # torch and BLAS load within the budget; torch's (idle) inter-op pool is sized by the
    # first settings() after torch loads; configure() resizes everything in place.
    assert fresh(code, TACTILE_SYNTH_THREADS="1") == [[1, [1]], [1, 1, [1]], [3, 1, [3]]]


def test_any_thread_can_resize_the_blas_pools():
    # The main thread sizes the pools (when the module loads and after numpy loads); a
    # worker thread (a cluster task's) resizes them, the main thread again after it, and
    # a library's own threadpool_limits block in another thread (NCFS's) still applies.
    code = """
import json, threading, numpy, threadpoolctl
from tactile_synth import threads as t

def blas():
    return sorted({i["num_threads"] for i in threadpoolctl.threadpool_info()
                   if i["user_api"] == "blas"})

def in_thread(f):
    w = threading.Thread(target=f)
    w.start()
    w.join()

def block():
    with threadpoolctl.threadpool_limits(limits=1, user_api="blas"):
        seen.append(blas())

t.configure()
seen = [blas()]
in_thread(lambda: (t.configure(1), seen.append(blas())))
t.configure(3)
seen.append(blas())
in_thread(block)
seen.append(blas())
print(json.dumps(seen))
"""
    assert fresh(code, TACTILE_SYNTH_THREADS="2") == [[2], [1], [3], [1], [3]]


# -- generation: one share per worker, and data independent of thread counts ---------------
def _threads_probe(specs, synth_config, n_threads):
    """Stand-in simulator that writes what the worker running it was given into channel 0."""
    from threadpoolctl import threadpool_info

    blas = {i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"}
    seen = [n_threads, threads.settings().threads, max(blas), int(os.environ["OMP_NUM_THREADS"])]
    out = np.zeros((len(specs), 4, synth.N_SAMPLES), np.float32)
    out[:, 0, : len(seen)] = seen
    return out


def _tiny(**changes) -> synth.GenerationConfig:
    base = dict(shapes=("square",), materials=("wood",), trials_per_class=4, chunk_trials=2)
    return synth.GenerationConfig(**{**base, **changes})


@pytest.mark.slow
def test_process_pool_workers_each_get_one_share(tmp_path, monkeypatch):
    share = threads.worker_threads(2)
    monkeypatch.setenv("TACTILE_SYNTH_THREADS", str(share + 2))  # what workers would inherit
    out = synth.generate(
        _tiny(), tmp_path / "ds", workers=2, progress=False, simulator=_threads_probe
    )
    seen = load_dataset(out).signals[:, 0, :4]
    assert (seen == share).all(), seen


@pytest.mark.slow
def test_dask_workers_run_their_tasks_on_one_thread(tmp_path, monkeypatch):
    from dask.distributed import Client, LocalCluster

    # Workers whose environment asks for 3 threads: each task still runs on one. Dask's
    # nanny starts each worker with the parent's OPENBLAS_NUM_THREADS, so its OpenBLAS
    # pools load with 2 threads (on 2 or more CPUs), in the worker's main thread, before
    # any task runs in a thread of its own.
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "2")
    env = {"TACTILE_SYNTH_THREADS": "3", "OMP_NUM_THREADS": "3"}
    with (
        LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None, env=env) as cluster,
        Client(cluster) as client,
    ):
        out = synth.generate(
            _tiny(),
            tmp_path / "ds",
            executor=client.get_executor(),
            workers=2,
            progress=False,
            simulator=_threads_probe,
        )
    seen = load_dataset(out).signals[:, 0, :4]
    # Our budget, the settings, every BLAS pool and the exported OpenMP count: one thread.
    assert (seen == 1).all(), seen


@pytest.mark.slow
def test_generated_bytes_do_not_depend_on_thread_counts(tmp_path, restore_threads):
    config = _tiny(trials_per_class=3, chunk_trials=3)  # one rollout batch of 3 trials
    threads.configure(3)  # more threads than trials' worth of work per thread
    many = synth.generate(config, tmp_path / "many", workers=1, progress=False)
    cmd = [sys.executable, "-m", "benchmark.cli", "generate", "--out", str(tmp_path / "one"),
           "--shapes", "square", "--materials", "wood", "--trials-per-class", "3",
           "--chunk-trials", "3", "--threads", "1"]  # fmt: skip
    subprocess.run(cmd, cwd=ROOT, check=True, capture_output=True)
    a, b = load_dataset(many), load_dataset(tmp_path / "one")
    assert a.signals.tobytes() == b.signals.tobytes()
    assert np.isfinite(a.signals).all() and a.signals.std() > 0


# -- the report says which settings produced it ----------------------------------------------
def test_cli_threads_option_sizes_the_run_and_the_report_states_it(tmp_path, restore_threads):
    from benchmark.cli import main
    from tests.support import class_signals

    path = tmp_path / "ds"
    config = synth.PRESETS["quick"].replace(trials_per_class=6)
    synth.generate(config, path, workers=1, progress=False, simulator=class_signals)
    out = tmp_path / "out"
    args = ["benchmark", "closed-set", "--data", str(path), "--out", str(out)]
    assert main([*args, "--methods", "AFOP-ML", "--episodes", "5", "--threads", "1"]) == 0
    assert threads.settings().threads == 1
    line = f"- thread settings: {threads.describe()}"
    assert "1 per process (set by --threads)" in line
    assert line in (out / "report.md").read_text().splitlines()
    assert main([*args, "--threads", "0"]) == 2
