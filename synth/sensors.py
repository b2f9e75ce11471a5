"""Virtual sensor chain: strain gauges and PVDF films, then the DAQ.

Everything here works on arrays ``(trials, steps)`` at the physics rate and is elementwise
or filters along the time axis only, so each trial's output is independent of the batch
it was computed in (bit-identical whatever the batching).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import signal

from .config import PVDF, Acquisition, Finger, StrainGauge

STANDARD_GRAVITY = 9.80665


@dataclass(frozen=True)
class Mechanics:
    """Physics-rate signals of a batch, each ``(b, n)`` (global frame unless noted).

    mount_force/mount_torque: load carried by the PDMS mount, in the pad's frame ``(b, n, 3)``.
    pad_acc_z: vertical acceleration of the pad (skin), gravity included.
    contact_force: net skin-specimen contact force on the specimen ``(b, n, 3)``.
    contact_x_rel: force centroid along x relative to the pad centre.
    """

    mount_force: np.ndarray
    mount_torque: np.ndarray
    pad_acc_z: np.ndarray
    contact_force: np.ndarray
    contact_x_rel: np.ndarray


def gauge_strains(mech: Mechanics, finger: Finger, sg: StrainGauge) -> np.ndarray:
    """Surface strain at the two gauges ``(b, 2, n)``.

    The phalanx is a square cantilever above the mount: at height ``H`` the bending moment
    is the mount torque plus ``H x`` the transmitted force. sg1 (front face) sees bending
    in the sliding plane, sg2 (side face) bending from lateral load; both see the axial
    (normal) load. Strain = M c / (E I) + N / (E A).
    """
    a = sg.beam_side_m
    ei = sg.beam_modulus_pa * a**4 / 12.0
    ea = sg.beam_modulus_pa * a * a
    c = a / 2
    f, t = mech.mount_force, mech.mount_torque
    axial = f[..., 2] / ea
    h1, h2 = finger.gauge_heights_m
    m_sliding = t[..., 1] - h1 * f[..., 0]  # moment about y at gauge 1
    m_lateral = t[..., 0] + h2 * f[..., 1]  # moment about x at gauge 2
    return np.stack([m_sliding * c / ei + axial, m_lateral * c / ei + axial], axis=1)


def bridge_volts(strain: np.ndarray, sg: StrainGauge, fs_hz: float) -> np.ndarray:
    """Quarter Wheatstone bridge (exact, slightly non-linear), amplifier, low-pass."""
    x = sg.gauge_factor * (strain + sg.offset_strain)
    v = sg.excitation_v * (x / 4.0) / (1.0 + x / 2.0) * sg.amplifier_gain
    sos = signal.butter(2, sg.lowpass_hz, fs=fs_hz, output="sos")
    return signal.sosfilt(sos, v, axis=-1)


def bridge_zero_v(sg: StrainGauge) -> float:
    """Conditioned bridge output at zero load (its residual unbalance): the level a user
    reads before touching anything, subtracted when calibrating."""
    x = sg.gauge_factor * sg.offset_strain
    return sg.excitation_v * (x / 4.0) / (1.0 + x / 2.0) * sg.amplifier_gain


def film_loads(mech: Mechanics, finger: Finger) -> np.ndarray:
    """Load on the front and rear films ``(b, 2, n)`` (N).

    The skin spreads the contact load over both films; the share of the front film rises
    smoothly with the contact centroid's position ahead of the pad centre (spread length
    a third of the pad radius). The skin's own vibration adds an inertial load.
    """
    total = np.linalg.norm(mech.contact_force, axis=-1)
    spread = finger.pad_radius_m / 3
    front = 0.5 * (1.0 + np.tanh(mech.contact_x_rel / spread))
    inertial = finger.film_skin_mass_kg * (mech.pad_acc_z - STANDARD_GRAVITY)
    return np.stack([front * total + inertial, (1.0 - front) * total + inertial], axis=1)


def pvdf_volts(load_n: np.ndarray, pvdf: PVDF, fs_hz: float) -> np.ndarray:
    """Film charge ``d33 * load`` on its capacitance, loaded by the amplifier's input
    resistance (first-order RC high-pass: below the corner the output follows the load
    rate), times the amplifier gain."""
    v_open = pvdf.d33_c_per_n * load_n / pvdf.capacitance_f
    rc = pvdf.input_resistance_ohm * pvdf.capacitance_f
    b, a = signal.bilinear([rc, 0.0], [rc, 1.0], fs=fs_hz)
    # Zero initial state: the film rests before the finger loads it at t = 0.
    return signal.lfilter(b, a, v_open, axis=-1) * pvdf.amplifier_gain


def antialias(volts: np.ndarray, acq: Acquisition, fs_hz: float) -> np.ndarray:
    """The DAQ's anti-alias low-pass at the physics rate (before resampling)."""
    sos = signal.butter(acq.antialias_order, acq.antialias_hz, fs=fs_hz, output="sos")
    return signal.sosfilt(sos, volts, axis=-1)


def digitise(
    volts: np.ndarray,
    acq: Acquisition,
    fs_hz: float,
    rngs: list[np.random.Generator],
    dc_coupled: np.ndarray,
) -> np.ndarray:
    """Add white noise, mains pickup and (on the ``dc_coupled`` channels) drift at the DAQ
    rate, then quantise over +-range_v with ``adc_bits``. ``volts`` is
    ``(b, channels, n)``; one generator per trial.

    Raises ValueError when a trial saturates the ADC (it would return clipped data)."""
    _b, ch, n = volts.shape
    t = np.arange(n) / fs_hz
    out = np.empty_like(volts)
    for i, rng in enumerate(rngs):
        white = rng.standard_normal((ch, n)) * acq.noise_v_rms
        phase = rng.uniform(0, 2 * math.pi, size=(ch, 1))
        mains = acq.mains_v * np.sin(2 * math.pi * acq.mains_hz * t + phase)
        drift = np.cumsum(rng.standard_normal((ch, n)), axis=1)
        drift *= acq.drift_v_per_sqrt_s / math.sqrt(fs_hz) * dc_coupled[:, None]
        out[i] = volts[i] + white + mains + drift
    lsb = 2 * acq.range_v / 2**acq.adc_bits
    if np.any(np.abs(out) > acq.range_v):
        worst = np.unravel_index(np.argmax(np.abs(out)), out.shape)
        raise SaturationError(
            f"ADC saturated ({float(out[worst]):.2f} V beyond +-{acq.range_v} V) in trial "
            f"{worst[0]} of the batch, channel {worst[1]}: lower the amplifier gain"
        )
    return np.round(out / lsb) * lsb


class SaturationError(ValueError):
    """A channel left the ADC's input range."""
