"""The skin's viscoelasticity: the silicone's complex modulus ``E*(omega)`` from a Prony
series.

A platinum-cure silicone relaxes: a step strain held at rest leaves the relaxed modulus
``E_inf`` after the series' relaxation times, and a fast strain meets the relaxed modulus
plus every Prony term whose time is longer than the strain's period. The generalised
Maxwell (Prony) model gives, at angular frequency ``omega``,

    E*(omega) = E_inf + sum_i E_i (i omega tau_i) / (1 + i omega tau_i),

storage modulus ``Re E*`` rising and loss modulus ``Im E*`` peaking near each
``1 / tau_i``. The finger's relaxed modulus is ``Finger.skin_modulus_pa`` (the
quasi-static indentation the skin's Hertz contact follows); the Prony terms are given
relative to it (:attr:`Viscoelastic.ratios`), so a lab that changes the skin's modulus
keeps the compound's relaxation shape.

Where the finger uses it: :mod:`synth.tribology` derives each material's friction from
the surface's roughness and this modulus at the frequencies the roughness excites,
``omega = q v`` (wavevector ``q``, sliding speed ``v``); and, with
``Finger.skin_texture_response = "viscoelastic"``, the skin answers the texture it slides
over with this modulus (:meth:`Viscoelastic.sampled_arms`, :func:`synth.kernels.viscoelastic_felt`):
the height and slope the surface imposes at the contact reach the skin's contact force
through ``E*(omega) / E_inf``, so a texture passed faster meets a stiffer, lossier skin.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import params


@dataclass(frozen=True)
class PronyTerm:
    """One Maxwell arm: its modulus relative to the relaxed modulus and its relaxation
    time."""

    ratio: float
    relaxation_time_s: float

    def __post_init__(self) -> None:
        params.non_negative(self, "ratio")
        params.positive(self, "relaxation_time_s")


@dataclass(frozen=True)
class Viscoelastic:
    """A generalised Maxwell solid: relaxed modulus ``relaxed_modulus_pa`` plus Prony
    arms (:class:`PronyTerm`)."""

    relaxed_modulus_pa: float
    terms: tuple[PronyTerm, ...] = ()

    def __post_init__(self) -> None:
        params.positive(self, "relaxed_modulus_pa")
        for t in self.terms:
            if not isinstance(t, PronyTerm):
                raise ValueError(f"Viscoelastic.terms items must be PronyTerm; got {t!r}")

    @property
    def ratios(self) -> np.ndarray:
        return np.array([t.ratio for t in self.terms])

    @property
    def times_s(self) -> np.ndarray:
        return np.array([t.relaxation_time_s for t in self.terms])

    def complex_modulus_pa(self, omega_rad_s) -> np.ndarray:
        """``E*(omega)`` (complex, Pa), elementwise over ``omega_rad_s`` (>= 0)."""
        w = np.asarray(omega_rad_s, dtype=float)[..., None]
        iwt = 1j * w * self.times_s
        arms = (self.ratios * iwt / (1.0 + iwt)).sum(axis=-1)
        return self.relaxed_modulus_pa * (1.0 + arms)

    def loss_tangent(self, omega_rad_s) -> np.ndarray:
        """``tan(delta) = Im E* / Re E*`` at ``omega_rad_s``."""
        e = self.complex_modulus_pa(omega_rad_s)
        return e.imag / e.real

    def scaled(self, relaxed_modulus_pa: float) -> Viscoelastic:
        """The same compound's relaxation shape at another relaxed modulus."""
        return Viscoelastic(relaxed_modulus_pa, self.terms)

    def sampled_arms(self, step_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The Prony arms as recursive filters of a strain sampled every ``step_s``
        seconds: ``(ratios, decays, gains)``. Each arm is the high-pass ``i omega tau /
        (1 + i omega tau)`` of the strain, discretised ramp-invariantly (the strain
        linear between samples): ``y_n = decay y_(n-1) + gain (x_n - x_(n-1))`` with
        ``decay = exp(-step / tau)`` and ``gain = tau / step (1 - decay)``, exact for a
        piecewise-linear strain; the stress over ``E_inf`` is ``x + sum ratio_i y_i``. An
        arm faster than the step (``tau < step``) relaxes within it (decay near 0) and
        answers as a dashpot, ``y ~ tau dx/dt`` (gain near ``tau / step``)."""
        if not step_s > 0:
            raise ValueError(f"step_s must be > 0; got {step_s!r}")
        decays = np.array([math.exp(-step_s / t.relaxation_time_s) for t in self.terms])
        return self.ratios, decays, self.times_s / step_s * (1.0 - decays)


#: The skin compound's relaxation shape, relative to its relaxed modulus: three arms a
#: decade or two apart, which make the storage modulus of a soft platinum-cure silicone
#: rise by 60 % from rest to well above a kilohertz (|E*| is 1.23-1.32 times the relaxed
#: modulus across the films' 20-400 Hz band). A generic shape of the class, not a fit to
#: a measured table of this skin (docs/friction.md: "Its inputs, and how well each is
#: known").
SILICONE_PRONY: tuple[PronyTerm, ...] = (
    PronyTerm(ratio=0.30, relaxation_time_s=1.0e-4),
    PronyTerm(ratio=0.20, relaxation_time_s=1.0e-2),
    PronyTerm(ratio=0.10, relaxation_time_s=1.0),
)
