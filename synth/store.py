"""The on-disk dataset: one Zarr v3 store per dataset, checked on every read.

Layout (a plain ``zarr.open_group(path)`` reads all of it)::

    signals      float32 (n, 4, T)   chunks (chunk_trials, 4, T), Blosc-zstd + byte shuffle
    label        int16   (n,)        index into attrs classes (the 36 CLASS_NAMES)
    condition    int16   (n,)        index into attrs conditions
    trial_index  int32   (n,)        trial number within its (class, condition)
    force_n      float64 (n,)
    speed_mm_s   float64 (n,)
    seed         int64   (n,)        the trial's own seed: simulate(..., seed=seed[i]) redoes row i
    checksum     uint32  (n_chunks,) CRC-32C of chunk k's signals and its trials' plan rows
    done         uint8   (n_chunks,) chunk k of ``signals`` is complete iff done[k] == 1

Every array ends each chunk file with a CRC-32C of the file (zarr's ``crc32c`` codec),
so any zarr reader detects a truncated or bit-flipped file. Trial order is canonical
(condition, class, trial index), fixed by the configuration, so chunk k always holds the
same trials; the per-trial arrays are the plan of that configuration, written when the
store is created. The group attribute ``tactile_synth`` (format version, configuration,
versions, store id, creation time) is written last and marks a usable store.

A chunk task writes its ``signals`` chunk (zarr writes each chunk file to a temporary name
and renames it), flushes it to the disk, writes ``checksum[k]`` and only then ``done[k]``,
one file per flag, so no two tasks touch the same file and a reader never takes a torn or
unfinished chunk for data. ``checksum[k]`` covers the chunk's signals together with the
label, force, speed and seed of its trials, so a chunk file that is missing, swapped with
another chunk's, copied from another dataset or edited fails it; every reader here
(:func:`load_dataset`, ``inspect``, ``plot``, ``export``, the benchmark) checks it, and
checks the per-trial arrays against the plan regenerated from the stored configuration.
Problems raise :class:`DatasetDamaged`, naming the chunk, its file and the repair command.

Two kinds of store share this layout (attribute ``kind``): ``"simulated"`` (written by
``tactile-synth generate``; a store without ``kind`` is one) holds the configuration its
per-trial arrays are regenerated from, as above; ``"imported"`` (written by
``tactile-synth import`` from real recordings, :mod:`synth.importer`) has no plan to
regenerate, so its attributes hold a CRC-32C of each per-trial array instead, checked
on every read, and the import's provenance under ``import``. Its chunks carry the same
checksums, computed from the stored label, force, speed and seed of their trials. An
imported store cannot be resumed or repaired by simulation: it is rebuilt by running
the import again.
"""

from __future__ import annotations

import datetime as _dt
import importlib.metadata
import json
import os
import re
import shlex
import uuid
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from shapes import SHAPE_NAMES

from . import atomic
from .dataset import Dataset
from .materials import MATERIAL_NAMES
from .presets import PRESETS, GenerationConfig, TrialPlan, condition_name, plan
from .trial import CHANNELS, CLASS_NAMES, N_SAMPLES, SAMPLE_RATE_HZ, TrialSpec, class_index

#: Bumped whenever the layout above changes incompatibly or the simulator writes other
#: signals for the same configuration (a store is only resumed by the simulator that
#: started it).
FORMAT_VERSION: int = 10
ATTR_KEY = "tactile_synth"
#: The two kinds of store (attribute ``kind``; a store without it is simulated).
KIND_SIMULATED = "simulated"
KIND_IMPORTED = "imported"
_PLAN_DTYPES = {
    "label": "int16",
    "condition": "int16",
    "trial_index": "int32",
    "force_n": "float64",
    "speed_mm_s": "float64",
    "seed": "int64",
}
_PLAN_ARRAYS = tuple(_PLAN_DTYPES)
#: Uncompressed bytes of one trial's signals (float32, 4 channels).
TRIAL_BYTES: int = 4 * len(CHANNELS) * N_SAMPLES


# -- errors -------------------------------------------------------------------------------
class DatasetError(ValueError):
    """A dataset problem the user must act on. ``problem`` says what is wrong, ``fix``
    what to run (as ``tactile-synth generate`` options); ``str()`` is both on one line."""

    def __init__(self, problem: str, fix: str = "") -> None:
        self.problem = problem
        self.fix = fix
        super().__init__(f"{problem}; {fix}" if fix else problem)


