"""Where a dataset's material information lies: steady sliding against the edges.

The whole 2 s window holds the edge crossings, where the films ring some hundred times
harder than while the skin slides over a face (volts against tens of millivolts).
:func:`steady_diagnosis` finds, in each trial's own signals, the stretches of steady
sliding at least :data:`EDGE_GAP_S` from any wall crossing, and reports per channel
group (all channels, strain gauges only, PVDF films only):

- leave-one-out 1-NN accuracy of the material on features of those steady stretches
  alone (:func:`steady_features`), beside the whole window's (the diagnosis's own);
- the films' RMS in the texture band (20-400 Hz) on the steady stretches, per material.

A wall crossing is found as a lab finds it in a record: where the films' magnitude
reaches :data:`EDGE_FRACTION` of the trial's largest (the films ring at every wall the
skin meets or leaves, concave outlines' inner walls included). A trial without a
steady stretch of :data:`MIN_STEADY_S` is left out of the steady scores, and the count
is reported.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
from scipy import signal

from synth.trial import SAMPLE_RATE_HZ

#: Steady sliding starts and ends this long from any wall crossing (the default).
EDGE_GAP_S = 0.3
#: Longest gap allowed: a 2 s window must keep a :data:`MIN_STEADY_S` stretch between two
#: gaps.
MAX_EDGE_GAP_S = 0.9
#: A wall crossing: the films' magnitude reaches this fraction of the trial's largest.
EDGE_FRACTION = 0.05
#: Shortest steady stretch scored.
MIN_STEADY_S = 0.2
#: The texture band.
BAND_HZ = (20.0, 400.0)
#: Log-spaced bands of the films' spectrum, the steady features of the PVDF group.
FILM_BANDS_HZ = np.geomspace(20.0, 400.0, 7)
PVDF, SG = (0, 1), (2, 3)


def check_edge_gap(edge_gap_s: float, name: str = "edge_gap_s") -> float:
    """``edge_gap_s`` as a float; a one-line ``ValueError`` naming it (as ``name``) outside
    ``[0, MAX_EDGE_GAP_S]``."""
    gap = float(edge_gap_s)
    if not 0.0 <= gap <= MAX_EDGE_GAP_S:
        raise ValueError(
            f"{name} must lie in 0..{MAX_EDGE_GAP_S:g} s (a 2 s window keeps a "
            f"{MIN_STEADY_S:g} s stretch between two gaps); got {edge_gap_s!r}"
        )
    return gap


def steady_stretch(signals: np.ndarray, edge_gap_s: float = EDGE_GAP_S) -> slice | None:
    """The longest stretch of ``signals`` ``(4, n)`` at least ``edge_gap_s`` from every
    wall crossing, or ``None`` if it is shorter than :data:`MIN_STEADY_S`."""
    films = np.abs(np.asarray(signals[list(PVDF)], dtype=float) - np.median(signals[list(PVDF)]))
    mag = films.max(axis=0)
    peak = mag.max()
    n = mag.size
    quiet = np.ones(n, dtype=bool)
    if peak > 0:
        gap = round(edge_gap_s * SAMPLE_RATE_HZ)
        for i in np.flatnonzero(mag >= EDGE_FRACTION * peak):
            quiet[max(i - gap, 0) : i + gap + 1] = False
    padded = np.concatenate([[0], quiet.astype(np.int8), [0]])
    edges = np.flatnonzero(np.diff(padded))
    if edges.size == 0:
        return None
    starts, ends = edges[::2], edges[1::2]
    best = int(np.argmax(ends - starts))
    if ends[best] - starts[best] < MIN_STEADY_S * SAMPLE_RATE_HZ:
        return None
    return slice(int(starts[best]), int(ends[best]))


def _band_rms(x: np.ndarray, lo: float, hi: float) -> float:
    sos = signal.butter(4, (lo, hi), btype="bandpass", fs=SAMPLE_RATE_HZ, output="sos")
    return float(np.sqrt(np.mean(signal.sosfiltfilt(sos, x - x.mean(), padlen=0) ** 2)))


def steady_features(signals: np.ndarray, stretch: slice) -> dict[str, np.ndarray]:
    """Features of one trial's steady stretch, per channel group: for each film, the log
    RMS in the log-spaced bands :data:`FILM_BANDS_HZ`; for each gauge, its mean, its
    standard deviation and its slope over the stretch (V/s)."""
    x = np.asarray(signals[:, stretch], dtype=float)
    film = [
        np.log(_band_rms(x[c], lo, hi) + 1e-9)
        for c in PVDF
        for lo, hi in itertools.pairwise(FILM_BANDS_HZ)
    ]
    t = np.arange(x.shape[1]) / SAMPLE_RATE_HZ
    gauge = []
    for c in SG:
        gauge += [x[c].mean(), x[c].std(), np.polyfit(t, x[c], 1)[0]]
    pvdf, sg = np.array(film), np.array(gauge)
    return {"all": np.concatenate([sg, pvdf]), "sg": sg, "pvdf": pvdf}


def steady_diagnosis(
    signals: np.ndarray, material: np.ndarray, edge_gap_s: float = EDGE_GAP_S
) -> dict[str, Any]:
    """The steady-sliding report of a dataset's ``signals`` ``(n, 4, 2000)`` with their
    ``material`` labels: ``{"scored", "left_out", "left_out_by_material": {material:
    count}, "material_accuracy": {group: acc}, "texture_band_rms_v": {material: mean films'
    RMS}, "chance"}``. The trials left out are counted per material: a material whose
    films ring harder while sliding reaches the wall threshold more often, loses more
    steady stretches, and so is scored on fewer trials than the others."""
    from .nearest import loo_nearest, loo_score

    edge_gap_s = check_edge_gap(edge_gap_s)
    material = np.asarray(material)
    rows, feats, rms = [], [], []
    for i, sig in enumerate(signals):
        stretch = steady_stretch(sig, edge_gap_s)
        if stretch is None:
            continue
        rows.append(i)
        feats.append(steady_features(sig, stretch))
        rms.append(np.mean([_band_rms(np.asarray(sig[c, stretch], float), *BAND_HZ) for c in PVDF]))
    out: dict[str, Any] = {
        "edge_gap_s": edge_gap_s,
        "scored": len(rows),
        "left_out": int(len(signals) - len(rows)),
        "left_out_by_material": {
            str(m): int(np.sum(material == m)) - int(np.sum(material[rows] == m))
            for m in np.unique(material)
        },
        "material_accuracy": None,
        "chance": None,
        "texture_band_rms_v": {},
    }
    if not rows:
        return out
    labels = material[rows]
    for m in np.unique(labels):
        out["texture_band_rms_v"][str(m)] = float(np.mean(np.array(rms)[labels == m]))
    if np.unique(labels).size < 2 or len(rows) < 2:
        return out
    accuracy = {}
    for group in ("all", "sg", "pvdf"):
        x = np.stack([f[group] for f in feats])
        z = (x - x.mean(axis=0)) / np.where(x.std(axis=0) > 0, x.std(axis=0), 1.0)
        score = loo_score(loo_nearest(z), labels)
        accuracy[group] = score.accuracy
        out["chance"] = score.chance
    out["material_accuracy"] = accuracy
    return out


def summary_lines(report: dict[str, Any] | None, whole: dict[str, float | None] | None) -> list:
    """Text lines for the CLI's summary: the steady material accuracy per group beside the
    whole window's (``whole``: the diagnosis's material accuracy per group)."""
    if not report or report.get("material_accuracy") is None:
        return []
    acc = report["material_accuracy"]
    lines = [
        f"material 1-NN on steady sliding (>= {report['edge_gap_s']:g} s from any wall; "
        f"{report['scored']} trials, {report['left_out']} without a steady stretch"
        + (
            ": " + ", ".join(f"{m} {n}" for m, n in report["left_out_by_material"].items())
            if report["left_out"] and report.get("left_out_by_material")
            else ""
        )
        + "):",
    ]
    for group in ("all", "sg", "pvdf"):
        w = None if whole is None else whole.get(group)
        w_text = "n/a" if w is None else f"{w:.3f}"
        lines.append(f"  {group:<5} steady {acc[group]:.3f}   whole window {w_text}")
    lines.append(
        "films' 20-400 Hz RMS on steady sliding: "
        + ", ".join(f"{m} {v * 1e3:.2f} mV" for m, v in report["texture_band_rms_v"].items())
    )
    return lines


def markdown_lines(report: dict[str, Any] | None, whole: dict[str, float | None] | None) -> list:
    """The report's Markdown section (empty without a steady score)."""
    lines = summary_lines(report, whole)
    if not lines:
        return []
    return ["", "## Steady sliding", "", "```", *lines, "```"]
