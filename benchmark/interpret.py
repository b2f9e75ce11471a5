"""Interpretability (paper Section V-D): sensor shares of the selected features, a t-SNE of
the closed-set top-D features and the paper's three indicators of Fig. 7, and
:func:`analyse`, which produces them (with the D-scan figure's data) from the records of
the closed-set AFOP-ML fit the protocols evaluated.

Where the indicators are computed: the paper's caption says "t-SNE is used only for
qualitative visualization; overlaps in 2D do not necessarily imply misclassification in
the original Top-D space", so its indicators describe the top-D feature space. They are
computed there (the closed-set test-half trials in the fit's top-D features, each column
standardised, Euclidean distance: the very input of the t-SNE), and again on the 2-D
t-SNE embedding beside them, labelled as such (:class:`Indicators`, ``embedding_*``).

Indicator definitions (the same on either point set):

- ``nn1_shape_accuracy``: leave-one-out 1-nearest-neighbour accuracy of the *shape* label
  (the point itself excluded). 1 = every trial's nearest neighbour has its shape; chance
  is about 1/12.
- ``mix_sil``: a 0-1 material-mixing score. Within each shape's points, the silhouette
  coefficient of the *material* labels is computed (scikit-learn, Euclidean); ``s`` is the
  trial-weighted mean over shapes. ``mix_sil = 1 - clip(s, 0, 1)``: 1 when materials do
  not form sub-clusters inside a shape cluster (s <= 0), 0 when every material is a
  perfectly separated sub-cluster (s = 1). Higher = more material-invariant.
- ``dgi``, the paper's "ratio of cross-material to same-material neighbors" (> 1: strong
  mixing): in the k-nearest-neighbour graph of the points (:data:`DGI_K` neighbours per
  point, Euclidean), among the edges that join two points of the same shape, the number
  joining different materials divided by the number joining the same material (counts
  pooled over all points). If materials were randomly mixed within each shape, the
  ratio would be that of the pairs: with n trials per class and 3 materials, 2n / (n - 1)
  (about 2.07 for the 30 test trials per class of the paper preset); :func:`dgi_random`
  gives it for the actual labels. When each material forms its own sub-cluster inside a
  shape cluster the neighbours are same-material and the ratio falls towards 0. ``k`` =
  10: well below the 29 other trials of a point's class, so a material sub-cluster can
  fill a point's whole neighbourhood (with k >= 30 even perfectly separated materials
  would show cross-material neighbours), and enough edges per point for stable counts.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from models.features import sensor_shares
from tactile_synth.validation import check_int

from .labels import CLOSED_SET
from .results import Record, select, tsne_record
from .splits import split_halves

if TYPE_CHECKING:
    from synth import Dataset

    from .cells import Features

__all__ = [
    "DGI_K",
    "Artefacts",
    "Indicators",
    "analyse",
    "dgi",
    "dgi_random",
    "indicators",
    "mixing_silhouette",
    "nearest_neighbours",
    "nn1_accuracy",
    "sensor_shares",
    "standardise",
    "tsne_embedding",
]


#: Neighbours per point in the DGI's k-nearest-neighbour graph (see the module docstring).
DGI_K = 10


def standardise(features: np.ndarray) -> np.ndarray:
    """Each column of ``features`` ``(n, D)`` to zero mean and unit variance (constant
    columns left at zero): the top-D space the indicators and the t-SNE read (the D
    features have different units)."""
    x = np.asarray(features, dtype=np.float64)
    std = x.std(axis=0)
    return (x - x.mean(axis=0)) / np.where(std > 0, std, 1.0)


def tsne_embedding(features: np.ndarray, *, seed: int) -> np.ndarray:
    """2-D t-SNE of ``features`` ``(n, D)`` -> ``(n, 2)``, deterministic for a seed.

    Features are standardised per column first (:func:`standardise`); perplexity is 30 or
    less for small n.
    """
    from sklearn.manifold import TSNE

    x = np.asarray(features, dtype=np.float64)
    if x.ndim != 2 or x.shape[0] < 5:
        raise ValueError(f"features must have shape (n >= 5, D); got {x.shape}")
    check_int("seed", seed, minimum=0)
    x = standardise(x)
    perplexity = float(min(30.0, (x.shape[0] - 1) / 3.0))
    tsne = TSNE(
        n_components=2,
        perplexity=perplexity,
        init="pca",
        random_state=seed,
        learning_rate="auto",
        n_jobs=1,
    )
    return tsne.fit_transform(x)


@dataclass(frozen=True)
class Indicators:
    """The paper's Fig. 7 indicators of one point set (definitions in the module
    docstring); ``dgi_k`` the neighbours per point of the DGI's graph."""

    nn1_shape_accuracy: float
    mix_sil: float
    dgi: float
    dgi_k: int = DGI_K


