"""Interpretability (paper Section V-D): sensor shares of the selected features, a t-SNE of
the closed-set top-D features and the paper's three indicators of Fig. 7, and
:func:`analyse`, which produces them (with the D-scan figure's data) from the records of
the closed-set AFOP-ML fit the protocols evaluated.

Indicator definitions (computed on the 2-D t-SNE embedding, as the paper's figure):

- ``nn1_shape_accuracy``: leave-one-out 1-nearest-neighbour accuracy of the *shape* label
  (Euclidean distance in the embedding, the point itself excluded). 1 = every trial's
  nearest neighbour has its shape; chance is about 1/12.
- ``mix_sil``: a 0-1 material-mixing score. Within each shape's points, the silhouette
  coefficient of the *material* labels is computed (scikit-learn, Euclidean); ``s`` is the
  trial-weighted mean over shapes. ``mix_sil = 1 - clip(s, 0, 1)``: 1 when materials do
  not form sub-clusters inside a shape cluster (s <= 0), 0 when every material is a
  perfectly separated sub-cluster (s = 1). Higher = more material-invariant.
- ``dgi`` (Distance to Geometric Impostor): for each trial, ``b`` = distance to its
  nearest *geometric impostor* (a trial of the same material but a different shape) and
  ``a`` = distance to its nearest trial of the same shape but a different material;
  ``dgi`` is the median over trials of ``b / a``. It compares the nearest cross-material
  neighbour of a trial's own geometry with the nearest same-material neighbour of
  another geometry: ``dgi > 1`` means a trial's other-material twins lie nearer than
  anything sharing its material (materials mix inside the shape clusters; geometry, not
  material, organises the space), ``dgi < 1`` means material pulls trials together more
  than geometry does. Scale-free; equal to (shape-cluster separation) / (within-cluster
  spacing) when materials are randomly mixed inside compact, well-separated shape
  clusters. It does not see material sub-clusters inside a shape cluster as long as
  they are nearer to each other than to other shapes: that is what ``mix_sil`` measures.
  Trials without a same-shape other-material or a same-material other-shape trial are
  skipped.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from tactile_synth.validation import check_int

if TYPE_CHECKING:
    from synth import Dataset

    from .engine import Features
    from .results import Record


def sensor_shares(selected: Sequence[int], feature_names: Sequence[str]) -> tuple[float, float]:
    """(PVDF share, SG share) among the ``selected`` feature indices.

    Feature names are ``<channel>.<domain>.<statistic>``; channels ``pvdf*`` and ``sg*``.
    """
    sel = [int(i) for i in selected]
    if not sel:
        raise ValueError("selected must hold at least one feature index")
    channels = [feature_names[i].split(".", 1)[0] for i in sel]
    pvdf = sum(c.startswith("pvdf") for c in channels)
    sg = sum(c.startswith("sg") for c in channels)
    return pvdf / len(sel), sg / len(sel)


def tsne_embedding(features: np.ndarray, *, seed: int) -> np.ndarray:
    """2-D t-SNE of ``features`` ``(n, D)`` -> ``(n, 2)``, deterministic for a seed.

    Features are standardised per column first (D-dimensional top-D features have
    different units); perplexity is 30 or less for small n.
    """
    from sklearn.manifold import TSNE

    x = np.asarray(features, dtype=np.float64)
    if x.ndim != 2 or x.shape[0] < 5:
        raise ValueError(f"features must have shape (n >= 5, D); got {x.shape}")
    check_int("seed", seed, minimum=0)
    std = x.std(axis=0)
    x = (x - x.mean(axis=0)) / np.where(std > 0, std, 1.0)
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
class TsneIndicators:
    """The paper's Fig. 7 indicators (definitions in the module docstring)."""

    nn1_shape_accuracy: float
    mix_sil: float
    dgi: float


def _pairwise(emb: np.ndarray) -> np.ndarray:
    d = np.sqrt(((emb[:, None, :] - emb[None, :, :]) ** 2).sum(-1))
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


