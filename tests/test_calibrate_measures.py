"""The calibration's measurements: a candidate's figures over seeds, AFOP-ML's selection
shares, the features' variance shares, the picks command, and the scatters and scales
the defaults are derived from (scripts/calibrate.py's subcommands that print them)."""

from __future__ import annotations

import dataclasses
import math
import re
import types

import numpy as np
import pytest

import benchmark.calibration as measure
import synth
from models.features import FEATURE_NAMES
from synth import contact
from synth.calibration import scatter, settings, sweep
from tests.support import load_script
from tests.synthetic_data import make_dataset


def test_a_candidate_over_seeds_reports_means_the_share_gap_and_their_spread():
    runs = [
        {
            "class_all": 0.9,
            "pvdf_share_cross_shape": 0.6,
            "pvdf_share_cross_material": 0.5,
            "pvdf_share_paper_d_cross_shape": 0.5,
            "pvdf_share_paper_d_cross_material": 0.25,
        },
        {
            "class_all": 0.8,
            "pvdf_share_cross_shape": 0.4,
            "pvdf_share_cross_material": 0.5,
            "pvdf_share_paper_d_cross_shape": 1 / 6,
            "pvdf_share_paper_d_cross_material": 0.5,
        },
    ]
    got = sweep.over_seeds(runs)
    assert got["class_all"] == pytest.approx(0.85)
    assert got["pvdf_share_cross_shape"] == pytest.approx(0.5)
    assert got["pvdf_share_gap"] == pytest.approx(0.0)
    # Sample standard deviations over the seeds: shares 0.6/0.4, gaps +0.1/-0.1.
    assert got["pvdf_share_cross_shape_sd"] == pytest.approx(0.1414, abs=1e-4)
    assert got["pvdf_share_cross_material_sd"] == pytest.approx(0.0)
    assert got["pvdf_share_gap_sd"] == pytest.approx(0.1414, abs=1e-4)
    # At the paper's D: gaps +0.25 and -1/3.
    assert got["pvdf_share_paper_d_gap"] == pytest.approx((0.25 - 1 / 3) / 2)
    assert got["pvdf_share_paper_d_gap_sd"] == pytest.approx((0.25 + 1 / 3) / 2**0.5)
    one = sweep.over_seeds(runs[:1])
    assert one["pvdf_share_gap"] == pytest.approx(0.1)
    assert one["pvdf_share_gap_sd"] == 0.0


#: AFOP-ML's selection hyper-parameters for the planted-information test, fixed so that
#: what it checks does not move when scripts/tune.py retunes on simulated data.
PLANTED_AFOP = {"ncfs_lam_n": 1.052632, "ncfs_max_iter": 15, "alpha": 150.0}


@pytest.mark.parametrize("seed", [0, 6])
def test_selection_shares_follow_where_the_planted_information_lies(seed, monkeypatch):
    # Shapes live only in the strain-gauge channels of this dataset, materials in the PVDF
    # ones: a one-material training split (cross-material) needs SG features only, a
    # three-material split (cross-shape) needs PVDF features for the materials as well.
    # Over seeds 0-9 the cross-shape share exceeds the cross-material one by 0.21 or more.
    import models.tuned

    values = models.tuned.tuned_values()
    monkeypatch.setattr(
        models.tuned, "tuned_values", lambda *a: {**values, "AFOP-ML": PLANTED_AFOP}
    )
    data = make_dataset(trials_per_class=6, noise=0.3, seed=seed)
    shares = measure.selection_shares(data)
    assert shares["pvdf_share_cross_material"] < 0.35
    assert shares["pvdf_share_cross_shape"] > shares["pvdf_share_cross_material"] + 0.10
    # The median feature count each protocol's selections chose, out of the pool's.
    for key in ("d_cross_shape", "d_cross_material"):
        assert 1 <= shares[key] <= len(FEATURE_NAMES)
    # The first 12 ranked features of a one-material split are mostly the gauges' (the
    # first 6 of a three-material split still start with them: shapes outnumber materials).
    assert shares["pvdf_share_paper_d_cross_material"] < 0.35


