"""Shared test configuration. Fixtures stay tiny and inline; slow end-to-end tests are
marked ``@pytest.mark.slow`` (CI runs them too)."""

import os

import pytest

# Before any test module loads numpy or torch: thread pools sized to the CPUs this
# process may use, idle threads sleeping (so the suite keeps its pace beside other jobs).
import tactile_synth.threads  # noqa: F401

# Keep matplotlib headless.
os.environ.setdefault("MPLBACKEND", "Agg")


@pytest.fixture(autouse=True)
def _environment_as_found():
    """Every test hands the process environment back as it found it.

    Some libraries write to ``os.environ`` behind the test's back: a Dask ``LocalCluster``
    started in this process sets ``MALLOC_TRIM_THRESHOLD_=65536`` here (its nannies'
    pre-spawn environment). Every process a later test spawns would inherit it, and with
    that trim threshold glibc hands each freed array back to the kernel, so a worker
    pool's fits spend much of their time faulting memory in again.
    """
    before = dict(os.environ)
    yield
    for name in set(os.environ) - set(before):
        del os.environ[name]
    for name, value in before.items():
        if os.environ.get(name) != value:
            os.environ[name] = value


@pytest.fixture
def one_torch_thread():
    """One torch thread for the test: on a shared 2-core machine torch's default intra-op
    pool oversubscribes the cores and a training-heavy test slows down several-fold."""
    import torch

    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)
