"""Virtual sensor chain: strain gauges and PVDF films, then the DAQ.

Everything here works on arrays ``(trials, steps)`` at the physics rate and is elementwise
or filters along the time axis only, so each trial's output is independent of the batch
it was computed in (bit-identical whatever the batching).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy import signal

from . import kernels
from .config import PVDF, Acquisition, Finger, StrainGauge, SynthConfig


@dataclass(frozen=True)
class Mechanics:
    """Physics-rate signals of a batch, each ``(b, n)`` unless noted.

    mount_force/mount_torque: load carried by the PDMS mount, in the phalanx's frame
        ``(b, n, 3)``.
    contact_ahead_m: the contact's force centroid ahead of the pad's axis along the path
        (0 without contact).
    indentation_m: the skin's deepest penetration into the specimen (0 without contact).
    traction_n: the contact's tangential force on the skin along the path (0 without
        contact).
    """

    mount_force: np.ndarray
    mount_torque: np.ndarray
    contact_ahead_m: np.ndarray
    indentation_m: np.ndarray
    traction_n: np.ndarray


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
    return signal.sosfilt(_butter_sos(2, sg.lowpass_hz, fs_hz), v, axis=-1)


def bridge_zero_v(sg: StrainGauge) -> float:
    """Conditioned bridge output at zero load (its residual unbalance): the level a user
    reads before touching anything, subtracted when calibrating."""
    x = sg.gauge_factor * sg.offset_strain
    return sg.excitation_v * (x / 4.0) / (1.0 + x / 2.0) * sg.amplifier_gain


def film_strains(mech: Mechanics, finger: Finger, pvdf: PVDF) -> np.ndarray:
    """In-plane strain of the front and rear films ``(b, 2, n)``: their bending plus the
    skin's shear under the traction.

    Each film lies along the path under the skin and bends with the skin's surface, which
    the contact pushes in by ``w(x)`` (:func:`synth.contact.surface_deflection_m`: the
    sphere's shape inside the contact, the half-space solution outside). The film's mean
    curvature over its length ``L`` is the change of the surface's slope from one end to
    the other, ``(w'(x2) - w'(x1)) / L`` (:func:`synth.contact.surface_slope`): a film
    that is only moved, not bent, carries none. Its mean strain through the thickness,
    which its charge follows, is that curvature times the distance ``e`` from its
    mid-plane to the neutral axis (:attr:`synth.config.PVDF.neutral_axis_offset_m`); the
    sign is the one of a film stretched on its bonded face by a concave bend. The shear
    adds ``shear_strain_per_n`` times the traction along the path, with opposite signs in
    the two films (:attr:`synth.config.PVDF.shear_strain_per_n`).
    """
    ahead = np.ascontiguousarray(mech.contact_ahead_m, dtype=float)
    out = np.empty((ahead.shape[0], 2, ahead.shape[1]))
    signs = np.array([1.0, -1.0])  # front film ahead of the pad's axis, rear film behind it
    # A traction along the path shortens the skin ahead of the contact and stretches it
    # behind (Cerruti); sliding friction, against the path, does the reverse.
    kernels.film_strains(
        ahead,
        np.ascontiguousarray(mech.indentation_m, dtype=float),
        np.ascontiguousarray(mech.traction_n, dtype=float),
        # A pitched finger turns the films about the pad's centre: its right-hand turn
        # about y moves them back by R sin(pitch) against the contact.
        signs * pvdf.offset_m - finger.pad_radius_m * math.sin(finger.pitch_rad),
        pvdf.length_m / 2.0,
        finger.pad_radius_m,
        -pvdf.neutral_axis_offset_m,
        pvdf.length_m,
        signs * pvdf.shear_strain_per_n,
        out,
    )
    return out


def film_on_carrier(
    pvdf: PVDF, finger: Finger, carrier_thickness_m: float, carrier_modulus_pa: float
) -> tuple[float, float]:
    """``(neutral_axis_offset_m, shear_strain_per_n)`` of ``pvdf``'s film bonded on a
    carrier of ``carrier_thickness_m`` and ``carrier_modulus_pa``: the derivation of
    :class:`synth.config.PVDF`'s two defaults (rounded from a 75 um polyester carrier).

    The laminate bends about the height where the layers' first moments of ``E t``
    balance; the film's charge follows the strain at its mid-plane, ``e`` from that
    axis. Under a tangential traction ``Q`` the skin's in-plane force per unit width at
    the film's distance ``x`` from the contact is ``(1 + nu) Q / (pi x)`` (Cerruti), and
    the laminate strains by it over its in-plane stiffness ``sum(E t)``."""
    film = pvdf.youngs_modulus_pa * pvdf.thickness_m
    carrier = carrier_modulus_pa * carrier_thickness_m
    # Heights above the carrier's free face: the carrier's mid-plane, the film's.
    axis = (
        carrier * carrier_thickness_m / 2 + film * (carrier_thickness_m + pvdf.thickness_m / 2)
    ) / (carrier + film)
    offset = carrier_thickness_m + pvdf.thickness_m / 2 - axis
    shear = (1 + finger.skin_poisson) / (math.pi * pvdf.offset_m * (film + carrier))
    return offset, shear


def pvdf_volts(strain: np.ndarray, pvdf: PVDF, fs_hz: float) -> np.ndarray:
    """Charge ``d31 E strain A`` into a charge amplifier: ``-q / C_f`` above the high-pass
    corner of its feedback ``R_f C_f`` (first order: below the corner the output follows
    the strain rate), times the post-amplifier gain."""
    charge = pvdf.d31_c_per_n * pvdf.youngs_modulus_pa * strain * pvdf.area_m2
    b, a, zi_unit = _charge_amplifier(
        pvdf.feedback_resistance_ohm * pvdf.feedback_capacitance_f, fs_hz
    )
    # The finger has rested under load long before the record starts: the amplifier has
    # settled to the initial strain (zero output for a constant input).
    x = -charge / pvdf.feedback_capacitance_f
    zi = zi_unit * x[..., :1]
    v, _ = signal.lfilter(b, a, x, axis=-1, zi=zi)
    return v * pvdf.post_gain


def amplifier_noise_v(config: SynthConfig) -> np.ndarray:
    """RMS output noise of each channel's amplifier ``(4,)`` (PVDF, PVDF, SG, SG): its
    input noise density times its noise gain over its noise bandwidth (first-order
    equivalent: pi / 2 times the channel's band edge)."""
    pv, sg, acq = config.pvdf, config.strain_gauge, config.acquisition
    noise_gain = 1.0 + pv.capacitance_f / pv.feedback_capacitance_f
    pvdf_rms = (
        pv.amplifier_noise_v_per_sqrt_hz
        * noise_gain
        * pv.post_gain
        * math.sqrt(math.pi / 2 * acq.antialias_hz)
    )
    sg_rms = (
        sg.amplifier_noise_v_per_sqrt_hz
        * sg.amplifier_gain
        * math.sqrt(math.pi / 2 * sg.lowpass_hz)
    )
    return np.array([pvdf_rms, pvdf_rms, sg_rms, sg_rms])


def antialias(volts: np.ndarray, acq: Acquisition, fs_hz: float) -> np.ndarray:
    """The DAQ's anti-alias low-pass at the physics rate (before resampling)."""
    return signal.sosfilt(_butter_sos(acq.antialias_order, acq.antialias_hz, fs_hz), volts, axis=-1)


def _butter_sos(order: int, cutoff_hz: float, fs_hz: float) -> np.ndarray:
    """A Butterworth low-pass's second-order sections, a fresh copy of the design (made
    once per setting: every batch filters with the same few)."""
    return _butter_design(order, cutoff_hz, fs_hz).copy()


@functools.lru_cache(maxsize=16)
def _butter_design(order: int, cutoff_hz: float, fs_hz: float) -> np.ndarray:
    return signal.butter(order, cutoff_hz, fs=fs_hz, output="sos")


def _charge_amplifier(rc_s: float, fs_hz: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(b, a, zi)`` of the charge amplifier's first-order high-pass ``s rc / (s rc + 1)``
    at ``fs_hz`` (bilinear transform) and its steady state for a unit input; fresh copies
    of the design, made once per setting."""
    return tuple(x.copy() for x in _charge_design(rc_s, fs_hz))


@functools.lru_cache(maxsize=16)
def _charge_design(rc_s: float, fs_hz: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    b, a = signal.bilinear([rc_s, 0.0], [rc_s, 1.0], fs=fs_hz)
    return b, a, signal.lfilter_zi(b, a)


def digitise(
    volts: np.ndarray,
    acq: Acquisition,
    fs_hz: float,
    rngs: list[np.random.Generator],
    dc_coupled: np.ndarray,
    amplifier_noise_v: np.ndarray | None = None,
) -> np.ndarray:
    """Add white noise (the ADC's and, per channel, ``amplifier_noise_v`` RMS), mains
    pickup and (on the ``dc_coupled`` channels) drift at the DAQ rate, then quantise over
    +-range_v with ``adc_bits``. ``volts`` is ``(b, channels, n)``; one generator per trial.

    Raises ValueError when a trial saturates the ADC (it would return clipped data)."""
    _b, ch, n = volts.shape
    amp = np.zeros(ch) if amplifier_noise_v is None else np.asarray(amplifier_noise_v)
    noise_rms = np.sqrt(acq.noise_v_rms**2 + amp**2)
    t = np.arange(n) / fs_hz
    out = np.empty_like(volts)
    for i, rng in enumerate(rngs):
        white = rng.standard_normal((ch, n)) * noise_rms[:, None]
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
            f"{worst[0]} of the batch, channel {worst[1]}: a lighter force, or a smaller "
            "gain of that channel's amplifier (pvdf.post_gain, strain_gauge.amplifier_gain), "
            "keeps it inside"
        )
    return np.round(out / lsb) * lsb


class SaturationError(ValueError):
    """A channel left the ADC's input range."""
