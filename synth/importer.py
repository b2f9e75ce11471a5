"""Real recordings into a dataset store (``tactile-synth import``).

The input is a folder with one recording per trial, a CSV or NPZ file of the four
channels ``pvdf1, pvdf2, sg1, sg2`` in volts, and a table of labels (CSV) naming each
file's shape, material, normal force and sliding speed (docs/recordings.md has the
layout with an example). Each recording is checked, brought to the DAQ rate of the
simulator (:data:`synth.trial.SAMPLE_RATE_HZ`) with an anti-aliasing polyphase filter,
and cut to one 2 s window (:data:`synth.trial.N_SAMPLES`): centred on the contact phase
found in the strain-gauge channels, or from a given start. The windows go into the same
Zarr store the simulator writes (kind ``"imported"``, see :mod:`synth.store`), so
``load_dataset``, ``inspect``, ``diagnose`` and ``benchmark`` read it unchanged.

Every problem is reported with the file and line at fault. The store is built beside
``--out`` under the dataset's lock and renamed into place only once complete and
verified: a failed or interrupted import leaves nothing behind and any previous dataset
whole.
"""

from __future__ import annotations

import csv
import dataclasses
import hashlib
import io
import math
import os
import shutil
import warnings
import zipfile
from collections.abc import Callable, Sequence
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from shapes import SHAPE_NAMES
from shapes.validation import check_choice, check_int, parse_number
from tactile_synth.interrupts import StopRequests

from . import atomic, store
from .materials import MATERIAL_NAMES
from .presets import (
    MAX_CHUNK_TRIALS,
    PHYSICAL_FORCE_RANGE_N,
    PHYSICAL_SPEED_RANGE_MM_S,
    TrialPlan,
    condition_name,
)
from .progress import progress as show_progress
from .trial import CHANNELS, N_SAMPLES, SAMPLE_RATE_HZ, TrialSpec, class_index

#: Columns every labels table has: the recording file (relative to the recordings
#: folder), the class, and the trial's nominal force and speed set-points.
REQUIRED_COLUMNS: tuple[str, ...] = ("file", "shape", "material", "force_n", "speed_mm_s")
#: Optional columns: ``trial`` (trial number within its class and condition) and ``seed``
#: (an integer id of the trial) must be filled on every row when present;
#: ``sample_rate_hz`` and ``window_start_s`` may be left empty on some rows.
OPTIONAL_COLUMNS: tuple[str, ...] = ("trial", "seed", "sample_rate_hz", "window_start_s")
LABEL_COLUMNS: tuple[str, ...] = REQUIRED_COLUMNS + OPTIONAL_COLUMNS
#: Default name of the labels table inside the recordings folder.
LABELS_FILE = "labels.csv"
#: Optional column (CSV) or array (NPZ) of sample times in seconds.
TIME_COLUMN = "time_s"
RECORDING_SUFFIXES: tuple[str, ...] = (".csv", ".npz")

#: Highest sample rate accepted: twice the 500 kS/s per channel of the paper's DAQ
#: (NI USB-6346); a larger value is a unit mistake (e.g. samples per minute).
MAX_SAMPLE_RATE_HZ: float = 1e6
#: Lowest sample rate accepted: a 2 s window at 10 Hz holds 20 samples, too few to show
#: a slide; a smaller value is a unit mistake (e.g. kHz for Hz).
MIN_SAMPLE_RATE_HZ: float = 10.0
#: Longest recording accepted, in seconds at SAMPLE_RATE_HZ (checked before resampling):
#: an hour is far beyond one slide and its four channels stay near 100 MB in memory.
MAX_RECORDING_S: float = 3600.0
#: Largest magnitude of a sample: the store holds float32 volts.
MAX_SAMPLE_V: float = float(np.finfo(np.float32).max)
#: Two statements of one recording's sample rate (the labels table, the file, the time
#: column, --sample-rate) must agree this closely (relative): 0.5 % of the 2 s window is
#: 10 ms, 0.1 mm of sliding at 10 mm/s, a fifth of the 0.5 mm fingerprint ridge period.
RATE_TOLERANCE: float = 0.005
#: A step of the time column may differ from the mean step by this fraction: rounding of
#: printed times stays far below it, a dropped or repeated sample does not.
TIME_STEP_TOLERANCE: float = 0.1
#: Largest denominator of the resampling ratio 1000 / rate (resample_poly's up/down):
#: any rate written with five significant digits is resampled exactly.
MAX_RATIO_DENOMINATOR: int = 100_000

#: The strain gauges are smoothed over 50 ms before the contact phase is looked for:
#: longer than the PVDF-like vibration and noise, shorter than crossing a 16 mm outline
#: at the paper's 10 mm/s (1.6 s).
CONTACT_SMOOTH_S: float = 0.05
#: The first and last tenth of a recording give the strain gauges' rest level (the
#: finger off the specimen, before and after the slide).
REST_FRACTION: float = 0.1
#: A sample belongs to the contact phase when a strain gauge deviates from its rest level
#: by at least this fraction of its largest deviation: a twentieth keeps the light load of
#: a finger sliding on the plate, which can be several times smaller than the bending
#: while it rides onto the outline, while slow drift and ripple stay below it.
CONTACT_FRACTION: float = 0.05
#: ... and by at least this many times the robust standard deviation of its smoothed rest
#: level; a gauge whose largest deviation stays below that shows no contact at all.
CONTACT_SNR: float = 10.0
#: Rest noise is taken as at least one step of a 16-bit +-10 V DAQ such as the paper's
#: (20 V / 2**16): a quantised, otherwise constant rest level has no smaller change.
DAQ_STEP_V: float = 20.0 / 2**16

