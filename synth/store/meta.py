"""A store's metadata (the ``tactile_synth`` attributes): reading it with errors that name the
file, its format and kind checks, its configuration, and the commands that rebuild it."""

from __future__ import annotations

import json
import os
import re
import shlex
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from shapes.specimen import NAME_PATTERN
from tactile_synth import atomic
from tactile_synth.atomic import enclosing_store, is_store

from .. import config as config_mod
from ..presets import PRESETS, GenerationConfig
from .errors import DatasetError, Problem
from .layout import (
    ATTR_KEY,
    FORMAT_VERSION,
    KIND_IMPORTED,
    KIND_SIMULATED,
    PLAN_ARRAYS,
    package_version,
    pending_path,
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
        meta = read_meta(Path(path))
    except (OSError, ValueError):
        meta = {}
    if store_kind(meta) == KIND_IMPORTED:
        return reimport_command(path, meta)
    return f"tactile-synth generate --resume --repair --out {path}"


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
            imported = store_kind(read_meta(pending)) == KIND_IMPORTED
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


def read_meta(path: Path) -> dict[str, Any]:
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


def rebuild_advice(path: Path, meta: dict[str, Any]) -> str:
    """How to rebuild the whole store ``path`` from what made it."""
    if store_kind(meta) == KIND_IMPORTED:
        return f"import it again with `{reimport_command(path, meta)}`"
    try:
        grid = GenerationConfig.from_dict(meta["config"])
        if grid.synth is not None:
            config_mod.validate_synth_config(grid.synth)  # the generator's own check
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


def check_format(path: Path, meta: dict[str, Any]) -> None:
    version = meta.get("format_version")
    if version != FORMAT_VERSION:
        raise DatasetError(
            f"{path} has dataset format version {version!r} (written by tactile-synth "
            f"{meta.get('package_version', 'unknown')}) but this tactile-synth "
            f"({package_version()}) reads version {FORMAT_VERSION}",
            f"{rebuild_advice(path, meta)}, or read it with the tactile-synth version "
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
    meta = read_meta(path)
    if store_kind(meta) == KIND_IMPORTED:
        raise DatasetError(
            f"{path} holds imported recordings (tactile-synth import): it has no generation "
            f"configuration to simulate from",
            "give the grid with --preset, --config or the grid options",
        )
    return config_of(path, meta)


def config_of(path: Path, meta: dict[str, Any]) -> GenerationConfig:
    try:
        return GenerationConfig.from_dict(meta["config"])
    except (KeyError, TypeError, ValueError) as exc:
        raise DatasetError(
            f"{path / 'zarr.json'} holds no valid generation configuration ({exc})",
            "regenerate it with your original `tactile-synth generate` command plus --overwrite",
        ) from None


def check_classes(
    path: Path, meta: dict[str, Any], config: GenerationConfig | None = None
) -> tuple[str, ...]:
    """The store's class list (attribute ``classes``), checked: a non-empty list of unique
    ``"<specimen>/<material>"`` names (each part a specimen or material name), and for a
    simulated store (``config``) the classes of its configuration. A one-line
    :class:`DatasetError` naming the file otherwise."""
    meta_file = path / "zarr.json"
    classes = meta.get("classes")
    rule = 'a list of unique "<specimen>/<material>" names'
    if not isinstance(classes, list) or not classes:
        raise DatasetError(
            f"{meta_file} holds no valid classes ({rule}); got {classes!r}",
            rebuild_advice(path, meta),
        )
    for name in classes:
        parts = name.split("/") if isinstance(name, str) else []
        if len(parts) != 2 or not all(NAME_PATTERN.fullmatch(p) for p in parts):
            raise DatasetError(
                f"{meta_file} holds no valid classes ({rule}); {name!r} is not one",
                rebuild_advice(path, meta),
            )
    repeated = sorted({c for c in classes if classes.count(c) > 1})
    if repeated:
        raise DatasetError(
            f"{meta_file} holds no valid classes ({rule}); {repeated[0]!r} appears twice",
            rebuild_advice(path, meta),
        )
    if config is not None and tuple(classes) != config.classes:
        raise DatasetError(
            f"{meta_file} lists classes that differ from its configuration's "
            f"({len(classes)} there, {len(config.classes)} in the configuration)",
            rebuild_advice(path, meta),
        )
    return tuple(classes)


def check_imported_meta(path: Path, meta: dict[str, Any]) -> None:
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
                rebuild_advice(path, meta),
            )
        return value

    n, c = count("n_trials", 1), count("chunk_trials", 1)
    if count("n_chunks", 1) != -(-n // c):
        raise DatasetError(
            f"{meta_file} says {meta['n_chunks']} chunks, but {n} trials in chunks of {c} "
            f"make {-(-n // c)}",
            rebuild_advice(path, meta),
        )
    sums = meta.get("array_checksums")
    if not isinstance(sums, dict) or any(
        isinstance(sums.get(k), bool) or not isinstance(sums.get(k), int) for k in PLAN_ARRAYS
    ):
        raise DatasetError(
            f"{meta_file} holds no valid array_checksums (one integer for each of "
            f"{', '.join(PLAN_ARRAYS)})",
            rebuild_advice(path, meta),
        )
    classes = check_classes(path, meta)
    for key, part in (("shapes", 0), ("materials", 1)):
        names = meta.get(key)
        expected = list(dict.fromkeys(c.split("/")[part] for c in classes))
        if names != expected:
            raise DatasetError(
                f"{meta_file} holds no valid {key} (the {key} of its classes, in their order: "
                f"{', '.join(expected)})",
                rebuild_advice(path, meta),
            )
    conditions = meta.get("conditions")
    if not isinstance(conditions, list) or not conditions:
        raise DatasetError(
            f"{meta_file} holds no valid conditions (a list of force/speed names)",
            rebuild_advice(path, meta),
        )
