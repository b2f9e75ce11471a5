"""Every parameter of the simulated experiment: one frozen, validated dataclass per physical
component, SI units with the unit in the field name, a one-line rationale per value.

``SynthConfig`` bundles them (plus the material table) and round-trips through plain
dicts (``to_dict``/``from_dict``) so a dataset stores the exact configuration that made it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, Self

from . import params
from .materials import MATERIAL_NAMES, MATERIALS, Material


@dataclass(frozen=True)
class Finger:
    """The paper's finger (Sec. III): rigid phalanx, soft skin pad on a PDMS support."""

    #: Fingertip pad radius; a human-sized fingertip is ~7-8 mm in radius, and it must
    #: drop into the moon's 12.5 mm notch (sag over 6.25 mm > 2 mm needs r < 10.8 mm).
    pad_radius_m: float = 0.007
    #: Moving mass of skin + pad below the PDMS support (a few grams of silicone).
    pad_mass_kg: float = 0.003
    #: Phalanx + carriage mass the robot's force loop moves vertically.
    phalanx_mass_kg: float = 0.05
    #: PDMS support stiffness, normal (1 N compresses ~0.4 mm of soft PDMS).
    pdms_normal_stiffness_n_m: float = 2500.0
    #: PDMS shear stiffness (roughly half the normal one for an elastomer layer).
    pdms_shear_stiffness_n_m: float = 1500.0
    #: PDMS rocking stiffness about the lateral axis (1 N of friction 14 mm below the
    #: mount tilts the pad ~1.5 degrees).
    pdms_pitch_stiffness_nm_rad: float = 0.5
    #: Damping ratio of the PDMS modes (silicone elastomers: 0.1-0.2).
    pdms_damping_ratio: float = 0.15
    #: Fingerprint ridge spacing (human ~0.45 mm; the paper's finger has printed ridges).
    ridge_spacing_m: float = 0.45e-3
    #: Width of one ridge's contact with the surface (averages finer texture).
    ridge_width_m: float = 0.15e-3
    #: Ridges in contact along the sliding direction (contact patch ~3 mm / spacing).
    ridges_in_contact: int = 7
    #: Irregularity of the ridge spacing (real fingerprints are not perfectly periodic).
    ridge_jitter: float = 0.25
    #: MuJoCo solimp of the skin contact (impedance 0.9 -> 0.95 over 1 mm of indentation):
    #: the constraint stiffens as the skin is pressed, like soft tissue.
    skin_solimp: tuple[float, ...] = (0.9, 0.95, 0.001, 0.5, 2.0)
    #: Skin's effective mass loading each PVDF film (inertial stress from skin vibration).
    film_skin_mass_kg: float = 0.001
    #: Height of the two strain-gauge sites above the pad's mount (phalanx as a cantilever).
    gauge_heights_m: tuple[float, ...] = (0.012, 0.020)

    def __post_init__(self) -> None:
        params.positive(
            self,
            "pad_radius_m",
            "pad_mass_kg",
            "phalanx_mass_kg",
            "pdms_normal_stiffness_n_m",
            "pdms_shear_stiffness_n_m",
            "pdms_pitch_stiffness_nm_rad",
            "pdms_damping_ratio",
            "ridge_spacing_m",
            "ridge_width_m",
            "film_skin_mass_kg",
        )
        params.non_negative(self, "ridge_jitter")
        params.below(self, "ridge_jitter", 0.5, "ridges must not swap order")
        if not isinstance(self.ridges_in_contact, int) or self.ridges_in_contact < 1:
            raise ValueError(
                f"Finger.ridges_in_contact must be an integer >= 1; got {self.ridges_in_contact!r}"
            )
        imp = self.skin_solimp
        if len(imp) != 5 or not (0 < imp[0] <= imp[1] < 1) or imp[2] <= 0:
            raise ValueError(
                "Finger.skin_solimp must be (dmin, dmax, width_m, midpoint, power) with "
                f"0 < dmin <= dmax < 1 and width_m > 0; got {imp!r}"
            )
        if len(self.gauge_heights_m) != 2 or min(self.gauge_heights_m) <= 0:
            raise ValueError(
                f"Finger.gauge_heights_m must be two heights > 0; got {self.gauge_heights_m!r}"
            )


