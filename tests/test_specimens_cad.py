"""User specimens through build123d: SVG files, Python functions, solids, cached meshes,
export, the ``shapes`` commands with ``--experiment``, and the shipped example."""

from __future__ import annotations

import argparse
import math
import re
import textwrap
from pathlib import Path

import numpy as np
import pytest
import shapely
import trimesh

import shapes
from shapes import SPECIMEN, Specimen, SpecimenError, cache, load_specimens, meshes
from shapes import cli as shapes_cli

MM = 1e-3
ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "my_lab" / "experiment.toml"

KEYHOLE = """<svg xmlns="http://www.w3.org/2000/svg" width="30mm" height="30mm" viewBox="0 0 30 30">
  <path id="keyhole" d="M 13 16.58258 A 5 5 0 1 1 17 16.58258 L 18.5 23 L 11.5 23 Z"/>
  <path id="axis" fill="none" stroke="red" d="M 15 5 L 15 25"/>
</svg>"""

FUNCTIONS = """
import build123d as bd

def slot(length=16.0, width=8.0):
    return bd.Sketch() + bd.SlotOverall(length, width)

def ring():
    return bd.Sketch() + bd.Circle(8) - bd.Circle(3)

def two():
    return bd.Sketch() + bd.Pos(-5, 0) * bd.Circle(3) + bd.Pos(5, 0) * bd.Circle(3)

def tilted():
    return bd.Plane.XZ * bd.Rectangle(12, 10)

def number():
    return 42

def broken(r=1.0):
    raise ZeroDivisionError("no\\nway")

def wire():
    return bd.Polyline((0, 0), (12, 0), (12, 9), (0, 9), close=True)

def open_wire():
    return bd.Polyline((0, 0), (12, 0), (12, 9))
"""


@pytest.fixture(autouse=True)
def _private_cache(tmp_path_factory, monkeypatch):
    # Meshes are cached on disk: keep them out of the user's cache directory.
    monkeypatch.setenv(cache.CACHE_ENV, str(tmp_path_factory.getbasetemp() / "specimen-cache"))


def write(tmp_path: Path, body: str, **files: str) -> Path:
    for name, text in files.items():
        (tmp_path / name.replace("__", ".")).write_text(textwrap.dedent(text))
    path = tmp_path / "experiment.toml"
    path.write_text(textwrap.dedent(body))
    return path


def one(tmp_path: Path, source: str, **files: str) -> Specimen:
    (spec,) = load_specimens(write(tmp_path, f'[[specimen]]\nname = "part"\n{source}\n', **files))
    return spec


def bad(tmp_path: Path, source: str, **files: str) -> str:
    path = write(tmp_path, f'[[specimen]]\nname = "part"\n{source}\n', **files)
    with pytest.raises(ValueError) as err:
        load_specimens(path)
    message = str(err.value)
    assert "\n" not in message
    prefix = f"{path}: specimen 'part': "
    assert message.startswith(prefix), message
    return message[len(prefix) :]


# --- SVG ---------------------------------------------------------------------------------


def test_svg_arc_polygonised_within_the_chord_tolerance(tmp_path):
    spec = one(tmp_path, 'svg = "k.svg"\nsvg_path_id = "keyhole"', k__svg=KEYHOLE)
    assert spec.curved and spec.source == "svg k.svg#keyhole"
    # The disc (r = 5 mm) sits 3 mm above the centre after flipping y and centring.
    _, y0, _, y1 = spec.bounds_m
    assert (y0, y1) == pytest.approx((-8 * MM, 8 * MM), abs=2e-5)
    centre = np.array([0.0, 3 * MM])
    ring = np.array(spec.vertices_m)
    radii = np.hypot(*(ring - centre).T)
    on_arc = np.abs(radii - 5 * MM) < 0.1 * MM
    assert on_arc.sum() > 20  # the rest are the slot's 2 corners
    assert len(ring) == on_arc.sum() + 2
    assert np.abs(radii[on_arc] - 5 * MM).max() < 1e-3 * MM  # vertices on the arc
    t = np.linspace(0, 2 * np.pi, 20000)
    exact = centre + 5 * MM * np.column_stack([np.cos(t), np.sin(t)])
    top = exact[exact[:, 1] > -1.4 * MM]  # the disc's visible arc, above the slot
    gap = shapely.distance(spec.polygon.exterior, shapely.points(top))
    assert gap.max() <= SPECIMEN.curve_tolerance_m * 1.01
    assert gap.max() > 0.2 * SPECIMEN.curve_tolerance_m  # not wastefully fine either