def test_selection_shares_report_each_fits_selection_and_ranking(monkeypatch):
    # A stand-in fit with a known selection and ranking: a three-material training split
    # (cross-shape, 24 classes) selects 3 PVDF and 1 SG feature and ranks 5 PVDF features
    # first; a one-material split (12 classes) selects 4 SG features and ranks 3 PVDF
    # features first. The shares and sizes are exactly those, whatever the data.
    import models.afop

    pvdf = [i for i, n in enumerate(FEATURE_NAMES) if n.startswith("pvdf")]
    sg = [i for i, n in enumerate(FEATURE_NAMES) if n.startswith("sg")]

    class KnownFit:
        def __init__(self, *, seed):
            self.seed = seed

        def fit(self, signals, labels, *, features):
            assert len(signals) == len(labels) == len(features)
            three_materials = len(set(labels.tolist())) > 12
            if three_materials:
                self.selected_ = pvdf[:3] + sg[:1]
                ranking = pvdf[:5] + sg[:20]
            else:
                self.selected_ = sg[:4]
                ranking = pvdf[:3] + sg[:20]
            self.ncfs_ = types.SimpleNamespace(ranking_=ranking)
            return self

    monkeypatch.setattr(models.afop, "AFOPML", KnownFit)
    shares = measure.selection_shares(make_dataset(trials_per_class=2, seed=0))
    assert shares == pytest.approx(
        {
            "pvdf_share_cross_shape": 0.75,
            "d_cross_shape": 4.0,
            "pvdf_share_paper_d_cross_shape": 5 / 6,
            "pvdf_share_cross_material": 0.0,
            "d_cross_material": 4.0,
            "pvdf_share_paper_d_cross_material": 3 / 12,
        }
    )


def test_variance_shares_split_a_features_variance_between_shapes_materials_and_trials():
    # Two shapes x two materials x two trials. Column 0 follows the shape, column 1 the
    # material, column 2 is constant, column 3 the trial inside its class; column 4 is the
    # shape plus the trial (half the variance between shapes), column 5 the shape plus
    # twice the material (variances 0.25 and 1 of 1.25).
    shape = np.repeat(["a", "b"], 4)
    material = np.tile(np.repeat(["wood", "resin"], 2), 2)
    trial = np.tile([0.0, 1.0], 4)
    s = (shape == "b").astype(float)
    m = (material == "resin").astype(float)
    x = np.stack([s, m, np.full(8, 3.0), trial, s + trial, s + 2 * m], axis=1)
    by_shape, by_material = measure.variance_shares(x, shape, material)
    np.testing.assert_allclose(by_shape, [1.0, 0.0, 0.0, 0.0, 0.5, 0.2], atol=1e-12)
    np.testing.assert_allclose(by_material, [0.0, 1.0, 0.0, 0.0, 0.0, 0.8], atol=1e-12)


@pytest.mark.parametrize("seed", [0, 6])
def test_picks_show_a_three_material_selection_telling_materials_apart_with_the_films(
    seed, monkeypatch
):
    # As in the planted-information test: the films carry the materials, the gauges the
    # shapes (and the materials through one gauge's level). The cross-shape selections'
    # PVDF features are material-led (over seeds 0-9 at least 82 of 83), their SG features
    # mostly shape-led (at most 25 of 61 material-led); a one-material split has no
    # material variance at all.
    import models.tuned

    values = models.tuned.tuned_values()
    monkeypatch.setattr(
        models.tuned, "tuned_values", lambda *a: {**values, "AFOP-ML": PLANTED_AFOP}
    )
    fits = measure.selection_picks(make_dataset(trials_per_class=6, noise=0.3, seed=seed), 5)
    assert [f["protocol"] for f in fits] == ["cross_shape"] * 3 + ["cross_material"] * 3
    cross_shape = fits[:3]
    pvdf = sum(f["pvdf"]["selected"] for f in cross_shape)
    assert pvdf >= 1
    assert sum(f["pvdf"]["material_led"] for f in cross_shape) >= 0.9 * pvdf
    sg = sum(f["sg"]["selected"] for f in cross_shape)
    assert sum(f["sg"]["material_led"] for f in cross_shape) <= 0.6 * sg
    for f in fits:
        assert f["d"] == f["pvdf"]["selected"] + f["sg"]["selected"]
        assert [r["rank"] for r in f["top"]] == [1, 2, 3, 4, 5]
        for r in f["top"]:
            assert r["sensor"] in ("pvdf", "sg")
            assert 0.0 <= r["shape_share"] <= 1.0 and 0.0 <= r["material_share"] <= 1.0
            assert r["shape_share"] + r["material_share"] <= 1.0 + 1e-9
    for f in fits[3:]:
        assert f["pvdf"]["material_led"] == f["sg"]["material_led"] == 0
        assert all(r["material_share"] < 1e-9 for r in f["top"])


