"""The calibration: scripts/calibrate.py's command line (argument checks, each subcommand
run end to end) and the computations it calls in synth.calibration and
benchmark.calibration (the sweep's bookkeeping, the settings and what-ifs);
`test_calibrate_measures.py` holds the measurements (shares, scatters, scales)."""

from __future__ import annotations

import dataclasses
import json
import math
import re

import numpy as np
import pytest

import benchmark.calibration as measure
import synth
from benchmark.twin import cli as twin_cli
from synth import contact, sensors
from synth.calibration import gain, settings, sweep, update
from synth.calibration.settings import CalibrationError
from tests.support import load_script


@pytest.fixture(autouse=True)
def _gain_rule_without_simulation(monkeypatch):
    """The sweep and whatif size each configuration's post-gain by simulating the grid's
    corner; here they get the defaults' gain without it (the rule itself is measured by
    the gain command's test, the sizing per candidate by a test that fakes it)."""
    default = synth.SynthConfig().pvdf.post_gain

    def at_default(config):
        return dataclasses.replace(config, pvdf=dataclasses.replace(config.pvdf, post_gain=default))

    monkeypatch.setattr(gain, "at_sized_gain", at_default)


def test_sweep_refuses_an_unknown_parameter_by_name():
    with pytest.raises(SystemExit, match="--only must name a swept parameter"):
        twin_cli.main(["--sweep", "--only", "finger.no_such_field"])


def test_sweep_refuses_fewer_than_one_seed_by_name():
    with pytest.raises(SystemExit, match="--seeds must be at least 1"):
        twin_cli.main(["--sweep", "--seeds", "0"])


@pytest.mark.parametrize(
    ("item", "message"),
    [
        ("motion.servo_damping_n_s_m=65", "--base must be SECTION.FIELD=VALUE"),
        ("variability.friction_rel", "--base must be SECTION.FIELD=VALUE"),
        ("variability.friction_rel=high", "--base variability.friction_rel needs a number"),
        ("variability.friction_rel=0_05", "--base variability.friction_rel needs a number"),
        ("variability.friction_rel=0.3", "must lie in its cited range 0.039..0.15"),
        ("variability.yaw_rad=-0.001", "must lie in its cited range 0..0.02"),
    ],
)
def test_sweep_refuses_a_base_value_outside_a_swept_parameters_range(item, message, monkeypatch):
    # A value the sweep accepts would start measuring: fail at once instead of simulating.
    monkeypatch.setattr(measure, "evaluate", lambda *a, **k: pytest.fail(f"{item} was swept"))
    with pytest.raises(SystemExit, match=re.escape(message)):
        twin_cli.main(["--sweep", "--base", item])


def test_base_values_set_the_configuration_the_others_are_swept_around():
    got = settings.parse_base(["variability.yaw_rad=0.01", "materials.texture_scale=0.5"])
    assert got == {("variability", "yaw_rad"): 0.01, ("materials", "texture_scale"): 0.5}
    with pytest.raises(CalibrationError, match=re.escape("sets variability.yaw_rad twice")):
        settings.parse_base(["variability.yaw_rad=0.01", "variability.yaw_rad=0.02"])


def test_a_held_parameter_is_set_in_every_candidate_and_not_swept(tmp_path, monkeypatch):
    seen = []

    def evaluate(config, trials_per_class, where, seed):
        seen.append((config.variability.friction_rel, config.variability.yaw_rad, seed))
        return {
            "class_all": 0.5,
            "pvdf_share_cross_shape": 0.5,
            "pvdf_share_cross_material": 0.5,
            "pvdf_share_paper_d_cross_shape": 0.5,
            "pvdf_share_paper_d_cross_material": 0.5,
        }

    monkeypatch.setattr(measure, "evaluate", evaluate)
    argv = ["--sweep", "--base", "variability.friction_rel=0.05", "--out", str(tmp_path)]
    argv += ["--only", "variability.friction_rel", "--only", "variability.yaw_rad"]
    assert twin_cli.main(argv) == 0
    rows = json.loads((tmp_path / "calibration.json").read_text())
    assert [r["parameter"] for r in rows] == ["variability.yaw_rad"] * 4
    assert [r["default"] for r in rows] == [False, True, False, False]
    assert sorted({(f, y) for f, y, _ in seen}) == [
        (0.05, 0.0),
        (0.05, 0.005),
        (0.05, 0.01),
        (0.05, 0.02),
    ]


def test_set_moves_the_configuration_the_sweep_starts_from(tmp_path, monkeypatch):
    seen = []

    def evaluate(config, trials_per_class, where, seed):
        seen.append((config.pvdf.post_gain, config.variability.yaw_rad))
        return _fake_metrics(config)

    monkeypatch.setattr(measure, "evaluate", evaluate)
    argv = ["--sweep", "--set", "pvdf.post_gain=2", "--set", "variability.yaw_rad=0.01"]
    argv += ["--only", "variability.yaw_rad", "--out", str(tmp_path)]
    assert twin_cli.main(argv) == 0
    rows = json.loads((tmp_path / "calibration.json").read_text())
    assert [r["default"] for r in rows] == [False, False, True, False]
    assert sorted(set(seen)) == [(2.0, 0.0), (2.0, 0.005), (2.0, 0.01), (2.0, 0.02)]
    with pytest.raises(SystemExit, match=r"^--set must be SECTION.FIELD=VALUE"):
        twin_cli.main(["--sweep", "--set", "pvdf.no_such_field=1"])


