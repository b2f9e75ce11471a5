"""Experiment files (synth.experiment), grids with their own classes (GenerationConfig,
SynthConfig's materials and specimens, class seed keys) and ``generate --experiment``'s
refusals: every bad input one line naming the file, the entry and the rule, nothing
written."""

from __future__ import annotations

import json
import shutil
import zlib
from pathlib import Path

import numpy as np
import pytest

import shapes
from benchmark.cli import main
from synth import CLASS_NAMES, store
from synth.config import SynthConfig
from synth.experiment import PACKAGED, load_experiment, packaged_path
from synth.grid import GenerationConfig, plan, trial_seed
from synth.material_data import library
from synth.materials import MATERIALS
from synth.presets import PRESETS
from synth.trial import TrialSpec, class_key

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "my_lab" / "experiment.toml"

#: A small valid experiment: two built-ins and one polygon, a library material and one
#: of the file's own.
GOOD = """\
name = "bench"
trials_per_class = 3
materials = ["glass", "cork"]

[conditions]
force_n = [1.0, 1.4]
speed_mm_s = [10.0]

[[specimen]]
name = "l_bracket"
polygon_mm = [[-8, -6], [8, -6], [8, -2], [-4, -2], [-4, 6], [-8, 6]]

[[specimen]]
name = "square"

[[specimen]]
name = "circle"

[[material]]
name = "cork"
[material.friction]
kinetic = 0.9
static = 1.1
[material.texture]
roughness_rms_m = 20e-6
correlation_length_m = 200e-6
"""


def _polygon_l_bracket() -> str:
    return (
        '[[specimen]]\nname = "l_bracket"\n'
        "polygon_mm = [[-8, -6], [8, -6], [8, -2], [-4, -2], [-4, 6], [-8, 6]]\n"
    )


