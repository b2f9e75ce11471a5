"""CRC-32C checksums binding a chunk's signals to its trials, and of per-trial arrays."""

from __future__ import annotations

import numpy as np


def _readonly(a: np.ndarray, dtype: str) -> np.ndarray:
    out = np.ascontiguousarray(a, dtype=dtype)
    if out is a:
        out = out.view()
    out.flags.writeable = False  # google_crc32c takes read-only buffers without a copy
    return out


def chunk_checksum(
    signals: np.ndarray,
    label: np.ndarray,
    force_n: np.ndarray,
    speed_mm_s: np.ndarray,
    seed: np.ndarray,
) -> int:
    """CRC-32C of a chunk's signals (float32 little-endian, C order) followed by its trials'
    label (int16), force, speed (float64) and seed (int64): binds data to their trials."""
    import google_crc32c

    crc = google_crc32c.value(_readonly(signals, "<f4"))
    for values, dtype in ((label, "<i2"), (force_n, "<f8"), (speed_mm_s, "<f8"), (seed, "<i8")):
        crc = google_crc32c.extend(crc, _readonly(values, dtype))
    return int(crc)


def array_checksum(values: np.ndarray, dtype: str) -> int:
    """CRC-32C of a per-trial array as stored (little-endian ``dtype``, C order)."""
    import google_crc32c

    return int(google_crc32c.value(_readonly(values, np.dtype(dtype).newbyteorder("<").str)))
