"""The benchmark scripts in scripts/: a bad argument ends them with one line naming it and
exit status 2, and ``--help`` shows a complete first sentence of what each measures."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import synth.store
from tests.support import SCRIPTS, load_script
from tests.synthetic_data import make_dataset

ROOT = Path(__file__).resolve().parents[1]


def _script(name: str, monkeypatch):
    monkeypatch.syspath_prepend(str(SCRIPTS))  # the scripts import their shared helper
    return load_script(name)


def _fails(main, argv, capsys) -> str:
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err


@pytest.mark.parametrize(
    "name", ["bench_methods", "bench_closed_set", "bench_store", "embedding_probe"]
)
def test_a_missing_dataset_is_one_line_naming_data(name, tmp_path, monkeypatch, capsys):
    main = _script(name, monkeypatch).main
    err = _fails(main, ["--data", str(tmp_path / "nope")], capsys)
    assert f"error: --data {tmp_path / 'nope'}: dataset" in err


def test_bench_features_names_data_for_a_missing_dataset(tmp_path):
    # A child process: the script pins its process to one CPU when it loads.
    proc = subprocess.run(
        [sys.executable, str(SCRIPTS / "bench_features.py"), "--data", str(tmp_path / "nope")],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert proc.returncode == 2
    assert proc.stderr.startswith("bench_features.py: error: --data ")
    assert proc.stderr.count("\n") == 1, proc.stderr


@pytest.mark.parametrize("name", ["bench_methods", "bench_closed_set"])
def test_an_unknown_method_is_one_line_naming_methods(name, tmp_path, monkeypatch, capsys):
    main = _script(name, monkeypatch).main
    err = _fails(main, ["--data", str(tmp_path), "--methods", "Bogus"], capsys)
    assert "error: --methods must be one of" in err and "'Bogus'" in err


@pytest.mark.parametrize(
    ("name", "trials", "message"),
    [
        ("bench_methods", 4, "is too small: 5-way 5-shot episodes"),
        ("bench_closed_set", 1, "is too small: its test half holds no Table I column"),
    ],
)
def test_a_dataset_too_small_is_one_line_naming_data(name, trials, message, monkeypatch, capsys):
    data = make_dataset(trials_per_class=trials, n_samples=64)
    monkeypatch.setattr(synth.store, "load_dataset", lambda path: data)
    main = _script(name, monkeypatch).main
    err = _fails(main, ["--data", "small", "--methods", "AFOP-ML", "--episodes", "1"], capsys)
    assert f"error: --data small {message}" in err


@pytest.mark.parametrize(
    "name", ["bench_methods", "bench_malloc", "bench_store", "tune", "embedding_probe"]
)
def test_help_shows_the_whole_first_sentence(name, monkeypatch, capsys):
    module = _script(name, monkeypatch)
    with pytest.raises(SystemExit):
        module.main(["--help"])
    first = " ".join(module.__doc__.split("\n\n")[0].split())
    assert first.endswith(".")
    assert first in " ".join(capsys.readouterr().out.split())


def test_an_incomplete_dataset_is_finished_the_cli_way(monkeypatch, capsys):
    def incomplete(path):
        raise synth.store.DatasetIncomplete(
            f"dataset {path} is incomplete (1/3 chunks done)",
            f"finish it with `tactile-synth generate --resume --out {path}`",
            "load it with allow_incomplete=True",
        )

    monkeypatch.setattr(synth.store, "load_dataset", incomplete)
    main = _script("bench_store", monkeypatch).main
    err = _fails(main, ["--data", "part"], capsys)
    assert "error: --data part: dataset part is incomplete" in err
    assert "generate --resume --out part`" in err and "allow_incomplete" not in err


@pytest.mark.parametrize(
    ("name", "argv"),
    [
        ("bench_afop", ["--episodes", "1_000"]),
        ("bench_closed_set", ["--episodes", "1_000"]),
        ("bench_features", ["--repeats", "1_000"]),
        ("bench_generate", ["--repeat", "1_000"]),
        ("bench_load", ["--rounds", "1_000"]),
        ("bench_malloc", ["--repeats", "1_000"]),
        ("bench_methods", ["--episodes", "1_000"]),
        ("bench_run", ["--target-s", "1_000"]),
        ("bench_sim", ["--repeat", "1_000"]),
        ("bench_steady", ["--seeds", "1_000"]),
        ("bench_stress", ["--target-s", "1_000"]),
        ("bench_store", ["--repeat", "1_000"]),
        ("calibrate", ["fingerprint", "--draws", "1_000"]),
        ("tune", ["--episodes", "1_000"]),
    ],
)
@pytest.mark.slow
def test_a_number_with_an_underscore_is_refused_naming_the_option(name, argv, tmp_path):
    # A child process: some scripts pin their CPU or allocator when they load.
    proc = subprocess.run(
        [sys.executable, str(SCRIPTS / f"{name}.py"), *argv],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    option = next(a for a in argv if a.startswith("--"))
    last = proc.stderr.splitlines()[-1]  # argparse's usage, then its error line
    assert f"error: argument {option}: '1_000' is not a" in last
    assert "write '1000'" in last


def test_bench_texture_transfer_gives_the_films_per_unit_of_push_per_frequency(
    monkeypatch, tmp_path, capsys
):
    main = _script("bench_texture", monkeypatch).main
    out = tmp_path / "transfer.json"
    assert main(["--transfer", "40", "170", "--seeds", "1", "--json", str(out)]) == 0
    import json

    table = json.loads(out.read_text())
    assert set(table) == {"40.0", "170.0"}
    ratios = [row["films_v"] / row["push_n"] for row in table.values()]
    assert all(r > 0 for r in ratios) and max(ratios) / min(ratios) < 1.15
    assert "highest over lowest ratio" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        main(["--transfer", "10"])  # its +-15 % band would leave the texture band
    assert "--transfer frequencies must lie in 23.5..347.8 Hz" in capsys.readouterr().err


def test_bench_texture_reports_the_films_and_the_push_they_read(monkeypatch, tmp_path, capsys):
    # One trial per material: the push's table comes from the same steady segments as the
    # films', and wood's rough surface pushes the skin more than milled aluminium's.
    main = _script("bench_texture", monkeypatch).main
    out = tmp_path / "texture.json"
    assert main(["--seeds", "1", "--speeds", "10", "--json", str(out)]) == 0
    import json

    tables = json.loads(out.read_text())
    assert set(tables) == {"shared", "derived"}  # both friction models, side by side
    for table in tables.values():
        assert set(table) == {"films_v", "push_n"}
        for name in ("films_v", "push_n"):
            assert set(table[name]) == {"resin", "wood", "aluminum"}
            assert all(v["10.0"] > 0 for v in table[name].values())
        assert table["push_n"]["wood"]["10.0"] > 1.5 * table["push_n"]["aluminum"]["10.0"]
    printed = capsys.readouterr().out
    assert "texture push on the skin" in printed and "films per unit of push" in printed
    assert "== friction model: derived, skin: elastic" in printed and "hysteresis" in printed


@pytest.mark.parametrize(
    ("item", "message"),
    [
        ("wod.correlation_length_m=1e-4", "no material 'wod' (known: aluminum, resin, wood)"),
        ("wood.ra_m=1e-6", "FIELD must be one of roughness_rms_m, correlation_length_m"),
        ("wood.correlation_length_m=-1", "Texture.correlation_length_m must be > 0"),
        ("wood.roughness_rms_m=x", "'x' is not a number"),
        ("wood.roughness_rms_m=1_0e-6", "underscores are not accepted"),
        ("woodcorr", "write MATERIAL.FIELD=VALUE"),
    ],
)
def test_bench_texture_refuses_a_bad_texture_item_naming_it(item, message, monkeypatch, capsys):
    main = _script("bench_texture", monkeypatch).main
    with pytest.raises(SystemExit):
        main(["--texture", item])
    err = capsys.readouterr().err.splitlines()[-1]
    assert f"--texture {item!r}" in err and message in err


def test_bench_texture_sets_a_materials_texture_and_leaves_the_others(monkeypatch):
    module = _script("bench_texture", monkeypatch)
    base = module.synth.SynthConfig()
    cfg = module.with_texture(base, ["wood.correlation_length_m=5e-5"])
    assert cfg.materials["wood"].texture.correlation_length_m == 5e-5
    assert cfg.materials["wood"].texture.periodic == base.materials["wood"].texture.periodic
    assert cfg.materials["resin"] == base.materials["resin"]
    assert cfg.materials["aluminum"] == base.materials["aluminum"]


def test_bench_texture_measures_a_set_configuration_at_its_own_post_gain(monkeypatch, capsys):
    """``--set`` measures that configuration at the films' gain the gain rule sizes for it
    (as calibrate --whatif does), unless ``--set pvdf.post_gain`` holds one; a
    configuration no gain fits ends with one line."""
    module = _script("bench_texture", monkeypatch)
    from synth.calibration import gain
    from synth.calibration.settings import CalibrationError

    seen, sized = [], []

    def sized_gain(config):
        sized.append(config.pvdf.feedback_resistance_ohm)
        if config.pvdf.feedback_resistance_ohm == 1e6:
            raise CalibrationError("no post-gain from 0.1 up keeps the worst PVDF transient")
        return 1.2, 5.0

    def measure(config, speeds, seeds, force_n, margin_m):
        seen.append(config.pvdf)
        table = {m: {v: 1e-3 for v in speeds} for m in module.synth.MATERIAL_NAMES}
        return table, table

    monkeypatch.setattr(gain, "sized_gain", sized_gain)
    monkeypatch.setattr(module, "measure", measure)
    assert module.main(["--set", "pvdf.feedback_resistance_ohm=1.8e6"]) == 0
    assert capsys.readouterr().out.startswith("films' post-gain 5\n")
    assert (seen[-1].feedback_resistance_ohm, seen[-1].post_gain) == (1.8e6, 5.0)
    argv = ["--set", "pvdf.feedback_resistance_ohm=1.8e6", "--set", "pvdf.post_gain=2"]
    assert module.main(argv) == 0
    assert seen[-1].post_gain == 2.0 and sized == [1.8e6]
    with pytest.raises(SystemExit, match=r"^--set: no post-gain from 0.1 up keeps"):
        module.main(["--set", "pvdf.feedback_resistance_ohm=1e6"])


def test_bench_steady_compares_the_steady_stretches_with_the_pads_position(monkeypatch, capsys):
    """On simulated trials the finder's stretches keep clear of the edges the pad's axis
    crosses (its 0.3 s gap runs from the films' transients, which the crossings lie
    among); the table has one row per material; a bad count is refused by name."""
    module = _script("bench_steady", monkeypatch)
    res = module.measure(1, 1.0, 10.0)
    assert set(res) == {"resin", "wood", "aluminum"}
    for row in res.values():
        assert row["trials"] == 12 and 0 < row["found"] <= 12
        assert row["min_crossing_gap_s"] >= 0.2
        assert 0.2 <= row["mean_length_s"] <= 2.0
        assert 0 <= row["overlapping_at_end"] <= row["overlapping"] <= row["found"]
    assert module.main(["--seeds", "1"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert len(out) == 2 + 3 and out[2].startswith("resin")
    err = _fails(module.main, ["--seeds", "0"], capsys)
    assert "--seeds must be at least 1" in err


def test_embedding_probe_scores_what_an_embedding_holds(monkeypatch):
    """A planted embedding: one dimension per shape index, nothing of the material; the
    shape's 1-NN is perfect, the material's and the class's stay near their chance."""
    probe = _script("embedding_probe", monkeypatch).probe
    rng = np.random.default_rng(0)
    shapes_, materials = ("circle", "square", "moon"), ("resin", "wood", "aluminum")
    classes = np.array([f"{s}/{m}" for s in shapes_ for m in materials for _ in range(20)])
    shape_index = np.array([shapes_.index(c.split("/")[0]) for c in classes])
    embedding = np.column_stack([10.0 * shape_index, rng.normal(size=classes.size)])
    scores = probe(embedding, classes)
    assert scores["shape"][0] == 1.0
    assert scores["material"][1] == pytest.approx(59 / 179)
    assert scores["material"][0] < 0.5 and scores["class"][0] < 0.5, scores


