"""The store's layout constants, the versions a store records, and where its files and
its writer's lock and pending replacement live."""

from __future__ import annotations

import importlib.metadata
import os
from pathlib import Path
from typing import Any

import numpy as np

from tactile_synth import atomic

from ..trial import CHANNELS, N_SAMPLES

#: Bumped whenever the layout above changes incompatibly or the simulator writes other
#: signals for the same configuration (a store is only resumed by the simulator that
#: started it). Version 11: ``label`` indexes the store's own class list (attribute
#: ``classes``, the grid's classes), no longer the paper's 36 names. Version 12: the
#: texture's slope turns the specimen under the contact (its push reaches the skin
#: through the contact itself), so every trial's signals differ from version 11's.
#: Version 15: the finger records how its skin answers the texture
#: (``Finger.skin_texture_response``).
FORMAT_VERSION: int = 15
ATTR_KEY = "tactile_synth"
#: The two kinds of store (attribute ``kind``; a store without it is simulated).
KIND_SIMULATED = "simulated"
KIND_IMPORTED = "imported"
PLAN_DTYPES = {
    "label": "int16",
    "condition": "int16",
    "trial_index": "int32",
    "force_n": "float64",
    "speed_mm_s": "float64",
    "seed": "int64",
}
PLAN_ARRAYS = tuple(PLAN_DTYPES)
#: Uncompressed bytes of one trial's signals (float32, 4 channels).
TRIAL_BYTES: int = 4 * len(CHANNELS) * N_SAMPLES


def package_version() -> str:
    try:
        return importlib.metadata.version("tactile-synth")
    except importlib.metadata.PackageNotFoundError:  # pragma: no cover - source checkout
        return "unknown"


def versions() -> dict[str, str]:
    """The versions a store records (a store's data depend on the first two)."""
    import mujoco
    import zarr

    return {
        "package_version": package_version(),
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


def chunk_file(path: Path, name: str, chunk: int) -> Path:
    """The file holding chunk ``chunk`` of array ``name`` (zarr v3 default chunk keys)."""
    if name == "signals":
        return path / name / "c" / str(chunk) / "0" / "0"
    return path / name / "c" / str(chunk)
