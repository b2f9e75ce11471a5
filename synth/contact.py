"""Contact mechanics of the skin: Hertz's sphere-on-flat law, the surface deflection of an
elastic half-space around the contact, and the friction law.

Hertz (Johnson, *Contact Mechanics*, 1985, ch. 3-4): a sphere of radius ``R`` and
modulus ``E`` (Poisson ``nu``) pressed on a rigid flat with force ``F`` indents by
``delta = (9 F^2 / (16 E*^2 R))^(1/3)``, ``E* = E / (1 - nu^2)``, over a contact radius
``a = sqrt(R delta)``. Outside the contact the surface is still pushed in by
``w(r) = delta / pi * ((2 - r^2/a^2) asin(a/r) + sqrt(r^2/a^2 - 1))`` (half of
``delta`` at the contact's rim, decaying as ``a / r``).

All functions are elementwise over numpy arrays. Cube roots, arcsines, exponentials and
powers come from the C library (:mod:`synth.kernels`), whatever vector kernels numpy picks.
"""

from __future__ import annotations

import numpy as np

from . import kernels
from .materials import FrictionLaw


def effective_modulus_pa(modulus_pa: float, poisson: float) -> float:
    """Plane-strain modulus ``E / (1 - nu^2)`` of the skin against a rigid body."""
    return modulus_pa / (1.0 - poisson**2)


def hertz_indentation_m(force_n, radius_m: float, modulus_pa: float, poisson: float):
    """Indentation (m) of an elastic sphere on a rigid flat under ``force_n``."""
    e_star = effective_modulus_pa(modulus_pa, poisson)
    f = np.maximum(np.asarray(force_n, dtype=float), 0.0)
    return kernels.cbrt(9.0 * f**2 / (16.0 * e_star**2 * radius_m))


def hertz_force_n(indentation_m, radius_m: float, modulus_pa: float, poisson: float):
    """Force (N) that indents an elastic sphere on a rigid flat by ``indentation_m``."""
    e_star = effective_modulus_pa(modulus_pa, poisson)
    d = np.maximum(np.asarray(indentation_m, dtype=float), 0.0)
    return 4.0 / 3.0 * e_star * np.sqrt(radius_m) * kernels.power(d, 1.5)


def surface_deflection_m(distance_m, indentation_m, radius_m: float):
    """Inward deflection of the skin's surface at ``distance_m`` from the contact centre
    (inside the contact: the sphere's shape; outside: the half-space solution)."""
    r = np.abs(np.asarray(distance_m, dtype=float))
    delta = np.maximum(np.asarray(indentation_m, dtype=float), 0.0)
    a = np.sqrt(radius_m * delta)
    inside = r <= a
    a_safe = np.where(a > 0, a, 1.0)
    ratio = np.clip(a_safe / np.maximum(r, 1e-12), 0.0, 1.0)
    rr = np.maximum(r / a_safe, 1.0)
    outside = delta / np.pi * ((2.0 - rr**2) * kernels.arcsin(ratio) + np.sqrt(rr**2 - 1.0))
    within = delta - r**2 / (2.0 * radius_m)
    out = np.where(inside, within, outside)
    return np.where(delta > 0, np.maximum(out, 0.0), 0.0)


def surface_slope(distance_m, indentation_m, radius_m: float):
    """Slope ``dw/dx`` of the inward deflection :func:`surface_deflection_m` along a line
    through the contact centre, at the signed distance ``distance_m`` from it (inside the
    contact the sphere's ``-x / R``; outside, the half-space solution's
    ``delta / (pi a) (2 sqrt(rho^2 - 1) / rho - 2 rho asin(1 / rho))`` with
    ``rho = |x| / a``, signed with ``x``; both give ``-a / R`` at the rim)."""
    x = np.asarray(distance_m, dtype=float)
    r = np.abs(x)
    delta = np.maximum(np.asarray(indentation_m, dtype=float), 0.0)
    a = np.sqrt(radius_m * delta)
    a_safe = np.where(a > 0, a, 1.0)
    rho = np.maximum(r / a_safe, 1.0)
    outside = (
        delta
        / (np.pi * a_safe)
        * (2.0 * np.sqrt(rho**2 - 1.0) / rho - 2.0 * rho * kernels.arcsin(1.0 / rho))
    )
    slope = np.where(r <= a, -r / radius_m, outside) * np.sign(x)
    return np.where(delta > 0, slope, 0.0)


def friction_coefficient(law: FrictionLaw, slip_speed_m_s, normal_force_n, scale=1.0):
    """The law's coefficient at ``slip_speed_m_s`` and ``normal_force_n``, times ``scale``
    (the stroke's scatter factor)."""
    v = np.abs(np.asarray(slip_speed_m_s, dtype=float))
    f = np.maximum(np.asarray(normal_force_n, dtype=float), 0.05)  # bounded at light touch
    kinetic = law.kinetic
    if law.velocity_exponent != 0.0:
        v_kin = np.maximum(v, law.stribeck_velocity_m_s) / law.reference_speed_m_s
        kinetic = kinetic * kernels.power(v_kin, law.velocity_exponent)
    stribeck = kinetic + (law.static - law.kinetic) * kernels.exp(
        -((v / law.stribeck_velocity_m_s) ** 2)
    )
    return stribeck * kernels.power(f, law.load_exponent) * scale