#: How the windows are cut, recorded in the provenance of every trial.
WINDOW_CONTACT = "contact"  # centred on the contact phase found in sg1/sg2
WINDOW_GIVEN = "given"  # from --window-start or the window_start_s column
WINDOW_WHOLE = "whole"  # the recording is exactly one window long


class RecordingError(ValueError):
    """Bad input recordings or labels. ``problems`` lists each one, naming the file and
    line at fault; ``str()`` shows the first three on one line."""

    def __init__(self, problems: Sequence[str]) -> None:
        self.problems = list(problems)
        if len(self.problems) == 1:
            text = self.problems[0]
        else:
            shown = "; ".join(self.problems[:3])
            more = len(self.problems) - 3
            text = f"{len(self.problems)} problems: {shown}" + (
                f"; and {more} more" if more > 0 else ""
            )
        super().__init__(text)


class RecordingWarning(UserWarning):
    """Something the import changed or left out that the user should know (resampling,
    recordings in the folder that the labels table does not list)."""


class _Bad(Exception):
    """One problem with one recording (collected into a :class:`RecordingError`)."""


# -- the labels table ----------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class LabelRow:
    """One trial of the labels table: ``line`` (1-based, in the table), ``file`` as
    written and its ``path``; the optional values are ``None`` where not given."""

    line: int
    file: str
    path: Path
    shape: str
    material: str
    force_n: float
    speed_mm_s: float
    trial: int | None = None
    seed: int | None = None
    sample_rate_hz: float | None = None
    window_start_s: float | None = None


def _number(text: str, column: str) -> float:
    try:
        value = parse_number(text, float)
    except ValueError as exc:
        raise _Bad(f"column {column}: {exc}") from None
    if not math.isfinite(value):
        raise _Bad(f"column {column}: {text!r} is not a finite number")
    return value


def _integer(text: str, column: str, maximum: int) -> int:
    try:
        value = parse_number(text, int)
    except ValueError as exc:
        raise _Bad(f"column {column}: {exc}") from None
    if not 0 <= value <= maximum:
        raise _Bad(f"column {column} must be in 0..{maximum}; got {value}")
    return value


def _in_range(value: float, column: str, unit: str, bounds: tuple[float, float]) -> float:
    lo, hi = bounds
    if not lo <= value <= hi:
        raise _Bad(
            f"column {column} must lie in {lo:g}..{hi:g} {unit} (the physical range of a "
            f"fingertip sliding over a surface); got {value:g}"
        )
    return value


def _check_header(names: list[str], allowed: Sequence[str], where: str, raw: str) -> None:
    """Refuse a header with unknown, repeated or unnamed columns (``where``: file and line)."""
    if len(names) == 1 and any(sep in raw for sep in (";", "\t")):
        sep = ";" if ";" in raw else "tab"
        raise _Bad(f"{where}: the columns are separated by {sep}; separate them with commas")
    for name in names:
        try:
            float(name)
        except ValueError:
            pass
        else:
            raise _Bad(
                f"{where} holds numbers, not column names; the first line names the columns "
                f"({', '.join(allowed)})"
            )
        if not name:
            raise _Bad(f"{where}: a column has no name")
        try:
            check_choice("column", name, allowed)
        except ValueError as exc:
            raise _Bad(f"{where}: {exc}") from None
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise _Bad(f"{where}: column {repeated[0]} appears twice")


def _read_text(path: Path, what: str) -> str:
    try:
        return path.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise RecordingError(
            [f"{path}: {what} is not UTF-8 text (byte {exc.start} cannot be decoded)"]
        ) from None


def read_labels(labels: str | Path, recordings: str | Path) -> list[LabelRow]:
    """The rows of the labels table ``labels``, every value checked; files are looked up
    in ``recordings``. Raises :class:`RecordingError` listing every bad line."""
    labels, recordings = Path(labels), Path(recordings)
    if not labels.is_file():
        raise FileNotFoundError(
            f"--labels {labels} does not exist (the table naming each recording's "
            f"{', '.join(REQUIRED_COLUMNS)})"
        )
    lines = _read_text(labels, "the labels table").splitlines()
    if not lines or not lines[0].strip():
        raise RecordingError(
            [f"{labels} line 1 is empty; it names the columns ({', '.join(REQUIRED_COLUMNS)})"]
        )
    reader = csv.reader(lines)
    header = [h.strip().lower() for h in next(reader)]
    try:
        _check_header(header, LABEL_COLUMNS, f"{labels} line 1", lines[0])
    except _Bad as exc:
        raise RecordingError([str(exc)]) from None
    missing = [c for c in REQUIRED_COLUMNS if c not in header]
    if missing:
        raise RecordingError(
            [
                f"{labels} line 1 has no column {', '.join(missing)} (a labels table has "
                f"{', '.join(REQUIRED_COLUMNS)}; optional: {', '.join(OPTIONAL_COLUMNS)})"
            ]
        )
    problems: list[str] = []
    rows: list[LabelRow] = []
    seen_files: dict[Path, int] = {}
    seen_trials: dict[tuple[int, float, float, int], int] = {}
    seen_seeds: dict[int, int] = {}
    for cells in reader:
        line = reader.line_num
        if not any(c.strip() for c in cells):
            continue  # a blank line
        where = f"{labels} line {line}"
        if len(cells) != len(header):
            problems.append(
                f"{where} has {len(cells)} cells; the header names {len(header)} columns "
                f"({', '.join(header)})"
            )
            continue
        values = {name: cell.strip() for name, cell in zip(header, cells, strict=True)}
        try:
            row = _label_row(values, line, recordings)
        except _Bad as exc:
            problems.append(f"{where}: {exc}")
            continue
        key = row.path.resolve()
        if key in seen_files:
            problems.append(f"{where}: file {row.file} is listed again (first on line "
                            f"{seen_files[key]})")  # fmt: skip
            continue
        seen_files[key] = line
        if not row.path.is_file():
            problems.append(f"{where}: file {row.file} does not exist (looked for {row.path})")
        if row.trial is not None:
            tkey = (class_index(row.shape, row.material), row.force_n, row.speed_mm_s, row.trial)
            if tkey in seen_trials:
                problems.append(
                    f"{where}: trial {row.trial} of {row.shape}/{row.material} at "
                    f"{row.force_n:g} N, {row.speed_mm_s:g} mm/s is also on line "
                    f"{seen_trials[tkey]}"
                )
            seen_trials.setdefault(tkey, line)
        if row.seed is not None:
            if row.seed in seen_seeds:
                problems.append(f"{where}: seed {row.seed} is also on line {seen_seeds[row.seed]}")
            seen_seeds.setdefault(row.seed, line)
        rows.append(row)
    if not rows and not problems:
        problems.append(f"{labels} lists no recordings (only its header line)")
    if problems:
        raise RecordingError(problems)
    return rows


