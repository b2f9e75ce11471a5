"""Specimen materials: contact friction, stiffness and damping, density, surface texture.

Values are for the paper's three specimen materials touched by a silicone/PDMS-skinned
finger, chosen from published ranges (sources per field below). The contact stiffness
and damping are those of the *skin-material interface*: the skin (MPa) is far softer
than any of the materials (GPa), so the interface is dominated by the skin and the
materials differ mainly in how the hard surface loses energy (wood's fibres are lossy,
metal rings). MuJoCo's soft-contact parameters ``solref = (timeconst, dampratio)`` express
this; ``timeconst`` must stay >= 2 physics steps.

Texture is the specimen surface height along the sliding path: band-limited random
roughness (Gaussian, exponential autocorrelation = Lorentzian spectrum, with a given RMS
height and correlation length) plus periodic components (wood grain, printed-resin
layer lines, machining feed marks) running across the sliding direction.
"""

from __future__ import annotations

from dataclasses import dataclass

from . import params

MATERIAL_NAMES: tuple[str, ...] = ("resin", "wood", "aluminum")


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
    """One specimen material. ``friction`` is the skin-material sliding coefficient."""

    name: str
    friction: float
    contact_timeconst_s: float
    contact_dampratio: float
    density_kg_m3: float
    texture: Texture

    def __post_init__(self) -> None:
        params.positive(
            self, "friction", "contact_timeconst_s", "contact_dampratio", "density_kg_m3"
        )
        params.below(self, "friction", 3.0, "a skin-on-solid sliding coefficient")
        if not isinstance(self.texture, Texture):
            raise ValueError(f"Material.texture must be a Texture; got {self.texture!r}")


MATERIALS: dict[str, Material] = {
    # 3-D printed resin: skin-on-polymer friction 0.4-0.7 (Derler & Gerhardt 2012,
    # Tribol. Lett. 45); printed top surface Rq ~1-2 um between raster/layer lines ~0.4 mm
    # apart and a few um deep. Density of cured acrylate resin ~1.18 g/cm3.
    "resin": Material(
        name="resin",
        friction=0.55,
        contact_timeconst_s=0.0025,
        contact_dampratio=1.0,
        density_kg_m3=1180.0,
        texture=Texture(
            roughness_rms_m=1.5e-6,
            correlation_length_m=60e-6,
            periodic=(Periodic(wavelength_m=0.4e-3, amplitude_m=3.0e-6),),
        ),
    ),
    # Planed hardwood (beech): skin-on-wood 0.5-0.8 (Derler & Gerhardt 2012); sanded wood
    # Rq ~5-10 um; earlywood/latewood grain bands ~0.5-1.5 mm wide, ~10 um relief; fibres
    # dissipate (dampratio > 1). Beech ~0.70 g/cm3.
    "wood": Material(
        name="wood",
        friction=0.70,
        contact_timeconst_s=0.003,
        contact_dampratio=1.3,
        density_kg_m3=700.0,
        texture=Texture(
            roughness_rms_m=6.0e-6,
            correlation_length_m=200e-6,
            periodic=(Periodic(wavelength_m=0.9e-3, amplitude_m=8.0e-6),),
        ),
    ),
    # Milled aluminium 6061: skin-on-aluminium 0.3-0.5 (Derler & Gerhardt 2012); milled
    # Ra ~0.4-0.8 um with feed marks at the ~0.1 mm feed per revolution; stiff and lightly damped
    # (dampratio < 1: the hard surface rings). 2.70 g/cm3.
    "aluminum": Material(
        name="aluminum",
        friction=0.40,
        contact_timeconst_s=0.002,
        contact_dampratio=0.8,
        density_kg_m3=2700.0,
        texture=Texture(
            roughness_rms_m=0.5e-6,
            correlation_length_m=20e-6,
            periodic=(Periodic(wavelength_m=0.1e-3, amplitude_m=0.4e-6),),
        ),
    ),
}