def test_svg_without_an_id_takes_its_only_closed_path_and_honours_units(tmp_path):
    square = """<svg xmlns="http://www.w3.org/2000/svg" width="24mm" height="24mm"
        viewBox="0 0 12 12"><path d="M 1 1 H 9 V 7 H 1 Z"/>
        <path d="M 0 0 L 3 3" fill="none" stroke="black"/></svg>"""
    spec = one(tmp_path, 'svg = "s.svg"', s__svg=square)  # 2 mm per user unit
    assert spec.x_extent_m == pytest.approx(16 * MM, rel=1e-5)
    assert spec.y_extent_m == pytest.approx(12 * MM, rel=1e-5)
    assert not spec.curved


@pytest.mark.parametrize(
    ("svg", "table", "expected"),
    [
        (
            '<path id="o" d="M 0 0 L 12 0 L 12 9" fill="none" stroke="black"/>',
            'svg_path_id = "o"',
            r"^the SVG element 'o': the outline is open: its ends are 15 mm apart$",
        ),
        (
            '<path id="o" d="M 0 0 L 12 0 L 12 9" fill="none" stroke="black"/>',
            "",
            r"holds no closed outline; open paths: o$",
        ),
        (
            '<circle id="a" cx="10" cy="10" r="5"/><circle id="b" cx="30" cy="10" r="5"/>',
            "",
            r"holds 2 closed outlines \(a, b\); choose one with svg_path_id$",
        ),
        (
            '<circle id="a" cx="10" cy="10" r="5"/>',
            'svg_path_id = "b"',
            r"has no element with id 'b' \(ids: a\)$",
        ),
        (
            '<path id="bow" d="M 0 0 L 16 10 L 16 0 L 0 10 Z"/>',
            "",
            r"^the outline crosses or touches itself near \(8.0, -5.0\) mm$",
        ),
        (
            '<path id="washer" fill-rule="evenodd" '
            'd="M 0 0 H 16 V 12 H 0 Z M 5 3 H 11 V 9 H 5 Z"/>',
            "",
            r"the outline has 1 hole\(s\); a specimen is one outline without holes",
        ),
        ("<path id='x' d='M 0 0 L", "", r"cannot read the SVG file|holds no closed outline"),
    ],
)
def test_bad_svg_files(tmp_path, svg, table, expected):
    text = f'<svg xmlns="http://www.w3.org/2000/svg">{svg}</svg>'
    message = bad(tmp_path, f'svg = "p.svg"\n{table}', p__svg=text)
    assert re.search(expected, message), message


# --- functions --------------------------------------------------------------------------


def test_a_function_in_a_file_beside_the_experiment(tmp_path):
    spec = one(
        tmp_path,
        'function = "fns.py:slot"\nkwargs = { length = 15.0, width = 9.0 }',
        fns__py=FUNCTIONS,
    )
    assert spec.curved and spec.source == 'function fns.py:slot {"length": 15.0, "width": 9.0}'
    assert spec.x_extent_m == pytest.approx(15 * MM, abs=2 * SPECIMEN.curve_tolerance_m)
    exact = (6 * 9 + math.pi * 4.5**2) * MM * MM
    # Chords cut inside the arcs: 2/3 x 0.02 mm x the arcs' length (28 mm) = 0.3 % less.
    assert spec.area_m2 == pytest.approx(exact, rel=5e-3) and spec.area_m2 < exact
    closed = one(tmp_path, 'function = "fns.py:wire"', fns__py=FUNCTIONS)
    assert closed.area_m2 == pytest.approx(108 * MM * MM, rel=1e-12) and not closed.curved


def test_a_function_in_a_module_found_beside_the_experiment(tmp_path):
    (tmp_path / "labshapes").mkdir()
    (tmp_path / "labshapes" / "__init__.py").write_text(FUNCTIONS)
    spec = one(tmp_path, 'function = "labshapes:slot"')
    assert spec.x_extent_m == pytest.approx(16 * MM, abs=2 * SPECIMEN.curve_tolerance_m)
    assert str(tmp_path.resolve()) not in __import__("sys").path  # searched, not kept