def _fake_metrics(config) -> dict:
    yaw = config.variability.yaw_rad
    return {
        "class_all": 0.5 + yaw,
        "pvdf_share_cross_shape": 0.5,
        "pvdf_share_cross_material": 0.5 - yaw,
        "pvdf_share_paper_d_cross_shape": 0.5,
        "pvdf_share_paper_d_cross_material": 0.5,
    }


def test_an_interrupted_sweep_keeps_its_rows_and_resumes_where_it_stopped(tmp_path, monkeypatch):
    calls = []

    def evaluate(config, trials_per_class, where, seed):
        if len(calls) == 2:
            raise KeyboardInterrupt
        calls.append(config.variability.yaw_rad)
        return _fake_metrics(config)

    monkeypatch.setattr(measure, "evaluate", evaluate)
    argv = ["--sweep", "--only", "variability.yaw_rad", "--out", str(tmp_path)]
    with pytest.raises(SystemExit, match=r"sweep interrupted; 2 rows are in .*--resume"):
        twin_cli.main(argv)
    rows = json.loads((tmp_path / "calibration.json").read_text())
    assert [r["value"] for r in rows] == [0.0, 0.005]
    assert len((tmp_path / "calibration.md").read_text().splitlines()) == 2 + 2

    def resumed(config, trials_per_class, where, seed):
        calls.append(config.variability.yaw_rad)
        return _fake_metrics(config)

    monkeypatch.setattr(measure, "evaluate", resumed)
    assert twin_cli.main([*argv, "--resume"]) == 0
    assert calls == [0.0, 0.005, 0.01, 0.02]  # the first two were not measured again
    rows = json.loads((tmp_path / "calibration.json").read_text())
    assert [r["value"] for r in rows] == [0.0, 0.005, 0.01, 0.02]
    assert [r["pvdf_share_gap"] for r in rows] == pytest.approx([0.0, 0.005, 0.01, 0.02])
    # other trials per class: nothing is reused
    assert twin_cli.main([*argv, "--resume", "--trials-per-class", "5"]) == 0
    assert calls[4:] == [0.0, 0.005, 0.01, 0.02]
    # other tuned hyper-parameters (AFOP-ML's selection measures with them): nothing either
    import models.tuned

    values = models.tuned.tuned_values()
    retuned = {**values, "AFOP-ML": {**values["AFOP-ML"], "ncfs_max_iter": 7}}
    monkeypatch.setattr(models.tuned, "tuned_values", lambda *a: retuned)
    assert twin_cli.main([*argv, "--resume", "--trials-per-class", "5"]) == 0
    assert calls[8:] == [0.0, 0.005, 0.01, 0.02]


def test_a_resumed_sweep_of_one_parameter_keeps_the_table_of_the_others(tmp_path, monkeypatch):
    """``--resume --only`` adds a parameter's rows to a table swept from the same base, in
    the sweep's order, and measures nothing already there; a table swept from another
    base keeps none of its other rows (they would describe that base)."""
    calls = []

    def evaluate(config, trials_per_class, where, seed):
        calls.append((config.variability.yaw_rad, config.variability.friction_rel))
        return _fake_metrics(config)

    monkeypatch.setattr(measure, "evaluate", evaluate)
    out = ["--out", str(tmp_path)]
    assert twin_cli.main(["--sweep", "--only", "variability.friction_rel", *out]) == 0
    assert twin_cli.main(["--sweep", "--only", "variability.yaw_rad", *out, "--resume"]) == 0
    rows = json.loads((tmp_path / "calibration.json").read_text())
    assert [r["parameter"] for r in rows] == ["variability.yaw_rad"] * 4 + [
        "variability.friction_rel"
    ] * 5
    assert len(calls) == 5 + 3  # yaw's default row is friction's, measured once
    table = (tmp_path / "calibration.md").read_text().splitlines()
    assert len(table) == 2 + 9 and table[6].startswith("| variability.friction_rel | 0.039 (")
    # interrupted, it says how many rows the table holds, the kept ones with its own

    def interrupted(config, trials_per_class, where, seed):
        raise KeyboardInterrupt

    monkeypatch.setattr(measure, "evaluate", interrupted)
    with pytest.raises(SystemExit, match=r"sweep interrupted; 9 rows are in .*--resume"):
        twin_cli.main(["--sweep", "--only", "variability.force_rel", *out, "--resume"])
    assert len(json.loads((tmp_path / "calibration.json").read_text())) == 9
    monkeypatch.setattr(measure, "evaluate", evaluate)
    # from another base, the friction rows are not this table's
    argv = ["--sweep", "--only", "variability.yaw_rad", *out, "--resume"]
    assert twin_cli.main([*argv, "--set", "variability.force_rel=0.1"]) == 0
    rows = json.loads((tmp_path / "calibration.json").read_text())
    assert [r["parameter"] for r in rows] == ["variability.yaw_rad"] * 4
    assert len(calls) == 8 + 4


