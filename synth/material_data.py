"""Materials as data: the ``[[material]]`` TOML schema, its checked loader, and the shipped
library of cited rigid materials.

A material is what :class:`synth.materials.Material` holds: a name, the skin's friction
law on the surface (:class:`~synth.materials.FrictionLaw`) and the surface texture
(:class:`~synth.materials.Texture`). In a file it is one table::

    [[material]]
    name = "cork"                       # [a-z0-9][a-z0-9_-]*, at most 64 characters
    [material.friction]
    kinetic = 1.15                      # sliding coefficient at 1 N
    static = 1.38                       # coefficient at rest, >= kinetic
    stribeck_velocity_m_s = 1e-3        # optional (FrictionLaw's default)
    load_exponent = -0.21               # optional (FrictionLaw's default)
    velocity_exponent = 0.0             # optional: mu ~ (v / reference_speed_m_s)^this
    reference_speed_m_s = 0.010         # optional (FrictionLaw's default)
    [material.texture]
    roughness_rms_m = 20e-6
    correlation_length_m = 200e-6
    [[material.texture.periodic]]       # optional, any number
    wavelength_m = 1e-3
    amplitude_m = 5e-6

Every number has its unit in its name and a physical range (:data:`RANGES`, explained in
``docs/materials.md``). A bad table raises one ``ValueError`` line naming the file, the
entry and the field and the rule it breaks, e.g.
``lab.toml: material 'cork': texture.roughness_rms_m must lie in 0..100e-6 m; got -1e-06``
(``material #N`` where the N-th table has no usable name). Loading writes nothing.

The library (:func:`library`) is the paper's three materials
(:data:`synth.materials.MATERIALS`) plus the cited ones shipped in
``synth/material_library.toml``, read on first use. A file's material may not take a
library material's name unless its table says ``replace = true``: a lab that writes its
own "glass" by accident would otherwise silently shadow the cited one, or be shadowed by
it.
"""

from __future__ import annotations

import difflib
import functools
import math
import os
import re
import tomllib
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from importlib import resources
from numbers import Real
from typing import Any

from tactile_synth.validation import check_choice, read_toml

from .materials import MATERIALS, FrictionLaw, Material, Periodic, Texture

#: A material's name is one part of a class name ``<specimen>/<material>`` (the same rule
#: as a specimen's name).
NAME_PATTERN = re.compile(r"[a-z0-9][a-z0-9_-]{0,63}")
NAME_RULE = "lower-case letters, digits, '_' and '-' (starting with a letter or digit, at most 64)"
#: The library's data file, inside the ``synth`` package.
LIBRARY_FILE = "material_library.toml"
#: How the library's file is named in errors.
LIBRARY_LABEL = f"synth/{LIBRARY_FILE}"

#: Keys of a ``[[material]]`` table and of its sub-tables.
MATERIAL_KEYS = ("name", "friction", "texture", "replace")
FRICTION_KEYS = (
    "kinetic",
    "static",
    "stribeck_velocity_m_s",
    "load_exponent",
    "velocity_exponent",
    "reference_speed_m_s",
)
TEXTURE_KEYS = ("roughness_rms_m", "correlation_length_m", "periodic")
PERIODIC_KEYS = ("wavelength_m", "amplitude_m")
#: Keys with a default: FrictionLaw's own defaults; no periodic marks.
OPTIONAL_KEYS = frozenset(
    {
        "stribeck_velocity_m_s",
        "load_exponent",
        "velocity_exponent",
        "reference_speed_m_s",
        "periodic",
        "replace",
    }
)


@dataclass(frozen=True)
class Bound:
    """The physical range of one field: ``lo <= value <= hi`` (``< hi`` if ``hi_open``).

    ``text`` is the range as the error and the docs show it; ``why`` the reason.
    """

    lo: float
    hi: float
    text: str
    why: str
    hi_open: bool = False

    def contains(self, value: float) -> bool:
        return self.lo <= value and (value < self.hi if self.hi_open else value <= self.hi)

    @property
    def rule(self) -> str:
        return f"must lie in {self.text}"