@pytest.mark.parametrize(
    ("function", "expected"),
    [
        ("broken", r"^function 'fns.py:broken' raised ZeroDivisionError: no way$"),
        (
            "number",
            r"^function 'fns.py:number': got int, not a build123d Face, Sketch or closed Wire$",
        ),
        ("missing", r"^function 'fns.py:missing': fns.py has no attribute 'missing'$"),
        ("ring", r"the outline has 1 hole\(s\)"),
        ("two", r"the shape holds 2 faces; a specimen is one outline"),
        ("tilted", r"the outline leaves the plane z = 0"),
        ("open_wire", r"the outline is open: its ends are 15 mm apart"),
    ],
)
def test_bad_functions(tmp_path, function, expected):
    message = bad(tmp_path, f'function = "fns.py:{function}"', fns__py=FUNCTIONS)
    assert re.search(expected, message), message


def test_a_function_file_that_fails_to_import(tmp_path):
    message = bad(tmp_path, 'function = "bad.py:f"', bad__py="import no_such_module_xyz\n")
    assert message.startswith("function 'bad.py:f': importing ")
    assert "ModuleNotFoundError: No module named 'no_such_module_xyz'" in message


def test_from_build123d_takes_a_face_in_any_unit():
    import build123d as bd

    face = bd.Rectangle(0.6, 0.5).face()  # inches
    spec = Specimen.from_build123d("plate", face, unit_m=25.4 * MM, source="inline")
    assert spec.x_extent_m == pytest.approx(15.24 * MM) and spec.source == "inline"
    with pytest.raises(SpecimenError, match=r"^specimen 'plate': got str, not a build123d"):
        Specimen.from_build123d("plate", "square")


# --- solids, meshes, export ---------------------------------------------------------------


@pytest.fixture(scope="module")
def gear() -> Specimen:
    functions = ROOT / "examples" / "my_lab"
    from shapes import sources

    ring, curved = sources.function_outline(
        "my_shapes.py:gear", {"teeth": 8}, functions, SPECIMEN.curve_tolerance_m
    )
    return Specimen.from_outline("gear", ring, curved=curved, height_m=2.5 * MM)


def test_solid_and_mesh_of_a_specimen_match_its_polygon(gear):
    from shapes import cad

    top_area, volume = cad.area_and_volume(shapes.solid(gear))
    assert top_area == pytest.approx(gear.area_m2, rel=1e-9)
    assert volume == pytest.approx(gear.area_m2 * 2.5 * MM, rel=1e-9)
    m = shapes.mesh(gear)
    assert m.is_watertight and m.is_winding_consistent
    assert m.volume == pytest.approx(gear.area_m2 * 2.5 * MM, rel=1e-9)
    assert m.bounds[1, 2] == pytest.approx(2.5 * MM)
    pieces = shapes.convex_pieces(gear)
    assert len(pieces) > 8  # one per tooth at least, the gaps between teeth left open
    assert sum(p.volume for p in pieces) == pytest.approx(m.volume, rel=1e-9)


def test_specimen_meshes_are_cached_by_geometry(gear):
    path = cache.geometry_entry_path("mesh", "gear", gear.geometry_hash)
    first = shapes.mesh(gear)
    assert path.is_file() and path.name.startswith("mesh-specimen-gear-")
    meshes._mesh_arrays.cache_clear()
    stamp = path.stat().st_mtime_ns
    again = shapes.mesh(gear)
    assert np.array_equal(again.vertices, first.vertices) and path.stat().st_mtime_ns == stamp
    renamed = Specimen.from_dict({**gear.to_dict(), "name": "cog"})
    taller = Specimen.from_dict(
        {**gear.to_dict(), "height_m": 3 * MM, "geometry_sha256": None} | {"source": "x"}
    )
    assert renamed.geometry_hash == gear.geometry_hash
    assert cache.geometry_entry_path(
        "mesh", "x", taller.geometry_hash
    ) != cache.geometry_entry_path("mesh", "x", gear.geometry_hash)
    # Built-ins keep their own keys: no specimen entry is ever read for them.
    assert cache.entry_path("mesh", "circle", SPECIMEN).name.startswith("mesh-circle-")


@pytest.mark.parametrize("fmt", ["stl", "step"])
def test_export_a_specimen(gear, tmp_path, fmt):
    from shapes.export import export

    path = export(gear, tmp_path, fmt, unit="mm")
    assert path == tmp_path / f"gear.{fmt}"
    if fmt == "stl":
        back = trimesh.load(path, force="mesh")
        assert back.volume == pytest.approx(gear.area_m2 * 2.5 * MM * 1e9, rel=1e-6)
    else:
        assert path.read_text().startswith("ISO-10303")


# --- the commands ---------------------------------------------------------------------------


def _cli(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="tactile-synth")
    sub = parser.add_subparsers(dest="command", required=True)
    shapes_cli.register(sub)
    args = parser.parse_args(argv)
    return args.handler(args)


