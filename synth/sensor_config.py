"""The sensing chain's configuration: the strain gauges and their bridge
(:class:`StrainGauge`), the PVDF films and their charge amplifiers (:class:`PVDF`) and the
DAQ (:class:`Acquisition`), each parameter in SI units with the unit in its name and a
one-line rationale. :mod:`synth.config` bundles them into ``SynthConfig``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from . import params

#: Vacuum permittivity (F/m).
VACUUM_PERMITTIVITY_F_M = 8.8541878128e-12


@dataclass(frozen=True)
class StrainGauge:
    """Foil strain gauges on the phalanx in quarter Wheatstone bridges (channels 3-4).

    sg1 sits on the front face (bending in the sliding plane), sg2 on the side face
    (bending from lateral load); both also see the axial (normal) load.
    """

    #: Phalanx as a square printed beam (PLA-like): modulus and cross-section side. The
    #: section is not dimensioned in the finger's description: a free choice, plausible
    #: 6-10 mm, which ``tactile-synth calibrate --sweep`` measures.
    beam_modulus_pa: float = 3.5e9
    beam_side_m: float = 0.008
    #: Constantan foil gauge factor (2.0-2.2).
    gauge_factor: float = 2.0
    #: Bridge excitation (2.5-10 V is usual for 350 ohm gauges).
    excitation_v: float = 5.0
    #: Instrumentation amplifier gain. The finger's description does not give it: a free
    #: choice, plausible 1000-4000 (the front gauge's strongest strokes, about 3 V at
    #: 2000, stay inside the DAQ's +-10 V at every load), which
    #: ``tactile-synth calibrate --sweep`` measures.
    amplifier_gain: float = 2000.0
    #: Input-referred voltage noise density of the instrumentation amplifier: 9 nV/sqrt(Hz)
    #: for an AD620, 38 for an INA125 (data sheets, at 1 kHz).
    amplifier_noise_v_per_sqrt_hz: float = 20e-9
    #: DC-coupled low-pass of the conditioning (static channels). The finger's description
    #: does not give the conditioning: a free choice, plausible 10-400 Hz (a static
    #: reading up to the DAQ's anti-alias corner), which ``tactile-synth calibrate --sweep``
    #: measures.
    lowpass_hz: float = 100.0
    #: Unbalance of the bridge at zero load, as strain (resistor tolerance after nulling).
    #: Not measured: a free choice, plausible 0-10 microstrain, which
    #: ``tactile-synth calibrate --sweep`` measures.
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
    #: carrier's figures and prints the ``whatif`` options that measure each stock).
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
    #: pad's front / rear flank. Not dimensioned in the finger's description: free
    #: choices; the sweep measures lengths of 3-6 mm and widths of 3-5 mm.
    length_m: float = 5.0e-3
    width_m: float = 4.0e-3
    #: Position of each film's centre: this far ahead of (front) and behind (rear) the
    #: pad's axis, on the skin's surface. Not dimensioned in the finger's description: a
    #: free choice that keeps both strips on the 7 mm pad's flank and apart (3-4.5 mm,
    #: which ``tactile-synth calibrate --sweep`` measures).
    offset_m: float = 4.0e-3
    #: Charge amplifier feedback capacitance and resistance: 1 nF, 100 MOhm -> 1.6 Hz
    #: high-pass, which blocks the film's pyroelectric and slow thermal drift. The
    #: finger's description does not give the films' readout: a free choice. A charge
    #: amplifier reads the film's stress at every frequency above its corner; a film read
    #: in voltage mode across a load resistor is the same first-order high-pass of the
    #: charge, with the film's and the input's capacitance in place of ``C_f`` (Piezo
    #: Film Sensors Technical Manual: 10 MOhm in its example), and across 10 MOhm its
    #: corner, about 90 Hz, lies inside the texture band, where the output follows the
    #: stress's rate. ``tactile-synth calibrate --sweep`` measures a corner of 88 Hz beside
    #: the default (``docs/simulator.md``, "The films' readout").
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
    #: Mains pickup: frequency and amplitude (random phase per trial). The amplitude is
    #: not measured: a free choice, plausible 0.3-3 mV (about one to ten codes), which
    #: ``tactile-synth calibrate --sweep`` measures.
    mains_hz: float = 50.0
    mains_v: float = 1.0e-3
    #: Slow thermal drift of the DC-coupled bridge channels (random walk, volts per
    #: sqrt(second)); the AC-coupled PVDF chain blocks drift. Not measured: a free
    #: choice, plausible 0.5-5 mV per root second, which ``tactile-synth calibrate --sweep``
    #: measures.
    drift_v_per_sqrt_s: float = 2.0e-3

    def __post_init__(self) -> None:
        params.positive(self, "antialias_hz", "range_v", "mains_hz")
        params.non_negative(self, "noise_v_rms", "mains_v", "drift_v_per_sqrt_s")
        params.below(self, "antialias_hz", 500.0, "below the 1 kHz DAQ's Nyquist frequency")
        for name, lo, hi in (("antialias_order", 1, 10), ("adc_bits", 8, 24)):
            value = getattr(self, name)
            if not isinstance(value, int) or not lo <= value <= hi:
                raise ValueError(f"Acquisition.{name} must be an integer in {lo}..{hi}")
