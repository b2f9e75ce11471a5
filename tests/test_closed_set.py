"""Closed-set protocol: split, records, honest statistics, and the CLI command."""

from __future__ import annotations

import json

import numpy as np
import pytest

from benchmark import protocols
from benchmark.protocols import closed_set
from benchmark.results import AccuracyRecord, read_results, select
from tests.support import class_signals, record_fields
from tests.synthetic_data import make_dataset

pytestmark = pytest.mark.usefixtures("one_torch_thread")


FIELDS = record_fields(AccuracyRecord)


def test_split_halves_is_a_seeded_per_class_half_split():
    labels = np.repeat(np.arange(6), [10, 10, 11, 4, 1, 2])
    train, test = closed_set.split_halves(labels, seed=3)
    assert not set(train) & set(test) and len(train) + len(test) == labels.size
    for c in range(6):
        n_tr, n_te = np.sum(labels[train] == c), np.sum(labels[test] == c)
        assert n_tr == np.sum(labels == c) // 2 and n_te >= n_tr
    again = closed_set.split_halves(labels, seed=3)
    np.testing.assert_array_equal(train, again[0])
    assert not np.array_equal(train, closed_set.split_halves(labels, seed=4)[0])


@pytest.mark.slow
@pytest.mark.parametrize(("shuffle", "expect"), [(False, "high"), (True, "chance")])
def test_accuracy_is_high_when_separable_and_chance_when_shuffled(shuffle, expect):
    noise = 0.1  # separable by construction: each class has its own frequencies
    data = make_dataset(trials_per_class=12, n_samples=400, noise=noise, shuffle_labels=shuffle)
    records = protocols.run("closed-set", data, methods=["AFOP-ML"], episodes=100, seed=0)
    acc = select(records, "accuracy")
    assert {r["protocol"] for r in records} == {"closed-set"}
    assert all(set(r) == FIELDS for r in acc)
    assert {(r["shot"], r["way"]) for r in acc} == set(closed_set.TABLE_ONE_COLUMNS)
    assert select(records, "selection")
    for r in acc:
        assert r["episodes"] == 100 and 0 <= r["ci95"] < 0.1
        if expect == "high":  # ~1 at 5-way, a little lower among 36 look-alike classes
            floor = 0.97 if r["way"] == 5 else 0.9 if r["way"] <= 12 else 0.8
            assert r["accuracy"] > floor, r
        else:
            chance = 1.0 / r["way"]
            assert abs(r["accuracy"] - chance) < max(3 * r["ci95"], 0.04), r


def test_columns_shrink_to_what_small_pools_hold():
    labels = np.repeat(np.arange(36), 2)  # 2 test trials per class: 1-shot, 1 query
    assert closed_set.columns_for(labels) == [(1, n, 1) for n in (5, 10, 12, 28, 36)]
    with pytest.raises(ValueError, match="too small"):
        protocols.run("closed-set", make_dataset(trials_per_class=1, n_samples=300), episodes=5)


def test_cli_writes_results_report_and_table(tmp_path, capsys):
    import synth
    from benchmark.cli import main

    path = tmp_path / "ds"
    config = synth.PRESETS["quick"].replace(trials_per_class=6)
    synth.generate(config, path, workers=1, progress=False, simulator=class_signals)
    out = tmp_path / "out"
    args = ["benchmark", "closed-set", "--data", str(path), "--out", str(out)]
    assert main([*args, "--methods", "AFOP-ML", "--episodes", "20"]) == 0
    records = read_results(out / "results.json")
    assert json.loads((out / "results.json").read_text()) == records
    assert (out / "report.md").read_text().startswith("# tactile-synth benchmark report")
    table = (out / "table1.md").read_text()
    assert table.splitlines()[0].startswith("| method | 1-shot 5-way")
    capsys.readouterr()
    assert main([*args, "--methods", "SVM"]) == 2
    assert "--methods must be one of" in capsys.readouterr().err
    assert main(["benchmark", "perturbation", "--data", str(path), "--out", str(out)]) == 2
    assert "--perturbed is required" in capsys.readouterr().err