class DatasetLocked(DatasetError):
    """Another process is writing the dataset (``pid``: its process id, if known)."""

    def __init__(self, path: Path, pid: int | None) -> None:
        self.pid = pid
        who = f"process {pid}" if pid is not None else "another process"
        super().__init__(
            f"dataset {path} is being written by {who} (tactile-synth generate)",
            f"wait for it to finish or stop it{f' (kill {pid})' if pid else ''}, then retry",
        )


class DatasetIncomplete(DatasetError):
    """Not every chunk of the dataset is done. ``str()`` also offers the Python API's
    ``allow_incomplete=True``; ``cli_message`` is the same advice without it, for
    command-line users, who finish the store with ``fix`` instead."""

    def __init__(self, problem: str, fix: str, api_fix: str = "") -> None:
        self.cli_message = f"{problem}; {fix}"
        super().__init__(problem, f"{fix}, or {api_fix}" if api_fix else fix)
        self.fix = fix


@dataclass(frozen=True)
class Problem:
    """One damaged part of a store: ``what`` (e.g. ``"chunk 3"``, ``"label"``), the
    ``file`` holding it, ``why`` it fails, and for a chunk its index and trials."""

    what: str
    file: Path
    why: str
    chunk: int | None = None
    trials: str = ""

    def __str__(self) -> str:
        where = f"{self.trials}, file {self.file}" if self.trials else f"file {self.file}"
        return f"{self.what} ({where}) {self.why}"


class DatasetDamaged(DatasetError):
    """Stored data fail their checks; ``problems`` lists every part that does."""

    def __init__(self, path: Path, problems: Sequence[Problem]) -> None:
        self.problems = list(problems)
        shown = "; ".join(str(p) for p in self.problems[:3])
        more = len(self.problems) - 3
        command = repair_command(path)
        imported = command.startswith("tactile-synth import")
        how = "import it again" if imported else "re-simulate the damaged parts"
        super().__init__(
            f"dataset {path} is damaged: {shown}" + (f"; and {more} more" if more > 0 else ""),
            f"{how} with `{command}`",
        )


def store_kind(meta: dict[str, Any]) -> str:
    """``"simulated"`` or ``"imported"`` (see the module docstring)."""
    return str(meta.get("kind", KIND_SIMULATED))


def reimport_command(path: str | Path, meta: dict[str, Any]) -> str:
    """The ``tactile-synth import`` command that rebuilds the imported store ``path`` from
    its recordings (read from its provenance)."""
    prov = meta.get("import") or {}
    argv = ["tactile-synth", "import", str(prov.get("recordings", "RECORDINGS"))]
    if prov.get("labels"):
        argv += ["--labels", str(prov["labels"])]
    options = prov.get("options") or {}
    for key, flag in (
        ("sample_rate_hz", "--sample-rate"),
        ("window_start_s", "--window-start"),
        ("chunk_trials", "--chunk-trials"),
    ):
        if options.get(key) is not None:
            argv += [flag, f"{options[key]:g}"]
    argv += ["--out", str(path), "--overwrite"]
    return shlex.join(argv)


def repair_command(path: str | Path) -> str:
    """The command that rebuilds the damaged parts of the store ``path``: re-simulation for
    a simulated store, the import again for an imported one."""
    try:
        meta = _read_meta(Path(path))
    except (OSError, ValueError):
        meta = {}
    if store_kind(meta) == KIND_IMPORTED:
        return reimport_command(path, meta)
    return f"tactile-synth generate --resume --repair --out {path}"


# -- versions -----------------------------------------------------------------------------
def _package_version() -> str:
    try:
        return importlib.metadata.version("tactile-synth")
    except importlib.metadata.PackageNotFoundError:  # pragma: no cover - source checkout
        return "unknown"


def versions() -> dict[str, str]:
    """The versions a store records (a store's data depend on the first two)."""
    import mujoco
    import zarr

    return {
        "package_version": _package_version(),
        "mujoco_version": mujoco.__version__,
        "zarr_version": zarr.__version__,
        "numpy_version": np.__version__,
    }


def writer_mismatch(meta: dict[str, Any]) -> list[str]:
    """How the versions that wrote a store differ from this installation's (tactile-synth
    and MuJoCo decide the bytes of every chunk); empty if they agree."""
    now = versions()
    out = []
    for key, name in (("package_version", "tactile-synth"), ("mujoco_version", "MuJoCo")):
        if meta.get(key) != now[key]:
            out.append(f"{name} {meta.get(key)} there, {now[key]} here")
    return out


# -- paths and locking --------------------------------------------------------------------
def is_store(path: Path) -> bool:
    """True if ``path`` is a Zarr group directory (a tactile-synth store or a half-created one)."""
    return (Path(path) / "zarr.json").is_file()


