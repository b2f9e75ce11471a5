"""The 386-feature pool of AFOP-ML (paper Sec. IV-B), vectorised over trials.

194 time-domain features: 48 statistics of each of the 4 channels (192) plus 2
cross-channel correlations (PVDF1-PVDF2, SG1-SG2). 192 frequency-domain features: a
3-level discrete wavelet transform (Daubechies-4, PyWavelets) of the two PVDF channels,
24 statistics of each of the 4 sub-bands cA3, cD3, cD2, cD1 (2 x 4 x 24).

Names are ``<channel>.<domain>.<statistic>``: ``sg1.time.rms``, ``pvdf2.dwt.cD2.energy``,
``pvdf.time.corr`` (cross-channel: channel group ``pvdf``/``sg``). Every statistic is
computed for all trials at once (numpy along the time axis); nothing loops per trial.
Constant or all-zero signals give finite values (ratios guard their denominators).

:func:`table` lists every feature with its definition (``docs/features.md`` is generated
from it).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import pywt

CHANNELS: tuple[str, ...] = ("pvdf1", "pvdf2", "sg1", "sg2")
PVDF_CHANNELS: tuple[int, ...] = (0, 1)
WAVELET = "db4"
DWT_LEVEL = 3
SUBBANDS: tuple[str, ...] = ("cA3", "cD3", "cD2", "cD1")
SAMPLE_RATE_HZ = 1000.0
_EPS = 1e-12

Stat = Callable[[dict], np.ndarray]


def _safe_div(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.divide(a, b, out=np.zeros_like(a, dtype=np.float64), where=np.abs(b) > _EPS)


def _moments(x: np.ndarray) -> dict:
    """Shared intermediate results of a ``(n, T)`` block (computed once per block)."""
    mean = x.mean(axis=1)
    c = x - mean[:, None]
    c2 = c * c
    var = c2.mean(axis=1)
    std = np.sqrt(var)
    absx = np.abs(x)
    q = np.percentile(x, [5, 10, 25, 50, 75, 90, 95], axis=1)
    d1 = np.diff(x, axis=1)
    d2 = np.diff(d1, axis=1)
    return {
        "x": x,
        "c": c,
        "c2": c2,
        "mean": mean,
        "var": var,
        "std": std,
        "abs": absx,
        "abs_mean": absx.mean(axis=1),
        "abs_max": absx.max(axis=1),
        "rms": np.sqrt((x * x).mean(axis=1)),
        "q": q,
        "d1": d1,
        "d2": d2,
        "d1_var": d1.var(axis=1),
        "d2_var": d2.var(axis=1),
    }


def _skew(m: dict) -> np.ndarray:
    return _safe_div((m["c2"] * m["c"]).mean(axis=1), m["std"] ** 3)


def _kurt(m: dict) -> np.ndarray:
    return _safe_div((m["c2"] * m["c2"]).mean(axis=1), m["var"] ** 2)


def _zero_cross_rate(c: np.ndarray) -> np.ndarray:
    s = np.signbit(c)
    return (s[:, 1:] != s[:, :-1]).mean(axis=1)


def _mobility(m: dict) -> np.ndarray:
    return np.sqrt(_safe_div(m["d1_var"], m["var"]))


def _complexity(m: dict) -> np.ndarray:
    mob_d1 = np.sqrt(_safe_div(m["d2_var"], m["d1_var"]))
    return _safe_div(mob_d1, _mobility(m))


def _autocorr(m: dict, lag: int) -> np.ndarray:
    c = m["c"]
    return _safe_div((c[:, :-lag] * c[:, lag:]).mean(axis=1), m["var"])


def _hist_entropy(m: dict, bins: int = 10) -> np.ndarray:
    x = m["x"]
    lo = x.min(axis=1, keepdims=True)
    span = x.max(axis=1, keepdims=True) - lo
    idx = np.clip(
        (_safe_div(x - lo, np.broadcast_to(span, x.shape)) * bins).astype(int), 0, bins - 1
    )
    flat = (np.arange(x.shape[0])[:, None] * bins + idx).ravel()
    counts = np.bincount(flat, minlength=x.shape[0] * bins).reshape(x.shape[0], bins)
    p = counts / x.shape[1]
    return -(p * np.log(np.where(p > 0, p, 1.0))).sum(axis=1)


def _spectrum(m: dict) -> tuple[np.ndarray, np.ndarray]:
    power = np.abs(np.fft.rfft(m["c"], axis=1)) ** 2
    freqs = np.fft.rfftfreq(m["x"].shape[1], d=1.0 / SAMPLE_RATE_HZ)
    return freqs, power


def _trend(m: dict) -> np.ndarray:
    n = m["x"].shape[1]
    t = np.arange(n) - (n - 1) / 2
    return (m["c"] * t).sum(axis=1) / (t * t).sum() * SAMPLE_RATE_HZ  # units per second


def _quarter(m: dict, k: int) -> np.ndarray:
    n = m["x"].shape[1]
    return m["c"][:, k * n // 4 : (k + 1) * n // 4].mean(axis=1)


def _half_diff(m: dict) -> np.ndarray:
    n = m["x"].shape[1]
    return m["x"][:, n // 2 :].mean(axis=1) - m["x"][:, : n // 2].mean(axis=1)


def _peak_rate(m: dict) -> np.ndarray:
    x = m["x"]
    thr = (m["mean"] + m["std"])[:, None]
    mid = x[:, 1:-1]
    peaks = (mid > x[:, :-2]) & (mid >= x[:, 2:]) & (mid > thr) & (m["std"][:, None] > _EPS)
    return peaks.sum(axis=1) / (x.shape[1] / SAMPLE_RATE_HZ)


def _spectral(m: dict, which: str) -> np.ndarray:
    freqs, power = m.setdefault("_spec", _spectrum(m))
    total = power.sum(axis=1)
    if which == "centroid":
        return _safe_div((power * freqs).sum(axis=1), total)
    return np.where(total > _EPS, freqs[np.argmax(power, axis=1)], 0.0)


#: The 48 time-domain statistics: name -> (definition, function of the block's moments).
TIME_STATS: dict[str, tuple[str, Stat]] = {
    "mean": ("arithmetic mean", lambda m: m["mean"]),
    "std": ("standard deviation (population)", lambda m: m["std"]),
    "var": ("variance (population)", lambda m: m["var"]),
    "rms": ("root mean square", lambda m: m["rms"]),
    "min": ("minimum", lambda m: m["x"].min(axis=1)),
    "max": ("maximum", lambda m: m["x"].max(axis=1)),
    "range": ("max - min", lambda m: m["x"].max(axis=1) - m["x"].min(axis=1)),
    "abs_mean": ("mean of |x|", lambda m: m["abs_mean"]),
    "abs_max": ("max of |x|", lambda m: m["abs_max"]),
    "median": ("median", lambda m: m["q"][3]),
    "mad": (
        "median absolute deviation from the median",
        lambda m: np.median(np.abs(m["x"] - m["q"][3][:, None]), axis=1),
    ),
    "iqr": ("75th - 25th percentile", lambda m: m["q"][4] - m["q"][2]),
    "p05": ("5th percentile", lambda m: m["q"][0]),
    "p10": ("10th percentile", lambda m: m["q"][1]),
    "p25": ("25th percentile", lambda m: m["q"][2]),
    "p75": ("75th percentile", lambda m: m["q"][4]),
    "p90": ("90th percentile", lambda m: m["q"][5]),
    "p95": ("95th percentile", lambda m: m["q"][6]),
    "skewness": ("third standardised moment (0 if constant)", _skew),
    "kurtosis": ("fourth standardised moment (0 if constant)", _kurt),
    "energy": ("mean of x^2", lambda m: m["rms"] ** 2),
    "crest": ("max|x| / rms", lambda m: _safe_div(m["abs_max"], m["rms"])),
    "shape_factor": ("rms / mean|x|", lambda m: _safe_div(m["rms"], m["abs_mean"])),
    "impulse": ("max|x| / mean|x|", lambda m: _safe_div(m["abs_max"], m["abs_mean"])),
    "clearance": (
        "max|x| / mean(sqrt|x|)^2",
        lambda m: _safe_div(m["abs_max"], np.sqrt(m["abs"]).mean(axis=1) ** 2),
    ),
    "zcr": ("rate of sign changes of x - mean (per sample)", lambda m: _zero_cross_rate(m["c"])),
    "ssc": ("rate of slope sign changes (per sample)", lambda m: _zero_cross_rate(m["d1"])),
    "wl": ("waveform length: mean |x[t+1] - x[t]|", lambda m: np.abs(m["d1"]).mean(axis=1)),
    "diff_std": ("std of the first difference", lambda m: np.sqrt(m["d1_var"])),
    "diff_absmax": ("max |first difference|", lambda m: np.abs(m["d1"]).max(axis=1)),
    "diff2_std": ("std of the second difference", lambda m: np.sqrt(m["d2_var"])),
    "mobility": ("Hjorth mobility sqrt(var(dx)/var(x))", _mobility),
    "complexity": ("Hjorth complexity mobility(dx)/mobility(x)", _complexity),
    "acf1": ("autocorrelation at lag 1 sample", lambda m: _autocorr(m, 1)),
    "acf10": ("autocorrelation at lag 10 samples", lambda m: _autocorr(m, 10)),
    "acf100": ("autocorrelation at lag 100 samples", lambda m: _autocorr(m, 100)),
    "argmax": (
        "time of the maximum / window length",
        lambda m: m["x"].argmax(axis=1) / m["x"].shape[1],
    ),
    "argmin": (
        "time of the minimum / window length",
        lambda m: m["x"].argmin(axis=1) / m["x"].shape[1],
    ),
    "trend": ("least-squares slope (units per second)", _trend),
    "half_diff": (
        "mean of the second half - mean of the first half",
        lambda m: _half_diff(m),
    ),
    "hist_entropy": ("Shannon entropy of a 10-bin amplitude histogram (nats)", _hist_entropy),
    "peak_rate": ("local maxima above mean + std, per second", _peak_rate),
    "q1_mean": (
        "mean of the 1st quarter of the window minus the window mean",
        lambda m: _quarter(m, 0),
    ),
    "q2_mean": ("mean of the 2nd quarter minus the window mean", lambda m: _quarter(m, 1)),
    "q3_mean": ("mean of the 3rd quarter minus the window mean", lambda m: _quarter(m, 2)),
    "q4_mean": ("mean of the 4th quarter minus the window mean", lambda m: _quarter(m, 3)),
    "spec_centroid": (
        "power-weighted mean frequency of x - mean (Hz)",
        lambda m: _spectral(m, "centroid"),
    ),
}
TIME_STATS["dominant_freq"] = (
    "frequency of the largest FFT power of x - mean (Hz)",
    lambda m: _spectral(m, "dominant"),
)


def _subband_stats(m: dict, total_energy: np.ndarray) -> dict[str, np.ndarray]:
    energy = m["rms"] ** 2 * m["x"].shape[1]
    p = _safe_div(m["x"] ** 2, energy[:, None])
    entropy = -(p * np.log(np.where(p > 0, p, 1.0))).sum(axis=1)
    return {k: f(m) for k, (_, f) in DWT_STAT_FUNCS.items()} | {
        "energy": energy,
        "rel_energy": _safe_div(energy, total_energy),
        "log_energy": np.log(energy + _EPS),
        "entropy": entropy,
    }


#: The 24 statistics of each DWT sub-band (coefficients c): name -> definition.
DWT_STATS: dict[str, str] = {
    "mean": "mean of c",
    "std": "standard deviation of c",
    "var": "variance of c",
    "rms": "root mean square of c",
    "min": "minimum of c",
    "max": "maximum of c",
    "range": "max - min of c",
    "abs_mean": "mean |c|",
    "median": "median of c",
    "mad": "median absolute deviation of c",
    "iqr": "75th - 25th percentile of c",
    "p05": "5th percentile of c",
    "p95": "95th percentile of c",
    "skewness": "third standardised moment of c",
    "kurtosis": "fourth standardised moment of c",
    "energy": "sum of c^2",
    "rel_energy": "sum of c^2 over the sum across the 4 sub-bands",
    "log_energy": "log(sum of c^2 + 1e-12)",
    "entropy": "Shannon entropy of c^2 / sum c^2 (nats)",
    "zcr": "rate of sign changes of c - mean",
    "wl": "mean |c[k+1] - c[k]|",
    "crest": "max|c| / rms",
    "mobility": "Hjorth mobility of c",
    "complexity": "Hjorth complexity of c",
}
DWT_STAT_FUNCS: dict[str, tuple[str, Stat]] = {
    k: TIME_STATS[k]
    for k in (
        "mean",
        "std",
        "var",
        "rms",
        "min",
        "max",
        "range",
        "abs_mean",
        "median",
        "mad",
        "iqr",
        "p05",
        "p95",
        "skewness",
        "kurtosis",
        "zcr",
        "wl",
        "crest",
        "mobility",
        "complexity",
    )
}

CROSS_STATS: dict[str, str] = {
    "pvdf.time.corr": "Pearson correlation of pvdf1 and pvdf2 (0 if either is constant)",
    "sg.time.corr": "Pearson correlation of sg1 and sg2 (0 if either is constant)",
}

FEATURE_NAMES: tuple[str, ...] = (
    tuple(f"{ch}.time.{s}" for ch in CHANNELS for s in TIME_STATS)
    + tuple(CROSS_STATS)
    + tuple(
        f"{CHANNELS[c]}.dwt.{b}.{s}" for c in PVDF_CHANNELS for b in SUBBANDS for s in DWT_STATS
    )
)
N_FEATURES = len(FEATURE_NAMES)


def _check_signals(signals: object) -> np.ndarray:
    x = np.asarray(signals)
    if x.ndim != 3 or x.shape[1] != len(CHANNELS) or x.shape[2] < 128:
        raise ValueError(
            f"signals must be an array (n, {len(CHANNELS)}, T) with T >= 128; got shape {x.shape}"
        )
    if not np.issubdtype(x.dtype, np.floating) and not np.issubdtype(x.dtype, np.integer):
        raise ValueError(f"signals must be numeric; got dtype {x.dtype}")
    x = x.astype(np.float64)
    if not np.all(np.isfinite(x)):
        raise ValueError("signals contain NaN or inf")
    return x


def _corr(a: dict, b: dict) -> np.ndarray:
    return _safe_div((a["c"] * b["c"]).mean(axis=1), a["std"] * b["std"])


def extract(signals: np.ndarray, *, batch: int = 512) -> np.ndarray:
    """The 386 features of every trial: ``(n, 4, T)`` -> float32 ``(n, 386)``, in the
    order of :data:`FEATURE_NAMES`. Trials are processed ``batch`` at a time (memory)."""
    x = _check_signals(signals)
    out = np.empty((x.shape[0], N_FEATURES), dtype=np.float32)
    for start in range(0, x.shape[0], batch):
        out[start : start + batch] = _extract_block(x[start : start + batch])
    return out


def pool_of(signals: np.ndarray, features: np.ndarray | None) -> np.ndarray:
    """The caller's precomputed pool ``features`` as float32, else :func:`extract`."""
    return extract(signals) if features is None else np.asarray(features, dtype=np.float32)


