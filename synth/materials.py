"""Specimen materials: the skin's friction law on each surface and the surface texture.

The finger's skin is the same for every specimen, so the contact's stiffness and damping
belong to the finger (:class:`synth.config.Finger`), not to the material: silicone
(~0.3 MPa) is four orders of magnitude softer than printed resin, wood or aluminium
(GPa), so the indentation is the skin's whatever it touches. Materials differ by their
surface: how the skin rubs on it (:class:`FrictionLaw`) and its topography
(:class:`Texture`).

Friction values are for a silicone pad; the sources are named at
:data:`SILICONE_FRICTION`. Texture is the specimen surface height along the sliding direction:
band-limited random roughness (Gaussian, exponential autocorrelation) plus periodic
components running across the sliding direction (machining feed marks, printing raster,
wood grain).
"""

from __future__ import annotations

from dataclasses import dataclass

from . import params

MATERIAL_NAMES: tuple[str, ...] = ("resin", "wood", "aluminum")


@dataclass(frozen=True)
class FrictionLaw:
    """Skin-on-surface friction coefficient as elastomers show it.

    ``mu(v, F) = (kinetic * r(v) + (static - kinetic) * exp(-(v / stribeck_velocity_m_s)^2))
    * (F / 1 N)^load_exponent`` with ``r(v) = (max(v, stribeck_velocity_m_s) /
    reference_speed_m_s)^velocity_exponent`` (1 for the rate-independent law): the
    static coefficient holds at rest and decays to the kinetic one within a few
    ``stribeck_velocity_m_s`` of slip (a Stribeck-type velocity-weakening law), and a
    soft Hertzian contact's coefficient falls with load (a constant interfacial shear
    strength over a contact area growing as ``F^(2/3)``).
    Velocity weakening of this kind is what lets stick-slip arise in the simulation.
    """

    #: Sliding (kinetic) coefficient at 1 N.
    kinetic: float
    #: Coefficient at rest (>= kinetic). Skin and silicone show static / kinetic ratios of
    #: 1.1-1.3 (Temel, Johnson & Lloyd 2022, Tribol. Lett. 70: 0.90 / 0.79 and 0.31 / 0.25).
    static: float
    #: Slip speed over which the coefficient falls from static to kinetic. Not measured
    #: for silicone on these surfaces; 1 mm/s is the order of a contact-renewal length of a
    #: few micrometres over the millisecond relaxation time of a soft elastomer, well
    #: below the 6-14 mm/s sliding speeds, so sliding itself runs at the kinetic level.
    #: A free choice; ``tactile-synth calibrate --sweep`` measures 0.3-3 mm/s for every
    #: material at once (``materials.stribeck_velocity_m_s``).
    stribeck_velocity_m_s: float = 1.0e-3
    #: Exponent of the load dependence: -0.21 measured for a finger pad over 1-20 N (Seo
    #: et al. 2009, Ergonomics 52: coefficient down 46 % from 1 to 20 N); Hertz with a
    #: constant interfacial shear strength gives -1/3.
    load_exponent: float = -0.21
    #: Exponent of the kinetic coefficient's speed dependence, ``(v / reference_speed_m_s)
    #: ^ velocity_exponent`` (slip speeds below the Stribeck speed count as it): 0 for a
    #: rate-independent law (the shared silicone law); the derived laws
    #: (:func:`synth.tribology.derived_law`) take it from the skin's viscoelasticity.
    velocity_exponent: float = 0.0
    #: Speed at which ``kinetic`` holds when ``velocity_exponent`` is not 0.
    reference_speed_m_s: float = 0.010

    def __post_init__(self) -> None:
        params.positive(self, "kinetic", "static", "stribeck_velocity_m_s", "reference_speed_m_s")
        if not -1.0 <= params._value(self, "velocity_exponent") <= 1.0:
            raise ValueError(
                f"FrictionLaw.velocity_exponent must lie in -1..1; got {self.velocity_exponent!r}"
            )
        params.below(self, "static", 3.0, "a skin-on-solid coefficient")
        if self.static < self.kinetic:
            raise ValueError(
                f"FrictionLaw.static must be >= kinetic ({self.kinetic!r}); got {self.static!r}"
            )
        if not -1.0 <= params._value(self, "load_exponent") <= 0.0:
            raise ValueError(
                f"FrictionLaw.load_exponent must lie in -1..0; got {self.load_exponent!r}"
            )


@dataclass(frozen=True)
class Periodic:
    """One periodic surface component ``amplitude * cos(2 pi s / wavelength + phase)``,
    random phase per trial."""

    wavelength_m: float
    amplitude_m: float

    def __post_init__(self) -> None:
        params.positive(self, "wavelength_m")
        params.non_negative(self, "amplitude_m")


@dataclass(frozen=True)
class Texture:
    """Surface height profile model along the sliding path (metres).

    roughness_rms_m: RMS height of the random roughness (Ra ~ 0.8 Rq for Gaussian).
    correlation_length_m: its exponential autocorrelation length (sets the spectrum).
    periodic: periodic components across the sliding direction.
    """

    roughness_rms_m: float
    correlation_length_m: float
    periodic: tuple[Periodic, ...] = ()

    def __post_init__(self) -> None:
        params.non_negative(self, "roughness_rms_m")
        params.positive(self, "correlation_length_m")
        for p in self.periodic:
            if not isinstance(p, Periodic):
                raise ValueError(f"Texture.periodic items must be Periodic; got {p!r}")