@dataclass(frozen=True)
class Motion:
    """The robot's open-loop motion and the physics integration."""

    #: Physics step; 0.5 ms resolves skin vibration up to the 1 kHz DAQ's band and keeps
    #: contact time constants >= 2 steps.
    timestep_s: float = 0.0005
    #: Load phase: finger pressed at the target force before it starts sliding.
    settle_s: float = 0.12
    #: Velocity ramp at the slide start (the robot's acceleration limit).
    ramp_s: float = 0.02
    #: Earliest window start after the slide starts (lets the start transient pass).
    lead_s: float = 0.05
    #: Stiffness of the robot's x/y position servos (a robot arm tip is stiff; soft drives
    #: let friction creep, see MUJOCO-NOTES).
    servo_stiffness_n_m: float = 5000.0
    #: Their damping (about critical for the phalanx mass).
    servo_damping_n_s_m: float = 30.0
    #: Damping of the vertical force loop (the force controller's bandwidth).
    force_loop_damping_n_s_m: float = 5.0
    #: MuJoCo impratio: frictional/normal constraint impedance; 10 makes the elliptic
    #: cone's tangential/normal match the coefficient (MUJOCO-NOTES: 0.83 at 1 vs 0.90).
    impratio: float = 10.0
    #: Where the window centre sits along x relative to the specimen centre.
    window_center_x_m: float = 0.0
    #: Nominal lateral (y) position of the path over the specimen centre.
    path_y_m: float = 0.0
    #: False: slide on the bare base plate (sensor calibration runs, physics checks).
    raised_shape: bool = True

    def __post_init__(self) -> None:
        params.positive(
            self,
            "timestep_s",
            "settle_s",
            "ramp_s",
            "servo_stiffness_n_m",
            "servo_damping_n_s_m",
            "force_loop_damping_n_s_m",
            "impratio",
        )
        params.non_negative(self, "lead_s")
        params.below(self, "timestep_s", 0.001, "the physics must run faster than the 1 kHz DAQ")
        ratio = 1.0 / (self.timestep_s * 1000.0)
        if abs(ratio - round(ratio)) > 1e-9:
            raise ValueError(
                "Motion.timestep_s must divide the 1 ms DAQ period (e.g. 0.0005, 0.00025); "
                f"got {self.timestep_s!r}"
            )
        for name in ("window_center_x_m", "path_y_m"):
            if abs(params._value(self, name)) > 0.01:
                raise ValueError(
                    f"Motion.{name} must lie within +-0.01 m; got {getattr(self, name)!r}"
                )
        if not isinstance(self.raised_shape, bool):
            raise ValueError(
                f"Motion.raised_shape must be True or False; got {self.raised_shape!r}"
            )


@dataclass(frozen=True)
class Variability:
    """Per-trial scatter, drawn from the trial's seed (standard deviations unless noted)."""

    #: Lateral (y) offset of the path: uniform within +- this (placement repeatability).
    lateral_offset_m: float = 1.0e-3
    #: Yaw of the path relative to the specimen.
    yaw_rad: float = 0.02
    #: Start position along x (shifts where the window sits on the specimen).
    start_x_m: float = 0.5e-3
    #: Relative force and speed jitter of the robot.
    force_rel: float = 0.02
    speed_rel: float = 0.02
    #: Specimen-to-specimen material scatter of friction and contact time constant.
    friction_rel: float = 0.04
    stiffness_rel: float = 0.05
    #: Sensor gain scatter (film bonding, gauge placement).
    gain_rel: float = 0.03
    #: The 2 s window's start within the contact phase: uniform in [0, this].
    window_jitter_s: float = 0.08

    def __post_init__(self) -> None:
        names = [f.name for f in dataclasses.fields(self)]
        params.non_negative(self, *names)
        for name in ("force_rel", "speed_rel", "friction_rel", "stiffness_rel", "gain_rel"):
            params.below(self, name, 0.3, "relative scatter")

    def nominal(self) -> Variability:
        """No scatter at all (physics tests use it to compare conditions exactly)."""
        return Variability(**{f.name: 0.0 for f in dataclasses.fields(self)})


@dataclass(frozen=True)
class StrainGauge:
    """Foil strain gauges on the phalanx in quarter Wheatstone bridges (channels 3-4).

    sg1 sits on the front face (bending in the sliding plane), sg2 on the side face
    (bending from lateral load); both also see the axial (normal) load.
    """

    #: Phalanx as a square printed beam (PLA-like): modulus and cross-section side.
    beam_modulus_pa: float = 3.5e9
    beam_side_m: float = 0.008
    #: Constantan foil gauge factor.
    gauge_factor: float = 2.0
    #: Bridge excitation.
    excitation_v: float = 5.0
    #: Instrumentation amplifier gain.
    amplifier_gain: float = 2000.0
    #: DC-coupled low-pass of the conditioning (static channels).
    lowpass_hz: float = 100.0
    #: Unbalance of the bridge at zero load, as strain (resistor tolerance after nulling).
    offset_strain: float = 2e-6

    def __post_init__(self) -> None:
        params.positive(
            self,
            "beam_modulus_pa",
            "beam_side_m",
            "gauge_factor",
            "excitation_v",
            "amplifier_gain",
            "lowpass_hz",
        )
        params.non_negative(self, "offset_strain")
        params.below(self, "lowpass_hz", 500.0, "below the 1 kHz DAQ's Nyquist frequency")


