"""User specimens: the Specimen dataclass, its checks and bounds, and the experiment
file's [[specimen]] tables from polygons and DXF files (no build123d: fast)."""

from __future__ import annotations

import dataclasses
import json
import math
import re
import textwrap
from pathlib import Path

import ezdxf
import numpy as np
import pytest
import shapely

import shapes
from shapes import (
    SHAPE_NAMES,
    SPECIMEN,
    Specimen,
    SpecimenDims,
    SpecimenError,
    convex_pieces,
    limits,
    load_specimens,
    outline,
)

MM = 1e-3
L_MM = [(-8, -6), (8, -6), (8, -2), (-4, -2), (-4, 6), (-8, 6)]  # an L, 16 x 12 mm


def ell(name: str = "l_bracket", **kwargs) -> Specimen:
    return Specimen.from_outline(name, np.array(L_MM) * MM, **kwargs)


# --- the bounds -------------------------------------------------------------------------


def test_bounds_follow_from_the_simulators_finger_and_timing():
    """Every bound in shapes.limits, recomputed from the simulator's own values."""
    from synth import contact
    from synth.config import SynthConfig
    from synth.presets import FORCE_RANGE_N, NOMINAL_SPEED_MM_S
    from synth.trial import WINDOW_S

    config = SynthConfig()
    f, var = config.finger, config.variability
    assert limits.PAD_RADIUS_M == f.pad_radius_m
    assert limits.WINDOW_S == WINDOW_S
    assert limits.NOMINAL_SPEED_M_S == NOMINAL_SPEED_MM_S * 1e-3
    assert limits.SPEED_SCATTER_REL == pytest.approx(3 * var.speed_rel)
    assert limits.WINDOW_JITTER_S == var.window_jitter_s

    def sink(force_n: float) -> float:
        return float(
            contact.hertz_indentation_m(force_n, f.pad_radius_m, f.skin_modulus_pa, f.skin_poisson)
        )

    lo, hi = FORCE_RANGE_N
    patch = 2 * math.sqrt(f.pad_radius_m * sink(hi))
    assert limits.CONTACT_DIAMETER_AT_MAX_FORCE_M == pytest.approx(patch, abs=0.005 * MM)
    assert limits.INDENTATION_AT_MIN_FORCE_M == pytest.approx(sink(lo), abs=0.001 * MM)
    assert limits.INDENTATION_AT_MAX_FORCE_M == pytest.approx(sink(hi), abs=0.005 * MM)
    # Each bound is its quantity rounded outwards (never tighter than derived).
    assert patch <= limits.MIN_EXTENT_M < patch + 0.1 * MM
    assert sink(lo) <= limits.MIN_HEIGHT_M < sink(lo) + 0.1 * MM
    assert limits.MAX_X_EXTENT_M == pytest.approx(19.206 * MM, abs=1e-9)
    # The tallest step meets the skin below the pad's equator at the largest force.
    assert limits.MAX_HEIGHT_M + sink(hi) < f.pad_radius_m
    # The skin's first touch of an edge (the simulator's touch distance) lies within a
    # pad radius of it, which the x margin assumes.
    r = f.pad_radius_m
    touch = math.sqrt(r * r - (r - SPECIMEN.height_m - sink(hi)) ** 2)
    assert touch < r and limits.PLATE_MARGIN_X_M == pytest.approx(1.5 * r)


def test_window_at_nominal_speed_holds_the_largest_crossing():
    slowest = limits.NOMINAL_SPEED_M_S * (1 - limits.SPEED_SCATTER_REL)
    crossing_s = limits.MAX_X_EXTENT_M / slowest
    assert crossing_s + limits.WINDOW_JITTER_S == pytest.approx(limits.WINDOW_S)


@pytest.mark.parametrize("name", SHAPE_NAMES)
def test_the_papers_outlines_meet_every_bound(name):
    x0, y0, x1, y1 = outline(name).bounds
    assert limits.MIN_EXTENT_M <= min(x1 - x0, y1 - y0)
    assert x1 - x0 <= limits.MAX_X_EXTENT_M
    assert limits.MIN_HEIGHT_M <= SPECIMEN.height_m <= limits.MAX_HEIGHT_M
    assert max(-x0, x1) <= SPECIMEN.base_length_m / 2 - limits.PLATE_MARGIN_X_M
    assert max(-y0, y1) <= SPECIMEN.base_width_m / 2 - limits.PLATE_MARGIN_Y_M
    # And as a Specimen of the same polygon, they pass the same checks.
    ring = np.asarray(outline(name).exterior.coords)[:-1]
    spec = Specimen.from_outline(f"copy-{name}", ring)
    assert spec.area_m2 == pytest.approx(outline(name).area, rel=1e-12)


