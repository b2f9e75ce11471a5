"""Materials as data: the [[material]] schema, its one-line errors, the round trip and the
shipped library (synth.material_data, synth/material_library.toml, docs/materials.md)."""

from __future__ import annotations

import doctest
import json
import math
import re
from pathlib import Path

import pytest

from synth import material_data as md
from synth.materials import MATERIALS, FrictionLaw, Material, Periodic, Texture

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = ("glass", "pla_fdm", "sandpaper_p120", "brushed_steel")

GOOD = """
[[material]]
name = "cork"
[material.friction]
kinetic = 0.9
static = 1
stribeck_velocity_m_s = 2e-3
load_exponent = -0.3
[material.texture]
roughness_rms_m = 20e-6
correlation_length_m = 200e-6
[[material.texture.periodic]]
wavelength_m = 1e-3
amplitude_m = 5e-6
[[material.texture.periodic]]
wavelength_m = 0.3e-3
amplitude_m = 1e-6

[[material]]
name = "felt-2"
[material.friction]
kinetic = 0.6
static = 0.7
[material.texture]
roughness_rms_m = 0
correlation_length_m = 1e-3
"""

#: A valid table's text, to be broken one field at a time.
CORK = """[[material]]
name = "cork"
[material.friction]
kinetic = 1.15
static = 1.38
[material.texture]
roughness_rms_m = 20e-6
correlation_length_m = 200e-6
[[material.texture.periodic]]
wavelength_m = 1e-3
amplitude_m = 5e-6
"""


