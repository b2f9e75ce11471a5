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
