"""Friction of the silicone skin derived from each surface's roughness (Persson's theory of
rubber friction), instead of one measured coefficient for every material.

An elastomer sliding at speed ``v`` over a rough, rigid surface feels two forces
(Persson 2001, J. Chem. Phys. 115, 3840; Persson 2006, Surf. Sci. Rep. 61, 201):

- **hysteresis**: every roughness component of wavevector ``q`` deforms the skin at the
  frequency ``omega = q v cos(phi)``, and the skin's loss modulus dissipates energy,

      mu_h = 1/2 int dq q^3 C(q) P(q) int_0^2pi dphi cos(phi)
             Im E*(q v cos phi) / ((1 - nu^2) sigma_0),

  with ``C(q)`` the surface's power spectrum, ``sigma_0`` the nominal pressure and
  ``P(q)`` the fraction of the nominal area in contact at magnification ``q``,
  ``P(q) = erf(1 / (2 sqrt(G(q))))``,
  ``G(q) = 1/8 int_{q_L}^q dq' q'^3 C(q') int dphi |E*(q' v cos phi) / ((1 - nu^2)
  sigma_0)|^2``;
- **adhesion**: the real contact area ``P(q_1) A_0`` at the shortest wavelength
  resolved carries the interface's frictional shear stress ``tau_f``:
  ``mu_a = tau_f P(q_1) / sigma_0``.

A rough surface (wood) keeps the skin on its asperities' tops, so its contact is small
and its friction mostly hysteresis; a smooth one (milled aluminium) is nearly in full
contact, so its friction is mostly the interface's shear. Both change with speed through
``E*(omega)`` (:mod:`synth.viscoelastic`): the skin stiffens at higher frequency, which
lowers the contact area and raises the loss.

The surface's spectrum is the texture model's own (:class:`synth.materials.Texture`):
its random roughness (exponential autocorrelation of length ``l``, RMS ``h``) has the
isotropic spectrum ``C(q) = h^2 l^2 / (2 pi (1 + q^2 l^2)^(3/2))`` (the 2-D Fourier
transform of ``h^2 exp(-r / l)``; ``int d^2q C = h^2``), and each periodic mark of
amplitude ``A`` and wavevector ``k`` running across the path adds a line
``(A^2 / 4)(delta(q - k) + delta(q + k))`` along the sliding direction: a term
``k^2 A^2 Im E*(k v) P(k) / (4 (1 - nu^2) sigma_0)`` to ``mu_h`` and
``k^2 A^2 |E*(k v)|^2 / (16 (1 - nu^2)^2 sigma_0^2)`` to ``G`` beyond ``k``.

The integrals are numerical (a log-spaced wavevector grid and Gauss-Legendre nodes in
the angle); :func:`derived_law` caches its result per material and finger.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy.special import erf

from . import contact, params
from .finger_config import Finger
from .materials import FrictionLaw, Material, Texture
from .viscoelastic import SILICONE_PRONY, PronyTerm, Viscoelastic

#: Sliding speed the derived law's kinetic coefficient is quoted at (the paper's nominal
#: 10 mm/s), and the speeds its velocity exponent is fitted between (the paper's range).
REFERENCE_SPEED_M_S = 0.010
EXPONENT_SPEEDS_M_S = (0.006, 0.014)
#: Loads the derived law's load exponent is fitted between (the paper's 0.5-2 N range).
EXPONENT_LOADS_N = (0.5, 2.0)
#: Static over kinetic coefficient of skin and silicone, 1.1-1.3 (Temel, Johnson & Lloyd
#: 2022, Tribol. Lett. 70): the middle. The theory gives sliding friction only.
STATIC_OVER_KINETIC = 1.2


@dataclass(frozen=True)
class SkinTribology:
    """What the derived friction needs beyond the finger and the surfaces.

    prony: the silicone's relaxation, as Prony arms relative to the relaxed modulus
        (``Finger.skin_modulus_pa``).
    interfacial_shear_stress_pa: the frictional shear stress of silicone in intimate
        contact with a smooth solid.
    roughness_cutoff_m: the shortest roughness wavelength that counts (``q_1 = 2 pi /
        roughness_cutoff_m``).
    """

    prony: tuple[PronyTerm, ...]
    interfacial_shear_stress_pa: float
    roughness_cutoff_m: float

    def __post_init__(self) -> None:
        params.positive(self, "interfacial_shear_stress_pa", "roughness_cutoff_m")
        for t in self.prony:
            if not isinstance(t, PronyTerm):
                raise ValueError(f"SkinTribology.prony items must be PronyTerm; got {t!r}")

    def skin(self, finger: Finger) -> Viscoelastic:
        return Viscoelastic(finger.skin_modulus_pa, self.prony)


#: Cited values: see docs/friction.md for every source.
SILICONE_TRIBOLOGY = SkinTribology(
    prony=SILICONE_PRONY,
    interfacial_shear_stress_pa=5.0e4,
    roughness_cutoff_m=10e-6,
)

#: Wavevectors per decade and angle nodes of the numerical integrals.
_PER_DECADE = 48
_ANGLES = 32


def nominal_pressure_pa(finger: Finger, force_n: float) -> float:
    """Mean Hertz pressure ``F / (pi a^2)`` of the skin's contact under ``force_n``."""
    delta = float(
        contact.hertz_indentation_m(
            force_n, finger.pad_radius_m, finger.skin_modulus_pa, finger.skin_poisson
        )
    )
    a2 = finger.pad_radius_m * delta
    return force_n / (math.pi * a2)