def enclosing_store(path: str | Path, *, itself: bool = False) -> Path | None:
    """The store that holds ``path`` below its root (one of its arrays, or anything
    further down), or with ``itself`` also the store that ``path`` is, if any: a dataset
    or a file written there would replace part of that store. An array's directory has
    its own ``zarr.json``, so the outermost one is the store."""
    p = Path(os.path.abspath(path))
    stores = [q for q in ((p,) if itself else ()) + tuple(p.parents) if is_store(q)]
    return stores[-1] if stores else None


def check_not_inside_a_store(
    out: str | Path, *, itself: bool = False, advice: str = "choose a path outside it"
) -> None:
    """A one-line ``ValueError`` naming ``--out`` (ending with ``advice``) if ``out`` lies
    inside another dataset store (or, with ``itself``, is one), where writing (or
    replacing with ``--overwrite``) would damage that store."""
    inside = enclosing_store(out, itself=itself)
    if inside is not None:
        raise ValueError(f"--out {out} lies inside the dataset {inside}; {advice}")


def is_complete(path: str | Path) -> bool:
    """``path`` is a readable store whose every chunk is finished."""
    try:
        return bool(Store.open(path).status()[0].all())
    except (OSError, ValueError):
        return False


def existing_parent(path: str | Path) -> Path:
    """The nearest existing directory at or above ``path`` (where a new file there would
    live: its free disk space is what a write to ``path`` can use)."""
    p = Path(os.path.abspath(path))
    while not p.exists():
        p = p.parent
    return p if p.is_dir() else p.parent


def pending_path(path: str | Path) -> Path:
    """Where a replacement of ``path`` is built (``--overwrite``) before it is renamed into
    place: a hidden sibling, ``.<name>.tactile-synth-new``."""
    return atomic.sibling(path, "new")


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


def chunk_file(path: Path, name: str, chunk: int) -> Path:
    """The file holding chunk ``chunk`` of array ``name`` (zarr v3 default chunk keys)."""
    if name == "signals":
        return path / name / "c" / str(chunk) / "0" / "0"
    return path / name / "c" / str(chunk)


# -- checksums ----------------------------------------------------------------------------
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


# -- creating -----------------------------------------------------------------------------
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
    for name, dtype in _PLAN_DTYPES.items():
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
        "classes": list(CLASS_NAMES),
        "channels": list(CHANNELS),
        "conditions": [condition_name(f, s) for f, s in config.conditions],
        "sample_rate_hz": SAMPLE_RATE_HZ,
        "n_trials": len(trials),
        "chunk_trials": config.chunk_trials,
        "n_chunks": config.n_chunks,
    }
    return store_id


def array_checksum(values: np.ndarray, dtype: str) -> int:
    """CRC-32C of a per-trial array as stored (little-endian ``dtype``, C order)."""
    import google_crc32c

    return int(google_crc32c.value(_readonly(values, np.dtype(dtype).newbyteorder("<").str)))


def create_imported(
    path: str | Path,
    trials: TrialPlan,
    conditions: Sequence[tuple[float, float]],
    chunk_trials: int,
) -> str:
    """Create an imported store's skeleton at an absent or empty ``path``: the per-trial
    arrays of ``trials`` (in store order; ``condition`` indexes ``conditions``), no
    signal yet. Its chunks are written with :func:`write_chunk`, then
    :func:`finish_imported` writes the trials' seeds (``trials.seed`` holds placeholders
    until then) and records the array checksums and provenance. Returns the store's id.
    """
    path = Path(path)
    n = len(trials)
    if n == 0:
        raise ValueError("an imported dataset needs at least one trial")
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
        "classes": list(CLASS_NAMES),
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
    group["seed"][:] = np.asarray(seed, dtype=_PLAN_DTYPES["seed"])
    meta = dict(group.attrs[ATTR_KEY])
    sums = {}
    for name, dtype in _PLAN_DTYPES.items():
        sums[name] = array_checksum(np.asarray(group[name][:]), dtype)
    shapes_, materials = set(), set()
    for cls in np.unique(np.asarray(group["label"][:])):
        shape, material = CLASS_NAMES[int(cls)].split("/")
        shapes_.add(shape)
        materials.add(material)
    meta["shapes"] = [s for s in SHAPE_NAMES if s in shapes_]
    meta["materials"] = [m for m in MATERIAL_NAMES if m in materials]
    meta["array_checksums"] = sums
    meta["import"] = provenance
    group.attrs[ATTR_KEY] = meta