def test_a_candidate_that_cannot_be_simulated_is_reported_and_the_sweep_goes_on(
    tmp_path, monkeypatch
):
    calls = []

    def evaluate(config, trials_per_class, where, seed):
        calls.append(config.variability.yaw_rad)
        if config.variability.yaw_rad == 0.01:
            raise synth.SimulationError("MuJoCo warning mjWARN_BADQACC while simulating x")
        return _fake_metrics(config)

    monkeypatch.setattr(measure, "evaluate", evaluate)
    argv = ["--sweep", "--only", "variability.yaw_rad", "--out", str(tmp_path)]
    assert twin_cli.main(argv) == 0
    rows = json.loads((tmp_path / "calibration.json").read_text())
    assert [r["value"] for r in rows] == [0.0, 0.005, 0.01, 0.02]
    assert rows[2]["failed"] == "MuJoCo warning mjWARN_BADQACC while simulating x"
    assert "class_all" not in rows[2] and rows[3]["class_all"] == pytest.approx(0.52)
    table = (tmp_path / "calibration.md").read_text().splitlines()
    assert table[4].startswith("| variability.yaw_rad | 0.01 | 1 | not measured: MuJoCo warning")
    assert table[4].count("|") == table[0].count("|")
    # resumed, the failed candidate is not simulated again (it would fail bit for bit)
    assert twin_cli.main([*argv, "--resume"]) == 0
    assert calls == [0.0, 0.005, 0.01, 0.02]
    assert json.loads((tmp_path / "calibration.json").read_text()) == rows
    # whatif, which measures one configuration, stops with one line naming the trial
    with pytest.raises(SystemExit, match=r"^calibrate --whatif: MuJoCo warning mjWARN_BADQACC"):
        twin_cli.main(["--whatif", "--set", "variability.yaw_rad=0.01"])


def test_each_candidate_is_measured_at_the_post_gain_its_own_films_size(tmp_path, monkeypatch):
    """A readout with smaller transients gets a larger gain, one whose transients no gain
    fits is reported unmeasured; ``--set pvdf.post_gain`` holds the gain for all; whatif
    sizes its configuration's gain alike and says so."""
    sized, seen = [], []
    per_ohm = {1e9: 0.5, 100e6: 1.0, 10e6: 2.0}

    def sized_gain(config):
        sized.append(config.pvdf.feedback_resistance_ohm)
        if config.pvdf.feedback_resistance_ohm not in per_ohm:
            raise CalibrationError("no post-gain from 0.1 up keeps the worst PVDF transient")
        return 1.0, per_ohm[config.pvdf.feedback_resistance_ohm]

    def evaluate(config, trials_per_class, where, seed):
        seen.append((config.pvdf.feedback_resistance_ohm, config.pvdf.post_gain))
        return _fake_metrics(config)

    monkeypatch.undo()  # the real rule, over a faked sizing
    monkeypatch.setattr(gain, "sized_gain", sized_gain)
    monkeypatch.setattr(measure, "evaluate", evaluate)
    argv = ["--sweep", "--only", "pvdf.feedback_resistance_ohm", "--out", str(tmp_path)]
    assert twin_cli.main(argv) == 0
    rows = json.loads((tmp_path / "calibration.json").read_text())
    assert [(r["value"], r.get("post_gain")) for r in rows] == [
        (1e9, 0.5),
        (100e6, 1.0),
        (10e6, 2.0),
        (1.8e6, None),
    ]
    assert seen == [(1e9, 0.5), (100e6, 1.0), (10e6, 2.0)]
    assert rows[3]["failed"].startswith("no post-gain could be sized for it: no post-gain from")
    table = (tmp_path / "calibration.md").read_text().splitlines()
    assert table[0].startswith("| parameter | value | post-gain | class_all |")
    assert table[4].startswith("| pvdf.feedback_resistance_ohm | 1e+07 | 2 | 0.505 |")
    assert table[5].startswith("| pvdf.feedback_resistance_ohm | 1.8e+06 |  | not measured: no")
    # resumed: every candidate is sized again (cheap), none measured again
    assert twin_cli.main([*argv, "--resume"]) == 0
    assert len(seen) == 3 and len(sized) == 8
    # held: every candidate at the gain --set gives, nothing sized
    seen.clear()
    assert twin_cli.main([*argv, "--set", "pvdf.post_gain=2"]) == 0
    assert {g for _, g in seen} == {2.0} and len(seen) == 4 and len(sized) == 8
    assert twin_cli.main(["--whatif", "--set", "pvdf.feedback_resistance_ohm=1e9"]) == 0
    assert seen[-1] == (1e9, 0.5)
    with pytest.raises(SystemExit, match=r"^no post-gain from 0.1 up keeps the worst PVDF"):
        twin_cli.main(["--whatif", "--set", "pvdf.feedback_resistance_ohm=1.8e6"])