def geometric_impostor_ratio(emb: np.ndarray, shape: np.ndarray, material: np.ndarray) -> float:
    """DGI: median over trials of (distance to the nearest same-material trial of another
    shape) / (distance to the nearest same-shape trial of another material). NaN when no
    trial has both kinds of neighbour."""
    shape = np.asarray(shape)
    material = np.asarray(material)
    d = _pairwise(np.asarray(emb, dtype=np.float64))
    same_shape = shape[:, None] == shape[None, :]
    same_material = material[:, None] == material[None, :]
    a = np.where(same_shape & ~same_material, d, np.inf).min(axis=1)
    b = np.where(same_material & ~same_shape, d, np.inf).min(axis=1)
    ok = np.isfinite(a) & np.isfinite(b) & ((a > 0) | (b > 0))
    if not ok.any():
        return float("nan")
    with np.errstate(divide="ignore"):
        ratio = b[ok] / a[ok]  # a == 0 < b: a twin on top of the trial, ratio inf
    return float(np.median(ratio))


def tsne_indicators(emb: np.ndarray, shape: np.ndarray, material: np.ndarray) -> TsneIndicators:
    """All three indicators for an embedding ``(n, 2)`` with per-trial labels ``(n,)``."""
    shape = np.asarray(shape)
    material = np.asarray(material)
    return TsneIndicators(
        nn1_shape_accuracy=nn1_accuracy(emb, shape),
        mix_sil=mixing_silhouette(emb, shape, material),
        dgi=geometric_impostor_ratio(emb, shape, material),
    )


@dataclass(frozen=True)
class Artefacts:
    """In-memory results behind Fig. 7 and the D-scan figure (not in results.json rows).

    dscan: the closed-set AFOP-ML fit's D-scan (``D``, ``mean``, ``ci95`` lists of its
    ``dscan`` record) or None; chosen_d: that fit's D; emb: ``(n, 2)`` t-SNE of the
    closed-set test half in that fit's top-D features; shape, material: ``(n,)`` labels;
    indicators: the three Fig. 7 indicators; reference_episodes: episodes per way of the
    reference curve.
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
    from .protocols.closed_set import PROTOCOL
    from .results import select, tsne_record
    from .splits import split_halves

    sel = select(records, "selection", protocol=PROTOCOL, fold=None)
    if len(sel) != 1 or sel[0].get("selected") is None:
        raise ValueError(
            "the interpretability analysis needs the closed-set AFOP-ML fit's selection "
            f"record with its selected features; got {len(sel)} closed-set selection "
            f"record(s){' without selected' if len(sel) == 1 else ''}"
        )
    chosen_d = int(sel[0]["D"])
    selected = np.asarray(sel[0]["selected"], dtype=np.intp)
    scans = select(records, "dscan", protocol=PROTOCOL, fold=None)
    dscan = {k: list(scans[0][k]) for k in ("D", "mean", "ci95")} if scans else None
    test = split_halves(data.label, seed=seed)[1]
    top = features.of(data)[test][:, selected]
    emb = tsne_embedding(top, seed=seed)
    ind = tsne_indicators(emb, data.shape[test], data.material[test])
    out: list[Record] = [
        tsne_record(
            protocol=PROTOCOL,
            D=chosen_d,
            nn1_shape_accuracy=ind.nn1_shape_accuracy,
            mix_sil=ind.mix_sil,
            dgi=ind.dgi,
        )
    ]
    art = Artefacts(
        dscan=dscan,
        chosen_d=chosen_d,
        emb=emb,
        shape=np.asarray(data.shape[test]),
        material=np.asarray(data.material[test]),
        indicators={
            "nn1_shape_accuracy": ind.nn1_shape_accuracy,
            "mix_sil": ind.mix_sil,
            "dgi": ind.dgi,
        },
        reference_episodes=episodes,
    )
    return out, art