# --- Specimen -------------------------------------------------------------------------


def test_from_outline_orients_centres_and_keeps_the_outline():
    clockwise = (np.array(L_MM[::-1]) + np.array([30.0, -5.0])) * MM  # moved, reversed
    spec = Specimen.from_outline("l_bracket", np.vstack([clockwise, clockwise[:1]]))  # closed
    assert np.allclose(spec.vertices_m, ell().vertices_m, rtol=0, atol=1e-15)
    poly = spec.polygon
    assert poly.exterior.is_ccw and len(spec.vertices_m) == 6
    x0, y0, x1, y1 = poly.bounds
    assert (x0, y0, x1, y1) == pytest.approx((-8 * MM, -6 * MM, 8 * MM, 6 * MM), abs=1e-15)
    assert spec.x_extent_m == pytest.approx(16 * MM) and spec.y_extent_m == pytest.approx(12 * MM)
    assert spec.area_m2 == pytest.approx(96 * MM * MM, rel=1e-12)
    assert spec.height_m == SPECIMEN.height_m and not spec.curved
    moved = ell(offset_y_m=1.5 * MM)
    assert moved.bounds_m[1] == pytest.approx(-4.5 * MM) and moved.bounds_m[3] == pytest.approx(
        7.5 * MM
    )


def test_to_dict_round_trips_through_json_bit_for_bit():
    spec = Specimen.from_outline(
        "blob",
        [(math.cos(t) * 7.3 * MM, math.sin(t) * 5.1 * MM) for t in np.linspace(0, 6.2, 57)],
        height_m=2.5 * MM,
        source="function blob.py:blob",
        curved=True,
    )
    text = json.dumps(spec.to_dict())
    back = Specimen.from_dict(json.loads(text))
    assert back == spec and back.geometry_hash == spec.geometry_hash
    assert np.array_equal(np.array(back.vertices_m), np.array(spec.vertices_m))
    assert back.to_dict() == spec.to_dict()
    assert hash(back) == hash(spec)
    # Built-ins travel as their names, beside specimens.
    listed = shapes.specimens_from_json(shapes.specimens_to_json(["moon", spec]))
    assert listed == ("moon", spec)
    assert shapes.specimen_to_dict("moon") == {"name": "moon"}


def test_geometry_hash_is_the_geometry_only():
    a = ell()
    assert a.geometry_hash == ell("other", source="elsewhere").geometry_hash
    assert a.geometry_hash != ell(height_m=3 * MM).geometry_hash
    assert a.geometry_hash != ell(offset_y_m=0.1 * MM).geometry_hash
    assert len(a.geometry_hash) == 64


def test_negative_zero_is_zero():
    def rectangle(zero: float) -> Specimen:
        corners = [(-8, -6), (8, -6), (8, zero), (8, 6), (-8, 6), (-8, zero)]
        return Specimen("z", tuple((x * MM, y * MM) for x, y in corners))

    a, b = rectangle(-0.0), rectangle(0.0)
    assert math.copysign(1, a.vertices_m[2][1]) == 1.0
    assert a == b and a.geometry_hash == b.geometry_hash


def test_from_dict_refuses_damaged_records():
    good = ell().to_dict()
    with pytest.raises(ValueError, match="unknown keys: colour"):
        Specimen.from_dict({**good, "colour": "red"})
    with pytest.raises(ValueError, match="lacks vertices_m"):
        Specimen.from_dict({"name": "x"})
    with pytest.raises(ValueError, match="record format 99"):
        Specimen.from_dict({**good, "format": 99})
    tampered = {**good, "vertices_m": [[x, y * 1.01] for x, y in good["vertices_m"]]}
    with pytest.raises(ValueError, match="geometry_sha256 does not match"):
        Specimen.from_dict(tampered)
    with pytest.raises(ValueError, match="must be a mapping"):
        Specimen.from_dict([1, 2])


