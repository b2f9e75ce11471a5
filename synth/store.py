"""The on-disk dataset: one Zarr v3 store per dataset.

Layout (a plain ``zarr.open_group(path)`` reads all of it)::

    signals      float32 (n, 4, T)   chunks (chunk_trials, 4, T), Blosc-zstd + byte shuffle
    label        int16   (n,)        index into attrs classes (the 36 CLASS_NAMES)
    condition    int16   (n,)        index into attrs conditions
    trial_index  int32   (n,)        trial number within its (class, condition)
    force_n      float64 (n,)
    speed_mm_s   float64 (n,)
    seed         int64   (n,)        the trial's own seed: simulate(..., seed=seed[i]) redoes row i
    done         uint8   (n_chunks,) chunk k of ``signals`` is complete iff done[k] == 1

Trial order is canonical (condition, class, trial index), fixed by the configuration, so
chunk k always holds the same trials. Every per-trial array except ``signals`` is written
when the store is created; the group attribute ``tactile_synth`` (format version,
configuration, versions, creation time) is written last and marks a usable store.
A task writes its ``signals`` chunk (zarr's LocalStore writes each chunk file to a temporary
name and renames it) and only then sets ``done[k]``, one file per flag, so no two tasks
touch the same file and a torn or unfinished chunk is never marked done.
"""

from __future__ import annotations

import datetime as _dt
import importlib.metadata
import os
import shutil
from pathlib import Path
from typing import Any

import numpy as np

from .dataset import Dataset
from .presets import GenerationConfig, condition_name, plan
from .trial import CHANNELS, CLASS_NAMES, N_SAMPLES, SAMPLE_RATE_HZ

#: Bumped whenever the layout above changes incompatibly.
FORMAT_VERSION: int = 1
ATTR_KEY = "tactile_synth"
_PLAN_ARRAYS = ("label", "condition", "trial_index", "force_n", "speed_mm_s", "seed")


def _package_version() -> str:
    try:
        return importlib.metadata.version("tactile-synth")
    except importlib.metadata.PackageNotFoundError:  # pragma: no cover - source checkout
        return "unknown"


def _versions() -> dict[str, str]:
    import mujoco
    import zarr

    return {
        "package_version": _package_version(),
        "mujoco_version": mujoco.__version__,
        "zarr_version": zarr.__version__,
        "numpy_version": np.__version__,
    }


def is_store(path: Path) -> bool:
    """True if ``path`` is a Zarr group directory (a tactile-synth store or a half-created one)."""
    return (path / "zarr.json").is_file()


def create(path: str | Path, config: GenerationConfig) -> None:
    """Create the store for ``config`` (``config.synth`` must be resolved) at an absent or
    empty ``path``; no signal is written yet."""
    import zarr
    from zarr.codecs import BloscCodec

    path = Path(path)
    if config.synth is None:
        raise ValueError("config.synth must be resolved (SynthConfig.to_dict()) before create")
    trials = plan(config)
    n, c = len(trials), config.chunk_trials
    group = zarr.open_group(path, mode="w-", zarr_format=3)
    group.create_array(
        "signals",
        shape=(n, len(CHANNELS), N_SAMPLES),
        chunks=(c, len(CHANNELS), N_SAMPLES),
        dtype="float32",
        compressors=BloscCodec(cname="zstd", clevel=3, shuffle="shuffle"),
        fill_value=np.float32(0),
        dimension_names=("trial", "channel", "time"),
    )
    for name in _PLAN_ARRAYS:
        values = getattr(trials, name)
        arr = group.create_array(
            name,
            shape=values.shape,
            chunks=(max(n, 1),),
            dtype=values.dtype,
            dimension_names=("trial",),
        )
        arr[:] = values
    group.create_array(
        "done",
        shape=(config.n_chunks,),
        chunks=(1,),
        dtype="uint8",
        fill_value=0,
        dimension_names=("chunk",),
    )
    # Written last: a store without it is a creation that did not finish.
    group.attrs[ATTR_KEY] = {
        "format_version": FORMAT_VERSION,
        **_versions(),
        "created_at": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "config": config.to_dict(),
        "classes": list(CLASS_NAMES),
        "channels": list(CHANNELS),
        "conditions": [condition_name(f, s) for f, s in config.conditions],
        "sample_rate_hz": SAMPLE_RATE_HZ,
        "n_trials": n,
        "chunk_trials": c,
        "n_chunks": config.n_chunks,
    }


