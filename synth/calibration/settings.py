"""Which global parameters the calibration moves, over which cited ranges, and the
configurations a command line asks for (``--set SECTION.FIELD=VALUE`` and the sweep's
``--base``).

Two factors are not configuration fields: :data:`TEXTURE_SCALE` scales every material's
texture amplitudes (roughness and periodic marks), :data:`MARKS_SCALE` the periodic marks
alone; :func:`with_value` applies them like any field. ``materials.MATERIAL.kinetic_friction``
sets one material's kinetic friction coefficient (its static one keeps its ratio to it),
to ask what a friction level of its own per material would change;
``materials.MATERIAL.roughness_rms_m``, ``.correlation_length_m`` and
``.mark_amplitude_m`` set one material's surface, whose measured ranges and free choices
the sweep spans; ``materials.stribeck_velocity_m_s`` sets every material's Stribeck
velocity, and ``finger.gauge_heights_m.0`` / ``.1`` one strain gauge's height. Setting
the pad's radius or the skin's modulus or Poisson's ratio
(:data:`synth.skin_fit.HERTZ_FIELDS`) refits the skin's MuJoCo contact to the new skin's
Hertz law (:func:`synth.skin_fit.fit_skin_contact`), so that the simulated indentation
follows it as the default skin's does.

Examples
--------
>>> import synth
>>> config = configured(["variability.yaw_rad=0.01", "materials.texture_scale=0.5"])
>>> config.variability.yaw_rad
0.01
>>> law = configured(["materials.wood.kinetic_friction=0.9"]).materials["wood"].friction
>>> round(law.kinetic, 3), round(law.static, 3)
(0.9, 1.08)
>>> try:
...     parse_base(["variability.friction_rel=0.3"])
... except CalibrationError as exc:
...     print(exc)
--base variability.friction_rel must lie in its cited range 0.039..0.15; got 0.3
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

from tactile_synth.validation import parse_number

from ..config import SynthConfig
from ..materials import Material, Periodic
from ..skin_fit import HERTZ_FIELDS, SimulationError, with_fitted_skin


class CalibrationError(ValueError):
    """A calibration's input is refused or its measurement cannot be made; the message is
    one line naming the option (``scripts/calibrate.py`` prints it and exits)."""


#: Not a configuration field: a factor on every material's texture amplitudes (roughness
#: and periodic marks), swept to see how much of the materials' signature the texture
#: carries.
TEXTURE_SCALE = ("materials", "texture_scale")
#: Not a configuration field either: a factor on every material's periodic marks alone
#: (the random roughness kept), for whatif to ask what the marks carry.
MARKS_SCALE = ("materials", "marks_scale")
#: The material-wide factors, which are not configuration fields.
MATERIAL_FACTORS = (TEXTURE_SCALE, MARKS_SCALE)
#: ``materials.MATERIAL.<this>``: one material's kinetic friction coefficient.
KINETIC_FRICTION = "kinetic_friction"
#: ``materials.MATERIAL.<this>``: one material's surface, the random roughness's RMS and
#: correlation length and its periodic mark's amplitude (a material with one mark).
TEXTURE_FIELDS = ("roughness_rms_m", "correlation_length_m", "mark_amplitude_m")
#: Every ``materials.MATERIAL.<field>`` a setting may name.
MATERIAL_FIELDS = (KINETIC_FRICTION, *TEXTURE_FIELDS)
#: ``materials.<this>``: the Stribeck velocity of every material's friction law (one
#: value for all: no source gives one per material).
STRIBECK = ("materials", "stribeck_velocity_m_s")
#: ``finger.<this>.I``: the height of gauge I (0 the front face's, 1 the side face's) of
#: the tuple ``Finger.gauge_heights_m``, one number each.
GAUGE_HEIGHTS = "gauge_heights_m"
#: Configuration sections whose numeric fields ``--set`` may change.
SECTIONS = ("finger", "motion", "variability", "strain_gauge", "pvdf", "acquisition")

#: Global parameters and the values their sources allow: (section, field, candidates, why).
SWEEP: tuple[tuple[str, str, tuple[float, ...], str], ...] = (
    (
        "motion",
        "path_y_m",
        (0.0, 0.001, 0.002, 0.003),
        "where the robot slides relative to the outline's centre line (experiment design)",
    ),
    (
        "variability",
        "lateral_offset_m",
        (0.1e-3, 0.25e-3, 0.5e-3),
        "UR repeatability (+-0.1 mm) plus the specimen's play",
    ),
    (
        "variability",
        "yaw_rad",
        (0.0, 0.005, 0.01, 0.02),
        "the plate's turn in its fixture pocket: 2 x 0.15 mm play / 60 mm = 0.005 rad; 0 aligned",
    ),
    (
        "variability",
        "friction_rel",
        (0.039, 0.05, 0.08, 0.12, 0.15),
        "stroke-to-stroke friction scatter: 3.2-4.6 % (silicone on PLA at the skin's "
        "pressure, their mean the default), 6-8 % (human skin) to 15 % (contaminated)",
    ),
    (
        "variability",
        "force_rel",
        (0.02, 0.052, 0.1, 0.2),
        "stroke-to-stroke error of the normal force at 1 N: 5.2 % from a UR5's +-0.1 mm pose "
        "repeatability against the servo, PDMS and skin in series (the default), up to the "
        "0.38 N a UR5e's force mode misses 1-10 N set points by (Trochimczuk et al. 2026); "
        "2 % a tight servo",
    ),
    (
        "motion",
        "wrist_force_noise_n",
        (0.0, 0.015, 0.05, 0.1),
        "the wrist force sensor's noise per 10 ms reading: an FT 300's 0.1 N noise-free "
        "resolution read as 6.6 standard deviations (the default) or as the RMS; 0 an ideal "
        "sensor",
    ),
    (
        "finger",
        "pdms_thickness_m",
        (0.003, 0.004, 0.006),
        "the PDMS support's thickness (a free choice, 1-4 mm plausible): modes from 380 / "
        "310 Hz (shear / rocking, 3 mm) down to 270 / 165 Hz (6 mm); 2 mm diverges at the "
        "0.5 ms step",
    ),
    (
        "finger",
        "pdms_damping_ratio",
        (0.05, 0.15, 0.2),
        "damping of the PDMS modes: half a silicone's loss tangent (0.1-0.4); 0.05 diverges "
        "in a trial at the 0.5 ms step (measure it with motion.timestep_s=0.25e-3)",
    ),
    (
        "pvdf",
        "feedback_resistance_ohm",
        (1e9, 100e6, 10e6, 1.8e6),
        "charge-amplifier high-pass 0.16 / 1.6 / 16 Hz; 88 Hz, inside the texture band, is "
        "the corner of a film read in voltage mode across the piezo-film manual's 10 MOhm "
        "load (the film's 76 pF and some 100 pF of cable and input): the readout is not "
        "described; each corner is measured at the post-gain the gain rule sizes for it "
        "(0.5 / 1 / 2 / 5)",
    ),
    (
        "pvdf",
        "shear_strain_per_n",
        (1.9e-4, 2.81e-4, 4.2e-4),
        "the films' shear coupling on their 75 um carrier: the depth the skin carries the "
        "traction over, known to within a factor of 1.5 (the carrier's own range, 23-125 "
        "um, is `calibrate.py carrier`'s)",
    ),
    (
        "finger",
        "ridge_width_m",
        (0.1e-3, 0.15e-3, 0.2e-3, 0.3e-3),
        "a fingerprint ridge's contact width: ridges are 100-300 um wide (Maltoni et al.)",
    ),
    (
        "finger",
        "ridge_profile_exponent",
        (0.0, 0.5),
        "the pressure across a ridge's width: elliptical, a Hertzian line contact (0.5, "
        "Johnson 1985), against the flat box average it idealises (0)",
    ),
    (
        "finger",
        "ridge_width_pressure_exponent",
        (0.0, 0.5),
        "the ridges' widths: narrowing towards the contact's rim as a Hertzian line "
        "contact's width follows its load (0.5), against every ridge equally wide (0)",
    ),
    (
        "finger",
        "ridge_jitter",
        (0.0, 0.1, 0.25, 0.4),
        "irregularity of the ridge spacing: 0 a regular comb, up to 0.4 (ridges keep order)",
    ),
    (
        "materials",
        "resin.roughness_rms_m",
        (1.09e-6, 3.3e-6, 5.55e-6),
        "SLA prints' measured Ra 0.87-4.44 um (Rq = 1.25 Ra; the middle the default)",
    ),
    (
        "materials",
        "resin.correlation_length_m",
        (20e-6, 40e-6, 85e-6),
        "not measured: a free choice of the order of the laser spot, 20-85 um",
    ),
    (
        "materials",
        "resin.mark_amplitude_m",
        (0.5e-6, 1e-6, 2e-6),
        "the laser raster's depth, not measured: a free choice of 0.5-2 um, under the face's Ra",
    ),
    (
        "materials",
        "wood.roughness_rms_m",
        (3.75e-6, 6.9e-6, 10e-6),
        "sanded beech's measured Ra 3-8 um from P150 to P60 grit (the middle the default)",
    ),
    (
        "materials",
        "wood.correlation_length_m",
        (50e-6, 120e-6, 200e-6),
        "not measured: a free choice of the order of beech's vessels and fibres, 50-200 um",
    ),
    (
        "materials",
        "wood.mark_amplitude_m",
        (2e-6, 4e-6, 6e-6),
        "the growth rings' relief, a free choice within sanded wood's waviness of a few um, 2-6",
    ),
    (
        "materials",
        "aluminum.correlation_length_m",
        (5e-6, 15e-6, 30e-6),
        "not measured: a free choice of the order of the cutting edge's own marks, 5-30 um",
    ),
    (
        "finger",
        "pdms_diameter_m",
        (6e-3, 10e-3, 12e-3),
        "the PDMS support's diameter under the 14 mm pad, a free choice of 6-12 mm",
    ),
    (
        "finger",
        "pdms_modulus_pa",
        (0.57e6, 2.0e6, 3.7e6),
        "the PDMS support's modulus: Sylgard 184 from 33:1 to 5:1 base to curing agent "
        "(Wang, Volinsky & Gallant 2014), the usual 10:1 the default; the mix is not "
        "given, and the mount's modes move from 205 / 166 Hz (shear / rocking, 0.57 MPa) "
        "to 522 / 422 Hz (3.7 MPa)",
    ),
    (
        "finger",
        "skin_modulus_pa",
        (0.1e6, 0.29e6, 0.58e6),
        "the skin's modulus: its silicone is not named; from a fingertip-soft 0.1 MPa (a "
        "human fingertip is 0.07-0.2 MPa, Oprisan et al. 2016) over the Dragon Skin 20 "
        "class's 0.29 MPa (the default) to twice that, a harder compound; the skin's "
        "contact is refitted to each modulus's Hertz law",
    ),
    (
        "finger",
        "pad_radius_m",
        (0.006, 0.007, 0.008),
        "the pad's radius, not dimensioned: a free choice of 6-8 mm, a human fingertip's "
        "size, under the 10.8 mm the moon's 12.5 mm notch allows; the skin's contact is "
        "refitted to each radius's Hertz law",
    ),
    (
        "variability",
        "speed_rel",
        (0.0, 0.0025, 0.01, 0.03),
        "stroke-to-stroke scatter of the path speed: no source, 1 % an assumption; 0 an "
        "exact servo, 0.25 % a timed path whose points repeat as a UR5's poses do "
        "(sqrt(2) x 0.033 mm over the 19-29 mm between an outline's first and last "
        "touch, at most 0.25 %: calibrate.py speed), 3 % a loose one",
    ),
    (
        "variability",
        "window_jitter_s",
        (0.0, 0.02, 0.05),
        "how closely the contact onset found in the signals places the window: a free "
        "choice, 0 (exact) to 50 ms",
    ),
    (
        "motion",
        "force_loop_bandwidth_hz",
        (1.0, 2.0, 5.0, 10.0),
        "the force loop's closed-loop bandwidth: not published for UR force mode, 1-10 Hz "
        "for a 125-500 Hz admittance loop with a sample or two of latency",
    ),
    (
        "motion",
        "servo_stiffness_n_m",
        (10000.0, 20000.0, 40000.0),
        "the robot's position servos: not published for the arm's tip, a free choice of "
        "10-40 kN/m (1 N of friction deflects the tip 0.1-0.025 mm); with the phalanx the "
        "servo mode moves from 69 to 138 Hz, its damping held (ratio 1.41 to 0.71)",
    ),
    (
        "finger",
        "phalanx_mass_kg",
        (0.025, 0.05, 0.1),
        "the phalanx and carriage the servos move: not measured, a free choice of 25-100 g; "
        "the servo mode moves from 134 to 70 Hz, its damping held (ratio 1.37 to 0.72)",
    ),
    (
        "finger",
        "pad_mass_kg",
        (0.001, 0.002, 0.003, 0.004),
        "the mass below the PDMS support (skin pad, films, the support's moving half): not "
        "measured, 1-4 g; the mount's modes move from 665 / 537 Hz (shear / rocking, 1 g) "
        "to 332 / 269 Hz (4 g)",
    ),
    (
        "finger",
        "ridge_spacing_m",
        (0.3e-3, 0.45e-3, 0.6e-3),
        "the printed fingerprint's ridge spacing, not dimensioned: human ridges lie about "
        "0.5 mm apart (Maltoni et al.), a free choice of 0.3-0.6 mm",
    ),
    (
        "pvdf",
        "offset_m",
        (3e-3, 4e-3, 4.5e-3),
        "where the films' centres sit ahead of and behind the pad's axis, not dimensioned: "
        "their 5 mm strips stay on the 7 mm pad's flank and apart, 3-4.5 mm",
    ),
    (
        "pvdf",
        "length_m",
        (3e-3, 5e-3, 6e-3),
        "the films' electrode length along the path, not dimensioned: a strip on the 7 mm "
        "pad's flank, 3-6 mm",
    ),
    (
        "pvdf",
        "width_m",
        (3e-3, 4e-3, 5e-3),
        "the films' electrode width across the path, not dimensioned: a strip on the 7 mm "
        "pad's flank, 3-5 mm",
    ),
    (
        "strain_gauge",
        "lowpass_hz",
        (10.0, 100.0, 400.0),
        "the bridge conditioning's low-pass, not described: a free choice from 10 Hz (a "
        "static reading) to 400 Hz (none below the DAQ's anti-alias corner)",
    ),
    (
        "strain_gauge",
        "beam_side_m",
        (6e-3, 8e-3, 10e-3),
        "the printed phalanx's square section under the gauges, not dimensioned: 6-10 mm "
        "(its bending strain per newton goes as the side's cube)",
    ),
    (
        "strain_gauge",
        "amplifier_gain",
        (1000.0, 2000.0, 4000.0),
        "the bridge's instrumentation amplifier gain, not described: a free choice that "
        "keeps the front gauge's strongest strokes (about 3 V at 2000) inside the DAQ's "
        "+-10 V at every load of the grid, 1000-4000",
    ),
    (
        "strain_gauge",
        "offset_strain",
        (0.0, 2e-6, 1e-5),
        "the bridge's unbalance at zero load after nulling, not measured: a free choice "
        "from a perfect null to a 10 microstrain residual",
    ),
    (
        "finger",
        "gauge_heights_m.0",
        (0.008, 0.012, 0.016),
        "the front gauge's height above the pad's mount on the phalanx, not dimensioned: "
        "a free choice of 8-16 mm",
    ),
    (
        "finger",
        "gauge_heights_m.1",
        (0.016, 0.020, 0.024),
        "the side gauge's height above the pad's mount on the phalanx, not dimensioned: a "
        "free choice of 16-24 mm",
    ),
    (
        "acquisition",
        "mains_v",
        (0.3e-3, 1e-3, 3e-3),
        "50 Hz mains pickup at the DAQ's input, not measured: a free choice of 0.3-3 mV "
        "(about a code of the 16-bit input to ten), inside the films' texture band",
    ),
    (
        "acquisition",
        "drift_v_per_sqrt_s",
        (0.5e-3, 2e-3, 5e-3),
        "the bridge channels' slow thermal drift (a random walk), not measured: a free "
        "choice of 0.5-5 mV per root second",
    ),
    (
        *STRIBECK,
        (0.3e-3, 1e-3, 3e-3),
        "the slip speed over which the skin's friction falls from static to kinetic, not "
        "measured: a contact-renewal length of micrometres over a soft elastomer's "
        "millisecond relaxation, 0.3-3 mm/s, below the 6-14 mm/s sliding speeds",
    ),
    (
        *TEXTURE_SCALE,
        (0.0, 0.5, 1.0, 2.0),
        "sensitivity, not a calibration: every material's texture scaled; at 0 the "
        "materials do not differ at all (they share the silicone's friction law)",
    ),
)


def scaled_texture(
    material: Material, factor: float, roughness_factor: float | None = None
) -> Material:
    """``material`` with every periodic mark's amplitude times ``factor`` and its
    roughness RMS times ``roughness_factor`` (``factor`` if not given); its correlation
    length and wavelengths unchanged."""
    texture = material.texture
    roughness = factor if roughness_factor is None else roughness_factor
    marks = tuple(
        dataclasses.replace(p, amplitude_m=p.amplitude_m * factor) for p in texture.periodic
    )
    scaled = dataclasses.replace(
        texture, roughness_rms_m=texture.roughness_rms_m * roughness, periodic=marks
    )
    return dataclasses.replace(material, texture=scaled)


def material_field(config: SynthConfig, section: str, field: str) -> tuple[str, str] | None:
    """``(material, field)`` when ``section.field`` names one material's own setting
    (``materials.MATERIAL.FIELD``, FIELD one of :data:`MATERIAL_FIELDS`), or None."""
    name, _, rest = field.partition(".")
    if section == "materials" and rest in MATERIAL_FIELDS and name in config.materials:
        return name, rest
    return None


def gauge_index(section: str, field: str) -> int | None:
    """``I`` when ``section.field`` is ``finger.gauge_heights_m.I`` (one gauge's height,
    ``I`` 0 or 1), or None."""
    name, _, index = field.partition(".")
    if section == "finger" and name == GAUGE_HEIGHTS and index in ("0", "1"):
        return int(index)
    return None


def _one_mark(config: SynthConfig, name: str) -> Periodic:
    """``name``'s periodic mark, which ``mark_amplitude_m`` sets; a one-line refusal for a
    material with none or several."""
    marks = config.materials[name].texture.periodic
    if len(marks) != 1:
        raise CalibrationError(
            f"materials.{name}.mark_amplitude_m: {name} has {len(marks)} periodic marks; "
            "the setting needs exactly one"
        )
    return marks[0]


def _material_with(config: SynthConfig, name: str, field: str, value: float) -> SynthConfig:
    material = config.materials[name]
    if field == KINETIC_FRICTION:  # the static coefficient kept in the same ratio
        law = material.friction
        scaled = dataclasses.replace(law, kinetic=value, static=value * law.static / law.kinetic)
        return config.with_material(dataclasses.replace(material, friction=scaled))
    texture = material.texture
    if field == "mark_amplitude_m":
        mark = dataclasses.replace(_one_mark(config, name), amplitude_m=value)
        texture = dataclasses.replace(texture, periodic=(mark,))
    else:
        texture = dataclasses.replace(texture, **{field: value})
    return config.with_material(dataclasses.replace(material, texture=texture))


@dataclasses.dataclass(frozen=True)
class Setting:
    """A setting that is not one plain numeric field of a configuration section: how to
    read its value from a configuration and how to set it."""

    read: Callable[[SynthConfig], float]
    write: Callable[[SynthConfig, float], SynthConfig]


def special_setting(config: SynthConfig, section: str, field: str) -> Setting | None:
    """The setting ``section.field`` names when it is not a plain field, or None: a
    material-wide factor of :data:`MATERIAL_FACTORS` (read as 1; it scales every
    material's texture); ``materials.MATERIAL.kinetic_friction`` (that material's kinetic
    friction, its static coefficient kept in the same ratio) and
    ``materials.MATERIAL.FIELD`` with FIELD one of :data:`TEXTURE_FIELDS` (that
    material's surface); ``materials.stribeck_velocity_m_s`` (every material's Stribeck
    velocity, read as the largest); ``finger.gauge_heights_m.I`` (gauge I's height);
    ``finger.FIELD`` with FIELD one of :data:`synth.skin_fit.HERTZ_FIELDS` (the skin's
    contact refitted to its new Hertz law)."""
    own = material_field(config, section, field)
    if own is not None:
        name, attr = own
        return Setting(
            lambda c: _material_value(c, name, attr),
            lambda c, value: _material_with(c, name, attr, value),
        )
    if (section, field) in MATERIAL_FACTORS:
        roughness_too = (section, field) == TEXTURE_SCALE
        return Setting(
            lambda c: 1.0,
            lambda c, value: _texture_scaled(c, value, value if roughness_too else 1.0),
        )
    if (section, field) == STRIBECK:
        return Setting(
            lambda c: max(m.friction.stribeck_velocity_m_s for m in c.materials.values()),
            _with_stribeck,
        )
    gauge = gauge_index(section, field)
    if gauge is not None:
        return Setting(
            lambda c: c.finger.gauge_heights_m[gauge],
            lambda c, value: _with_gauge_height(c, gauge, value),
        )
    if section == "finger" and field in HERTZ_FIELDS:
        return Setting(
            lambda c: getattr(c.finger, field),
            lambda c, value: _with_refitted_skin(c, field, value),
        )
    return None


def _material_value(config: SynthConfig, name: str, attr: str) -> float:
    if attr == KINETIC_FRICTION:
        return config.materials[name].friction.kinetic
    if attr == "mark_amplitude_m":
        return _one_mark(config, name).amplitude_m
    return getattr(config.materials[name].texture, attr)


def _texture_scaled(config: SynthConfig, factor: float, roughness: float) -> SynthConfig:
    for material in config.materials.values():
        config = config.with_material(scaled_texture(material, factor, roughness))
    return config


def _with_stribeck(config: SynthConfig, value: float) -> SynthConfig:
    for material in config.materials.values():
        law = dataclasses.replace(material.friction, stribeck_velocity_m_s=value)
        config = config.with_material(dataclasses.replace(material, friction=law))
    return config


def _with_gauge_height(config: SynthConfig, gauge: int, value: float) -> SynthConfig:
    heights = list(config.finger.gauge_heights_m)
    heights[gauge] = value
    finger = dataclasses.replace(config.finger, gauge_heights_m=tuple(heights))
    return dataclasses.replace(config, finger=finger)


def _with_refitted_skin(config: SynthConfig, field: str, value: float) -> SynthConfig:
    """``config`` with the finger's ``field`` at ``value`` and the skin's MuJoCo contact
    fitted to the resulting Hertz law; the fit's failure is a one-line refusal."""
    if getattr(config.finger, field) == value:  # the skin as it is: its fit stands
        return config
    changed = dataclasses.replace(
        config, finger=dataclasses.replace(config.finger, **{field: value})
    )
    try:
        return with_fitted_skin(changed)
    except SimulationError as exc:
        raise CalibrationError(f"the skin's contact cannot be fitted to this skin: {exc}") from None


def with_value(config: SynthConfig, section: str, field: str, value: float) -> SynthConfig:
    """``config`` with ``section.field`` set to ``value``: a plain field, or one of the
    settings :func:`special_setting` knows."""
    special = special_setting(config, section, field)
    if special is not None:
        return special.write(config, value)
    part = dataclasses.replace(getattr(config, section), **{field: value})
    return dataclasses.replace(config, **{section: part})


def default_value(config: SynthConfig, section: str, field: str) -> float:
    """The configuration's value of a swept parameter (1 for the material factors)."""
    special = special_setting(config, section, field)
    if special is not None:
        return special.read(config)
    return getattr(getattr(config, section), field)


def parse_set(items: list[str] | None) -> dict[tuple[str, str], float]:
    """``--set SECTION.FIELD=VALUE`` items as ``{(section, field): value}``: a numeric
    field of a configuration section (or ``materials.texture_scale``,
    ``materials.marks_scale`` or ``materials.MATERIAL.FIELD`` with FIELD one of
    :data:`MATERIAL_FIELDS`, ``materials.stribeck_velocity_m_s``, every material's, or
    ``finger.gauge_heights_m.I``, one gauge's height), each set once; none gives an
    empty table."""
    defaults = SynthConfig()
    out: dict[tuple[str, str], float] = {}
    for item in items or ():
        name, sep, text = item.partition("=")
        section, _, field = name.partition(".")
        special = special_setting(defaults, section, field) is not None
        known = special or (
            section in SECTIONS
            and field in {f.name for f in dataclasses.fields(getattr(defaults, section))}
            and type(getattr(getattr(defaults, section), field)) in (int, float)
        )
        if not sep or not known:
            raise CalibrationError(
                "--set must be SECTION.FIELD=VALUE with a numeric field of "
                f"{', '.join(SECTIONS)} (or materials.texture_scale, .marks_scale or "
                f".MATERIAL.FIELD with MATERIAL one of {', '.join(defaults.materials)} and "
                f"FIELD one of {', '.join(MATERIAL_FIELDS)}, materials.{STRIBECK[1]}, or "
                f"finger.{GAUGE_HEIGHTS}.0 or .1); got {item!r}"
            )
        try:
            value = parse_number(text)
        except ValueError:
            value = math.nan
        if not math.isfinite(value):
            raise CalibrationError(f"--set {name} needs a finite number; got {text!r}")
        if (section, field) in out:
            raise CalibrationError(f"--set sets {name} twice")
        if not special and type(getattr(getattr(defaults, section), field)) is int:
            if not value.is_integer():
                raise CalibrationError(f"--set {name} needs a whole number; got {text!r}")
            value = int(value)
        out[section, field] = value
    return out


def configured(items: list[str] | None) -> SynthConfig:
    """The default configuration with the ``--set`` items applied (none: the defaults)."""
    config = SynthConfig()
    for (section, field), value in parse_set(items).items():
        try:
            config = with_value(config, section, field, value)
        except ValueError as exc:
            raise CalibrationError(f"--set {section}.{field}={value:g}: {exc}") from None
    return config


#: ``--set pvdf.post_gain=G`` holds the films' post-gain at G; without it the sweep,
#: whatif and the texture bench size it for each configuration
#: (:func:`synth.calibration.gain.at_sized_gain`).
POST_GAIN = ("pvdf", "post_gain")


def holds_gain(items: list[str] | None) -> bool:
    """Whether the ``--set`` items fix the films' post-gain (:data:`POST_GAIN`)."""
    return POST_GAIN in parse_set(items)


def parse_base(items: list[str] | None) -> dict[tuple[str, str], float]:
    """``--base SECTION.FIELD=VALUE`` items as ``{(section, field): value}``, each naming a
    swept parameter once and a value inside the range its candidates span (its cited
    range)."""
    ranges = {f"{s}.{f}": (s, f, min(c), max(c)) for s, f, c, _ in SWEEP}
    out: dict[tuple[str, str], float] = {}
    for item in items or ():
        name, sep, text = item.partition("=")
        if not sep or name not in ranges:
            raise CalibrationError(
                f"--base must be SECTION.FIELD=VALUE with a swept parameter "
                f"({', '.join(sorted(ranges))}); got {item!r}"
            )
        try:
            value = parse_number(text)
        except ValueError:
            raise CalibrationError(f"--base {name} needs a number; got {text!r}") from None
        section, field, lo, hi = ranges[name]
        if (section, field) in out:
            raise CalibrationError(f"--base sets {name} twice")
        if not lo <= value <= hi:
            raise CalibrationError(
                f"--base {name} must lie in its cited range {lo:g}..{hi:g}; got {value:g}"
            )
        out[section, field] = value
    return out


def check_swept(names: list[str] | None) -> None:
    """Refuse ``--only`` names that are not swept parameters."""
    known = {f"{section}.{field}" for section, field, _, _ in SWEEP}
    for name in names or ():
        if name not in known:
            raise CalibrationError(
                f"--only must name a swept parameter ({', '.join(sorted(known))})"
            )