def test_sweep_resume_refuses_without_out_and_a_foreign_table(tmp_path, monkeypatch):

    def evaluate(*args):
        raise AssertionError("a refused sweep measures nothing")

    monkeypatch.setattr(measure, "evaluate", evaluate)
    with pytest.raises(SystemExit, match=r"--resume needs --out DIR"):
        twin_cli.main(["--sweep", "--resume"])
    table = tmp_path / "calibration.json"
    table.write_text('{"rows": 1}')
    with pytest.raises(SystemExit, match=rf"^--out {table} is a file; choose a directory"):
        twin_cli.main(["--sweep", "--out", str(table)])
    with pytest.raises(SystemExit, match=r"^--resume: .*calibration.json is not a sweep table"):
        twin_cli.main(["--sweep", "--out", str(tmp_path), "--resume"])


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--set", "pvdf.no_such_field=1"], "--set must be SECTION.FIELD=VALUE"),
        (["--set", "materials.resin=1"], "--set must be SECTION.FIELD=VALUE"),
        (["--set", "pvdf.post_gain"], "--set must be SECTION.FIELD=VALUE"),
        (["--set", "finger.skin_solref=1"], "--set must be SECTION.FIELD=VALUE"),
        (["--set", "pvdf.post_gain=loud"], "--set pvdf.post_gain needs a finite number"),
        (["--set", "pvdf.post_gain=nan"], "--set pvdf.post_gain needs a finite number"),
        (["--set", "pvdf.post_gain=1_0"], "--set pvdf.post_gain needs a finite number"),
        (["--set", "acquisition.adc_bits=12.5"], "acquisition.adc_bits needs a whole number"),
        (["--set", "pvdf.post_gain=2", "--set", "pvdf.post_gain=3"], "sets pvdf.post_gain twice"),
        (["--set", "pvdf.post_gain=-1"], "--set pvdf.post_gain=-1: PVDF.post_gain must be > 0"),
        (["--set", "materials.oak.kinetic_friction=1"], "MATERIAL one of resin, wood, aluminum"),
        (["--set", "materials.wood.friction=1"], "--set must be SECTION.FIELD=VALUE"),
        (
            ["--set", "materials.wood.kinetic_friction=-1"],
            "--set materials.wood.kinetic_friction=-1: FrictionLaw.kinetic must be > 0",
        ),
        (
            [
                "--set",
                "materials.wood.kinetic_friction=1",
                "--set",
                "materials.wood.kinetic_friction=2",
            ],
            "sets materials.wood.kinetic_friction twice",
        ),
    ],
)
def test_whatif_refuses_a_bad_setting_in_one_line(argv, message):
    with pytest.raises(SystemExit, match=re.escape(message)):
        twin_cli.main(["--whatif", *argv])


def test_set_gives_one_material_a_friction_level_of_its_own():
    """``materials.MATERIAL.kinetic_friction`` moves that material's law alone, its static
    coefficient in the same ratio, and the others keep the shared law."""
    base = synth.SynthConfig()
    config = settings.configured(
        ["materials.wood.kinetic_friction=0.9", "materials.aluminum.kinetic_friction=1.4"]
    )
    shared = base.materials["resin"].friction
    assert config.materials["resin"].friction == shared
    for name, mu in (("wood", 0.9), ("aluminum", 1.4)):
        law = config.materials[name].friction
        assert law.kinetic == mu
        assert law.static / law.kinetic == pytest.approx(shared.static / shared.kinetic)
        assert law.load_exponent == shared.load_exponent
        assert config.materials[name].texture == base.materials[name].texture
    assert settings.default_value(config, "materials", "wood.kinetic_friction") == 0.9


def test_set_gives_one_material_a_surface_of_its_own_and_the_sweep_spans_them(tmp_path):
    """``materials.MATERIAL.roughness_rms_m`` / ``.correlation_length_m`` /
    ``.mark_amplitude_m`` move that material's surface alone (the mark's wavelength and the
    friction kept); the sweep spans each material's measured range or free choice, its
    default inside; a material with other than one mark is refused by name."""
    base = synth.SynthConfig()
    config = settings.configured(
        [
            "materials.resin.correlation_length_m=20e-6",
            "materials.resin.mark_amplitude_m=2e-6",
            "materials.wood.roughness_rms_m=1e-5",
        ]
    )
    resin, wood = config.materials["resin"], config.materials["wood"]
    assert resin.texture.correlation_length_m == 20e-6
    assert resin.texture.roughness_rms_m == base.materials["resin"].texture.roughness_rms_m
    (mark,) = resin.texture.periodic
    assert mark.amplitude_m == 2e-6
    assert mark.wavelength_m == base.materials["resin"].texture.periodic[0].wavelength_m
    assert wood.texture.roughness_rms_m == 1e-5
    assert wood.texture.periodic == base.materials["wood"].texture.periodic
    assert config.materials["aluminum"] == base.materials["aluminum"]
    assert resin.friction == base.materials["resin"].friction
    assert settings.default_value(config, "materials", "resin.mark_amplitude_m") == 2e-6
    swept = {f"{s}.{f}": values for s, f, values, _ in settings.SWEEP}
    for name in ("resin", "wood"):
        for field in settings.TEXTURE_FIELDS:
            values = swept[f"materials.{name}.{field}"]
            default = settings.default_value(base, "materials", f"{name}.{field}")
            assert min(values) < default < max(values) and default in values
    rows = list(sweep.candidates(base, ["materials.wood.mark_amplitude_m"]))
    assert [(v, d) for _, _, v, _, d, _ in rows] == [(2e-6, False), (4e-6, True), (6e-6, False)]
    assert rows[2][5].materials["wood"].texture.periodic[0].amplitude_m == 6e-6
    bare = dataclasses.replace(
        base.materials["resin"], texture=dataclasses.replace(resin.texture, periodic=())
    )
    with pytest.raises(CalibrationError, match=r"^materials.resin.mark_amplitude_m: resin has 0"):
        settings.with_value(base.with_material(bare), "materials", "resin.mark_amplitude_m", 1e-6)
    with pytest.raises(CalibrationError, match=r"^--set must be SECTION.FIELD=VALUE .* FIELD one"):
        settings.parse_set(["materials.resin.wavelength_m=1e-4"])
    with pytest.raises(CalibrationError, match=r"^--set materials.wood.correlation_length_m=-1: "):
        settings.configured(["materials.wood.correlation_length_m=-1"])