#: Physical range of every number of the schema, by its path in the table. The overlap
#: with the dataclasses' own checks is the same rule (static < 3, load_exponent in -1..0,
#: lengths >= 0 or > 0); these ranges are narrower, never wider.
RANGES: dict[str, Bound] = {
    # A dry skin-on-solid coefficient: silicone on PLA spans 0.62-1.67 (the library
    # file's header) and soft adhesive contacts on smooth glass run higher; below 0.05 is
    # a lubricated bearing, not a dry fingertip. FrictionLaw accepts static < 3 only.
    "friction.kinetic": Bound(
        0.05, 3.0, "0.05..3 (3 excluded)", "a dry skin-on-solid coefficient", hi_open=True
    ),
    "friction.static": Bound(
        0.05, 3.0, "0.05..3 (3 excluded)", "a dry skin-on-solid coefficient", hi_open=True
    ),
    # Two decades either side of the 1 mm/s default: below 10 um/s the static level
    # would hold only at imperceptible creep; above 0.1 m/s, 4.5 times the fastest
    # sliding speed the simulator accepts (22 mm/s), the coefficient would never reach
    # its kinetic value during a stroke.
    "friction.stribeck_velocity_m_s": Bound(
        1e-5, 0.1, "1e-5..0.1 m/s", "a velocity-weakening scale below sliding speeds"
    ),
    # 0: Amontons (load-independent); -1/3: Hertz with a constant interfacial shear
    # strength; -1: a friction force that no longer grows with load. A coefficient rising
    # with load is not an adhesive soft contact. FrictionLaw's own range.
    "friction.load_exponent": Bound(
        -1.0, 0.0, "-1..0", "a soft contact's coefficient falls with load, at most as 1/F"
    ),
    # 0 is the rate-independent law. An elastomer's sliding friction grows with speed
    # below its peak by d ln mu / d ln v of a few tenths at most (Grosch 1963, Proc. R.
    # Soc. A 274, 21: mu rises about fivefold over four decades of speed); half leaves a
    # margin either way, and a falling coefficient is the stick-slip regime.
    "friction.velocity_exponent": Bound(
        -0.5, 0.5, "-0.5..0.5", "an elastomer's friction changes slowly with speed"
    ),
    # The speed the kinetic coefficient is quoted at: within the simulator's sliding
    # speeds (up to 22 mm/s) and a decade below them.
    "friction.reference_speed_m_s": Bound(
        1e-4, 0.1, "1e-4..0.1 m/s", "a sliding speed the coefficient was measured at"
    ),
    # P120 sandpaper measures Rq ~53 um (the library's sandpaper_p120); 100 um leaves room
    # for coarser papers, and a rougher relief is one a fingertip catches on rather than
    # slides over.
    "texture.roughness_rms_m": Bound(0.0, 100e-6, "0..100e-6 m", "up to coarse sandpaper"),
    # Below 1 um the relief is far under the simulator's 5 um profile grid and the
    # 0.15 mm fingerprint ridges; beyond 5 mm the exponential model puts most of its
    # variance at wavelengths longer than the 20 mm a 2 s window covers at 10 mm/s: a
    # waviness or tilt of the plate, not a texture.
    "texture.correlation_length_m": Bound(
        1e-6, 5e-3, "1e-6..5e-3 m", "a texture, not a waviness of the plate"
    ),
    # 10 um is twice the 5 um profile grid (synth.texture.GRID_M): the shortest
    # wavelength the grid represents without aliasing. 20 mm is the path a 2 s window
    # covers at the nominal 10 mm/s: a longer period is a tilt of the stroke.
    "texture.periodic.wavelength_m": Bound(
        10e-6, 20e-3, "10e-6..20e-3 m", "resolved by the profile grid, shorter than a stroke"
    ),
    # As the random roughness: a relief of 0.1 mm is a shape, not a texture.
    "texture.periodic.amplitude_m": Bound(0.0, 100e-6, "0..100e-6 m", "a texture's relief"),
}

#: Steepest slope of a periodic mark, ``2 pi amplitude / wavelength``: 1 (45 degrees).
#: The texture acts through its height and small slope under the contact
#: (synth.texture); a steeper relief is an edge, which the specimen's outline models.
MAX_MARK_SLOPE = 1.0