def open_store(path: str | Path, mode: str = "r") -> tuple[Any, dict[str, Any]]:
    """``(zarr group, provenance attrs)`` of a tactile-synth store; ``ValueError`` naming
    the fix when ``path`` is not one or has an incompatible format version."""
    import zarr

    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(
            f"dataset {path} does not exist; create it with `tactile-synth generate --out {path}`"
        )
    if not is_store(path):
        raise ValueError(f"{path} is not a tactile-synth dataset (no zarr.json)")
    group = zarr.open_group(path, mode=mode, zarr_format=3)
    meta = group.attrs.get(ATTR_KEY)
    if not isinstance(meta, dict):
        raise ValueError(
            f"{path} is not a complete tactile-synth dataset (its creation was interrupted "
            f"or it was made by another tool); regenerate it with --overwrite"
        )
    version = meta.get("format_version")
    if version != FORMAT_VERSION:
        raise ValueError(
            f"{path} has dataset format version {version!r} but this tactile-synth "
            f"({_package_version()}) reads version {FORMAT_VERSION}; use the tactile-synth "
            f"version that wrote it ({meta.get('package_version', 'unknown')}) or regenerate it"
        )
    return group, meta


def stored_config(path: str | Path) -> GenerationConfig:
    """The configuration saved in a store (regenerates it bit for bit)."""
    _, meta = open_store(path)
    return GenerationConfig.from_dict(meta["config"])


def done_mask(group: Any) -> np.ndarray:
    """bool ``(n_chunks,)``: which chunks are complete."""
    return np.asarray(group["done"][:]).astype(bool)


def write_chunk(path: str | Path, chunk: int, signals: np.ndarray) -> None:
    """Write chunk ``chunk``'s signals ``(b, 4, T)`` and then mark it done."""
    import zarr

    group = zarr.open_group(Path(path), mode="r+", zarr_format=3)
    arr = group["signals"]
    c = arr.chunks[0]
    start = chunk * c
    stop = min(start + c, arr.shape[0])
    expected = (stop - start, *arr.shape[1:])
    if signals.shape != expected or signals.dtype != np.float32:
        raise ValueError(
            f"chunk {chunk} signals must be float32 {expected}; got {signals.dtype} {signals.shape}"
        )
    arr[start:stop] = signals
    # zarr renamed the chunk file into place whole; flush it to the disk before the flag, so
    # even a power cut cannot leave a chunk marked done whose data never reached the disk.
    _fsync_chunk(Path(path) / "signals" / "c" / str(chunk))
    group["done"][chunk] = 1


def _fsync_chunk(chunk_dir: Path) -> None:
    for file in chunk_dir.rglob("*"):
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


def remove(path: str | Path) -> None:
    """Delete a store (only a Zarr group directory, so a mistyped path cannot wipe a folder)."""
    path = Path(path)
    if not is_store(path):
        raise FileExistsError(
            f"{path} exists and is not a tactile-synth dataset; refusing to overwrite it "
            f"(choose another --out or delete it yourself)"
        )
    shutil.rmtree(path)


def load_dataset(path: str | Path, *, allow_incomplete: bool = False) -> Dataset:
    """Read a store into a :class:`Dataset` (signals float32 ``(n, 4, T)``).

    An incomplete store (an interrupted generation) raises ``ValueError`` unless
    ``allow_incomplete``, in which case only the finished chunks' trials are returned.
    """
    group, meta = open_store(path)
    done = done_mask(group)
    if not done.all() and not allow_incomplete:
        raise ValueError(
            f"dataset {path} is incomplete ({int(done.sum())}/{done.size} chunks done); "
            f"finish it with `tactile-synth generate --resume --out {path}` "
            f"or load it with allow_incomplete=True"
        )
    c = int(meta["chunk_trials"])
    n = int(meta["n_trials"])
    rows = np.zeros(n, dtype=bool)
    for k in np.flatnonzero(done):
        rows[k * c : (k + 1) * c] = True
    columns = {name: np.asarray(group[name][:]) for name in _PLAN_ARRAYS}
    if rows.all():
        signals = np.asarray(group["signals"][:])
    else:
        signals = np.concatenate(
            [np.asarray(group["signals"][k * c : (k + 1) * c]) for k in np.flatnonzero(done)]
            or [np.zeros((0, len(CHANNELS), N_SAMPLES), np.float32)]
        )
    columns = {k: v[rows] for k, v in columns.items()}
    classes = tuple(meta["classes"])
    if classes != CLASS_NAMES:
        raise ValueError(f"dataset {path} lists classes that differ from synth.CLASS_NAMES")
    names = np.array(classes)[columns["label"].astype(np.intp)]
    shape = np.array([s.split("/")[0] for s in names], dtype=str)
    material = np.array([s.split("/")[1] for s in names], dtype=str)
    attrs = dict(meta)
    attrs["complete"] = bool(done.all())
    return Dataset(
        signals=signals,
        shape=shape,
        material=material,
        label=columns["label"].astype(np.int64),
        force_n=columns["force_n"],
        speed_mm_s=columns["speed_mm_s"],
        seed=columns["seed"],
        classes=classes,
        attrs=attrs,
    )