def _write(tmp_path: Path, text: str, name: str = "lab.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def _error(path: Path) -> str:
    before = sorted(p.name for p in path.parent.iterdir())
    with pytest.raises(ValueError) as info:
        md.load_materials(path)
    assert sorted(p.name for p in path.parent.iterdir()) == before  # nothing written
    message = str(info.value)
    assert "\n" not in message
    return message


def test_the_library_is_the_papers_three_then_the_shipped_file():
    lib = md.library()
    assert list(lib)[:3] == list(MATERIALS)
    assert all(lib[name] is MATERIALS[name] for name in MATERIALS)  # imported, not copied
    assert set(SHIPPED) <= set(lib)
    assert all(isinstance(m, Material) and m.name == n for n, m in lib.items())
    lib["glass"] = None  # a copy: the cached library is untouched
    assert md.library()["glass"] is not None


def test_library_values_are_the_cited_ones():
    lib = md.library()
    # The silicone law where no silicone-on-X measurement exists; measured on PLA.
    for name in SHIPPED:
        assert lib[name].friction == FrictionLaw(kinetic=1.15, static=1.38)
    assert lib["glass"].texture == Texture(roughness_rms_m=0.3e-9, correlation_length_m=5e-6)
    assert lib["pla_fdm"].texture.periodic == (Periodic(wavelength_m=0.2e-3, amplitude_m=26e-6),)
    assert lib["sandpaper_p120"].texture.roughness_rms_m == 53e-6
    assert lib["brushed_steel"].texture.roughness_rms_m == 0.56e-6


def test_the_glass_roughness_follows_from_frozen_capillary_waves():
    # w^2 = k T_F / (2 pi gamma) ln(L / a), the library file's derivation.
    k_b, t_f, gamma = 1.380649e-23, 820.0, 0.315
    w = math.sqrt(k_b * t_f / (2 * math.pi * gamma) * math.log(1e-3 / 0.5e-9))
    assert md.library()["glass"].texture.roughness_rms_m == pytest.approx(w, rel=0.05)


def test_the_pla_marks_carry_the_measured_ra_across_the_lines():
    mark = md.library()["pla_fdm"].texture.periodic[0]
    ra_across = (15.31e-6 + 18.14e-6) / 2  # middle of the measured range
    assert 2 / math.pi * mark.amplitude_m == pytest.approx(ra_across, rel=0.02)


def test_every_library_value_has_its_source_beside_or_above_it():
    lines = (ROOT / "synth" / md.LIBRARY_FILE).read_text().splitlines()
    for i, line in enumerate(lines):
        if re.match(r"\s*[a-z_]+\s*=\s*[-0-9.]", line):
            commented = "#" in line or (i > 0 and lines[i - 1].lstrip().startswith("#"))
            assert commented, f"line {i + 1} has no source: {line!r}"


@pytest.mark.parametrize("name", list(md.library()))
def test_every_library_material_round_trips(name):
    material = md.library()[name]
    table = md.material_to_table(material)
    assert md.material_from_table(table) == material
    assert md.material_from_table(json.loads(json.dumps(table))) == material
    assert set(table) == {"name", "friction", "texture"}
    assert set(table["friction"]) == set(md.FRICTION_KEYS)


def test_load_a_file_with_every_field_and_the_defaults(tmp_path):
    loaded = md.load_materials(_write(tmp_path, GOOD))
    assert list(loaded) == ["cork", "felt-2"]
    assert loaded["cork"] == Material(
        name="cork",
        friction=FrictionLaw(
            kinetic=0.9, static=1.0, stribeck_velocity_m_s=2e-3, load_exponent=-0.3
        ),
        texture=Texture(
            roughness_rms_m=20e-6,
            correlation_length_m=200e-6,
            periodic=(
                Periodic(wavelength_m=1e-3, amplitude_m=5e-6),
                Periodic(wavelength_m=0.3e-3, amplitude_m=1e-6),
            ),
        ),
    )
    felt = loaded["felt-2"]
    assert felt.friction == FrictionLaw(kinetic=0.6, static=0.7)  # FrictionLaw's defaults
    assert felt.texture.periodic == ()
    assert isinstance(loaded["cork"].friction.static, float)  # an integer becomes a float


BAD = [
    # (replace this, with this, the message after "lab.toml: ")
    (
        "roughness_rms_m = 20e-6",
        "roughness_rms_m = -1e-6",
        "material 'cork': texture.roughness_rms_m must lie in 0..100e-6 m; got -1e-06",
    ),
    (
        "roughness_rms_m = 20e-6",
        "roughness_rms_m = 0.2e-3",
        "material 'cork': texture.roughness_rms_m must lie in 0..100e-6 m; got 0.0002",
    ),
    (
        "[material.texture]",
        "[material.texure]",
        "material 'cork': key must be one of name, friction, texture, replace; "
        "got 'texure' (did you mean 'texture'?)",
    ),
    (
        "kinetic = 1.15",
        "kinetc = 1.15",
        "material 'cork': friction key must be one of kinetic, static, "
        "stribeck_velocity_m_s, load_exponent, velocity_exponent, reference_speed_m_s; "
        "got 'kinetc' (did you mean 'kinetic'?)",
    ),
    (
        "wavelength_m = 1e-3",
        "wavelength_mm = 1",
        "material 'cork': texture.periodic[1] key must be one of wavelength_m, amplitude_m; "
        "got 'wavelength_mm' (did you mean 'wavelength_m'?)",
    ),
    (
        "static = 1.38",
        "static = 1.0",
        "material 'cork': friction.static must be >= friction.kinetic (1.15); got 1.0",
    ),
    ("kinetic = 1.15\n", "", "material 'cork': friction.kinetic is required"),
    (
        "wavelength_m = 1e-3",
        "wavelength_m = 5e-6",
        "material 'cork': texture.periodic[1].wavelength_m must lie in 10e-6..20e-3 m; got 5e-06",
    ),
    (
        "wavelength_m = 1e-3",
        "wavelength_m = 0.03",
        "material 'cork': texture.periodic[1].wavelength_m must lie in 10e-6..20e-3 m; got 0.03",
    ),
    (
        "kinetic = 1.15",
        'kinetic = "high"',
        "material 'cork': friction.kinetic must be a number; got 'high'",
    ),
    (
        "roughness_rms_m = 20e-6",
        "roughness_rms_m = true",
        "material 'cork': texture.roughness_rms_m must be a number; got True",
    ),
    (
        "correlation_length_m = 200e-6",
        "correlation_length_m = inf",
        "material 'cork': texture.correlation_length_m must be a finite number; got inf",
    ),
    (
        "correlation_length_m = 200e-6",
        "correlation_length_m = 0",
        "material 'cork': texture.correlation_length_m must lie in 1e-6..5e-3 m; got 0",
    ),
    (
        "kinetic = 1.15",
        "kinetic = 0.01",
        "material 'cork': friction.kinetic must lie in 0.05..3 (3 excluded); got 0.01",
    ),
    (
        "static = 1.38",
        "static = 3.0",
        "material 'cork': friction.static must lie in 0.05..3 (3 excluded); got 3.0",
    ),
    (
        "static = 1.38",
        "static = 1.38\nload_exponent = 0.1",
        "material 'cork': friction.load_exponent must lie in -1..0; got 0.1",
    ),
    (
        "static = 1.38",
        "static = 1.38\nstribeck_velocity_m_s = 1.0",
        "material 'cork': friction.stribeck_velocity_m_s must lie in 1e-5..0.1 m/s; got 1.0",
    ),
    (
        "amplitude_m = 5e-6",
        "amplitude_m = 0.2e-3",
        "material 'cork': texture.periodic[1].amplitude_m must lie in 0..100e-6 m; got 0.0002",
    ),
    (
        "amplitude_m = 5e-6",
        "amplitude_m = 90e-6\n[[material.texture.periodic]]\nwavelength_m = 0.3e-3\n"
        "amplitude_m = 60e-6",
        "material 'cork': texture.periodic[2].amplitude_m must be <= wavelength_m / (2 pi) = "
        "4.77e-05 m (a mark's slope of at most 1, 45 degrees; a steeper relief is an edge "
        "of the outline); got 6e-05",
    ),
    (
        'name = "cork"',
        'name = "Cork"',
        "material #1: name must hold only lower-case letters, digits, '_' and '-' (starting "
        "with a letter or digit, at most 64); got 'Cork'",
    ),
    ('name = "cork"\n', "", "material #1: name is required"),
    (
        "[material.friction]\nkinetic = 1.15\nstatic = 1.38\n",
        "",
        "material 'cork': friction is required (a [material.friction] table)",
    ),
    (
        'name = "cork"',
        'name = "cork"\nreplace = "yes"',
        "material 'cork': replace must be true or false; got 'yes'",
    ),
    (
        "[[material.texture.periodic]]\nwavelength_m = 1e-3\namplitude_m = 5e-6\n",
        "periodic = [1e-3, 5e-6]\n",
        "material 'cork': texture.periodic must be an array of tables "
        "([[material.texture.periodic]]); got [0.001, 5e-06]",
    ),
]


@pytest.mark.parametrize(("old", "new", "expected"), BAD, ids=[b[2][:60] for b in BAD])
def test_bad_tables_name_the_file_the_entry_the_field_and_the_rule(tmp_path, old, new, expected):
    assert old in CORK
    path = _write(tmp_path, CORK.replace(old, new, 1))
    assert _error(path) == f"{path}: {expected}"


def test_the_nth_table_is_named_by_its_position(tmp_path):
    path = _write(tmp_path, CORK + CORK.replace('name = "cork"', "name = 3"))
    assert _error(path) == (
        f"{path}: material #2: name must hold only lower-case letters, digits, '_' and '-' "
        "(starting with a letter or digit, at most 64); got 3"
    )


def test_duplicate_names_fail(tmp_path):
    path = _write(tmp_path, CORK + GOOD)
    assert _error(path) == (
        f"{path}: material 'cork': the name appears twice (material tables 1 and 2); every "
        "material needs its own name"
    )


def test_a_library_name_needs_replace_and_replace_needs_a_library_name(tmp_path):
    glass = CORK.replace('name = "cork"', 'name = "glass"')
    path = _write(tmp_path, glass)
    assert _error(path) == (
        f"{path}: material 'glass': 'glass' is a library material; give yours another name, "
        "or set replace = true in its table to use it instead of the library's"
    )
    path = _write(tmp_path, glass.replace('name = "glass"', 'name = "glass"\nreplace = true'))
    mine = md.load_materials(path)["glass"]
    assert mine != md.library()["glass"] and mine.texture.roughness_rms_m == 20e-6
    assert {**md.library(), **md.load_materials(path)}["glass"] == mine
    path = _write(tmp_path, glass.replace('name = "glass"', 'name = "glas"\nreplace = true'))
    assert _error(path) == (
        f"{path}: material 'glas': replace = true, but the library has no material 'glas' to "
        "replace (did you mean 'glass'?); remove replace for a new material"
    )
    # The paper's three are library materials too.
    path = _write(tmp_path, CORK.replace('name = "cork"', 'name = "wood"'))
    assert "'wood' is a library material" in _error(path)


def test_parse_materials_takes_the_library_names_it_is_given():
    tables = [md.material_to_table(md.library()["glass"])]
    assert md.parse_materials(tables, file="x.toml", library_names=()) == {
        "glass": md.library()["glass"]
    }
    with pytest.raises(ValueError, match="'glass' is a library material"):
        md.parse_materials(tables, file="x.toml")
    assert md.parse_materials(None, file="x.toml") == {}  # an experiment naming only the library's


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("", "no [[material]] tables (see docs/materials.md)"),
        ("material = []", "no [[material]] tables"),
        (
            '[material]\nname = "cork"',
            "write [[material]] (one table per material), not [material]",
        ),
        ("material = 3", "'material' must be an array of tables ([[material]])"),
        ("material = [3]", "material #1 must be a table ([[material]]); got 3"),
        (
            "[[materials]]\nname = 'cork'",
            "top-level key must be one of material; got 'materials' (did you mean 'material'?)",
        ),
        ("[[material]\n", "not valid TOML: "),
    ],
)
def test_file_level_errors(tmp_path, text, expected):
    path = _write(tmp_path, text)
    assert _error(path).startswith(f"{path}: {expected}")