def _contact_diameter_m(finger: Finger, force_n: float) -> float:
    delta = float(
        contact.hertz_indentation_m(
            force_n, finger.pad_radius_m, finger.skin_modulus_pa, finger.skin_poisson
        )
    )
    return 2.0 * math.sqrt(finger.pad_radius_m * delta)


@dataclass(frozen=True)
class Friction:
    """The derived friction at one speed and load: its hysteresis and adhesive parts and
    the real contact area's fraction of the nominal one."""

    hysteresis: float
    adhesion: float
    contact_fraction: float

    @property
    def total(self) -> float:
        return self.hysteresis + self.adhesion


def friction(
    texture: Texture,
    finger: Finger,
    tribology: SkinTribology,
    *,
    speed_m_s: float,
    force_n: float,
) -> Friction:
    """Persson's sliding friction of the skin on ``texture`` at ``speed_m_s`` under
    ``force_n`` (module docstring)."""
    if not speed_m_s > 0 or not force_n > 0:
        raise ValueError(f"speed_m_s and force_n must be > 0; got {speed_m_s!r}, {force_n!r}")
    skin = tribology.skin(finger)
    sigma0 = nominal_pressure_pa(finger, force_n)
    scale = 1.0 / ((1.0 - finger.skin_poisson**2) * sigma0)
    q_lo = 2.0 * math.pi / _contact_diameter_m(finger, force_n)
    q_hi = 2.0 * math.pi / tribology.roughness_cutoff_m
    n = max(8, int(_PER_DECADE * math.log10(q_hi / q_lo)) + 1)
    q = np.geomspace(q_lo, q_hi, n)
    # Angle integrals over 0..pi/2 (the integrands are even about 0 and pi): x4.
    x, w = np.polynomial.legendre.leggauss(_ANGLES)
    phi = (x + 1.0) * math.pi / 4.0
    w_phi = w * math.pi / 4.0
    e = skin.complex_modulus_pa(q[:, None] * speed_m_s * np.cos(phi)[None, :]) * scale
    loss = 4.0 * (e.imag * np.cos(phi) * w_phi).sum(axis=1)  # int cos(phi) Im E / ...
    mag2 = 4.0 * ((np.abs(e) ** 2) * w_phi).sum(axis=1)  # int |E / ...|^2
    h, length = texture.roughness_rms_m, texture.correlation_length_m
    c = h**2 * length**2 / (2.0 * math.pi * (1.0 + (q * length) ** 2) ** 1.5)
    # G(q): trapezoidal cumulative integral in log q (dq = q dlnq), then the marks' lines.
    dg = q**4 * c * mag2 / 8.0
    lnq = np.log(q)
    g = np.concatenate([[0.0], np.cumsum(0.5 * (dg[1:] + dg[:-1]) * np.diff(lnq))])
    marks = [
        (2.0 * math.pi / p.wavelength_m, p.amplitude_m)
        for p in texture.periodic
        if q_lo <= 2.0 * math.pi / p.wavelength_m <= q_hi
    ]
    mark_g = []
    for k, amp in marks:
        ek = complex(skin.complex_modulus_pa(k * speed_m_s)) * scale
        mark_g.append((k, k**2 * amp**2 * abs(ek) ** 2 / 16.0))
        g = g + np.where(q >= k, mark_g[-1][1], 0.0)
    p_q = _contact(g)
    mu_h = 0.5 * np.trapezoid(q**4 * c * p_q * loss, lnq)
    for k, amp in marks:
        ek = complex(skin.complex_modulus_pa(k * speed_m_s)) * scale
        g_k = float(np.interp(np.log(k), lnq, g))
        mu_h += k**2 * amp**2 * ek.imag * float(_contact(np.array([g_k]))[0]) / 4.0
    fraction = float(p_q[-1])
    mu_a = tribology.interfacial_shear_stress_pa * fraction / sigma0
    return Friction(hysteresis=float(mu_h), adhesion=float(mu_a), contact_fraction=fraction)