def _extract_block(x: np.ndarray) -> np.ndarray:
    cols: list[np.ndarray] = []
    moments = [_moments(x[:, c]) for c in range(len(CHANNELS))]
    for m in moments:
        cols += [f(m) for _, f in TIME_STATS.values()]
    cols.append(_corr(moments[0], moments[1]))
    cols.append(_corr(moments[2], moments[3]))
    for c in PVDF_CHANNELS:
        coeffs = pywt.wavedec(x[:, c], WAVELET, level=DWT_LEVEL, axis=-1)  # cA3, cD3, cD2, cD1
        bands = [_moments(band) for band in coeffs]
        total = sum((b["rms"] ** 2) * b["x"].shape[1] for b in bands)
        for b in bands:
            stats = _subband_stats(b, total)
            cols += [stats[s] for s in DWT_STATS]
    feats = np.stack(cols, axis=1)
    return np.nan_to_num(feats, nan=0.0, posinf=0.0, neginf=0.0)


def table() -> list[tuple[int, str, str, str, str]]:
    """(index, name, sensor, domain, definition) of every feature."""
    rows = []
    for i, name in enumerate(FEATURE_NAMES):
        parts = name.split(".")
        sensor = "PVDF" if parts[0].startswith("pvdf") else "SG"
        if name in CROSS_STATS:
            rows.append((i, name, sensor, "time", CROSS_STATS[name]))
        elif parts[1] == "time":
            rows.append((i, name, sensor, "time", TIME_STATS[parts[2]][0]))
        else:
            rows.append((i, name, sensor, f"DWT {parts[2]}", DWT_STATS[parts[3]]))
    return rows