def write(tmp_path: Path, text: str = GOOD, name: str = "exp.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


# -- the presets are experiment files -----------------------------------------------------
def test_presets_are_the_packaged_experiment_files_and_the_grids_they_always_were():
    expected = {
        "quick": GenerationConfig(preset="quick", trials_per_class=4),
        "paper": GenerationConfig(preset="paper", trials_per_class=60),
        "perturbation": GenerationConfig(
            preset="perturbation",
            trials_per_class=10,
            forces_n=(0.6, 1.0, 1.4),
            speeds_mm_s=(6.0, 10.0, 14.0),
            include_nominal=False,
        ),
    }
    assert tuple(PRESETS) == PACKAGED
    for name in PACKAGED:
        assert load_experiment(packaged_path(name)) == expected[name] == PRESETS[name]
        assert PRESETS[name].classes == CLASS_NAMES
        assert PRESETS[name].synth is None  # the simulator's defaults, resolved when stored


# -- loading ---------------------------------------------------------------------------------
def test_an_experiment_loads_into_a_grid_with_its_own_classes(tmp_path):
    grid = load_experiment(write(tmp_path))
    # Built-ins in the paper's order, then the file's own specimens in its order; the
    # materials in the order the file lists them.
    assert grid.shapes == ("circle", "square", "l_bracket")
    assert grid.materials == ("glass", "cork")
    assert grid.classes == (
        "circle/glass", "circle/cork", "square/glass", "square/cork", "l_bracket/glass",
        "l_bracket/cork",
    )  # fmt: skip
    assert grid.preset == "bench" and grid.trials_per_class == 3 and grid.seed == 0
    assert grid.conditions == ((1.0, 10.0), (1.4, 10.0)) and grid.n_trials == 36
    synth = SynthConfig.from_dict(grid.synth)
    assert list(synth.materials) == ["glass", "cork"]
    assert synth.materials["glass"] == library()["glass"]
    assert synth.materials["cork"].friction.kinetic == 0.9
    assert list(synth.specimens) == ["l_bracket"]
    assert synth.specimens["l_bracket"].x_extent_m == pytest.approx(16e-3)
    # The whole configuration survives the store's JSON: the grid needs no file.
    again = GenerationConfig.from_dict(json.loads(json.dumps(grid.to_dict())))
    assert again == grid and again.classes == grid.classes


def test_the_example_experiment_loads(tmp_path):
    grid = load_experiment(EXAMPLE)
    assert grid.preset == "my_lab" and len(grid.classes) == 27 and grid.n_trials == 540
    assert grid.materials == ("pla_fdm", "glass", "pla_top")
    assert grid.shapes[:2] == ("circle", "moon") and "gear" in grid.shapes
    own = SynthConfig.from_dict(grid.synth).specimens
    assert len(own) == 7 and all(isinstance(s, shapes.Specimen) for s in own.values())
    # --trials-per-class overrides the file's count
    assert grid.replace(trials_per_class=2).n_trials == 54


def test_simulator_tables_set_only_the_fields_they_name(tmp_path):
    path = write(tmp_path, GOOD + "\n[simulator.motion]\napproach_s = 0.12\n")
    synth = SynthConfig.from_dict(load_experiment(path).synth)
    assert synth.motion.approach_s == 0.12
    assert synth.motion.timestep_s == SynthConfig().motion.timestep_s
    assert synth.finger == SynthConfig().finger


def test_a_file_that_changes_the_skin_gets_its_contact_fitted_to_the_new_skin(tmp_path):
    """A softer skin (or another pad radius) in ``[simulator.finger]`` refits the skin's
    MuJoCo contact to its own Hertz law, also without resin among the materials (the
    default contact would sink the 2.9 times softer skin half as deep as Hertz says);
    a file that sets the contact itself keeps it."""
    from synth import contact
    from synth.skin_fit import measure_indentation

    path = write(tmp_path, GOOD + "\n[simulator.finger]\nskin_modulus_pa = 0.1e6\n")
    synth = SynthConfig.from_dict(load_experiment(path).synth)
    f = synth.finger
    assert f.skin_solimp != SynthConfig().finger.skin_solimp
    hertz = contact.hertz_indentation_m(1.0, f.pad_radius_m, f.skin_modulus_pa, f.skin_poisson)
    assert measure_indentation(synth, (1.0,))[0] == pytest.approx(hertz, rel=0.05)
    own = (
        "\n[simulator.finger]\nskin_modulus_pa = 0.1e6\nskin_solimp = [0.3, 0.95, 0.006, 0.5, 1]\n"
    )
    synth = SynthConfig.from_dict(load_experiment(write(tmp_path, GOOD + own)).synth)
    assert synth.finger.skin_solimp == (0.3, 0.95, 0.006, 0.5, 1)


def test_a_paper_experiment_stores_the_simulator_defaults_as_none(tmp_path):
    text = GOOD.replace('["glass", "cork"]', '["resin", "wood", "aluminum"]')
    text = text.split("[[material]]")[0].replace(_polygon_l_bracket(), "")
    grid = load_experiment(write(tmp_path, text))
    assert grid.synth is None and grid.classes[:3] == CLASS_NAMES[:3]
    # Anything else is stored in full: here one material of the paper's three.
    text = text.replace('["resin", "wood", "aluminum"]', '["wood"]')
    grid = load_experiment(write(tmp_path, text))
    assert list(grid.synth["materials"]) == ["wood"]


# -- bad inputs: one line naming the file, the entry and the rule ---------------------------
def _polygon(name: str, points: str) -> str:
    return f'\n[[specimen]]\nname = "{name}"\npolygon_mm = {points}\n'


BAD = {
    "unknown top-level key": (
        GOOD.replace("trials_per_class = 3", "trials_per_clas = 3"),
        "exp.toml: unknown top-level key 'trials_per_clas' (did you mean 'trials_per_class'?)",
    ),
    "no trials_per_class": (
        GOOD.replace("trials_per_class = 3\n", ""),
        "exp.toml: trials_per_class is required",
    ),
    "unknown material": (
        GOOD.replace('"glass", "cork"', '"glas", "cork"'),
        "exp.toml: material 'glas': neither a [[material]] table of the file nor a library "
        "material (did you mean 'glass'?)",
    ),
    "material listed twice (a duplicate class name)": (
        GOOD.replace('"glass", "cork"', '"glass", "cork", "glass"'),
        "exp.toml: material 'glass': listed twice in materials; every class "
        "<specimen>/glass would appear twice",
    ),
    "specimen twice (a duplicate class name)": (
        GOOD + '\n[[specimen]]\nname = "square"\n',
        "exp.toml: specimen 'square': the name appears twice (specimen tables 2 and 4)",
    ),
    "material defined, not listed": (
        GOOD.replace('"glass", "cork"', '"glass"'),
        "exp.toml: material 'cork': defined in a [[material]] table but not listed",
    ),
    "unknown material field": (
        GOOD.replace("[material.texture]", "[material.textur]"),
        "exp.toml: material 'cork': key must be one of name, friction, texture, replace; "
        "got 'textur' (did you mean 'texture'?)",
    ),
    "negative roughness": (
        GOOD.replace("roughness_rms_m = 20e-6", "roughness_rms_m = -1e-6"),
        "exp.toml: material 'cork': texture.roughness_rms_m must lie in 0..100e-6 m; got -1e-06",
    ),
    "self-intersecting outline": (
        GOOD + _polygon("bow", "[[-8, -5], [8, 5], [8, -5], [-8, 5]]"),
        "exp.toml: specimen 'bow': the outline crosses or touches itself near (0.0, 0.0) mm",
    ),
    "larger than the plate": (
        GOOD + _polygon("huge", "[[-9.5, -12.5], [9.5, -12.5], [9.5, 12.5], [-9.5, 12.5]]"),
        "exp.toml: specimen 'huge': the outline (x -9.5 to 9.5 mm, y -12.5 to 12.5 mm) does "
        "not fit the 60 x 30 mm plate",
    ),
    "no conditions": (
        GOOD.replace("[conditions]\nforce_n = [1.0, 1.4]\nspeed_mm_s = [10.0]\n", ""),
        "exp.toml: no [conditions] table",
    ),
    "force out of range": (
        GOOD.replace("force_n = [1.0, 1.4]", "force_n = [5.0]"),
        "exp.toml: conditions.force_n must lie in 0.4..3 N",
    ),
    "unknown condition key": (
        GOOD.replace("speed_mm_s = [10.0]", "speed_mm_s = [10.0]\nforces = [1.0]"),
        "exp.toml: [conditions]: unknown key 'forces' (did you mean 'force_n'?)",
    ),
    "unknown simulator section": (
        GOOD + "\n[simulator.moton]\napproach_s = 0.1\n",
        "exp.toml: [simulator]: unknown section 'moton' (did you mean 'motion'?)",
    ),
    "unknown simulator field": (
        GOOD + "\n[simulator.motion]\napproach = 0.1\n",
        "exp.toml: [simulator.motion]: unknown field 'approach' (did you mean 'approach_s'?)",
    ),
    "bad simulator value": (
        GOOD + "\n[simulator.motion]\napproach_s = -0.1\n",
        "exp.toml: simulator: Motion.approach_s must be > 0; got -0.1",
    ),
    "bad name": (
        'name = "My Lab"\n' + GOOD.replace('name = "bench"\n', ""),
        "exp.toml: name must hold only lower-case letters",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_every_bad_input_is_one_line_naming_file_entry_and_rule(tmp_path, case):
    text, expected = BAD[case]
    with pytest.raises(ValueError) as exc:
        load_experiment(write(tmp_path, text))
    message = str(exc.value)
    assert "\n" not in message
    assert message.startswith(f"{tmp_path / 'exp.toml'}: ")
    assert expected.replace("exp.toml", str(tmp_path / "exp.toml")) in message, message


def _open_dxf(path: Path) -> None:
    import ezdxf

    doc = ezdxf.new()
    doc.units = ezdxf.units.MM
    doc.modelspace().add_lwpolyline([(0, 0), (16, 0), (16, 10), (0, 9)])  # ends 9 mm apart
    doc.saveas(path)


@pytest.mark.parametrize(
    "case",
    [
        "open outline",
        "self-intersecting outline",
        "larger than the plate",
        "unknown material field",
        "negative roughness",
        "material listed twice (a duplicate class name)",
        "specimen twice (a duplicate class name)",
        "unknown top-level key",
    ],
)
def test_generate_refuses_bad_experiments_and_writes_nothing(tmp_path, capsys, case):
    if case == "open outline":
        _open_dxf(tmp_path / "open.dxf")
        text = GOOD + '\n[[specimen]]\nname = "hook"\ndxf = "open.dxf"\n'
        expected = "specimen 'hook': the outline in the DXF file"
        rule = "is open: its ends are 9 mm apart"
    else:
        text, expected = BAD[case]
        expected, rule = expected.replace("exp.toml: ", ""), ""
    exp = write(tmp_path, text)
    out = tmp_path / "new" / "data"
    rc = main(["generate", "--experiment", str(exp), "--out", str(out)])
    err = capsys.readouterr().err.strip()
    assert rc == 2
    assert len(err.splitlines()) == 1
    assert err.startswith(f"tactile-synth generate: error: {exp}: ")
    assert expected in err and rule in err, err
    assert not (tmp_path / "new").exists()  # nothing written, no directory made


# -- grids with their own classes -----------------------------------------------------------
def test_class_keys_keep_the_paper_s_indices_and_give_others_fixed_32_bit_numbers():
    assert [class_key(c) for c in CLASS_NAMES] == list(range(36))
    for name in ("gear/cork", "circle/glass", "l_bracket/pla_top"):
        key = class_key(name)
        assert key == zlib.crc32(name.encode()) | 0x80000000
        assert 2**31 <= key < 2**32


def test_plan_labels_index_the_grid_s_classes_and_seeds_follow_the_class_keys(tmp_path):
    grid = load_experiment(write(tmp_path))
    trials = plan(grid)
    assert trials.classes == grid.classes
    assert np.array_equal(np.unique(trials.label), np.arange(len(grid.classes)))
    for i in (0, 5, 17, 35):
        name = grid.classes[trials.label[i]]
        want = trial_seed(0, class_key(name), trials.force_n[i], trials.speed_mm_s[i], 0)
        if trials.trial_index[i] == 0:
            assert trials.seed[i] == want
    specs = trials.specs(0, 3)
    assert [f"{s.shape}/{s.material}" for s in specs] == [grid.classes[0]] * 3
    # A paper class has the same seeds in a grid of its own as in the paper preset.
    paper = plan(PRESETS["paper"])
    sub = plan(PRESETS["paper"].replace(shapes=("square",), materials=("wood",)))
    row = CLASS_NAMES.index("square/wood") * 60
    assert np.array_equal(sub.seed, paper.seed[row : row + 60])
    assert sub.classes == ("square/wood",) and not sub.label.any()


def test_a_grid_names_only_its_simulator_s_specimens_and_materials():
    with pytest.raises(ValueError, match=r"shapes must be one of .*; got 'gear'"):
        GenerationConfig(shapes=("gear",))
    with pytest.raises(ValueError, match="materials must be one of resin, wood, aluminum"):
        GenerationConfig(materials=("glass",))
    synth = SynthConfig(materials={"glass": library()["glass"]}).to_dict()
    grid = GenerationConfig(materials=("glass",), synth=synth)
    assert grid.classes[:2] == ("circle/glass", "ellipse/glass")


def test_synth_config_holds_any_materials_and_specimens_and_round_trips():
    gear = shapes.Specimen.from_outline(
        "wedge", [(-8e-3, -5e-3), (8e-3, -5e-3), (0.0, 5e-3)], height_m=2.5e-3
    )
    config = SynthConfig(materials={"glass": library()["glass"]}, specimens={"wedge": gear})
    record = json.loads(json.dumps(config.to_dict()))
    assert list(record["specimens"]) == ["wedge"]
    assert SynthConfig.from_dict(record) == config
    assert config.specimen("wedge") is gear and config.specimen("moon") == "moon"
    assert "specimens" not in SynthConfig().to_dict()  # the paper's layout is unchanged
    with pytest.raises(ValueError, match="shape 'gear' is neither a built-in shape nor"):
        config.specimen("gear")
    with pytest.raises(ValueError, match="material 'wood' is not a material of the config"):
        config.material("wood")
    with pytest.raises(ValueError, match="at least one material"):
        SynthConfig(materials={})
    with pytest.raises(ValueError, match=r"SynthConfig.materials\['x'\] must be a Material"):
        SynthConfig(materials={"x": MATERIALS["wood"]})


def test_the_simulator_resolves_names_and_refuses_unknown_ones():
    from synth import simulator

    with pytest.raises(ValueError, match="shape 'gear' is neither a built-in shape nor a spec"):
        simulator.plan(TrialSpec("gear", "wood"), SynthConfig())
    with pytest.raises(ValueError, match="material 'cork' is not a material of the config"):
        simulator.plan(TrialSpec("circle", "cork"), SynthConfig())


def test_a_longer_or_higher_specimen_gets_the_steps_its_crossing_needs():
    from synth.simulator import n_steps, touch_distance_m

    config = SynthConfig()
    long = shapes.Specimen.from_outline(
        "long", [(-9.5e-3, -4e-3), (9.5e-3, -4e-3), (9.5e-3, 4e-3), (-9.5e-3, 4e-3)]
    )
    short = shapes.Specimen.from_outline(
        "short", [(-6e-3, -4e-3), (6e-3, -4e-3), (6e-3, 4e-3), (-6e-3, 4e-3)]
    )
    base = n_steps(config, 10.0, 1.0)
    assert n_steps(config, 10.0, 1.0, "moon") == base == n_steps(config, 10.0, 1.0, short)
    assert n_steps(config, 10.0, 1.0, long) > base
    assert touch_distance_m(config, 1.0, 3e-3) > touch_distance_m(config, 1.0)


def test_resume_and_from_config_need_no_experiment_file(tmp_path):
    # The stored configuration holds the specimens' vertices: a copy of the experiment's
    # grid rebuilt from the store alone equals the one loaded from the file.
    exp_dir = tmp_path / "lab"
    shutil.copytree(EXAMPLE.parent, exp_dir)
    grid = load_experiment(exp_dir / "experiment.toml").replace(
        shapes=("gear", "circle"), materials=("pla_top",), trials_per_class=1
    )
    out = tmp_path / "ds"
    store.create(out, grid.replace(synth=grid.synth))
    shutil.rmtree(exp_dir)
    assert store.stored_config(out) == grid
    meta = store.read_meta(out)
    assert meta["classes"] == ["circle/pla_top", "gear/pla_top"]


def test_resume_names_what_changed_in_the_experiment_by_its_path(tmp_path):
    from synth import generation

    grid = load_experiment(EXAMPLE).replace(shapes=("gear",), trials_per_class=1)
    out = tmp_path / "ds"
    store.create(out, grid)
    changed = EXAMPLE.read_text().replace("roughness_rms_m = 1.5e-6", "roughness_rms_m = 2e-6")
    lab = tmp_path / "lab"
    shutil.copytree(EXAMPLE.parent, lab)
    (lab / "experiment.toml").write_text(changed)
    edited = load_experiment(lab / "experiment.toml").replace(shapes=("gear",), trials_per_class=1)
    with pytest.raises(store.DatasetError) as exc:
        generation.prepare(edited, out, resume=True)
    message = str(exc.value)
    assert "synth.materials.pla_top.texture.roughness_rms_m=1.5e-06 there, 2e-06 here" in message
    assert len(message) < 400 and "\n" not in message
    assert generation.prepare(grid, out, resume=True).todo == [0]  # the same file resumes


def test_run_simulates_the_perturbation_grid_for_the_nominal_dataset_s_own_classes(tmp_path):
    from benchmark.plan import perturbation_for, run_plan

    base = run_plan(True).perturbation
    grid = load_experiment(EXAMPLE).replace(shapes=("gear", "moon"), trials_per_class=2)
    store.create(tmp_path / "lab", grid)
    pert = perturbation_for(tmp_path / "lab", base)
    assert pert.classes == grid.classes and pert.synth == grid.synth
    assert (pert.conditions, pert.trials_per_class) == (base.conditions, base.trials_per_class)
    # The paper preset's store gives the perturbation preset itself (its settings resolved).
    paper = PRESETS["paper"].replace(synth=SynthConfig().to_dict())
    store.create(tmp_path / "paper", paper)
    full = run_plan(False).perturbation
    assert perturbation_for(tmp_path / "paper", full) == full.replace(synth=paper.synth)


def test_an_imported_store_of_unknown_specimens_needs_its_perturbation_dataset_given(tmp_path):
    from benchmark.plan import perturbation_for, run_plan
    from synth.grid import TrialPlan

    trials = TrialPlan(
        label=np.zeros(2, np.int16),
        condition=np.zeros(2, np.int16),
        trial_index=np.arange(2, dtype=np.int32),
        force_n=np.ones(2),
        speed_mm_s=np.full(2, 10.0),
        seed=np.zeros(2, np.int64),
        classes=("gear/cork",),
    )
    path = tmp_path / "imported"
    store.create_imported(path, trials, [(1.0, 10.0)], 2)
    store.finish_imported(path, np.arange(2), {"recordings": "r"})
    with pytest.raises(ValueError, match=r"holds imported recordings of gear, cork.*--perturbed"):
        perturbation_for(path, run_plan(True).perturbation)


def test_the_report_names_the_dataset_s_classes():
    from synthetic_data import make_dataset

    from benchmark.report import class_grid, classes_section, generalisation_titles

    data = make_dataset(trials_per_class=2, shapes=("moon", "square"), materials=("wood",))
    lines = classes_section({"classes": class_grid(data)})
    assert "| specimen | wood |" in lines and "| moon | 2 |" in lines
    titles = generalisation_titles([], {"cross_shape_folds": [["a", "b"], ["c"]]})
    assert titles["cross-shape"] == "### Cross-shape (2 fixed folds of 1-2 unseen shapes)"
    paper = generalisation_titles([], {"cross_shape_folds": [["a"] * 4] * 3})
    assert paper["cross-shape"] == "### Cross-shape (3 fixed folds of 4 unseen shapes)"


def test_a_higher_specimen_may_lose_contact_longer_where_it_runs_off_its_wall():
    from synth.simulator import MAX_CONTACT_GAP_S, contact_gap_limit_s

    config = SynthConfig()
    assert contact_gap_limit_s(config, 0.6, 2e-3) == MAX_CONTACT_GAP_S  # the built-ins'
    assert contact_gap_limit_s(config, 0.6, 1e-3) == MAX_CONTACT_GAP_S
    # 0.5 mm more at 0.6 N: the loop's fastest descent, gain x force, takes 35 ms more.
    assert contact_gap_limit_s(config, 0.6, 2.5e-3) == pytest.approx(0.0856, abs=5e-4)
    assert contact_gap_limit_s(config, 1.4, 2.5e-3) < contact_gap_limit_s(config, 0.6, 2.5e-3)