#: The former name of :class:`Indicators`.
TsneIndicators = Indicators


def _pairwise(emb: np.ndarray) -> np.ndarray:
    x = np.asarray(emb, dtype=np.float64)
    sq = (x * x).sum(axis=1)
    d = np.sqrt(np.maximum(sq[:, None] + sq[None, :] - 2.0 * (x @ x.T), 0.0))
    np.fill_diagonal(d, np.inf)
    return d


def nn1_accuracy(emb: np.ndarray, labels: np.ndarray) -> float:
    """Leave-one-out 1-NN accuracy of ``labels`` ``(n,)`` in ``emb`` ``(n, d)``."""
    d = _pairwise(np.asarray(emb, dtype=np.float64))
    nearest = np.argmin(d, axis=1)
    return float(np.mean(labels[nearest] == labels))


def mixing_silhouette(emb: np.ndarray, shape: np.ndarray, material: np.ndarray) -> float:
    """``1 - clip(s, 0, 1)`` with ``s`` the trial-weighted mean over shapes of the
    material silhouette inside each shape's points (shapes with < 2 materials or fewer
    than 3 trials are skipped; 1.0 when none qualifies)."""
    from sklearn.metrics import silhouette_score

    emb = np.asarray(emb, dtype=np.float64)
    total, weight = 0.0, 0
    for s in np.unique(shape):
        idx = np.flatnonzero(shape == s)
        mats = material[idx]
        n_mats = np.unique(mats).size
        if n_mats < 2 or idx.size <= n_mats:
            continue
        total += silhouette_score(emb[idx], mats, metric="euclidean") * idx.size
        weight += idx.size
    if weight == 0:
        return 1.0
    return float(1.0 - np.clip(total / weight, 0.0, 1.0))


def nearest_neighbours(points: np.ndarray, k: int) -> np.ndarray:
    """``(n, k)`` indices of each point's ``k`` nearest other points (Euclidean; equal
    distances broken by the lower index)."""
    d = _pairwise(points)
    k = check_int("k", k, minimum=1)
    if k >= d.shape[0]:
        raise ValueError(f"k must be below the number of points ({d.shape[0]}); got {k}")
    return np.argsort(d, axis=1, kind="stable")[:, :k]


def _dgi_ratio(cross: float, same: float) -> float:
    if same > 0:
        return float(cross / same)
    return float("inf") if cross > 0 else float("nan")


def dgi(points: np.ndarray, shape: np.ndarray, material: np.ndarray, *, k: int = DGI_K) -> float:
    """The paper's DGI: in the ``k``-nearest-neighbour graph of ``points`` ``(n, d)``,
    the number of same-shape edges joining different materials divided by the number
    joining the same material, pooled over all points. inf when no same-shape edge joins
    one material, NaN when no edge joins two points of one shape."""
    shape = np.asarray(shape)
    material = np.asarray(material)
    nb = nearest_neighbours(points, k)
    same_shape = shape[nb] == shape[:, None]
    same_material = material[nb] == material[:, None]
    return _dgi_ratio(
        float((same_shape & ~same_material).sum()), float((same_shape & same_material).sum())
    )


def dgi_random(shape: np.ndarray, material: np.ndarray) -> float:
    """The DGI that materials randomly mixed within each shape would give on average: the
    ratio of the same-shape pairs of points with different materials to those with the
    same material (2n / (n - 1) for n trials per class and 3 materials)."""
    shape = np.asarray(shape)
    material = np.asarray(material)
    cross = same = 0
    for s in np.unique(shape):
        _, counts = np.unique(material[shape == s], return_counts=True)
        total = counts.sum()
        same += int((counts * (counts - 1)).sum())
        cross += int((counts * (total - counts)).sum())
    return _dgi_ratio(cross, same)


