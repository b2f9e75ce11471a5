"""The 12 planar outlines (S1..S12 of the reference paper) as exact definitions.

Every outline is defined from one nominal size ``s = dims.outline_size_m``
(16 mm by default) with the ratios below, so all 12 scale together and have
comparable size. Frame: x is the sliding direction, y across it; each outline
is centred on the origin by its bounding box, except ``moon`` (see below).

==============  ======================================================  =========
name            definition (values at s = 16 mm)                        x extent
==============  ======================================================  =========
circle          disc, diameter s (16)                                   16
ellipse         semi-axes 9/16 s along x, 6/16 s along y (18 x 12)      18
semicircle      half disc, radius s/2 (8), flat side parallel to x,     16
                facing -y (the chord at y = 0 is 13.9 mm long)
hexagon         regular, circumradius s/2 (8), vertices on the x axis   16
moon            crescent: disc radius s/2 centred at the origin minus   16
                a disc of the same radius centred at (0, 5/16 s); the
                notch opens towards +y and the centre line y = 0
                crosses horn (1.8 mm), notch (12.5 mm), horn
parallelogram   sides 3/4 s (12) along x, height 5/8 s (10), top side   16
                shifted +1/4 s (4) in x
pentagon        regular, circumradius s/2 (8), one vertex towards +y    15.2
pentagram       regular {5/2} star (concave, 10 vertices), outer        16.2
                radius 17/32 s (8.5), inner radius 0.382 x outer
                (= (3 - sqrt 5) / 2), one point towards +y
rhombus         diagonals s (16) along x and 11/16 s (11) along y       16
square          side 7/8 s (14; area close to the circle's), edges      14
                parallel to the axes
trapezoid       isosceles, bottom base s (16), top base s/2 (8),        16
                height 5/8 s (10)
triangle        equilateral, side s (16), one side parallel to x        16
                (at -y), apex towards +y
==============  ======================================================  =========

The moon is centred on its parent disc rather than its bounding box so that the
path along y = 0 runs through the notch (a bounding-box centre would put the
path on the crescent's solid band and hide the concavity).

Curved outlines are returned as polygons whose vertices lie on the exact curve
with chord error <= ``dims.curve_tolerance_m``; ``analytic_area_m2`` gives the
exact area of the definition, computed from the formulas, not from a polygon.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import Polygon

from shapes.dims import SPECIMEN, SpecimenDims, check_dims
from shapes.names import SHAPE_NAMES, check_shape
from shapes.specimen import Specimen, SpecimenLike

# Dimensionless ratios of the definitions above (multiples of s).
ELLIPSE_SEMI_AXES = (9 / 16, 6 / 16)
MOON_OFFSET = 5 / 16
PARALLELOGRAM_SIDE, PARALLELOGRAM_HEIGHT, PARALLELOGRAM_SHIFT = 3 / 4, 5 / 8, 1 / 4
PENTAGRAM_OUTER = 17 / 32
PENTAGRAM_INNER_RATIO = (3 - math.sqrt(5)) / 2  # regular {5/2} star: cos 72 deg / cos 36 deg
RHOMBUS_DIAGONALS = (1.0, 11 / 16)
SQUARE_SIDE = 7 / 8
TRAPEZOID_BASES, TRAPEZOID_HEIGHT = (1.0, 1 / 2), 5 / 8
TRIANGLE_SIDE = 1.0


@dataclass(frozen=True)
class ShapeDef:
    """How one outline is built: vertices (k, 2) in metres, exact area, curved or not."""

    vertices: Callable[[SpecimenDims], np.ndarray]
    area_m2: Callable[[SpecimenDims], float]
    curved: bool


def sample_curve(
    point: Callable[[np.ndarray], np.ndarray], t0: float, t1: float, tolerance_m: float
) -> np.ndarray:
    """Points (n + 1, 2) on a smooth curve ``point(t)`` (t: (m,) -> (m, 2)), endpoints
    included, uniform in t, with the fewest segments whose chord error <= tolerance_m.

    The error of each chord is measured at the curve point half-way in t, which is
    the largest deviation for circular arcs and within a few percent of it for the
    ellipse's gentle changes of curvature (tests check the result independently).
    """
    n = 4
    while True:
        t = np.linspace(t0, t1, n + 1)
        pts = point(t)
        mid = point((t[:-1] + t[1:]) / 2)
        chord = pts[1:] - pts[:-1]
        rel = mid - pts[:-1]
        dev = np.abs(chord[:, 0] * rel[:, 1] - chord[:, 1] * rel[:, 0]) / np.hypot(*chord.T)
        if dev.max() <= 0.9 * tolerance_m:
            return pts
        n = math.ceil(n * 1.1) + 1


def _arc(cx: float, cy: float, r: float) -> Callable[[np.ndarray], np.ndarray]:
    return lambda t: np.column_stack([cx + r * np.cos(t), cy + r * np.sin(t)])


def _regular(n: int, radius: float, start_deg: float) -> np.ndarray:
    ang = np.deg2rad(start_deg) + 2 * np.pi * np.arange(n) / n
    return np.column_stack([radius * np.cos(ang), radius * np.sin(ang)])


def _lens_area(r: float, d: float) -> float:
    """Area of the intersection of two discs of radius r whose centres are d apart."""
    return 2 * r * r * math.acos(d / (2 * r)) - d / 2 * math.sqrt(4 * r * r - d * d)


def _circle(d: SpecimenDims) -> np.ndarray:
    r = d.outline_size_m / 2
    return sample_curve(_arc(0, 0, r), 0, 2 * np.pi, d.curve_tolerance_m)[:-1]


def _ellipse(d: SpecimenDims) -> np.ndarray:
    a, b = (k * d.outline_size_m for k in ELLIPSE_SEMI_AXES)

    def point(t: np.ndarray) -> np.ndarray:
        return np.column_stack([a * np.cos(t), b * np.sin(t)])

    return sample_curve(point, 0, 2 * np.pi, d.curve_tolerance_m)[:-1]


def _semicircle(d: SpecimenDims) -> np.ndarray:
    r = d.outline_size_m / 2
    # Arc from (r, -r/2) over the top to (-r, -r/2); the flat side closes the ring.
    return sample_curve(_arc(0, -r / 2, r), 0, np.pi, d.curve_tolerance_m)


def _moon(d: SpecimenDims) -> np.ndarray:
    r = d.outline_size_m / 2
    off = MOON_OFFSET * d.outline_size_m
    tip_x = math.sqrt(r * r - off * off / 4)  # horn tips at (+-tip_x, off/2)
    # The right tip is at angle +alpha from the disc's centre and -alpha from the bite's.
    alpha = math.atan2(off / 2, tip_x)
    tol = d.curve_tolerance_m
    # Outer arc counter-clockwise from the left tip round the bottom to the right tip,
    # then the bite's lower arc clockwise back to the left tip.
    outer = sample_curve(_arc(0, 0, r), np.pi - alpha, 2 * np.pi + alpha, tol)
    inner = sample_curve(_arc(0, off, r), -alpha, -np.pi + alpha, tol)
    return np.vstack([outer, inner[1:-1]])


def _parallelogram(d: SpecimenDims) -> np.ndarray:
    s = d.outline_size_m
    a, h, shift = PARALLELOGRAM_SIDE * s, PARALLELOGRAM_HEIGHT * s, PARALLELOGRAM_SHIFT * s
    x0 = -(a + shift) / 2
    return np.array([[x0, -h / 2], [x0 + a, -h / 2], [x0 + a + shift, h / 2], [x0 + shift, h / 2]])


def _centre_y(pts: np.ndarray, radius: float) -> np.ndarray:
    # Five-fold shapes pointing up span y in [-radius cos 36 deg, radius]: centre that box.
    return pts - [0.0, radius * (1 - math.cos(math.radians(36))) / 2]


def _pentagon(d: SpecimenDims) -> np.ndarray:
    return _centre_y(_regular(5, d.outline_size_m / 2, 90.0), d.outline_size_m / 2)


def _pentagram(d: SpecimenDims) -> np.ndarray:
    ro = PENTAGRAM_OUTER * d.outline_size_m
    radii = np.where(np.arange(10) % 2 == 0, ro, ro * PENTAGRAM_INNER_RATIO)
    ang = np.deg2rad(90.0 + 36.0 * np.arange(10))
    return _centre_y(np.column_stack([radii * np.cos(ang), radii * np.sin(ang)]), ro)


def _rhombus(d: SpecimenDims) -> np.ndarray:
    dx, dy = (k * d.outline_size_m / 2 for k in RHOMBUS_DIAGONALS)
    return np.array([[dx, 0.0], [0.0, dy], [-dx, 0.0], [0.0, -dy]])


def _square(d: SpecimenDims) -> np.ndarray:
    h = SQUARE_SIDE * d.outline_size_m / 2
    return np.array([[-h, -h], [h, -h], [h, h], [-h, h]])


def _trapezoid(d: SpecimenDims) -> np.ndarray:
    s = d.outline_size_m
    b1, b2 = (k * s / 2 for k in TRAPEZOID_BASES)
    h = TRAPEZOID_HEIGHT * s / 2
    return np.array([[-b1, -h], [b1, -h], [b2, h], [-b2, h]])


def _triangle(d: SpecimenDims) -> np.ndarray:
    a = TRIANGLE_SIDE * d.outline_size_m
    h = a * math.sqrt(3) / 2
    return np.array([[-a / 2, -h / 2], [a / 2, -h / 2], [0.0, h / 2]])


def _pentagram_area(d: SpecimenDims) -> float:
    ro = PENTAGRAM_OUTER * d.outline_size_m
    return 5 * ro * ro * PENTAGRAM_INNER_RATIO * math.sin(math.radians(36))


def _moon_area(d: SpecimenDims) -> float:
    r = d.outline_size_m / 2
    return math.pi * r * r - _lens_area(r, MOON_OFFSET * d.outline_size_m)


SHAPES: dict[str, ShapeDef] = {
    "circle": ShapeDef(_circle, lambda d: math.pi * (d.outline_size_m / 2) ** 2, True),
    "ellipse": ShapeDef(
        _ellipse,
        lambda d: math.pi * ELLIPSE_SEMI_AXES[0] * ELLIPSE_SEMI_AXES[1] * d.outline_size_m**2,
        True,
    ),
    "semicircle": ShapeDef(_semicircle, lambda d: math.pi * (d.outline_size_m / 2) ** 2 / 2, True),
    "hexagon": ShapeDef(
        lambda d: _regular(6, d.outline_size_m / 2, 0.0),
        lambda d: 1.5 * math.sqrt(3) * (d.outline_size_m / 2) ** 2,
        False,
    ),
    "moon": ShapeDef(_moon, _moon_area, True),
    "parallelogram": ShapeDef(
        _parallelogram,
        lambda d: PARALLELOGRAM_SIDE * PARALLELOGRAM_HEIGHT * d.outline_size_m**2,
        False,
    ),
    "pentagon": ShapeDef(
        _pentagon,
        lambda d: 2.5 * (d.outline_size_m / 2) ** 2 * math.sin(math.radians(72)),
        False,
    ),
    "pentagram": ShapeDef(_pentagram, _pentagram_area, False),
    "rhombus": ShapeDef(
        _rhombus,
        lambda d: RHOMBUS_DIAGONALS[0] * RHOMBUS_DIAGONALS[1] * d.outline_size_m**2 / 2,
        False,
    ),
    "square": ShapeDef(_square, lambda d: (SQUARE_SIDE * d.outline_size_m) ** 2, False),
    "trapezoid": ShapeDef(
        _trapezoid,
        lambda d: sum(TRAPEZOID_BASES) / 2 * TRAPEZOID_HEIGHT * d.outline_size_m**2,
        False,
    ),
    "triangle": ShapeDef(
        _triangle, lambda d: math.sqrt(3) / 4 * (TRIANGLE_SIDE * d.outline_size_m) ** 2, False
    ),
}
assert tuple(SHAPES) == SHAPE_NAMES


def check_specimen(shape: object) -> SpecimenLike:
    """Return ``shape`` if it is a ``Specimen`` or one of ``SHAPE_NAMES``; else raise
    ``ValueError`` listing the names."""
    return shape if isinstance(shape, Specimen) else check_shape(shape)


def outline_vertices(name: str, dims: SpecimenDims = SPECIMEN) -> np.ndarray:
    """Counter-clockwise outline vertices (k, 2) in metres, without repeating the first."""
    pts = SHAPES[check_shape(name)].vertices(check_dims(dims))
    ring = shapely.LinearRing(pts)
    return np.ascontiguousarray(pts if ring.is_ccw else pts[::-1], dtype=np.float64)


def outline(name: SpecimenLike, dims: SpecimenDims = SPECIMEN) -> Polygon:
    """The outline as a shapely Polygon in metres (x: sliding direction), centred as
    documented in this module; curved sides polygonised within ``dims.curve_tolerance_m``.

    ``name`` is a built-in shape name or a ``Specimen``, whose own outline is returned
    (checked to fit ``dims``' plate; its size does not follow ``dims.outline_size_m``)."""
    if isinstance(name, Specimen):
        return Polygon(name.check_on_plate(check_dims(dims)).vertices_m)
    poly = Polygon(outline_vertices(name, dims))
    if not poly.is_valid:  # only reachable through a broken definition above
        raise RuntimeError(f"outline of {name} is not a valid polygon")
    return poly


def analytic_area_m2(name: SpecimenLike, dims: SpecimenDims = SPECIMEN) -> float:
    """Exact area of the outline's definition (m^2), from closed-form formulas; for a
    ``Specimen``, the area of its polygon (its definition)."""
    if isinstance(name, Specimen):
        check_dims(dims)
        return name.area_m2
    return float(SHAPES[check_shape(name)].area_m2(check_dims(dims)))


def is_curved(name: SpecimenLike) -> bool:
    """True for outlines with curved sides (approximated by polygons in meshes); for a
    ``Specimen``, whether its source had curved sides."""
    if isinstance(name, Specimen):
        return name.curved
    return SHAPES[check_shape(name)].curved


def x_extent_m(name: SpecimenLike, dims: SpecimenDims = SPECIMEN) -> float:
    """Length of the outline along x, the sliding direction (m): what the simulator's
    path must cross."""
    x0, _, x1, _ = outline(name, dims).bounds
    return float(x1 - x0)
