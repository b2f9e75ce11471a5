"""The example experiment end to end, small: generate it from its file (a subset of its
specimens and materials, 4 trials per class), diagnose it and run the quick benchmark
on it; the reports name its own classes, and the perturbation dataset `run` simulates
holds them too."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from benchmark.cli import main
from synth import load_dataset, store

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
CLASSES = (
    "circle/glass",
    "circle/pla_top",
    "l_bracket/glass",
    "l_bracket/pla_top",
    "gear/glass",
    "gear/pla_top",
)


def test_the_example_experiment_generates_diagnoses_and_benchmarks(tmp_path, capsys):
    lab = tmp_path / "my_lab"
    shutil.copytree(ROOT / "examples" / "my_lab", lab)
    data, diag, run = tmp_path / "data", tmp_path / "diag", tmp_path / "run"
    argv = ["generate", "--experiment", str(lab / "experiment.toml"), "--out", str(data)]
    argv += ["--trials-per-class", "4", "--shapes", "gear", "circle", "l_bracket"]
    assert main([*argv, "--materials", "pla_top", "glass"]) == 0
    assert "24 trials (6 classes x 1 condition x 4 trials)" in capsys.readouterr().out
    shutil.rmtree(lab)  # everything downstream reads the store alone
    nominal = load_dataset(data)
    assert nominal.classes == CLASSES
    assert store.read_meta(data)["classes"] == list(CLASSES)

    assert main(["inspect", str(data)]) == 0
    assert "gear/pla_top" in capsys.readouterr().out

    assert main(["diagnose", str(data), "--out", str(diag)]) == 0
    text = (diag / "diagnose.md").read_text()
    assert "| gear |" in text and "| shape | glass | pla_top |" in text
    assert json.loads((diag / "diagnose.json").read_text())["classes"] == list(CLASSES)

    argv = ["run", "--quick", "--data", str(data), "--out", str(run), "--methods", "AFOP-ML"]
    assert main(argv) == 0
    perturbed = load_dataset(run / "data" / "perturbation")
    assert perturbed.classes == CLASSES
    assert store.stored_config(run / "data" / "perturbation").synth == (
        store.stored_config(data).synth
    )
    report = (run / "report.md").read_text()
    # The class table: a row per specimen, a column per material, nominal / perturbation.
    assert "| specimen | glass | pla_top |" in report
    assert "| gear | 4 / 8 | 4 / 8 |" in report
    assert "| l_bracket | 4 / 8 | 4 / 8 |" in report
    # Every protocol ran on the dataset's own splits.
    assert "Test shapes per fold: fold 0: circle; fold 1: l_bracket; fold 2: gear." in report
    assert "### Cross-material (train on 1 material, test on the other 1)" in report
    assert "| glass |" in report and "| pla_top |" in report  # the per-fold table
    records = json.loads((run / "results.json").read_text())
    assert {r["protocol"] for r in records} >= {"closed-set", "cross-shape", "cross-material"}
