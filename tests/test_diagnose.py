"""``tactile-synth diagnose``: leave-one-out 1-NN per channel group on datasets whose answer
is known by construction, the exact nearest-neighbour search, the edge cases of small and
odd grids, and the CLI on a store on disk."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchmark.cli import main
from benchmark.diagnose import (
    CURVES_NAME,
    FIGURES,
    JSON_NAME,
    MARKDOWN_NAME,
    diagnose,
    json_ready,
    loo_nearest,
    loo_score,
    markdown,
    plot_accuracy,
    run_diagnose,
    summary_table,
    write_diagnosis,
)
from shapes import SHAPE_NAMES
from synth import (
    CLASS_NAMES,
    MATERIAL_NAMES,
    N_SAMPLES,
    Dataset,
    GenerationConfig,
    load_dataset,
    store,
)
from synth.presets import plan

SHAPES4 = ("circle", "hexagon", "square", "triangle")


def trial_signals(
    shape: str, material: str, rng: np.random.Generator, *, n_samples: int, speed: float = 10.0
) -> np.ndarray:
    """One trial whose strain gauges depend on the shape only and whose PVDF films depend
    on the material only (and the speed scales the PVDF frequency)."""
    t = np.arange(n_samples) / 1000.0
    s = SHAPE_NAMES.index(shape)
    m = MATERIAL_NAMES.index(material)
    # Shape: a bump whose time and width depend on the shape, on both gauges.
    centre = 0.15 + 0.05 * s + 0.01 * rng.standard_normal()
    width = 0.03 + 0.01 * s
    bump = np.exp(-0.5 * ((t - centre) / width) ** 2)
    sg1 = 0.5 * bump + 0.02 * rng.standard_normal(n_samples)
    sg2 = -0.3 * bump * (1 + 0.2 * s) + 0.02 * rng.standard_normal(n_samples)
    # Material: a tone whose frequency depends on the material, random phase.
    f = (40.0 + 70.0 * m) * speed / 10.0
    phase = rng.uniform(0, 2 * np.pi)
    pv1 = 0.3 * np.sin(2 * np.pi * f * t + phase) + 0.2 * rng.standard_normal(n_samples)
    pv2 = 0.2 * np.sin(2 * np.pi * 1.5 * f * t + phase) + 0.2 * rng.standard_normal(n_samples)
    return np.stack([pv1, pv2, sg1, sg2]).astype(np.float32)


def separable(
    *,
    shapes: tuple[str, ...] = SHAPES4,
    materials: tuple[str, ...] = MATERIAL_NAMES,
    trials: int = 6,
    speeds: tuple[float, ...] = (10.0,),
    n_samples: int = 1000,
    seed: int = 0,
) -> Dataset:
    rng = np.random.default_rng(seed)
    rows, meta = [], []
    for v in speeds:
        for s in shapes:
            for m in materials:
                for _ in range(trials):
                    rows.append(trial_signals(s, m, rng, n_samples=n_samples, speed=v))
                    meta.append((s, m, v))
    n = len(rows)
    return Dataset(
        signals=np.stack(rows),
        shape=np.array([s for s, _, _ in meta]),
        material=np.array([m for _, m, _ in meta]),
        label=np.array([CLASS_NAMES.index(f"{s}/{m}") for s, m, _ in meta], dtype=np.int64),
        force_n=np.ones(n),
        speed_mm_s=np.array([v for _, _, v in meta], dtype=np.float64),
        seed=np.arange(n, dtype=np.int64),
        attrs={"source": "test"},
    )


# -- the exact nearest-neighbour search ---------------------------------------------------
def brute_nearest(x: np.ndarray) -> np.ndarray:
    """Directly summed squared differences; equal distances go to the lowest index."""
    x = x.astype(np.float64)
    out = []
    for i in range(len(x)):
        d = ((x - x[i]) ** 2).sum(axis=1)
        d[i] = np.inf
        out.append(int(np.flatnonzero(d == d.min())[0]))
    return np.array(out)


@pytest.mark.parametrize("block_rows", [1, 7, 256])
def test_loo_nearest_is_exact_with_ties_to_the_lowest_index(block_rows):
    rng = np.random.default_rng(3)
    # Integer points: many exactly equal distances; duplicated rows: distance 0 ties.
    x = rng.integers(0, 3, size=(60, 5)).astype(np.float64)
    x[40:45] = x[10]
    got = loo_nearest(x, block_rows=block_rows)
    assert np.array_equal(got, brute_nearest(x))
    assert not np.any(got == np.arange(len(x)))  # never itself
    # Continuous data of many dimensions, far from the origin (cancellation-prone).
    y = 1e3 + rng.standard_normal((80, 300))
    assert np.array_equal(loo_nearest(y, block_rows=block_rows), brute_nearest(y))


def test_loo_score_leaves_out_labels_no_other_trial_shares():
    labels = np.array(["a", "a", "b", "b", "c"])
    nearest = np.array([1, 2, 3, 0, 0])  # a->a right, a->b wrong, b->b right, b->a wrong
    s = loo_score(nearest, labels)
    assert s.accuracy == 0.5 and s.scored == 4 and s.left_out == 1
    assert s.chance == pytest.approx(1 / 4)  # (2 - 1) / (5 - 1) for every scored trial
    none = loo_score(np.array([1, 0]), np.array(["a", "b"]))
    assert none.accuracy is None and none.scored == 0 and none.left_out == 2


def test_loo_nearest_rejects_bad_input():
    with pytest.raises(ValueError, match="n >= 2"):
        loo_nearest(np.zeros((1, 3)))
    with pytest.raises(ValueError, match="NaN"):
        loo_nearest(np.array([[0.0], [np.nan]]))


# -- diagnose on data with a known answer -------------------------------------------------
def test_shape_lives_in_the_strain_gauges_and_material_in_the_pvdf():
    d = diagnose(separable(seed=1))
    acc = d.accuracy
    assert d.n_features == {"all": 386, "sg": 97, "pvdf": 289}
    # The channel group carrying the label separates it...
    assert acc["shape"]["sg"] >= 0.95
    assert acc["material"]["pvdf"] >= 0.95
    # ...and the other one is near chance (chance 0.24 shape, 0.32 material; over 10
    # seeds at most 0.29 and 0.46).
    assert d.chance["shape"] == pytest.approx(17 / 71)
    assert d.chance["material"] == pytest.approx(23 / 71)
    assert acc["shape"]["pvdf"] <= 0.5
    assert acc["material"]["sg"] <= 0.6
    # Class needs both: only all features get most of both right (over 10 seeds: all
    # >= 0.81, each single group <= 0.46, chance 0.07).
    assert acc["class"]["all"] >= 0.7
    assert acc["class"]["all"] >= max(acc["class"]["sg"], acc["class"]["pvdf"]) + 0.25
    assert acc["condition"] is None and "one condition" in d.notes["condition"]
    assert set(d.per_shape["sg"]) == set(SHAPES4)
    assert min(d.per_shape["sg"].values()) >= 0.9
    assert min(d.per_material["pvdf"].values()) >= 0.9
    # The SG-only confusions are between materials of one shape.
    assert all(p.differ_by == "material" for p in d.confused_pairs["sg"][:3])
    assert d.confusion["all"].sum() == d.n_trials


def test_diagnosis_is_deterministic_and_takes_precomputed_features():
    from models.features import extract

    data = separable(seed=2)
    a = diagnose(data)
    b = diagnose(data, features=extract(data.signals))
    assert json.dumps(json_ready(a.to_dict())) == json.dumps(json_ready(b.to_dict()))
    assert np.array_equal(a.spectra.psd_v2_per_hz, b.spectra.psd_v2_per_hz)


def test_spectra_peak_at_each_materials_tone_and_traces_per_shape():
    d = diagnose(separable(seed=4))
    summary = d.spectra.summary()["force=1N,speed=10mm/s"]
    resolution = d.spectra.freq_hz[1]
    for m, mat in enumerate(MATERIAL_NAMES):
        assert abs(summary[mat]["pvdf1"]["peak_hz"] - (40 + 70 * m)) <= resolution
    tr = d.sg_traces
    assert tr.mean_v.shape == (1, len(SHAPES4), 2, 1000)
    # Each shape's mean sg1 bump peaks where the builder put it (0.15 + 0.05 * index s).
    for si, shape in enumerate(tr.shapes):
        peak_s = tr.time_s[np.argmax(tr.mean_v[0, si, 0])]
        assert abs(peak_s - (0.15 + 0.05 * SHAPE_NAMES.index(shape))) < 0.01


# -- odd grids -----------------------------------------------------------------------------
def test_one_material_is_not_applicable_and_nothing_crashes(tmp_path):
    d = diagnose(separable(materials=("wood",), seed=5))
    assert d.accuracy["material"] is None and d.per_material is None
    assert d.chance["material"] is None
    assert "one material (wood)" in d.notes["material"]
    assert d.accuracy["shape"]["sg"] >= 0.95
    assert "n/a" in summary_table(d)
    assert "Not applicable" in markdown(d)
    written = write_diagnosis(d, tmp_path, figures=False)
    assert {p.name for p in written} == {MARKDOWN_NAME, JSON_NAME, CURVES_NAME}
    assert json.loads((tmp_path / JSON_NAME).read_text())["accuracy"]["material"] is None
    # The accuracy figure is the one that lays out per-material panels.
    assert plot_accuracy(d, tmp_path / "acc.png").stat().st_size > 0


def test_a_class_with_one_trial_is_left_out_of_the_class_score():
    full = separable(seed=6)
    keep = np.ones(len(full), dtype=bool)
    lone = np.flatnonzero((full.shape == "circle") & (full.material == "wood"))
    keep[lone[1:]] = False
    d = diagnose(full.subset(keep))
    assert d.scored["class"] == d.n_trials - 1
    assert "1 trial(s) left out" in d.notes["class"]
    assert d.per_class["all"]["circle/wood"] is None
    assert d.scored["shape"] == d.n_trials  # its shape has other trials
    assert d.trials_per_class == (1, 6)


def test_every_class_with_one_trial_and_two_trials_in_all():
    d = diagnose(separable(trials=1, seed=7))
    assert d.accuracy["class"] == {"all": None, "sg": None, "pvdf": None}
    assert "has one trial" in d.notes["class"]
    assert d.accuracy["shape"] is not None  # each shape has 3 trials (3 materials)
    two = diagnose(separable(shapes=("moon",), materials=("resin",), trials=2, seed=8))
    assert all(two.accuracy[t] is None for t in ("class", "shape", "material", "condition"))
    assert "one class (moon/resin)" in two.notes["class"]
    assert "n/a" in summary_table(two) and "Not applicable" in markdown(two)


def test_several_conditions_report_condition_accuracy():
    d = diagnose(separable(speeds=(14.0, 6.0), trials=4, seed=9))
    assert d.conditions == ("force=1N,speed=6mm/s", "force=1N,speed=14mm/s")
    # The speed moves the PVDF tone: the condition is found by PVDF, not by the gauges.
    # Over 10 seeds: PVDF >= 0.95, SG <= 0.54 (chance 0.49), per condition >= 0.75.
    assert d.accuracy["condition"]["pvdf"] >= 0.85
    assert d.accuracy["condition"]["sg"] <= 0.75
    assert set(d.per_condition) == set(d.conditions)
    assert min(v["all"] for v in d.per_condition.values()) >= 0.6
    assert d.spectra.psd_v2_per_hz.shape[:2] == (2, 3)
    assert "condition" in summary_table(d).splitlines()[1]


def test_silent_films_give_no_spectral_peak():
    data = separable(trials=2, seed=12)
    data.signals[:, :2] = 0.0
    d = diagnose(data)
    v = d.spectra.summary()["force=1N,speed=10mm/s"]["wood"]["pvdf1"]
    assert v == {"rms_v": 0.0, "centroid_hz": None, "peak_hz": None}
    assert d.accuracy["material"]["pvdf"] is not None  # scored, whatever it is


def test_bad_input_names_the_argument():
    data = separable(trials=2, seed=10)
    with pytest.raises(ValueError, match="features must have shape"):
        diagnose(data, features=np.zeros((3, 386)))
    with pytest.raises(ValueError, match="at least 2 trials"):
        diagnose(data.subset(np.array([0])))
    with pytest.raises(ValueError, match=r"synth\.Dataset"):
        diagnose(data.signals)


# -- the CLI on a store on disk ------------------------------------------------------------
def make_store(
    path, *, chunks_done: int | None = None, materials=MATERIAL_NAMES, chunk_trials: int = 12
) -> None:
    """A store with the builder's signals (no simulation); ``chunks_done`` of its chunks
    written (all if None)."""
    config = GenerationConfig(
        preset="custom",
        shapes=SHAPES4,
        materials=materials,
        trials_per_class=4,
        chunk_trials=chunk_trials,
        synth={"test": True},
    )
    store_id = store.create(path, config)
    trials = plan(config)
    rng = np.random.default_rng(11)
    signals = np.stack(
        [
            trial_signals(*CLASS_NAMES[int(k)].split("/"), rng, n_samples=N_SAMPLES)
            for k in trials.label
        ]
    )
    c = config.chunk_trials
    for k in range(config.n_chunks if chunks_done is None else chunks_done):
        specs = trials.specs(k * c, (k + 1) * c)
        store.write_chunk(path, k, signals[k * c : (k + 1) * c], specs, store_id)


@pytest.mark.slow
def test_cli_prints_the_table_and_writes_the_report(tmp_path, capsys):
    data, out = tmp_path / "data", tmp_path / "out"
    make_store(data)
    assert main(["diagnose", str(data), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "strain gauges only (97)" in printed and "chance" in printed
    md = (out / MARKDOWN_NAME).read_text()
    assert "## Accuracy per channel group" in md
    for name in FIGURES.values():
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert f"]({name})" in md
    result = json.loads((out / JSON_NAME).read_text())
    assert result["n_trials"] == 48 and result["accuracy"]["shape"]["sg"] >= 0.95
    library = diagnose(load_dataset(data), source=str(data)).to_dict()
    assert result == json.loads(json.dumps(json_ready(library)))
    with np.load(out / CURVES_NAME, allow_pickle=False) as curves:
        assert curves["sg_mean_v"].shape == (1, 4, 2, N_SAMPLES)
        assert list(curves["psd_materials"]) == list(MATERIAL_NAMES)


def test_cli_help_explains_the_numbers(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["diagnose", "--help"])
    assert exit_info.value.code == 0
    text = capsys.readouterr().out
    for phrase in ("nearest other trial", "chance", "strain gauges only", "left out", "n/a"):
        assert phrase in text


def test_cli_refuses_an_incomplete_store_naming_the_fix(tmp_path, capsys):
    data = tmp_path / "data"
    make_store(data, chunks_done=2, materials=("resin",), chunk_trials=4)
    assert main(["diagnose", str(data)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert "incomplete (2/4 chunks done)" in err
    assert f"tactile-synth generate --resume --out {data}" in err and "--allow-incomplete" in err
    assert main(["diagnose", str(data), "--allow-incomplete"]) == 0
    printed = capsys.readouterr().out
    assert "incomplete store" in printed and "8 trials" in printed
    assert main(["diagnose", str(tmp_path / "absent")]) == 2
    assert "does not exist" in capsys.readouterr().err
    for out in (data, data / "report"):
        assert main(["diagnose", str(data), "--allow-incomplete", "--out", str(out)]) == 2
        err = capsys.readouterr().err.strip()
        assert err.endswith(f"--out {out} lies inside the dataset {data}; choose another DIR")
        assert len(err.splitlines()) == 1
    assert not (data / "report").exists() and not (data / MARKDOWN_NAME).exists()
    # a steady gap outside its range is refused by its option's name, before any loading
    assert main(["diagnose", str(tmp_path / "absent"), "--edge-gap-s", "1.5"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (
        "tactile-synth diagnose: error: --edge-gap-s must lie in 0..0.9 s (a 2 s window "
        "keeps a 0.2 s stretch between two gaps); got 1.5"
    )
    assert main(["diagnose", str(data), "--allow-incomplete", "--edge-gap-s", "0.45"]) == 0
    assert run_diagnose(data, allow_incomplete=True, edge_gap_s=0.45).steady["edge_gap_s"] == 0.45


def test_steady_stretches_keep_clear_of_the_edges_and_score_the_material():
    """Two edge transients at 0.2 s and 1.8 s: the steady stretch lies 0.3 s from both;
    films whose steady tone differs by material give a perfect steady 1-NN score, while
    gauges carrying no material information score near chance."""
    from benchmark.diagnose import steady

    rng = np.random.default_rng(0)
    t = np.arange(2000) / 1000.0
    signals, material = [], []
    for i in range(24):
        m = ("resin", "wood", "aluminum")[i % 3]
        x = rng.normal(0, 1e-4, (4, 2000))
        x[:2, 200] += 3.0  # entry edge
        x[:2, 1800] -= 3.0  # exit edge
        f = {"resin": 60.0, "wood": 150.0, "aluminum": 300.0}[m]
        x[:2] += 2e-3 * np.sin(2 * np.pi * f * t + rng.uniform(0, 6))
        signals.append(x)
        material.append(m)
    stretch = steady.steady_stretch(signals[0])
    assert stretch == slice(501, 1500)
    assert steady.steady_stretch(signals[0], 0.45) == slice(651, 1350)
    assert steady.steady_stretch(signals[0], 0.7) is None  # under 0.2 s left between them
    report = steady.steady_diagnosis(np.array(signals), np.array(material))
    assert report["scored"] == 24 and report["left_out"] == 0
    assert report["left_out_by_material"] == {"aluminum": 0, "resin": 0, "wood": 0}
    assert report["material_accuracy"]["pvdf"] == 1.0
    assert report["material_accuracy"]["sg"] < 0.7
    assert set(report["texture_band_rms_v"]) == {"resin", "wood", "aluminum"}
    assert "24 trials, 0 without a steady stretch):" in steady.summary_lines(report, None)[0]
    # wood's films ring at the wall threshold all along two trials: no steady stretch there
    for i in (1, 4):
        signals[i][:2, 300:1700] += 0.5 * np.sign(np.sin(2 * np.pi * 5 * t[300:1700]))
    report = steady.steady_diagnosis(np.array(signals), np.array(material))
    assert report["scored"] == 22 and report["left_out"] == 2
    assert report["left_out_by_material"] == {"aluminum": 0, "resin": 0, "wood": 2}
    line = steady.summary_lines(report, None)[0]
    assert line.endswith("22 trials, 2 without a steady stretch: aluminum 0, resin 0, wood 2):")
    wider = steady.steady_diagnosis(np.array(signals), np.array(material), edge_gap_s=0.45)
    assert wider["edge_gap_s"] == 0.45 and wider["scored"] == 22
    first = steady.summary_lines(wider, None)[0]
    assert first.startswith("material 1-NN on steady sliding (>= 0.45 s")
    for bad in (-0.1, 0.95, float("nan")):
        with pytest.raises(ValueError, match=r"^edge_gap_s must lie in 0..0.9 s"):
            steady.steady_diagnosis(np.array(signals), np.array(material), edge_gap_s=bad)


def test_friction_lines_show_the_stored_laws_of_each_friction_model(tmp_path):
    import synth
    from benchmark.diagnose.text import friction_lines
    from synth.contact import friction_coefficient
    from synth.dataset_cli import with_friction_model, with_skin_response

    base = GenerationConfig(preset="custom", shapes=SHAPES4, trials_per_class=2)
    rows = {}
    for model in ("shared", "derived"):
        config = with_friction_model(base, model)
        if model == "derived":
            config = with_skin_response(config, "viscoelastic")
        store.create(tmp_path / model, config)
        lines = friction_lines(str(tmp_path / model))
        assert lines[0].startswith("skin friction per material")
        laws = synth.SynthConfig.from_dict(dict(config.synth)).materials
        skin = {"shared": "elastic (its relaxed modulus)", "derived": "viscoelastic (|E*| / E_inf"}
        assert lines[-1].startswith(f"  skin's answer to the texture: {skin[model]}"), lines[-1]
        rows[model] = {}
        for line in lines[2:-1]:
            name, mu, _, exponent = line.split()
            law = laws[name].friction
            assert float(mu) == pytest.approx(float(friction_coefficient(law, 0.01, 1.0)), abs=6e-4)
            assert float(exponent) == pytest.approx(law.velocity_exponent, abs=6e-5)
            rows[model][name] = float(mu)
        assert set(rows[model]) == set(MATERIAL_NAMES)
    assert len(set(rows["shared"].values())) == 1  # one law for every material
    assert len(set(rows["derived"].values())) == 3  # one per surface
    make_store(tmp_path / "built")  # signals without the simulator: no laws to show
    assert friction_lines(str(tmp_path / "built")) == []