def _label_row(values: dict[str, str], line: int, recordings: Path) -> LabelRow:
    for column in (*REQUIRED_COLUMNS, "trial", "seed"):
        if column in values and not values[column]:
            raise _Bad(f"column {column} is empty")
    file = values["file"]
    if Path(file).suffix.lower() not in RECORDING_SUFFIXES:
        raise _Bad(f"file {file} is neither a .csv nor a .npz recording")
    try:
        shape = check_choice("shape", values["shape"].lower(), SHAPE_NAMES)
        material = check_choice("material", values["material"].lower(), MATERIAL_NAMES)
    except ValueError as exc:
        raise _Bad(str(exc)) from None
    force = _in_range(_number(values["force_n"], "force_n"), "force_n", "N", PHYSICAL_FORCE_RANGE_N)
    speed = _in_range(
        _number(values["speed_mm_s"], "speed_mm_s"), "speed_mm_s", "mm/s", PHYSICAL_SPEED_RANGE_MM_S
    )
    trial = _integer(values["trial"], "trial", 2**31 - 1) if "trial" in values else None
    seed = _integer(values["seed"], "seed", 2**63 - 1) if "seed" in values else None
    rate = None
    if values.get("sample_rate_hz"):
        rate = _check_rate(_number(values["sample_rate_hz"], "sample_rate_hz"), "sample_rate_hz")
    start = None
    if values.get("window_start_s"):
        start = _number(values["window_start_s"], "window_start_s")
        if start < 0:
            raise _Bad(f"column window_start_s must be >= 0 s; got {start:g}")
    return LabelRow(
        line=line,
        file=file,
        path=recordings / file,
        shape=shape,
        material=material,
        force_n=force,
        speed_mm_s=speed,
        trial=trial,
        seed=seed,
        sample_rate_hz=rate,
        window_start_s=start,
    )


def _check_rate(rate: float, what: str) -> float:
    if not math.isfinite(rate) or rate <= 0:
        raise _Bad(f"{what} must be a finite number > 0 Hz; got {rate!r}")
    if rate > MAX_SAMPLE_RATE_HZ:
        raise _Bad(
            f"{what} {rate:g} Hz is above {MAX_SAMPLE_RATE_HZ:g} Hz (is it in another unit?)"
        )
    if rate < MIN_SAMPLE_RATE_HZ:
        raise _Bad(
            f"{what} {rate:g} Hz is below {MIN_SAMPLE_RATE_HZ:g} Hz (is it in another unit?)"
        )
    return rate


# -- one recording -------------------------------------------------------------------------
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
    except _Bad as exc:
        raise RecordingError([str(exc)]) from None
    return rec, hashlib.sha256(data).hexdigest()