def material_from_table(
    table: object, *, file: str = "<table>", entry: int | None = None
) -> Material:
    """One ``[[material]]`` table (a mapping, as ``tomllib`` reads it) as a checked
    :class:`~synth.materials.Material`.

    Parameters
    ----------
    table : mapping
        ``name``, a ``friction`` table and a ``texture`` table (module docstring); an
        optional ``replace`` (true or false) is checked here and used by
        :func:`parse_materials`.
    file : str
        Names the file in errors.
    entry : int, optional
        The table's position in its file (from 1), named in errors when the table has
        no usable name.

    Raises
    ------
    ValueError
        One line: ``"FILE: material 'NAME': FIELD RULE; got VALUE"``.

    Examples
    --------
    >>> m = material_from_table({
    ...     "name": "cork",
    ...     "friction": {"kinetic": 1.15, "static": 1.38},
    ...     "texture": {"roughness_rms_m": 20e-6, "correlation_length_m": 200e-6},
    ... })
    >>> m.friction.load_exponent, m.texture.periodic
    (-0.21, ())
    >>> material_from_table({"name": "cork"}, file="lab.toml")
    Traceback (most recent call last):
    ...
    ValueError: lab.toml: material 'cork': friction is required (a [material.friction] table)
    """
    where = _where(file, entry, table)
    if not isinstance(table, Mapping):
        raise ValueError(f"{where} must be a table ([[material]]); got {table!r}")
    _check_keys(where, "key", table, MATERIAL_KEYS)
    name = _check_name(where, table)
    where = f"{file}: material {name!r}"
    if "replace" in table and not isinstance(table["replace"], bool):
        raise ValueError(f"{where}: replace must be true or false; got {table['replace']!r}")
    friction = _friction(where, _sub_table(where, table, "friction", "[material.friction]"))
    texture = _texture(where, _sub_table(where, table, "texture", "[material.texture]"))
    try:
        return Material(name=name, friction=friction, texture=texture)
    except ValueError as exc:  # the dataclass's own rule, should one be stricter than ours
        raise ValueError(f"{where}: {exc}") from None


def material_to_table(material: Material) -> dict[str, Any]:
    """``material`` as a ``[[material]]`` table (plain dicts, lists and floats: it
    serialises as TOML or JSON), every field written out, so that
    ``material_from_table(material_to_table(m)) == m``.

    Examples
    --------
    >>> from synth.materials import MATERIALS
    >>> table = material_to_table(MATERIALS["aluminum"])
    >>> sorted(table), sorted(table["texture"])
    (['friction', 'name', 'texture'], ['correlation_length_m', 'periodic', 'roughness_rms_m'])
    >>> material_from_table(table) == MATERIALS["aluminum"]
    True
    """
    if not isinstance(material, Material):
        raise ValueError(f"material must be a Material; got {material!r}")
    f, t = material.friction, material.texture
    return {
        "name": material.name,
        "friction": {key: float(getattr(f, key)) for key in FRICTION_KEYS},
        "texture": {
            "roughness_rms_m": float(t.roughness_rms_m),
            "correlation_length_m": float(t.correlation_length_m),
            "periodic": [
                {"wavelength_m": float(p.wavelength_m), "amplitude_m": float(p.amplitude_m)}
                for p in t.periodic
            ],
        },
    }


def parse_materials(
    tables: object, *, file: str, library_names: Collection[str] | None = None
) -> dict[str, Material]:
    """The materials of an already parsed file's ``material`` array, by name in the
    file's order; ``{}`` if ``tables`` is None (an experiment file that defines no
    material of its own and names only library ones).

    Every table is checked (:func:`material_from_table`); two tables may not share a
    name; a name in ``library_names`` (default: the names of :func:`library`) is an
    error unless the table says ``replace = true``, and ``replace = true`` on a name the
    library does not hold is an error too (most likely a misspelt name). Raises a
    one-line ``ValueError`` naming ``file``, the entry and the rule.
    """
    if tables is None:
        return {}
    if library_names is None:
        library_names = tuple(library())
    return _parse(tables, file=file, reserved=tuple(library_names), allow_replace=True)