@dataclass(frozen=True)
class Material:
    """One specimen material: how the skin rubs on it and what its surface looks like."""

    name: str
    friction: FrictionLaw
    texture: Texture

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"Material.name must be a non-empty string; got {self.name!r}")
        if not isinstance(self.friction, FrictionLaw):
            raise ValueError(f"Material.friction must be a FrictionLaw; got {self.friction!r}")
        if not isinstance(self.texture, Texture):
            raise ValueError(f"Material.texture must be a Texture; got {self.texture!r}")


#: The silicone skin's friction, the same law on every specimen. Silicone on a smooth
#: solid is adhesion-dominated at these speeds, and the one measurement of silicone
#: skins on a counterface of this kind found for this finger is on a printed polymer:
#: two platinum-cure silicones slid over PLA at 10 mm/s under 62.5 kPa, the pressure
#: nearest the skin's mean Hertz pressure at 1 N, give 0.62 (Sil 950) and 1.67 (Dragon
#: Skin 10) (Tortos-Vinocour et al. 2024, IEEE Robot. Autom. Lett.,
#: doi:10.1109/LRA.2024.3376975; ``scripts/calibrate.py friction``): the middle of that
#: range, 1.15, is the kinetic coefficient. No measurement of a silicone skin on wood or
#: aluminium was found: the same law stands for them, so the three materials differ by
#: their surfaces' topography alone, not by a friction figure without a source. Static
#: over kinetic: 1.1-1.3 for skin and silicone (Temel, Johnson & Lloyd 2022, Tribol.
#: Lett. 70), its middle 1.2. The stroke-to-stroke scatter comes from the same silicone
#: runs (``Variability.friction_rel``).
SILICONE_FRICTION = FrictionLaw(kinetic=1.15, static=1.38)

MATERIALS: dict[str, Material] = {
    # Printed (SLA) acrylate resin. Texture: SLA prints measured with a stylus
    # profilometer show Ra 0.87-4.44 um (Arnold, Monsees, Hey & Schweyen 2019, Materials
    # 12, 1970): the middle, Ra 2.66 um, is Rq 3.3 um for a Gaussian profile (Rq = 1.25
    # Ra). A laser SLA printer leaves the raster of its laser spot on a top face, 85 um
    # on a Formlabs Form 3 (its data sheet); the raster's depth is not measured, a free
    # choice of 1 um (plausible 0.5-2 um, under the face's Ra). The correlation length
    # is not measured either: 40 um, the order of the spot (plausible 20-85 um).
    "resin": Material(
        name="resin",
        friction=SILICONE_FRICTION,
        texture=Texture(
            roughness_rms_m=3.3e-6,
            correlation_length_m=40e-6,
            periodic=(Periodic(wavelength_m=85e-6, amplitude_m=1.0e-6),),
        ),
    ),
    # Planed and sanded beech. Texture: sanded beech Ra 3-8 um, rising with the grit's
    # size from P150 to P60 (Gurau, Irle & Buchner 2019, BioResources 14, 4512): the
    # middle, Ra 5.5 um, is Rq 6.9 um. Vessels and fibres give the short-scale roughness
    # (correlation length 120 um, the order of beech's vessels, 50-100 um across, and
    # fibres: not measured as such, plausible 50-200 um); the growth rings a slow relief
    # of a few um every 2-5 mm (ring widths 2-8 mm: Adamopoulos et al. 2009, Eur. J.
    # Wood Prod. 67; its depth, 4 um, is a free choice within the waviness of a few um,
    # 2-6 um; ``tactile-synth calibrate --sweep`` measures both ends).
    "wood": Material(
        name="wood",
        friction=SILICONE_FRICTION,
        texture=Texture(
            roughness_rms_m=6.9e-6,
            correlation_length_m=120e-6,
            periodic=(Periodic(wavelength_m=3.0e-3, amplitude_m=4.0e-6),),
        ),
    ),
    # Face-milled aluminium 6xxx. Texture: Ra 0.34-0.48 um (Chuchala et al. 2021,
    # Materials 14). A 0.8 mm tool nose radius r leaves a cusp profile x^2 / (2 r) at
    # every feed per tooth f = 0.1 mm: peak-to-valley f^2 / (8 r) = 1.6 um, Ra f^2 / (18
    # sqrt(3) r) = 0.40 um. The marks are its fundamental, amplitude f^2 / (2 pi^2 r) =
    # 0.63 um (a cosine with the cusps' Ra); the harmonics (50 um and finer) are left
    # out, as a ridge's contact width averages them away. The random roughness is what
    # the marks leave of the measured Ra: 0.25 um RMS brings the profile to Ra 0.44 um,
    # inside the measured range (correlation length 15 um, not measured: plausible
    # 5-30 um, the order of the cutting edge's own marks).
    "aluminum": Material(
        name="aluminum",
        friction=SILICONE_FRICTION,
        texture=Texture(
            roughness_rms_m=0.25e-6,
            correlation_length_m=15e-6,
            periodic=(Periodic(wavelength_m=0.1e-3, amplitude_m=0.63e-6),),
        ),
    ),
}
