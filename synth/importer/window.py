"""A recording's sample rate, its resampling to the DAQ rate and the 2 s window cut from it."""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from fractions import Fraction

import numpy as np

from ..trial import CHANNELS, N_SAMPLES, SAMPLE_RATE_HZ
from .errors import (
    CONTACT_FRACTION,
    CONTACT_SMOOTH_S,
    CONTACT_SNR,
    DAQ_STEP_V,
    MAX_RATIO_DENOMINATOR,
    MAX_RECORDING_S,
    RATE_TOLERANCE,
    REST_FRACTION,
    TIME_COLUMN,
    TIME_STEP_TOLERANCE,
    WINDOW_CONTACT,
    WINDOW_GIVEN,
    WINDOW_WHOLE,
    Bad,
)
from .labels import LabelRow
from .recording import Recording


def rate_from_times(times: np.ndarray, where: Callable[[int], str], shown: str) -> float:
    """The sample rate of uniformly spaced sample times (seconds), to 6 significant
    digits; ``Bad`` naming the first step that is not increasing or breaks the uniform
    spacing."""
    if times.size < 2:
        raise Bad(f"{shown}: one sample time gives no sample rate")
    steps = np.diff(times)
    if np.any(steps <= 0):
        i = int(np.flatnonzero(steps <= 0)[0]) + 1
        raise Bad(f"{shown} {where(i)}: {TIME_COLUMN} does not increase")
    mean = (times[-1] - times[0]) / (times.size - 1)
    off = np.abs(steps - mean) > TIME_STEP_TOLERANCE * mean
    if np.any(off):
        i = int(np.flatnonzero(off)[0]) + 1
        raise Bad(
            f"{shown} {where(i)}: {TIME_COLUMN} steps by {steps[i - 1]:.6g} s where the "
            f"recording's mean step is {mean:.6g} s (a dropped or repeated sample?); "
            f"a recording must be uniformly sampled"
        )
    return float(f"{1.0 / mean:.6g}")  # printed times carry no more digits than this


def sample_rate(row: LabelRow, rec: Recording, option: float | None, shown: str) -> float:
    """The recording's sample rate: the file's own (NPZ ``sample_rate_hz``) or the labels
    table's, else ``option`` (--sample-rate), else its time column; every statement given
    must agree with the others within :data:`RATE_TOLERANCE`."""
    stated = []
    if rec.sample_rate_hz is not None:
        stated.append(("its array 'sample_rate_hz'", rec.sample_rate_hz))
    if row.sample_rate_hz is not None:
        stated.append((f"labels line {row.line}", row.sample_rate_hz))
    if not stated and option is not None:
        stated.append(("--sample-rate", option))
    if rec.time_s is not None:
        stated.append((f"its {TIME_COLUMN}", rate_from_times(rec.time_s, rec.time_where, shown)))
    if not stated:
        raise Bad(
            f"{shown} (labels line {row.line}) states no sample rate; give --sample-rate HZ, "
            f"a sample_rate_hz column in the labels table, or a {TIME_COLUMN} column"
        )
    (first, rate), others = stated[0], stated[1:]
    for name, value in others:
        if abs(value - rate) > RATE_TOLERANCE * rate:
            raise Bad(
                f"{shown} (labels line {row.line}): {first} says {rate:g} Hz but {name} "
                f"gives {value:.6g} Hz"
            )
    return rate


def resampling_ratio(rate_hz: float) -> tuple[int, int]:
    """``(up, down)`` with ``up / down`` = SAMPLE_RATE_HZ / rate_hz in lowest terms
    (denominator at most :data:`MAX_RATIO_DENOMINATOR`)."""
    ratio = (Fraction(SAMPLE_RATE_HZ) / Fraction(rate_hz)).limit_denominator(MAX_RATIO_DENOMINATOR)
    return ratio.numerator, ratio.denominator


def check_duration(samples: int, rate_hz: float, shown: str) -> None:
    """Refuse, before resampling allocates it, a recording longer than
    :data:`MAX_RECORDING_S` (a rate in the wrong unit makes a short file hours long)."""
    seconds = samples / rate_hz
    if seconds > MAX_RECORDING_S:
        raise Bad(
            f"{shown}: {samples} samples at {rate_hz:g} Hz last {seconds:,.0f} s; a recording "
            f"may last at most {MAX_RECORDING_S:,.0f} s (is the sample rate in another unit?)"
        )


def to_daq_rate(signals: np.ndarray, rate_hz: float) -> np.ndarray:
    """``signals`` ``(C, n)`` sampled at ``rate_hz`` brought to SAMPLE_RATE_HZ with
    scipy's polyphase resampler: its Kaiser-windowed FIR low-pass (cut-off at the lower
    of the two Nyquist frequencies) removes what would alias. The ends are padded along
    the line through the edge samples, so a strain gauge's offset does not ring."""
    up, down = resampling_ratio(rate_hz)
    if up == down:
        return np.asarray(signals, dtype=np.float64)
    from scipy.signal import resample_poly

    return resample_poly(signals, up, down, axis=1, padtype="line")


