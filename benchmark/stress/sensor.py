"""The shipped sensor families: faults of the films, the gauges and the DAQ, applied to
recorded windows after the DAQ (:mod:`synth.faults`). ``docs/stress.md`` gives the
reasoning behind every range."""

from __future__ import annotations

import numpy as np

from synth import CHANNELS
from synth.faults import (
    added_noise,
    clipped,
    dead_channel,
    dropped_samples,
    fault_key,
    gain_error,
    offset,
)

from .families import SensorFamily

PVDF = tuple(i for i, c in enumerate(CHANNELS) if c.startswith("pvdf"))
SG = tuple(i for i, c in enumerate(CHANNELS) if c.startswith("sg"))
ALL = tuple(range(len(CHANNELS)))


class PvdfNoise(SensorFamily):
    """White noise on the films' channels: a noisier charge amplifier, film leads (high
    impedance) picking up a motor drive."""

    name = "pvdf-noise"
    summary = "noise floor raised on the PVDF films (signal-level)"
    unit = "mV RMS"
    nominal = 0.0
    levels = (1.0, 3.0, 10.0, 30.0, 100.0)

    def apply(self, signals: np.ndarray, value: float, seeds: np.ndarray) -> np.ndarray:
        return added_noise(signals, PVDF, value * 1e-3, seeds, key=fault_key(self.name, value))


class SgNoise(PvdfNoise):
    """White noise on the gauges' channels: a noisier bridge amplifier, pickup."""

    name = "sg-noise"
    summary = "noise floor raised on the strain gauges (signal-level)"

    def apply(self, signals: np.ndarray, value: float, seeds: np.ndarray) -> np.ndarray:
        return added_noise(signals, SG, value * 1e-3, seeds, key=fault_key(self.name, value))


class SgOffset(SensorFamily):
    """A constant offset on each gauge channel, its sign drawn per trial: the bridge's
    zero moved since it was nulled (temperature, adhesive creep)."""

    name = "sg-offset"
    summary = "strain-gauge offset drift (signal-level)"
    unit = "mV"
    nominal = 0.0
    levels = (10.0, 30.0, 100.0, 300.0, 1000.0)

    def apply(self, signals: np.ndarray, value: float, seeds: np.ndarray) -> np.ndarray:
        return offset(signals, SG, value * 1e-3, seeds, key=fault_key(self.name, value))


class GainError(SensorFamily):
    """Every channel's gain off by the value (its sign fixed per channel): amplifiers
    calibrated with the wrong gain, films whose coupling changed."""

    name = "gain"
    summary = "gain miscalibration of every channel (signal-level)"
    unit = "%"
    nominal = 0.0
    levels = (2.0, 5.0, 10.0, 20.0, 40.0)

    def apply(self, signals: np.ndarray, value: float, seeds: np.ndarray) -> np.ndarray:
        return gain_error(signals, ALL, value / 100.0, key=fault_key(self.name, value))


class DeadChannel(SensorFamily):
    """One channel per trial reads only the DAQ's noise for a share of the window, in
    100 ms bursts: an intermittent lead, dead for good at 100 %."""

    name = "dead-channel"
    summary = "one channel dead for a share of the window (signal-level)"
    unit = "% of window"
    nominal = 0.0
    levels = (10.0, 25.0, 50.0, 75.0, 100.0)

    def apply(self, signals: np.ndarray, value: float, seeds: np.ndarray) -> np.ndarray:
        return dead_channel(signals, value / 100.0, seeds, key=fault_key(self.name, value))


class Clipping(SensorFamily):
    """Every channel clipped at a lower limit than the DAQ's +-10 V: an input range set too
    low, an amplifier saturating at a lower rail."""

    name = "clipping"
    summary = "saturation at a lower input range (signal-level)"
    unit = "V"
    nominal = 10.0
    levels = (5.0, 2.0, 1.0, 0.5, 0.2)

    def apply(self, signals: np.ndarray, value: float, seeds: np.ndarray) -> np.ndarray:
        return signals.copy() if value >= self.nominal else clipped(signals, value)


class DroppedSamples(SensorFamily):
    """A share of the samples lost in 16-sample packets, the rest moved up: a USB DAQ whose
    buffer overruns."""

    name = "dropped-samples"
    summary = "samples dropped by the acquisition (signal-level)"
    unit = "% of samples"
    nominal = 0.0
    levels = (0.5, 1.0, 2.0, 5.0, 10.0)

    def apply(self, signals: np.ndarray, value: float, seeds: np.ndarray) -> np.ndarray:
        return dropped_samples(signals, value / 100.0, seeds, key=fault_key(self.name, value))
