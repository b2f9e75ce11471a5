"""The allocator thresholds (``tactile_synth.allocator``): freed blocks of tens of MB are
reused without faulting their pages in again, and users keep their own settings."""

from __future__ import annotations

import os

import pytest

from tests.fresh_interpreter import run_json

_VARS = (
    "TACTILE_SYNTH_MALLOC",
    "MALLOC_MMAP_THRESHOLD_",
    "MALLOC_TRIM_THRESHOLD_",
    "GLIBC_TUNABLES",
)

# Allocates, writes and frees a 48 MB block ten times (libc's malloc: numpy would ask for
# huge pages, which hide the faults) and counts the page faults of the loop.
PROBE = """
import ctypes, ctypes.util, json, resource
import tactile_synth
libc = ctypes.CDLL(ctypes.util.find_library("c"))
libc.malloc.restype = ctypes.c_void_p
libc.free.argtypes = (ctypes.c_void_p,)
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(10):
    block = libc.malloc(48_000_000)
    ctypes.memset(block, 1, 48_000_000)
    libc.free(block)
faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before
print(json.dumps({"tuned": tactile_synth.allocator.TUNED, "faults": faults}))
"""
PAGES = 48_000_000 // 4096  # pages of one array


def probe(**env: str) -> dict:
    return run_json(PROBE, _VARS, **env)


def _is_glibc() -> bool:
    try:
        return (os.confstr("CS_GNU_LIBC_VERSION") or "").startswith("glibc")
    except (AttributeError, ValueError, OSError):
        return False


glibc = pytest.mark.skipif(not _is_glibc(), reason="mallopt thresholds are glibc's")


@glibc
def test_freed_blocks_are_reused_without_faulting_again():
    tuned = probe()
    system = probe(TACTILE_SYNTH_MALLOC="system")
    assert tuned["tuned"] and not system["tuned"]
    # glibc's defaults map and unmap the block every time: ten arrays' worth of faults.
    assert system["faults"] > 8 * PAGES
    # Tuned: the first array faults its pages in, the others reuse them.
    assert tuned["faults"] < 2 * PAGES


@glibc
@pytest.mark.parametrize(
    "env",
    [
        {"MALLOC_TRIM_THRESHOLD_": "131072"},
        {"MALLOC_MMAP_THRESHOLD_": "131072"},
        {"GLIBC_TUNABLES": "glibc.malloc.trim_threshold=131072"},
        {"TACTILE_SYNTH_MALLOC": "system"},
    ],
)
def test_user_settings_are_left_alone(env):
    assert probe(**env)["tuned"] is False


def test_without_user_settings_removes_exactly_what_the_module_defers_to():
    from tactile_synth.allocator import without_user_settings

    env = {
        "PATH": "/usr/bin",
        "TACTILE_SYNTH_MALLOC": "system",
        "MALLOC_TRIM_THRESHOLD_": "65536",
        "MALLOC_MMAP_THRESHOLD_": "131072",
        "GLIBC_TUNABLES": "glibc.malloc.trim_threshold=1:glibc.elision.enable=1",
    }
    out = without_user_settings(env)
    assert out == {"PATH": "/usr/bin", "GLIBC_TUNABLES": "glibc.elision.enable=1"}
    assert env["MALLOC_TRIM_THRESHOLD_"] == "65536"  # the caller's mapping is not touched
    only_malloc = {"GLIBC_TUNABLES": "glibc.malloc.mmap_threshold=1:glibc.malloc.arena_max=2"}
    assert without_user_settings(only_malloc) == {}


@glibc
def test_a_process_started_without_user_settings_gets_the_thresholds():
    from tactile_synth.allocator import without_user_settings

    # Every setting the module would defer to, as a Dask cluster or a user leaves them.
    leftover = {
        "MALLOC_TRIM_THRESHOLD_": "65536",
        "GLIBC_TUNABLES": "glibc.malloc.trim_threshold=65536:glibc.elision.enable=1",
    }
    assert probe(**leftover)["tuned"] is False
    cleaned = without_user_settings(leftover)
    assert cleaned == {"GLIBC_TUNABLES": "glibc.elision.enable=1"}
    assert probe(**cleaned)["tuned"] is True
