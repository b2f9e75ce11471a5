"""The ``[[specimen]]`` tables of an experiment file (TOML): built-in shapes by name and
the user's own outlines from polygons, SVG and DXF files and Python functions.

Schema (``docs/specimens.md`` has it in full, with examples)::

    [[specimen]]
    name = "l_bracket"                  # class-name part: [a-z0-9][a-z0-9_-]*, unique
    polygon_mm = [[-8, -6], [8, -6], [8, -2], [-4, -2], [-4, 6], [-8, 6]]
    height_mm = 2.0                     # optional (default 2 mm)
    offset_y_mm = 0.0                   # optional: move the centred outline along y

    [[specimen]]
    name = "gear"
    svg = "gear.svg"                    # relative to the experiment file
    svg_path_id = "outline"             # optional: which element (default: the only closed one)

    [[specimen]]
    name = "clip"
    dxf = "clip.dxf"
    dxf_layer = "outline"               # optional: which layer (default: all)

    [[specimen]]
    name = "blob"
    function = "my_shapes.py:blob"      # or "package.module:function"
    kwargs = { r = 6.0 }                # optional keyword arguments

    [[specimen]]
    name = "circle"                     # a built-in: its name alone

Only the ``specimen`` tables are read here; every other top-level key belongs to the
rest of the experiment (materials, conditions, simulator) and is left alone.
``tactile-synth generate --experiment FILE`` validates the whole file.

Every table is checked (keys, names, sources, duplicates) before any outline is built,
and every outline before anything is written; a bad one raises a one-line
``ValueError``: ``"FILE: specimen 'NAME': RULE"`` (``specimen #N`` where the N-th table
has no usable name).
"""

from __future__ import annotations

import difflib
import json
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from shapes import sources
from shapes.dims import SPECIMEN
from shapes.outlines import SHAPE_NAMES
from shapes.specimen import NAME_PATTERN, NAME_RULE, Specimen, SpecimenError, SpecimenLike
from tactile_synth import validation

#: The keys that give a specimen its outline; a table has exactly one (or none, for a
#: built-in shape).
SOURCE_KEYS = ("polygon_mm", "svg", "dxf", "function")
#: Keys that refine one source.
SOURCE_OPTIONS = {"svg_path_id": "svg", "dxf_layer": "dxf", "kwargs": "function"}
#: Keys that apply to every user specimen.
COMMON_KEYS = ("height_mm", "offset_y_mm")
KEYS = ("name", *SOURCE_KEYS, *SOURCE_OPTIONS, *COMMON_KEYS)


def read_toml(path: str | os.PathLike) -> dict[str, Any]:
    """The parsed experiment file; a one-line ``ValueError`` naming the file if it is
    missing or not TOML."""
    return validation.read_toml(path, "an experiment file")


def load_specimens(path: str | os.PathLike) -> tuple[SpecimenLike, ...]:
    """The specimens of an experiment file, in the file's order: each built-in as its
    name (``str``), each user outline as a checked ``Specimen``.

    Paths and modules in the file are found relative to the file's directory. Raises a
    one-line ``ValueError`` naming the file, the entry and the rule.
    """
    data = read_toml(path)
    return parse_specimens(data.get("specimen"), base_dir=Path(path).parent, file=str(path))


def parse_specimens(
    tables: object, *, base_dir: str | os.PathLike, file: str
) -> tuple[SpecimenLike, ...]:
    """The specimens of an already parsed experiment's ``specimen`` array (see
    :func:`load_specimens`); ``file`` names the file in errors, ``base_dir`` is where
    its relative paths start."""
    if tables is None:
        raise ValueError(
            f"{file}: no [[specimen]] tables: an experiment names its specimens "
            "(see docs/specimens.md)"
        )
    if isinstance(tables, Mapping):
        raise ValueError(f"{file}: write [[specimen]] (one table per specimen), not [specimen]")
    if not isinstance(tables, list) or not all(isinstance(t, Mapping) for t in tables):
        raise ValueError(f"{file}: 'specimen' must be an array of tables ([[specimen]])")
    if not tables:
        raise ValueError(f"{file}: no [[specimen]] tables")
    checked = [_check_table(file, i, t) for i, t in enumerate(tables, start=1)]
    seen: dict[str, int] = {}
    for i, table in enumerate(checked, start=1):
        name = table["name"]
        if name in seen:
            raise ValueError(
                f"{file}: specimen {name!r}: the name appears twice (specimen tables "
                f"{seen[name]} and {i}); every specimen needs its own name"
            )
        seen[name] = i
    return tuple(_build(file, Path(base_dir), t) for t in checked)


