"""Every parameter of the simulated experiment: one frozen, validated dataclass per physical
component, SI units with the unit in the field name, a one-line rationale per value.

``SynthConfig`` bundles them (plus the materials and the user's specimens) and round-trips
through plain dicts (``to_dict``/``from_dict``) so a dataset stores the exact
configuration that made it.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Self

from shapes import SHAPE_NAMES, Specimen, SpecimenLike, specimen_from_dict, specimen_to_dict

from . import params
from .materials import MATERIALS, Material
from .trial import check_name

#: Vacuum permittivity (F/m).
VACUUM_PERMITTIVITY_F_M = 8.8541878128e-12


@dataclass(frozen=True)
class Finger:
    """The paper's finger (Sec. III): rigid phalanx, soft skin pad on a PDMS support."""

    #: Fingertip pad radius; a human-sized fingertip is ~7-8 mm in radius, and it must
    #: drop into the moon's 12.5 mm notch (sag over 6.25 mm > 2 mm needs r < 10.8 mm).
    pad_radius_m: float = 0.007
    #: Moving mass below the PDMS support: silicone skin pad, films and the support's
    #: moving half (a silicone hemisphere of 7 mm radius alone is ~0.8 g). Not measured
    #: for the paper's finger; plausible 1-4 g (``scripts/calibrate.py mount`` prints the
    #: mount's modes for it).
    pad_mass_kg: float = 0.003
    #: Phalanx + carriage mass the robot's drives move.
    phalanx_mass_kg: float = 0.05
    #: Young's modulus of the PDMS support: Sylgard 184 at the usual 10:1 mix, 2.0 MPa
    #: (``E = 20 MPa / mix ratio`` over 5:1-33:1, 0.57-3.7 MPa, measured in compression:
    #: Wang, Volinsky & Gallant 2014, J. Appl. Polym. Sci. 131, 41050). Nearly
    #: incompressible, so its shear modulus is ``E / 3``.
    pdms_modulus_pa: float = 2.0e6
    #: The support's geometry, a PDMS disc bonded between the phalanx and the pad. The
    #: finger's description does not give it: a free choice that fits under the 14 mm
    #: pad (plausible 6-12 mm across, 1-4 mm thick; ``scripts/calibrate.py sweep``
    #: measures the thickness). Its stiffnesses follow (:attr:`pdms_shear_stiffness_n_m`,
    #: :attr:`pdms_pitch_stiffness_nm_rad`, :attr:`pdms_normal_stiffness_derived_n_m`).
    #: 10 x 3 mm puts the shear mode at 380 Hz and the rocking mode at 310 Hz, above the
    #: texture's tones (60-170 Hz from 6 to 14 mm/s) but inside the 20-400 Hz band: the
    #: thinner 2 mm disc, whose modes lie above 400 Hz (470 and 500 Hz), rocks with a
    #: mode the 0.5 ms step cannot integrate under stick-slip (MuJoCo diverges), so 3 mm
    #: is the thinnest disc in half-millimetre steps the simulation carries. A limit of
    #: the physics step, stated as such (``docs/simulator.md``, "The finger's mount").
    pdms_diameter_m: float = 0.010
    pdms_thickness_m: float = 0.003
    #: The support's compression stiffness as simulated. A bonded disc this squat is some
    #: 14 times stiffer in compression than in shear (:attr:`pdms_normal_stiffness_derived_n_m`,
    #: about 330 kN/m): its mode on the pad's mass would lie near 1.7 kHz, which the
    #: 0.5 ms physics step cannot integrate (MuJoCo steps joint springs explicitly, stable
    #: up to about 600 Hz at that step). The simulated support is therefore the stiffest
    #: whose mode, with the skin contact beside it, lies above the 400 Hz anti-alias
    #: corner with a margin (35 kN/m: 560 Hz at 3 g). Below the band the two read alike:
    #: either deflects by a few hundredths of a millimetre under 1 N, against the skin's
    #: 0.8 mm indentation. A numerical stand-in, not a measured value.
    pdms_normal_stiffness_n_m: float = 21000.0
    #: Damping ratio of the PDMS modes: half the loss tangent of a silicone elastomer
    #: (0.1-0.4 at 10-1000 Hz at room temperature); not measured for this support, a free
    #: choice in that range.
    pdms_damping_ratio: float = 0.15
    #: Young's modulus of the silicone skin: platinum-cure silicone of the Dragon Skin 20
    #: class, 0.29 MPa small-strain tensile modulus (Marechal et al. 2021, Soft Robotics
    #: Materials Database); a human fingertip is 0.07-0.2 MPa (Oprisan et al. 2016).
    skin_modulus_pa: float = 0.29e6
    #: Poisson's ratio of silicone (nearly incompressible: 0.48-0.499).
    skin_poisson: float = 0.49
    #: MuJoCo soft-contact parameters of the skin, one set for every material: solref
    #: (time constant s, damping ratio) and solimp (dmin, dmax, width m, midpoint, power).
    #: Fitted by ``scripts/calibrate.py skin`` so that the simulated indentation follows
    #: Hertz's law of a sphere of ``pad_radius_m`` and ``skin_modulus_pa`` on a rigid flat
    #: over 0.3-2 N (``synth.contact.hertz_indentation_m``), within 3.1 % at every load.
    skin_solref: tuple[float, ...] = (0.001, 1.0)
    skin_solimp: tuple[float, ...] = (0.351913, 0.95, 0.005386, 0.5, 1.0)
    #: Fingerprint ridge spacing (human ~0.45 mm; the paper's finger has printed ridges).
    ridge_spacing_m: float = 0.45e-3
    #: Width of one ridge's contact with the surface (averages finer texture). Fingerprint
    #: ridges are 100-300 um wide, about 500 um apart (Maltoni et al. 2009, Handbook of
    #: Fingerprint Recognition, ch. 3); a ridge pressed flat touches across its width.
    ridge_width_m: float = 0.15e-3
    #: The ridges that touch the surface. ``None``: the fingerprint covers the pad
    #: (``2 pad_radius_m / ridge_spacing_m + 1`` ridges) and every ridge inside the
    #: skin's Hertz contact under the simulated load touches: 10 at 1 N (a 4.8 mm wide
    #: contact), more under a larger load. Each is weighted by its chord of the contact
    #: circle (a ridge's line contact is a spring as stiff as it is long, and the pad
    #: follows the stiffness-weighted mean height). An integer: that many ridges around
    #: the contact centre, weighted equally, whatever the load (a fingerprint patch
    #: smaller than the contact).
    ridges_in_contact: int | None = None
    #: Irregularity of the ridge spacing (real fingerprints are not perfectly periodic).
    ridge_jitter: float = 0.25
    #: Height of the two strain-gauge sites above the pad's mount (phalanx as a cantilever).
    gauge_heights_m: tuple[float, ...] = (0.012, 0.020)
    #: The finger's pitch: the phalanx turned about the lateral (y) axis, the same axis
    #: and sign as the pad's rocking on its support. 0: upright, as the paper's finger
    #: slides. Modelled kinematically: the pad is a sphere, so it touches the surface the
    #: same way whatever its tilt, but the films turn with it (they sit ``R sin(pitch)``
    #: further back relative to the contact) and the gauges read the mount's loads in the
    #: tilted phalanx's frame; the support's compliance keeps its upright axes, which
    #: holds for small angles (the stress suite's ``pitch`` family goes to 15 deg).
    pitch_rad: float = 0.0

    def __post_init__(self) -> None:
        params.positive(
            self,
            "pad_radius_m",
            "pad_mass_kg",
            "phalanx_mass_kg",
            "pdms_normal_stiffness_n_m",
            "pdms_modulus_pa",
            "pdms_diameter_m",
            "pdms_thickness_m",
            "pdms_damping_ratio",
            "skin_modulus_pa",
            "ridge_spacing_m",
            "ridge_width_m",
        )
        params.non_negative(self, "ridge_jitter", "skin_poisson")
        params.below(self, "skin_poisson", 0.5, "an elastic solid")
        params.below(self, "ridge_jitter", 0.5, "ridges must not swap order")
        n = self.ridges_in_contact
        if n is not None and (isinstance(n, bool) or not isinstance(n, int) or n < 1):
            raise ValueError(
                f"Finger.ridges_in_contact must be null (the ridges inside the contact) or an "
                f"integer >= 1; got {n!r}"
            )
        ref = self.skin_solref
        if len(ref) != 2 or not (ref[0] > 0 and ref[1] > 0):
            raise ValueError(
                f"Finger.skin_solref must be (timeconst_s > 0, dampratio > 0); got {ref!r}"
            )
        imp = self.skin_solimp
        if len(imp) != 5 or not (0 < imp[0] <= imp[1] < 1) or imp[2] <= 0:
            raise ValueError(
                "Finger.skin_solimp must be (dmin, dmax, width_m, midpoint, power) with "
                f"0 < dmin <= dmax < 1 and width_m > 0; got {imp!r}"
            )
        if not abs(params._value(self, "pitch_rad")) <= 0.6:
            raise ValueError(
                f"Finger.pitch_rad must lie within +-0.6 rad (34 deg: the pad still touches "
                f"with its tip); got {self.pitch_rad!r}"
            )
        if len(self.gauge_heights_m) != 2 or min(self.gauge_heights_m) <= 0:
            raise ValueError(
                f"Finger.gauge_heights_m must be two heights > 0; got {self.gauge_heights_m!r}"
            )

    @property
    def pdms_area_m2(self) -> float:
        return math.pi * self.pdms_diameter_m**2 / 4

    @property
    def pdms_shape_factor(self) -> float:
        """Loaded over free area of the bonded disc, ``d / (4 t)``: how much its bonded
        faces stiffen it in compression and bending (Gent's rule ``E (1 + 2 S^2)``)."""
        return self.pdms_diameter_m / (4 * self.pdms_thickness_m)

    @property
    def pdms_shear_stiffness_n_m(self) -> float:
        """Shear stiffness of the bonded PDMS disc: ``G A / t`` with ``G = E / 3``."""
        return self.pdms_modulus_pa / 3 * self.pdms_area_m2 / self.pdms_thickness_m

    @property
    def pdms_compression_modulus_pa(self) -> float:
        """Effective modulus of the bonded disc in compression, ``E (1 + 2 S^2)`` (Gent)."""
        return self.pdms_modulus_pa * (1 + 2 * self.pdms_shape_factor**2)

    @property
    def pdms_normal_stiffness_derived_n_m(self) -> float:
        """Compression stiffness the disc's geometry gives, ``E_c A / t`` (the simulated
        one is :attr:`pdms_normal_stiffness_n_m`)."""
        return self.pdms_compression_modulus_pa * self.pdms_area_m2 / self.pdms_thickness_m

    @property
    def pdms_pitch_stiffness_nm_rad(self) -> float:
        """Rocking stiffness of the bonded disc about a diameter: ``E_c I / t`` with the
        disc's second moment of area ``I = pi d^4 / 64``."""
        inertia = math.pi * self.pdms_diameter_m**4 / 64
        return self.pdms_compression_modulus_pa * inertia / self.pdms_thickness_m

    @property
    def pad_pitch_inertia_kg_m2(self) -> float:
        """The pad's moment of inertia about its mount, one radius above its centre (a
        solid sphere of the pad's mass)."""
        return 1.4 * self.pad_mass_kg * self.pad_radius_m**2

    def mount_modes_hz(self, skin_n_m: float = 0.0) -> dict[str, float]:
        """Undamped natural frequencies of the pad on its support: shear, compression
        (with the skin contact's stiffness ``skin_n_m`` beside the support) and rocking."""
        m = self.pad_mass_kg
        return {
            "shear": math.sqrt(self.pdms_shear_stiffness_n_m / m) / (2 * math.pi),
            "normal": math.sqrt((self.pdms_normal_stiffness_n_m + skin_n_m) / m) / (2 * math.pi),
            "pitch": math.sqrt(self.pdms_pitch_stiffness_nm_rad / self.pad_pitch_inertia_kg_m2)
            / (2 * math.pi),
        }