SMALL = """
[conditions]
speeds_mm_s = [10]      # another section: ignored by the shapes commands

[[specimen]]
name = "moon"

[[specimen]]
name = "l_bracket"
polygon_mm = [[-8, -6], [8, -6], [8, -2], [-4, -2], [-4, 6], [-8, 6]]
height_mm = 3
"""


def test_commands_with_an_experiment(tmp_path, capsys):
    path = write(tmp_path, SMALL)
    assert _cli(["shapes", "info", "--experiment", str(path)]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == f"experiment {path}: 2 specimens on a 60 x 30 x 3 mm plate"
    assert out[2].split()[0] == "moon" and out[2].endswith("built-in S5")
    assert out[3].split()[:7] == ["l_bracket", "16.00", "12.00", "3.00", "96.00", "2", "polygon_mm"]
    png = tmp_path / "p.png"
    assert _cli(["shapes", "preview", "--experiment", str(path), "--out", str(png)]) == 0
    assert png.read_bytes().startswith(b"\x89PNG")
    out_dir = tmp_path / "stl"
    assert _cli(["shapes", "export", "--experiment", str(path), "--out", str(out_dir)]) == 0
    assert sorted(p.name for p in out_dir.iterdir()) == ["l_bracket.stl", "moon.stl"]
    one_dir = tmp_path / "one"
    argv = ["shapes", "export", "--experiment", str(path), "--out", str(one_dir)]
    assert _cli([*argv, "--shape", "l_bracket"]) == 0
    assert [p.name for p in one_dir.iterdir()] == ["l_bracket.stl"]
    with pytest.raises(ValueError, match=r"^--shape must be one of moon, l_bracket; got 'circle'"):
        _cli([*argv, "--shape", "circle"])


def test_a_bad_experiment_writes_nothing(tmp_path):
    path = write(tmp_path, SMALL + '\n[[specimen]]\nname = "l_bracket"\nsvg = "x.svg"\n')
    out = tmp_path / "out"
    for argv in (
        ["preview", "--out", str(out / "p.png")],
        ["export", "--out", str(out)],
        ["info"],
    ):
        with pytest.raises(ValueError, match=rf"^{path}: specimen 'l_bracket': the name appears"):
            _cli(["shapes", *argv, "--experiment", str(path)])
    assert not out.exists()


def test_the_my_lab_example_loads():
    loaded = load_specimens(EXAMPLE)
    names = [shapes.specimen_name(s) for s in loaded]
    assert names[:2] == ["circle", "moon"]
    user = [s for s in loaded if isinstance(s, Specimen)]
    assert len(user) >= 5
    kinds = {s.source.split()[0] for s in user}
    assert {"polygon_mm", "svg", "dxf", "function"} <= kinds
    for s in user:
        assert shapes.convex_pieces(s) and Specimen.from_dict(s.to_dict()) == s
    assert {s.name for s in user if len(shapes.convex_pieces(s)) > 1} >= {"gear", "clip"}


@pytest.mark.parametrize(
    ("name", "solid_xy_mm", "open_xy_mm"),
    [
        ("clip", (-5.96, 0.0), (0.5, 0.0)),
        ("gear", (0.0, -1.0), (7.3, 1.4)),
        ("keyhole", (0, 3), None),
    ],
)
def test_example_specimens_collide_in_mujoco_as_their_pieces(name, solid_xy_mm, open_xy_mm):
    """MuJoCo collides each piece as its hull: a probe rests on the top where the outline
    is solid and drops to the plate in a concavity (the clip's hollow, between teeth)."""
    from test_shapes_mujoco import _rest_height

    (spec,) = [s for s in load_specimens(EXAMPLE) if shapes.specimen_name(s) == name]
    pieces = shapes.convex_pieces(spec)
    # The probe that rests on the top is as wide as the clip's band: a smaller one, which
    # MuJoCo's soft default contact lets sink deep, leaves a piece sideways through a seam.
    on_top = _rest_height(pieces, np.array(solid_xy_mm) * MM, 1.5 * MM)
    assert spec.polygon.buffer(-1.4 * MM).contains(shapely.Point(np.array(solid_xy_mm) * MM))
    assert on_top > spec.height_m
    if open_xy_mm is not None:
        xy = np.array(open_xy_mm) * MM
        assert spec.polygon.convex_hull.contains(shapely.Point(xy))
        assert not spec.polygon.buffer(0.5 * MM).contains(shapely.Point(xy))
        assert _rest_height(pieces, xy, 0.5 * MM) < 1.0 * MM  # on the plate