def test_picks_refuse_a_missing_dataset_and_a_bad_count_in_one_line(tmp_path, capsys):
    calibrate = load_script("calibrate")
    with pytest.raises(SystemExit, match=re.escape(f"DATA ({tmp_path / 'none'}): ")):
        calibrate.main(["picks", str(tmp_path / "none")])
    with pytest.raises(SystemExit):
        calibrate.main(["picks", str(tmp_path), "--top", "0"])
    assert "--top must be at least 1" in capsys.readouterr().err


def test_the_texture_scale_scales_every_texture_amplitude_and_nothing_else():
    base = synth.SynthConfig()
    half = settings.with_value(base, *settings.TEXTURE_SCALE, 0.5)
    for name, material in base.materials.items():
        scaled = half.materials[name]
        assert scaled.friction == material.friction
        assert scaled.texture.roughness_rms_m == pytest.approx(
            0.5 * material.texture.roughness_rms_m
        )
        assert scaled.texture.correlation_length_m == material.texture.correlation_length_m
        for mark, original in zip(scaled.texture.periodic, material.texture.periodic, strict=True):
            assert mark.amplitude_m == pytest.approx(0.5 * original.amplitude_m)
            assert mark.wavelength_m == original.wavelength_m
    assert dataclasses.replace(half, materials=base.materials) == base
    # At its default the sweep evaluates the unchanged configuration (shared with every
    # other parameter's default row).
    default = settings.default_value(base, *settings.TEXTURE_SCALE)
    assert settings.with_value(base, *settings.TEXTURE_SCALE, default).to_dict() == base.to_dict()


def test_the_friction_scatter_default_is_the_one_the_silicone_measurements_give(capsys):
    calibrate = load_script("calibrate")
    config = synth.SynthConfig()
    got = scatter.friction_scatter(config)
    # The skin's mean Hertz pressure at 1 N lies nearest the 62.5 kPa runs of both silicones.
    assert 40 < got["pressure_kpa"] < 70
    assert got["chosen"] == {"Dragon Skin 10": 62.5, "Sil 950": 62.5}
    assert all(run["cof"].size >= 29 for run in got["runs"].values())
    assert round(got["value"], 3) == config.variability.friction_rel
    assert calibrate.main(["friction"]) == 0
    out = capsys.readouterr().out
    assert f"Variability.friction_rel = {config.variability.friction_rel:.3f}" in out
    assert out.count("<- nearest") == 2


def test_the_force_scatter_default_is_the_one_the_arms_repeatability_gives(capsys):
    calibrate = load_script("calibrate")
    config = synth.SynthConfig()
    got = scatter.force_scatter(config)
    f, m = config.finger, config.motion
    delta = float(
        contact.hertz_indentation_m(1.0, f.pad_radius_m, f.skin_modulus_pa, f.skin_poisson)
    )
    assert got["indentation_m"] == pytest.approx(delta)
    # Servo, PDMS support and the skin's Hertz tangent stiffness, in series.
    k = 1.0 / (1.0 / m.servo_stiffness_n_m + 1.0 / f.pdms_normal_stiffness_n_m + delta / 1.5)
    assert got["series_stiffness_n_m"] == pytest.approx(k)
    assert got["value"] == pytest.approx(k * 0.1e-3 / 3)
    # Every compliance in series lowers the scatter below the skin's alone.
    assert got["value"] < 1.5 * (0.1e-3 / 3) / delta
    # The same repeatability takes a smaller sd from a Gaussian scatter in three axes, a
    # larger one from a scatter along the press direction alone: they bound the reading.
    assert 0.8 * got["value"] < got["gaussian_3d"] < got["value"] < got["gaussian_1d"]
    assert got["gaussian_1d"] < 1.2 * got["value"]
    assert round(got["value"], 3) == config.variability.force_rel
    assert calibrate.main(["force"]) == 0
    out = capsys.readouterr().out
    assert f"Variability.force_rel = {config.variability.force_rel:.3f}" in out