def _read_csv(data: bytes, shown: str) -> Recording:
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise _Bad(f"{shown} is not UTF-8 text (byte {exc.start} cannot be decoded)") from None
    lines = text.splitlines()
    while lines and not lines[-1].strip():
        lines.pop()
    allowed = (*CHANNELS, TIME_COLUMN)
    if not lines:
        raise _Bad(f"{shown} is empty; its first line names the columns ({', '.join(allowed)})")
    names = [h.strip().lower() for h in next(csv.reader(lines[:1]))]
    _check_header(names, allowed, f"{shown} line 1", lines[0])
    channels = [n for n in names if n in CHANNELS]
    if len(channels) != len(CHANNELS):
        missing = [c for c in CHANNELS if c not in names]
        raise _Bad(
            f"{shown} line 1 names {len(channels)} channels ({', '.join(channels) or 'none'}); "
            f"a recording has the {len(CHANNELS)} channels {', '.join(CHANNELS)} "
            f"(missing: {', '.join(missing)})"
        )
    body = lines[1:]
    if not body:
        raise _Bad(f"{shown} has a header but no samples")
    for i, line in enumerate(body):
        if not line.strip():
            raise _Bad(f"{shown} line {i + 2} is empty")
    try:
        values = np.loadtxt(body, delimiter=",", dtype=np.float64, ndmin=2, comments=None)
        if values.shape != (len(body), len(names)):
            raise ValueError("shape")
    except ValueError:
        values = _parse_csv_rows(body, names, shown)  # names the line at fault
    bad = np.argwhere(~np.isfinite(values))
    if bad.size:
        r, c = (int(v) for v in bad[0])
        raise _Bad(
            f"{shown} line {r + 2}, column {names[c]}: {values[r, c]} (every sample must be "
            f"a finite number)"
        )
    channel = np.array([n in CHANNELS for n in names])
    huge = np.argwhere((np.abs(values) > MAX_SAMPLE_V) & channel)
    if huge.size:
        r, c = (int(v) for v in huge[0])
        raise _Bad(
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
            raise _Bad(
                f"{shown} line {line} has {len(cells)} values; the header names "
                f"{len(names)} columns ({', '.join(names)})"
            )
        for j, cell in enumerate(cells):
            text = cell.strip()
            if not text:
                raise _Bad(f"{shown} line {line}, column {names[j]} is empty")
            try:
                out[i, j] = parse_number(text, float)
            except ValueError as exc:
                raise _Bad(f"{shown} line {line}, column {names[j]}: {exc}") from None
    return out


def _read_npz(data: bytes, shown: str) -> Recording:
    allowed = ("signals", *CHANNELS, TIME_COLUMN, "sample_rate_hz")
    try:
        npz = np.load(io.BytesIO(data), allow_pickle=False)
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as exc:
        raise _Bad(f"{shown} is not a readable .npz file ({exc})") from None
    if not isinstance(npz, np.lib.npyio.NpzFile):
        raise _Bad(f"{shown} holds a single .npy array, not an .npz archive of named arrays")
    arrays: dict[str, np.ndarray] = {}
    with npz:
        for key in npz.files:
            try:
                check_choice("array", key, allowed)
            except ValueError as exc:
                raise _Bad(f"{shown}: {exc}") from None
            try:
                arrays[key] = npz[key]
            except (ValueError, OSError, zipfile.BadZipFile, EOFError) as exc:
                raise _Bad(f"{shown}: array {key!r} cannot be read ({exc})") from None
    for key, arr in arrays.items():
        kind = arr.dtype.kind
        if kind not in "iuf":
            raise _Bad(f"{shown}: array {key!r} holds {arr.dtype} values, not real numbers")
    per_channel = [ch for ch in CHANNELS if ch in arrays]
    if "signals" in arrays:
        if per_channel:
            raise _Bad(
                f"{shown} holds both 'signals' and per-channel arrays ({', '.join(per_channel)})"
                f"; keep one or the other"
            )
        x = arrays["signals"]
        if x.ndim != 2 or x.shape[0] != len(CHANNELS):
            raise _Bad(
                f"{shown}: array 'signals' has shape {x.shape}; it must be ({len(CHANNELS)}, n)"
                f": the channels {', '.join(CHANNELS)}, then the samples"
            )
        signals = x.astype(np.float64)
    else:
        if len(per_channel) != len(CHANNELS):
            missing = [c for c in CHANNELS if c not in arrays]
            raise _Bad(
                f"{shown} holds {len(per_channel)} of the {len(CHANNELS)} channel arrays "
                f"(missing: {', '.join(missing)}); a recording has {', '.join(CHANNELS)} "
                f"(or one 'signals' array of shape ({len(CHANNELS)}, n))"
            )
        lengths = {ch: arrays[ch].shape for ch in CHANNELS}
        if any(len(s) != 1 for s in lengths.values()) or len(set(lengths.values())) != 1:
            shapes = ", ".join(f"{ch} {s}" for ch, s in lengths.items())
            raise _Bad(f"{shown}: the channel arrays must be 1-D and equally long; got {shapes}")
        signals = np.stack([arrays[ch] for ch in CHANNELS]).astype(np.float64)
    if signals.shape[1] == 0:
        raise _Bad(f"{shown} holds no samples")
    bad = np.argwhere(~np.isfinite(signals))
    if bad.size:
        c, i = (int(v) for v in bad[0])
        raise _Bad(
            f"{shown}: channel {CHANNELS[c]} at sample index {i} is {signals[c, i]} (every "
            f"sample must be a finite number)"
        )
    huge = np.argwhere(np.abs(signals) > MAX_SAMPLE_V)
    if huge.size:
        c, i = (int(v) for v in huge[0])
        raise _Bad(
            f"{shown}: channel {CHANNELS[c]} at sample index {i} is {signals[c, i]:g} V, beyond "
            f"the +-{MAX_SAMPLE_V:.3g} V a float32 sample holds"
        )
    rate = None
    if "sample_rate_hz" in arrays:
        r = arrays["sample_rate_hz"]
        if r.size != 1:
            raise _Bad(f"{shown}: array 'sample_rate_hz' must be one number; got shape {r.shape}")
        try:
            rate = _check_rate(float(r.reshape(())), "array 'sample_rate_hz'")
        except _Bad as exc:
            raise _Bad(f"{shown}: {exc}") from None
    times = None
    if TIME_COLUMN in arrays:
        times = arrays[TIME_COLUMN].astype(np.float64)
        if times.shape != (signals.shape[1],):
            raise _Bad(
                f"{shown}: array {TIME_COLUMN!r} has shape {times.shape}; it must hold one time "
                f"per sample, ({signals.shape[1]},)"
            )
        if not np.all(np.isfinite(times)):
            i = int(np.flatnonzero(~np.isfinite(times))[0])
            raise _Bad(f"{shown}: array {TIME_COLUMN!r} at index {i} is {times[i]}")
    return Recording(signals, rate, times, lambda i: f"index {i} of array {TIME_COLUMN!r}")


# -- sample rate, resampling, window -------------------------------------------------------
def rate_from_times(times: np.ndarray, where: Callable[[int], str], shown: str) -> float:
    """The sample rate of uniformly spaced sample times (seconds), to 6 significant
    digits; ``_Bad`` naming the first step that is not increasing or breaks the uniform
    spacing."""
    if times.size < 2:
        raise _Bad(f"{shown}: one sample time gives no sample rate")
    steps = np.diff(times)
    if np.any(steps <= 0):
        i = int(np.flatnonzero(steps <= 0)[0]) + 1
        raise _Bad(f"{shown} {where(i)}: {TIME_COLUMN} does not increase")
    mean = (times[-1] - times[0]) / (times.size - 1)
    off = np.abs(steps - mean) > TIME_STEP_TOLERANCE * mean
    if np.any(off):
        i = int(np.flatnonzero(off)[0]) + 1
        raise _Bad(
            f"{shown} {where(i)}: {TIME_COLUMN} steps by {steps[i - 1]:.6g} s where the "
            f"recording's mean step is {mean:.6g} s (a dropped or repeated sample?); "
            f"a recording must be uniformly sampled"
        )
    return float(f"{1.0 / mean:.6g}")  # printed times carry no more digits than this


def sample_rate(row: LabelRow, rec: Recording, option: float | None, shown: str) -> float:
    """The recording's sample rate: the file's own (NPZ ``sample_rate_hz``) or the labels
    table's, else ``option`` (--sample-rate), else its time column; every statement given
    must agree with the others within :data:`RATE_TOLERANCE`."""
    stated = []
    if rec.sample_rate_hz is not None:
        stated.append(("its array 'sample_rate_hz'", rec.sample_rate_hz))
    if row.sample_rate_hz is not None:
        stated.append((f"labels line {row.line}", row.sample_rate_hz))
    if not stated and option is not None:
        stated.append(("--sample-rate", option))
    if rec.time_s is not None:
        stated.append((f"its {TIME_COLUMN}", rate_from_times(rec.time_s, rec.time_where, shown)))
    if not stated:
        raise _Bad(
            f"{shown} (labels line {row.line}) states no sample rate; give --sample-rate HZ, "
            f"a sample_rate_hz column in the labels table, or a {TIME_COLUMN} column"
        )
    (first, rate), others = stated[0], stated[1:]
    for name, value in others:
        if abs(value - rate) > RATE_TOLERANCE * rate:
            raise _Bad(
                f"{shown} (labels line {row.line}): {first} says {rate:g} Hz but {name} "
                f"gives {value:.6g} Hz"
            )
    return rate


def resampling_ratio(rate_hz: float) -> tuple[int, int]:
    """``(up, down)`` with ``up / down`` = SAMPLE_RATE_HZ / rate_hz in lowest terms
    (denominator at most :data:`MAX_RATIO_DENOMINATOR`)."""
    ratio = (Fraction(SAMPLE_RATE_HZ) / Fraction(rate_hz)).limit_denominator(MAX_RATIO_DENOMINATOR)
    return ratio.numerator, ratio.denominator


def check_duration(samples: int, rate_hz: float, shown: str) -> None:
    """Refuse, before resampling allocates it, a recording longer than
    :data:`MAX_RECORDING_S` (a rate in the wrong unit makes a short file hours long)."""
    seconds = samples / rate_hz
    if seconds > MAX_RECORDING_S:
        raise _Bad(
            f"{shown}: {samples} samples at {rate_hz:g} Hz last {seconds:,.0f} s; a recording "
            f"may last at most {MAX_RECORDING_S:,.0f} s (is the sample rate in another unit?)"
        )


def to_daq_rate(signals: np.ndarray, rate_hz: float) -> np.ndarray:
    """``signals`` ``(C, n)`` sampled at ``rate_hz`` brought to SAMPLE_RATE_HZ with
    scipy's polyphase resampler: its Kaiser-windowed FIR low-pass (cut-off at the lower
    of the two Nyquist frequencies) removes what would alias. The ends are padded along
    the line through the edge samples, so a strain gauge's offset does not ring."""
    up, down = resampling_ratio(rate_hz)
    if up == down:
        return np.asarray(signals, dtype=np.float64)
    from scipy.signal import resample_poly

    return resample_poly(signals, up, down, axis=1, padtype="line")


def contact_phase(sg: np.ndarray) -> tuple[int, int] | None:
    """First and last sample of the contact phase in strain-gauge signals ``(k, n)`` at
    SAMPLE_RATE_HZ, or ``None`` if no gauge leaves its rest levels.

    Each gauge is smoothed over :data:`CONTACT_SMOOTH_S`. Its two rest levels are the
    medians of the first and of the last :data:`REST_FRACTION` of the recording (before
    and after the slide; they may differ, e.g. by drift or a finger left on the plate),
    and a sample's deviation is its distance to the nearer one. A gauge counts if its
    largest deviation exceeds :data:`CONTACT_SNR` times its rest noise; the contact phase
    spans the samples where a counted gauge deviates by at least
    :data:`CONTACT_FRACTION` of its largest deviation.
    """
    from scipy.ndimage import uniform_filter1d

    sg = np.asarray(sg, dtype=np.float64)
    n = sg.shape[1]
    width = max(1, round(CONTACT_SMOOTH_S * SAMPLE_RATE_HZ))
    smooth = uniform_filter1d(sg, size=width, axis=1, mode="nearest")
    edge = max(1, int(n * REST_FRACTION))
    deviation = np.full(sg.shape, np.inf)
    noise = np.zeros(sg.shape[0])
    for rest in (smooth[:, :edge], smooth[:, n - edge :]):
        level = np.median(rest, axis=1, keepdims=True)
        spread = 1.4826 * np.median(np.abs(rest - level), axis=1)  # robust standard deviation
        noise = np.maximum(noise, spread)
        deviation = np.minimum(deviation, np.abs(smooth - level))
    peak = deviation.max(axis=1)
    floor = CONTACT_SNR * np.maximum(noise, DAQ_STEP_V)
    live = peak > floor
    if not live.any():
        return None
    threshold = np.maximum(CONTACT_FRACTION * peak, floor)[live, None]
    inside = (deviation[live] >= threshold).any(axis=0)
    idx = np.flatnonzero(inside)
    return int(idx[0]), int(idx[-1])


def window_start(
    signals: np.ndarray, start_s: float | None, shown: str, rate_hz: float
) -> tuple[int, str]:
    """``(first sample, how)`` of the N_SAMPLES window of ``signals`` ``(4, m)`` at
    SAMPLE_RATE_HZ: from ``start_s`` if given, the whole recording if it is one window
    long, else centred on :func:`contact_phase` of sg1/sg2 (kept inside the recording)."""
    m = signals.shape[1]
    if m < N_SAMPLES:
        raise _Bad(
            f"{shown} is {m / SAMPLE_RATE_HZ:.3f} s long ({round(m * rate_hz / SAMPLE_RATE_HZ)}"
            f" samples at {rate_hz:g} Hz); a trial needs a window of "
            f"{N_SAMPLES / SAMPLE_RATE_HZ:g} s"
        )
    if start_s is not None:
        first = round(start_s * SAMPLE_RATE_HZ)
        if first + N_SAMPLES > m:
            raise _Bad(
                f"{shown}: a window starting at {start_s:g} s ends after the recording's "
                f"{m / SAMPLE_RATE_HZ:.3f} s; the latest start is "
                f"{(m - N_SAMPLES) / SAMPLE_RATE_HZ:g} s"
            )
        return first, WINDOW_GIVEN
    if m == N_SAMPLES:
        return 0, WINDOW_WHOLE
    sg = signals[[CHANNELS.index("sg1"), CHANNELS.index("sg2")]]
    phase = contact_phase(sg)
    if phase is None:
        raise _Bad(
            f"{shown}: no contact phase found (sg1 and sg2 stay at their rest levels); "
            f"give the window's start with --window-start S or a window_start_s column"
        )
    centre = (phase[0] + phase[1] + 1) / 2
    first = int(np.clip(round(centre - N_SAMPLES / 2), 0, m - N_SAMPLES))
    return first, WINDOW_CONTACT


def window_id(window: np.ndarray) -> int:
    """A 63-bit id of a trial's window (BLAKE2b of its float32 little-endian bytes): the
    ``seed`` of an imported trial unless the labels table gives one. The same window
    imported twice gets the same id, so the benchmark's check that a perturbation dataset
    does not repeat the nominal one's trials holds for recordings too."""
    digest = hashlib.blake2b(np.ascontiguousarray(window, "<f4").tobytes(), digest_size=8)
    return int.from_bytes(digest.digest(), "little") & (2**63 - 1)


# -- the import ----------------------------------------------------------------------------
@dataclasses.dataclass
class _Order:
    """Store order of the labels rows and the per-trial arrays in that order."""

    rows: list[LabelRow]
    conditions: list[tuple[float, float]]
    plan: TrialPlan


def _store_order(rows: Sequence[LabelRow]) -> _Order:
    """Rows sorted like a simulated store: condition (force, then speed), class, trial.
    Rows without a trial number are numbered in table order within their class and
    condition."""
    conditions = sorted({(r.force_n, r.speed_mm_s) for r in rows})
    cond_of = {c: i for i, c in enumerate(conditions)}
    counters: dict[tuple[int, int], int] = {}
    keyed = []
    for r in rows:
        label = class_index(r.shape, r.material)
        cond = cond_of[(r.force_n, r.speed_mm_s)]
        if r.trial is None:
            trial = counters.get((label, cond), 0)
            counters[(label, cond)] = trial + 1
        else:
            trial = r.trial
        keyed.append(((cond, label, trial), r))
    keyed.sort(key=lambda kr: kr[0])
    ordered = [r for _, r in keyed]
    plan = TrialPlan(
        label=np.array([k[1] for k, _ in keyed], dtype=np.int16),
        condition=np.array([k[0] for k, _ in keyed], dtype=np.int16),
        trial_index=np.array([k[2] for k, _ in keyed], dtype=np.int32),
        force_n=np.array([r.force_n for r in ordered], dtype=np.float64),
        speed_mm_s=np.array([r.speed_mm_s for r in ordered], dtype=np.float64),
        seed=np.zeros(len(ordered), dtype=np.int64),
    )
    return _Order(ordered, conditions, plan)


def _check_options(
    sample_rate_hz: float | None, window_start_s: float | None, chunk_trials: int
) -> None:
    if sample_rate_hz is not None:
        if isinstance(sample_rate_hz, bool) or not isinstance(sample_rate_hz, int | float):
            raise ValueError(f"--sample-rate must be a number of Hz; got {sample_rate_hz!r}")
        try:
            _check_rate(float(sample_rate_hz), "--sample-rate")
        except _Bad as exc:
            raise ValueError(str(exc)) from None
    if window_start_s is not None and (
        isinstance(window_start_s, bool)
        or not isinstance(window_start_s, int | float)
        or not math.isfinite(window_start_s)
        or window_start_s < 0
    ):
        raise ValueError(f"--window-start must be a number of seconds >= 0; got {window_start_s!r}")
    check_int("--chunk-trials", chunk_trials, minimum=1)
    if chunk_trials > MAX_CHUNK_TRIALS:
        raise ValueError(f"--chunk-trials must be at most {MAX_CHUNK_TRIALS}; got {chunk_trials}")


def _inside(path: Path, folder: Path) -> bool:
    path, folder = path.resolve(), folder.resolve()
    return path == folder or folder in path.parents


def _is_labels_table(path: Path) -> bool:
    """Whether the CSV file ``path`` looks like a labels table (its first line names a
    ``file`` column), not a recording."""
    try:
        with open(path, encoding="utf-8-sig", errors="replace", newline="") as fh:
            header = next(csv.reader([fh.readline()]), [])
    except OSError:
        return False
    return "file" in (h.strip().lower() for h in header)


def _unlisted(recordings: Path, rows: Sequence[LabelRow], labels: Path) -> list[str]:
    """Recording files directly in ``recordings`` that the labels table does not list
    (other labels tables beside it are not recordings)."""
    listed = {r.path.resolve() for r in rows} | {labels.resolve()}
    return sorted(
        p.name
        for p in recordings.iterdir()
        if p.is_file()
        and p.suffix.lower() in RECORDING_SUFFIXES
        and not p.name.startswith(".")
        and p.resolve() not in listed
        and not (p.suffix.lower() == ".csv" and _is_labels_table(p))
    )


@dataclasses.dataclass
class ImportSummary:
    """What :func:`import_recordings` wrote: ``path``, trial and class counts, the
    conditions, how many recordings were CSV / NPZ, resampled (``{rate: count}``), and
    how their windows were cut (``{how: count}``)."""

    path: Path
    n_trials: int
    n_classes: int
    conditions: list[str]
    formats: dict[str, int]
    resampled: dict[float, int]
    windows: dict[str, int]


def import_recordings(
    recordings: str | Path,
    out: str | Path,
    *,
    labels: str | Path | None = None,
    sample_rate_hz: float | None = None,
    window_start_s: float | None = None,
    chunk_trials: int = 36,
    overwrite: bool = False,
    progress: bool = True,
) -> ImportSummary:
    """Import the recordings in the folder ``recordings`` (labels table ``labels``,
    default ``recordings/labels.csv``) into a new dataset store at ``out``.

    sample_rate_hz: the rate of recordings that state none (no ``sample_rate_hz`` in the
    labels table or the file). window_start_s: the start of every window, in seconds from
    the recording's first sample (the labels column ``window_start_s`` overrides it per
    file); default: centred on the contact phase. chunk_trials: trials per storage chunk.
    overwrite: replace an existing dataset at ``out`` (a non-empty ``out`` is refused
    otherwise). Recordings not at SAMPLE_RATE_HZ are resampled with a
    :class:`RecordingWarning`. Raises :class:`RecordingError` (a ``ValueError``) naming
    every bad file and line; nothing is written then. progress: report the recordings
    read on stderr (a bar on a terminal, plain lines elsewhere; see :mod:`synth.progress`).
    """
    recordings = Path(recordings)
    if not recordings.exists():
        raise FileNotFoundError(f"RECORDINGS {recordings} does not exist")
    if not recordings.is_dir():
        raise NotADirectoryError(
            f"RECORDINGS {recordings} is a file; give the folder that holds the recordings"
        )
    labels = Path(labels) if labels is not None else recordings / LABELS_FILE
    _check_options(sample_rate_hz, window_start_s, chunk_trials)
    out = Path(out)
    atomic.check_out_dir(out, advice="choose a directory path for the dataset")
    store.check_not_inside_a_store(out)
    for what, path in (("RECORDINGS", recordings), ("--labels", labels)):
        if out.exists() and _inside(path, out):
            raise ValueError(
                f"--out {out} holds {what} {path}; replacing it would delete them: choose "
                f"another --out"
            )
    rows = read_labels(labels, recordings)  # every label checked before any lock or write
    with store.locked(out):
        pending = store.pending_path(out)
        atomic.recover(out, complete=store.is_complete(pending))
        occupied = out.exists() and any(out.iterdir())
        # --overwrite replaces only a dataset, so a directory of other files is refused
        # first, without suggesting it.
        if occupied and not store.is_store(out):
            raise FileExistsError(
                f"--out {out} exists and is not a tactile-synth dataset; refusing to "
                f"overwrite it (choose another --out or delete it yourself)"
            )
        if occupied and not overwrite:
            raise FileExistsError(
                f"--out {out} exists and is not empty; pass --overwrite to replace it, "
                f"or choose another path"
            )
        _check_disk(out, len(rows))
        if pending.exists():
            # The unfinished copy of an import or generation that was killed (or stopped
            # by a second Ctrl-C): this import replaces it.
            shutil.rmtree(pending)
            warnings.warn(
                f"removed {pending}, the unfinished copy an interrupted import or generation "
                f"of {out} left beside it",
                RecordingWarning,
                stacklevel=2,
            )
        options = {
            "sample_rate_hz": sample_rate_hz,
            "window_start_s": window_start_s,
            "chunk_trials": chunk_trials,
        }
        # Ctrl-C stops between recordings and chunks, never inside a zarr write: zarr's IO
        # thread would finish that write after the copy below was removed, and leave it.
        with StopRequests() as stop:
            try:
                summary = _build(pending, rows, recordings, labels, options, progress, stop.check)
                stop.check()
                if occupied:
                    atomic.replace_dir(pending, out)
                else:
                    os.rename(pending, out)  # out is absent or an empty directory
                    atomic.fsync_dir(out.parent)
            except BaseException:
                shutil.rmtree(pending, ignore_errors=True)
                raise
    summary.path = out
    unlisted = _unlisted(recordings, rows, labels)
    if unlisted:
        names = ", ".join(unlisted[:3]) + (
            f" and {len(unlisted) - 3} more" if len(unlisted) > 3 else ""
        )
        warnings.warn(
            f"{len(unlisted)} recording file(s) in {recordings} are not in {labels} and were "
            f"not imported: {names}",
            RecordingWarning,
            stacklevel=2,
        )
    if summary.resampled:
        warnings.warn(
            _resampling_note(summary.resampled, len(rows)), RecordingWarning, stacklevel=2
        )
    return summary


def _resampling_note(resampled: dict[float, int], n: int) -> str:
    parts = []
    for rate, count in sorted(resampled.items()):
        part = f"{count} at {rate:g} Hz"
        if rate < SAMPLE_RATE_HZ:
            part += f" (upsampled: nothing above {rate / 2:g} Hz)"
        parts.append(part)
    return (
        f"resampled {sum(resampled.values())} of {n} recordings to {SAMPLE_RATE_HZ} Hz "
        f"(anti-aliasing polyphase filter, scipy.signal.resample_poly): {', '.join(parts)}"
    )


def _check_disk(out: Path, n: int) -> None:
    """Refuse an import whose store (at most its raw float32 size) cannot fit."""
    need = n * store.TRIAL_BYTES
    where = store.existing_parent(out)
    free = shutil.disk_usage(where).free
    if need > free:
        raise ValueError(
            f"--out {out}: {n} trials need up to {need / 1e6:,.1f} MB but {where} has "
            f"{free / 1e6:,.1f} MB free; choose another --out"
        )


def _build(
    target: Path,
    rows: Sequence[LabelRow],
    recordings: Path,
    labels: Path,
    options: dict[str, Any],
    progress: bool,
    stop: Callable[[], None] = lambda: None,
) -> ImportSummary:
    """Write the whole imported store at ``target`` (absent), or raise
    :class:`RecordingError` with every bad recording (``target`` then holds junk that
    the caller deletes). ``stop`` is called before each recording is read and after each
    chunk is written (it raises to stop the import there). ``progress``: report the
    recordings read on stderr, one chunk at a time (:func:`synth.progress.progress`: a
    bar on a terminal, plain lines elsewhere)."""
    order = _store_order(rows)
    c = int(options["chunk_trials"])
    n = len(order.rows)
    store_id = store.create_imported(target, order.plan, order.conditions, c)
    problems: list[tuple[int, str]] = []  # (labels line, problem)
    seeds = np.zeros(n, dtype=np.int64)
    first_of: dict[int, int] = {}  # window id -> first row holding it
    prov: dict[str, list[Any]] = {
        k: []
        for k in (
            "file",
            "labels_line",
            "sha256",
            "sample_rate_hz",
            "samples",
            "window_start_s",
            "window",
        )
    }
    formats: dict[str, int] = {}
    resampled: dict[float, int] = {}
    windows: dict[str, int] = {}
    bar = show_progress(n, desc="import", enabled=progress)
    try:
        for k in range(-(-n // c)):
            batch = np.zeros((min(c, n - k * c), len(CHANNELS), N_SAMPLES), dtype=np.float32)
            for j in range(batch.shape[0]):
                stop()
                i = k * c + j
                row = order.rows[i]
                shown = str(recordings / row.file)
                try:
                    rec, sha = read_recording(row.path, shown)
                    rate = sample_rate(row, rec, options["sample_rate_hz"], shown)
                    check_duration(rec.signals.shape[1], rate, shown)
                    x = to_daq_rate(rec.signals, rate)
                    start = row.window_start_s
                    if start is None:
                        start = options["window_start_s"]
                    first, how = window_start(x, start, shown, rate)
                except RecordingError as exc:
                    problems += [(row.line, p) for p in exc.problems]
                    continue
                except _Bad as exc:
                    problems.append((row.line, str(exc)))
                    continue
                batch[j] = x[:, first : first + N_SAMPLES]
                wid = window_id(batch[j])
                if wid in first_of:
                    other = order.rows[first_of[wid]]
                    problems.append(
                        (
                            row.line,
                            f"{shown} (labels line {row.line}) holds the same window as "
                            f"{recordings / other.file} (labels line {other.line})",
                        )
                    )
                first_of.setdefault(wid, i)
                seeds[i] = row.seed if row.seed is not None else wid
                suffix = row.path.suffix.lower().lstrip(".")
                formats[suffix] = formats.get(suffix, 0) + 1
                if resampling_ratio(rate) != (1, 1):
                    resampled[rate] = resampled.get(rate, 0) + 1
                windows[how] = windows.get(how, 0) + 1
                for key, value in (
                    ("file", row.file),
                    ("labels_line", row.line),
                    ("sha256", sha),
                    ("sample_rate_hz", rate),
                    ("samples", int(rec.signals.shape[1])),
                    ("window_start_s", first / SAMPLE_RATE_HZ),
                    ("window", how),
                ):
                    prov[key].append(value)
            bar.update(batch.shape[0])
            if problems:
                continue  # keep checking the other files; nothing more is written
            rs = slice(k * c, k * c + batch.shape[0])
            specs = [
                TrialSpec(r.shape, r.material, r.force_n, r.speed_mm_s, int(s))
                for r, s in zip(order.rows[rs], seeds[rs], strict=True)
            ]
            store.write_chunk(target, k, batch, specs, store_id)
            stop()
    finally:
        bar.close()
    if problems:
        raise RecordingError([p for _, p in sorted(problems, key=lambda lp: lp[0])])
    provenance = {
        "recordings": str(recordings.resolve()),
        "labels": str(labels.resolve()),
        "labels_sha256": hashlib.sha256(labels.read_bytes()).hexdigest(),
        "options": options,
        "window_s": N_SAMPLES / SAMPLE_RATE_HZ,
        "resampler": "scipy.signal.resample_poly (Kaiser-windowed FIR, beta 5; line padding)",
        "contact_detector": {
            "smooth_s": CONTACT_SMOOTH_S,
            "rest_fraction": REST_FRACTION,
            "threshold_fraction": CONTACT_FRACTION,
            "min_snr": CONTACT_SNR,
        },
        "trials": prov,
    }
    store.finish_imported(target, seeds, provenance)
    problems_left = store.Store.open(target).verify()
    if problems_left:  # pragma: no cover - what was just written must pass its own checks
        raise RuntimeError(f"the imported store fails its checks: {problems_left[0]}")
    return ImportSummary(
        path=target,
        n_trials=n,
        n_classes=int(np.unique(order.plan.label).size),
        conditions=[condition_name(f, s) for f, s in order.conditions],
        formats=formats,
        resampled=resampled,
        windows=windows,
    )


__all__ = [
    "LABEL_COLUMNS",
    "ImportSummary",
    "LabelRow",
    "Recording",
    "RecordingError",
    "RecordingWarning",
    "contact_phase",
    "import_recordings",
    "read_labels",
    "read_recording",
]
