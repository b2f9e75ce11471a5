"""Cross-shape / cross-material splits and interpretability indicators."""

from __future__ import annotations

import numpy as np
import pytest

from benchmark.interpret import (
    DGI_K,
    dgi,
    dgi_random,
    indicators,
    mixing_silhouette,
    nearest_neighbours,
    nn1_accuracy,
    sensor_shares,
    tsne_embedding,
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
    emb, shp, mat = _clusters(mixed=True, per=12)
    ind = indicators(emb, shp, mat)
    assert ind.nn1_shape_accuracy == 1.0 and ind.dgi_k == DGI_K
    assert ind.mix_sil > 0.8
    # Materials mixed at random inside compact shape clusters: the DGI lies near what
    # random mixing gives (2n/(n-1) = 24/11 with n = 12 per class), far from 0.
    assert dgi_random(shp, mat) == pytest.approx(24 / 11)
    assert 1.5 < ind.dgi < 3.0


def test_indicators_on_separated_materials():
    emb, shp, mat = _clusters(mixed=False, per=12)
    assert nn1_accuracy(emb, shp) == 1.0
    assert mixing_silhouette(emb, shp, mat) < 0.4
    # Material sub-clusters 6 apart (noise sd 1) inside shape clusters ~100 apart: nearly
    # every one of a trial's 10 nearest neighbours is among the 11 others of its class, so
    # the DGI lies near 0, far below random mixing's 24/11.
    assert dgi(emb, shp, mat) < 0.1


def _ring(per_shape: int, shapes: int = 2) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each shape a ring of ``per_shape`` equally spaced points (shapes far apart), the
    materials going round a, b, c, a, b, c, ..."""
    pts, shp, mat = [], [], []
    for s in range(shapes):
        for i in range(per_shape):
            angle = 2 * np.pi * i / per_shape
            pts.append([1000.0 * s + np.cos(angle), np.sin(angle)])
            shp.append(f"S{s}")
            mat.append("abc"[i % 3])
    return np.array(pts), np.array(shp), np.array(mat)


def test_dgi_known_answers():
    # On a ring with the materials going round a, b, c: a point's 2 nearest neighbours
    # (i +- 1) are of other materials, the next 2 (i +- 2) too, the next 2 (i +- 3) of
    # its own: k = 2 or 4 gives no same-material edge (inf), k = 6 gives 4 / 2 = 2.
    pts, shp, mat = _ring(30)
    assert dgi(pts, shp, mat, k=4) == np.inf
    assert dgi(pts, shp, mat, k=6) == pytest.approx(2.0)
    # k = 8: i +- 1, 2, 4 cross, i +- 3 same: 6 / 2 = 3.
    assert dgi(pts, shp, mat, k=8) == pytest.approx(3.0)
    # Scaling or moving the points changes no neighbour.
    assert dgi(7.5 * pts + 3.0, shp, mat, k=6) == pytest.approx(2.0)
    # The materials grouped on the ring (a run of 10 of each): in a run, the points 0, 1, 2
    # places from its ends have 3, 2, 1 neighbours across the end: 12 cross edges per run,
    # 36 of a ring's 180: DGI = 36 / 144.
    grouped = np.array(["abc"[i // 10] for i in range(30)] * 2)
    assert dgi(pts, shp, grouped, k=6) == pytest.approx(0.25)
    assert nearest_neighbours(pts, 2)[0].tolist() == [1, 29]  # ties: the lower index first
    # No same-shape neighbour at all: undefined; one material only: no cross edge.
    lone = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    assert np.isnan(dgi(lone, np.array(["A", "B", "C"]), np.array(["a", "a", "a"]), k=1))
    assert dgi(pts, shp, np.array(["a"] * 60), k=6) == 0.0
    with pytest.raises(ValueError, match="k must be below"):
        dgi(lone, np.array(["A", "A", "A"]), np.array(["a", "b", "c"]), k=3)


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