def test_set_gives_every_material_one_stribeck_velocity_and_the_law_follows_it():
    """``materials.stribeck_velocity_m_s`` sets every material's, the rest of each law
    kept; the coefficient at a slip of that speed sits where the law puts it
    (``kinetic + (static - kinetic) / e``), and the sweep moves it around the default."""
    base = synth.SynthConfig()
    config = settings.configured(["materials.stribeck_velocity_m_s=3e-3"])
    for name, material in config.materials.items():
        law, old = material.friction, base.materials[name].friction
        assert law == dataclasses.replace(old, stribeck_velocity_m_s=3e-3)
        mu = contact.friction_coefficient(law, 3e-3, 1.0)
        assert mu == pytest.approx(law.kinetic + (law.static - law.kinetic) / math.e)
    assert settings.default_value(config, "materials", "stribeck_velocity_m_s") == 3e-3
    rows = list(sweep.candidates(base, ["materials.stribeck_velocity_m_s"]))
    assert [(v, d) for _, _, v, _, d, _ in rows] == [(0.3e-3, False), (1e-3, True), (3e-3, False)]
    with pytest.raises(CalibrationError, match=r"^--set materials.stribeck_velocity_m_s=0: "):
        settings.configured(["materials.stribeck_velocity_m_s=0"])


def test_set_moves_one_gauge_and_the_sweep_spans_both_heights():
    """``finger.gauge_heights_m.I`` sets gauge I's height alone, the sweep's candidates
    move each gauge around its default, and a height the finger refuses or an index it
    has not is refused by name."""
    base = synth.SynthConfig()
    config = settings.configured(["finger.gauge_heights_m.1=0.024"])
    assert config.finger.gauge_heights_m == (base.finger.gauge_heights_m[0], 0.024)
    assert settings.default_value(config, "finger", "gauge_heights_m.1") == 0.024
    rows = list(sweep.candidates(base, ["finger.gauge_heights_m.0"]))
    assert [(v, d) for _, _, v, _, d, _ in rows] == [(0.008, False), (0.012, True), (0.016, False)]
    assert rows[0][5].finger.gauge_heights_m == (0.008, base.finger.gauge_heights_m[1])
    # the gauge's reading follows its height: the moment at it is the torque minus H x Fx
    mech = sensors.Mechanics(
        mount_force=np.array([[[1.0, 0.0, 0.0]]]),
        mount_torque=np.zeros((1, 1, 3)),
        contact_ahead_m=np.zeros((1, 1)),
        indentation_m=np.zeros((1, 1)),
        traction_n=np.zeros((1, 1)),
    )
    low, high = (sensors.gauge_strains(mech, r[5].finger, base.strain_gauge) for r in rows[::2])
    assert high[0, 0, 0] / low[0, 0, 0] == pytest.approx(2.0)
    for item in ("finger.gauge_heights_m.2=0.01", "finger.gauge_heights_m=0.01"):
        with pytest.raises(CalibrationError, match=r"^--set must be SECTION.FIELD=VALUE .*gauge"):
            settings.configured([item])
    with pytest.raises(CalibrationError, match=r"^--set finger.gauge_heights_m.0=-1: Finger.gauge"):
        settings.configured(["finger.gauge_heights_m.0=-1"])


@pytest.mark.slow
def test_setting_the_skins_modulus_or_the_pads_radius_refits_its_contact_to_hertz():
    """``--set finger.skin_modulus_pa`` / ``finger.pad_radius_m`` refit the skin's MuJoCo
    contact, so that the simulated indentation follows the new skin's Hertz law as the
    default's does; the default skin's contact would not (a skin 2.9 times softer sinks
    twice as deep). The sweep moves both around their defaults, and the default value
    gives the default configuration (no refit)."""
    from synth.skin_fit import measure_indentation

    base = synth.SynthConfig()
    forces = (0.6, 1.0, 1.4)
    for item in ("finger.skin_modulus_pa=0.1e6", "finger.pad_radius_m=0.006"):
        config = settings.configured([item])
        f = config.finger
        hertz = contact.hertz_indentation_m(
            np.array(forces), f.pad_radius_m, f.skin_modulus_pa, f.skin_poisson
        )
        np.testing.assert_allclose(measure_indentation(config, forces), hertz, rtol=0.05)
        assert f.skin_solimp != base.finger.skin_solimp
    stale = dataclasses.replace(
        config,
        finger=dataclasses.replace(
            settings.configured(["finger.skin_modulus_pa=0.1e6"]).finger,
            skin_solref=base.finger.skin_solref,
            skin_solimp=base.finger.skin_solimp,
        ),
    )
    f = stale.finger
    hertz = contact.hertz_indentation_m(1.0, f.pad_radius_m, f.skin_modulus_pa, f.skin_poisson)
    assert measure_indentation(stale, (1.0,))[0] < 0.7 * hertz
    assert settings.configured(["finger.skin_modulus_pa=0.29e6"]) == base
    for name, values in (
        ("finger.skin_modulus_pa", (0.1e6, 0.29e6, 0.58e6)),
        ("finger.pad_radius_m", (0.006, 0.007, 0.008)),
    ):
        rows = list(sweep.candidates(base, [name]))
        got = [(v, d) for _, _, v, _, d, _ in rows]
        assert got == [(values[0], False), (values[1], True), (values[2], False)]
    with pytest.raises(CalibrationError, match=r"^--set finger.pad_radius_m=-0.007: Finger.pad"):
        settings.configured(["finger.pad_radius_m=-0.007"])