# -- opening ------------------------------------------------------------------------------
def _missing_message(path: Path) -> str:
    pending, old = pending_path(path), atomic.sibling(path, "old")
    if old.exists():
        return (
            f"dataset {path} is being replaced right now, or its replacement was interrupted "
            f"(the previous version is at {old}); retry in a moment, or complete it with "
            f"`tactile-synth generate --resume --out {path}`"
        )
    if is_store(pending):
        try:
            imported = store_kind(_read_meta(pending)) == KIND_IMPORTED
        except (OSError, ValueError):
            imported = False
        if imported:
            return (
                f"dataset {path} does not exist, but an interrupted import left its "
                f"replacement at {pending}; run your `tactile-synth import` command again"
            )
        return (
            f"dataset {path} does not exist, but an interrupted generation left its "
            f"replacement at {pending}; finish it with "
            f"`tactile-synth generate --resume --out {path}`"
        )
    return f"dataset {path} does not exist; create it with `tactile-synth generate --out {path}`"


def _read_meta(path: Path) -> dict[str, Any]:
    """The ``tactile_synth`` attributes, read as JSON ourselves so a damaged metadata file
    is named (zarr's own error names no file)."""
    if not path.exists():
        raise FileNotFoundError(_missing_message(path))
    if not path.is_dir():
        raise NotADirectoryError(f"{path} is a file, not a dataset (a Zarr store directory)")
    meta_file = path / "zarr.json"
    if not meta_file.is_file():
        _check_not_a_part(path)
        raise DatasetError(
            f"{path} is not a tactile-synth dataset (no zarr.json)",
            "check the path, or create it with `tactile-synth generate --out PATH`",
        )
    raw = meta_file.read_bytes()
    try:
        doc = json.loads(raw)
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise DatasetError(
            f"{meta_file} is damaged (not valid JSON: {exc}), so the dataset's configuration "
            f"is lost",
            _rebuild_unreadable(raw),
        ) from None
    meta = doc.get("attributes", {}).get(ATTR_KEY) if isinstance(doc, dict) else None
    if not isinstance(meta, dict):
        _check_not_a_part(path)
        raise DatasetError(
            f"{path} is not a complete tactile-synth dataset (its creation was interrupted "
            f"or it was made by another tool)",
            "regenerate it with your original `tactile-synth generate` command plus --overwrite",
        )
    return meta


def _rebuild_unreadable(raw: bytes) -> str:
    """How to rebuild a store whose metadata is no longer valid JSON: by the command that
    made it, an import or a generation, as far as the surviving text still says which."""
    kind = re.search(rb'"kind"\s*:\s*"(\w+)"', raw)
    if kind is not None and kind.group(1).decode() == KIND_IMPORTED:
        return "import it again with your original `tactile-synth import` command plus --overwrite"
    if kind is not None:
        return "regenerate it with your original `tactile-synth generate` command plus --overwrite"
    return (
        "rebuild it with the command that made it, your original `tactile-synth generate` "
        "or `tactile-synth import` command, plus --overwrite"
    )


def _check_not_a_part(path: Path) -> None:
    """``DatasetError`` naming the dataset when ``path`` is one of its arrays (or lies
    further down in it), so the user is sent to the dataset instead of being told to
    regenerate a store that is fine."""
    inside = enclosing_store(path)
    if inside is None:
        return
    # The dataset as the user would type it: the parent of the given path that it is.
    shown = next((q for q in path.parents if Path(os.path.abspath(q)) == inside), inside)
    what = "an array of" if Path(os.path.abspath(path)).parent == inside else "inside"
    raise DatasetError(
        f"{path} is {what} the dataset {shown}, not a dataset itself",
        f"give the dataset instead, e.g. `tactile-synth inspect {shown}`",
    )


def _rebuild_advice(path: Path, meta: dict[str, Any]) -> str:
    """How to rebuild the whole store ``path`` from what made it."""
    if store_kind(meta) == KIND_IMPORTED:
        return f"import it again with `{reimport_command(path, meta)}`"
    from . import generation  # the generator's own check of a stored configuration

    try:
        grid = GenerationConfig.from_dict(meta["config"])
        if grid.synth is not None:
            generation.validate_synth_config(grid.synth)
    except (KeyError, TypeError, ValueError):
        # A configuration this version no longer reads (a parameter renamed or derived
        # now): the store's grid is regenerated under the current parameters.
        preset = meta.get("config", {}).get("preset") if isinstance(meta, dict) else None
        if isinstance(preset, str) and preset in PRESETS:
            return (
                f"its parameters predate this version's: regenerate the dataset with "
                f"`tactile-synth generate --preset {preset} --out {path} --overwrite`"
            )
        return (
            "its parameters predate this version's: regenerate it with your original "
            "`tactile-synth generate` command plus --overwrite"
        )
    return (
        f"regenerate the dataset with `tactile-synth generate --from-config "
        f"{path} --out {path} --overwrite`"
    )


