"""Cross-shape / cross-material splits and interpretability indicators."""

from __future__ import annotations

import numpy as np
import pytest

from benchmark.interpret import (
    geometric_impostor_ratio,
    mixing_silhouette,
    nn1_accuracy,
    sensor_shares,
    tsne_embedding,
    tsne_indicators,
)
from benchmark.splits import (
    CROSS_SHAPE_FOLDS,
    CURVED_SHAPES,
    condition_name,
    cross_material_split,
    cross_material_splits,
    cross_shape_split,
    cross_shape_splits,
    parse_condition,
)
from shapes import SHAPE_NAMES
from synth import MATERIAL_NAMES
from tests.synthetic_data import make_dataset


@pytest.fixture(scope="module")
def data():
    return make_dataset(trials_per_class=2, n_samples=64)


def test_cross_shape_folds_partition_the_shapes():
    flat = [s for f in CROSS_SHAPE_FOLDS for s in f]
    assert len(CROSS_SHAPE_FOLDS) == 3
    assert all(len(f) == 4 for f in CROSS_SHAPE_FOLDS)
    assert sorted(flat) == sorted(SHAPE_NAMES)
    # Deliberate balance: every fold tests >= 1 curved and >= 1 polygonal outline, and
    # every fold's training side keeps >= 2 curved outlines.
    for f in CROSS_SHAPE_FOLDS:
        assert 1 <= len(CURVED_SHAPES & set(f)) <= 2
        assert len(CURVED_SHAPES - set(f)) >= 2


def test_cross_shape_splits_disjoint_and_cover(data):
    test_union = np.zeros(len(data), dtype=bool)
    for split in cross_shape_splits(data):
        assert not np.any(split.train & split.test)
        assert np.all(split.train | split.test)
        assert set(data.shape[split.test]) == set(split.test_values)
        assert not set(data.shape[split.train]) & set(split.test_values)
        assert set(data.material[split.train]) == set(MATERIAL_NAMES)
        assert np.unique(data.label[split.test]).size == 12
        assert np.unique(data.label[split.train]).size == 24
        assert not set(data.label[split.train]) & set(data.label[split.test])
        test_union |= split.test
    assert np.all(test_union)  # every trial is tested in exactly one fold


def test_cross_material_splits_disjoint_and_cover(data):
    seen_train = []
    for split in cross_material_splits(data):
        assert not np.any(split.train & split.test)
        assert np.all(split.train | split.test)
        assert set(data.material[split.train]) == {split.fold}
        assert split.fold not in set(data.material[split.test])
        assert np.unique(data.label[split.train]).size == 12
        assert np.unique(data.label[split.test]).size == 24
        seen_train.append(split.fold)
    assert seen_train == list(MATERIAL_NAMES)


def test_split_arguments_are_validated(data):
    with pytest.raises(ValueError, match=r"fold must be in 0\.\.2"):
        cross_shape_split(data, 3)
    with pytest.raises(ValueError, match="train_material must be one of"):
        cross_material_split(data, "steel")


def test_condition_names_round_trip():
    name = condition_name(1.4, 6.0)
    assert name == "force=1.4N,speed=6mm/s"
    assert parse_condition(name) == (1.4, 6.0)
    assert parse_condition("pooled") is None


def test_sensor_shares():
    names = ["pvdf1.time.rms", "pvdf2.dwt.cD2.energy", "sg1.time.mean", "sg2.time.max"]
    assert sensor_shares([0, 1, 2], names) == pytest.approx((2 / 3, 1 / 3))
    assert sensor_shares([3], names) == (0.0, 1.0)
    with pytest.raises(ValueError):
        sensor_shares([], names)


def _clusters(mixed: bool, seed: int = 0, per: int = 5):
    """12 well-separated shape clusters of 3 materials x ``per`` points; materials either
    interleaved (mixed) or in separate sub-clusters."""
    rng = np.random.default_rng(seed)
    pts, shp, mat = [], [], []
    for s_i, s in enumerate(SHAPE_NAMES):
        centre = np.array([np.cos(s_i), np.sin(s_i)]) * 100 + s_i * 5
        for m_i, m in enumerate(MATERIAL_NAMES):
            off = np.zeros(2) if mixed else np.array([m_i * 6.0, 0.0])
            for _ in range(per):
                pts.append(centre + off + rng.normal(0, 1.0, 2))
                shp.append(s)
                mat.append(m)
    return np.array(pts), np.array(shp), np.array(mat)


def test_indicators_on_mixed_clusters():
    emb, shp, mat = _clusters(mixed=True)
    ind = tsne_indicators(emb, shp, mat)
    assert ind.nn1_shape_accuracy == 1.0
    assert ind.mix_sil > 0.8
    # Shape clusters ~100 apart, within-cluster spacing ~1: twins far nearer than impostors.
    assert ind.dgi > 10.0


def test_indicators_on_separated_materials():
    emb, shp, mat = _clusters(mixed=False, per=12)
    assert nn1_accuracy(emb, shp) == 1.0
    assert mixing_silhouette(emb, shp, mat) < 0.4
    # Material sub-clusters 6 apart inside shape clusters ~100 apart: DGI still > 1 (it
    # compares materials with geometry); mix-sil is the indicator that sees sub-clusters.
    assert geometric_impostor_ratio(emb, shp, mat) > 5.0


def test_dgi_known_answers():
    # A line: shape A at 0 (resin) and 1 (wood), shape B at 3 (resin) and 4 (wood). Every
    # trial's other-material twin is 1 away, its impostor 3 away: DGI = 3 exactly.
    emb = np.array([[0.0, 0.0], [1.0, 0.0], [3.0, 0.0], [4.0, 0.0]])
    shp = np.array(["A", "A", "B", "B"])
    mat = np.array(["resin", "wood", "resin", "wood"])
    assert geometric_impostor_ratio(emb, shp, mat) == pytest.approx(3.0)
    # Swapping the roles of shape and material inverts it; scaling leaves it unchanged.
    assert geometric_impostor_ratio(emb, mat, shp) == pytest.approx(1 / 3)
    assert geometric_impostor_ratio(7.5 * emb, shp, mat) == pytest.approx(3.0)
    # Material-organised space (3 material clusters, shapes mixed inside): DGI < 1.
    emb2, shp2, mat2 = _clusters(mixed=True)
    assert geometric_impostor_ratio(emb2, mat2, shp2) < 0.2
    # No trial has both kinds of neighbour: undefined.
    assert np.isnan(geometric_impostor_ratio(emb[:2], shp[:2], np.array(["r", "r"])))


def test_tsne_is_deterministic_and_keeps_clusters():
    emb, shp, _ = _clusters(mixed=True)
    # 5-D features: the 2-D clusters plus 3 informative mixtures of them.
    mix = emb @ np.random.default_rng(1).normal(size=(2, 3))
    x = np.hstack([emb, mix])
    a = tsne_embedding(x, seed=3)
    b = tsne_embedding(x, seed=3)
    assert a.shape == (x.shape[0], 2)
    np.testing.assert_array_equal(a, b)
    assert nn1_accuracy(a, shp) > 0.9