def test_fingerprint_gains_follow_the_ridges_places_and_widths(capsys):
    """The fingerprint passes a periodic mark by the ridges' phases and each ridge's width:
    a regular comb 4.5 feed periods apart cancels the 0.1 mm feed marks ridge against
    ridge, a ridge as wide as a mark's wavelength averages it away, and a mark much longer
    than the contact reaches every ridge in phase; the finger's own draw ranks among the
    others as its comb gain says. The command prints the table and refuses bad options."""
    from synth.calibration.finger import fingerprint_gains

    base = synth.SynthConfig()
    got = fingerprint_gains(base, 1.0, draws=50)
    assert got["ridges"] == 10
    feed = next(m for m in got["marks"] if m["material"] == "aluminum")
    assert feed["box"] == pytest.approx(np.sinc(1.5))  # 0.15 mm ridges on a 0.1 mm mark
    assert abs(feed["rounded"]) < abs(feed["box"])
    assert 0 < feed["comb"] < 1 and 0 <= feed["percentile"] <= 100
    assert 0 < feed["felt"] < feed["comb"]  # each ridge averages part of the mark away
    # Equal box ridges: the fingerprint passes the comb times the box's gain (sampled on
    # the grid: within 1 % of the continuous box's).
    box = dataclasses.replace(
        base.finger, ridge_profile_exponent=0.0, ridge_width_pressure_exponent=0.0
    )
    got = fingerprint_gains(dataclasses.replace(base, finger=box), 1.0, draws=5)
    feed = next(m for m in got["marks"] if m["material"] == "aluminum")
    assert feed["felt"] == pytest.approx(feed["comb"] * abs(feed["box"]), rel=0.01)
    regular = dataclasses.replace(box, ridge_jitter=0.0, ridge_width_m=0.1e-3)
    got = fingerprint_gains(dataclasses.replace(base, finger=regular), 1.0, draws=5)
    feed = next(m for m in got["marks"] if m["material"] == "aluminum")
    assert feed["comb"] < 1e-6 and abs(feed["box"]) < 1e-12 and feed["felt"] < 1e-6
    assert feed["comb_median"] == pytest.approx(feed["comb"], abs=1e-9)  # every draw alike
    long = dataclasses.replace(base.materials["wood"].texture.periodic[0], wavelength_m=1.0)
    wood = dataclasses.replace(
        base.materials["wood"],
        texture=dataclasses.replace(base.materials["wood"].texture, periodic=(long,)),
    )
    got = fingerprint_gains(base.with_material(wood), 1.0, draws=5)
    swell = next(m for m in got["marks"] if m["material"] == "wood")
    assert swell["comb"] > 0.999 and swell["box"] > 0.999
    calibrate = load_script("calibrate")
    assert calibrate.main(["fingerprint", "--draws", "20"]) == 0
    out = capsys.readouterr().out
    assert "10 ridges in a contact 4.79 mm across" in out and "aluminum" in out
    for argv, message in (
        (["fingerprint", "--draws", "0"], "--draws must be at least 1"),
        (["fingerprint", "--force-n", "0"], "--force-n must be a load above 0 N"),
    ):
        with pytest.raises(SystemExit):
            calibrate.main(argv)
        assert message in capsys.readouterr().err


@pytest.mark.slow
def test_gain_sizes_the_default_post_gain_and_any_configurations(monkeypatch, capsys):
    """The default post-gain is the one the script sizes; a film carrier that multiplies
    the bending charge by 4.8 (the 125 um laminate) gets a smaller one, rounded in the
    1-2-5 series (half: the shear coupling's charge does not grow with the carrier)."""
    calibrate = load_script("calibrate")
    assert calibrate.main(["gain"]) == 0
    default = synth.SynthConfig().pvdf.post_gain
    assert f"post_gain = {default:g} (" in capsys.readouterr().out
    assert calibrate.main(["gain", "--set", "pvdf.neutral_axis_offset_m=6.7e-5"]) == 0
    assert "post_gain = 0.5 (" in capsys.readouterr().out
    argv = ["gain", "--set", "pvdf.neutral_axis_offset_m=9e-4", "--set", "pvdf.d31_c_per_n=1e-9"]
    with pytest.raises(SystemExit, match=r"^the PVDF transients exceed \+-1000 V per unit"):
        calibrate.main(argv)
    # a readout whose corner lies in the texture band leaves smaller transients: a larger
    # gain, the one the sweep and whatif then measure that readout at
    readout = ["pvdf.feedback_resistance_ohm=1.8e6"]
    monkeypatch.undo()  # the real sizing
    config = gain.configured_at_own_gain(readout)
    assert config.pvdf.post_gain == 5.0 and config.pvdf.feedback_resistance_ohm == 1.8e6
    assert gain.configured_at_own_gain([*readout, "pvdf.post_gain=2"]).pvdf.post_gain == 2.0


