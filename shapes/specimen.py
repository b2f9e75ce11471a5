"""A user's specimen: one planar outline, raised on the plate like the paper's 12.

``Specimen`` holds the outline's vertices themselves (metres), so a dataset can record
its specimens and be resumed or regenerated without the files they were made from.
Every function of ``shapes`` that takes a built-in shape name also takes a
``Specimen`` (``outline``, ``solid``, ``mesh``, ``convex_pieces``, ``analytic_area_m2``,
``is_curved``, ``x_extent_m``).

Frame (as the built-ins, see ``shapes.dims``): x is the sliding direction, y is across
it, z is up; the plate's top is z = 0 and the outline is raised to z = ``height_m``.
The outline is centred on the origin along x by its bounding box (the simulator centres
its window on the crossing); along y it is centred by its bounding box unless the
specimen was made with an ``offset_y_m`` (the path runs along y = ``Motion.path_y_m``,
2 mm by default, so an offset chooses which part of the outline the finger crosses).

The checks and the reasons for every bound are in ``shapes.limits`` and
``docs/specimens.md``.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from typing import Any

import numpy as np
import shapely
from shapely.geometry import Polygon

from shapes import limits
from shapes.dims import SPECIMEN, SpecimenDims, check_dims
from shapes.names import SHAPE_NAMES, check_shape

#: A specimen's name is one part of a class name ``<specimen>/<material>``.
NAME_PATTERN = re.compile(r"[a-z0-9][a-z0-9_-]{0,63}")
NAME_RULE = "lower-case letters, digits, '_' and '-' (starting with a letter or digit, at most 64)"
#: Version of ``Specimen.to_dict`` and of the geometry hash.
FORMAT_VERSION = 1
#: Vertices closer than this are one vertex (far below any feature the finger can feel,
#: far above the rounding of coordinates read from a file).
DUPLICATE_TOL_M = 1e-9
#: Largest tolerated offset of the bounding box's centre from x = 0.
CENTRE_TOL_M = 1e-9


class SpecimenError(ValueError):
    """A specimen breaks one rule. ``str()`` is ``"specimen 'NAME': RULE"``; ``rule`` and
    ``name`` are kept apart so a loader can prefix the file and entry."""

    def __init__(self, name: object, rule: str) -> None:
        self.name = name
        self.rule = rule
        super().__init__(f"specimen {name!r}: {rule}")

    def __reduce__(self) -> tuple:
        # Rebuilt from its parts (a worker process may send it back to the client).
        return type(self), (self.name, self.rule)


def check_name(name: object) -> str:
    """Return ``name`` if it is a valid specimen name that no built-in shape has; else
    raise ``SpecimenError``."""
    if not isinstance(name, str) or not NAME_PATTERN.fullmatch(name):
        raise SpecimenError(name, f"a specimen name holds only {NAME_RULE}")
    if name in SHAPE_NAMES:
        raise SpecimenError(
            name,
            f"{name!r} is a built-in shape; a specimen with its own outline needs another name",
        )
    return name


def _mm(value_m: float) -> str:
    return f"{value_m * 1e3:.4g}"


def _point_mm(x_m: float, y_m: float) -> str:
    return f"({x_m * 1e3:.1f}, {y_m * 1e3:.1f}) mm"


def ring_array(name: object, vertices: object) -> np.ndarray:
    """``vertices`` as a float array (k, 2) with the closing repeat and consecutive
    duplicates removed; ``SpecimenError`` unless it holds >= 3 finite (x, y) pairs."""
    try:
        ring = np.array(vertices, dtype=np.float64)
    except (TypeError, ValueError):
        ring = None
    if ring is None or ring.ndim != 2 or ring.shape[1] != 2:
        raise SpecimenError(name, "the outline must be a list of (x, y) vertices")
    if not np.isfinite(ring).all():
        raise SpecimenError(name, "the outline's vertices must be finite numbers")
    if len(ring) > 1:
        # A vertex equal to the one before it goes, and the last one if it closes the ring.
        keep = np.ones(len(ring), dtype=bool)
        keep[1:] = np.hypot(*np.diff(ring, axis=0).T) > DUPLICATE_TOL_M
        ring = ring[keep]
        if len(ring) > 1 and np.hypot(*(ring[-1] - ring[0])) <= DUPLICATE_TOL_M:
            ring = ring[:-1]
    if len(ring) < 3:
        raise SpecimenError(name, "the outline needs at least 3 distinct vertices")
    return ring


def check_simple(name: object, ring: np.ndarray) -> Polygon:
    """The ring (k, 2) as a Polygon; ``SpecimenError`` if it crosses or touches itself,
    naming where (mm, in the ring's own coordinates)."""
    poly = Polygon(ring)
    if poly.is_valid and poly.area > 0:
        return poly
    if poly.convex_hull.area == 0:
        raise SpecimenError(name, "the outline encloses no area (its vertices lie on a line)")
    reason = shapely.is_valid_reason(poly)
    where = re.search(r"\[\s*([-+0-9.eE]+)\s+([-+0-9.eE]+)\s*\]", reason)
    near = f" near {_point_mm(float(where[1]), float(where[2]))}" if where else ""
    if "Self-intersection" in reason or "self-intersection" in reason.lower():
        raise SpecimenError(name, f"the outline crosses or touches itself{near}")
    raise SpecimenError(name, f"the outline is not a simple polygon ({reason})")


def _in_range(value: float, lo: float, hi: float) -> bool:
    return lo <= value <= hi


@dataclass(frozen=True)
class Specimen:
    """One planar outline extruded ``height_m`` above the plate: a user's specimen.

    Make one with :meth:`from_outline` (which orients and centres the vertices), with
    :meth:`from_build123d`, or from an experiment file (``shapes.load_specimens``);
    the constructor itself checks but changes nothing, so ``from_dict(to_dict())``
    gives back the same bits.

    Parameters
    ----------
    name : str
        The class-name part: lower-case letters, digits, ``_`` and ``-`` (at most 64),
        not one of ``shapes.SHAPE_NAMES``.
    vertices_m : sequence of (x, y)
        The outline in metres in the specimen frame (module docstring):
        counter-clockwise, the first vertex not repeated at the end, the bounding box
        centred on x = 0. Stored as a tuple of ``(float, float)`` tuples.
    height_m : float
        Raised height above the plate (default the paper's 2 mm); within
        ``shapes.limits.MIN_HEIGHT_M`` .. ``MAX_HEIGHT_M``.
    source : str
        Where the outline came from (free text, e.g. ``"svg gear.svg#outline"``).
    curved : bool
        True if the source had curved sides (polygonised within
        ``SPECIMEN.curve_tolerance_m``); as ``shapes.is_curved`` for the built-ins.

    Raises
    ------
    SpecimenError
        (a ``ValueError``) naming the specimen and the rule it breaks: the outline is
        not simple, encloses no area, runs clockwise, is not centred along x, is
        smaller than ``MIN_EXTENT_M`` or longer along x than ``MAX_X_EXTENT_M``, does
        not fit the default plate with its margins, or has no exact convex partition.

    Examples
    --------
    >>> import shapes
    >>> ell = Specimen.from_outline(
    ...     "l_bracket",
    ...     [(-8e-3, -6e-3), (8e-3, -6e-3), (8e-3, -2e-3), (-4e-3, -2e-3), (-4e-3, 6e-3),
    ...      (-8e-3, 6e-3)],
    ... )
    >>> round(ell.x_extent_m * 1e3, 6), len(shapes.convex_pieces(ell))
    (16.0, 2)
    """

    name: str
    vertices_m: tuple[tuple[float, float], ...]
    height_m: float = SPECIMEN.height_m
    source: str = ""
    curved: bool = False

    def __post_init__(self) -> None:
        name = check_name(self.name)
        if not isinstance(self.source, str):
            raise SpecimenError(name, f"source must be a string; got {self.source!r}")
        if not isinstance(self.curved, bool):
            raise SpecimenError(name, f"curved must be True or False; got {self.curved!r}")
        h = self.height_m
        if isinstance(h, bool) or not isinstance(h, int | float) or not math.isfinite(h):
            raise SpecimenError(name, f"height_m must be a number; got {h!r}")
        if not _in_range(h, limits.MIN_HEIGHT_M, limits.MAX_HEIGHT_M):
            raise SpecimenError(
                name,
                f"the height must lie within {_mm(limits.MIN_HEIGHT_M)}-"
                f"{_mm(limits.MAX_HEIGHT_M)} mm (the finger rides onto such a step); "
                f"got {_mm(h)} mm",
            )
        object.__setattr__(self, "height_m", float(h))
        ring = ring_array(name, self.vertices_m)
        if len(ring) != len(self.vertices_m):
            raise SpecimenError(
                name, "the outline repeats a vertex (Specimen.from_outline removes repeats)"
            )
        # + 0.0 turns -0.0 into 0.0: equal specimens then have equal geometry hashes.
        vertices = tuple((float(x) + 0.0, float(y) + 0.0) for x, y in ring)
        object.__setattr__(self, "vertices_m", vertices)
        poly = check_simple(name, ring)
        if not poly.exterior.is_ccw:
            raise SpecimenError(
                name,
                "the vertices must run counter-clockwise (Specimen.from_outline orients them)",
            )
        x0, y0, x1, y1 = poly.bounds
        if abs(x0 + x1) / 2 > CENTRE_TOL_M:
            raise SpecimenError(
                name,
                "the outline must be centred on x = 0 by its bounding box "
                f"(its centre is at x = {_mm((x0 + x1) / 2)} mm; Specimen.from_outline "
                "centres it)",
            )
        _check_size(name, x1 - x0, y1 - y0)
        _check_on_plate(name, poly, SPECIMEN)
        _check_partition(name, poly)

    # --- construction -------------------------------------------------------------

    @classmethod
    def from_outline(
        cls,
        name: str,
        vertices_m: object,
        *,
        height_m: float = SPECIMEN.height_m,
        source: str = "",
        curved: bool = False,
        offset_y_m: float = 0.0,
    ) -> Specimen:
        """A specimen from outline vertices (k, 2) in metres, in any position and either
        orientation, closed or not (a repeated first vertex is dropped).

        The outline is checked for simplicity in its own coordinates (so an error names
        the place where it crosses itself as the caller gave it), then turned
        counter-clockwise and centred on the origin by its bounding box, then moved
        ``offset_y_m`` along y.
        """
        check_name(name)
        if (
            isinstance(offset_y_m, bool)
            or not isinstance(offset_y_m, int | float)
            or not math.isfinite(offset_y_m)
        ):
            raise SpecimenError(name, f"offset_y_m must be a number; got {offset_y_m!r}")
        ring = ring_array(name, vertices_m)
        poly = check_simple(name, ring)
        if not poly.exterior.is_ccw:
            ring = ring[::-1]
        x0, y0, x1, y1 = poly.bounds
        ring = ring - [(x0 + x1) / 2, (y0 + y1) / 2 - float(offset_y_m)]
        return cls(
            name=name,
            vertices_m=tuple((float(x), float(y)) for x, y in ring),
            height_m=height_m,
            source=source,
            curved=curved,
        )

    @classmethod
    def from_build123d(
        cls,
        name: str,
        shape: object,
        *,
        unit_m: float = 1e-3,
        height_m: float = SPECIMEN.height_m,
        source: str = "",
        offset_y_m: float = 0.0,
    ) -> Specimen:
        """A specimen from a build123d ``Face``, ``Sketch`` (one face) or closed ``Wire``
        in the plane z = 0, its numbers in units of ``unit_m`` metres (millimetres by
        default). Curved sides are polygonised within ``SPECIMEN.curve_tolerance_m``."""
        from shapes.sources import build123d_outline

        try:
            ring_m, curved = build123d_outline(shape, SPECIMEN.curve_tolerance_m, unit_m)
        except ValueError as exc:
            raise SpecimenError(name, str(exc)) from None
        return cls.from_outline(
            name,
            ring_m,
            height_m=height_m,
            source=source,
            curved=curved,
            offset_y_m=offset_y_m,
        )

    # --- serialisation ------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        """A plain JSON-serialisable dict holding everything, vertices included, and the
        geometry hash (checked by :meth:`from_dict`)."""
        return {
            "format": FORMAT_VERSION,
            "name": self.name,
            "source": self.source,
            "curved": self.curved,
            "height_m": self.height_m,
            "vertices_m": [[x, y] for x, y in self.vertices_m],
            "geometry_sha256": self.geometry_hash,
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Specimen:
        """The specimen :meth:`to_dict` wrote (``ValueError`` naming the key otherwise).
        JSON keeps every float exactly, so the result equals the original."""
        if not isinstance(data, Mapping):
            raise ValueError(f"a specimen record must be a mapping; got {type(data).__name__}")
        expected = {"format", "geometry_sha256", *(f.name for f in fields(cls))}
        unknown = sorted(set(data) - expected)
        if unknown:
            raise ValueError(f"a specimen record has unknown keys: {', '.join(unknown)}")
        missing = [k for k in ("name", "vertices_m") if k not in data]
        if missing:
            raise ValueError(f"a specimen record lacks {', '.join(missing)}")
        if data.get("format", FORMAT_VERSION) != FORMAT_VERSION:
            raise ValueError(
                f"specimen {data['name']!r}: record format {data['format']!r} is not "
                f"{FORMAT_VERSION} (written by another version of tactile-synth)"
            )
        spec = cls(**{f.name: data[f.name] for f in fields(cls) if f.name in data})
        stored = data.get("geometry_sha256")
        if stored is not None and stored != spec.geometry_hash:
            raise SpecimenError(
                spec.name, "the record's geometry_sha256 does not match its vertices"
            )
        return spec

    @functools.cached_property
    def geometry_hash(self) -> str:
        """SHA-256 (hex) of the geometry: vertices and height, not name or source. Keys
        the mesh cache, and tells whether two specimens are the same solid."""
        key = json.dumps(
            {"format": FORMAT_VERSION, "height_m": self.height_m, "vertices_m": self.vertices_m}
        )
        return hashlib.sha256(key.encode()).hexdigest()

    # --- geometry -----------------------------------------------------------------

    @functools.cached_property
    def polygon(self) -> Polygon:
        """The outline as a shapely Polygon (metres)."""
        return Polygon(self.vertices_m)

    @property
    def bounds_m(self) -> tuple[float, float, float, float]:
        """``(x_min, y_min, x_max, y_max)`` in metres."""
        return tuple(float(v) for v in self.polygon.bounds)

    @property
    def x_extent_m(self) -> float:
        """Length along x, the sliding direction (sizes the simulator's path)."""
        x0, _, x1, _ = self.bounds_m
        return x1 - x0

    @property
    def y_extent_m(self) -> float:
        """Width across the sliding direction."""
        _, y0, _, y1 = self.bounds_m
        return y1 - y0

    @property
    def area_m2(self) -> float:
        """Area of the outline polygon (exact for it; a curved source's polygon lies
        within the chord tolerance of its curves)."""
        return float(self.polygon.area)

    def check_on_plate(self, dims: SpecimenDims = SPECIMEN) -> Specimen:
        """Return self if the outline fits ``dims``' plate with the finger's margins
        (``shapes.limits``); else ``SpecimenError``. The constructor checks the default
        plate; functions taking a ``dims`` check theirs."""
        check_dims(dims)
        _check_on_plate(self.name, self.polygon, dims)
        return self


def _check_size(name: str, x_extent: float, y_extent: float) -> None:
    lo, hi = limits.MIN_EXTENT_M, limits.MAX_X_EXTENT_M
    if x_extent > hi:
        raise SpecimenError(
            name,
            f"the outline is {_mm(x_extent)} mm long along x; at most {_mm(hi)} mm fits the "
            "2 s window at 10 mm/s",
        )
    for axis, extent in (("x", x_extent), ("y", y_extent)):
        if extent < lo:
            raise SpecimenError(
                name,
                f"the outline is {_mm(extent)} mm across along {axis}; at least {_mm(lo)} mm "
                "carries the finger's contact patch",
            )


def _check_on_plate(name: str, poly: Polygon, dims: SpecimenDims) -> None:
    x0, y0, x1, y1 = poly.bounds
    x_lim = dims.base_length_m / 2 - limits.PLATE_MARGIN_X_M
    y_lim = dims.base_width_m / 2 - limits.PLATE_MARGIN_Y_M
    if max(-x0, x1) > x_lim or max(-y0, y1) > y_lim:
        raise SpecimenError(
            name,
            f"the outline (x {_mm(x0)} to {_mm(x1)} mm, y {_mm(y0)} to {_mm(y1)} mm) does not "
            f"fit the {_mm(dims.base_length_m)} x {_mm(dims.base_width_m)} mm plate with the "
            f"finger's margins: it must lie within |x| <= {_mm(x_lim)} mm and "
            f"|y| <= {_mm(y_lim)} mm",
        )


def _check_partition(name: str, poly: Polygon) -> None:
    from shapes.partition import convex_partition

    try:
        pieces = convex_partition(poly)
    except (RuntimeError, ValueError) as exc:
        raise SpecimenError(name, f"the outline has no exact convex partition ({exc})") from None
    total = sum(Polygon(p).area for p in pieces)
    if not math.isclose(total, poly.area, rel_tol=1e-9):
        raise SpecimenError(name, "the outline's convex pieces do not add up to its area")


#: A built-in shape name or a user's specimen: what every ``shapes`` function takes.
SpecimenLike = str | Specimen


def specimen_name(shape: SpecimenLike) -> str:
    """The name of a built-in shape or a specimen (the class-name part)."""
    return shape.name if isinstance(shape, Specimen) else shape


def specimen_to_dict(shape: SpecimenLike) -> dict[str, Any]:
    """A JSON-serialisable record of a built-in (``{"name": ...}``) or a specimen
    (:meth:`Specimen.to_dict`), for a dataset's list of its specimens."""
    if isinstance(shape, Specimen):
        return shape.to_dict()
    return {"name": check_shape(shape)}


def specimen_from_dict(data: Mapping[str, Any]) -> SpecimenLike:
    """The inverse of :func:`specimen_to_dict`: a built-in's name or a ``Specimen``."""
    if isinstance(data, Mapping) and set(data) == {"name"} and data["name"] in SHAPE_NAMES:
        return data["name"]
    return Specimen.from_dict(data)


def specimens_to_json(shapes_: Sequence[SpecimenLike]) -> str:
    """A list of built-ins and specimens as one JSON text (see :func:`specimen_to_dict`)."""
    return json.dumps([specimen_to_dict(s) for s in shapes_])


def specimens_from_json(text: str) -> tuple[SpecimenLike, ...]:
    """The inverse of :func:`specimens_to_json`."""
    data = json.loads(text)
    if not isinstance(data, list):
        raise ValueError("a specimen list must be a JSON list")
    return tuple(specimen_from_dict(d) for d in data)
