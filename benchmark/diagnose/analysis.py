"""The analysis: :func:`diagnose` computes a :class:`Diagnosis` from a dataset."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from synth import SAMPLE_RATE_HZ, Dataset

from ..splits import condition_name
from . import steady
from .nearest import loo_nearest, loo_score
from .result import (
    GROUP_NAMES,
    GROUPS,
    N_CONFUSED_PAIRS,
    PVDF_CHANNELS,
    SG_CHANNELS,
    WELCH_SEGMENT_SAMPLES,
    ConfusedPair,
    Diagnosis,
    PvdfSpectra,
    SgTraces,
)

#: Channel groups: key, human-readable name, sensor kept (None: all features).


def group_columns(feature_names: Sequence[str]) -> dict[str, np.ndarray]:
    """Column indices of each channel group in a pool with ``feature_names``."""
    from models.features import sensor_of

    sensors = np.array([sensor_of(n) for n in feature_names])
    out = {}
    for key, _, sensor in GROUPS:
        out[key] = np.arange(sensors.size) if sensor is None else np.flatnonzero(sensors == sensor)
    return out


def _conditions(data: Dataset) -> tuple[np.ndarray, tuple[str, ...]]:
    """Per-trial condition names and the distinct ones sorted by (force, speed)."""
    pairs = sorted(
        {(float(f), float(s)) for f, s in zip(data.force_n, data.speed_mm_s, strict=True)}
    )
    names = np.array(
        [
            condition_name(float(f), float(s))
            for f, s in zip(data.force_n, data.speed_mm_s, strict=True)
        ]
    )
    return names, tuple(condition_name(f, s) for f, s in pairs)


def _subset_accuracy(nearest: np.ndarray, labels: np.ndarray, values: Sequence[str]) -> dict:
    """``{value: accuracy of labels among the trials with that value}`` (None if alone)."""
    hit = labels[nearest] == labels
    out: dict[str, float | None] = {}
    for v in values:
        rows = labels == v
        out[v] = float(np.mean(hit[rows])) if rows.sum() > 1 else None
    return out


def _confused_pairs(counts: np.ndarray, classes: Sequence[str], top: int) -> list[ConfusedPair]:
    """The ``top`` class pairs with the largest share of cross-pair nearest neighbours."""
    k = len(classes)
    sizes = counts.sum(axis=1)
    pairs = []
    for a in range(k):
        for b in range(a + 1, k):
            total = int(counts[a, b] + counts[b, a])
            if total:
                pairs.append((total / (sizes[a] + sizes[b]), total, a, b))
    # Most confused first; ties by class order, so the list is deterministic.
    pairs.sort(key=lambda p: (-p[0], -p[1], p[2], p[3]))
    out = []
    for share, _, a, b in pairs[:top]:
        (sa, ma), (sb, mb) = classes[a].split("/"), classes[b].split("/")
        differ = "material" if sa == sb else "shape" if ma == mb else "shape and material"
        out.append(
            ConfusedPair(
                a=classes[a],
                b=classes[b],
                a_to_b=int(counts[a, b]),
                b_to_a=int(counts[b, a]),
                share=float(share),
                differ_by=differ,
            )
        )
    return out


def confusion_counts(nearest: np.ndarray, cls: np.ndarray, classes: Sequence[str]) -> np.ndarray:
    """``(k, k)`` counts: row = a trial's class, column = its nearest neighbour's class."""
    index = {c: i for i, c in enumerate(classes)}
    ci = np.array([index[c] for c in cls], dtype=np.intp)
    counts = np.zeros((len(classes), len(classes)), dtype=np.int64)
    np.add.at(counts, (ci, ci[nearest]), 1)
    return counts


def _pvdf_spectra(
    data: Dataset, cond: np.ndarray, conditions: Sequence[str], materials: Sequence[str]
) -> PvdfSpectra:
    from scipy.signal import welch

    n_t = data.signals.shape[2]
    nper = min(WELCH_SEGMENT_SAMPLES, n_t)
    freq, _ = welch(np.zeros(n_t), fs=SAMPLE_RATE_HZ, nperseg=nper)
    psd = np.full((len(conditions), len(materials), len(PVDF_CHANNELS), freq.size), np.nan)
    for ci, c in enumerate(conditions):
        for mi, m in enumerate(materials):
            rows = np.flatnonzero((cond == c) & (data.material == m))
            if rows.size:
                x = data.signals[rows][:, PVDF_CHANNELS].astype(np.float64)
                _, p = welch(x, fs=SAMPLE_RATE_HZ, nperseg=nper, axis=-1)
                psd[ci, mi] = p.mean(axis=0)
    return PvdfSpectra(freq, psd, tuple(conditions), tuple(materials))


def _sg_traces(
    data: Dataset, cond: np.ndarray, conditions: Sequence[str], shapes: Sequence[str]
) -> SgTraces:
    n_t = data.signals.shape[2]
    shape = (len(conditions), len(shapes), len(SG_CHANNELS), n_t)
    mean, std = np.full(shape, np.nan), np.full(shape, np.nan)
    for ci, c in enumerate(conditions):
        for si, s in enumerate(shapes):
            rows = np.flatnonzero((cond == c) & (data.shape == s))
            if rows.size:
                x = data.signals[rows][:, SG_CHANNELS].astype(np.float64)
                mean[ci, si], std[ci, si] = x.mean(axis=0), x.std(axis=0)
    return SgTraces(np.arange(n_t) / SAMPLE_RATE_HZ, mean, std, tuple(conditions), tuple(shapes))


def _check_features(features: object, n: int, n_features: int) -> np.ndarray:
    x = np.asarray(features)
    if x.shape != (n, n_features):
        raise ValueError(f"features must have shape ({n}, {n_features}); got {x.shape}")
    x = x.astype(np.float64)
    if not np.all(np.isfinite(x)):
        raise ValueError("features contain NaN or inf")
    return x


def diagnose(
    data: Dataset,
    *,
    features: np.ndarray | None = None,
    source: str | None = None,
    progress: Callable[[str], None] | None = None,
    edge_gap_s: float = steady.EDGE_GAP_S,
) -> Diagnosis:
    """Diagnose ``data``: what its classes differ by, channel group by channel group
    (see :mod:`benchmark.diagnose` for what is measured).

    Parameters
    ----------
    data : synth.Dataset
        Any dataset with at least 2 trials (any classes, conditions, trial counts).
    features : numpy.ndarray, optional
        Its raw 386-feature pool ``(n, 386)`` if already computed (else extracted).
    source : str, optional
        A description kept in the result (default: ``data.attrs["source"]`` or
        ``"dataset"``).
    progress : callable, optional
        Called with a one-line message at each stage (e.g. ``print``).
    edge_gap_s : float, optional
        How far the steady-sliding stretches keep from every wall crossing the films
        show, in seconds (default 0.3; 0 to 0.9).

    Returns
    -------
    Diagnosis
        Leave-one-out 1-NN accuracies per label and channel group, per-shape, material
        and class accuracies, the most confused pairs, PVDF spectra and gauge traces.

    Examples
    --------
    >>> import numpy as np
    >>> from synth import Dataset
    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(2000) / 1000
    >>> shape = np.repeat(["circle", "square"], 6)
    >>> tone = np.where(shape == "circle", 20.0, 60.0)[:, None, None]
    >>> signals = np.sin(2 * np.pi * tone * t) + 0.1 * rng.standard_normal((12, 4, 2000))
    >>> data = Dataset(
    ...     signals=signals.astype(np.float32),
    ...     shape=shape,
    ...     material=np.array(["wood"] * 12),
    ...     label=np.repeat([0, 1], 6),
    ...     force_n=np.ones(12),
    ...     speed_mm_s=np.full(12, 10.0),
    ...     seed=np.arange(12),
    ...     classes=("circle/wood", "square/wood"),
    ... )
    >>> d = diagnose(data)
    >>> d.accuracy["shape"]["all"]
    1.0
    """
    from models.features import FEATURE_NAMES, extract
    from models.scaling import FeatureScaler

    if not isinstance(data, Dataset):
        raise ValueError(f"data must be a synth.Dataset; got {type(data).__name__}")
    n = len(data)
    if n < 2:
        raise ValueError(f"data must hold at least 2 trials to find neighbours; it holds {n}")
    say = progress or (lambda msg: None)
    if features is None:
        say(f"extracting the {len(FEATURE_NAMES)}-feature pool of {n} trials")
        raw = extract(data.signals).astype(np.float64)
    else:
        raw = _check_features(features, n, len(FEATURE_NAMES))
    # One z-scoring over the whole dataset: a diagnosis of separability, not an evaluation
    # with a held-out test set (one trial's share of the statistics is 1/n).
    z = FeatureScaler().fit_transform(raw).astype(np.float64)
    columns = group_columns(FEATURE_NAMES)

    shapes = data.specimens
    materials = data.materials
    cls = np.array([f"{s}/{m}" for s, m in zip(data.shape, data.material, strict=True)])
    classes = data.class_names
    cond, conditions = _conditions(data)
    labels = {"class": cls, "shape": data.shape, "material": data.material, "condition": cond}
    plural = {
        "class": "classes",
        "shape": "shapes",
        "material": "materials",
        "condition": "conditions",
    }

    say("finding every trial's nearest neighbour (all features, SG only, PVDF only)")
    nearest = {g: loo_nearest(z[:, columns[g]]) for g in GROUP_NAMES}

    accuracy: dict[str, dict[str, float | None] | None] = {}
    chance: dict[str, float | None] = {}
    scored: dict[str, int] = {}
    notes: dict[str, str] = {}
    for target, lab in labels.items():
        values = np.unique(lab)
        if values.size < 2:
            accuracy[target], chance[target], scored[target] = None, None, 0
            notes[target] = (
                f"not applicable: the dataset holds one {target} ({values[0]}), "
                f"so every neighbour has it"
            )
            continue
        scores = {g: loo_score(nearest[g], lab) for g in GROUP_NAMES}
        first = scores[GROUP_NAMES[0]]
        accuracy[target] = {g: s.accuracy for g, s in scores.items()}
        chance[target], scored[target] = first.chance, first.scored
        if first.scored == 0:
            notes[target] = f"not scored: each of the {values.size} {plural[target]} has one trial"
        elif first.left_out:
            notes[target] = (
                f"{first.left_out} trial(s) left out: no other trial shares their {target}"
            )

    def per_value(target: str, values: Sequence[str]) -> dict | None:
        if accuracy[target] is None:
            return None
        return {g: _subset_accuracy(nearest[g], labels[target], values) for g in GROUP_NAMES}

    per_condition = None
    if len(conditions) > 1 and accuracy["class"] is not None:
        say("class accuracy within each condition")
        per_condition = {}
        for c in conditions:
            rows = np.flatnonzero(cond == c)
            per_condition[c] = {}
            for g in GROUP_NAMES:
                if np.unique(cls[rows]).size < 2:  # one class here: nothing to tell apart
                    per_condition[c][g] = None
                    continue
                nn = loo_nearest(z[np.ix_(rows, columns[g])])
                per_condition[c][g] = loo_score(nn, cls[rows]).accuracy

    confusion = {g: confusion_counts(nearest[g], cls, classes) for g in GROUP_NAMES}
    say("PVDF spectra per material and SG mean traces per shape")
    counts = np.unique(cls, return_counts=True)[1]
    return Diagnosis(
        source=source or str(data.attrs.get("source", "dataset")),
        n_trials=n,
        complete=bool(data.attrs.get("complete", True)),
        shapes=shapes,
        materials=materials,
        conditions=conditions,
        classes=classes,
        trials_per_class=(int(counts.min()), int(counts.max())),
        n_features={g: int(columns[g].size) for g in GROUP_NAMES},
        accuracy=accuracy,
        chance=chance,
        scored=scored,
        notes=notes,
        per_shape=per_value("shape", shapes),
        per_material=per_value("material", materials),
        per_class={g: _subset_accuracy(nearest[g], cls, classes) for g in GROUP_NAMES},
        per_condition=per_condition,
        confused_pairs={
            g: _confused_pairs(confusion[g], classes, N_CONFUSED_PAIRS) for g in GROUP_NAMES
        },
        confusion=confusion,
        spectra=_pvdf_spectra(data, cond, conditions, materials),
        sg_traces=_sg_traces(data, cond, conditions, shapes),
        steady=steady.steady_diagnosis(data.signals, data.material, edge_gap_s),
    )