def test_the_speed_scatter_bound_is_the_repeatability_over_each_outlines_touches(capsys):
    """A square 14 mm wide is first and last touched a touch distance before and after
    its walls; the repeatability bound is sqrt(2) x (0.1 mm / 3) over that, the
    shortest outline (the triangle) gives the largest, and a path that misses an outline
    is refused naming the option."""
    config = synth.SynthConfig()
    got = scatter.speed_scatter(config)
    reach = synth.planning.touch_distance_m(config, 1.0)
    step = synth.planning.TOUCH_STEP_M  # the touch search's resolution, at each end
    assert got["phase_m"]["square"] == pytest.approx(14e-3 + 2 * reach, abs=2 * step)
    assert got["per_shape"]["square"] == pytest.approx(
        math.sqrt(2) * (0.1e-3 / 3) / got["phase_m"]["square"], rel=1e-12
    )
    assert got["value"] == got["per_shape"]["triangle"] == max(got["per_shape"].values())
    assert 0.002 < got["value"] < 0.003
    calibrate = load_script("calibrate")
    assert calibrate.main(["speed"]) == 0
    assert "triangle: 18.6 mm -> 0.253 %" in capsys.readouterr().out
    with pytest.raises(SystemExit, match=r"^motion.path_y_m: the path at y = 9.00 mm misses"):
        calibrate.main(["speed", "--set", "motion.path_y_m=0.009"])


def test_the_force_scatter_follows_the_finger_it_is_derived_from():
    config = synth.SynthConfig()
    rigid = dataclasses.replace(
        config,
        finger=dataclasses.replace(config.finger, pdms_normal_stiffness_n_m=1e15),
        motion=dataclasses.replace(config.motion, servo_stiffness_n_m=1e15),
    )
    stiff = dataclasses.replace(
        rigid,
        finger=dataclasses.replace(rigid.finger, skin_modulus_pa=8 * config.finger.skin_modulus_pa),
    )
    # With the servo and the support rigid the skin alone sets it: Hertz's load goes as
    # the indentation to the power 1.5, and the indentation as E^(-2/3), so 8 x the
    # modulus sinks 4 x less deep and the same depth error scatters the load 4 x more.
    f = config.finger
    delta = float(
        contact.hertz_indentation_m(1.0, f.pad_radius_m, f.skin_modulus_pa, f.skin_poisson)
    )
    skin_only = scatter.force_scatter(rigid)["value"]
    assert skin_only == pytest.approx(1.5 * (0.1e-3 / 3) / delta, rel=1e-9)
    assert scatter.force_scatter(stiff)["value"] / skin_only == pytest.approx(4.0, rel=1e-9)
    # A softer support takes up more of the depth error.
    soft = dataclasses.replace(
        config, finger=dataclasses.replace(f, pdms_normal_stiffness_n_m=1000.0)
    )
    assert scatter.force_scatter(soft)["value"] < scatter.force_scatter(config)["value"]


def test_a_stiffer_skin_draws_the_friction_scatter_from_a_higher_pressure_run():
    config = synth.SynthConfig()
    stiff = dataclasses.replace(
        config, finger=dataclasses.replace(config.finger, skin_modulus_pa=3.0e6)
    )
    got = scatter.friction_scatter(stiff)
    assert got["pressure_kpa"] > 100
    assert got["chosen"]["Sil 950"] > 62.5
