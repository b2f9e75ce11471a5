"""The summary statistics a calibration compares recordings and twin by.

Chosen from what the diagnosis and the feature pool already read, before any fit was
seen, each a mean over trials (so that its expectation does not depend on how many
trials a store holds) or an unbiased within-class spread:

- per material (the texture, the friction and the edges differ by material): every
  channel's log RMS in four bands (1-20, 20-60, 60-150, 150-400 Hz; Welch, 1 Hz bins),
  each film's log texture-band RMS (20-400 Hz) on its steady sliding stretch away from
  the edges (:func:`benchmark.diagnose.steady.steady_stretch`), each film's log peak
  magnitude (the edge crossings) and each gauge's mean level;
- pooled: the gauges' shape profile (each gauge's mean in eight equal stretches of the
  window), every channel's 50 Hz line over its neighbouring bins (log; mains pickup);
- the stroke-to-stroke scatter: the within-class standard deviation of each gauge's
  mean level over its across-class mean magnitude, and of each film's log texture-band
  RMS (variances with one degree of freedom removed, pooled over classes).
"""

from __future__ import annotations

import numpy as np
from scipy import signal

from benchmark.diagnose.steady import BAND_HZ, steady_stretch
from synth.trial import SAMPLE_RATE_HZ

#: The spectral bands of every channel (Hz).
BANDS_HZ = ((1.0, 20.0), (20.0, 60.0), (60.0, 150.0), (150.0, 400.0))
#: Equal stretches of the window the gauges' profile averages.
PROFILE_BINS = 8
#: The mains line and the neighbourhood its level is read against (Hz).
MAINS_HZ, MAINS_SIDE_HZ = 50.0, (40.0, 60.0)
FILMS, GAUGES = (0, 1), (2, 3)
_TINY = 1e-12


def _per_trial(signals: np.ndarray) -> dict[str, np.ndarray]:
    """Per-trial statistics of ``signals`` ``(n, 4, T)``, each ``(n, k)``."""
    x = np.asarray(signals, dtype=np.float64)
    n, _, t = x.shape
    freq, psd = signal.welch(x, fs=SAMPLE_RATE_HZ, nperseg=min(1000, t), axis=-1)
    df = freq[1] - freq[0]
    bands = np.stack(
        [
            0.5 * np.log(psd[..., (freq >= lo) & (freq < hi)].sum(axis=-1) * df + _TINY)
            for lo, hi in BANDS_HZ
        ],
        axis=-1,
    ).reshape(n, -1)
    line = np.argmin(np.abs(freq - MAINS_HZ))
    side = (freq >= MAINS_SIDE_HZ[0]) & (freq <= MAINS_SIDE_HZ[1]) & (np.arange(freq.size) != line)
    mains = np.log(psd[..., line] + _TINY) - np.log(np.median(psd[..., side], axis=-1) + _TINY)
    films = x[:, list(FILMS)]
    peak = np.log(np.abs(films - np.median(films, axis=-1, keepdims=True)).max(axis=-1) + _TINY)
    gauges = x[:, list(GAUGES)]
    level = gauges.mean(axis=-1)
    cut = np.array_split(np.arange(t), PROFILE_BINS)
    profile = np.stack([gauges[..., c].mean(axis=-1) for c in cut], axis=-1).reshape(n, -1)
    texture = np.full((n, len(FILMS)), np.nan)
    sos = signal.butter(4, BAND_HZ, btype="bandpass", fs=SAMPLE_RATE_HZ, output="sos")
    for i in range(n):
        stretch = steady_stretch(x[i])
        if stretch is None:
            continue
        part = films[i][:, stretch]
        part = signal.sosfiltfilt(sos, part - part.mean(axis=-1, keepdims=True), padlen=0)
        texture[i] = 0.5 * np.log(np.mean(part**2, axis=-1) + _TINY)
    return {
        "bands": bands,
        "texture": texture,
        "peak": peak,
        "level": level,
        "profile": profile,
        "mains": mains,
    }


#: The statistics averaged per material, and those pooled over every trial.
PER_MATERIAL = ("bands", "texture", "peak", "level")
POOLED = ("profile", "mains")


def _within_class_sd(values: np.ndarray, label: np.ndarray) -> np.ndarray:
    """Pooled within-class standard deviation of ``values`` ``(n, k)`` (NaN rows left out)."""
    total, dof = np.zeros(values.shape[1]), np.zeros(values.shape[1])
    for c in np.unique(label):
        v = values[label == c]
        ok = ~np.isnan(v)
        m = ok.sum(axis=0)
        mean = np.where(m > 0, np.nansum(v, axis=0) / np.maximum(m, 1), 0.0)
        total += np.nansum((v - mean) ** 2, axis=0)
        dof += np.maximum(m - 1, 0)
    return np.sqrt(total / np.maximum(dof, 1))


def summary_names(materials: tuple[str, ...]) -> list[str]:
    """The names of :func:`summarize`'s entries, in its order."""
    channels = ("pvdf1", "pvdf2", "sg1", "sg2")
    per = (
        [f"{c}.band{lo:g}-{hi:g}Hz" for c in channels for lo, hi in BANDS_HZ]
        + [f"{c}.steady_texture" for c in channels[:2]]
        + [f"{c}.peak" for c in channels[:2]]
        + [f"{c}.level" for c in channels[2:]]
    )
    names = [f"{m}:{p}" for m in materials for p in per]
    names += [f"{c}.profile{k}" for c in channels[2:] for k in range(PROFILE_BINS)]
    names += [f"{c}.mains" for c in channels]
    names += [f"{c}.level_scatter" for c in channels[2:]]
    names += [f"{c}.texture_scatter" for c in channels[:2]]
    return names


def summarize(
    signals: np.ndarray, material: np.ndarray, label: np.ndarray, materials: tuple[str, ...]
) -> np.ndarray:
    """One store's summary vector (:func:`summary_names` names its entries): NaN where a
    material has no trial or no trial has a steady stretch."""
    stats = _per_trial(signals)
    material = np.asarray(material).astype(str)
    parts = []
    for m in materials:
        rows = material == m
        for key in PER_MATERIAL:
            v = stats[key][rows]
            with np.errstate(all="ignore"):
                parts.append(
                    np.nanmean(v, axis=0)
                    if rows.any() and not np.isnan(v).all()
                    else np.full(v.shape[1], np.nan)
                )
    for key in POOLED:
        parts.append(stats[key].mean(axis=0))
    level = stats["level"]
    scale = np.abs(level).mean(axis=0) + _TINY
    parts.append(np.log(_within_class_sd(level, label) / scale + _TINY))
    parts.append(_within_class_sd(stats["texture"], label))
    return np.concatenate(parts)