def contact_phase(sg: np.ndarray) -> tuple[int, int] | None:
    """First and last sample of the contact phase in strain-gauge signals ``(k, n)`` at
    SAMPLE_RATE_HZ, or ``None`` if no gauge leaves its rest levels.

    Each gauge is smoothed over :data:`CONTACT_SMOOTH_S`. Its two rest levels are the
    medians of the first and of the last :data:`REST_FRACTION` of the recording (before
    and after the slide; they may differ, e.g. by drift or a finger left on the plate),
    and a sample's deviation is its distance to the nearer one. A gauge counts if its
    largest deviation exceeds :data:`CONTACT_SNR` times its rest noise; the contact phase
    spans the samples where a counted gauge deviates by at least
    :data:`CONTACT_FRACTION` of its largest deviation.
    """
    from scipy.ndimage import uniform_filter1d

    sg = np.asarray(sg, dtype=np.float64)
    n = sg.shape[1]
    width = max(1, round(CONTACT_SMOOTH_S * SAMPLE_RATE_HZ))
    smooth = uniform_filter1d(sg, size=width, axis=1, mode="nearest")
    edge = max(1, int(n * REST_FRACTION))
    deviation = np.full(sg.shape, np.inf)
    noise = np.zeros(sg.shape[0])
    for rest in (smooth[:, :edge], smooth[:, n - edge :]):
        level = np.median(rest, axis=1, keepdims=True)
        spread = 1.4826 * np.median(np.abs(rest - level), axis=1)  # robust standard deviation
        noise = np.maximum(noise, spread)
        deviation = np.minimum(deviation, np.abs(smooth - level))
    peak = deviation.max(axis=1)
    floor = CONTACT_SNR * np.maximum(noise, DAQ_STEP_V)
    live = peak > floor
    if not live.any():
        return None
    threshold = np.maximum(CONTACT_FRACTION * peak, floor)[live, None]
    inside = (deviation[live] >= threshold).any(axis=0)
    idx = np.flatnonzero(inside)
    return int(idx[0]), int(idx[-1])


def window_start(
    signals: np.ndarray, start_s: float | None, shown: str, rate_hz: float
) -> tuple[int, str]:
    """``(first sample, how)`` of the N_SAMPLES window of ``signals`` ``(4, m)`` at
    SAMPLE_RATE_HZ: from ``start_s`` if given, the whole recording if it is one window
    long, else centred on :func:`contact_phase` of sg1/sg2 (kept inside the recording)."""
    m = signals.shape[1]
    if m < N_SAMPLES:
        raise Bad(
            f"{shown} is {m / SAMPLE_RATE_HZ:.3f} s long ({round(m * rate_hz / SAMPLE_RATE_HZ)}"
            f" samples at {rate_hz:g} Hz); a trial needs a window of "
            f"{N_SAMPLES / SAMPLE_RATE_HZ:g} s"
        )
    if start_s is not None:
        first = round(start_s * SAMPLE_RATE_HZ)
        if first + N_SAMPLES > m:
            raise Bad(
                f"{shown}: a window starting at {start_s:g} s ends after the recording's "
                f"{m / SAMPLE_RATE_HZ:.3f} s; the latest start is "
                f"{(m - N_SAMPLES) / SAMPLE_RATE_HZ:g} s"
            )
        return first, WINDOW_GIVEN
    if m == N_SAMPLES:
        return 0, WINDOW_WHOLE
    sg = signals[[CHANNELS.index("sg1"), CHANNELS.index("sg2")]]
    phase = contact_phase(sg)
    if phase is None:
        raise Bad(
            f"{shown}: no contact phase found (sg1 and sg2 stay at their rest levels); "
            f"give the window's start with --window-start S or a window_start_s column"
        )
    centre = (phase[0] + phase[1] + 1) / 2
    first = int(np.clip(round(centre - N_SAMPLES / 2), 0, m - N_SAMPLES))
    return first, WINDOW_CONTACT


def window_id(window: np.ndarray) -> int:
    """A 63-bit id of a trial's window (BLAKE2b of its float32 little-endian bytes): the
    ``seed`` of an imported trial unless the labels table gives one. The same window
    imported twice gets the same id, so the benchmark's check that a perturbation dataset
    does not repeat the nominal one's trials holds for recordings too."""
    digest = hashlib.blake2b(np.ascontiguousarray(window, "<f4").tobytes(), digest_size=8)
    return int.from_bytes(digest.digest(), "little") & (2**63 - 1)