def test_a_missing_file_is_one_line(tmp_path):
    with pytest.raises(ValueError, match=r"^.*nope\.toml: no such file$"):
        md.load_materials(tmp_path / "nope.toml")


def test_library_material_hints_a_close_name():
    assert md.library_material("glass") is md.library()["glass"]
    with pytest.raises(ValueError, match=r"got 'glas' \(did you mean 'glass'\?\)"):
        md.library_material("glas")


def test_material_to_table_checks_its_argument():
    with pytest.raises(ValueError, match="material must be a Material; got 'glass'"):
        md.material_to_table("glass")


# The ranges against the dataclasses' own checks, where the two overlap: whatever the
# loader accepts the dataclass accepts, and whatever the dataclass refuses the loader
# refuses (with its own one-line message).
OVERLAP = {
    "friction.kinetic": [-1.0, 0.0, 0.049, 0.05, 1.0, 2.99, 3.0, 3.5],
    "friction.static": [0.0, 0.05, 2.999, 3.0, 4.0],
    "friction.stribeck_velocity_m_s": [-1e-3, 0.0, 1e-5, 0.1, 0.2],
    "friction.load_exponent": [-1.5, -1.0, -0.21, 0.0, 0.01],
    "texture.roughness_rms_m": [-1e-12, 0.0, 1e-6, 100e-6, 101e-6],
    "texture.correlation_length_m": [-1e-6, 0.0, 1e-6, 5e-3, 6e-3],
    "texture.periodic.wavelength_m": [-1e-3, 0.0, 10e-6, 20e-3, 21e-3],
    "texture.periodic.amplitude_m": [-1e-9, 0.0, 1e-6, 100e-6, 101e-6],
}


