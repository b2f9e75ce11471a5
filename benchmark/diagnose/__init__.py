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

The package's modules, one job each: :mod:`.result` (constants and result types),
:mod:`.nearest` (leave-one-out nearest neighbours), :mod:`.analysis` (:func:`diagnose`),
:mod:`.text` (summary table and Markdown), :mod:`.plots` (figures) and :mod:`.files`
(loading a store, writing the files, :func:`run_diagnose`), :mod:`.steady` (material
information on steady sliding, away from the edges).
"""

from __future__ import annotations

from .analysis import confusion_counts, diagnose, group_columns
from .files import json_ready, load_for_diagnosis, run_diagnose, write_curves, write_diagnosis
from .nearest import LooScore, loo_nearest, loo_score
from .plots import plot_accuracy, plot_confusion, plot_pvdf_spectra, plot_sg_traces
from .result import (
    CURVES_NAME,
    FIGURES,
    FORMAT_VERSION,
    GROUP_NAMES,
    GROUPS,
    JSON_NAME,
    MARKDOWN_NAME,
    N_CONFUSED_PAIRS,
    PVDF_CHANNELS,
    SG_CHANNELS,
    TARGETS,
    WELCH_SEGMENT_SAMPLES,
    ConfusedPair,
    Diagnosis,
    PvdfSpectra,
    SgTraces,
)
from .text import describe, markdown, summary_table

__all__ = [
    "CURVES_NAME",
    "FIGURES",
    "FORMAT_VERSION",
    "GROUPS",
    "GROUP_NAMES",
    "JSON_NAME",
    "MARKDOWN_NAME",
    "N_CONFUSED_PAIRS",
    "PVDF_CHANNELS",
    "SG_CHANNELS",
    "TARGETS",
    "WELCH_SEGMENT_SAMPLES",
    "ConfusedPair",
    "Diagnosis",
    "LooScore",
    "PvdfSpectra",
    "SgTraces",
    "confusion_counts",
    "describe",
    "diagnose",
    "group_columns",
    "json_ready",
    "load_for_diagnosis",
    "loo_nearest",
    "loo_score",
    "markdown",
    "plot_accuracy",
    "plot_confusion",
    "plot_pvdf_spectra",
    "plot_sg_traces",
    "run_diagnose",
    "summary_table",
    "write_curves",
    "write_diagnosis",
]
