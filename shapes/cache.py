"""On-disk cache of generated meshes, so build123d runs once per shape and version.

Entries are ``.npz`` files (no pickle) keyed by a hash of the shape name, the
specimen dimensions, this package's version and the cache format; a user's
``Specimen`` by its geometry hash instead of name and dimensions. Writers go
through a temporary file in the same directory and ``os.replace``, which is
atomic, so concurrent workers never read a half-written entry (at worst two
workers build the same entry and one replaces the other with identical data).

Location: ``$TACTILE_SYNTH_CACHE`` if set, else the user cache directory
(platformdirs when installed, else ``~/.cache/tactile-synth``).
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from importlib import metadata
from pathlib import Path

import numpy as np

from shapes.dims import SpecimenDims

CACHE_ENV = "TACTILE_SYNTH_CACHE"
FORMAT_VERSION = 2  # bump whenever the stored meshes change


def cache_dir() -> Path:
    """The directory holding cache entries (not created here)."""
    env = os.environ.get(CACHE_ENV)
    if env:
        return Path(env).expanduser()
    try:
        import platformdirs
    except ImportError:
        return Path.home() / ".cache" / "tactile-synth"
    return Path(platformdirs.user_cache_dir("tactile-synth"))


def package_version() -> str:
    try:
        return metadata.version("tactile-synth")
    except metadata.PackageNotFoundError:
        return "unknown"


def entry_path(kind: str, name: str, dims: SpecimenDims) -> Path:
    """Where the cache entry for (kind, shape name, dims) lives."""
    key = json.dumps(
        {
            "format": FORMAT_VERSION,
            "package": package_version(),
            "kind": kind,
            "name": name,
            "dims": dims.to_dict(),
        },
        sort_keys=True,
    )
    digest = hashlib.sha256(key.encode()).hexdigest()[:20]
    return cache_dir() / f"{kind}-{name}-{digest}.npz"


def geometry_entry_path(kind: str, name: str, geometry_hash: str) -> Path:
    """Where the cache entry for a user's specimen lives: keyed by its geometry hash
    (``Specimen.geometry_hash``: vertices and height), so an edited outline gets a new
    entry; ``name`` only makes the file name readable."""
    key = json.dumps(
        {
            "format": FORMAT_VERSION,
            "package": package_version(),
            "kind": kind,
            "geometry": geometry_hash,
        },
        sort_keys=True,
    )
    digest = hashlib.sha256(key.encode()).hexdigest()[:20]
    return cache_dir() / f"{kind}-specimen-{name}-{digest}.npz"


def load(path: Path) -> dict[str, np.ndarray] | None:
    """The arrays of an entry, or None if it is missing or unreadable."""
    try:
        with np.load(path, allow_pickle=False) as data:
            return {k: data[k] for k in data.files}
    except (OSError, ValueError, EOFError):
        # A damaged entry (e.g. disk full during a manual copy) is rebuilt, not fatal.
        return None


def save(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """Write an entry atomically (temporary file in the same directory + os.replace)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, **arrays)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