@pytest.mark.parametrize(
    ("vertices_mm", "kwargs", "rule"),
    [
        (
            [(0, 0), (10, 10), (10, 0), (0, 10)],
            {},
            r"crosses or touches itself near \(5.0, 5.0\) mm",
        ),
        ([(0, 0), (10, 0), (5, 5), (10, 10), (0, 10), (5, 5)], {}, "touches itself near"),
        ([(0, 0), (10, 0), (20, 0)], {}, "encloses no area"),
        ([(0, 0), (10, 0)], {}, "at least 3 distinct vertices"),
        ([(0, 0), (10, 0), (float("nan"), 3)], {}, "finite"),
        ([(0, 0), (5, 0), (5, 5), (0, 5)], {}, "5 mm across along x; at least 7 mm"),
        ([(0, 0), (16, 0), (16, 5), (0, 5)], {}, "5 mm across along y; at least 7 mm"),
        ([(0, 0), (20, 0), (20, 10), (0, 10)], {}, "20 mm long along x; at most 19.21 mm"),
        ([(0, 0), (15, 0), (15, 24), (0, 24)], {}, r"does not fit the 60 x 30 mm plate"),
        (L_MM, {"height_m": 0.2 * MM}, "height must lie within 0.5-3.5 mm"),
        (L_MM, {"height_m": 5 * MM}, "height must lie within 0.5-3.5 mm"),
        (L_MM, {"offset_y_m": 6 * MM}, r"\|y\| <= 11.5 mm"),
        (L_MM, {"offset_y_m": "up"}, "offset_y_m must be a number"),
    ],
)
def test_bad_outlines_are_refused_naming_the_rule(vertices_mm, kwargs, rule):
    with pytest.raises(SpecimenError, match=rf"^specimen 'bad': .*{rule}") as err:
        Specimen.from_outline("bad", np.array(vertices_mm, dtype=float) * MM, **kwargs)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(
    ("name", "rule"),
    [
        ("circle", "'circle' is a built-in shape"),
        ("L-bracket", "lower-case letters"),
        ("a/b", "lower-case letters"),
        ("", "lower-case letters"),
        ("x" * 65, "at most 64"),
        (3, "lower-case letters"),
    ],
)
def test_names_are_class_name_parts_and_not_built_ins(name, rule):
    with pytest.raises(SpecimenError, match=rule):
        ell(name)


def test_the_constructor_checks_but_changes_nothing():
    v = ell().vertices_m
    with pytest.raises(SpecimenError, match="counter-clockwise"):
        Specimen("x", v[::-1])
    with pytest.raises(SpecimenError, match="centred on x = 0"):
        Specimen("x", tuple((x + 1 * MM, y) for x, y in v))
    with pytest.raises(SpecimenError, match="repeats a vertex"):
        Specimen("x", (*v, v[0]))
    with pytest.raises(SpecimenError, match="source must be a string"):
        Specimen("x", v, source=None)
    with pytest.raises(SpecimenError, match="height_m must be a number"):
        Specimen("x", v, height_m="2")
    spec = Specimen("x", [list(p) for p in v])  # lists become tuples, values unchanged
    assert spec.vertices_m == v
    with pytest.raises(dataclasses.FrozenInstanceError):
        spec.height_m = 1.0


# --- the shapes API takes a Specimen ----------------------------------------------------


def test_shapes_functions_take_a_specimen():
    spec = ell(height_m=2.5 * MM)
    assert outline(spec).equals(spec.polygon)
    assert shapes.analytic_area_m2(spec) == pytest.approx(96e-6, rel=1e-12)
    assert not shapes.is_curved(spec)
    assert shapes.x_extent_m(spec) == pytest.approx(16 * MM)
    assert shapes.x_extent_m("ellipse") == pytest.approx(18 * MM, abs=SPECIMEN.curve_tolerance_m)
    assert shapes.specimen_name(spec) == "l_bracket" and shapes.specimen_name("moon") == "moon"
    pieces = convex_pieces(spec)
    assert len(pieces) == 2
    for p in pieces:
        assert p.is_watertight and p.volume == pytest.approx(p.convex_hull.volume, rel=1e-9)
        assert p.bounds[0, 2] == 0.0 and p.bounds[1, 2] == pytest.approx(2.5 * MM)
    assert sum(p.volume for p in pieces) == pytest.approx(96e-6 * 2.5 * MM, rel=1e-9)
    feet = shapely.union_all(
        [shapely.Polygon(p.vertices[p.vertices[:, 2] == 0][:, :2]).convex_hull for p in pieces]
    )
    assert feet.symmetric_difference(spec.polygon).area < 1e-12 * spec.area_m2


