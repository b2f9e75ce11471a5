"""The finger's contact and mount: MuJoCo's soft-contact parameters of the skin fitted so
that its indentation follows Hertz's law (:mod:`synth.skin_fit`), and the PDMS support's
stiffnesses from its geometry and modulus with the pad's modes on it."""

from __future__ import annotations

import dataclasses

import numpy as np

from ..config import SynthConfig


def skin_contact(config: SynthConfig) -> dict:
    """The skin's soft contact fitted for ``config``'s finger: ``solref`` and ``solimp``
    (``Finger.skin_solref``/``skin_solimp``), and at each of the fit's forces
    (``forces_n``) Hertz's indentation (``hertz_m``) beside the fitted simulation's
    (``simulated_m``)."""
    from .. import contact, skin_fit

    solref, solimp = skin_fit.fit_skin_contact(config)
    fitted = dataclasses.replace(
        config, finger=dataclasses.replace(config.finger, skin_solref=solref, skin_solimp=solimp)
    )
    forces = np.asarray(skin_fit.FIT_FORCES_N)
    f = config.finger
    hertz = contact.hertz_indentation_m(forces, f.pad_radius_m, f.skin_modulus_pa, f.skin_poisson)
    return {
        "solref": solref,
        "solimp": solimp,
        "forces_n": forces,
        "hertz_m": hertz,
        "simulated_m": skin_fit.measure_indentation(fitted, forces),
    }


def mount_figures(config: SynthConfig) -> dict:
    """The PDMS support's stiffnesses from its geometry and modulus, the simulated
    compression stand-in, and the pad's modes on it (compression with the skin's Hertz
    contact at the nominal force beside the support)."""
    from ..closed_loop import skin_stiffness_n_m
    from ..presets import NOMINAL_FORCE_N

    f = config.finger
    return {
        "modulus_pa": f.pdms_modulus_pa,
        "diameter_m": f.pdms_diameter_m,
        "thickness_m": f.pdms_thickness_m,
        "shape_factor": f.pdms_shape_factor,
        "shear_n_m": f.pdms_shear_stiffness_n_m,
        "compression_derived_n_m": f.pdms_normal_stiffness_derived_n_m,
        "compression_simulated_n_m": f.pdms_normal_stiffness_n_m,
        "pitch_nm_rad": f.pdms_pitch_stiffness_nm_rad,
        "modes_hz": f.mount_modes_hz(skin_stiffness_n_m(config, NOMINAL_FORCE_N)),
    }


def fingerprint_gains(config: SynthConfig, force_n: float = 1.0, draws: int = 200) -> dict:
    """How much of each material's periodic marks the fingerprint passes on to the pad
    under ``force_n`` (the marks running along the ridges):

    - ``comb``: the ridges inside the skin's Hertz contact, each weighted by its chord,
      add the mark's phases at their places, ``|sum w exp(i k x)| / sum w``;
    - ``box``: what the central ridge, ``w = ridge_width_m`` wide, passes when it averages
      the surface over its width with equal weight, ``sinc(w / lambda)``;
    - ``rounded``: what it passes when it presses with a rounded (Hertzian line-contact,
      elliptical) pressure profile across its width, ``2 J1(x) / x`` with
      ``x = pi w / lambda``;
    - ``felt``: what the finger passes as the model takes it, every ridge through its
      own width and pressure profile (:func:`synth.texture.ridge_widths_m`,
      :func:`synth.texture.ridge_gains`): ``|sum w g exp(i k x)| / sum w``;
    - ``comb_median`` / ``comb_p90`` / ``percentile``: the comb gain of ``draws`` other
      draws of the same irregularity, and where the finger's own draw ranks among them.

    Returns ``{"ridges", "contact_radius_m", "marks": [{"material", "wavelength_m",
    "comb", "box", "rounded", "felt", "comb_median", "comb_p90", "percentile"}, ...]}``.
    """
    from scipy.special import j1

    from ..texture import (
        FINGERPRINT_SEED,
        contact_radius_m,
        ridge_draw,
        ridge_gains,
        ridge_offsets,
        ridge_widths_m,
        touching_ridges,
    )

    f = config.finger
    radius = float(contact_radius_m(f, force_n))
    own_offsets, own_weights = touching_ridges(f, radius)
    own_widths = ridge_widths_m(f, own_offsets, radius)
    n = ridge_offsets(f).size
    others = [
        touching_ridges(f, radius, ridge_draw(n, f.ridge_spacing_m, f.ridge_jitter, seed))
        for seed in range(FINGERPRINT_SEED + 1, FINGERPRINT_SEED + 1 + draws)
    ]

    def comb(offsets: np.ndarray, weights: np.ndarray, k: float) -> float:
        return float(abs(np.sum(weights * np.exp(1j * k * offsets))) / weights.sum())

    marks = []
    for name, material in config.materials.items():
        for mark in material.texture.periodic:
            k = 2.0 * np.pi / mark.wavelength_m
            x = np.pi * f.ridge_width_m / mark.wavelength_m
            own = comb(own_offsets, own_weights, k)
            gains = ridge_gains(f, own_widths, mark.wavelength_m)
            felt = abs(np.sum(own_weights * gains * np.exp(1j * k * own_offsets)))
            spread = np.array([comb(o, w, k) for o, w in others])
            marks.append(
                {
                    "material": name,
                    "wavelength_m": mark.wavelength_m,
                    "comb": own,
                    "box": float(np.sinc(f.ridge_width_m / mark.wavelength_m)),
                    "rounded": float(2.0 * j1(x) / x),
                    "felt": float(felt / own_weights.sum()),
                    "comb_median": float(np.median(spread)),
                    "comb_p90": float(np.percentile(spread, 90)),
                    "percentile": float(100.0 * np.mean(spread < own)),
                }
            )
    return {"ridges": int(own_offsets.size), "contact_radius_m": radius, "marks": marks}
