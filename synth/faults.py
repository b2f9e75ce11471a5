"""Sensor and acquisition faults, applied to recorded signals after the DAQ.

The simulator's sensor chain (:mod:`synth.sensors`) models a finger whose films, gauges,
amplifiers and DAQ work as specified. A deployed finger meets other states: a noisier
amplifier or a cable near a motor, a bridge whose zero has moved with temperature, an
amplifier calibrated with the wrong gain, a broken lead, an input range set too low, a
USB DAQ that loses packets. Each function here turns a batch of recorded windows into
what such a fault would have recorded, as a transformation of the recorded signals
(the simulated physics stays as it was): every fault is labelled as a signal-level
fault wherever it is reported.

Conventions, for every function:

- ``signals``: float32 ``(n, 4, T)`` volts at the DAQ rate, channels as
  :data:`synth.trial.CHANNELS`; a new array is returned, the input is never changed.
- ``channels``: the channel indices the fault affects.
- ``seeds``: int ``(n,)``, one per trial (the trial's own seed): a fault's random draws
  for trial ``i`` come from ``SeedSequence([seeds[i], key])`` only, so a trial's faulted
  window does not depend on the batch it is in, and ``key`` (one per fault and
  severity) keeps faults independent of each other.
- Faults that act before the ADC (noise, offsets, gains, a narrowed input range) return
  values on the DAQ's code grid and inside its range (:func:`requantise`), as the DAQ
  would have recorded them.
"""

from __future__ import annotations

import zlib
from collections.abc import Sequence

import numpy as np

from tactile_synth.validation import check_int, check_non_negative

from .config import Acquisition

#: The DAQ the faults requantise for (the simulator's default acquisition).
DAQ = Acquisition()


def fault_key(*parts: object) -> int:
    """A 32-bit key for a fault's random draws from its name and severity."""
    return zlib.crc32("/".join(str(p) for p in parts).encode())


def _rng(seed: int, key: int) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence([int(seed) & 0xFFFFFFFFFFFFFFFF, key]))


def _check(signals: np.ndarray, seeds: np.ndarray | None) -> np.ndarray:
    x = np.asarray(signals)
    if x.ndim != 3 or x.dtype != np.float32:
        raise ValueError(f"signals must be float32 (n, channels, T); got {x.dtype} {x.shape}")
    if seeds is not None and np.asarray(seeds).shape != (x.shape[0],):
        raise ValueError(f"seeds must have one entry per trial ({x.shape[0]},)")
    return x


def _channels(channels: Sequence[int], n_channels: int) -> list[int]:
    out = [check_int("channels", c, minimum=0) for c in channels]
    if not out or max(out) >= n_channels:
        raise ValueError(f"channels must be indices in 0..{n_channels - 1}; got {list(channels)}")
    return out


def requantise(volts: np.ndarray, acq: Acquisition = DAQ) -> np.ndarray:
    """``volts`` clipped to the DAQ's ``+-range_v`` and rounded to its code width, as
    float32 (what the DAQ records of an input that reaches it)."""
    lsb = 2 * acq.range_v / 2**acq.adc_bits
    clipped = np.clip(np.asarray(volts, dtype=np.float64), -acq.range_v, acq.range_v)
    return (np.round(clipped / lsb) * lsb).astype(np.float32)


def added_noise(
    signals: np.ndarray, channels: Sequence[int], rms_v: float, seeds: np.ndarray, *, key: int
) -> np.ndarray:
    """White Gaussian noise of ``rms_v`` volts RMS added on ``channels`` (a noisier
    amplifier, pickup on the leads) before the DAQ."""
    x = _check(signals, seeds)
    rms = check_non_negative("rms_v", rms_v)
    chans = _channels(channels, x.shape[1])
    out = x.astype(np.float64)
    for i, seed in enumerate(seeds):
        out[i, chans] += rms * _rng(seed, key).standard_normal((len(chans), x.shape[2]))
    return requantise(out)


def offset(
    signals: np.ndarray, channels: Sequence[int], offset_v: float, seeds: np.ndarray, *, key: int
) -> np.ndarray:
    """A constant offset of ``offset_v`` volts on each of ``channels``, its sign drawn per
    trial and channel (a bridge whose zero moved since it was nulled: temperature, creep
    of the adhesive), before the DAQ."""
    x = _check(signals, seeds)
    size = check_non_negative("offset_v", offset_v)
    chans = _channels(channels, x.shape[1])
    out = x.astype(np.float64)
    for i, seed in enumerate(seeds):
        signs = np.where(_rng(seed, key).random(len(chans)) < 0.5, -1.0, 1.0)
        out[i, chans] += size * signs[:, None]
    return requantise(out)


