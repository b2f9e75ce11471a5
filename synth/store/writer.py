"""Writing a store: creating it (simulated or imported), its chunks with their checksums and
done flags, and the writer's lock."""

from __future__ import annotations

import datetime as _dt
import os
import uuid
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from tactile_synth import atomic

from ..presets import GenerationConfig, TrialPlan, condition_name, plan
from ..trial import CHANNELS, N_SAMPLES, SAMPLE_RATE_HZ, TrialSpec
from .checksums import array_checksum, chunk_checksum
from .errors import DatasetError, DatasetLocked
from .layout import (
    ATTR_KEY,
    FORMAT_VERSION,
    KIND_IMPORTED,
    KIND_SIMULATED,
    PLAN_DTYPES,
    chunk_file,
    versions,
)
from .meta import stored_config


@contextmanager
def locked(path: str | Path) -> Iterator[None]:
    """Hold the writer lock of the dataset ``path`` (covers its pending replacement too);
    :class:`DatasetLocked` at once if another process holds it.

    The lock file lives beside ``path``, so the missing directories above ``path`` are
    created; if the block raises they are removed again (as far as they are empty), so a
    failed or refused job leaves no empty directories behind.
    """
    made = [p for p in Path(os.path.abspath(path)).parents if not p.exists()]  # deepest first
    lock = atomic.PathLock(path)
    try:
        try:
            lock.acquire()
        except atomic.LockedError as exc:
            raise DatasetLocked(Path(path), exc.pid) from None
        try:
            yield
        finally:
            lock.release()
    except BaseException:
        for p in made:
            try:
                p.rmdir()
            except OSError:  # not empty (or not ours to remove): stop there
                break
        raise


def _now() -> str:
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")