def _check_format(path: Path, meta: dict[str, Any]) -> None:
    version = meta.get("format_version")
    if version != FORMAT_VERSION:
        raise DatasetError(
            f"{path} has dataset format version {version!r} (written by tactile-synth "
            f"{meta.get('package_version', 'unknown')}) but this tactile-synth "
            f"({_package_version()}) reads version {FORMAT_VERSION}",
            f"{_rebuild_advice(path, meta)}, or read it with the tactile-synth version "
            f"that wrote it",
        )
    kind = meta.get("kind", KIND_SIMULATED)
    if kind not in (KIND_SIMULATED, KIND_IMPORTED):
        raise DatasetError(
            f"{path / 'zarr.json'} names an unknown dataset kind {kind!r} (this tactile-synth "
            f"reads {KIND_SIMULATED!r} and {KIND_IMPORTED!r} datasets)",
            "read it with the tactile-synth version that wrote it",
        )


def stored_config(path: str | Path) -> GenerationConfig:
    """The configuration saved in a store (regenerates it bit for bit). Read from any
    format version, so ``--from-config`` can regenerate an old dataset in the new format."""
    path = Path(path)
    meta = _read_meta(path)
    if store_kind(meta) == KIND_IMPORTED:
        raise DatasetError(
            f"{path} holds imported recordings (tactile-synth import): it has no generation "
            f"configuration to simulate from",
            "give the grid with --preset, --config or the grid options",
        )
    return _config_of(path, meta)


def _config_of(path: Path, meta: dict[str, Any]) -> GenerationConfig:
    try:
        return GenerationConfig.from_dict(meta["config"])
    except (KeyError, TypeError, ValueError) as exc:
        raise DatasetError(
            f"{path / 'zarr.json'} holds no valid generation configuration ({exc})",
            "regenerate it with your original `tactile-synth generate` command plus --overwrite",
        ) from None