def test_embedding_probe_prints_each_methods_row_and_refuses_one_without_embedding(
    monkeypatch, capsys
):
    data = make_dataset(trials_per_class=4, shapes=("circle", "square", "moon"), n_samples=500)
    monkeypatch.setattr(synth.store, "load_dataset", lambda path: data)
    main = _script("embedding_probe", monkeypatch).main
    err = _fails(main, ["--data", "tiny", "--methods", "CNN"], capsys)
    assert "error: --methods CNN has no embedding to probe" in err
    assert main(["--data", "tiny", "--methods", "AFOP-ML"]) == 0
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if line.startswith("| AFOP-ML |"))
    cells = row.strip("|").split("|")
    assert len(cells) == 5
    assert float(cells[3].split()[0]) > 0.9, row  # the synthetic materials are separable


def test_bench_methods_refuses_a_negative_latency_count_naming_it(monkeypatch, capsys):
    main = _script("bench_methods", monkeypatch).main
    err = _fails(main, ["--data", "unused", "--latency", "-1"], capsys)
    assert "error: --latency must be >= 0; got -1" in err


def test_bench_friction_models_prints_the_models_side_by_side(monkeypatch, tmp_path, capsys):
    module = _script("bench_friction_models", monkeypatch)
    records = [
        {"record": "accuracy", "way": 5, "shot": 1, "condition": None, "accuracy": 0.9},
        {"record": "accuracy", "way": 5, "shot": 1, "condition": "f1s10", "accuracy": 0.8},
    ]
    assert module._accuracy(records, 5, 1) == 0.9
    assert module._accuracy(records, 5, 1, "f1s10") == 0.8
    with pytest.raises(KeyError, match="36-way 1-shot"):
        module._accuracy(records, 36, 1)
    import json

    seen = []

    def measure(out, model, perturbation):
        seen.append((model, perturbation))
        return {"generate_paper_s": None if model == "shared" else 61.0, "closed_D": 8}

    monkeypatch.setattr(module, "measure", measure)
    out = tmp_path / "table.json"
    assert module.main(["--out", str(tmp_path / "fm"), "--json", str(out)]) == 0
    assert seen == [("shared", False), ("derived", False), ("derived+viscoelastic", False)]
    printed = capsys.readouterr().out.splitlines()
    assert printed[0].split() == ["shared", "derived", "derived+viscoelastic"]
    assert printed[1].split()[-3:] == ["reused", "61.0", "61.0"]
    assert printed[2].split()[-3:] == ["8", "8", "8"] and len(printed) == 3
    assert json.loads(out.read_text())["derived"]["generate_paper_s"] == 61.0
    seen.clear()
    assert module.main(["--out", str(tmp_path / "fm"), "--models", "derived+viscoelastic"]) == 0
    assert seen == [("derived+viscoelastic", False)]


