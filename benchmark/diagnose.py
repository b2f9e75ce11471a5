"""Dataset diagnosis: what a dataset's classes differ by, channel group by channel group.

:func:`diagnose` takes any :class:`synth.Dataset` (any grid: a subset of shapes or
materials, one material, several force/speed conditions, a few trials per class) and
returns a :class:`Diagnosis`:

- leave-one-out 1-nearest-neighbour (1-NN) accuracy of the class, shape, material and
  (with several conditions) force/speed condition labels, on the z-scored 386-feature pool
  restricted to each channel group: all features, strain gauges only, PVDF only;
- per-shape, per-material and per-class accuracy, per-condition class accuracy, and the
  most confused class pairs;
- the mean Welch power spectral density of the PVDF channels per material and the mean
  strain-gauge traces per shape (each per condition).

Leave-one-out 1-NN: every trial gets the label of its nearest *other* trial (Euclidean
distance between z-scored feature vectors, float64); the accuracy is the share of trials
labelled right. Distances are exact and ties go to the lowest trial index, so the result
does not depend on BLAS threads (see :func:`loo_nearest`). A trial whose label no other
trial shares can never be labelled right; it is left out of that label's score and the
note says how many were. A label with a single value in the dataset (one material) is
not applicable and is reported as such.

:func:`write_diagnosis` writes ``diagnose.md``, ``diagnose.json`` (every number),
``diagnose.npz`` (the curves: spectra and traces, readable with ``allow_pickle=False``)
and PNG figures; :func:`summary_table` is the compact text the CLI prints.
"""

from __future__ import annotations

import copy
import json
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from benchmark import steady
from shapes import SHAPE_NAMES
from synth import CHANNELS, CLASS_NAMES, MATERIAL_NAMES, SAMPLE_RATE_HZ, Dataset
from synth.atomic import check_out_dir
from synth.store import check_not_inside_a_store

from .splits import condition_name

#: Channel groups: key, human-readable name, sensor kept (None: all features).
GROUPS: tuple[tuple[str, str, str | None], ...] = (
    ("all", "all features", None),
    ("sg", "strain gauges only", "SG"),
    ("pvdf", "PVDF only", "PVDF"),
)
GROUP_NAMES: tuple[str, ...] = tuple(g for g, _, _ in GROUPS)
#: The labels whose leave-one-out 1-NN accuracy is reported.
TARGETS: tuple[str, ...] = ("class", "shape", "material", "condition")
#: How many confused class pairs each channel group lists.
N_CONFUSED_PAIRS: int = 10
#: Welch segment length of the PVDF spectra: 256 samples = 0.256 s at 1 kHz, i.e.
#: 3.9 Hz resolution and 14 half-overlapping segments averaged per 2 s trial.
WELCH_SEGMENT_SAMPLES: int = 256
PVDF_CHANNELS: tuple[int, ...] = tuple(i for i, c in enumerate(CHANNELS) if c.startswith("pvdf"))
SG_CHANNELS: tuple[int, ...] = tuple(i for i, c in enumerate(CHANNELS) if c.startswith("sg"))
#: Files :func:`write_diagnosis` writes (figures listed in :data:`FIGURES`).
MARKDOWN_NAME = "diagnose.md"
JSON_NAME = "diagnose.json"
CURVES_NAME = "diagnose.npz"
FIGURES: dict[str, str] = {
    "accuracy": "diagnose_accuracy.png",
    "confusion": "diagnose_confusion.png",
    "pvdf_spectra": "diagnose_pvdf_spectra.png",
    "sg_traces": "diagnose_sg_traces.png",
}
#: Version of the diagnose.json / diagnose.npz layout.
FORMAT_VERSION: int = 1


