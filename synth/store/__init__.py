"""The on-disk dataset: one Zarr v3 store per dataset, checked on every read.

Layout (a plain ``zarr.open_group(path)`` reads all of it)::

    signals      float32 (n, 4, T)   chunks (chunk_trials, 4, T), Blosc-zstd + byte shuffle
    label        int16   (n,)        index into attrs classes (the dataset's own class list)
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
class list, versions, store id, creation time) is written last and marks a usable store.
Its ``classes`` is the dataset's class list, ``"<specimen>/<material>"`` names
specimen-major (a simulated store's is its configuration's ``GenerationConfig.classes``:
the paper's 36 for the paper presets, any set for a user's experiment).

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

The package's modules, one job each: :mod:`.layout` (format constants, versions, paths),
:mod:`.errors`, :mod:`.checksums`, :mod:`.meta` (reading and checking the attributes,
the rebuild commands), :mod:`.reader` (:class:`Store`, checked reads), :mod:`.writer`
(creating, writing chunks, the writer's lock) and :mod:`.loader` (:func:`load_dataset`).
Everything is re-exported here: ``synth.store.X`` names every part.
"""

from __future__ import annotations

from tactile_synth.atomic import check_not_inside_a_store, enclosing_store, is_store

from .checksums import array_checksum, chunk_checksum
from .errors import DatasetError, DatasetIncomplete, DatasetLocked, Problem
from .layout import (
    ATTR_KEY,
    FORMAT_VERSION,
    KIND_IMPORTED,
    KIND_SIMULATED,
    PLAN_ARRAYS,
    PLAN_DTYPES,
    TRIAL_BYTES,
    chunk_file,
    existing_parent,
    package_version,
    pending_path,
    versions,
    writer_mismatch,
)
from .loader import load_dataset
from .meta import (
    DatasetDamaged,
    check_format,
    check_imported_meta,
    config_of,
    read_meta,
    rebuild_advice,
    reimport_command,
    repair_command,
    store_kind,
    stored_config,
)
from .reader import Store, is_complete
from .writer import (
    clear_chunks,
    create,
    create_imported,
    finish_imported,
    locked,
    remove_partial_files,
    rewrite_plan,
    write_chunk,
)

__all__ = [
    "ATTR_KEY",
    "FORMAT_VERSION",
    "KIND_IMPORTED",
    "KIND_SIMULATED",
    "PLAN_ARRAYS",
    "PLAN_DTYPES",
    "TRIAL_BYTES",
    "DatasetDamaged",
    "DatasetError",
    "DatasetIncomplete",
    "DatasetLocked",
    "Problem",
    "Store",
    "array_checksum",
    "check_format",
    "check_imported_meta",
    "check_not_inside_a_store",
    "chunk_checksum",
    "chunk_file",
    "clear_chunks",
    "config_of",
    "create",
    "create_imported",
    "enclosing_store",
    "existing_parent",
    "finish_imported",
    "is_complete",
    "is_store",
    "load_dataset",
    "locked",
    "package_version",
    "pending_path",
    "read_meta",
    "rebuild_advice",
    "reimport_command",
    "remove_partial_files",
    "repair_command",
    "rewrite_plan",
    "store_kind",
    "stored_config",
    "versions",
    "write_chunk",
    "writer_mismatch",
]
