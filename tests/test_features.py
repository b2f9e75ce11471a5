"""The 386-feature pool: every feature against a direct, per-trial reference computation."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import pywt
from scipy import stats

from models import features as F
from models.features import FEATURE_NAMES, extract

FS = 1000.0


def _ref_time(x: np.ndarray, stat: str) -> float:
    """Plain, one-trial reference of a time-domain statistic (loops and library calls)."""
    n = x.size
    c = x - x.mean()
    sd = x.std()
    rms = np.sqrt(np.mean(x**2))
    am = np.mean(np.abs(x))
    amax = np.max(np.abs(x))
    d1, d2 = np.diff(x), np.diff(x, 2)

    def mob(v, dv):
        return np.sqrt(dv.var() / v.var()) if v.var() > 0 else 0.0

    def zcr(v):
        s = np.signbit(v)
        return np.count_nonzero(s[1:] != s[:-1]) / (v.size - 1)

    def acf(lag):
        return np.mean(c[:-lag] * c[lag:]) / sd**2 if sd > 0 else 0.0

    def quarter(k):
        return c[k * n // 4 : (k + 1) * n // 4].mean()

    if stat == "mean":
        return x.mean()
    if stat == "std":
        return sd
    if stat == "var":
        return x.var()
    if stat == "rms":
        return rms
    if stat == "min":
        return x.min()
    if stat == "max":
        return x.max()
    if stat == "range":
        return np.ptp(x)
    if stat == "abs_mean":
        return am
    if stat == "abs_max":
        return amax
    if stat == "median":
        return np.median(x)
    if stat == "mad":
        return np.median(np.abs(x - np.median(x)))
    if stat == "iqr":
        return stats.iqr(x)
    if stat.startswith("p") and stat[1:].isdigit():
        return np.percentile(x, int(stat[1:]))
    if stat == "skewness":
        return stats.skew(x) if sd > 0 else 0.0
    if stat == "kurtosis":
        return stats.kurtosis(x, fisher=False) if sd > 0 else 0.0
    if stat == "energy":
        return np.mean(x**2)
    if stat == "crest":
        return amax / rms
    if stat == "shape_factor":
        return rms / am
    if stat == "impulse":
        return amax / am
    if stat == "clearance":
        return amax / np.mean(np.sqrt(np.abs(x))) ** 2
    if stat == "zcr":
        return zcr(c)
    if stat == "ssc":
        return zcr(d1)
    if stat == "wl":
        return np.mean(np.abs(d1))
    if stat == "diff_std":
        return d1.std()
    if stat == "diff_absmax":
        return np.max(np.abs(d1))
    if stat == "diff2_std":
        return d2.std()
    if stat == "mobility":
        return mob(x, d1)
    if stat == "complexity":
        return mob(d1, d2) / mob(x, d1)
    if stat.startswith("acf"):
        return acf(int(stat[3:]))
    if stat == "argmax":
        return np.argmax(x) / n
    if stat == "argmin":
        return np.argmin(x) / n
    if stat == "trend":
        return np.polyfit(np.arange(n) / FS, x, 1)[0]
    if stat == "half_diff":
        return x[n // 2 :].mean() - x[: n // 2].mean()
    if stat == "hist_entropy":
        counts, _ = np.histogram(x, bins=10)
        p = counts[counts > 0] / n
        return -np.sum(p * np.log(p))
    if stat == "peak_rate":
        thr = x.mean() + sd
        peaks = [i for i in range(1, n - 1) if x[i] > x[i - 1] and x[i] >= x[i + 1] and x[i] > thr]
        return len(peaks) / (n / FS)
    if stat.startswith("q") and stat.endswith("_mean"):
        return quarter(int(stat[1]) - 1)
    if stat == "spec_centroid":
        p = np.abs(np.fft.rfft(c)) ** 2
        f = np.fft.rfftfreq(n, 1 / FS)
        return np.sum(p * f) / np.sum(p)
    if stat == "dominant_freq":
        p = np.abs(np.fft.rfft(c)) ** 2
        return np.fft.rfftfreq(n, 1 / FS)[np.argmax(p)]
    raise KeyError(stat)


def _ref_dwt(coeff: np.ndarray, total_energy: float, stat: str) -> float:
    energy = np.sum(coeff**2)
    if stat == "energy":
        return energy
    if stat == "rel_energy":
        return energy / total_energy
    if stat == "log_energy":
        return np.log(energy + 1e-12)
    if stat == "entropy":
        p = coeff**2 / energy
        p = p[p > 0]
        return -np.sum(p * np.log(p))
    return _ref_time(coeff, stat)


def _reference(trial: np.ndarray) -> np.ndarray:
    out = []
    for name in FEATURE_NAMES:
        parts = name.split(".")
        if name == "pvdf.time.corr":
            out.append(np.corrcoef(trial[0], trial[1])[0, 1])
        elif name == "sg.time.corr":
            out.append(np.corrcoef(trial[2], trial[3])[0, 1])
        elif parts[1] == "time":
            out.append(_ref_time(trial[F.CHANNELS.index(parts[0])].astype(np.float64), parts[2]))
        else:
            ch = trial[F.CHANNELS.index(parts[0])].astype(np.float64)
            coeffs = dict(zip(F.SUBBANDS, pywt.wavedec(ch, F.WAVELET, level=3), strict=True))
            total = sum(np.sum(c**2) for c in coeffs.values())
            out.append(_ref_dwt(coeffs[parts[2]], total, parts[3]))
    return np.asarray(out)


def test_names_count_order_and_domains():
    assert len(FEATURE_NAMES) == 386 == len(set(FEATURE_NAMES))
    time = [n for n in FEATURE_NAMES if ".time." in n]
    dwt = [n for n in FEATURE_NAMES if ".dwt." in n]
    assert len(time) == 194 and len(dwt) == 192
    assert FEATURE_NAMES[:194] == tuple(time)  # time-domain first, then wavelet
    assert all(n.split(".")[0] in ("pvdf1", "pvdf2") for n in dwt)
    assert {F.sensor_of(n) for n in FEATURE_NAMES} == {"PVDF", "SG"}
    assert "sg1.time.rms" in FEATURE_NAMES and "pvdf2.dwt.cD2.energy" in FEATURE_NAMES


def test_every_feature_matches_a_direct_reference():
    rng = np.random.default_rng(3)
    t = np.arange(500) / FS
    trials = np.stack(
        [
            np.stack(
                [
                    np.sin(2 * np.pi * (20 + 7 * k) * t) + 0.3 * rng.standard_normal(t.size),
                    rng.standard_normal(t.size) ** 3,
                    1.5 + 0.2 * t + 0.05 * rng.standard_normal(t.size),
                    np.abs(rng.standard_normal(t.size)) - 0.2,
                ]
            )
            for k in range(3)
        ]
    ).astype(np.float32)
    got = extract(trials)
    for i in range(len(trials)):
        ref = _reference(trials[i].astype(np.float64))
        bad = [
            (FEATURE_NAMES[j], got[i, j], ref[j])
            for j in range(len(ref))
            if not np.isclose(got[i, j], ref[j], rtol=2e-4, atol=2e-5)
        ]
        assert not bad, bad[:5]


@pytest.mark.parametrize("value", [0.0, 1.0, -3.5])
def test_constant_signals_give_finite_features(value):
    out = extract(np.full((2, 4, 300), value, dtype=np.float32))
    assert out.shape == (2, 386) and out.dtype == np.float32
    assert np.all(np.isfinite(out))


def test_rejects_bad_input():
    with pytest.raises(ValueError, match="signals must be"):
        extract(np.zeros((2, 3, 300)))
    with pytest.raises(ValueError, match="NaN"):
        bad = np.zeros((1, 4, 300))
        bad[0, 0, 5] = np.nan
        extract(bad)


def test_batches_do_not_change_values():
    x = np.random.default_rng(0).standard_normal((7, 4, 400)).astype(np.float32)
    np.testing.assert_array_equal(extract(x, batch=3), extract(x, batch=512))


def test_feature_docs_are_up_to_date():
    doc = Path(__file__).resolve().parents[1] / "docs" / "features.md"
    assert doc.read_text() == F.markdown_table(), (
        "run: python3 -m models.features > docs/features.md"
    )