def _create_arrays(path: Path, trials: TrialPlan, chunk_trials: int) -> Any:
    """The arrays of a new store at an absent or empty ``path`` (per-trial arrays filled
    from ``trials``, no signal, no chunk done); returns the zarr group."""
    import zarr
    from zarr.codecs import BloscCodec, Crc32cCodec

    n, c = len(trials), chunk_trials
    group = zarr.open_group(path, mode="w-", zarr_format=3)
    group.create_array(
        "signals",
        shape=(n, len(CHANNELS), N_SAMPLES),
        chunks=(c, len(CHANNELS), N_SAMPLES),
        dtype="float32",
        compressors=[BloscCodec(cname="zstd", clevel=3, shuffle="shuffle"), Crc32cCodec()],
        fill_value=np.float32(0),
        dimension_names=("trial", "channel", "time"),
    )
    for name, dtype in PLAN_DTYPES.items():
        values = np.asarray(getattr(trials, name), dtype=dtype)
        arr = group.create_array(
            name,
            shape=values.shape,
            chunks=(max(n, 1),),
            dtype=dtype,
            compressors=[Crc32cCodec()],
            dimension_names=("trial",),
        )
        arr[:] = values
    for name, dtype in (("checksum", "uint32"), ("done", "uint8")):
        group.create_array(
            name,
            shape=(-(-n // c),),
            chunks=(1,),
            dtype=dtype,
            compressors=[Crc32cCodec()],
            fill_value=0,
            dimension_names=("chunk",),
        )
    return group


def create(path: str | Path, config: GenerationConfig) -> str:
    """Create the store for ``config`` (``config.synth`` must be resolved) at an absent or
    empty ``path``; no signal is written yet. Returns the new store's id."""
    path = Path(path)
    if config.synth is None:
        raise ValueError("config.synth must be resolved (SynthConfig.to_dict()) before create")
    trials = plan(config)
    group = _create_arrays(path, trials, config.chunk_trials)
    store_id = uuid.uuid4().hex
    # Written last: a store without it is a creation that did not finish.
    group.attrs[ATTR_KEY] = {
        "format_version": FORMAT_VERSION,
        "kind": KIND_SIMULATED,
        **versions(),
        "store_id": store_id,
        "created_at": _now(),
        "config": config.to_dict(),
        "classes": list(config.classes),
        "channels": list(CHANNELS),
        "conditions": [condition_name(f, s) for f, s in config.conditions],
        "sample_rate_hz": SAMPLE_RATE_HZ,
        "n_trials": len(trials),
        "chunk_trials": config.chunk_trials,
        "n_chunks": config.n_chunks,
    }
    return store_id


def create_imported(
    path: str | Path,
    trials: TrialPlan,
    conditions: Sequence[tuple[float, float]],
    chunk_trials: int,
) -> str:
    """Create an imported store's skeleton at an absent or empty ``path``: the per-trial
    arrays of ``trials`` (in store order; ``condition`` indexes ``conditions``, ``label``
    its ``classes``, recorded as the store's class list), no signal yet. Its chunks are
    written with :func:`write_chunk`, then :func:`finish_imported` writes the trials'
    seeds (``trials.seed`` holds placeholders until then) and records the array
    checksums and provenance. Returns the store's id.
    """
    path = Path(path)
    n = len(trials)
    if n == 0:
        raise ValueError("an imported dataset needs at least one trial")
    if not trials.classes:
        raise ValueError("an imported dataset's plan must name its classes")
    group = _create_arrays(path, trials, chunk_trials)
    store_id = uuid.uuid4().hex
    # No array checksums yet: Store.open refuses it as an unfinished import until
    # finish_imported writes them.
    group.attrs[ATTR_KEY] = {
        "format_version": FORMAT_VERSION,
        "kind": KIND_IMPORTED,
        **versions(),
        "store_id": store_id,
        "created_at": _now(),
        "classes": list(trials.classes),
        "channels": list(CHANNELS),
        "conditions": [condition_name(f, s) for f, s in conditions],
        "sample_rate_hz": SAMPLE_RATE_HZ,
        "n_trials": n,
        "chunk_trials": chunk_trials,
        "n_chunks": -(-n // chunk_trials),
    }
    return store_id


def finish_imported(path: str | Path, seed: np.ndarray, provenance: dict[str, Any]) -> None:
    """Write the trials' ``seed`` (the ids their chunks were written with), then record the
    CRC-32C of each per-trial array (read back from the disk) and the import's
    ``provenance``: the last write of an import, after every chunk is done."""
    import zarr

    path = Path(path)
    group = zarr.open_group(path, mode="r+", zarr_format=3)
    group["seed"][:] = np.asarray(seed, dtype=PLAN_DTYPES["seed"])
    meta = dict(group.attrs[ATTR_KEY])
    sums = {}
    for name, dtype in PLAN_DTYPES.items():
        sums[name] = array_checksum(np.asarray(group[name][:]), dtype)
    # The specimens and materials of the class list, in its order.
    names = [c.split("/") for c in meta["classes"]]
    meta["shapes"] = list(dict.fromkeys(s for s, _ in names))
    meta["materials"] = list(dict.fromkeys(m for _, m in names))
    meta["array_checksums"] = sums
    meta["import"] = provenance
    group.attrs[ATTR_KEY] = meta


def write_chunk(
    path: str | Path,
    chunk: int,
    signals: np.ndarray,
    specs: Sequence[TrialSpec],
    store_id: str,
) -> None:
    """Write chunk ``chunk``'s signals ``(b, 4, T)``, then its checksum, then mark it done.

    ``store_id`` is the id of the store the writer planned for: if the store at ``path``
    is another one (replaced while this task ran), nothing is written.
    """
    import zarr

    path = Path(path)
    group = zarr.open_group(path, mode="r+", zarr_format=3)
    meta = group.attrs.get(ATTR_KEY) or {}
    classes = {name: i for i, name in enumerate(meta.get("classes") or ())}
    if meta.get("store_id") != store_id:
        raise DatasetError(
            f"dataset {path} was replaced by another writer while chunk {chunk} was being "
            f"simulated; nothing was written to it",
            "check who else writes this path",
        )
    arr = group["signals"]
    c = arr.chunks[0]
    start = chunk * c
    stop = min(start + c, arr.shape[0])
    expected = (stop - start, *arr.shape[1:])
    if signals.shape != expected or signals.dtype != np.float32 or len(specs) != expected[0]:
        raise ValueError(
            f"chunk {chunk} signals must be float32 {expected} for {expected[0]} specs; "
            f"got {signals.dtype} {signals.shape} for {len(specs)} specs"
        )
    unknown = [f"{s.shape}/{s.material}" for s in specs if f"{s.shape}/{s.material}" not in classes]
    if unknown:
        raise ValueError(
            f"chunk {chunk}: class {unknown[0]} is not in the dataset's class list "
            f"({', '.join(classes)})"
        )
    crc = chunk_checksum(
        signals,
        np.array([classes[f"{s.shape}/{s.material}"] for s in specs], dtype=np.int16),
        np.array([s.force_n for s in specs], dtype=np.float64),
        np.array([s.speed_mm_s for s in specs], dtype=np.float64),
        np.array([s.seed for s in specs], dtype=np.int64),
    )
    arr[start:stop] = signals
    # zarr renamed each file into place whole; flush them to the disk before the flag, so
    # even a power cut cannot leave a chunk marked done whose data never reached the disk.
    _fsync(chunk_file(path, "signals", chunk))
    group["checksum"][chunk] = np.uint32(crc)
    _fsync(chunk_file(path, "checksum", chunk))
    group["done"][chunk] = 1


def clear_chunks(path: str | Path, chunks: Iterable[int]) -> None:
    """Mark ``chunks`` not done (before they are re-simulated)."""
    import zarr

    group = zarr.open_group(Path(path), mode="r+", zarr_format=3)
    for k in chunks:
        group["done"][int(k)] = 0


def rewrite_plan(path: str | Path, names: Iterable[str]) -> None:
    """Rewrite the per-trial arrays ``names`` from the stored configuration's plan."""
    import zarr

    path = Path(path)
    trials = plan(stored_config(path))
    group = zarr.open_group(path, mode="r+", zarr_format=3)
    for name in names:
        group[name][:] = getattr(trials, name)


def _fsync(file: Path) -> None:
    if file.is_file():
        fd = os.open(file, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def remove_partial_files(path: str | Path) -> int:
    """Delete temporary chunk files a killed writer left behind; returns how many."""
    count = 0
    for tmp in Path(path).rglob("*.partial"):
        tmp.unlink(missing_ok=True)
        count += 1
    return count