@dataclass(frozen=True)
class Motion:
    """The robot's motion (path, timeline, drives, force loop) and the physics step.

    The robot is position-controlled along the path (stiff x/y servos) and holds the
    normal force with a force loop: a discrete integral controller, run every
    ``control_period_s`` on the force its wrist measures, that moves the set point of a
    stiff z servo (the way a UR arm's force mode works).
    """

    #: Physics step; 0.5 ms resolves skin vibration up to the 1 kHz DAQ's band and keeps
    #: contact time constants >= 2 steps.
    timestep_s: float = 0.0005
    #: The robot controller's period: 8 ms, the 125 Hz real-time loop of a UR5 (CB3); the
    #: force loop acts at this rate.
    control_period_s: float = 0.008
    #: How often the surface's response (texture under the contact, friction coefficient)
    #: is recomputed from the simulated state. A numerical choice, not the robot's: short
    #: enough that the contact moves a small fraction of the finest felt wavelength between
    #: updates (20 um at 10 mm/s against 85-100 um marks), with the height and slope in
    #: between extrapolated along the contact's velocity.
    surface_update_s: float = 0.002
    #: Load phase: the finger presses on the plate, clear of the raised outline, before it
    #: starts sliding (it starts at rest under load, so the force loop only trims).
    settle_s: float = 0.05
    #: Velocity ramp at the slide start (the robot's acceleration limit).
    ramp_s: float = 0.02
    #: Sliding time from the slide start to the first touch of the raised outline: the
    #: start point is placed this far (in time, at the trial's speed) ahead of the outline,
    #: so the skin crosses the entry edge as a sliding finger does.
    approach_s: float = 0.10
    #: The window starts at least this long after the robot reaches speed (the start's
    #: transient in the friction and the PDMS shear has died out by then).
    start_transient_s: float = 0.05
    #: Stiffness of the robot's x/y/z position servos: 1 N of friction deflects the tip
    #: 0.05 mm (an arm's tip is stiff; soft drives let friction creep), and the servo mode
    #: with the phalanx mass (~100 Hz) stays resolved by the physics step.
    servo_stiffness_n_m: float = 20000.0
    #: Their damping: critical for the phalanx and pad mass (2 sqrt(k m)).
    servo_damping_n_s_m: float = 65.0
    #: Closed-loop bandwidth of the force loop. Not published for UR force mode; a 125-500
    #: Hz admittance loop with a sample or two of latency is stable up to ~1/10 of its
    #: rate, and contact bouncing is reported at the upper end: 5 Hz (range 1-10 Hz).
    force_loop_bandwidth_hz: float = 5.0
    #: MuJoCo impratio: frictional/normal constraint impedance; 10 makes the elliptic
    #: cone's tangential/normal match the coefficient (0.83 at 1 vs 0.90 for 0.9).
    impratio: float = 100.0
    #: The force the loop regulates is a wrist force sensor's reading: the true force the
    #: z drive transmits plus white noise of this RMS on every reading. The paper's UR5
    #: (CB3) has no wrist sensor, and its joint-current force estimate is specified to
    #: +-10 N (Universal Robots' answer on its forum, "Internal Force Sensor
    #: properties"), useless at 1 N; a rig that holds 1 N reads a wrist sensor of the
    #: Robotiq FT 300 class, the usual one on UR arms: 0.1 N noise-free resolution at
    #: 100 Hz (its data sheet). A noise-free resolution is the noise's peak-to-peak span,
    #: about 6.6 standard deviations, so 0.015 N RMS (plausible 0.015-0.1 N, the latter
    #: reading the resolution as the RMS; ``scripts/calibrate.py sweep`` measures both).
    #: Each control period reads the latest reading.
    wrist_force_noise_n: float = 0.015
    #: Wrist force sensor's output rate: 100 Hz (Robotiq FT 300).
    wrist_sensor_rate_hz: float = 100.0
    #: Lateral (y) position of the path relative to the specimen's centre line. The paper
    #: does not say where its strokes crossed the specimens; a free choice, plausible 0-3
    #: mm (a stroke aimed at the centre, up to a quarter of the smallest outline off it).
    #: 2 mm off the axis the skin crosses the edges obliquely, so the edges' lateral push
    #: has one sign in every trial instead of flipping with the placement scatter; on the
    #: axis the side gauge reads the symmetric shapes' edges with a sign that the
    #: placement scatter flips (``scripts/calibrate.py sweep`` measures 0-3 mm).
    path_y_m: float = 0.002
    #: False: slide on the bare base plate (sensor calibration runs, physics checks).
    raised_shape: bool = True
    #: The specimen turned in its fixture by this yaw (about the vertical), on top of the
    #: stroke-to-stroke scatter (``Variability.yaw_rad``): the path crosses the outline at
    #: this angle and the surface's marks run at it to the fingerprint's ridges. 0: the
    #: specimen square to the path, as at enrolment.
    specimen_yaw_rad: float = 0.0

    def __post_init__(self) -> None:
        params.positive(
            self,
            "timestep_s",
            "control_period_s",
            "surface_update_s",
            "settle_s",
            "ramp_s",
            "approach_s",
            "start_transient_s",
            "servo_stiffness_n_m",
            "servo_damping_n_s_m",
            "force_loop_bandwidth_hz",
            "impratio",
            "wrist_sensor_rate_hz",
        )
        params.non_negative(self, "wrist_force_noise_n")
        params.below(self, "timestep_s", 0.001, "the physics must run faster than the 1 kHz DAQ")
        ratio = 1.0 / (self.timestep_s * 1000.0)
        if abs(ratio - round(ratio)) > 1e-9:
            raise ValueError(
                "Motion.timestep_s must divide the 1 ms DAQ period (e.g. 0.0005, 0.00025); "
                f"got {self.timestep_s!r}"
            )
        steps = self.surface_update_s / self.timestep_s
        if abs(steps - round(steps)) > 1e-9 or round(steps) < 2:
            raise ValueError(
                "Motion.surface_update_s must be a whole number (>= 2) of physics steps "
                f"({self.timestep_s} s); got {self.surface_update_s!r}"
            )
        periods = self.control_period_s / self.surface_update_s
        if abs(periods - round(periods)) > 1e-9 or round(periods) < 1:
            raise ValueError(
                "Motion.control_period_s must be a whole number of surface updates "
                f"({self.surface_update_s} s); got {self.control_period_s!r}"
            )
        if abs(params._value(self, "path_y_m")) > 0.01:
            raise ValueError(f"Motion.path_y_m must lie within +-0.01 m; got {self.path_y_m!r}")
        if not abs(params._value(self, "specimen_yaw_rad")) < math.pi / 2:
            raise ValueError(
                f"Motion.specimen_yaw_rad must lie within +-pi/2 (a specimen turned by less than "
                f"a right angle); got {self.specimen_yaw_rad!r}"
            )
        if not isinstance(self.raised_shape, bool):
            raise ValueError(
                f"Motion.raised_shape must be True or False; got {self.raised_shape!r}"
            )

    @property
    def control_steps(self) -> int:
        """Physics steps per controller period."""
        return round(self.control_period_s / self.timestep_s)

    @property
    def surface_steps(self) -> int:
        """Physics steps per surface update."""
        return round(self.surface_update_s / self.timestep_s)