def gain_error(
    signals: np.ndarray, channels: Sequence[int], relative: float, *, key: int
) -> np.ndarray:
    """Each of ``channels`` scaled by ``1 + s * relative`` (an amplifier calibrated with
    the wrong gain), ``s`` = +1 or -1 per channel, drawn once from ``key``: the same for
    every trial, as one miscalibrated instrument records them all."""
    x = _check(signals, None)
    rel = check_non_negative("relative", relative)
    if rel >= 1:
        raise ValueError(f"relative must be < 1 (a gain that keeps its sign); got {relative!r}")
    chans = _channels(channels, x.shape[1])
    signs = np.where(_rng(0, key).random(len(chans)) < 0.5, -1.0, 1.0)
    out = x.astype(np.float64)
    out[:, chans] *= (1.0 + signs * rel)[None, :, None]
    return requantise(out)


def dead_channel(
    signals: np.ndarray,
    fraction: float,
    seeds: np.ndarray,
    *,
    key: int,
    burst_samples: int = 100,
    acq: Acquisition = DAQ,
) -> np.ndarray:
    """One channel per trial (drawn per trial) reads only the DAQ's own noise for
    ``fraction`` of the window: a lead that breaks contact. The lost samples come in bursts
    of ``burst_samples`` at random places (1: the whole window); the DAQ still digitises
    its input noise (``acq.noise_v_rms``) there."""
    x = _check(signals, seeds)
    frac = check_non_negative("fraction", fraction)
    if frac > 1:
        raise ValueError(f"fraction must lie in 0..1; got {fraction!r}")
    check_int("burst_samples", burst_samples, minimum=1)
    _n, c, t = x.shape
    out = x.astype(np.float64)
    blocks = -(-t // burst_samples)
    lost = round(frac * blocks)
    for i, seed in enumerate(seeds):
        rng = _rng(seed, key)
        ch = int(rng.integers(c))
        gone = rng.choice(blocks, size=lost, replace=False)
        mask = np.zeros(blocks * burst_samples, dtype=bool)
        for b in gone:
            mask[b * burst_samples : (b + 1) * burst_samples] = True
        mask = mask[:t]
        out[i, ch, mask] = acq.noise_v_rms * rng.standard_normal(int(mask.sum()))
    return requantise(out)


def clipped(signals: np.ndarray, limit_v: float) -> np.ndarray:
    """Every channel clipped to ``+-limit_v`` (an input range set too low, an amplifier
    that saturates at a lower rail)."""
    x = _check(signals, None)
    limit = check_non_negative("limit_v", limit_v)
    if limit == 0:
        raise ValueError("limit_v must be > 0")
    return np.clip(x, -limit, limit).astype(np.float32)


def dropped_samples(
    signals: np.ndarray,
    fraction: float,
    seeds: np.ndarray,
    *,
    key: int,
    packet_samples: int = 16,
) -> np.ndarray:
    """``fraction`` of the window's samples lost in packets of ``packet_samples`` (a USB
    DAQ whose buffer overruns drops whole packets, all channels at once): the samples
    after a lost packet move up, as a recording that does not know about the loss stores
    them, and the window's end holds its last recorded sample."""
    x = _check(signals, seeds)
    frac = check_non_negative("fraction", fraction)
    if frac >= 1:
        raise ValueError(f"fraction must be < 1; got {fraction!r}")
    check_int("packet_samples", packet_samples, minimum=1)
    _n, _c, t = x.shape
    packets = t // packet_samples
    lost = round(frac * packets)
    out = np.empty_like(x)
    for i, seed in enumerate(seeds):
        gone = _rng(seed, key).choice(packets, size=lost, replace=False)
        keep = np.ones(t, dtype=bool)
        for p in gone:
            keep[p * packet_samples : (p + 1) * packet_samples] = False
        kept = x[i][:, keep]
        out[i, :, : kept.shape[1]] = kept
        out[i, :, kept.shape[1] :] = kept[:, -1:]
    return out