def load_materials(path: str | os.PathLike) -> dict[str, Material]:
    """The materials of a file of ``[[material]]`` tables (and nothing else), by name in
    the file's order; see :func:`parse_materials` for the rules. Only the file's own
    materials are returned: ``{**library(), **load_materials(path)}`` is the set a
    ``replace = true`` table means.

    Raises a one-line ``ValueError`` naming the file (and the entry and the rule) if the
    file is missing, not TOML, holds other top-level keys or a bad table.
    """
    file = str(path)
    data = read_toml(path, "a materials file")
    _check_keys(file, "top-level key", data, ("material",))
    if "material" not in data:
        raise ValueError(f"{file}: no [[material]] tables (see docs/materials.md)")
    return parse_materials(data["material"], file=file)


def library() -> dict[str, Material]:
    """The library: the paper's three (:data:`synth.materials.MATERIALS`, first) and the
    cited materials of ``synth/material_library.toml``, by name. A new dict each call
    (the materials themselves are frozen).

    Examples
    --------
    >>> lib = library()
    >>> list(lib)[:3]
    ['resin', 'wood', 'aluminum']
    >>> {"glass", "pla_fdm", "sandpaper_p120", "brushed_steel"} <= set(lib)
    True
    """
    return dict(_library())


def library_material(name: object) -> Material:
    """The library material called ``name``; a ``ValueError`` listing the library (with a
    did-you-mean hint) otherwise."""
    lib = _library()
    return lib[check_choice("material", name, lib)]