def _dataclass_accepts(field: str, value: float) -> bool:
    friction = {"kinetic": 0.05, "static": 2.99}
    texture = {"roughness_rms_m": 1e-6, "correlation_length_m": 1e-3}
    mark = {"wavelength_m": 20e-3, "amplitude_m": 1e-6}
    group, key = field.split(".", 1)
    if group == "friction":
        friction[key] = value
        if key == "kinetic":
            friction["static"] = max(value, 0.05)
    elif key.startswith("periodic."):
        mark[key.split(".")[1]] = value
    else:
        texture[key] = value
    try:
        Material(
            name="x",
            friction=FrictionLaw(**friction),
            texture=Texture(**texture, periodic=(Periodic(**mark),)),
        )
    except ValueError:
        return False
    return True


def _loader_accepts(field: str, value: float) -> bool:
    table = {
        "name": "x",
        "friction": {"kinetic": 0.05, "static": 2.99},
        "texture": {
            "roughness_rms_m": 1e-6,
            "correlation_length_m": 1e-3,
            "periodic": [{"wavelength_m": 20e-3, "amplitude_m": 1e-6}],
        },
    }
    group, key = field.split(".", 1)
    if group == "friction":
        table["friction"][key] = value
        if key == "kinetic":
            table["friction"]["static"] = max(value, 0.05)
    elif key.startswith("periodic."):
        table["texture"]["periodic"][0][key.split(".")[1]] = value
    else:
        table["texture"][key] = value
    try:
        md.material_from_table(table, file="f.toml")
    except ValueError as exc:
        assert str(exc).startswith("f.toml: material 'x': ")
        return False
    return True