def test_carrier_prints_each_films_settings_and_refuses_a_bad_thickness(monkeypatch, capsys):
    calibrate = load_script("calibrate")
    sized = []

    def sized_gain(config):
        sized.append(config.pvdf)
        return 1.0, 2.0

    monkeypatch.setattr(gain, "sized_gain", sized_gain)
    assert calibrate.main(["carrier", "--thickness-m", "50e-6"]) == 0
    out = capsys.readouterr().out
    offset, shear = sensors.film_on_carrier(
        sized[0], synth.SynthConfig().finger, 50e-6, gain.CARRIER_MODULUS_PA
    )
    assert (sized[0].neutral_axis_offset_m, sized[0].shear_strain_per_n) == (offset, shear)
    assert out.startswith("carrier 50 um: neutral_axis_offset_m 2.84e-05, shear_strain_per_n")
    assert f"--set pvdf.shear_strain_per_n={shear:.3g} --set pvdf.post_gain=2`" in out
    assert calibrate.main(["carrier"]) == 0
    assert len(capsys.readouterr().out.splitlines()) == len(gain.CARRIER_THICKNESSES_M)
    with pytest.raises(SystemExit, match=r"^--thickness-m 0: must be in \(0, 0.001\] m$"):
        calibrate.main(["carrier", "--thickness-m", "0"])


def test_marks_scale_scales_the_periodic_marks_and_keeps_the_roughness():
    base = synth.SynthConfig()
    ((key, value),) = settings.parse_set(["materials.marks_scale=0.25"]).items()
    scaled = settings.with_value(base, *key, value)
    for name, material in base.materials.items():
        texture = scaled.materials[name].texture
        assert texture.roughness_rms_m == material.texture.roughness_rms_m
        for mark, original in zip(texture.periodic, material.texture.periodic, strict=True):
            assert mark.amplitude_m == pytest.approx(0.25 * original.amplitude_m)
            assert mark.wavelength_m == original.wavelength_m
    assert settings.with_value(base, *key, 1.0).to_dict() == base.to_dict()


def test_whatif_refuses_a_configuration_the_adc_cannot_record_in_one_line():
    argv = ["--whatif", "--set", "pvdf.post_gain=500", "--trials-per-class", "2"]
    saturated = r"^--set pvdf.post_gain=500: ADC saturated .* while simulating shape='"
    with pytest.raises(SystemExit, match=saturated):
        twin_cli.main(argv)


def test_whatif_evaluates_the_set_configuration_over_every_seed(monkeypatch, capsys):
    seen, closed = [], []
    row = {
        "class_all": 0.5,
        "pvdf_share_cross_shape": 0.2,
        "pvdf_share_cross_material": 0.5,
        "pvdf_share_paper_d_cross_shape": 0.2,
        "pvdf_share_paper_d_cross_material": 0.5,
    }

    def evaluate(config, trials_per_class, where, seed):
        seen.append((config, trials_per_class, seed))
        return row

    def closed_set(config, episodes, where, dataset_seed=0):
        closed.append((config, episodes, dataset_seed))
        acc = 90.0 + 2.0 * dataset_seed
        return {"closed_set_1shot_5way": acc, "closed_set_d": 8, "tsne_dgi": 4.769}

    monkeypatch.setattr(measure, "evaluate", evaluate)
    monkeypatch.setattr(measure, "closed_set_row", closed_set)
    argv = ["--whatif", "--set", "pvdf.amplifier_noise_v_per_sqrt_hz=5.6e-4"]
    argv += ["--set", "acquisition.adc_bits=14", "--set", "materials.texture_scale=0.5"]
    argv += ["--set", "pvdf.post_gain=2"]
    assert twin_cli.main([*argv, "--seeds", "2", "--trials-per-class", "4"]) == 0
    assert [(t, s) for _, t, s in seen] == [(4, 0), (4, 1)]
    config = seen[0][0]
    assert config.pvdf.amplifier_noise_v_per_sqrt_hz == 5.6e-4
    assert config.acquisition.adc_bits == 14 and isinstance(config.acquisition.adc_bits, int)
    assert config.pvdf.post_gain == 2
    resin = synth.SynthConfig().materials["resin"].texture
    assert config.materials["resin"].texture.roughness_rms_m == resin.roughness_rms_m * 0.5
    assert not closed  # only with --closed-set
    out = capsys.readouterr().out
    assert "(PVDF post-gain 2, as set; amplifier noise 30.2 mV RMS at the DAQ)" in out
    assert "pvdf_share_gap -0.300" in out
    assert twin_cli.main([*argv, "--closed-set", "50"]) == 0
    assert [(e, s) for _, e, s in closed] == [(50, 0)]
    assert closed[0][0] == config
    assert "closed_set_1shot_5way 90.00, closed_set_d 8, tsne_dgi 4.769" in capsys.readouterr().out
    closed.clear()
    assert twin_cli.main([*argv, "--closed-set", "50", "--closed-set-seeds", "3"]) == 0
    assert [(e, s) for _, e, s in closed] == [(50, 0), (50, 1), (50, 2)]
    out = capsys.readouterr().out
    assert "dataset seed 2: closed_set_1shot_5way 94.00, closed_set_d 8" in out
    assert "mean +- sd over 3 dataset seeds: closed_set_1shot_5way 92.00 +- 2.00" in out
    assert "closed_set_d 8.0 +- 0.0, tsne_dgi 4.769 +- 0.000" in out


