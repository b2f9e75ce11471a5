"""Generalisation protocols: records, schema, leak checks (a spy method records what
``fit`` and ``predict_episodes`` receive), pooling across folds."""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import pytest

from benchmark import engine, fits, protocols
from benchmark.protocols import closed_set
from benchmark.results import TIMING_FIELDS, AccuracyRecord, SelectionRecord, select
from benchmark.splits import CROSS_SHAPE_FOLDS, NotApplicable, condition_name, split_halves
from models.base import FewShotMethod
from synth import CLASS_NAMES, MATERIAL_NAMES
from tests.support import record_fields
from tests.synthetic_data import make_dataset

ACCURACY_FIELDS = record_fields(AccuracyRecord)
SELECTION_FIELDS = record_fields(SelectionRecord)


class Spy(FewShotMethod):
    """Nearest-prototype on per-channel means; remembers every fit/predict input."""

    name = "AFOP-ML"
    log: ClassVar[list[dict]] = []

    def _fit(self, signals, labels, features):
        Spy.log.append(
            {
                "op": "fit",
                "labels": labels.copy(),
                "rows": _row_keys(signals),
                "seed": self.seed,
                "cells": self.test_cells_,
            }
        )
        self.D_ = 2  # what AFOP-ML exposes for selection records: a PVDF and an SG feature
        self.selected_ = np.array([0, 100])

    def _predict(self, signals, support, query, features):
        Spy.log.append({"op": "predict", "rows": _row_keys(signals)})
        x = signals.mean(axis=2)
        protos = x[support].mean(axis=2)  # (E, N, 4)
        d = ((x[query][:, :, None, :] - protos[:, None, :, :]) ** 2).sum(-1)
        return d.argmin(axis=2)


def _row_keys(signals: np.ndarray) -> set[bytes]:
    return {row.tobytes() for row in np.ascontiguousarray(signals[:, 0, :16])}


@pytest.fixture
def spy(monkeypatch):
    Spy.log = []
    monkeypatch.setattr(fits, "make_method", lambda name, seed=0: Spy(seed=seed))
    return Spy


@pytest.fixture(scope="module")
def data():
    return make_dataset(trials_per_class=4, n_samples=200, noise=0.2)


def _check_schema(records):
    for r in select(records, "accuracy"):
        assert set(r) == ACCURACY_FIELDS
        assert 0.0 <= r["accuracy"] <= 1.0 and r["ci95"] >= 0.0
        assert r["shot"] == 1 and 2 <= r["way"] <= 12
    for r in select(records, "selection"):
        assert set(r) == SELECTION_FIELDS
        assert len(r["selected"]) == r["D"]


def test_cross_shape_never_fits_on_test_shapes(data, spy):
    records = protocols.run(
        "cross-shape",
        data,
        methods=["AFOP-ML"],
        episodes=20,
        seed=1,
        features=np.zeros((len(data), 386), np.float32),
    )
    fits = [e for e in spy.log if e["op"] == "fit"]
    assert len(fits) == 3
    for fold, fit in enumerate(fits):
        test_shapes = set(CROSS_SHAPE_FOLDS[fold])
        shapes_seen = {CLASS_NAMES[c].split("/")[0] for c in np.unique(fit["labels"])}
        assert not shapes_seen & test_shapes
        assert len(shapes_seen) == 8
        train_rows = _row_keys(data.signals[~np.isin(data.shape, list(test_shapes))])
        assert fit["rows"] <= train_rows
        # The fit is told the protocol's design: 1-shot episodes of 2..12 ways.
        assert fit["cells"] == tuple((way, 1) for way in range(2, 13))
    # Episodes are drawn only from the fold's test shapes.
    preds = [e for e in spy.log if e["op"] == "predict"]
    for fold in range(3):
        test_rows = _row_keys(data.signals[np.isin(data.shape, CROSS_SHAPE_FOLDS[fold])])
        assert any(p["rows"] <= test_rows for p in preds)
    assert all(
        any(p["rows"] <= _row_keys(data.signals[np.isin(data.shape, f)]) for f in CROSS_SHAPE_FOLDS)
        for p in preds
    )
    _check_schema(records)
    acc = select(records, "accuracy")
    # 3 folds + the across-fold summary, 11 ways each.
    assert len(acc) == 4 * 11
    assert {r["fold"] for r in acc} == {0, 1, 2, None}
    pooled = [r for r in acc if r["fold"] is None]
    assert all(r["episodes"] == 60 for r in pooled)
    # Pooled mean = episode-weighted mean of the fold means.
    for r in pooled:
        per_fold = [x for x in acc if x["fold"] is not None and x["way"] == r["way"]]
        assert r["accuracy"] == pytest.approx(np.mean([x["accuracy"] for x in per_fold]))