@functools.cache
def _library() -> dict[str, Material]:
    raw = resources.files("synth").joinpath(LIBRARY_FILE).read_bytes()
    try:
        data = tomllib.loads(raw.decode("utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{LIBRARY_LABEL}: not valid TOML: {' '.join(str(exc).split())}") from None
    _check_keys(LIBRARY_LABEL, "top-level key", data, ("material",))
    shipped = _parse(
        data.get("material"), file=LIBRARY_LABEL, reserved=tuple(MATERIALS), allow_replace=False
    )
    return {**MATERIALS, **shipped}


def _parse(
    tables: object, *, file: str, reserved: tuple[str, ...], allow_replace: bool
) -> dict[str, Material]:
    if tables is None:
        raise ValueError(f"{file}: no [[material]] tables (see docs/materials.md)")
    if isinstance(tables, Mapping):
        raise ValueError(f"{file}: write [[material]] (one table per material), not [material]")
    if not isinstance(tables, list):
        raise ValueError(f"{file}: 'material' must be an array of tables ([[material]])")
    if not tables:
        raise ValueError(f"{file}: no [[material]] tables")
    materials: dict[str, Material] = {}
    seen: dict[str, int] = {}
    for index, table in enumerate(tables, start=1):
        material = material_from_table(table, file=file, entry=index)
        name = material.name
        where = f"{file}: material {name!r}"
        if name in seen:
            raise ValueError(
                f"{where}: the name appears twice (material tables {seen[name]} and {index}); "
                "every material needs its own name"
            )
        seen[name] = index
        replace = table.get("replace", False)
        if replace and not allow_replace:
            raise ValueError(f"{where}: replace is not allowed here")
        if name in reserved and not replace:
            raise ValueError(
                f"{where}: {name!r} is a library material; give yours another name, or "
                "set replace = true in its table to use it instead of the library's"
            )
        if replace and name not in reserved:
            raise ValueError(
                f"{where}: replace = true, but the library has no material {name!r} to "
                f"replace{_hint(name, reserved)}; remove replace for a new material"
            )
        materials[name] = material
    return materials


def _where(file: str, entry: int | None, table: object) -> str:
    name = table.get("name") if isinstance(table, Mapping) else None
    if isinstance(name, str) and NAME_PATTERN.fullmatch(name):
        return f"{file}: material {name!r}"
    return f"{file}: material #{entry}" if entry is not None else f"{file}: material"


def _hint(value: str, options: Collection[str]) -> str:
    close = difflib.get_close_matches(value, list(options), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _check_keys(where: str, what: str, table: Mapping[str, Any], keys: tuple[str, ...]) -> None:
    for key in table:
        try:
            check_choice(what, key, keys)
        except ValueError as exc:
            raise ValueError(f"{where}: {exc}") from None


def _check_name(where: str, table: Mapping[str, Any]) -> str:
    if "name" not in table:
        raise ValueError(f"{where}: name is required")
    name = table["name"]
    if not isinstance(name, str) or not NAME_PATTERN.fullmatch(name):
        raise ValueError(f"{where}: name must hold only {NAME_RULE}; got {name!r}")
    return name


def _sub_table(where: str, table: Mapping[str, Any], key: str, header: str) -> Mapping[str, Any]:
    if key not in table:
        raise ValueError(f"{where}: {key} is required (a {header} table)")
    sub = table[key]
    if not isinstance(sub, Mapping):
        raise ValueError(f"{where}: {key} must be a table ({header}); got {sub!r}")
    return sub


def _number(where: str, table: Mapping[str, Any], prefix: str, key: str, bound: str) -> float:
    """``table[key]`` as a float within ``RANGES[bound]``; the error names the field
    ``prefix + key``."""
    path = prefix + key
    if key not in table:
        raise ValueError(f"{where}: {path} is required")
    value = table[key]
    if isinstance(value, bool) or not isinstance(value, Real):
        raise ValueError(f"{where}: {path} must be a number; got {value!r}")
    if not math.isfinite(value):
        raise ValueError(f"{where}: {path} must be a finite number; got {value!r}")
    if not RANGES[bound].contains(value):
        raise ValueError(f"{where}: {path} {RANGES[bound].rule}; got {value!r}")
    return float(value)


def _friction(where: str, table: Mapping[str, Any]) -> FrictionLaw:
    _check_keys(where, "friction key", table, FRICTION_KEYS)
    values = {
        key: _number(where, table, "friction.", key, f"friction.{key}")
        for key in FRICTION_KEYS
        if key in table or key not in OPTIONAL_KEYS
    }
    if values["static"] < values["kinetic"]:
        raise ValueError(
            f"{where}: friction.static must be >= friction.kinetic ({table['kinetic']!r}); "
            f"got {table['static']!r}"
        )
    try:
        return FrictionLaw(**values)
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None


def _texture(where: str, table: Mapping[str, Any]) -> Texture:
    _check_keys(where, "texture key", table, TEXTURE_KEYS)
    rough = _number(where, table, "texture.", "roughness_rms_m", "texture.roughness_rms_m")
    corr = _number(where, table, "texture.", "correlation_length_m", "texture.correlation_length_m")
    marks = table.get("periodic", [])
    if not isinstance(marks, list) or not all(isinstance(m, Mapping) for m in marks):
        raise ValueError(
            f"{where}: texture.periodic must be an array of tables "
            f"([[material.texture.periodic]]); got {marks!r}"
        )
    periodic = tuple(_periodic(where, i, m) for i, m in enumerate(marks, start=1))
    try:
        return Texture(roughness_rms_m=rough, correlation_length_m=corr, periodic=periodic)
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None


def _periodic(where: str, index: int, table: Mapping[str, Any]) -> Periodic:
    path = f"texture.periodic[{index}]"
    _check_keys(where, f"{path} key", table, PERIODIC_KEYS)
    wavelength = _number(where, table, f"{path}.", "wavelength_m", "texture.periodic.wavelength_m")
    amplitude = _number(where, table, f"{path}.", "amplitude_m", "texture.periodic.amplitude_m")
    if 2 * math.pi * amplitude > MAX_MARK_SLOPE * wavelength:
        raise ValueError(
            f"{where}: {path}.amplitude_m must be <= wavelength_m / (2 pi) = "
            f"{wavelength / (2 * math.pi):.3g} m (a mark's slope of at most 1, 45 degrees; "
            f"a steeper relief is an edge of the outline); got {table['amplitude_m']!r}"
        )
    try:
        return Periodic(wavelength_m=wavelength, amplitude_m=amplitude)
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None
