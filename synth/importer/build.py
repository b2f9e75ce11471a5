"""The import itself: recordings in store order into a new store, built beside ``--out``
and renamed into place once complete and verified."""

from __future__ import annotations

import csv
import dataclasses
import difflib
import hashlib
import math
import os
import shutil
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from shapes import SHAPE_NAMES
from tactile_synth import atomic
from tactile_synth.interrupts import StopRequests
from tactile_synth.validation import check_int

from .. import store
from ..materials import MATERIAL_NAMES
from ..presets import (
    MAX_CHUNK_TRIALS,
    TrialPlan,
    condition_name,
)
from ..progress import progress as show_progress
from ..trial import CHANNELS, N_SAMPLES, SAMPLE_RATE_HZ, TrialSpec
from .errors import (
    CONTACT_FRACTION,
    CONTACT_SMOOTH_S,
    CONTACT_SNR,
    LABELS_FILE,
    RECORDING_SUFFIXES,
    REST_FRACTION,
    Bad,
    RecordingError,
    RecordingWarning,
)
from .labels import LabelRow, check_rate, read_labels
from .recording import read_recording
from .window import (
    check_duration,
    resampling_ratio,
    sample_rate,
    to_daq_rate,
    window_id,
    window_start,
)


@dataclasses.dataclass
class _Order:
    """Store order of the labels rows and the per-trial arrays in that order."""

    rows: list[LabelRow]
    conditions: list[tuple[float, float]]
    plan: TrialPlan


def import_classes(pairs: Sequence[tuple[str, str]]) -> tuple[str, ...]:
    """An imported dataset's class list: every ``(specimen, material)`` pair the labels
    table holds, specimen-major, as a generated grid orders them: the built-in shapes in
    the paper's order, then other specimens sorted by name; within a specimen, the
    paper's materials in the paper's order, then other materials sorted by name. The
    paper's classes thus keep their relative order."""

    def specimen_key(name: str) -> tuple[int, int | str]:
        return (0, SHAPE_NAMES.index(name)) if name in SHAPE_NAMES else (1, name)

    def material_key(name: str) -> tuple[int, int | str]:
        return (0, MATERIAL_NAMES.index(name)) if name in MATERIAL_NAMES else (1, name)

    unique = set(pairs)
    ordered = sorted(unique, key=lambda sm: (specimen_key(sm[0]), material_key(sm[1])))
    return tuple(f"{s}/{m}" for s, m in ordered)


def _store_order(rows: Sequence[LabelRow]) -> _Order:
    """Rows sorted like a simulated store: condition (force, then speed), class (in the
    order of :func:`import_classes`), trial. Rows without a trial number are numbered in
    table order within their class and condition."""
    conditions = sorted({(r.force_n, r.speed_mm_s) for r in rows})
    cond_of = {c: i for i, c in enumerate(conditions)}
    classes = import_classes([(r.shape, r.material) for r in rows])
    label_of = {name: i for i, name in enumerate(classes)}
    counters: dict[tuple[int, int], int] = {}
    keyed = []
    for r in rows:
        label = label_of[f"{r.shape}/{r.material}"]
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
        classes=classes,
    )
    return _Order(ordered, conditions, plan)


def _check_options(
    sample_rate_hz: float | None, window_start_s: float | None, chunk_trials: int
) -> None:
    if sample_rate_hz is not None:
        if isinstance(sample_rate_hz, bool) or not isinstance(sample_rate_hz, int | float):
            raise ValueError(f"--sample-rate must be a number of Hz; got {sample_rate_hz!r}")
        try:
            check_rate(float(sample_rate_hz), "--sample-rate")
        except Bad as exc:
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
    for note in near_misses(rows):
        warnings.warn(note, RecordingWarning, stacklevel=2)
    return summary


def near_misses(rows: Sequence[LabelRow]) -> list[str]:
    """A note for each specimen or material name of the table that is not one of the
    paper's but is close to one (``circel``): any name is a class of its own, so a typo
    would silently make one."""
    notes = []
    for column, known in (("shape", SHAPE_NAMES), ("material", MATERIAL_NAMES)):
        first: dict[str, int] = {}
        for r in rows:
            first.setdefault(getattr(r, column), r.line)
        for name, line in first.items():
            close = difflib.get_close_matches(name, known, n=1, cutoff=0.8)
            if name not in known and close:
                notes.append(
                    f"{column} {name!r} (labels line {line}) is not one of the paper's "
                    f"{column}s but is close to {close[0]!r}; it was imported as a {column} "
                    f"of its own (check the spelling)"
                )
    return notes


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
                except Bad as exc:
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