def test_cross_material_trains_on_one_material(data, spy):
    records = protocols.run(
        "cross-material",
        data,
        methods=["AFOP-ML"],
        episodes=10,
        seed=0,
        features=np.zeros((len(data), 386), np.float32),
    )
    fits = [e for e in spy.log if e["op"] == "fit"]
    assert len(fits) == 3
    for material, fit in zip(MATERIAL_NAMES, fits, strict=True):
        mats = {CLASS_NAMES[c].split("/")[1] for c in np.unique(fit["labels"])}
        assert mats == {material}
        assert np.unique(fit["labels"]).size == 12
    _check_schema(records)
    assert {r["fold"] for r in select(records, "accuracy")} == {*MATERIAL_NAMES, None}


def _run_perturbation(data, perturbed):
    """The perturbation protocol's records for AFOP-ML on all-zero feature pools."""
    return protocols.run(
        "perturbation",
        data,
        perturbed=perturbed,
        methods=["AFOP-ML"],
        episodes=10,
        seed=0,
        features=np.zeros((len(data), 386), np.float32),
        perturbed_features=np.zeros((len(perturbed), 386), np.float32),
    )


def test_perturbation_fits_on_nominal_training_half(data, spy):
    pert = make_dataset(trials_per_class=3, n_samples=200, force_n=1.4, speed_mm_s=6.0, seed=5)
    pert2 = make_dataset(trials_per_class=3, n_samples=200, force_n=0.6, speed_mm_s=14.0, seed=6)
    both = _concat(pert, pert2)
    records = _run_perturbation(data, both)
    fits = [e for e in spy.log if e["op"] == "fit"]
    assert len(fits) == 1  # one fit, tested on every condition
    # ... and it is the closed-set fit (same seed), so its D is the closed-set D.
    assert fits[0]["seed"] == closed_set.fit_seed(0)
    assert closed_set.fit_seed(0) == engine.child_seed(0, "closed-set", "fit")
    train_idx, _test_idx = split_halves(data.label, seed=0)
    assert fits[0]["rows"] == _row_keys(data.signals[train_idx])
    assert not fits[0]["rows"] & _row_keys(both.signals)
    acc = select(records, "accuracy")
    per_condition = {condition_name(1.4, 6.0), condition_name(0.6, 14.0)}
    enrolled = {f"enrolled:{c}" for c in per_condition}
    assert {r["condition"] for r in acc} == {
        *per_condition,
        "pooled",
        "within-condition",
        *enrolled,
        "enrolled",
    }
    # The enrolled reading's pools hold nominal test-half trials (its support) beside
    # perturbed ones (its queries); no pool holds a trial the method was fitted on.
    test_rows = _row_keys(data.signals[_test_idx])
    pools = [e["rows"] for e in spy.log if e["op"] == "predict"]
    assert any(rows & test_rows and rows & _row_keys(both.signals) for rows in pools)
    assert not any(rows & fits[0]["rows"] for rows in pools)
    # The within-condition summary holds every condition's episodes: their total, and
    # (equal budgets) the mean of the conditions' accuracies; the pooled one is separate.
    within = [r for r in acc if r["condition"] == "within-condition"]
    assert sorted(r["way"] for r in within) == sorted(
        r["way"] for r in acc if r["condition"] == "pooled"
    )
    for r in within:
        cells = [x for x in acc if x["condition"] in per_condition and x["way"] == r["way"]]
        assert len(cells) == 2
        assert r["episodes"] == sum(x["episodes"] for x in cells)
        assert r["accuracy"] == pytest.approx(np.mean([x["accuracy"] for x in cells]))
        assert r["fold"] is None
    _check_schema(records)


def test_perturbation_with_one_condition_still_has_its_summary(data):
    # A custom perturbation set with one force/speed combination: the within-condition
    # records the report leads with exist and repeat that condition's figures.
    pert = make_dataset(trials_per_class=3, n_samples=200, force_n=1.4, speed_mm_s=6.0, seed=5)
    records = _run_perturbation(data, pert)
    acc = select(records, "accuracy")
    one = {r["way"]: r for r in acc if r["condition"] == condition_name(1.4, 6.0)}
    within = {r["way"]: r for r in acc if r["condition"] == "within-condition"}
    assert one and within.keys() == one.keys()
    for way, r in within.items():
        assert (r["accuracy"], r["ci95"], r["episodes"]) == (
            one[way]["accuracy"],
            one[way]["ci95"],
            one[way]["episodes"],
        )


