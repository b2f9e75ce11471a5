"""The PVDF post-amplifier gain: the largest round gain that keeps the worst edge
transient of the perturbation grid's corner within the DAQ's range; and the films'
polyester carrier, which the finger's description does not give: the neutral-axis offset
and shear coupling each stock thickness gives the films, with the gain sized for them."""

from __future__ import annotations

import dataclasses

import numpy as np

from shapes import SHAPE_NAMES

from ..config import SynthConfig
from ..materials import MATERIAL_NAMES
from ..sensors import film_on_carrier
from .settings import CalibrationError, configured, holds_gain

#: Round post-amplifier gains (1-2-5 series) the gain command chooses from.
ROUND_GAINS: tuple[float, ...] = (0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0)


def sized_gain(config: SynthConfig) -> tuple[float, float]:
    """``(worst PVDF transient per unit post-gain (V), largest round gain that keeps it
    below 70 % of the DAQ's range)`` for ``config``; :class:`CalibrationError` when no
    gain fits."""
    from ..sensors import SaturationError
    from ..simulator import simulate_batch
    from ..trial import TrialSpec

    # The worst transient per unit post-gain, read through a DAQ of a wide range.
    probe = dataclasses.replace(
        config,
        pvdf=dataclasses.replace(config.pvdf, post_gain=1.0),
        acquisition=dataclasses.replace(config.acquisition, range_v=1e3, adc_bits=24),
    )
    specs = [
        TrialSpec(s, m, force_n=1.4, speed_mm_s=14.0, seed=k)
        for s in SHAPE_NAMES
        for m in MATERIAL_NAMES
        for k in range(2)
    ]
    try:
        trials = simulate_batch(specs, config=probe)
    except SaturationError as exc:
        raise CalibrationError(
            f"the PVDF transients exceed +-{probe.acquisition.range_v:g} V per unit "
            f"post-gain, so no gain from {ROUND_GAINS[0]:g} fits the DAQ ({exc})"
        ) from None
    per_gain = max(float(np.abs(t.signals[:2]).max()) for t in trials)
    budget = 0.7 * config.acquisition.range_v
    fits = [g for g in ROUND_GAINS if g * per_gain <= budget]
    if not fits:
        raise CalibrationError(
            f"no post-gain from {ROUND_GAINS[0]:g} up keeps the worst PVDF transient "
            f"({per_gain:.1f} V per unit gain) below {budget:g} V"
        )
    return per_gain, max(fits)


def at_sized_gain(config: SynthConfig) -> SynthConfig:
    """``config`` with the post-gain :func:`sized_gain` sizes for it: a lab sizes its
    amplifier for the finger it builds, so a configuration whose films give other
    transients (another readout, carrier or mount) is measured at its own gain, not
    saturated or left in the DAQ's floor by the defaults'."""
    _, best = sized_gain(config)
    return dataclasses.replace(config, pvdf=dataclasses.replace(config.pvdf, post_gain=best))


def configured_at_own_gain(items: list[str] | None) -> SynthConfig:
    """The configuration the ``--set`` ``items`` ask for
    (:func:`synth.calibration.settings.configured`), at the post-gain
    :func:`at_sized_gain` sizes for it unless the items set ``pvdf.post_gain``."""
    config = configured(items)
    return config if holds_gain(items) else at_sized_gain(config)


#: Young's modulus of the films' polyester carrier (PET film: 4-5 GPa).
CARRIER_MODULUS_PA = 4.5e9
#: Carrier thicknesses ``carrier`` reports by default: the standard polyester film
#: stocks, from the thinnest to the laminated elements' (Measurement Specialties, Piezo
#: Film Sensors Technical Manual: 125 um polyester under 28 um film). The defaults
#: assume 75 um, the stock nearest the middle of that range (docs/simulator.md).
CARRIER_THICKNESSES_M = (23e-6, 36e-6, 50e-6, 75e-6, 125e-6)


def carrier_film(config: SynthConfig, thickness_m: float) -> tuple[float, float, float]:
    """``(neutral_axis_offset_m, shear_strain_per_n, post_gain)`` of ``config``'s films on
    a polyester carrier ``thickness_m`` thick (:func:`synth.sensors.film_on_carrier`),
    the gain sized by :func:`sized_gain` for those films; :class:`CalibrationError`
    naming ``--thickness-m`` outside (0, 1 mm]."""
    if not 0 < thickness_m <= 1e-3:
        raise CalibrationError(f"--thickness-m {thickness_m:g}: must be in (0, 0.001] m")
    offset, shear = film_on_carrier(config.pvdf, config.finger, thickness_m, CARRIER_MODULUS_PA)
    pvdf = dataclasses.replace(config.pvdf, neutral_axis_offset_m=offset, shear_strain_per_n=shear)
    _, gain = sized_gain(dataclasses.replace(config, pvdf=pvdf))
    return offset, shear, gain
