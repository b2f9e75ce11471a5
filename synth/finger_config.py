"""The finger's configuration (:class:`Finger`): the rigid phalanx, the soft skin pad and
its ridges, and the PDMS support, each parameter in SI units with the unit in its name
and a one-line rationale. :mod:`synth.config` bundles it into ``SynthConfig``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from . import params

#: The skin's answers to the texture (:attr:`Finger.skin_texture_response`).
SKIN_TEXTURE_RESPONSES: tuple[str, ...] = ("elastic", "viscoelastic")


@dataclass(frozen=True)
class Finger:
    """The paper's finger (Sec. III): rigid phalanx, soft skin pad on a PDMS support."""

    #: Fingertip pad radius; a human-sized fingertip is ~7-8 mm in radius, and it must
    #: drop into the moon's 12.5 mm notch (sag over 6.25 mm > 2 mm needs r < 10.8 mm).
    #: Not dimensioned in the finger's description: a free choice, plausible 6-8 mm, which
    #: ``tactile-synth calibrate --sweep`` measures (refitting the skin's contact to each).
    pad_radius_m: float = 0.007
    #: Moving mass below the PDMS support: silicone skin pad, films and the support's
    #: moving half (a silicone hemisphere of 7 mm radius alone is ~0.8 g). Not measured
    #: for the paper's finger; plausible 1-4 g (``scripts/calibrate.py mount`` prints the
    #: mount's modes for it, ``tactile-synth calibrate --sweep`` measures the range).
    pad_mass_kg: float = 0.003
    #: Phalanx + carriage mass the robot's drives move. Not measured for the paper's
    #: finger (a printed phalanx with its mount and flange adapter): a free choice,
    #: plausible 25-100 g, which ``tactile-synth calibrate --sweep`` measures.
    phalanx_mass_kg: float = 0.05
    #: Young's modulus of the PDMS support: Sylgard 184 at the usual 10:1 mix, 2.0 MPa
    #: (``E = 20 MPa / mix ratio`` over 5:1-33:1, 0.57-3.7 MPa, measured in compression:
    #: Wang, Volinsky & Gallant 2014, J. Appl. Polym. Sci. 131, 41050). Nearly
    #: incompressible, so its shear modulus is ``E / 3``. The mix is not given: a free
    #: choice over that range, which ``tactile-synth calibrate --sweep`` measures.
    pdms_modulus_pa: float = 2.0e6
    #: The support's geometry, a PDMS disc bonded between the phalanx and the pad. The
    #: finger's description does not give it: a free choice that fits under the 14 mm
    #: pad (plausible 6-12 mm across, 1-4 mm thick; ``tactile-synth calibrate --sweep``
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
    #: Materials Database); a human fingertip is 0.07-0.2 MPa (Oprisan et al. 2016). The
    #: paper names no compound ("soft skin"): a free choice, plausible 0.1-0.58 MPa (a
    #: fingertip-soft silicone to a compound twice as hard), which ``tactile-synth calibrate
    #: --sweep`` measures (refitting the skin's contact to each; so does ``--set``).
    skin_modulus_pa: float = 0.29e6
    #: Poisson's ratio of silicone (nearly incompressible: 0.48-0.499).
    skin_poisson: float = 0.49
    #: How the skin answers the texture it slides over (:data:`SKIN_TEXTURE_RESPONSES`).
    #: ``"elastic"``: with its relaxed modulus at every frequency, the texture's height
    #: and slope reaching the contact as the surface has them. ``"viscoelastic"``: with
    #: the silicone's complex modulus ``E*(omega)`` (``synth.viscoelastic.SILICONE_PRONY``
    #: on ``skin_modulus_pa``), each Prony arm a recursive filter of the height and slope
    #: the simulated contact meets, step by step (``synth.kernels.viscoelastic_felt``):
    #: texture passed at ``omega = 2 pi v / lambda`` meets a skin ``|E*(omega)| / E_inf``
    #: times stiffer, whatever the path planned (docs/friction.md, "The skin's answer to
    #: the texture"). The default stays elastic: the Prony shape is not measured for
    #: this skin.
    skin_texture_response: str = "elastic"
    #: MuJoCo soft-contact parameters of the skin, one set for every material: solref
    #: (time constant s, damping ratio) and solimp (dmin, dmax, width m, midpoint, power).
    #: Fitted by ``scripts/calibrate.py skin`` so that the simulated indentation follows
    #: Hertz's law of a sphere of ``pad_radius_m`` and ``skin_modulus_pa`` on a rigid flat
    #: over 0.3-2 N (``synth.contact.hertz_indentation_m``), within 3.1 % at every load.
    #: A finger with another pad radius or skin needs them refitted:
    #: ``synth.skin_fit.with_fitted_skin`` does it, as ``--set`` and experiment files do.
    skin_solref: tuple[float, ...] = (0.001, 1.0)
    skin_solimp: tuple[float, ...] = (0.351913, 0.95, 0.005386, 0.5, 1.0)
    #: Fingerprint ridge spacing. The paper's finger carries a fingerprint its description
    #: does not dimension; human ridges lie about 0.5 mm apart (Maltoni et al. 2009,
    #: below). A free choice, plausible 0.3-0.6 mm, which the sweep measures.
    ridge_spacing_m: float = 0.45e-3
    #: Width of the central ridge's contact with the surface (averages finer texture).
    #: Fingerprint ridges are 100-300 um wide, about 500 um apart (Maltoni et al. 2009,
    #: Handbook of Fingerprint Recognition, ch. 3).
    ridge_width_m: float = 0.15e-3
    #: Shape of the pressure across one ridge's contact width ``w``: ``(1 - (2 x / w)^2)``
    #: to this power. 0.5: a rounded ridge pressed on a flat is a Hertzian line contact,
    #: whose pressure is elliptical (Johnson 1985, Contact Mechanics, sec. 4.2); 0: a
    #: flat pressure, each ridge averaging the surface over a sharp-edged box of its width.
    ridge_profile_exponent: float = 0.5
    #: How each ridge's contact width follows the pad's pressure where it lies: as that
    #: pressure to this power, relative to the central ridge's ``ridge_width_m``. 0.5: a
    #: Hertzian line contact's width grows as the square root of its load per length
    #: (Johnson 1985, sec. 4.2), and the pad's Hertz pressure falls from the contact's
    #: centre to its rim as ``sqrt(1 - (r / a)^2)``, so the ridges narrow towards the
    #: rim; 0: every ridge ``ridge_width_m`` wide. The central ridge's width does not
    #: follow the load (it would as the load's sixth root).
    ridge_width_pressure_exponent: float = 0.5
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
    #: Not dimensioned in the finger's description: free choices, plausible 8-16 mm (front
    #: gauge) and 16-24 mm (side gauge), which ``tactile-synth calibrate --sweep`` measures
    #: (``finger.gauge_heights_m.0`` and ``.1``).
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
        params.non_negative(
            self,
            "ridge_jitter",
            "skin_poisson",
            "ridge_profile_exponent",
            "ridge_width_pressure_exponent",
        )
        params.below(self, "skin_poisson", 0.5, "an elastic solid")
        params.below(self, "ridge_jitter", 0.5, "ridges must not swap order")
        if self.skin_texture_response not in SKIN_TEXTURE_RESPONSES:
            raise ValueError(
                "Finger.skin_texture_response must be one of "
                f"{', '.join(SKIN_TEXTURE_RESPONSES)}; got {self.skin_texture_response!r}"
            )
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