def test_bench_friction_models_sensitivity_moves_each_free_input(monkeypatch, capsys):
    import synth
    from synth import tribology
    from synth.materials import MATERIALS

    module = _script("bench_friction_models", monkeypatch)
    rows = dict(module.sensitivity())
    finger = synth.SynthConfig().finger
    shipped = [tribology.derived_law(MATERIALS[m], finger).kinetic for m in synth.MATERIAL_NAMES]
    assert rows.pop("as shipped") == pytest.approx(shipped, abs=1e-4)
    assert len(rows) == 10
    assert rows["resin at PLA's 1.15: 150 kPa"][0] == pytest.approx(1.15, abs=1e-9)
    tau = [rows[f"interfacial shear stress (kPa) {k}"] for k in (20, 100, 200)]
    for material in range(3):  # more shear stress, more friction on every surface
        assert tau[0][material] < shipped[material] < tau[1][material] < tau[2][material]
    assert module.main(["--sensitivity"]) == 0
    assert len(capsys.readouterr().out.splitlines()) == 12


def test_bench_head_shipped_head_predicts_as_the_step_by_step_reference(monkeypatch, capsys):
    bench = _script("bench_head", monkeypatch)
    rows = bench.measure(episodes=6, rounds=1, steps=40, seed=3)
    cosine = [r for r in rows if r["head"] == "cosine"]
    assert [(r["way"], r["shot"]) for r in cosine] == list(bench.SHAPES)
    assert all(r["predictions_differing"] == 0 and r["predictions"] > 0 for r in cosine), rows
    mlp = [r for r in rows if r["head"] == "mlp"]
    assert [(r["way"], r["shot"]) for r in mlp] == list(bench.SHAPES)
    # Rounding may flip a near-tie of the MLP head (see the script's docstring).
    assert all(r["predictions_differing"] <= 0.01 * r["predictions"] for r in mlp), rows
    assert "--steps must be at least 1" in _fails(bench.main, ["--steps", "0"], capsys)


