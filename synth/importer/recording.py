"""One recording (CSV or NPZ) read and checked: four channels in volts."""

from __future__ import annotations

import csv
import dataclasses
import hashlib
import io
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np

from tactile_synth.validation import check_choice, parse_number

from ..trial import CHANNELS
from .errors import MAX_SAMPLE_V, TIME_COLUMN, Bad, RecordingError
from .labels import check_header, check_rate


@dataclasses.dataclass
class Recording:
    """One file's samples: ``signals`` float64 ``(4, n)`` in :data:`CHANNELS` order;
    ``sample_rate_hz`` if the file states it; ``time_s`` ``(n,)`` if it has a time column
    (``time_where(i)`` names where sample ``i`` is, for messages)."""

    signals: np.ndarray
    sample_rate_hz: float | None = None
    time_s: np.ndarray | None = None
    time_where: Callable[[int], str] = dataclasses.field(default=lambda i: f"sample {i}")


def read_recording(path: str | Path, shown: str | None = None) -> tuple[Recording, str]:
    """Read one recording file (``.csv`` or ``.npz``); returns it and the SHA-256 of the
    file's bytes. ``shown``: the name used in messages (default ``path``). Raises
    :class:`RecordingError` naming the file and line at fault."""
    path = Path(path)
    shown = shown or str(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise RecordingError([f"{shown} cannot be read ({exc.strerror or exc})"]) from None
    try:
        if path.suffix.lower() == ".npz":
            rec = _read_npz(data, shown)
        else:
            rec = _read_csv(data, shown)
    except Bad as exc:
        raise RecordingError([str(exc)]) from None
    return rec, hashlib.sha256(data).hexdigest()


def _read_csv(data: bytes, shown: str) -> Recording:
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise Bad(f"{shown} is not UTF-8 text (byte {exc.start} cannot be decoded)") from None
    lines = text.splitlines()
    while lines and not lines[-1].strip():
        lines.pop()
    allowed = (*CHANNELS, TIME_COLUMN)
    if not lines:
        raise Bad(f"{shown} is empty; its first line names the columns ({', '.join(allowed)})")
    names = [h.strip().lower() for h in next(csv.reader(lines[:1]))]
    check_header(names, allowed, f"{shown} line 1", lines[0])
    channels = [n for n in names if n in CHANNELS]
    if len(channels) != len(CHANNELS):
        missing = [c for c in CHANNELS if c not in names]
        raise Bad(
            f"{shown} line 1 names {len(channels)} channels ({', '.join(channels) or 'none'}); "
            f"a recording has the {len(CHANNELS)} channels {', '.join(CHANNELS)} "
            f"(missing: {', '.join(missing)})"
        )
    body = lines[1:]
    if not body:
        raise Bad(f"{shown} has a header but no samples")
    for i, line in enumerate(body):
        if not line.strip():
            raise Bad(f"{shown} line {i + 2} is empty")
    try:
        values = np.loadtxt(body, delimiter=",", dtype=np.float64, ndmin=2, comments=None)
        if values.shape != (len(body), len(names)):
            raise ValueError("shape")
    except ValueError:
        values = _parse_csv_rows(body, names, shown)  # names the line at fault
    bad = np.argwhere(~np.isfinite(values))
    if bad.size:
        r, c = (int(v) for v in bad[0])
        raise Bad(
            f"{shown} line {r + 2}, column {names[c]}: {values[r, c]} (every sample must be "
            f"a finite number)"
        )
    channel = np.array([n in CHANNELS for n in names])
    huge = np.argwhere((np.abs(values) > MAX_SAMPLE_V) & channel)
    if huge.size:
        r, c = (int(v) for v in huge[0])
        raise Bad(
            f"{shown} line {r + 2}, column {names[c]}: {values[r, c]:g} V is beyond the "
            f"+-{MAX_SAMPLE_V:.3g} V a float32 sample holds"
        )
    signals = values[:, [names.index(ch) for ch in CHANNELS]].T.copy()
    times = values[:, names.index(TIME_COLUMN)] if TIME_COLUMN in names else None
    return Recording(signals, None, times, lambda i: f"line {i + 2}")


def _parse_csv_rows(body: list[str], names: list[str], shown: str) -> np.ndarray:
    """The rows parsed cell by cell (slow), raising at the first bad line."""
    out = np.empty((len(body), len(names)))
    for i, cells in enumerate(csv.reader(body)):
        line = i + 2
        if len(cells) != len(names):
            raise Bad(
                f"{shown} line {line} has {len(cells)} values; the header names "
                f"{len(names)} columns ({', '.join(names)})"
            )
        for j, cell in enumerate(cells):
            text = cell.strip()
            if not text:
                raise Bad(f"{shown} line {line}, column {names[j]} is empty")
            try:
                out[i, j] = parse_number(text, float)
            except ValueError as exc:
                raise Bad(f"{shown} line {line}, column {names[j]}: {exc}") from None
    return out


def _read_npz(data: bytes, shown: str) -> Recording:
    allowed = ("signals", *CHANNELS, TIME_COLUMN, "sample_rate_hz")
    try:
        npz = np.load(io.BytesIO(data), allow_pickle=False)
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as exc:
        raise Bad(f"{shown} is not a readable .npz file ({exc})") from None
    if not isinstance(npz, np.lib.npyio.NpzFile):
        raise Bad(f"{shown} holds a single .npy array, not an .npz archive of named arrays")
    arrays: dict[str, np.ndarray] = {}
    with npz:
        for key in npz.files:
            try:
                check_choice("array", key, allowed)
            except ValueError as exc:
                raise Bad(f"{shown}: {exc}") from None
            try:
                arrays[key] = npz[key]
            except (ValueError, OSError, zipfile.BadZipFile, EOFError) as exc:
                raise Bad(f"{shown}: array {key!r} cannot be read ({exc})") from None
    for key, arr in arrays.items():
        kind = arr.dtype.kind
        if kind not in "iuf":
            raise Bad(f"{shown}: array {key!r} holds {arr.dtype} values, not real numbers")
    per_channel = [ch for ch in CHANNELS if ch in arrays]
    if "signals" in arrays:
        if per_channel:
            raise Bad(
                f"{shown} holds both 'signals' and per-channel arrays ({', '.join(per_channel)})"
                f"; keep one or the other"
            )
        x = arrays["signals"]
        if x.ndim != 2 or x.shape[0] != len(CHANNELS):
            raise Bad(
                f"{shown}: array 'signals' has shape {x.shape}; it must be ({len(CHANNELS)}, n)"
                f": the channels {', '.join(CHANNELS)}, then the samples"
            )
        signals = x.astype(np.float64)
    else:
        if len(per_channel) != len(CHANNELS):
            missing = [c for c in CHANNELS if c not in arrays]
            raise Bad(
                f"{shown} holds {len(per_channel)} of the {len(CHANNELS)} channel arrays "
                f"(missing: {', '.join(missing)}); a recording has {', '.join(CHANNELS)} "
                f"(or one 'signals' array of shape ({len(CHANNELS)}, n))"
            )
        lengths = {ch: arrays[ch].shape for ch in CHANNELS}
        if any(len(s) != 1 for s in lengths.values()) or len(set(lengths.values())) != 1:
            shapes = ", ".join(f"{ch} {s}" for ch, s in lengths.items())
            raise Bad(f"{shown}: the channel arrays must be 1-D and equally long; got {shapes}")
        signals = np.stack([arrays[ch] for ch in CHANNELS]).astype(np.float64)
    if signals.shape[1] == 0:
        raise Bad(f"{shown} holds no samples")
    bad = np.argwhere(~np.isfinite(signals))
    if bad.size:
        c, i = (int(v) for v in bad[0])
        raise Bad(
            f"{shown}: channel {CHANNELS[c]} at sample index {i} is {signals[c, i]} (every "
            f"sample must be a finite number)"
        )
    huge = np.argwhere(np.abs(signals) > MAX_SAMPLE_V)
    if huge.size:
        c, i = (int(v) for v in huge[0])
        raise Bad(
            f"{shown}: channel {CHANNELS[c]} at sample index {i} is {signals[c, i]:g} V, beyond "
            f"the +-{MAX_SAMPLE_V:.3g} V a float32 sample holds"
        )
    rate = None
    if "sample_rate_hz" in arrays:
        r = arrays["sample_rate_hz"]
        if r.size != 1:
            raise Bad(f"{shown}: array 'sample_rate_hz' must be one number; got shape {r.shape}")
        try:
            rate = check_rate(float(r.reshape(())), "array 'sample_rate_hz'")
        except Bad as exc:
            raise Bad(f"{shown}: {exc}") from None
    times = None
    if TIME_COLUMN in arrays:
        times = arrays[TIME_COLUMN].astype(np.float64)
        if times.shape != (signals.shape[1],):
            raise Bad(
                f"{shown}: array {TIME_COLUMN!r} has shape {times.shape}; it must hold one time "
                f"per sample, ({signals.shape[1]},)"
            )
        if not np.all(np.isfinite(times)):
            i = int(np.flatnonzero(~np.isfinite(times))[0])
            raise Bad(f"{shown}: array {TIME_COLUMN!r} at index {i} is {times[i]}")
    return Recording(signals, rate, times, lambda i: f"index {i} of array {TIME_COLUMN!r}")