@dataclass(frozen=True)
class Variability:
    """Per-trial scatter, drawn from the trial's seed (standard deviations unless noted).

    Every trial uses the same finger and the same specimen of its class; what varies is
    where and how the robot slides and how the surface behaves on that stroke.
    """

    #: Lateral (y) offset of the path: uniform within +- this. UR arms repeat to +-0.1 mm;
    #: the specimen's play in its fixture adds about as much again.
    lateral_offset_m: float = 0.25e-3
    #: Yaw of the path relative to the specimen (standard deviation): the 60 mm plate
    #: turns in its fixture pocket by up to 2 x play / length = 2 x 0.15 mm / 60 mm =
    #: 0.005 rad as friction pushes it (the play as for ``lateral_offset_m``). It also
    #: sets the angle between the specimen's periodic marks and the fingerprint's ridges
    #: (:func:`synth.texture.mark_gains`).
    yaw_rad: float = 0.005
    #: Stroke-to-stroke relative error of the normal force (standard deviation). Not
    #: measured for this rig (the paper says only that its UR5 slid "with constant
    #: contact force"); derived from the arm's pose repeatability: a UR5 returns to a
    #: pose within +-0.1 mm (data sheet; ISO 9283 repeatability, the mean distance plus
    #: 3 standard deviations), so the press depth scatters by 0.1 mm / 3 = 0.033 mm, and
    #: the load by that times the stiffness of what the press compresses in series: the
    #: arm's servo (20 kN/m), the PDMS support as simulated (21 kN/m) and the skin's
    #: Hertz contact (1.8 kN/m at 1 N, 0.82 mm deep), 1.56 kN/m in all, so 5.2 % at 1 N
    #: (4.3 % for a Gaussian scatter in three axes, 6.0 % for one along the press
    #: alone). A force loop is not known to do better at this load: a UR5e in force
    #: mode, with its wrist force/torque sensor, misses set points of 1-10 N by 0.38 N on
    #: average (Trochimczuk et al. 2026, Sensors 26, 1709). The wrist sensor's own noise
    #: within a stroke is :attr:`Motion.wrist_force_noise_n`. ``scripts/calibrate.py
    #: force`` derives this value from the configured finger (``docs/simulator.md``, "The
    #: force scatter").
    force_rel: float = 0.052
    #: Relative error of the path speed: not measured for this rig either; an assumption.
    speed_rel: float = 0.01
    #: Stroke-to-stroke scatter of the friction coefficient on one specimen (coefficient
    #: of variation). Two platinum-cure silicones slid 30 times over one PLA track at
    #: 10 mm/s and 62.5 kPa, the measured pressure nearest the skin's mean Hertz pressure
    #: at 1 N (55 kPa), vary by 3.2 % and 4.6 %, run-in included (Tortos-Vinocour et al.
    #: 2024, IEEE Robot. Autom. Lett., doi:10.1109/LRA.2024.3376975): this is their mean,
    #: as ``scripts/calibrate.py friction`` derives it. Human skin varies more, 6-8 %
    #: between repeated device measurements (intraclass correlation 0.91; Temel, Johnson
    #: & Lloyd 2022, Tribol. Lett. 70), as its moisture changes from stroke to stroke;
    #: contaminated or worn contacts up to 10-15 %.
    friction_rel: float = 0.039
    #: When the window is cut from the record: the contact onset is found in the signals
    #: to within this (uniform in [0, this]).
    window_jitter_s: float = 0.02

    def __post_init__(self) -> None:
        names = [f.name for f in dataclasses.fields(self)]
        params.non_negative(self, *names)
        for name in ("force_rel", "speed_rel", "friction_rel"):
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
    #: Constantan foil gauge factor (2.0-2.2).
    gauge_factor: float = 2.0
    #: Bridge excitation (2.5-10 V is usual for 350 ohm gauges).
    excitation_v: float = 5.0
    #: Instrumentation amplifier gain.
    amplifier_gain: float = 2000.0
    #: Input-referred voltage noise density of the instrumentation amplifier: 9 nV/sqrt(Hz)
    #: for an AD620, 38 for an INA125 (data sheets, at 1 kHz).
    amplifier_noise_v_per_sqrt_hz: float = 20e-9
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
        params.non_negative(self, "offset_strain", "amplifier_noise_v_per_sqrt_hz")
        params.below(self, "lowpass_hz", 500.0, "below the 1 kHz DAQ's Nyquist frequency")