def markdown_table() -> str:
    """``docs/features.md``: every feature with its sensor, domain and definition."""
    lines = [
        "# The 386-feature pool",
        "",
        "Generated by `python3 -m models.features > docs/features.md` from",
        "`models/features.py`; a test fails when this file is out of date. Signals are",
        f"the four DAQ channels at {SAMPLE_RATE_HZ:g} Hz; the wavelet features use a "
        f"{DWT_LEVEL}-level `{WAVELET}` DWT",
        "of the PVDF channels. Features are z-scored with training statistics before use.",
        "",
        "| # | name | sensor | domain | definition |",
        "|---|---|---|---|---|",
    ]
    lines += [f"| {i} | `{n}` | {s} | {d} | {t} |" for i, n, s, d, t in table()]
    return "\n".join(lines) + "\n"


def sensor_of(name: str) -> str:
    """``"PVDF"`` or ``"SG"``: the sensor type a feature name comes from."""
    return "PVDF" if name.split(".")[0].startswith("pvdf") else "SG"


def sensor_shares(
    selected: Sequence[int], feature_names: Sequence[str] = FEATURE_NAMES
) -> tuple[float, float]:
    """(PVDF share, SG share) among the ``selected`` feature indices.

    Feature names are ``<channel>.<domain>.<statistic>``; channels ``pvdf*`` and ``sg*``.

    Examples
    --------
    >>> sensor_shares([0, FEATURE_NAMES.index("sg1.time.rms")])
    (0.5, 0.5)
    """
    sel = [int(i) for i in selected]
    if not sel:
        raise ValueError("selected must hold at least one feature index")
    channels = [feature_names[i].split(".", 1)[0] for i in sel]
    pvdf = sum(c.startswith("pvdf") for c in channels)
    sg = sum(c.startswith("sg") for c in channels)
    return pvdf / len(sel), sg / len(sel)


if __name__ == "__main__":
    print(markdown_table(), end="")