def test_whatif_keeps_the_dataset_of_seed_0_where_asked(tmp_path, monkeypatch, capsys):
    shares = ("cross_shape", "cross_material", "paper_d_cross_shape", "paper_d_cross_material")

    def evaluate(config, trials_per_class, where, seed):
        # Stands in for a generation into ``where`` (overwritten by each seed).
        where.mkdir(parents=True, exist_ok=True)
        (where / "seed").write_text(str(seed))
        return {"class_all": 0.5, **{f"pvdf_share_{k}": 0.3 for k in shares}}

    monkeypatch.setattr(measure, "evaluate", evaluate)
    keep = tmp_path / "kept"
    assert twin_cli.main(["--whatif", "--seeds", "3", "--keep", str(keep)]) == 0
    assert (keep / "seed").read_text() == "0"
    assert f"dataset of seed 0 kept in {keep}" in capsys.readouterr().out
    with pytest.raises(SystemExit, match=re.escape(f"--keep {keep} already exists")):
        twin_cli.main(["--whatif", "--keep", str(keep)])
    (tmp_path / "file").write_text("")
    with pytest.raises(SystemExit, match=re.escape(f"--keep {tmp_path / 'file'} is a file")):
        twin_cli.main(["--whatif", "--keep", str(tmp_path / "file")])


def test_whatif_without_a_setting_measures_the_defaults(monkeypatch, capsys):
    seen = []

    def evaluate(config, trials_per_class, where, seed):
        seen.append(config)
        shares = ("cross_shape", "cross_material", "paper_d_cross_shape", "paper_d_cross_material")
        return {"class_all": 0.5, **{f"pvdf_share_{k}": 0.3 for k in shares}}

    monkeypatch.setattr(measure, "evaluate", evaluate)
    assert twin_cli.main(["--whatif", "--trials-per-class", "4"]) == 0
    assert [c.to_dict() for c in seen] == [synth.SynthConfig().to_dict()]
    assert "what-if configuration: the defaults (" in capsys.readouterr().out
    with pytest.raises(SystemExit, match=r"^--closed-set-seeds must be at least 1"):
        twin_cli.main(["--whatif", "--closed-set", "5", "--closed-set-seeds", "0"])
    with pytest.raises(SystemExit, match=r"^--closed-set-seeds needs --closed-set EPISODES"):
        twin_cli.main(["--whatif", "--closed-set-seeds", "3"])
    assert len(seen) == 1  # refused before anything is simulated


def test_update_compares_each_period_with_the_reference_on_the_same_trials():
    small = dict(speeds=(10.0,), shapes=("circle",), materials=("wood", "aluminum"))
    config = synth.SynthConfig()
    same = update.update_convergence(config, (0.002, 0.002), **small)
    assert same["trials"] == 2 and same["reference_s"] == 0.002
    (row,) = same["rows"]
    assert row["speed_mm_s"] == 10.0
    # The same period twice: the same bits, so no difference and a power ratio of 1.
    assert row["band_power_ratio_median"] == row["band_power_ratio_max"] == 1.0
    assert row["pvdf_diff_p95"] == row["sg_diff_p95"] == 0.0
    # Another seed is another stroke: its difference is far from zero.
    seeds = same["seeds"][10.0]
    assert seeds["pvdf_diff_median"] > 0.01 and seeds["sg_diff_median"] > 0.01
    other = update.update_convergence(config, (0.001, 0.004), **small)
    (row,) = other["rows"]
    assert row["surface_update_s"] == 0.004 and 0.0 < row["pvdf_diff_median"] < 1.0


def test_every_swept_parameter_spans_its_default_and_says_why():
    base = synth.SynthConfig()
    by_name: dict[str, list] = {}
    for section, field, value, why, is_default, config in sweep.candidates(base):
        by_name.setdefault(f"{section}.{field}", []).append((value, why, is_default, config))
    assert len(by_name) == len(settings.SWEEP)
    for name, rows in by_name.items():
        assert len(rows) >= 2 and len({v for v, _, _, _ in rows}) == len(rows), name
        assert [d for _, _, d, _ in rows].count(True) == 1, name
        assert all(why.strip() for _, why, _, _ in rows), name
        assert all(config != base for _, _, d, config in rows if not d), name