@dataclass(frozen=True)
class PVDF:
    """PVDF films bonded under the skin at the pad's front and rear (channels 1-2).

    Each film lies along the path and conforms to the skin, whose surface the contact
    pushes in (the sphere's shape inside the contact, the elastic half-space's
    deflection outside it). Two strains stretch the film in-plane:

    - bending: its mean curvature, the change of the surface's slope from one end of
      the film to the other over its length (a film only moved, not bent, has none),
      times the distance ``e`` between its mid-plane and the neutral axis of what bends
      with it (the electrodes collect the charge of the strain averaged through the
      film's thickness, which is zero for a film bending about its own mid-plane);
    - the tangential traction: friction and the texture's push shear the skin, which
      shortens ahead of the contact and stretches behind it, and the bonded film takes
      part of that strain (``shear_strain_per_n``).

    The charge is ``d31 * E * strain * area`` (stress along the film's stretch axis); a
    charge amplifier (feedback ``C_f`` parallel ``R_f``) turns it into ``-q / C_f`` above
    its high-pass corner ``1 / (2 pi R_f C_f)``. Material constants: Measurement
    Specialties, Piezo Film Sensors Technical Manual (Table 1).
    """

    #: Piezoelectric strain coefficient along the stretch axis (23 pC/N).
    d31_c_per_n: float = 23e-12
    #: Young's modulus of PVDF film (2-4 GPa).
    youngs_modulus_pa: float = 3.0e9
    #: Relative permittivity (12-13).
    relative_permittivity: float = 12.0
    #: Film thickness (9, 28, 52 or 110 um stock).
    thickness_m: float = 28e-6
    #: Distance from the film's mid-plane to the bending neutral axis. A homogeneous film
    #: bending alone has 0: its two halves stretch and shorten alike and their charges
    #: cancel. A film on a carrier puts the axis where the layers' first moments of
    #: ``E t`` balance: 28 um PVDF gives 14 um (the film's bonded face) on the 23 um
    #: polyester stock (4-5 GPa), 21 um on the 36 um stock and about 67 um on the
    #: manual's laminated elements (125 um). The finger's description does not give the
    #: films' carrier: a free choice between the thinnest standard polyester stock,
    #: 23 um, and the laminated elements' 125 um (Measurement Specialties, Piezo Film
    #: Sensors Technical Manual). The default is the stock nearest the middle of that
    #: range, 75 um: 41.2 um (``scripts/calibrate.py carrier`` derives both of the
    #: carrier's figures; the sweep measures the range).
    neutral_axis_offset_m: float = 41.2e-6
    #: In-plane strain of a film per newton of tangential traction on the skin. A
    #: tangential point load ``Q`` on an elastic half-space (Cerruti; Johnson, *Contact
    #: Mechanics*, 1985, ch. 3) moves the surface along the load by
    #: ``(1 + nu) Q / (pi E x)`` at a distance ``x`` on its line: the skin's surface
    #: strain there is ``(1 + nu) Q / (pi E x^2)``, 10 % per newton at the film's 4 mm
    #: (``Finger.skin_modulus_pa``). The film with its carrier is some 200 times stiffer
    #: in-plane than the skin it is bonded in, which carries that strain over a depth of
    #: the order of ``x``; the film takes the skin's in-plane force instead,
    #: ``(1 + nu) Q / (pi x)`` per unit width, and strains by that over its in-plane
    #: stiffness ``E t`` plus its carrier's (28 um PVDF at 3 GPa, 75 um polyester at
    #: 4.5 GPa: 422 kN/m): ``(1 + nu) / (pi x sum(E t))`` = 2.8e-4 per newton. The
    #: depth the skin carries the load over is known only to within a factor of about
    #: 1.5 (the distance to the film, 4 mm, to its length, 5 mm, and below).
    shear_strain_per_n: float = 2.81e-4
    #: Electrode length (along the sliding direction) and width: a strip that fits on the
    #: pad's front / rear flank.
    length_m: float = 5.0e-3
    width_m: float = 4.0e-3
    #: Position of each film's centre: this far ahead of (front) and behind (rear) the
    #: pad's axis, on the skin's surface.
    offset_m: float = 4.0e-3
    #: Charge amplifier feedback capacitance and resistance: 1 nF, 100 MOhm -> 1.6 Hz
    #: high-pass, which blocks the film's pyroelectric and slow thermal drift.
    feedback_capacitance_f: float = 1.0e-9
    feedback_resistance_ohm: float = 100e6
    #: Voltage gain after the charge amplifier, sized so the sharpest edge transients of
    #: the perturbation grid stay inside the DAQ's +-10 V (``scripts/calibrate.py gain``).
    post_gain: float = 1.0
    #: Input voltage noise density of the charge amplifier's op-amp (JFET-input, ~10 nV/
    #: sqrt(Hz)); the film's capacitance raises its noise gain to 1 + C_film / C_f.
    amplifier_noise_v_per_sqrt_hz: float = 10e-9

    def __post_init__(self) -> None:
        params.positive(
            self,
            "d31_c_per_n",
            "youngs_modulus_pa",
            "relative_permittivity",
            "thickness_m",
            "length_m",
            "width_m",
            "feedback_capacitance_f",
            "feedback_resistance_ohm",
            "post_gain",
        )
        params.non_negative(
            self,
            "offset_m",
            "amplifier_noise_v_per_sqrt_hz",
            "neutral_axis_offset_m",
            "shear_strain_per_n",
        )
        params.below(self, "neutral_axis_offset_m", 1e-3, "a film's carrier is sub-millimetre")

    @property
    def area_m2(self) -> float:
        return self.length_m * self.width_m

    @property
    def capacitance_f(self) -> float:
        """Film capacitance from its geometry: eps0 eps_r A / t (~380 pF/cm2 at 28 um)."""
        return (
            VACUUM_PERMITTIVITY_F_M * self.relative_permittivity * self.area_m2 / self.thickness_m
        )

    @property
    def highpass_hz(self) -> float:
        return 1.0 / (2 * math.pi * self.feedback_resistance_ohm * self.feedback_capacitance_f)