def test_perturbation_dataset_too_small_for_any_episode_is_refused(data, spy):
    one = make_dataset(trials_per_class=1, n_samples=200, force_n=0.6, speed_mm_s=6.0, seed=5)
    with pytest.raises(ValueError, match=r"--perturbed is too small .* 2 trials per class"):
        _run_perturbation(data, one)
    assert spy.log == []  # refused before any fit


def test_generalisation_protocols_fold_any_specimens_and_materials(spy):
    few = make_dataset(trials_per_class=2, n_samples=200, shapes=("circle", "ellipse", "square"))
    tasks = protocols.get("cross-shape").tasks(
        few, None, seed=0, episodes=protocols.EpisodeBudget(5)
    )
    assert [set(few.shape[t.test.index]) for t in tasks] == [{"circle"}, {"ellipse"}, {"square"}]
    for t in tasks:
        assert not set(few.shape[t.fit.index]) & set(few.shape[t.test.index])
    two = make_dataset(trials_per_class=2, n_samples=200, materials=MATERIAL_NAMES[:2])
    tasks = protocols.get("cross-material").tasks(
        two, None, seed=0, episodes=protocols.EpisodeBudget(5)
    )
    assert [(t.fold, set(two.material[t.test.index])) for t in tasks] == [
        (MATERIAL_NAMES[0], {MATERIAL_NAMES[1]}),
        (MATERIAL_NAMES[1], {MATERIAL_NAMES[0]}),
    ]
    assert spy.log == []


def test_a_protocol_that_cannot_apply_says_what_it_needs(spy):
    one = make_dataset(trials_per_class=2, n_samples=200, shapes=("circle",))
    with pytest.raises(NotApplicable, match=r"^cross-shape needs >= 2 specimens .* this "
                       r"dataset has 1 \(circle\)$"):  # fmt: skip
        protocols.run("cross-shape", one, methods=["AFOP-ML"], episodes=5)
    one = make_dataset(trials_per_class=2, n_samples=200, materials=(MATERIAL_NAMES[0],))
    with pytest.raises(NotApplicable, match=r"^cross-material needs >= 2 materials .* this "
                       rf"dataset has 1 \({MATERIAL_NAMES[0]}\)$"):  # fmt: skip
        protocols.run("cross-material", one, methods=["AFOP-ML"], episodes=5)
    assert spy.log == []  # refused before any fit


def test_unknown_method_and_missing_perturbed(data):
    with pytest.raises(ValueError, match="method must be one of"):
        protocols.run("cross-shape", data, methods=["kNN"], episodes=5, seed=0)
    with pytest.raises(ValueError, match="perturbed"):
        protocols.run("perturbation", data, perturbed=None, methods=["AFOP-ML"], episodes=5)


@pytest.mark.slow
def test_same_seed_same_records_with_real_afop(data):
    def both():
        kw = dict(methods=["AFOP-ML"], episodes=15, seed=3)
        return protocols.run("cross-shape", data, **kw) + protocols.run(
            closed_set.Reference(), data, **kw
        )

    a, b = both(), both()

    def strip(rs):
        return [{k: v for k, v in r.items() if k not in TIMING_FIELDS} for r in rs]

    assert strip(a) == strip(b)
    _check_schema(a)
    sel = select(a, "selection")
    assert len(sel) == 3 and all(r["D"] >= 1 for r in sel)
    assert all(abs(r["pvdf_share"] + r["sg_share"] - 1) < 1e-9 for r in sel)
    ref = select(a, "accuracy", condition="reference")
    assert [r["way"] for r in ref] == list(range(2, 13))
    assert all(r["protocol"] == "closed-set" for r in ref)
    # Separable synthetic classes: well above chance on unseen shapes at 5-way.
    five = select(a, "accuracy", fold=None, way=5, protocol="cross-shape")
    assert five[0]["accuracy"] > 0.5


def _concat(a, b):
    from synth import Dataset

    return Dataset(
        signals=np.concatenate([a.signals, b.signals]),
        shape=np.concatenate([a.shape, b.shape]),
        material=np.concatenate([a.material, b.material]),
        label=np.concatenate([a.label, b.label]),
        force_n=np.concatenate([a.force_n, b.force_n]),
        speed_mm_s=np.concatenate([a.speed_mm_s, b.speed_mm_s]),
        seed=np.concatenate([a.seed, b.seed]),
    )