def _check_imported_meta(path: Path, meta: dict[str, Any]) -> None:
    """An imported store's attributes hold its geometry and the checksums of its per-trial
    arrays; an import that stopped before writing them is refused as unfinished."""
    meta_file = path / "zarr.json"
    if "array_checksums" not in meta:
        raise DatasetError(
            f"{path} is an import that did not finish (no array checksums in {meta_file})",
            f"run your `tactile-synth import ... --out {path}` command again with --overwrite",
        )

    def count(key: str, minimum: int) -> int:
        value = meta.get(key)
        if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
            raise DatasetError(
                f"{meta_file} holds no valid {key} (an integer >= {minimum}); got {value!r}",
                _rebuild_advice(path, meta),
            )
        return value

    n, c = count("n_trials", 1), count("chunk_trials", 1)
    if count("n_chunks", 1) != -(-n // c):
        raise DatasetError(
            f"{meta_file} says {meta['n_chunks']} chunks, but {n} trials in chunks of {c} "
            f"make {-(-n // c)}",
            _rebuild_advice(path, meta),
        )
    sums = meta.get("array_checksums")
    if not isinstance(sums, dict) or any(
        isinstance(sums.get(k), bool) or not isinstance(sums.get(k), int) for k in _PLAN_ARRAYS
    ):
        raise DatasetError(
            f"{meta_file} holds no valid array_checksums (one integer for each of "
            f"{', '.join(_PLAN_ARRAYS)})",
            _rebuild_advice(path, meta),
        )
    for key, allowed in (("shapes", SHAPE_NAMES), ("materials", MATERIAL_NAMES)):
        names = meta.get(key)
        if not isinstance(names, list) or not names or any(x not in allowed for x in names):
            raise DatasetError(
                f"{meta_file} holds no valid {key} (names from {', '.join(allowed)})",
                _rebuild_advice(path, meta),
            )
    conditions = meta.get("conditions")
    if not isinstance(conditions, list) or not conditions:
        raise DatasetError(
            f"{meta_file} holds no valid conditions (a list of force/speed names)",
            _rebuild_advice(path, meta),
        )


@dataclass
class Store:
    """An opened tactile-synth store: its metadata, configuration (``None`` for an
    imported store) and arrays, with checked reads. ``Store.open(path)`` raises one-line
    errors naming the file at fault."""

    path: Path
    group: Any
    meta: dict[str, Any]
    config: GenerationConfig | None
    arrays: dict[str, Any] = field(default_factory=dict)
    _checksums: tuple[np.ndarray, dict[int, str]] | None = field(default=None, repr=False)

    @classmethod
    def open(cls, path: str | Path, mode: str = "r") -> Store:
        import zarr

        path = Path(path)
        meta = _read_meta(path)
        _check_format(path, meta)
        if store_kind(meta) == KIND_IMPORTED:
            _check_imported_meta(path, meta)
            config = None
        else:
            config = _config_of(path, meta)
        try:
            group = zarr.open_group(path, mode=mode, zarr_format=3)
        except (ValueError, KeyError, TypeError) as exc:  # pragma: no cover - read above
            raise DatasetError(f"{path / 'zarr.json'} cannot be opened by zarr ({exc})") from None
        store = cls(path=path, group=group, meta=meta, config=config)
        store._open_arrays()
        return store

    def _open_arrays(self) -> None:
        import zarr

        n, c, k = self.n_trials, self.chunk_trials, self.n_chunks
        expected = {
            "signals": ((n, len(CHANNELS), N_SAMPLES), (c, len(CHANNELS), N_SAMPLES), "float32"),
            "checksum": ((k,), (1,), "uint32"),
            "done": ((k,), (1,), "uint8"),
        }
        for name, dtype in _PLAN_DTYPES.items():
            expected[name] = ((n,), (max(n, 1),), dtype)
        for name, (shape, chunks, dtype) in expected.items():
            meta_file = self.path / name / "zarr.json"
            regenerate = _rebuild_advice(self.path, self.meta)
            try:
                arr = self.group[name]
            except Exception as exc:  # zarr raises JSON, key and type errors on bad metadata
                if not meta_file.exists():
                    raise DatasetError(
                        f"dataset {self.path} has no {name} array ({meta_file} is missing)",
                        regenerate,
                    ) from None
                raise DatasetError(
                    f"{meta_file} is damaged ({type(exc).__name__}: {exc})", regenerate
                ) from None
            if not isinstance(arr, zarr.Array):
                raise DatasetError(
                    f"{meta_file} describes a group, not the dataset's {name} array",
                    regenerate,
                )
            if (arr.shape, arr.chunks, str(arr.dtype)) != (shape, chunks, dtype):
                raise DatasetError(
                    f"{meta_file} describes {arr.dtype} {arr.shape} in chunks {arr.chunks}, "
                    f"but the dataset's {'attributes' if self.imported else 'configuration'} "
                    f"need {dtype} {shape} in chunks {chunks}",
                    regenerate,
                )
            self.arrays[name] = arr

    # -- kind and geometry ---------------------------------------------------------------
    @property
    def kind(self) -> str:
        """``"simulated"`` or ``"imported"``."""
        return store_kind(self.meta)

    @property
    def imported(self) -> bool:
        return self.kind == KIND_IMPORTED

    @property
    def n_trials(self) -> int:
        return self.config.n_trials if self.config is not None else int(self.meta["n_trials"])

    @property
    def chunk_trials(self) -> int:
        if self.config is not None:
            return self.config.chunk_trials
        return int(self.meta["chunk_trials"])

    @property
    def n_chunks(self) -> int:
        return self.config.n_chunks if self.config is not None else int(self.meta["n_chunks"])

    @property
    def shapes(self) -> tuple[str, ...]:
        """The shapes of the dataset's classes (paper order)."""
        return self.config.shapes if self.config is not None else tuple(self.meta["shapes"])

    @property
    def materials(self) -> tuple[str, ...]:
        """The materials of the dataset's classes (paper order)."""
        if self.config is not None:
            return self.config.materials
        return tuple(self.meta["materials"])

    def check_complete(self, done: np.ndarray) -> None:
        """``DatasetError`` saying how to finish the store unless every chunk is ``done``
        (for commands that need every trial: ``plot``, ``export``)."""
        if not done.all():
            raise DatasetIncomplete(
                f"dataset {self.path} is incomplete ({int(done.sum())}/{done.size} chunks done)",
                self.finish_advice(),
            )

    def finish_advice(self) -> str:
        """How to complete this store when chunks are not done."""
        if self.imported:
            return _rebuild_advice(self.path, self.meta)
        return f"finish it with `tactile-synth generate --resume --out {self.path}`"

    @property
    def store_id(self) -> str | None:
        return self.meta.get("store_id")

    def rows(self, chunk: int) -> slice:
        c = self.chunk_trials
        return slice(chunk * c, min((chunk + 1) * c, self.n_trials))

    def file(self, name: str, chunk: int = 0) -> Path:
        return chunk_file(self.path, name, chunk)

    @cached_property
    def plan(self) -> TrialPlan:
        """The per-trial arrays: for a simulated store the plan of its configuration
        (regenerated, never read); for an imported one the stored arrays (checked by
        :meth:`check_plan`; one that cannot be read comes back as zeros, which fail it)."""
        if self.config is not None:
            return plan(self.config)
        values, _ = self._stored_trials
        return TrialPlan(**values)

    @cached_property
    def _stored_trials(self) -> tuple[dict[str, np.ndarray], dict[str, str]]:
        """An imported store's per-trial arrays and ``{name: error}`` for unreadable ones."""
        values, bad = {}, {}
        for name, dtype in _PLAN_DTYPES.items():
            try:
                values[name] = np.asarray(self.arrays[name][:], dtype=dtype)
            except Exception as exc:
                values[name] = np.zeros(self.n_trials, dtype=dtype)
                bad[name] = _decode_error(exc)
        return values, bad

    # -- flags ---------------------------------------------------------------------------
    def _flags(self, name: str) -> tuple[np.ndarray, dict[int, str]]:
        """An array of per-chunk values and ``{chunk: error}`` for files that fail to decode."""
        arr = self.arrays[name]
        try:
            return np.asarray(arr[:]), {}
        except Exception:  # one damaged file fails the whole read: find which
            values = np.zeros(arr.shape, dtype=arr.dtype)
            bad: dict[int, str] = {}
            for k in range(arr.shape[0]):
                try:
                    values[k] = arr[k]
                except Exception as exc:
                    bad[k] = _decode_error(exc)
            return values, bad

    def status(self) -> tuple[np.ndarray, list[Problem]]:
        """``(done, problems)``: bool ``(n_chunks,)`` of chunks marked complete, and the
        chunks whose done-flag file is damaged (they count as not done)."""
        done, bad_done = self._flags("done")
        mask = done == 1
        problems = [
            Problem(f"chunk {k}'s done flag", self.file("done", k), why, chunk=k)
            for k, why in bad_done.items()
        ]
        return mask, problems

    def checksums(self) -> tuple[np.ndarray, dict[int, str]]:
        """Recorded per-chunk checksums and ``{chunk: error}`` for damaged checksum files
        (read once per opened store)."""
        if self._checksums is None:
            self._checksums = self._flags("checksum")
        return self._checksums

    # -- verified reads ------------------------------------------------------------------
    def expected_checksum(self, chunk: int, signals: np.ndarray) -> int:
        r, p = self.rows(chunk), self.plan
        return chunk_checksum(signals, p.label[r], p.force_n[r], p.speed_mm_s[r], p.seed[r])

    def _chunk_problem(self, chunk: int, why: str) -> Problem:
        r = self.rows(chunk)
        return Problem(
            f"chunk {chunk}",
            self.file("signals", chunk),
            why,
            chunk=chunk,
            trials=f"trials {r.start}-{r.stop - 1}",
        )

    def _check_chunk(self, chunk: int, data: np.ndarray, recorded: int) -> Problem | None:
        if self.expected_checksum(chunk, data) == recorded:
            return None
        if not self.file("signals", chunk).is_file():
            return self._chunk_problem(chunk, "is missing")
        if not self.file("checksum", chunk).is_file():
            return self._chunk_problem(chunk, f"has no checksum ({self.file('checksum', chunk)})")
        return self._chunk_problem(
            chunk,
            "fails its checksum (edited, or swapped with another chunk or dataset)",
        )

    def read_chunks(self, chunks: Iterable[int]) -> tuple[dict[int, np.ndarray], list[Problem]]:
        """Signals of ``chunks`` (``{chunk: (b, 4, T)}``), each checked against its recorded
        checksum and its trials' plan; chunks that fail are left out and listed."""
        out, problems, _ = self._read_chunks(chunks)
        return out, problems

    def _read_chunks(
        self, chunks: Iterable[int]
    ) -> tuple[dict[int, np.ndarray], list[Problem], np.ndarray | None]:
        chunks = [int(k) for k in chunks]
        recorded, bad_sums = self.checksums()
        out: dict[int, np.ndarray] = {}
        problems: list[Problem] = []
        signals = self.arrays["signals"]
        whole = None
        if chunks and chunks == list(range(self.n_chunks)):
            try:
                whole = np.asarray(signals[:])  # one read: zarr decodes chunks in parallel
            except Exception:
                whole = None  # a damaged file: fall back to chunk by chunk to name it
        for k in chunks:
            if k in bad_sums:
                problems.append(
                    self._chunk_problem(k, f"has a damaged checksum file: {bad_sums[k]}")
                )
                continue
            if whole is not None:
                data = whole[self.rows(k)]
            else:
                try:
                    data = np.asarray(signals[self.rows(k)])
                except Exception as exc:
                    problems.append(self._chunk_problem(k, f"cannot be read: {_decode_error(exc)}"))
                    continue
            problem = self._check_chunk(k, data, int(recorded[k]))
            if problem is None:
                out[k] = data
            else:
                problems.append(problem)
        return out, problems, whole

    def check_plan(self) -> list[Problem]:
        """The stored per-trial arrays that differ from the plan of the stored configuration
        (simulated) or from their recorded checksums (imported)."""
        if self.imported:
            return self._check_imported_trials()
        problems = []
        for name in _PLAN_ARRAYS:
            file = self.file(name)
            try:
                stored = np.asarray(self.arrays[name][:])
            except Exception as exc:
                problems.append(Problem(name, file, f"cannot be read: {_decode_error(exc)}"))
                continue
            expected = getattr(self.plan, name)
            if not np.array_equal(stored, expected):
                if not file.is_file():
                    problems.append(Problem(name, file, "is missing"))
                    continue
                bad = np.flatnonzero(stored != expected)
                problems.append(
                    Problem(
                        name,
                        file,
                        f"differs from the dataset's configuration at {bad.size} trials "
                        f"(first: trial {int(bad[0])})",
                    )
                )
        return problems

    def _check_imported_trials(self) -> list[Problem]:
        values, bad = self._stored_trials
        sums = self.meta["array_checksums"]
        problems = []
        for name, dtype in _PLAN_DTYPES.items():
            file = self.file(name)
            if name in bad:
                problems.append(Problem(name, file, f"cannot be read: {bad[name]}"))
            elif array_checksum(values[name], dtype) != int(sums[name]):
                why = (
                    "is missing"
                    if not file.is_file()
                    else "fails its checksum (edited, or copied from another dataset)"
                )
                problems.append(Problem(name, file, why))
        return problems

    def verify(self) -> list[Problem]:
        """Every problem of the store: per-trial arrays, flags, and each finished chunk."""
        done, problems = self.status()
        problems += self.check_plan()
        _, chunk_problems = self.read_chunks(np.flatnonzero(done))
        return problems + chunk_problems


def _decode_error(exc: BaseException) -> str:
    text = str(exc).strip() or type(exc).__name__
    if "checksum" in text.lower():
        return "its stored CRC-32C does not match (truncated or corrupted)"
    if "blosc" in text.lower() or "decompress" in text.lower():
        return f"it does not decompress ({text}: truncated or corrupted)"
    return text.splitlines()[0]


# -- writing ------------------------------------------------------------------------------
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
    crc = chunk_checksum(
        signals,
        np.array([class_index(s.shape, s.material) for s in specs], dtype=np.int16),
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


# -- loading ------------------------------------------------------------------------------
def load_dataset(path: str | Path, *, allow_incomplete: bool = False) -> Dataset:
    """Read a store into a :class:`Dataset` (signals float32 ``(n, 4, T)``), checking
    every chunk it reads and the per-trial arrays (:class:`DatasetDamaged` if any fails).

    An incomplete store (an interrupted generation) raises ``DatasetError`` unless
    ``allow_incomplete``, in which case only the finished chunks' trials are returned.
    """
    store = Store.open(path)
    path = store.path
    done, problems = store.status()
    if not done.all() and not allow_incomplete and not problems:
        raise DatasetIncomplete(
            f"dataset {path} is incomplete ({int(done.sum())}/{done.size} chunks done)",
            store.finish_advice(),
            "load it with allow_incomplete=True",
        )
    problems += store.check_plan()
    chunks, chunk_problems, whole = store._read_chunks(np.flatnonzero(done))
    problems += chunk_problems
    if problems:
        raise DatasetDamaged(path, problems)
    classes = tuple(store.meta["classes"])
    if classes != CLASS_NAMES:
        raise DatasetError(f"dataset {path} lists classes that differ from synth.CLASS_NAMES")
    rows = np.zeros(store.n_trials, dtype=bool)
    for k in chunks:
        rows[store.rows(k)] = True
    if whole is not None:
        signals = whole  # every chunk read at once and verified: no copy
    else:
        signals = (
            np.concatenate([chunks[k] for k in sorted(chunks)])
            if chunks
            else np.zeros((0, len(CHANNELS), N_SAMPLES), np.float32)
        )
    trials = store.plan
    label = trials.label[rows]
    names = np.array(classes)[label.astype(np.intp)]
    attrs = dict(store.meta)
    attrs["complete"] = bool(done.all())
    return Dataset(
        signals=signals,
        shape=np.array([s.split("/")[0] for s in names], dtype=str),
        material=np.array([s.split("/")[1] for s in names], dtype=str),
        label=label.astype(np.int64),
        force_n=trials.force_n[rows],
        speed_mm_s=trials.speed_mm_s[rows],
        seed=trials.seed[rows],
        classes=classes,
        attrs=attrs,
    )