def test_bench_head_mlp_fine_tuning_labels_as_the_autograd_path(monkeypatch):
    import torch

    from models.afo_mlp import adapt_mlp_head

    bench = _script("bench_head", monkeypatch)
    mlp = bench.random_mlp(16, seed=2)
    features, support, query, truth = bench.episodes_of(5, 2, 24, seed=4, dim=16)
    x = torch.as_tensor(features)
    kw = dict(steps=30, lr=5e-3, lam=0.1, alpha=10.0)
    shipped = adapt_mlp_head(x, support, query, mlp, chunk=7, **kw)
    reference = bench.reference_mlp_head(x, support, query, mlp, **kw)
    assert (shipped != reference).mean() <= 0.01
    untrained = adapt_mlp_head(x, support, query, mlp, chunk=7, **{**kw, "steps": 0})
    assert (shipped != untrained).any()  # the steps change the labels
    assert 0.3 < (shipped == truth).mean() < 1.0


def test_bench_trainers_times_both_paths_on_the_same_episodes(monkeypatch, capsys):
    bench = _script("bench_trainers", monkeypatch)
    rows = bench.measure(episodes=4, rounds=1, seed=1, cells=((5, 1, 3, 3e-2), (5, 2, 3, 3e-2)))
    assert [(r["network"], r["way"], r["shot"]) for r in rows] == [
        (n, w, s) for n in ("BiLSTM", "AFO-MLP-ML") for w, s in ((5, 1), (5, 2))
    ]
    for r in rows:
        assert r["autograd_ms_per_episode"] > 0 and r["shipped_ms_per_episode"] > 0
        assert r["predictions"] == 4 * 5 * 2
        assert r["predictions_differing"] <= 0.01 * r["predictions"], rows
    assert "--rounds must be at least 1" in _fails(bench.main, ["--rounds", "0"], capsys)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--twin-truths", "0"], "--twin-truths must be at least 1"),
        (["--truths", "3", "--twin-truths", "4"], "--twin-truths (4) must not exceed --truths (3)"),
    ],
)
def test_bench_calibrate_names_a_bad_twin_check_size(argv, message, monkeypatch, capsys):
    main = _script("bench_calibrate", monkeypatch).main
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 2
    assert message in capsys.readouterr().err