@dataclass(frozen=True)
class PVDF:
    """PVDF films under the skin at the pad's front and rear (channels 1-2).

    Charge ``q = d33 * F_film`` (local contact force plus the skin's inertial load); the
    film capacitance with the amplifier's input resistance is an RC high-pass, so below
    its corner the output follows the stress *rate* (AC-coupled, zero mean).
    """

    #: Piezoelectric coefficient of PVDF (|d33| ~ 20-35 pC/N).
    d33_c_per_n: float = 25e-12
    #: Film capacitance (28 um film, ~1 cm2).
    capacitance_f: float = 1.0e-9
    #: Amplifier input resistance: RC = 10 ms, corner 16 Hz.
    input_resistance_ohm: float = 10e6
    #: Voltage amplifier gain: 1.5 V per newton of film load above the corner, so the
    #: sharpest edge snaps of the perturbation grid (1.4 N, 14 mm/s) peak near 7 V, inside
    #: the DAQ's +-10 V.
    amplifier_gain: float = 60.0

    def __post_init__(self) -> None:
        params.positive(
            self, "d33_c_per_n", "capacitance_f", "input_resistance_ohm", "amplifier_gain"
        )

    @property
    def highpass_hz(self) -> float:
        import math

        return 1.0 / (2 * math.pi * self.input_resistance_ohm * self.capacitance_f)


@dataclass(frozen=True)
class Acquisition:
    """A USB DAQ of the NI USB-6346 class: anti-alias filter, 1 kHz, 16 bit over +-10 V."""

    #: Anti-alias low-pass corner (below the 500 Hz Nyquist) and order (Butterworth).
    antialias_hz: float = 400.0
    antialias_order: int = 4
    #: ADC resolution and input range (+- range_v).
    adc_bits: int = 16
    range_v: float = 10.0
    #: White noise at the ADC input (amplifier + ADC noise; the USB-6346 class is ~0.2 mV
    #: RMS on +-10 V), RMS.
    noise_v_rms: float = 0.3e-3
    #: Mains pickup: frequency and amplitude (random phase per trial).
    mains_hz: float = 50.0
    mains_v: float = 1.0e-3
    #: Slow thermal drift of the DC-coupled bridge channels (random walk, volts per
    #: sqrt(second)); the AC-coupled PVDF chain blocks drift.
    drift_v_per_sqrt_s: float = 2.0e-3

    def __post_init__(self) -> None:
        params.positive(self, "antialias_hz", "range_v", "mains_hz")
        params.non_negative(self, "noise_v_rms", "mains_v", "drift_v_per_sqrt_s")
        params.below(self, "antialias_hz", 500.0, "below the 1 kHz DAQ's Nyquist frequency")
        for name, lo, hi in (("antialias_order", 1, 10), ("adc_bits", 8, 24)):
            value = getattr(self, name)
            if not isinstance(value, int) or not lo <= value <= hi:
                raise ValueError(f"Acquisition.{name} must be an integer in {lo}..{hi}")


def _default_materials() -> dict[str, Material]:
    return dict(MATERIALS)


@dataclass(frozen=True)
class SynthConfig:
    """The whole simulated experiment. ``SynthConfig()`` is the paper's set-up."""

    finger: Finger = field(default_factory=Finger)
    motion: Motion = field(default_factory=Motion)
    variability: Variability = field(default_factory=Variability)
    strain_gauge: StrainGauge = field(default_factory=StrainGauge)
    pvdf: PVDF = field(default_factory=PVDF)
    acquisition: Acquisition = field(default_factory=Acquisition)
    materials: dict[str, Material] = field(default_factory=_default_materials)

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            if f.name == "materials":
                continue
            value = getattr(self, f.name)
            if type(value).__name__ != f.type:
                raise ValueError(
                    f"SynthConfig.{f.name} must be a {f.type}; got {type(value).__name__}"
                )
        if sorted(self.materials) != sorted(MATERIAL_NAMES):
            raise ValueError(
                f"SynthConfig.materials must define exactly {', '.join(MATERIAL_NAMES)}; "
                f"got {', '.join(sorted(self.materials))}"
            )
        for name, mat in self.materials.items():
            if not isinstance(mat, Material) or mat.name != name:
                raise ValueError(
                    f"SynthConfig.materials[{name!r}] must be a Material named {name!r}"
                )
        shortest = min(self.materials[m].contact_timeconst_s for m in MATERIAL_NAMES)
        if shortest * (1 - 3 * self.variability.stiffness_rel) < 2 * self.motion.timestep_s:
            raise ValueError(
                "every material's contact_timeconst_s must stay >= 2 physics steps "
                f"(timestep {self.motion.timestep_s} s) under 3-sigma stiffness scatter; "
                f"shortest is {shortest} s"
            )

    def with_material(self, material: Material) -> Self:
        """A copy with ``material`` replacing the entry of the same name."""
        mats = dict(self.materials)
        if material.name not in mats:
            raise ValueError(
                f"material.name must be one of {', '.join(MATERIAL_NAMES)}; got {material.name!r}"
            )
        mats[material.name] = material
        return dataclasses.replace(self, materials=mats)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-serialisable dict of every parameter."""
        return params.to_dict(self)

    @classmethod
    def from_dict(cls, data: Any) -> SynthConfig:
        """Rebuild from :meth:`to_dict` output; unknown or missing keys raise ValueError."""
        return params.from_dict(cls, data)
