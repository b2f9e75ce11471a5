"""Experiment files: one TOML file names a study's specimens, materials, force/speed
conditions, trials per class and simulator settings, and loads into the
:class:`~synth.grid.GenerationConfig` that ``tactile-synth generate --experiment FILE``
simulates (``docs/experiments.md`` has the schema in full)::

    name = "my_lab"                     # optional: the dataset's name (default: the file's stem)
    trials_per_class = 20               # required
    seed = 0                            # optional (default 0)
    chunk_trials = 36                   # optional (default 36)
    materials = ["wood", "glass", "cork"]   # library materials and the file's own
    finger = "twin/finger.toml"         # optional: a calibrated finger file
                                        # (tactile-synth calibrate), applied last

    [conditions]
    force_n = [1.0]                     # normal forces (N)
    speed_mm_s = [10.0]                 # sliding speeds (mm/s)
    include_nominal = true              # optional: keep 1 N at 10 mm/s in the grid

    [[specimen]]                        # shapes.parse_specimens: built-ins and outlines
    name = "circle"

    [[material]]                        # synth.material_data: a material of the file's own
    name = "cork"
    ...

    [simulator.motion]                  # optional: simulator fields (synth.config)
    approach_s = 0.12

The grid's classes are every specimen with every material, ``"<specimen>/<material>"``,
specimen-major: the built-in shapes in the paper's order, then the file's own specimens
in the file's order; the materials in the order ``materials`` lists them.

Every bad input is one ``ValueError`` line naming the file, the entry and the rule,
raised before anything is simulated or written. Loading runs the Python functions a
``[[specimen]]`` table names (``function = "file.py:name"``): load only files you trust.
The configuration it returns holds the specimens' vertices and the materials' values,
so a dataset made from it is resumed and regenerated without the file.
"""

from __future__ import annotations

import dataclasses
import difflib
import os
from collections.abc import Collection, Mapping
from importlib import resources
from pathlib import Path
from typing import Any

import shapes
from shapes.experiment import read_toml
from shapes.specimen import NAME_PATTERN, NAME_RULE
from tactile_synth.validation import check_int

from .config import SynthConfig
from .grid import MAX_CHUNK_TRIALS, GenerationConfig, check_forces, check_speeds
from .materials import MATERIALS

#: The top-level keys of an experiment file.
KEYS = (
    "name",
    "trials_per_class",
    "seed",
    "chunk_trials",
    "materials",
    "conditions",
    "specimen",
    "material",
    "simulator",
    "finger",
)
#: The keys of its ``[conditions]`` table.
CONDITION_KEYS = ("force_n", "speed_mm_s", "include_nominal")
#: The simulator sections a ``[simulator.SECTION]`` table may set (``SynthConfig``'s
#: parameter sections; materials and specimens come from the file's own tables).
SIMULATOR_SECTIONS = ("finger", "motion", "variability", "strain_gauge", "pvdf", "acquisition")
#: The experiment files the package ships (its presets), in ``synth/experiments``.
PACKAGED = ("quick", "paper", "perturbation")