def _contact(g: np.ndarray) -> np.ndarray:
    out = np.ones_like(g)
    pos = g > 0
    out[pos] = erf(1.0 / (2.0 * np.sqrt(g[pos])))
    return out


def derived_law(
    material: Material,
    finger: Finger,
    tribology: SkinTribology = SILICONE_TRIBOLOGY,
    force_n: float = 1.0,
) -> FrictionLaw:
    """The material's :class:`FrictionLaw` derived from its texture: the kinetic
    coefficient at :data:`REFERENCE_SPEED_M_S` and ``force_n``, the static one
    :data:`STATIC_OVER_KINETIC` times it, the velocity exponent ``d ln mu / d ln v``
    between :data:`EXPONENT_SPEEDS_M_S` and the load exponent ``d ln mu / d ln F``
    between :data:`EXPONENT_LOADS_N` (clipped to the law's -1..0); the Stribeck speed is
    the material's own."""
    return _derived_law(material.texture, finger, tribology, float(force_n), material.friction)


@functools.lru_cache(maxsize=64)
def _derived_law(
    texture: Texture,
    finger: Finger,
    tribology: SkinTribology,
    force_n: float,
    base: FrictionLaw,
) -> FrictionLaw:
    def mu(v: float, f: float) -> float:
        return friction(texture, finger, tribology, speed_m_s=v, force_n=f).total

    kinetic = mu(REFERENCE_SPEED_M_S, force_n)
    v0, v1 = EXPONENT_SPEEDS_M_S
    f0, f1 = EXPONENT_LOADS_N
    vel_exp = math.log(mu(v1, force_n) / mu(v0, force_n)) / math.log(v1 / v0)
    load_exp = math.log(mu(REFERENCE_SPEED_M_S, f1) / mu(REFERENCE_SPEED_M_S, f0)) / math.log(
        f1 / f0
    )
    return dataclasses.replace(
        base,
        kinetic=round(kinetic, 4),
        static=round(STATIC_OVER_KINETIC * kinetic, 4),
        load_exponent=round(min(0.0, max(-1.0, load_exp)), 4),
        velocity_exponent=round(vel_exp, 4),
        reference_speed_m_s=REFERENCE_SPEED_M_S,
    )


FRICTION_MODELS: tuple[str, ...] = ("shared", "derived")


def with_friction_model(materials: dict[str, Material], finger: Finger, model: str):
    """``materials`` with their friction laws under ``model``: ``"shared"`` leaves them as
    they are (one measured silicone law, or a lab's own figures); ``"derived"`` replaces
    each by :func:`derived_law` from its texture."""
    if model not in FRICTION_MODELS:
        raise ValueError(
            f"friction_model must be one of {', '.join(FRICTION_MODELS)}; got {model!r}"
        )
    if model == "shared":
        return dict(materials)
    return {
        name: dataclasses.replace(m, friction=derived_law(m, finger))
        for name, m in materials.items()
    }
