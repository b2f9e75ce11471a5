"""Keep freed memory in the process for reuse, instead of handing it back to the OS at
every free (glibc's default).

torch trains the per-episode networks with tensors of a few to a few tens of MB that
are allocated and freed at every step. glibc serves a block above its mmap threshold
(dynamic, 128 kB to 32 MB) with a fresh ``mmap`` and unmaps it on free, and it trims
the heap's free top beyond 128 kB: every training step then faults its memory in again,
page by page, and a good part of a training loop's time goes to the kernel
(``scripts/bench_malloc.py`` measures it; ``docs/speed.md`` has the figures).

Importing this module raises both thresholds with ``mallopt`` (glibc only; elsewhere it
does nothing): blocks up to :data:`MMAP_THRESHOLD_BYTES` come from the heap, and up to
:data:`TRIM_THRESHOLD_BYTES` of free heap stay resident for the next allocation. The
cost is a resident size that stays near its peak instead of shrinking between steps.
A user who sets ``MALLOC_MMAP_THRESHOLD_``, ``MALLOC_TRIM_THRESHOLD_`` or a malloc
tunable in ``GLIBC_TUNABLES`` keeps their own settings, and ``TACTILE_SYNTH_MALLOC=system``
keeps glibc's defaults. This module imports only the standard library.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import sys
from collections.abc import Mapping

#: Largest block served from the heap: above the inputs of a stacked chunk of episodes
#: (tens of MB). glibc versions that refuse it get :data:`FALLBACK_MMAP_THRESHOLD_BYTES`.
MMAP_THRESHOLD_BYTES = 256 * 1024 * 1024
#: glibc's own upper bound for its dynamic threshold.
FALLBACK_MMAP_THRESHOLD_BYTES = 32 * 1024 * 1024
#: Free memory at the top of the heap kept before trimming.
TRIM_THRESHOLD_BYTES = 512 * 1024 * 1024

# mallopt parameter numbers (malloc.h).
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3

#: glibc's environment variables for the two thresholds: a user who sets one keeps it.
USER_VARS = ("MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_")
#: Environment variable: ``system`` leaves glibc's own thresholds in place.
MALLOC_ENV = "TACTILE_SYNTH_MALLOC"
#: Prefix of glibc's malloc tunables in ``GLIBC_TUNABLES`` (``name=value`` items joined
#: by ``:``).
_TUNABLE_PREFIX = "glibc.malloc."


def _user_settings() -> bool:
    if os.environ.get(MALLOC_ENV, "").strip().lower() == "system":
        return True
    if any(os.environ.get(v, "").strip() for v in USER_VARS):
        return True
    return _TUNABLE_PREFIX in os.environ.get("GLIBC_TUNABLES", "")


def without_user_settings(env: Mapping[str, str]) -> dict[str, str]:
    """A copy of the environment ``env`` without any allocator setting this module
    defers to: ``TACTILE_SYNTH_MALLOC``, the threshold variables and the malloc
    tunables of ``GLIBC_TUNABLES`` (its other tunables stay). A process started with it
    gets this module's thresholds, as a user who set nothing does."""
    out = {k: v for k, v in env.items() if k != MALLOC_ENV and k not in USER_VARS}
    if "GLIBC_TUNABLES" in out:
        kept = [t for t in out["GLIBC_TUNABLES"].split(":") if not t.startswith(_TUNABLE_PREFIX)]
        if any(kept):
            out["GLIBC_TUNABLES"] = ":".join(kept)
        else:
            del out["GLIBC_TUNABLES"]
    return out


def tune() -> bool:
    """Apply the thresholds to this process; True if glibc accepted both."""
    if not sys.platform.startswith("linux") or _user_settings():
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):  # not glibc (musl has no mallopt)
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    ok = mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES) or mallopt(
        _M_MMAP_THRESHOLD, FALLBACK_MMAP_THRESHOLD_BYTES
    )
    return bool(ok and mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES))


TUNED = tune()