def _where(file: str, index: int, table: Mapping[str, Any]) -> str:
    name = table.get("name")
    if isinstance(name, str) and NAME_PATTERN.fullmatch(name):
        return f"{file}: specimen {name!r}"
    return f"{file}: specimen #{index}"


def _check_table(file: str, index: int, table: Mapping[str, Any]) -> dict[str, Any]:
    """The cheap checks of one table (keys, name, one source); returns it as a dict."""
    where = _where(file, index, table)
    for key in table:
        if key not in KEYS:
            raise ValueError(
                f"{where}: unknown key {key!r}{_hint(key, KEYS)}; a specimen table takes "
                f"{', '.join(KEYS)}"
            )
    name = table.get("name")
    if name is None:
        raise ValueError(f"{where}: the table has no name")
    if not isinstance(name, str) or not NAME_PATTERN.fullmatch(name):
        raise ValueError(f"{where}: name must hold only {NAME_RULE}; got {name!r}")
    given = [k for k in SOURCE_KEYS if k in table]
    if len(given) > 1:
        raise ValueError(
            f"{where}: the table gives {len(given)} sources ({' and '.join(given)}); "
            "give exactly one"
        )
    if not given:
        if name not in SHAPE_NAMES:
            raise ValueError(
                f"{where}: the table gives no source ({', '.join(SOURCE_KEYS)}) and "
                f"{name!r} is not a built-in shape{_hint(name, SHAPE_NAMES)} "
                f"({', '.join(SHAPE_NAMES)})"
            )
        extra = [k for k in table if k != "name"]
        if extra:
            raise ValueError(
                f"{where}: {name!r} is a built-in shape, which takes no other key "
                f"(got {', '.join(extra)}); its dimensions are the paper's"
            )
        return dict(table)
    if name in SHAPE_NAMES:
        raise ValueError(
            f"{where}: {name!r} is a built-in shape; a specimen with its own outline "
            f"({given[0]}) needs another name"
        )
    for option, source in SOURCE_OPTIONS.items():
        if option in table and source not in table:
            raise ValueError(f"{where}: {option} applies only with {source}")
    for key in ("svg", "dxf", "function", "svg_path_id", "dxf_layer"):
        if key in table and (not isinstance(table[key], str) or not table[key]):
            raise ValueError(f"{where}: {key} must be a non-empty string; got {table[key]!r}")
    if "kwargs" in table and not isinstance(table["kwargs"], Mapping):
        raise ValueError(
            f"{where}: kwargs must be a table of keyword arguments (kwargs = {{ r = 6.0 }}); "
            f"got {table['kwargs']!r}"
        )
    for key in COMMON_KEYS:
        value = table.get(key)
        if value is not None and (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not math.isfinite(value)
        ):
            raise ValueError(f"{where}: {key} must be a number (mm); got {value!r}")
    return dict(table)


def _build(file: str, base_dir: Path, table: Mapping[str, Any]) -> SpecimenLike:
    name = table["name"]
    if not any(k in table for k in SOURCE_KEYS):
        return name
    where = f"{file}: specimen {name!r}"
    tol = SPECIMEN.curve_tolerance_m
    try:
        if "polygon_mm" in table:
            ring, curved = sources.polygon_outline(table["polygon_mm"]), False
            source = f"polygon_mm in {Path(file).name}"
        elif "svg" in table:
            path_id = table.get("svg_path_id")
            ring, curved = sources.svg_outline(_resolve(base_dir, table["svg"]), path_id, tol)
            source = f"svg {table['svg']}" + (f"#{path_id}" if path_id else "")
        elif "dxf" in table:
            layer = table.get("dxf_layer")
            ring, curved = sources.dxf_outline(_resolve(base_dir, table["dxf"]), layer, tol)
            source = f"dxf {table['dxf']}" + (f" layer {layer}" if layer else "")
        else:
            kwargs = dict(table.get("kwargs", {}))
            ring, curved = sources.function_outline(table["function"], kwargs, base_dir, tol)
            source = f"function {table['function']}" + (
                f" {json.dumps(kwargs, sort_keys=True, default=str)}" if kwargs else ""
            )
        height_mm = table.get("height_mm", SPECIMEN.height_m * 1e3)
        return Specimen.from_outline(
            name,
            ring,
            height_m=height_mm * 1e-3,
            source=source,
            curved=curved,
            offset_y_m=table.get("offset_y_mm", 0.0) * 1e-3,
        )
    except SpecimenError as exc:
        raise ValueError(f"{where}: {exc.rule}") from None
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None


def _hint(value: str, options: Sequence[str]) -> str:
    close = difflib.get_close_matches(value, options, n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _resolve(base_dir: Path, name: str) -> Path:
    path = Path(name).expanduser()
    return path if path.is_absolute() else base_dir / path