def indicators(
    points: np.ndarray, shape: np.ndarray, material: np.ndarray, *, k: int = DGI_K
) -> Indicators:
    """All three indicators of a point set ``(n, d)`` with per-trial labels ``(n,)``."""
    shape = np.asarray(shape)
    material = np.asarray(material)
    return Indicators(
        nn1_shape_accuracy=nn1_accuracy(points, shape),
        mix_sil=mixing_silhouette(points, shape, material),
        dgi=dgi(points, shape, material, k=k),
        dgi_k=int(k),
    )


#: The former name of :func:`indicators`.
tsne_indicators = indicators


@dataclass(frozen=True)
class Artefacts:
    """In-memory results behind Fig. 7 and the D-scan figure (not in results.json rows).

    dscan: the closed-set AFOP-ML fit's D-scan (``D``, ``mean``, ``ci95`` lists of its
    ``dscan`` record) or None; chosen_d: that fit's D; emb: ``(n, 2)`` t-SNE of the
    closed-set test half in that fit's top-D features; shape, material: ``(n,)`` labels;
    indicators: the Fig. 7 indicators in the top-D space (``nn1_shape_accuracy``,
    ``mix_sil``, ``dgi``) and on the embedding (``embedding_`` + the same names), and
    ``dgi_k``, ``dgi_random``; reference_episodes: episodes per way of the reference
    curve.
    """

    dscan: Mapping[str, Sequence[float]] | None
    chosen_d: int
    emb: np.ndarray
    shape: np.ndarray
    material: np.ndarray
    indicators: Mapping[str, float]
    reference_episodes: int


def analyse(
    data: Dataset,
    records: Sequence[Mapping[str, Any]],
    *,
    features: Features,
    episodes: int,
    seed: int,
) -> tuple[list[Record], Artefacts]:
    """The interpretability analysis of the closed-set AFOP-ML fit of ``records`` (the
    protocols' records of a run with ``seed``: the fit's ``selection`` record, with its
    ``selected`` features, and its ``dscan`` record): the t-SNE of the closed-set test
    half in its top-D features with the indicators (the returned ``tsne`` record), and
    the artefacts of the D-scan and t-SNE figures. Nothing is fitted here, so the D-scan,
    the t-SNE and the report's closed-set D and shares all describe one fit.

    episodes: episodes per way of the reference curve (for the figure notes).
    """
    sel = select(records, "selection", protocol=CLOSED_SET, fold=None)
    if len(sel) != 1 or sel[0].get("selected") is None:
        raise ValueError(
            "the interpretability analysis needs the closed-set AFOP-ML fit's selection "
            f"record with its selected features; got {len(sel)} closed-set selection "
            f"record(s){' without selected' if len(sel) == 1 else ''}"
        )
    chosen_d = int(sel[0]["D"])
    selected = np.asarray(sel[0]["selected"], dtype=np.intp)
    scans = select(records, "dscan", protocol=CLOSED_SET, fold=None)
    dscan = {k: list(scans[0][k]) for k in ("D", "mean", "ci95")} if scans else None
    test = split_halves(data.label, seed=seed)[1]
    top = features.of(data)[test][:, selected]
    shape, material = data.shape[test], data.material[test]
    emb = tsne_embedding(top, seed=seed)
    space = indicators(standardise(top), shape, material)
    flat = indicators(emb, shape, material)
    values = {
        "nn1_shape_accuracy": space.nn1_shape_accuracy,
        "mix_sil": space.mix_sil,
        "dgi": space.dgi,
        "dgi_k": space.dgi_k,
        "dgi_random": dgi_random(shape, material),
        "embedding_nn1_shape_accuracy": flat.nn1_shape_accuracy,
        "embedding_mix_sil": flat.mix_sil,
        "embedding_dgi": flat.dgi,
    }
    out: list[Record] = [tsne_record(protocol=CLOSED_SET, D=chosen_d, **values)]
    art = Artefacts(
        dscan=dscan,
        chosen_d=chosen_d,
        emb=emb,
        shape=np.asarray(shape),
        material=np.asarray(material),
        indicators=values,
        reference_episodes=episodes,
    )
    return out, art