def _hint(value: str, options: Collection[str]) -> str:
    close = difflib.get_close_matches(value, list(options), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _check_keys(where: str, what: str, table: Mapping[str, Any], allowed: tuple[str, ...]) -> None:
    for key in table:
        if key not in allowed:
            raise ValueError(
                f"{where}: unknown {what} {key!r}{_hint(str(key), allowed)}; "
                f"allowed: {', '.join(allowed)}"
            )


def load_experiment(path: str | os.PathLike) -> GenerationConfig:
    """The grid an experiment file describes (module docstring), every entry checked.

    Paths and modules its ``[[specimen]]`` tables name are found relative to the file's
    directory. Raises a one-line ``ValueError`` naming the file, the entry and the rule
    (``FileNotFoundError`` is a ``ValueError`` here too: the file is named).

    Examples
    --------
    >>> from synth.experiment import load_experiment, packaged_path
    >>> grid = load_experiment(packaged_path("paper"))
    >>> grid.preset, len(grid.classes), grid.trials_per_class, grid.n_trials
    ('paper', 36, 60, 2160)
    """
    data = read_toml(path)
    return parse_experiment(data, base_dir=Path(path).parent, file=str(path), stem=Path(path).stem)


def parse_experiment(
    data: Mapping[str, Any], *, base_dir: str | os.PathLike, file: str, stem: str = "experiment"
) -> GenerationConfig:
    """:func:`load_experiment` for an already parsed file: ``file`` names it in errors,
    ``base_dir`` is where its relative paths start, ``stem`` is the default name."""
    if not isinstance(data, Mapping) or not data:
        raise ValueError(f"{file}: the file sets nothing (see docs/experiments.md)")
    _check_keys(file, "top-level key", data, KEYS)
    name = data.get("name", stem)
    if not isinstance(name, str) or not NAME_PATTERN.fullmatch(name):
        raise ValueError(f"{file}: name must hold only {NAME_RULE}; got {name!r}")
    if "trials_per_class" not in data:
        raise ValueError(f"{file}: trials_per_class is required (trials of each class)")
    grid: dict[str, Any] = {"preset": name}
    for key, minimum in (("trials_per_class", 1), ("seed", 0), ("chunk_trials", 1)):
        if key in data:
            try:
                grid[key] = check_int(key, data[key], minimum=minimum)
            except ValueError as exc:
                raise ValueError(f"{file}: {exc}") from None
    if grid.get("chunk_trials", 0) > MAX_CHUNK_TRIALS:
        raise ValueError(
            f"{file}: chunk_trials must be at most {MAX_CHUNK_TRIALS} (one chunk's signals "
            f"are held in memory: 32 kB per trial); got {grid['chunk_trials']}"
        )
    grid.update(_conditions(file, data.get("conditions")))
    # The cheap checks of every section first; then the specimens' outlines are built.
    settings = _simulator_settings(file, data.get("simulator"))
    materials = _materials(file, data.get("materials"), data.get("material"))
    specimens = shapes.parse_specimens(data.get("specimen"), base_dir=base_dir, file=file)
    own = {s.name: s for s in specimens if isinstance(s, shapes.Specimen)}
    try:
        synth = SynthConfig.from_dict(settings)
    except ValueError as exc:
        raise ValueError(f"{file}: simulator: {exc}") from None
    synth = dataclasses.replace(synth, materials=materials, specimens=own)
    synth = _skin_fitted(file, data.get("simulator"), synth)
    synth = _with_finger(file, data.get("finger"), base_dir, synth)
    grid["shapes"] = tuple(shapes.specimen_name(s) for s in specimens)
    grid["materials"] = tuple(materials)
    # The paper's set-up is stored as None ("the simulator's defaults"), as the presets
    # always were; generation resolves and stores it.
    grid["synth"] = None if synth == SynthConfig() else synth.to_dict()
    try:
        return GenerationConfig(**grid)
    except ValueError as exc:
        raise ValueError(f"{file}: {exc}") from None


def _conditions(file: str, table: object) -> dict[str, Any]:
    where = f"{file}: [conditions]"
    if table is None:
        raise ValueError(
            f"{file}: no [conditions] table: give force_n = [...] (N) and speed_mm_s = [...] (mm/s)"
        )
    if not isinstance(table, Mapping):
        raise ValueError(f"{file}: conditions must be a table ([conditions]); got {table!r}")
    _check_keys(where, "key", table, CONDITION_KEYS)
    out: dict[str, Any] = {}
    for key, field_name, check in (
        ("force_n", "forces_n", check_forces),
        ("speed_mm_s", "speeds_mm_s", check_speeds),
    ):
        if key not in table:
            raise ValueError(f"{where}: {key} is required (a list of values)")
        try:
            out[field_name] = check(f"conditions.{key}", table[key])
        except ValueError as exc:
            raise ValueError(f"{file}: {exc}") from None
    if "include_nominal" in table:
        if not isinstance(table["include_nominal"], bool):
            raise ValueError(
                f"{where}: include_nominal must be true or false; got {table['include_nominal']!r}"
            )
        out["include_nominal"] = table["include_nominal"]
    return out


def _simulator_settings(file: str, table: object) -> dict[str, Any]:
    """The simulator's default settings (``SynthConfig().to_dict()``) with the file's
    ``[simulator.SECTION]`` fields in place of theirs (each key checked against its
    section's fields)."""
    base = SynthConfig().to_dict()
    if table is None:
        return base
    if not isinstance(table, Mapping):
        raise ValueError(f"{file}: simulator must be tables ([simulator.SECTION]); got {table!r}")
    _check_keys(f"{file}: [simulator]", "section", table, SIMULATOR_SECTIONS)
    for section, values in table.items():
        where = f"{file}: [simulator.{section}]"
        if not isinstance(values, Mapping):
            raise ValueError(f"{where} must be a table of fields; got {values!r}")
        _check_keys(where, "field", values, tuple(base[section]))
    return overlay(base, table)


def _skin_fitted(file: str, table: Mapping[str, Any] | None, config: SynthConfig) -> SynthConfig:
    """``config`` with the skin's MuJoCo contact refitted to its Hertz law when the file's
    ``[simulator.finger]`` changes what the law depends on (the pad's radius, the skin's
    modulus or Poisson's ratio) and does not set the contact itself: the default contact
    is fitted to the default skin, and a softer skin must sink deeper."""
    from .skin_fit import HERTZ_FIELDS, SimulationError, with_fitted_skin

    finger = (table or {}).get("finger") or {}
    if not any(k in finger for k in HERTZ_FIELDS) or any(
        k in finger for k in ("skin_solref", "skin_solimp")
    ):
        return config
    try:
        return with_fitted_skin(config)
    except SimulationError as exc:
        raise ValueError(
            f"{file}: [simulator.finger]: the skin's contact cannot be fitted: {exc}"
        ) from None


def _with_finger(
    file: str, path: object, base_dir: str | os.PathLike, config: SynthConfig
) -> SynthConfig:
    """``config`` with the finger file ``finger = "FILE"`` names (relative to the
    experiment file's directory) applied after the ``[simulator]`` tables."""
    if path is None:
        return config
    if not isinstance(path, str) or not path:
        raise ValueError(f"{file}: finger must be a file name (a finger TOML); got {path!r}")
    from .calibration.finger_file import apply_finger

    return apply_finger(config, Path(base_dir) / path, arg=f"{file}: finger")


def overlay(base: Mapping[str, Any], over: Mapping[str, Any]) -> dict[str, Any]:
    """``base`` with ``over``'s values in place of its own, table by table (keys ``base``
    lacks are kept, for the configuration's own check to name)."""
    out = dict(base)
    for key, value in over.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = overlay(out[key], value)
        else:
            out[key] = value
    return out


def _materials(file: str, names: object, tables: object) -> dict[str, Any]:
    """The experiment's materials by name, in the order ``materials`` lists them: each a
    ``[[material]]`` table of the file or a library material. The library's file is read
    only for a name that is not one of the paper's three (so loading the presets, which
    name only those, reads nothing more)."""
    own: dict[str, Any] = {}
    if tables is not None:
        from . import material_data

        own = material_data.parse_materials(tables, file=file)
    if names is None:
        if not own:
            raise ValueError(
                f"{file}: no materials: list library materials in materials = [...] "
                f"(library: {', '.join(_library())}) or define your own in [[material]] "
                f"tables"
            )
        names = list(own)
    if isinstance(names, str) or not isinstance(names, list) or not names:
        raise ValueError(f"{file}: materials must be a non-empty list of names; got {names!r}")
    out: dict[str, Any] = {}
    for index, name in enumerate(names, start=1):
        where = f"{file}: materials[{index}]"
        if not isinstance(name, str) or not NAME_PATTERN.fullmatch(name):
            raise ValueError(f"{where}: a material name holds only {NAME_RULE}; got {name!r}")
        if name in out:
            raise ValueError(
                f"{file}: material {name!r}: listed twice in materials; every class "
                f"<specimen>/{name} would appear twice"
            )
        if name in own:
            out[name] = own[name]
        elif name in MATERIALS:  # the library's first three
            out[name] = MATERIALS[name]
        elif name in _library():
            out[name] = _library()[name]
        else:
            lib = _library()
            known = (*own, *lib)
            raise ValueError(
                f"{file}: material {name!r}: neither a [[material]] table of the file nor a "
                f"library material{_hint(name, known)}; library: {', '.join(lib)}"
            )
    unused = [n for n in own if n not in out]
    if unused:
        raise ValueError(
            f"{file}: material {unused[0]!r}: defined in a [[material]] table but not "
            f"listed in materials; add it there or remove its table"
        )
    return out


def _library() -> dict[str, Any]:
    from . import material_data

    return material_data.library()


def packaged_path(name: str) -> Path:
    """The experiment file of the package's preset ``name`` (``synth/experiments``)."""
    if name not in PACKAGED:
        raise ValueError(f"no packaged experiment {name!r}; the package has {', '.join(PACKAGED)}")
    return Path(str(resources.files("synth").joinpath("experiments", f"{name}.toml")))


def packaged() -> dict[str, GenerationConfig]:
    """The package's presets, each loaded from its experiment file."""
    return {name: load_experiment(packaged_path(name)) for name in PACKAGED}
