"""Outlines, dimensions, convex partition and convex pieces (no build123d: fast)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from shapely.geometry import Point, Polygon

import shapes
from shapes import SHAPE_NAMES, SPECIMEN, SpecimenDims, analytic_area_m2, convex_pieces, outline
from shapes.outlines import is_curved, sample_curve
from shapes.partition import convex_partition, is_convex_ccw

PAPER_ORDER = (
    "circle ellipse semicircle hexagon moon parallelogram pentagon pentagram "
    "rhombus square trapezoid triangle"
).split()
CURVED = {"circle", "ellipse", "semicircle", "moon"}
TOL_M = 0.05e-3  # allowed distance of the convex pieces from a curved solid


def in_piece(piece, points: np.ndarray, eps: float = 1e-12) -> np.ndarray:
    """Which points (n, 3) lie in a convex mesh: behind every face plane."""
    normals = piece.face_normals
    offsets = np.einsum("ij,ij->i", normals, piece.triangles[:, 0])
    return np.all(points @ normals.T - offsets <= eps, axis=1)


def in_any_piece(name: str, points: np.ndarray) -> np.ndarray:
    return np.any([in_piece(p, points) for p in convex_pieces(name)], axis=0)


def at_mid_height(xy: np.ndarray) -> np.ndarray:
    xy = np.atleast_2d(xy)
    return np.column_stack([xy, np.full(len(xy), SPECIMEN.height_m / 2)])


def test_names_are_the_papers_order_and_curved_set():
    assert list(SHAPE_NAMES) == PAPER_ORDER
    assert {n for n in SHAPE_NAMES if is_curved(n)} == CURVED


@pytest.mark.parametrize(
    "func", [outline, analytic_area_m2, convex_pieces, shapes.mesh, shapes.solid, is_curved]
)
def test_unknown_name_lists_valid_names(func):
    with pytest.raises(ValueError, match="shape must be one of circle, ellipse") as err:
        func("pentagramm")
    assert "did you mean 'pentagram'" in str(err.value)
    assert "triangle" in str(err.value)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"height_m": 0.0},
        {"outline_size_m": -0.016},
        {"base_thickness_m": float("nan")},
        {"base_length_m": 0.017},  # narrower than the 18 mm ellipse
        {"base_width_m": 0.018},
        {"curve_tolerance_m": 0.001},
    ],
)
def test_dims_reject_bad_values(kwargs):
    with pytest.raises(ValueError, match=next(iter(kwargs))):
        SpecimenDims(**kwargs)


@pytest.mark.parametrize("func", [outline, analytic_area_m2, convex_pieces, shapes.mesh])
def test_dims_argument_is_checked(func):
    with pytest.raises(ValueError, match="dims must be a SpecimenDims"):
        func("circle", dims={"outline_size_m": 0.016})


@pytest.mark.parametrize("name", SHAPE_NAMES)
def test_outline_area_matches_definition(name):
    poly = outline(name)
    assert poly.is_valid and poly.exterior.is_ccw and not poly.interiors
    rel = abs(poly.area / analytic_area_m2(name) - 1)
    # Curved sides are chords inside the curve (0.02 mm): ~0.3% less area.
    assert rel < (0.01 if name in CURVED else 1e-9)


def test_analytic_areas_from_independent_formulas():
    s = SPECIMEN.outline_size_m
    r = s / 2
    lens = 2 * r * r * math.acos(5 / 16 * s / (2 * r)) - 5 / 32 * s * math.sqrt(
        4 * r * r - (5 / 16 * s) ** 2
    )
    expected_mm2 = {
        "circle": math.pi * 64,
        "ellipse": math.pi * 9 * 6,
        "semicircle": math.pi * 32,
        "hexagon": 6 * math.sqrt(3) / 4 * 64,
        "moon": (math.pi * r * r - lens) * 1e6,
        "parallelogram": 12 * 10,
        "pentagon": 5 / 2 * 64 * math.sin(math.radians(72)),
        # Ten triangles centre/outer point/inner point, radii 8.5 and 8.5*0.381966.
        "pentagram": 10 * 0.5 * 8.5 * 8.5 * 0.3819660112501051 * math.sin(math.radians(36)),
        "rhombus": 16 * 11 / 2,
        "square": 14 * 14,
        "trapezoid": (16 + 8) / 2 * 10,
        "triangle": math.sqrt(3) / 4 * 256,
    }
    for name in SHAPE_NAMES:
        assert analytic_area_m2(name) * 1e6 == pytest.approx(expected_mm2[name], rel=1e-12)


@pytest.mark.parametrize("name", SHAPE_NAMES)
def test_outline_size_centring_and_two_second_crossing(name):
    x0, y0, x1, y1 = outline(name).bounds
    width_mm = (x1 - x0) * 1e3
    # At 10 mm/s a 14-18 mm outline is crossed edge to edge in 1.4-1.8 s (< 2 s window).
    assert 13.9 <= width_mm <= 18.01
    assert width_mm / 10.0 < 2.0
    assert abs(x0 + x1) < 0.05e-3  # centred along the sliding axis
    if name != "moon":  # the moon is centred on its parent disc (see shapes.outlines)
        assert abs(y0 + y1) < 0.05e-3
    plate = Polygon.from_bounds(
        -SPECIMEN.base_length_m / 2,
        -SPECIMEN.base_width_m / 2,
        SPECIMEN.base_length_m / 2,
        SPECIMEN.base_width_m / 2,
    )
    assert plate.contains(outline(name))


def test_sizes_scale_with_outline_size():
    big = SpecimenDims(outline_size_m=0.020)
    for name in SHAPE_NAMES:
        ratio = analytic_area_m2(name, big) / analytic_area_m2(name)
        assert ratio == pytest.approx((20 / 16) ** 2, rel=1e-12)
        assert outline(name, big).area / outline(name).area == pytest.approx(1.5625, rel=2e-3)


@pytest.mark.parametrize("name", sorted(CURVED))
def test_curved_outlines_within_tolerance_of_exact_curve(name):
    coarse = outline(name)
    fine = outline(name, SpecimenDims(curve_tolerance_m=1e-8))
    # Vertices lie on the curve and chords stray at most curve_tolerance_m from it.
    assert coarse.hausdorff_distance(fine) <= SPECIMEN.curve_tolerance_m * 1.01
    # Chords cut inside a convex curve (the moon's bite bulges out instead).
    assert fine.buffer(2e-8).contains(coarse.exterior) or name == "moon"


def test_sample_curve_meets_tolerance_on_a_circle():
    r, tol = 0.008, 0.02e-3
    pts = sample_curve(lambda t: np.column_stack([r * np.cos(t), r * np.sin(t)]), 0, 2 * np.pi, tol)
    seg = len(pts) - 1
    sagitta = r * (1 - math.cos(math.pi / seg))
    assert sagitta <= tol
    # Not wastefully fine either: fewer than twice the minimal segment count.
    assert seg < 2 * math.pi / (2 * math.acos(1 - tol / r)) * 2


def _footprints(name: str) -> list[Polygon]:
    return [
        Polygon(p.vertices[p.vertices[:, 2] == 0][:, :2]).convex_hull for p in convex_pieces(name)
    ]


@pytest.mark.parametrize("name", SHAPE_NAMES)
def test_convex_pieces_are_watertight_convex_and_tile_the_outline(name):
    pieces = convex_pieces(name)
    if name in {"moon", "pentagram"}:  # the only concave outlines
        assert len(pieces) > 1
    else:
        assert len(pieces) == 1
    height = SPECIMEN.height_m
    for p in pieces:
        assert p.is_watertight and p.is_winding_consistent
        assert p.volume > 0
        assert p.volume == pytest.approx(p.convex_hull.volume, rel=1e-9)
        assert p.bounds[0, 2] == 0.0 and p.bounds[1, 2] == pytest.approx(height)
    total = sum(p.volume for p in pieces)
    poly = outline(name)
    # No overlap: the volumes add up to the union's (= outline area x height).
    assert total == pytest.approx(poly.area * height, rel=1e-9)
    feet = _footprints(name)
    union = shapely.union_all(feet)
    assert union.symmetric_difference(poly).area < 1e-9 * poly.area
    assert sum(f.area for f in feet) == pytest.approx(union.area, rel=1e-9)
    expected = analytic_area_m2(name) * height
    assert total == pytest.approx(expected, rel=0.01 if name in CURVED else 1e-9)


def test_moon_notch_points_lie_in_no_piece():
    # Notch: inside the parent disc, inside the bite (centre (0, 5 mm)), clear of edges.
    notch_mm = np.array([[0, 0], [0, -2.5], [4, 0], [-5.5, 0.5], [3, 2], [-6, 2]])
    xy = notch_mm * 1e-3
    poly = outline("moon")
    hull = poly.convex_hull
    for p in xy:
        assert hull.contains(Point(p)) and not poly.buffer(TOL_M).contains(Point(p))
    assert not in_any_piece("moon", at_mid_height(xy)).any()
    # A single mesh would be collided as its hull: these points would then be solid.
    whole = shapely.union_all(_footprints("moon")).convex_hull
    assert all(whole.contains(Point(p)) for p in xy)


def test_pentagram_between_points_lie_in_no_piece():
    # Halfway between the inner vertex and the hull edge, at each inner vertex's angle.
    ro = 8.5e-3
    ri = ro * 0.3819660112501051
    shift = ro * (1 - math.cos(math.radians(36))) / 2
    ang = np.deg2rad(90 + 36 + 72 * np.arange(5))
    rad = (ri + ro * math.cos(math.radians(36))) / 2
    xy = np.column_stack([rad * np.cos(ang), rad * np.sin(ang) - shift])
    poly = outline("pentagram")
    for p in xy:
        assert poly.convex_hull.contains(Point(p)) and not poly.buffer(TOL_M).contains(Point(p))
    assert not in_any_piece("pentagram", at_mid_height(xy)).any()


@pytest.mark.parametrize("name", SHAPE_NAMES)
def test_point_queries_inside_and_outside(name):
    rng = np.random.default_rng(np.random.SeedSequence(2026))
    poly = outline(name)
    x0, y0, x1, y1 = poly.bounds
    xy = rng.uniform([x0, y0], [x1, y1], size=(4000, 2))
    pts = shapely.points(xy)
    inside = shapely.contains(poly.buffer(-TOL_M), pts)
    outside = ~shapely.contains(poly.buffer(TOL_M), pts)
    hit = in_any_piece(name, at_mid_height(xy))
    assert inside.sum() > 500
    assert hit[inside].all()
    assert not hit[outside].any()
    # Above the raised height or below the plate top: nothing.
    above = np.column_stack([xy[inside], np.full(inside.sum(), SPECIMEN.height_m * 1.01)])
    assert not in_any_piece(name, above).any()
    if name in {"moon", "pentagram"}:
        assert (outside & shapely.contains(poly.convex_hull, pts)).sum() > 100


def _check_partition(poly: Polygon) -> list[np.ndarray]:
    pieces = convex_partition(poly)
    polys = [Polygon(p) for p in pieces]
    for p in pieces:
        assert is_convex_ccw(p) and Polygon(p).is_valid
    union = shapely.union_all(polys)
    assert union.symmetric_difference(poly).area < 1e-12 * poly.area
    assert sum(p.area for p in polys) == pytest.approx(poly.area, rel=1e-12)
    return pieces


def test_partition_of_an_l_shape_and_a_comb():
    ell = Polygon([(0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2)])
    # Optimum 2; Hertel-Mehlhorn on the Delaunay triangles may keep one more diagonal.
    assert 2 <= len(_check_partition(ell)) <= 3
    comb = Polygon([(0, 0), (5, 0), (5, 3), (4, 3), (4, 1), (3, 1), (3, 3), (2, 3), (2, 1),
                    (1, 1), (1, 3), (0, 3)])  # fmt: skip
    assert 4 <= len(_check_partition(comb)) <= 8  # Hertel-Mehlhorn: <= 4x optimum (4)


def test_partition_of_random_star_polygons():
    rng = np.random.default_rng(np.random.SeedSequence(7))
    for _ in range(20):
        k = int(rng.integers(5, 30))
        ang = np.sort(rng.uniform(0, 2 * np.pi, k))
        rad = rng.uniform(0.3, 1.0, k)
        poly = Polygon(np.column_stack([rad * np.cos(ang), rad * np.sin(ang)]))
        if poly.is_valid:
            _check_partition(poly)
    convex = Polygon([(0, 0), (1, 0), (2, 0), (2, 1), (0, 1)])  # collinear vertex dropped
    (piece,) = _check_partition(convex)
    assert len(piece) == 4


def test_partition_rejects_bad_input():
    with pytest.raises(ValueError, match="polygon"):
        convex_partition(Point(0, 0))
    with pytest.raises(ValueError, match="holes"):
        convex_partition(Polygon([(0, 0), (4, 0), (4, 4), (0, 4)], [[(1, 1), (2, 1), (2, 2)]]))
