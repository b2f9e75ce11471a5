"""The diagnosis's constants and result types: the channel groups and targets, the most confused
pairs, the PVDF spectra, the strain-gauge traces and :class:`Diagnosis` itself."""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from synth import CHANNELS

#: Channel groups: key, human-readable name, sensor kept (None: all features).

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
    #: The steady-sliding report (:func:`benchmark.diagnose.steady.steady_diagnosis`).
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