@dataclass(frozen=True)
class Acquisition:
    """A USB DAQ of the NI USB-6346 class: anti-alias filter, 1 kHz, 16 bit over +-10 V."""

    #: Anti-alias low-pass corner (below the 500 Hz Nyquist) and order (Butterworth).
    antialias_hz: float = 400.0
    antialias_order: int = 4
    #: ADC resolution and input range (+- range_v).
    adc_bits: int = 16
    range_v: float = 10.0
    #: White noise at the ADC input, RMS: 1-2 codes of a 16-bit +-10 V input (code width
    #: ~0.32 mV), the usual random-noise figure of this DAQ class.
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
    """The whole simulated experiment. ``SynthConfig()`` is the paper's set-up.

    ``materials``: the materials a trial may name, by name (any set of at least one; the
    default is the paper's three, :data:`synth.materials.MATERIALS`). ``specimens``: the
    user's specimens a trial may name besides the 12 built-in shapes (``shapes.Specimen``
    by name; default none). A trial's ``shape`` resolves to a built-in or one of
    ``specimens`` (:meth:`specimen`), its ``material`` to one of ``materials``
    (:meth:`material`).
    """

    finger: Finger = field(default_factory=Finger)
    motion: Motion = field(default_factory=Motion)
    variability: Variability = field(default_factory=Variability)
    strain_gauge: StrainGauge = field(default_factory=StrainGauge)
    pvdf: PVDF = field(default_factory=PVDF)
    acquisition: Acquisition = field(default_factory=Acquisition)
    materials: dict[str, Material] = field(default_factory=_default_materials)
    specimens: dict[str, Specimen] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            if f.name in ("materials", "specimens"):
                continue
            value = getattr(self, f.name)
            if type(value).__name__ != f.type:
                raise ValueError(
                    f"SynthConfig.{f.name} must be a {f.type}; got {type(value).__name__}"
                )
        if not isinstance(self.materials, Mapping) or not self.materials:
            raise ValueError("SynthConfig.materials must define at least one material")
        for name, mat in self.materials.items():
            check_name("SynthConfig.materials key", name)
            if not isinstance(mat, Material) or mat.name != name:
                raise ValueError(
                    f"SynthConfig.materials[{name!r}] must be a Material named {name!r}"
                )
        if not isinstance(self.specimens, Mapping):
            raise ValueError("SynthConfig.specimens must map names to shapes.Specimen")
        for name, spec in self.specimens.items():
            if not isinstance(spec, Specimen) or spec.name != name:
                raise ValueError(
                    f"SynthConfig.specimens[{name!r}] must be a shapes.Specimen named {name!r}"
                )
        if self.finger.skin_solref[0] < 2 * self.motion.timestep_s:
            raise ValueError(
                "Finger.skin_solref's time constant must be >= 2 physics steps "
                f"({2 * self.motion.timestep_s} s); got {self.finger.skin_solref[0]!r}"
            )

    @property
    def specimen_names(self) -> tuple[str, ...]:
        """Every specimen a trial may name: the 12 built-ins (paper order), then
        :attr:`specimens` in their order."""
        return (*SHAPE_NAMES, *self.specimens)

    def specimen(self, name: str) -> SpecimenLike:
        """The built-in shape name or the :class:`shapes.Specimen` that ``name`` names;
        a one-line ``ValueError`` naming the valid ones otherwise."""
        if name in SHAPE_NAMES:
            return name
        found = self.specimens.get(name)
        if found is None:
            raise ValueError(
                f"shape {name!r} is neither a built-in shape nor a specimen of the "
                f"configuration; valid: {', '.join(self.specimen_names)}"
            )
        return found

    def material(self, name: str) -> Material:
        """The material ``name`` names; a one-line ``ValueError`` naming the valid ones
        otherwise."""
        found = self.materials.get(name)
        if found is None:
            raise ValueError(
                f"material {name!r} is not a material of the configuration; valid: "
                f"{', '.join(self.materials)}"
            )
        return found

    def with_material(self, material: Material) -> Self:
        """A copy with ``material`` replacing the entry of the same name."""
        mats = dict(self.materials)
        if material.name not in mats:
            raise ValueError(
                f"material.name must be one of {', '.join(mats)}; got {material.name!r}"
            )
        mats[material.name] = material
        return dataclasses.replace(self, materials=mats)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-serialisable dict of every parameter. ``specimens`` holds each
        specimen's record (``shapes.specimen_to_dict``: its vertices, height and geometry
        hash) and is left out when there are none, as the paper's set-up has."""
        out = params.to_dict(dataclasses.replace(self, specimens={}))
        del out["specimens"]
        if self.specimens:
            out["specimens"] = {name: specimen_to_dict(s) for name, s in self.specimens.items()}
        return out

    @classmethod
    def from_dict(cls, data: Any) -> SynthConfig:
        """Rebuild from :meth:`to_dict` output; unknown or missing keys raise ValueError
        (``specimens`` may be absent: none)."""
        if not isinstance(data, Mapping):
            raise ValueError(f"SynthConfig must be a mapping; got {type(data).__name__}")
        records = data.get("specimens", {})
        if not isinstance(records, Mapping):
            raise ValueError(
                f"SynthConfig.specimens must be a mapping; got {type(records).__name__}"
            )
        specimens: dict[str, Specimen] = {}
        for name, record in records.items():
            try:
                spec = specimen_from_dict(record)
            except ValueError as exc:
                raise ValueError(f"SynthConfig.specimens.{name}: {exc}") from None
            if not isinstance(spec, Specimen):
                raise ValueError(
                    f"SynthConfig.specimens.{name}: a built-in shape needs no entry here"
                )
            specimens[str(name)] = spec
        base = params.from_dict(cls, {**data, "specimens": {}})
        return dataclasses.replace(base, specimens=specimens) if specimens else base


def default_synth_config() -> dict[str, Any]:
    """The simulator's default settings as a generation configuration stores them."""
    return SynthConfig().to_dict()


def validate_synth_config(synth: Mapping[str, Any]) -> None:
    """``ValueError`` unless ``synth`` holds valid simulator settings (every reader of a
    stored configuration checks it here)."""
    SynthConfig.from_dict(dict(synth))