@pytest.mark.parametrize("field", list(OVERLAP))
def test_ranges_are_never_wider_than_the_dataclasses_checks(field):
    assert field in md.RANGES
    outcomes = [
        (v, _loader_accepts(field, v), _dataclass_accepts(field, v)) for v in OVERLAP[field]
    ]
    for value, loader, dataclass in outcomes:
        assert not loader or dataclass, f"{field} = {value}: loader accepts, dataclass refuses"
        bound = md.RANGES[field]
        assert loader == bound.contains(value), f"{field} = {value}"
    assert any(loader for _, loader, _ in outcomes)
    assert any(not loader for _, loader, _ in outcomes)


def test_range_bounds_follow_from_the_simulator():
    from shapes import limits
    from synth import texture
    from synth.presets import SPEED_RANGE_MM_S

    wavelength = md.RANGES["texture.periodic.wavelength_m"]
    assert wavelength.lo == pytest.approx(2 * texture.GRID_M)  # no aliasing on the grid
    assert wavelength.hi == pytest.approx(limits.WINDOW_S * limits.NOMINAL_SPEED_M_S)
    stribeck = md.RANGES["friction.stribeck_velocity_m_s"]
    assert stribeck.hi / (SPEED_RANGE_MM_S[1] * 1e-3) == pytest.approx(4.5, rel=0.05)
    assert md.RANGES["friction.static"].hi == 3.0 and md.RANGES["friction.static"].hi_open
    assert md.RANGES["friction.load_exponent"].lo == -1.0
    assert md.RANGES["friction.load_exponent"].hi == 0.0


def test_docs_show_every_range_and_every_library_material():
    doc = (ROOT / "docs" / "materials.md").read_text()
    for field, bound in md.RANGES.items():
        assert f"`{bound.text}`" in doc, f"docs/materials.md lacks the range of {field}"
    for name in md.library():
        assert f"`{name}`" in doc, f"docs/materials.md lacks the library material {name}"


def test_the_docs_example_file_loads(tmp_path):
    doc = (ROOT / "docs" / "materials.md").read_text()
    blocks = re.findall(r"```toml\n(.*?)```", doc, flags=re.S)
    assert blocks
    for block in blocks:
        md.load_materials(_write(tmp_path, block, "doc.toml"))


def test_docstring_examples_run():
    finder = doctest.DocTestFinder(exclude_empty=True)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    tests = [t for t in finder.find(md, md.__name__) if t.examples]
    assert tests
    for test in tests:
        runner.run(test)
    assert runner.summarize(verbose=False).failed == 0


def test_importing_synth_leaves_the_library_unread():
    from tests.fresh_interpreter import run_json

    out = run_json(
        "import json, sys, synth; "
        "imported = 'synth.material_data' in sys.modules; "
        "from synth import material_data; "
        "print(json.dumps({'imported': imported, "
        "'read': material_data._library.cache_info().currsize}))",
        cleared=(),
    )
    assert out == {"imported": False, "read": 0}