# -- leave-one-out nearest neighbours ----------------------------------------------------
def loo_nearest(x: np.ndarray, *, block_rows: int = 256) -> np.ndarray:
    """Index of each row's nearest other row of ``x`` ``(n, d)`` (Euclidean), ``(n,)`` intp.

    Exact and deterministic: squared distances are first computed with the fast expansion
    ``|a|^2 + |b|^2 - 2 a.b`` (float64 matrix product), whose rounding error is bounded by
    ``(d + 3) * eps * (|a|^2 + |b|^2)``; every row whose candidates within twice that bound
    of its minimum are several is re-decided on directly summed squared differences, and
    equal distances go to the lowest index. The answer therefore does not depend on how
    the BLAS library blocks or threads the product. Rows are processed ``block_rows`` at a
    time (memory ``block_rows * n`` floats).
    """
    x = np.ascontiguousarray(x, dtype=np.float64)
    if x.ndim != 2 or x.shape[0] < 2:
        raise ValueError(f"x must be a 2-D array (n >= 2, d); got shape {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError("x contains NaN or inf")
    n, d = x.shape
    sq = np.einsum("ij,ij->i", x, x)
    margin = 8.0 * (d + 3) * np.finfo(np.float64).eps  # 2 x the bound, with room
    sq_max = float(sq.max())
    nearest = np.empty(n, dtype=np.intp)
    for start in range(0, n, block_rows):
        stop = min(start + block_rows, n)
        rows = np.arange(start, stop)
        approx = sq[start:stop, None] + sq[None, :] - 2.0 * (x[start:stop] @ x.T)
        approx[rows - start, rows] = np.inf
        best = approx.min(axis=1)
        tol = margin * (sq[start:stop] + sq_max)
        candidate = approx <= (best + tol)[:, None]
        nearest[start:stop] = np.argmax(candidate, axis=1)  # the first (only) candidate
        for r in np.flatnonzero(candidate.sum(axis=1) > 1):
            cols = np.flatnonzero(candidate[r])
            diff = x[cols] - x[start + r]
            exact = (diff * diff).sum(axis=1)
            nearest[start + r] = cols[int(np.argmin(exact))]  # argmin: first of equals
    return nearest


@dataclass(frozen=True)
class LooScore:
    """Leave-one-out 1-NN score of one label.

    accuracy: share of scored trials whose nearest neighbour has their label (``None``
    when no trial can be scored); chance: expected accuracy of a uniformly random other
    trial, ``mean((n_label - 1) / (n - 1))`` over the scored trials; scored: trials
    scored; left_out: trials left out because no other trial shares their label.
    """

    accuracy: float | None
    chance: float | None
    scored: int
    left_out: int


def loo_score(nearest: np.ndarray, labels: np.ndarray) -> LooScore:
    """Score ``labels`` ``(n,)`` given each trial's nearest neighbour ``nearest`` ``(n,)``."""
    labels = np.asarray(labels)
    _, inverse, counts = np.unique(labels, return_inverse=True, return_counts=True)
    per_trial = counts[inverse]
    scored = per_trial > 1
    k = int(scored.sum())
    if k == 0:
        return LooScore(None, None, 0, int(labels.size))
    hit = labels[nearest] == labels
    chance = float(np.mean((per_trial[scored] - 1) / (labels.size - 1)))
    return LooScore(float(np.mean(hit[scored])), chance, k, int(labels.size - k))


# -- the result --------------------------------------------------------------------------
@dataclass(frozen=True)
class ConfusedPair:
    """Two classes whose trials often have their nearest neighbour in the other class.

    a_to_b: trials of ``a`` whose nearest neighbour is of class ``b`` (and ``b_to_a``
    conversely); share: ``(a_to_b + b_to_a) / (trials of a + trials of b)``; differ_by:
    ``"material"`` (same shape), ``"shape"`` (same material) or ``"shape and material"``.
    """

    a: str
    b: str
    a_to_b: int
    b_to_a: int
    share: float
    differ_by: str


@dataclass(frozen=True)
class PvdfSpectra:
    """Mean Welch power spectral density of the PVDF channels.

    freq_hz ``(F,)``; psd_v2_per_hz ``(n_conditions, n_materials, 2, F)`` in V^2/Hz at
    the DAQ, channel order ``channels``; a (condition, material) cell without trials is NaN.
    """

    freq_hz: np.ndarray
    psd_v2_per_hz: np.ndarray
    conditions: tuple[str, ...]
    materials: tuple[str, ...]
    channels: tuple[str, ...] = tuple(CHANNELS[i] for i in PVDF_CHANNELS)

    def summary(self) -> dict[str, dict[str, dict[str, dict[str, float | None]]]]:
        """``{condition: {material: {channel: {"rms_v", "centroid_hz", "peak_hz"}}}}``.

        rms_v: square root of the PSD integrated above 0 Hz; centroid_hz: the
        PSD-weighted mean frequency; peak_hz: the frequency of the largest PSD bin above 0 Hz.
        """
        f = self.freq_hz
        df = float(f[1] - f[0]) if f.size > 1 else 1.0
        out: dict[str, dict[str, dict[str, dict[str, float | None]]]] = {}
        for ci, cond in enumerate(self.conditions):
            out[cond] = {}
            for mi, mat in enumerate(self.materials):
                out[cond][mat] = {}
                for k, ch in enumerate(self.channels):
                    p = self.psd_v2_per_hz[ci, mi, k, 1:]
                    if not np.all(np.isfinite(p)):
                        out[cond][mat][ch] = {"rms_v": None, "centroid_hz": None, "peak_hz": None}
                        continue
                    total = float(p.sum())
                    out[cond][mat][ch] = {
                        "rms_v": float(np.sqrt(total * df)),
                        "centroid_hz": float((f[1:] * p).sum() / total) if total > 0 else None,
                        "peak_hz": float(f[1 + int(np.argmax(p))]) if total > 0 else None,
                    }
        return out


@dataclass(frozen=True)
class SgTraces:
    """Mean and standard deviation over trials of the strain-gauge signals per shape.

    time_s ``(T,)``; mean_v, std_v ``(n_conditions, n_shapes, 2, T)`` volts at the DAQ,
    channel order ``channels``; a (condition, shape) cell without trials is NaN.
    """

    time_s: np.ndarray
    mean_v: np.ndarray
    std_v: np.ndarray
    conditions: tuple[str, ...]
    shapes: tuple[str, ...]
    channels: tuple[str, ...] = tuple(CHANNELS[i] for i in SG_CHANNELS)


@dataclass(frozen=True)
class Diagnosis:
    """What :func:`diagnose` measured on one dataset.

    Attributes
    ----------
    source: where the data came from (a path, or a caller's description).
    n_trials: trials diagnosed; complete: False if the store was partly generated.
    shapes, materials, conditions, classes: the values present, in the paper's order
        (conditions ``"force=1N,speed=10mm/s"``, sorted by force then speed; classes
        ``"<shape>/<material>"``).
    trials_per_class: ``(fewest, most)`` trials of a class (over all conditions).
    n_features: features per channel group (``"all"``, ``"sg"``, ``"pvdf"``).
    accuracy: ``{target: {group: accuracy}}`` for targets ``class``, ``shape``,
        ``material``, ``condition``; ``None`` in place of the inner dict when the target
        is not applicable (a single value in the dataset), and ``None`` for a group when
        no trial can be scored.
    chance: ``{target: chance accuracy}`` (a random other trial's label).
    scored: ``{target: trials scored}``; notes: ``{target: why not applicable, or how
        many trials were left out}``.
    per_shape: ``{group: {shape: shape accuracy of that shape's trials}}`` (``None`` when
        shape is not applicable); per_material likewise; per_class ``{group: {class:
        class accuracy of that class's trials}}``.
    per_condition: ``{condition: {group: class accuracy with neighbours restricted to the
        same condition}}``; ``None`` with a single condition or a single class.
    confused_pairs: ``{group: [ConfusedPair, ...]}``, most confused first.
    confusion: ``{group: (k, k) int array}``: row = a trial's class, column = its nearest
        neighbour's class, in ``classes`` order.
    spectra, sg_traces: the curves (see :class:`PvdfSpectra`, :class:`SgTraces`).

    Examples
    --------
    >>> from synth import load_dataset
    >>> d = diagnose(load_dataset("data/paper"))  # doctest: +SKIP
    >>> d.accuracy["shape"]["sg"]  # SG-only leave-one-out shape accuracy  # doctest: +SKIP
    """

    source: str
    n_trials: int
    complete: bool
    shapes: tuple[str, ...]
    materials: tuple[str, ...]
    conditions: tuple[str, ...]
    classes: tuple[str, ...]
    trials_per_class: tuple[int, int]
    n_features: dict[str, int]
    accuracy: dict[str, dict[str, float | None] | None]
    chance: dict[str, float | None]
    scored: dict[str, int]
    notes: dict[str, str]
    per_shape: dict[str, dict[str, float | None]] | None
    per_material: dict[str, dict[str, float | None]] | None
    per_class: dict[str, dict[str, float | None]]
    per_condition: dict[str, dict[str, float | None]] | None
    confused_pairs: dict[str, list[ConfusedPair]]
    confusion: dict[str, np.ndarray] = field(repr=False)
    spectra: PvdfSpectra = field(repr=False)
    sg_traces: SgTraces = field(repr=False)
    #: The steady-sliding report (:func:`benchmark.steady.steady_diagnosis`).
    steady: dict[str, Any] | None = None

    def to_dict(self) -> dict[str, Any]:
        """Every number as JSON-friendly types (the curves only by reference and summary);
        a copy, so changing it leaves the diagnosis as it is."""
        return copy.deepcopy(
            {
                "format_version": FORMAT_VERSION,
                "source": self.source,
                "n_trials": self.n_trials,
                "complete": self.complete,
                "shapes": list(self.shapes),
                "materials": list(self.materials),
                "conditions": list(self.conditions),
                "classes": list(self.classes),
                "trials_per_class": list(self.trials_per_class),
                "n_features": dict(self.n_features),
                "accuracy": self.accuracy,
                "chance": self.chance,
                "scored": self.scored,
                "notes": self.notes,
                "per_shape": self.per_shape,
                "per_material": self.per_material,
                "steady": self.steady,
                "per_class": self.per_class,
                "per_condition": self.per_condition,
                "confused_pairs": {
                    g: [vars(p) for p in pairs] for g, pairs in self.confused_pairs.items()
                },
                "confusion": {g: m.tolist() for g, m in self.confusion.items()},
                "pvdf_spectra": {
                    "welch_segment_samples": WELCH_SEGMENT_SAMPLES,
                    "summary": self.spectra.summary(),
                    "curves": f"{CURVES_NAME}: psd_freq_hz, psd_v2_per_hz",
                },
                "sg_traces": {"curves": f"{CURVES_NAME}: trace_time_s, sg_mean_v, sg_std_v"},
            }
        )


# -- the analysis ------------------------------------------------------------------------
def group_columns(feature_names: Sequence[str]) -> dict[str, np.ndarray]:
    """Column indices of each channel group in a pool with ``feature_names``."""
    from models.features import sensor_of

    sensors = np.array([sensor_of(n) for n in feature_names])
    out = {}
    for key, _, sensor in GROUPS:
        out[key] = np.arange(sensors.size) if sensor is None else np.flatnonzero(sensors == sensor)
    return out


def _ordered(values: np.ndarray, order: Sequence[str]) -> tuple[str, ...]:
    present = set(np.unique(values).tolist())
    return tuple(v for v in order if v in present)


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
) -> Diagnosis:
    """Diagnose ``data`` (see the module docstring for what is measured).

    Parameters
    ----------
    data: any dataset with at least 2 trials.
    features: its raw 386-feature pool ``(n, 386)`` if already computed (else extracted).
    source: a description kept in the result (default: ``data.attrs["source"]`` or
        ``"dataset"``).
    progress: called with a one-line message at each stage (e.g. ``print``).
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

    shapes = _ordered(data.shape, SHAPE_NAMES)
    materials = _ordered(data.material, MATERIAL_NAMES)
    cls = np.array([f"{s}/{m}" for s, m in zip(data.shape, data.material, strict=True)])
    classes = _ordered(cls, CLASS_NAMES)
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
        steady=steady.steady_diagnosis(data.signals, data.material),
    )


# -- reading a store -----------------------------------------------------------------------
def load_for_diagnosis(
    path: str | Path,
    *,
    allow_incomplete: bool = False,
    progress: Callable[[str], None] | None = None,
) -> Dataset:
    """The dataset at ``path``; an unfinished store is refused with a message naming both
    fixes (finish it, or diagnose its finished trials with ``--allow-incomplete``)."""
    from synth import load_dataset
    from synth.store import Store

    done, _ = Store.open(path).status()
    if not done.all() and not allow_incomplete:
        raise ValueError(
            f"dataset {path} is incomplete ({int(done.sum())}/{done.size} chunks done); "
            f"finish it with `tactile-synth generate --resume --out {path}` or add "
            f"--allow-incomplete to diagnose its finished trials"
        )
    if progress is not None:
        progress(f"reading {path}")
    data = load_dataset(path, allow_incomplete=allow_incomplete)
    if len(data) == 0:
        raise ValueError(
            f"dataset {path} has no finished trial yet; "
            f"finish it with `tactile-synth generate --resume --out {path}`"
        )
    return data


# -- text ------------------------------------------------------------------------------------
def _fmt(value: float | None, digits: int = 3) -> str:
    return "n/a" if value is None else f"{value:.{digits}f}"


def _group_label(diag: Diagnosis, group: str) -> str:
    name = dict((g, n) for g, n, _ in GROUPS)[group]
    return f"{name} ({diag.n_features[group]})"


def _targets(diag: Diagnosis) -> tuple[str, ...]:
    """The targets shown in tables: condition only when the dataset has several."""
    return tuple(t for t in TARGETS if t != "condition" or len(diag.conditions) > 1)


def _count(k: int, noun: str, plural: str | None = None) -> str:
    return f"{k} {noun if k == 1 else plural or noun + 's'}"


def describe(diag: Diagnosis) -> str:
    """One line: trials, grid, trials per class, completeness."""
    lo, hi = diag.trials_per_class
    per_class = f"{lo}" if lo == hi else f"{lo}-{hi}"
    conds = _count(len(diag.conditions), "condition")
    if len(diag.conditions) == 1:
        conds += f" ({diag.conditions[0]})"
    text = (
        f"{diag.n_trials} trials, {_count(len(diag.shapes), 'shape')} x "
        f"{_count(len(diag.materials), 'material')} x {conds}, {per_class} trials per class"
    )
    return text + ("" if diag.complete else " (incomplete store: its finished trials only)")


def _worst(values: dict[str, float | None], k: int = 3) -> str:
    ranked = sorted((v, name) for name, v in values.items() if v is not None)
    return ", ".join(f"{name} {v:.2f}" for v, name in ranked[:k]) or "n/a"


def _by_group(values: dict[str, float | None]) -> str:
    return " / ".join(_fmt(values[g], 2) for g in GROUP_NAMES)


def summary_table(diag: Diagnosis) -> str:
    """The compact text the CLI prints: the accuracy table, the worst shapes, the
    materials, the per-condition class accuracy, the most confused pairs and the notes."""
    targets = _targets(diag)
    width = max(len(_group_label(diag, g)) for g in GROUP_NAMES) + 2
    lines = [
        f"{diag.source}: {describe(diag)}",
        f"{'leave-one-out 1-NN accuracy':<{width}}" + "".join(f"{t:>10}" for t in targets),
    ]
    for g in GROUP_NAMES:
        cells = [_fmt(None if diag.accuracy[t] is None else diag.accuracy[t][g]) for t in targets]
        lines.append(f"{_group_label(diag, g):<{width}}" + "".join(f"{c:>10}" for c in cells))
    chance = [_fmt(diag.chance[t]) for t in targets]
    lines.append(f"{'chance':<{width}}" + "".join(f"{c:>10}" for c in chance))
    if diag.per_shape is not None:
        lines.append(f"worst shapes, all features: {_worst(diag.per_shape['all'])}")
        lines.append(f"worst shapes, SG only:      {_worst(diag.per_shape['sg'])}")
    if diag.per_material is not None:
        per = {g: diag.per_material[g] for g in GROUP_NAMES}
        lines.append(
            "materials (all / SG / PVDF): "
            + ", ".join(
                f"{m} {_by_group({g: per[g][m] for g in GROUP_NAMES})}" for m in diag.materials
            )
        )
    if diag.per_condition is not None:
        lines.append("class accuracy within each condition (all / SG / PVDF):")
        lines += [f"  {c}: {_by_group(v)}" for c, v in diag.per_condition.items()]
    pairs = diag.confused_pairs["all"][:3]
    if pairs:
        lines.append(
            "most confused, all features: "
            + ", ".join(f"{p.a} ~ {p.b} {p.share:.2f}" for p in pairs)
        )
    lines += steady.summary_lines(diag.steady, diag.accuracy.get("material"))
    lines += [f"note: {t}: {text}" for t, text in diag.notes.items() if t in targets]
    return "\n".join(lines)


def _md_table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return out


def markdown(diag: Diagnosis, figures: dict[str, str] | None = None) -> str:
    """``diagnose.md``: every table of the diagnosis, with the figures linked by name."""
    figures = figures or {}
    targets = _targets(diag)
    md = [
        "# Dataset diagnosis",
        "",
        f"`{diag.source}`: {describe(diag)}.",
        "",
        "Leave-one-out 1-nearest-neighbour accuracy on the z-scored 386-feature pool: each",
        "trial gets the label of its nearest other trial (Euclidean distance over the channel",
        "group's features) and the accuracy is the share labelled right. High = the labels",
        "differ in that channel group in a way a plain distance sees. Chance is the accuracy",
        "of a random other trial's label.",
        "",
        "## Accuracy per channel group",
        "",
    ]
    rows = [
        [dict((g, n) for g, n, _ in GROUPS)[g], str(diag.n_features[g])]
        + [_fmt(None if diag.accuracy[t] is None else diag.accuracy[t][g]) for t in targets]
        for g in GROUP_NAMES
    ]
    rows.append(["chance", ""] + [_fmt(diag.chance[t]) for t in targets])
    md += _md_table(["channel group", "features", *targets], rows)
    if diag.notes:
        md.append("")
        md += [f"- {t}: {text}" for t, text in diag.notes.items()]

    def per_value(title: str, target: str, table: dict | None, what: str) -> None:
        md.extend(["", f"## {title}", ""])
        if table is None:
            md.append(f"Not applicable: {diag.notes.get(target, 'a single value')}.")
            return
        md.append(f"{what} (n/a: a single trial).")
        md.append("")
        keys = list(table["all"])
        md.extend(
            _md_table(
                [target, "all", "SG", "PVDF"],
                [[k] + [_fmt(table[g][k]) for g in GROUP_NAMES] for k in keys],
            )
        )

    per_value(
        "Per shape",
        "shape",
        diag.per_shape,
        "Shape accuracy of each shape's trials: the share whose nearest neighbour has their shape",
    )
    per_value(
        "Per material",
        "material",
        diag.per_material,
        "Material accuracy of each material's trials: the share whose nearest neighbour has "
        "their material",
    )
    md += ["", "## Per class (all features)", ""]
    md.append("Class accuracy of each class's trials (rows: shapes; columns: materials).")
    md.append("")
    md += _md_table(
        ["shape", *diag.materials],
        [
            [s] + [_fmt(diag.per_class["all"].get(f"{s}/{m}")) for m in diag.materials]
            for s in diag.shapes
        ],
    )
    if diag.per_condition is not None:
        md += ["", "## Per condition", ""]
        md.append("Class accuracy with neighbours taken from the same condition only.")
        md.append("")
        md += _md_table(
            ["condition", "all", "SG", "PVDF"],
            [[c] + [_fmt(v[g]) for g in GROUP_NAMES] for c, v in diag.per_condition.items()],
        )
    md += ["", "## Most confused class pairs", ""]
    md.append(
        "a→b: trials of a whose nearest neighbour is of class b; share: (a→b + b→a) / "
        "trials of both."
    )
    for g in GROUP_NAMES:
        md += ["", f"{_group_label(diag, g)}:", ""]
        pairs = diag.confused_pairs[g]
        if not pairs:
            md.append("no trial's nearest neighbour is of another class.")
            continue
        md += _md_table(
            ["a", "b", "differ by", "a→b", "b→a", "share"],
            [
                [p.a, p.b, p.differ_by, str(p.a_to_b), str(p.b_to_a), f"{p.share:.3f}"]
                for p in pairs
            ],
        )
    md += ["", "## PVDF spectra per material", ""]
    md.append(
        f"Mean Welch power spectral density ({WELCH_SEGMENT_SAMPLES}-sample segments) of the "
        "PVDF channels; rms over 0 Hz < f, PSD-weighted mean (centroid) and peak frequency."
    )
    md.append("")
    rows = []
    for cond, mats in diag.spectra.summary().items():
        for mat, chans in mats.items():
            for ch, v in chans.items():
                rms = "n/a" if v["rms_v"] is None else f"{1e3 * v['rms_v']:.2f}"
                rows.append([cond, mat, ch, rms, _fmt(v["centroid_hz"], 1), _fmt(v["peak_hz"], 1)])
    md += _md_table(
        ["condition", "material", "channel", "rms (mV)", "centroid (Hz)", "peak (Hz)"], rows
    )
    if "pvdf_spectra" in figures:
        md += ["", f"![PVDF spectra per material]({figures['pvdf_spectra']})"]
    md += ["", "## Strain-gauge mean traces per shape", ""]
    if len(diag.conditions) == 1:
        md.append("Mean ± one standard deviation over each shape's trials (all materials).")
    else:
        md.append(
            "Mean over each shape's trials (all materials), one colour per condition; "
            "sg1 solid, sg2 dashed."
        )
    if "sg_traces" in figures:
        md += ["", f"![SG mean traces per shape]({figures['sg_traces']})"]
    extra = [
        (k, t)
        for k, t in (
            ("accuracy", "Per-shape and per-material accuracy"),
            ("confusion", "Nearest-neighbour class confusion"),
        )
        if k in figures
    ]
    if extra:
        md += ["", "## Figures", ""]
        for k, t in extra:
            md += [f"![{t}]({figures[k]})", ""]
        md.pop()
    md += steady.markdown_lines(diag.steady, diag.accuracy.get("material"))
    md += [
        "",
        f"Numbers: `{JSON_NAME}`; curves: `{CURVES_NAME}` (numpy, no pickle). What each "
        "number means: docs/diagnose.md in the tactile-synth repository.",
    ]
    return "\n".join(md) + "\n"


# -- figures ---------------------------------------------------------------------------------
def _condition_colours(conditions: Sequence[str]) -> list:
    import matplotlib.pyplot as plt

    cmap = plt.get_cmap("viridis")
    k = len(conditions)
    return [cmap(i / max(k - 1, 1)) for i in range(k)]


def plot_accuracy(diag: Diagnosis, path: str | Path) -> Path:
    """Bars: per-shape and per-material accuracy for each channel group."""
    import matplotlib.pyplot as plt

    from .figures import _save

    panels = [
        (t, diag.per_shape if t == "shape" else diag.per_material)
        for t in ("shape", "material")
        if (diag.per_shape if t == "shape" else diag.per_material) is not None
    ]
    if not panels:
        panels = [("class", diag.per_class)]
    widths = [max(len(tab["all"]), 2) for _, tab in panels]
    fig, axes = plt.subplots(
        1,
        len(panels),
        figsize=(2.0 + 0.55 * sum(widths), 3.6),
        squeeze=False,
        gridspec_kw={"width_ratios": widths},
        layout="constrained",
    )
    colours = {"all": "tab:gray", "sg": "tab:blue", "pvdf": "tab:red"}
    for ax, (target, table) in zip(axes[0], panels, strict=True):
        keys = list(table["all"])
        x = np.arange(len(keys))
        for j, (g, name, _) in enumerate(GROUPS):
            vals = [np.nan if table[g][k] is None else table[g][k] for k in keys]
            ax.bar(x + (j - 1) * 0.27, vals, 0.27, color=colours[g], label=name)
        chance = diag.chance.get(target)
        if chance is not None:
            ax.axhline(chance, color="k", lw=0.8, ls=":", label="chance")
        ax.set_xticks(x, keys, rotation=45, ha="right", fontsize=8)
        ax.set_ylim(0, 1.02)
        ax.set_title(f"{target} accuracy per {target}", fontsize=10)
    axes[0, 0].set_ylabel("leave-one-out 1-NN accuracy")
    axes[0, -1].legend(fontsize=7, loc="lower right")
    return _save(fig, path)


def plot_confusion(diag: Diagnosis, path: str | Path) -> Path:
    """Row-normalised nearest-neighbour class confusion, one panel per channel group."""
    import matplotlib.pyplot as plt

    from .figures import _save

    k = len(diag.classes)
    side = min(max(3.0, 0.16 * k + 1.5), 8.0)
    fig, axes = plt.subplots(1, 3, figsize=(3 * side, side + 0.6), layout="constrained")
    font = 8 if k <= 12 else 5
    for ax, (g, name, _) in zip(axes, GROUPS, strict=True):
        counts = diag.confusion[g].astype(np.float64)
        rates = counts / np.maximum(counts.sum(axis=1, keepdims=True), 1)
        im = ax.imshow(rates, vmin=0, vmax=1, cmap="Blues", interpolation="nearest")
        ax.set_xticks(range(k), diag.classes, rotation=90, fontsize=font)
        ax.set_yticks(range(k), diag.classes if g == "all" else [], fontsize=font)
        acc = diag.accuracy["class"]
        value = _fmt(None if acc is None else acc[g])
        ax.set_title(f"{name}: class accuracy {value}", fontsize=9)
        ax.set_xlabel("class of the nearest neighbour", fontsize=8)
    axes[0].set_ylabel("class of the trial", fontsize=8)
    fig.colorbar(im, ax=axes, shrink=0.6, label="share of the class's trials")
    return _save(fig, path)


def plot_pvdf_spectra(diag: Diagnosis, path: str | Path) -> Path:
    """Mean PVDF power spectral density per material: one row per condition, one column
    per PVDF channel (log scale)."""
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullLocator

    from .figures import MATERIAL_COLOURS, _save

    sp = diag.spectra
    rows = len(sp.conditions)
    fig, axes = plt.subplots(
        rows,
        len(sp.channels),
        figsize=(9, 2.6 * rows + 0.6),
        squeeze=False,
        sharex=True,
        sharey=True,
        layout="constrained",
    )
    f = sp.freq_hz
    for ci, cond in enumerate(sp.conditions):
        for k, ch in enumerate(sp.channels):
            ax = axes[ci, k]
            for mi, mat in enumerate(sp.materials):
                p = sp.psd_v2_per_hz[ci, mi, k]
                if np.all(np.isfinite(p)) and np.any(p[1:] > 0):
                    ax.semilogy(f[1:], p[1:], color=MATERIAL_COLOURS.get(mat), lw=1, label=mat)
            # Minor log ticks on many panels cost more to draw than everything else.
            ax.yaxis.set_minor_locator(NullLocator())
            ax.set_title(f"{ch}, {cond}", fontsize=9)
            ax.grid(True, which="major", lw=0.3)
            if k == 0:
                ax.set_ylabel("PSD (V²/Hz)")
    for ax in axes[-1]:
        ax.set_xlabel("frequency (Hz)")
    axes[0, -1].legend(fontsize=8)
    return _save(fig, path)


def plot_sg_traces(diag: Diagnosis, path: str | Path) -> Path:
    """Mean strain-gauge traces per shape (one panel per shape): with one condition
    sg1/sg2 mean ± std; with several, each condition's means in its own colour."""
    import matplotlib.pyplot as plt

    from .figures import _save

    tr = diag.sg_traces
    n_s = len(tr.shapes)
    cols = min(4, n_s)
    rows = -(-n_s // cols)
    fig, axes = plt.subplots(
        rows,
        cols,
        figsize=(3.2 * cols, 2.4 * rows + 0.8),
        squeeze=False,
        sharex=True,
        sharey=True,
        layout="constrained",
    )
    styles = ("-", "--")
    single = len(tr.conditions) == 1
    colours = ("tab:blue", "tab:cyan") if single else None
    cond_colours = _condition_colours(tr.conditions)
    for si, shape in enumerate(tr.shapes):
        ax = axes[si // cols, si % cols]
        for ci in range(len(tr.conditions)):
            for k, ch in enumerate(tr.channels):
                m = tr.mean_v[ci, si, k]
                if not np.all(np.isfinite(m)):
                    continue
                colour = colours[k] if single else cond_colours[ci]
                ax.plot(tr.time_s, m, color=colour, ls=styles[k % 2], lw=0.9, label=ch)
                if single:
                    s = tr.std_v[ci, si, k]
                    ax.fill_between(tr.time_s, m - s, m + s, color=colour, alpha=0.2, lw=0)
        ax.set_title(shape, fontsize=9)
    for j in range(n_s, rows * cols):
        axes[j // cols, j % cols].axis("off")
    for ax in axes[:, 0]:
        ax.set_ylabel("SG (V)")
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    if single:
        handles, labels = axes[0, 0].get_legend_handles_labels()
    else:
        from matplotlib.lines import Line2D

        # One entry per condition colour, and one per line style (channel).
        handles = [Line2D([], [], color=c, lw=1.5) for c in cond_colours]
        handles += [Line2D([], [], color="k", ls=styles[k], lw=0.9) for k in range(2)]
        labels = [*tr.conditions, *tr.channels]
    fig.legend(handles, labels, loc="outside lower center", ncol=min(len(labels), 5), fontsize=7)
    return _save(fig, path)


# -- files -------------------------------------------------------------------------------------
def _clean(value: Any) -> Any:
    """JSON-ready: non-finite floats become null, tuples lists."""
    if isinstance(value, float):
        return value if np.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_clean(v) for v in value]
    return value


def _atomic_write(path: Path, write: Callable[[Path], None]) -> None:
    tmp = path.with_name(path.name + ".tmp")
    write(tmp)
    os.replace(tmp, path)


def write_curves(diag: Diagnosis, path: str | Path) -> Path:
    """``diagnose.npz``: spectra and traces as plain arrays (``np.load(allow_pickle=False)``)."""
    path = Path(path)
    arrays = {
        "psd_freq_hz": diag.spectra.freq_hz,
        "psd_v2_per_hz": diag.spectra.psd_v2_per_hz,
        "psd_conditions": np.array(diag.spectra.conditions, dtype=str),
        "psd_materials": np.array(diag.spectra.materials, dtype=str),
        "psd_channels": np.array(diag.spectra.channels, dtype=str),
        "trace_time_s": diag.sg_traces.time_s,
        "sg_mean_v": diag.sg_traces.mean_v,
        "sg_std_v": diag.sg_traces.std_v,
        "trace_conditions": np.array(diag.sg_traces.conditions, dtype=str),
        "trace_shapes": np.array(diag.sg_traces.shapes, dtype=str),
        "trace_channels": np.array(diag.sg_traces.channels, dtype=str),
    }

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as fh:
            np.savez_compressed(fh, **arrays)

    _atomic_write(path, write)
    return path


def write_diagnosis(diag: Diagnosis, out: str | Path, *, figures: bool = True) -> list[Path]:
    """Write ``diagnose.md``, ``diagnose.json``, ``diagnose.npz`` and (``figures``) the PNG
    figures into directory ``out`` (created if needed); returns the paths written."""
    out = Path(out)
    check_out_dir(out)
    out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    names: dict[str, str] = {}
    if figures:
        plotters = {
            "accuracy": plot_accuracy,
            "confusion": plot_confusion,
            "pvdf_spectra": plot_pvdf_spectra,
            "sg_traces": plot_sg_traces,
        }
        for key, plot in plotters.items():
            written.append(plot(diag, out / FIGURES[key]))
            names[key] = FIGURES[key]
    text = json.dumps(_clean(diag.to_dict()), indent=1) + "\n"
    _atomic_write(out / JSON_NAME, lambda p: p.write_text(text))
    written.append(out / JSON_NAME)
    written.append(write_curves(diag, out / CURVES_NAME))
    md = markdown(diag, names)
    _atomic_write(out / MARKDOWN_NAME, lambda p: p.write_text(md))
    written.append(out / MARKDOWN_NAME)
    return written


def run_diagnose(
    path: str | Path,
    *,
    out: str | Path | None = None,
    allow_incomplete: bool = False,
    progress: Callable[[str], None] | None = None,
) -> Diagnosis:
    """The CLI's work: load the store at ``path``, diagnose it, and write the files into
    ``out`` when given."""
    say = progress or (lambda msg: None)
    if out is not None:
        check_out_dir(out)  # before loading, so a bad --out fails at once
        # The report's files do not belong in a store.
        check_not_inside_a_store(out, itself=True, advice="choose another DIR")
    data = load_for_diagnosis(path, allow_incomplete=allow_incomplete, progress=say)
    diag = diagnose(data, source=str(path), progress=say)
    if out is not None:
        say(f"writing {Path(out) / MARKDOWN_NAME}, {JSON_NAME}, {CURVES_NAME} and figures")
        write_diagnosis(diag, out)
    return diag