def test_a_smaller_plate_is_checked_where_it_is_given():
    small = SpecimenDims(base_width_m=0.020)  # |y| <= 10 - 3.5 = 6.5 mm: the L (6 mm) fits
    assert outline(ell(), small).area > 0
    with pytest.raises(SpecimenError, match=r"20 mm plate.*\|y\| <= 6.5 mm"):
        convex_pieces(ell(offset_y_m=1 * MM), small)
    with pytest.raises(ValueError, match="dims must be a SpecimenDims"):
        outline(ell(), dims={})


def test_wrong_types_still_list_the_built_in_names():
    with pytest.raises(ValueError, match="shape must be one of circle, ellipse"):
        convex_pieces(3)


# --- the experiment file -----------------------------------------------------------------


def write(tmp_path: Path, text: str, name: str = "experiment.toml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def test_load_polygons_and_built_ins_in_the_files_order(tmp_path):
    path = write(
        tmp_path,
        """
        title = "other sections are not read here"
        [materials.glass]
        mu = 0.3

        [[specimen]]
        name = "moon"

        [[specimen]]
        name = "l_bracket"
        polygon_mm = [[-8, -6], [8, -6], [8, -2], [-4, -2], [-4, 6], [-8, 6]]
        height_mm = 2.5

        [[specimen]]
        name = "wedge-2"
        polygon_mm = [[0, 0], [0, 10], [15, 0]]   # clockwise, off centre
        offset_y_mm = -1
        """,
    )
    moon, bracket, wedge = load_specimens(path)
    assert moon == "moon"
    assert bracket == ell(height_m=2.5 * MM, source="polygon_mm in experiment.toml")
    assert wedge.bounds_m == pytest.approx((-7.5 * MM, -6 * MM, 7.5 * MM, 4 * MM))
    assert shapes.parse_specimens([{"name": "square"}], base_dir=tmp_path, file="inline") == (
        "square",
    )


def _bad(tmp_path: Path, body: str) -> str:
    path = write(tmp_path, body)
    with pytest.raises(ValueError) as err:
        load_specimens(path)
    message = str(err.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: ")
    return message[len(f"{path}: ") :]


POLY = "polygon_mm = [[-8, -6], [8, -6], [8, 6], [-8, 6]]"


@pytest.mark.parametrize(
    ("body", "expected"),
    [
        (  # self-intersecting, located in the file's own coordinates
            'name = "bow"\npolygon_mm = [[0, 0], [16, 10], [16, 0], [0, 10]]',
            r"^specimen 'bow': the outline crosses or touches itself near \(8.0, 5.0\) mm$",
        ),
        (
            'name = "huge"\npolygon_mm = [[0, 0], [19, 0], [19, 25], [0, 25]]',
            "^specimen 'huge': the outline .* does not fit the 60 x 30 mm plate",
        ),
        (
            'name = "tiny"\npolygon_mm = [[0, 0], [4, 0], [4, 4], [0, 4]]',
            "^specimen 'tiny': the outline is 4 mm across along x; at least 7 mm",
        ),
        (
            f'name = "typo"\n{POLY}\nheigth_mm = 3',
            "^specimen 'typo': unknown key 'heigth_mm' \\(did you mean 'height_mm'\\?\\)",
        ),
        (
            f'name = "two"\n{POLY}\nsvg = "a.svg"',
            r"^specimen 'two': the table gives 2 sources \(polygon_mm and svg\); give exactly one",
        ),
        (
            f'name = "circle"\n{POLY}',
            "^specimen 'circle': 'circle' is a built-in shape; a specimen with its own outline "
            r"\(polygon_mm\) needs another name",
        ),
        (
            'name = "circle"\nheight_mm = 3',
            "^specimen 'circle': 'circle' is a built-in shape, which takes no other key",
        ),
        (
            'name = "circel"',
            "^specimen 'circel': the table gives no source .* and 'circel' is not a built-in "
            r"shape \(did you mean 'circle'\?\)",
        ),
        (f"{POLY}", "^specimen #1: the table has no name$"),
        (f'name = "Big L"\n{POLY}', "^specimen #1: name must hold only lower-case letters"),
        (
            'name = "sq"\nsvg = "missing.svg"',
            "^specimen 'sq': the SVG file .*missing.svg does not exist$",
        ),
        (
            'name = "sq"\ndxf = "missing.dxf"',
            "^specimen 'sq': the DXF file .*missing.dxf does not exist$",
        ),
        (
            'name = "sq"\nfunction = "missing.py:f"',
            "^specimen 'sq': function 'missing.py:f': file .*missing.py does not exist$",
        ),
        (
            'name = "sq"\nfunction = "no_such_module_xyz:f"',
            "^specimen 'sq': function 'no_such_module_xyz:f': no module named",
        ),
        ('name = "sq"\nfunction = "f"', "^specimen 'sq': function must be 'file.py:function'"),
        (f'name = "sq"\n{POLY}\nkwargs = {{ r = 1 }}', "^specimen 'sq': kwargs applies only with"),
        (
            'name = "sq"\npolygon_mm = [[0, 0], [10, 0], [10, "a"]]',
            r"^specimen 'sq': polygon_mm vertex 3 must be a pair \[x, y\] of numbers",
        ),
        ('name = "sq"\npolygon_mm = [[0, 0], [10, 0]]', "^specimen 'sq': polygon_mm must be"),
        (f'name = "sq"\n{POLY}\nheight_mm = "2"', r"^specimen 'sq': height_mm must be a number"),
        (f'name = "sq"\n{POLY}\nheight_mm = 9', r"^specimen 'sq': the height must lie within"),
    ],
)
def test_bad_tables_name_the_file_the_entry_and_the_rule(tmp_path, body, expected):
    message = _bad(tmp_path, "[[specimen]]\n" + body + "\n")
    assert re.search(expected, message), message


def test_duplicates_and_file_level_errors(tmp_path):
    twice = f'[[specimen]]\nname = "a"\n{POLY}\n[[specimen]]\nname = "moon"\n'
    twice += f'[[specimen]]\nname = "a"\n{POLY}\n'
    assert _bad(tmp_path, twice) == (
        "specimen 'a': the name appears twice (specimen tables 1 and 3); every specimen needs "
        "its own name"
    )
    built_in_twice = '[[specimen]]\nname = "moon"\n[[specimen]]\nname = "moon"\n'
    assert "appears twice" in _bad(tmp_path, built_in_twice)
    assert _bad(tmp_path, 'title = "x"\n').startswith("no [[specimen]] tables")
    assert _bad(tmp_path, '[specimen]\nname = "moon"\n').startswith("write [[specimen]]")
    assert _bad(tmp_path, "specimen = 3\n").startswith("'specimen' must be an array of tables")
    assert _bad(tmp_path, "[[specimen]\n").startswith("not valid TOML: ")
    missing = tmp_path / "nowhere.toml"
    with pytest.raises(ValueError, match=rf"^{missing}: no such file$"):
        load_specimens(missing)
    with pytest.raises(ValueError, match="is a directory"):
        load_specimens(tmp_path)


def test_cheap_checks_run_on_every_table_before_any_outline_is_built(tmp_path, monkeypatch):
    """A typo in the last table fails before the first table's source is read."""
    from shapes import sources

    def never(*args, **kwargs):
        raise AssertionError("an outline was built before all tables were checked")

    monkeypatch.setattr(sources, "dxf_outline", never)
    body = '[[specimen]]\nname = "clip"\ndxf = "clip.dxf"\n'
    body += f'[[specimen]]\nname = "sq"\n{POLY}\nsvg_path_id = "x"\n'
    assert "svg_path_id applies only with svg" in _bad(tmp_path, body)


# --- DXF ---------------------------------------------------------------------------------


def _dxf(path: Path, draw, units: int = 4) -> Path:
    doc = ezdxf.new("R2000", units=units)
    draw(doc.modelspace())
    doc.saveas(path)
    return path


def _clip(msp, layer: str = "0", r_out: float = 8.0, r_in: float = 5.0) -> None:
    bulge = math.tan(math.radians(300) / 4)
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    msp.add_lwpolyline(
        [
            (r_out * c, r_out * s, 0, 0, bulge),
            (r_out * c, -r_out * s, 0, 0, 0),
            (r_in * c, -r_in * s, 0, 0, -bulge),
            (r_in * c, r_in * s, 0, 0, 0),
        ],
        format="xyseb",
        close=True,
        dxfattribs={"layer": layer},
    )


def chord_loss_m2(arc_length_m: float) -> float:
    """Most area chords within the tolerance cut off a convex arc: 2/3 x sagitta x chord
    summed over the arc."""
    return 2 / 3 * SPECIMEN.curve_tolerance_m * arc_length_m


def _table(tmp_path: Path, source: str) -> Specimen:
    path = write(tmp_path, f'[[specimen]]\nname = "part"\n{source}\n')
    (spec,) = load_specimens(path)
    return spec


def test_dxf_polyline_with_arcs_within_the_chord_tolerance(tmp_path):
    _dxf(tmp_path / "clip.dxf", _clip)
    spec = _table(tmp_path, 'dxf = "clip.dxf"')
    assert spec.curved and spec.source == "dxf clip.dxf"
    # The exact C: a 300-degree sector ring of radii 5 and 8 mm plus nothing else.
    exact = math.radians(300) / 2 * (64 - 25) * MM * MM
    # Chords cut inside the outer arc and outside the inner one: at most 2/3 x tolerance
    # x arc length each way (a segment's area is 2/3 of its chord x sagitta).
    arcs_m = math.radians(300) * (8 + 5) * MM
    assert abs(spec.area_m2 - exact) <= 2 / 3 * SPECIMEN.curve_tolerance_m * arcs_m
    ring = np.array(spec.vertices_m)
    centre = np.array([ring[:, 0].min() + 8 * MM, 0.0])  # the arcs' centre, leftmost at -8
    radii = np.hypot(*(ring - centre).T)
    on_arc = (np.abs(radii - 8 * MM) < 1e-6) | (np.abs(radii - 5 * MM) < 1e-6)
    assert on_arc.all()  # every vertex on one of the two arcs
    dense = np.array([[math.cos(t), math.sin(t)] for t in np.linspace(0.6, 5.6, 4000)])
    outer = shapely.LineString(centre + 8 * MM * dense)
    assert spec.polygon.exterior.hausdorff_distance(outer) < 3.5 * MM  # sanity: same place
    # Chord error: the exact outer arc is within the tolerance of the polygon's boundary.
    assert shapely.distance(
        spec.polygon.exterior, shapely.points(centre + 8 * MM * dense)
    ).max() <= (SPECIMEN.curve_tolerance_m * 1.01)
    assert len(convex_pieces(spec)) > 2


def test_dxf_loop_of_lines_and_arcs_in_any_order_and_units(tmp_path):
    def parts(msp):  # an 18 x 8 mm slot with round ends, drawn as 4 separate entities
        msp.add_arc((0, 0), 4, 90, 270)  # left end (counter-clockwise)
        msp.add_line((10, -4), (0, -4))  # bottom, drawn backwards
        msp.add_arc((10, 0), 4, 270, 90)  # right end
        msp.add_line((0, 4), (10, 4))

    _dxf(tmp_path / "slot.dxf", parts)
    spec = _table(tmp_path, 'dxf = "slot.dxf"')
    assert spec.curved
    assert spec.x_extent_m == pytest.approx(18 * MM, abs=1e-6)
    exact = (10 * 8 + math.pi * 16) * MM * MM
    assert 0 < exact - spec.area_m2 <= chord_loss_m2(2 * math.pi * 4 * MM)
    # Inches: the same numbers are 25.4 times larger.
    square = [(0, 0), (0.5, 0), (0.5, 0.4), (0, 0.4)]
    _dxf(tmp_path / "inch.dxf", lambda m: m.add_lwpolyline(square, close=True), units=1)
    inch = _table(tmp_path, 'dxf = "inch.dxf"')
    assert inch.x_extent_m == pytest.approx(12.7 * MM)
    assert inch.y_extent_m == pytest.approx(10.16 * MM)
    assert not inch.curved
    # Unitless: millimetres.
    big = [(0, 0), (10, 0), (10, 8), (0, 8)]
    _dxf(tmp_path / "plain.dxf", lambda m: m.add_lwpolyline(big, close=True), units=0)
    assert _table(tmp_path, 'dxf = "plain.dxf"').x_extent_m == pytest.approx(10 * MM)


def _open(msp):
    msp.add_lwpolyline([(0, 0), (16, 0), (16, 10), (0, 9)])  # not closed, ends 9 mm apart


def _two(msp):
    _clip(msp, layer="outline")
    msp.add_circle((30, 0), 5, dxfattribs={"layer": "fixture"})


def _stray(msp):
    _clip(msp)
    msp.add_line((20, 0), (25, 0))


@pytest.mark.parametrize(
    ("draw", "table", "expected"),
    [
        (_open, "", r"the outline in the DXF file .* is open: its ends are 9 mm apart$"),
        (_two, "", r"holds 2 closed outlines; a specimen is one \(choose a layer with dxf_layer\)"),
        (
            _two,
            'dxf_layer = "nothing"',
            r"no lines or curves on layer 'nothing' \(layers: fixture, outline\)",
        ),
        (_stray, "", "lines or curves that close no outline besides its outline"),
    ],
)
def test_bad_dxf_drawings(tmp_path, draw, table, expected):
    _dxf(tmp_path / "part.dxf", draw)
    message = _bad(tmp_path, f'[[specimen]]\nname = "part"\ndxf = "part.dxf"\n{table}\n')
    assert message.startswith("specimen 'part': ")
    assert re.search(expected, message), message


def test_dxf_layer_picks_one_outline(tmp_path):
    _dxf(tmp_path / "part.dxf", _two)
    clip = _table(tmp_path, 'dxf = "part.dxf"\ndxf_layer = "OUTLINE"')  # case-insensitive
    assert clip.source == "dxf part.dxf layer OUTLINE"
    assert clip.x_extent_m == pytest.approx((8 + 8 * math.cos(math.radians(30))) * MM, abs=2e-5)
    circle = _table(tmp_path, 'dxf = "part.dxf"\ndxf_layer = "fixture"')
    exact = math.pi * 25 * MM * MM
    assert 0 < exact - circle.area_m2 <= chord_loss_m2(2 * math.pi * 5 * MM)


def test_a_gentle_dxf_arc_keeps_its_vertices_on_the_arc(tmp_path):
    """A 100 mm radius side: every vertex on the arc, every chord within the tolerance
    (a Bezier form of the arc would stray 27 um at this radius)."""
    half = math.degrees(math.asin(8 / 100))

    def part(msp):
        msp.add_arc((0, -100 + 5), 100, 90 - half, 90 + half)  # the top, bulging up
        msp.add_line((-8, -5), (8, -5))
        msp.add_line((-8, -5), (-8, 100 * math.cos(math.radians(half)) - 95))
        msp.add_line((8, -5), (8, 100 * math.cos(math.radians(half)) - 95))

    _dxf(tmp_path / "d.dxf", part)
    spec = _table(tmp_path, 'dxf = "d.dxf"')
    ring = np.array(spec.vertices_m)
    y0 = spec.bounds_m[1]
    centre = np.array([0.0, y0 - 90 * MM])  # as drawn: the bottom side at y = -5 mm
    top = ring[ring[:, 1] > y0 + 1 * MM]
    assert len(top) >= 6  # 5 chords of 3.2 mm: sagitta 3.2^2 / (8 x 100) = 0.013 mm
    assert np.abs(np.hypot(*(top - centre).T) - 100 * MM).max() < 1e-12
    t = np.linspace(90 - half, 90 + half, 5000)
    arc = centre + 100 * MM * np.column_stack([np.cos(np.radians(t)), np.sin(np.radians(t))])
    gap = shapely.distance(spec.polygon.exterior, shapely.points(arc))
    assert gap.max() <= SPECIMEN.curve_tolerance_m * 1.001


def test_errors_survive_a_trip_to_another_process():
    import pickle

    err = pickle.loads(pickle.dumps(SpecimenError("gear", "the outline is open")))
    assert (str(err), err.name, err.rule) == (
        "specimen 'gear': the outline is open",
        "gear",
        "the outline is open",
    )


def test_polygons_and_dxf_load_without_build123d(tmp_path):
    """Reading polygon and DXF specimens (and their pieces) stays light: no build123d."""
    from fresh_interpreter import run_json

    _dxf(tmp_path / "clip.dxf", _clip)
    path = write(
        tmp_path,
        f'[[specimen]]\nname = "a"\n{POLY}\n[[specimen]]\nname = "b"\ndxf = "clip.dxf"\n',
    )
    code = (
        "import json, sys, shapes; s = shapes.load_specimens(sys.argv[1]); "
        "[shapes.convex_pieces(x) for x in s]; "
        "print(json.dumps(['build123d' in sys.modules, len(s)]))"
    )
    assert run_json(code.replace("sys.argv[1]", repr(str(path))), cleared=()) == [False, 2]
