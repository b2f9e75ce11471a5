"""Reproduce the simulator's calibration from nothing.

Only global, physically meaningful parameters are calibrated, each within the range its
source gives; nothing is tuned per shape, material or class.

    python3 scripts/calibrate.py skin
        Fit MuJoCo's soft-contact parameters of the skin so that its indentation follows
        Hertz's law for the configured skin modulus; prints Finger.skin_solref/solimp.
    python3 scripts/calibrate.py friction
        The stroke-to-stroke scatter of the friction coefficient
        (Variability.friction_rel) from repeated-sliding measurements of two silicones on
        PLA (scripts/data/silicone_pla_friction.csv): for each silicone, the run whose
        pressure is nearest the skin's mean Hertz contact pressure at the nominal force,
        and in it the coefficient of variation of the friction coefficient over its
        cycles (run-in included); prints every run's figures and the mean of the two.
    python3 scripts/calibrate.py force
        The stroke-to-stroke scatter of the normal force (Variability.force_rel) from the
        arm's pose repeatability: one standard deviation of the press depth (the ISO 9283
        repeatability, mean distance plus 3 standard deviations, over 3; bounded by a
        Gaussian scatter in three axes and one along the press direction alone) times the
        stiffness the press compresses in series at the nominal force (the arm's servo,
        the PDMS support and the skin's Hertz contact); prints the three readings and the
        value the default is rounded from.
    python3 scripts/calibrate.py gain [--set SECTION.FIELD=VALUE ...]
        The PVDF post-amplifier gain: the largest round gain (1-2-5 series) that keeps
        the worst edge transient of the perturbation grid (every shape x material at
        1.4 N, 14 mm/s) below 70 % of the DAQ's range; with ``--set``, for the
        configuration whatif would measure.
    python3 scripts/calibrate.py carrier [--thickness-m T ...]
        The films' polyester carrier, which the finger's description does not give: for
        each carrier thickness (default: the standard polyester stocks from 23 um to the
        laminated elements' 125 um; the defaults assume 36 um) the neutral-axis offset
        and shear coupling it gives the films (:func:`synth.sensors.film_on_carrier`),
        the post-gain ``gain`` sizes for them, and the ``whatif --set`` options that
        measure that film.
    python3 scripts/calibrate.py sweep [--trials-per-class 20] [--seeds 1]
                                       [--only SECTION.FIELD] [--base SECTION.FIELD=VALUE]
                                       [--set SECTION.FIELD=VALUE] [--out DIR [--resume]]
        Each global parameter of SWEEP over its cited range (one at a time, the others at
        their defaults, or at the values ``--base`` sets, each within its parameter's cited
        range, to see how two parameters act together; ``--set`` changes any numeric field
        of the configuration the sweep starts from, as whatif's does): generates the paper
        grid, runs the leave-one-out diagnosis and AFOP-ML's feature selection on the
        generalisation protocols' training splits, and prints (and writes DIR/calibration.md
        and .json) the numbers the defaults were chosen by: strain-gauge shape accuracy
        (target >= 0.95, every shape >= 0.85), material accuracy per channel group, and the
        PVDF share of the selected features and the median D on cross-shape and
        cross-material training splits (the paper's real finger: 21 % and 50 %, D about 6
        and 12). Only training splits are used: no test accuracy enters. With ``--seeds N``
        every candidate is generated from N dataset seeds (0..N-1); the figures are their
        means, and the table adds the shares' standard deviation over the seeds and their
        difference ``pvdf_share_gap`` (cross-shape minus cross-material, negative on the
        real finger), since one dataset's shares move by several points with its seed. The
        paper's shares are of its own D, so the table also gives the share of each split's
        first 6 (cross-shape) and 12 (cross-material) ranked features and their gap
        (``pvdf_share_paper_d_*``).
        DIR's tables are rewritten after every candidate, so an interrupted sweep keeps
        the rows it measured; ``--resume`` reuses the rows of DIR's table measured with
        the same trials per class, seeds and configuration, and measures the rest.

    python3 scripts/calibrate.py update
        Not a calibration: the surface update period (Motion.surface_update_s, a numerical
        choice) of 2 and 4 ms against a 1 ms update, on the same trials (every shape x
        material, seed 0, at 2, 6, 10, 14 and 24 mm/s): the films' power above 150 Hz
        (where a too-slow update leaves its rate's tone) as a ratio to the 1 ms run's, and
        each channel group's RMS difference from the 1 ms run relative to its signal, with
        the difference between two seeds at the default period for scale.

    python3 scripts/calibrate.py picks DATA [--top 12]
        Not a calibration either: what AFOP-ML's selections on DATA's generalisation
        training splits lean on. For every cross-shape fold and cross-material split
        (fitted on the training split alone, as the sweep fits them) it lists the first
        ``--top`` features of the NCA ranking, whether the D-scan selected each, and the
        shares of each feature's variance on that split between the shapes' means and
        between the materials' means inside a shape; and counts, per sensor, the selected
        features that vary more between materials than between shapes (material-led).

    python3 scripts/calibrate.py whatif [--set SECTION.FIELD=VALUE ...]
                                        [--trials-per-class 20] [--seeds 1]
                                        [--closed-set EPISODES [--closed-set-seeds 1]]
                                        [--keep DIR]
        Not a calibration: one configuration with any numeric field set to any value its
        dataclass accepts, inside or outside a cited range (``materials.texture_scale``
        as in the sweep; ``materials.marks_scale`` scales the periodic marks alone), to
        measure what the real finger would have to be for a target to be met; without
        ``--set``, the defaults. Prints the sweep's metrics over the seeds and, with
        ``--closed-set N``, AFOP-ML's closed-set 1-shot row over N episodes on a
        paper-preset dataset (seed 0) of that configuration, with the fit's D, PVDF share
        and t-SNE indicators; ``--closed-set-seeds M`` measures that row on the datasets
        of seeds 0..M-1 and adds each figure's mean and standard deviation over them.
        ``--keep DIR`` keeps the measured dataset of seed 0 in DIR, a new directory (for
        ``picks`` or ``tactile-synth diagnose``). The defaults never come from it.

The sweep simulates 36 classes x ``--trials-per-class`` trials per candidate and seed
(720 at the default of 20); at 30 trials per class and three seeds a candidate takes
about 140 s on 2 idle cores, the selection included. The default configuration is
evaluated once.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import hashlib
import json
import math
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import synth
from shapes import SHAPE_NAMES
from synth.sensors import film_on_carrier
from tactile_synth.atomic import check_out_dir
from tactile_synth.validation import float_arg, int_arg, parse_number

#: Not a configuration field: a factor on every material's texture amplitudes (roughness
#: and periodic marks), swept to see how much of the materials' signature the texture
#: carries.
TEXTURE_SCALE = ("materials", "texture_scale")
#: Not a configuration field either: a factor on every material's periodic marks alone
#: (the random roughness kept), for whatif to ask what the marks carry.
MARKS_SCALE = ("materials", "marks_scale")
#: The material-wide factors, which are not configuration fields.
MATERIAL_FACTORS = (TEXTURE_SCALE, MARKS_SCALE)

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
        "damping of the PDMS modes: half a silicone's loss tangent (0.1-0.4)",
    ),
    (
        "pvdf",
        "feedback_resistance_ohm",
        (1e9, 100e6, 10e6),
        "charge-amplifier high-pass 0.16 / 1.6 / 16 Hz",
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
        "ridge_jitter",
        (0.0, 0.1, 0.25, 0.4),
        "irregularity of the ridge spacing: 0 a regular comb, up to 0.4 (ridges keep order)",
    ),
    (
        *TEXTURE_SCALE,
        (0.0, 0.5, 1.0, 2.0),
        "sensitivity, not a calibration: every material's texture scaled; at 0 the "
        "materials do not differ at all (they share the silicone's friction law)",
    ),
)


def _with(config: synth.SynthConfig, section: str, field: str, value: float):
    if (section, field) in MATERIAL_FACTORS:
        roughness = value if (section, field) == TEXTURE_SCALE else 1.0
        for material in config.materials.values():
            config = config.with_material(_scaled_texture(material, value, roughness))
        return config
    part = dataclasses.replace(getattr(config, section), **{field: value})
    return dataclasses.replace(config, **{section: part})


def _default(config: synth.SynthConfig, section: str, field: str) -> float:
    """The configuration's value of a swept parameter (1 for the texture scale)."""
    if (section, field) in MATERIAL_FACTORS:
        return 1.0
    return getattr(getattr(config, section), field)


def _scaled_texture(
    material: synth.Material, factor: float, roughness_factor: float | None = None
) -> synth.Material:
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


def cmd_skin(_args: argparse.Namespace) -> int:
    from synth import contact, skin_fit

    config = synth.SynthConfig()
    t0 = time.perf_counter()
    solref, solimp = skin_fit.fit_skin_contact(config)
    fitted = dataclasses.replace(
        config, finger=dataclasses.replace(config.finger, skin_solref=solref, skin_solimp=solimp)
    )
    forces = np.asarray(skin_fit.FIT_FORCES_N)
    f = config.finger
    hertz = contact.hertz_indentation_m(forces, f.pad_radius_m, f.skin_modulus_pa, f.skin_poisson)
    got = skin_fit.measure_indentation(fitted, forces)
    print(f"fitted in {time.perf_counter() - t0:.0f} s")
    print(f"skin_solref = {solref}")
    print(f"skin_solimp = {solimp}")
    print("force (N)   Hertz (mm)   simulated (mm)")
    for fn, h, g in zip(forces, hertz, got, strict=True):
        print(f"{fn:8.2f}   {h * 1e3:10.3f}   {g * 1e3:14.3f}")
    return 0


#: Repeated-sliding measurements of silicone on PLA (their source and licence are in the
#: file's header).
FRICTION_DATA = Path(__file__).resolve().parent / "data" / "silicone_pla_friction.csv"


def friction_runs(path: Path = FRICTION_DATA) -> dict[tuple[str, float], dict]:
    """The runs of ``path`` as ``{(silicone, pressure_kpa): {"load_mn", "cof"}}``, each
    run's friction coefficients in cycle order."""
    runs: dict[tuple[str, float], dict] = {}
    with open(path, newline="") as fh:
        lines = [line for line in fh if not line.startswith("#")]
    for row in csv.DictReader(lines):
        key = (row["silicone"], float(row["pressure_kpa"]))
        run = runs.setdefault(key, {"load_mn": float(row["load_mn"]), "cycles": []})
        run["cycles"].append((int(row["cycle"]), float(row["friction_coefficient"])))
    for run in runs.values():
        run["cof"] = np.array([c for _, c in sorted(run.pop("cycles"))])
    return runs


def skin_contact_pressure_pa(config: synth.SynthConfig, force_n: float) -> float:
    """Mean Hertz pressure of the skin's contact under ``force_n``: the force over the
    contact area ``pi a^2`` (:func:`synth.texture.contact_radius_m`)."""
    from synth.texture import contact_radius_m

    return force_n / (math.pi * float(contact_radius_m(config.finger, force_n)) ** 2)


def friction_scatter(config: synth.SynthConfig, path: Path = FRICTION_DATA) -> dict:
    """The friction scatter the measurements give for ``config``'s skin at the nominal
    force: per silicone, the coefficient of variation (``ddof=1``) of the run nearest the
    skin's contact pressure; ``value`` is their mean."""
    from synth.presets import NOMINAL_FORCE_N

    runs = friction_runs(path)
    pressure_kpa = skin_contact_pressure_pa(config, NOMINAL_FORCE_N) / 1e3
    chosen = {}
    for silicone in sorted({s for s, _ in runs}):
        p = min((p for s, p in runs if s == silicone), key=lambda p: abs(p - pressure_kpa))
        chosen[silicone] = p
    cv = {k: float(r["cof"].std(ddof=1) / r["cof"].mean()) for k, r in runs.items()}
    return {
        "pressure_kpa": pressure_kpa,
        "runs": runs,
        "cv": cv,
        "chosen": chosen,
        "value": float(np.mean([cv[(s, p)] for s, p in chosen.items()])),
    }


def cmd_friction(_args: argparse.Namespace) -> int:
    from synth.presets import NOMINAL_FORCE_N

    got = friction_scatter(synth.SynthConfig())
    print(f"skin's mean contact pressure at {NOMINAL_FORCE_N:g} N: {got['pressure_kpa']:.1f} kPa")
    print("silicone         load (mN)  pressure (kPa)  cycles  mean   CV (%)  CV after 5 (%)")
    for (silicone, p), run in sorted(got["runs"].items()):
        cof = run["cof"]
        late = cof[5:].std(ddof=1) / cof[5:].mean()
        mark = "  <- nearest" if got["chosen"].get(silicone) == p else ""
        print(
            f"{silicone:15s}  {run['load_mn']:9g}  {p:14g}  {cof.size:6d}  {cof.mean():.3f}"
            f"  {100 * got['cv'][(silicone, p)]:6.2f}  {100 * late:14.2f}{mark}"
        )
    print(f"Variability.friction_rel = {got['value']:.3f} (mean of the nearest runs' CV)")
    return 0


#: Pose repeatability of the UR5 (its data sheet: +-0.1 mm), stated as ISO 9283 states it:
#: the mean distance of the reached poses from their mean plus 3 standard deviations.
ARM_REPEATABILITY_M = 0.1e-3
#: Mean plus 3 standard deviations of the distance from the centre of a Gaussian scatter
#: of standard deviation 1 in each of three axes (a chi distribution of 3 degrees: mean
#: 2 sqrt(2 / pi), variance 3 - 8 / pi) ...
CHI3_MEAN_PLUS_3SD = 2 * math.sqrt(2 / math.pi) + 3 * math.sqrt(3 - 8 / math.pi)
#: ... and along one axis only (a folded normal: mean sqrt(2 / pi), variance 1 - 2 / pi).
CHI1_MEAN_PLUS_3SD = math.sqrt(2 / math.pi) + 3 * math.sqrt(1 - 2 / math.pi)


def force_scatter(config: synth.SynthConfig) -> dict:
    """The normal force's stroke-to-stroke scatter a press of ``config``'s finger at a
    repeatable depth gives at the nominal force ``F``: a depth error of standard deviation
    ``s`` changes the load by ``k s``, ``k`` the stiffness of everything the press
    compresses in series (the arm's servo, the PDMS support and the skin's Hertz contact,
    whose tangent stiffness is ``1.5 F / delta`` at the skin's indentation ``delta``:
    :func:`synth.closed_loop.series_stiffness_n_m` and ``skin_stiffness_n_m``), so it
    scatters by ``k s / F`` (relative). ``s`` is the arm's repeatability over 3 (the ISO
    figure read as three standard deviations of the press depth: the ``value`` the
    default is rounded from), and, to bound it, over :data:`CHI3_MEAN_PLUS_3SD` (a
    Gaussian scatter in three axes: ``gaussian_3d``) and :data:`CHI1_MEAN_PLUS_3SD` (all
    of it along the press direction: ``gaussian_1d``)."""
    from synth import contact
    from synth.closed_loop import series_stiffness_n_m, skin_stiffness_n_m
    from synth.presets import NOMINAL_FORCE_N

    f = config.finger
    delta = float(
        contact.hertz_indentation_m(
            NOMINAL_FORCE_N, f.pad_radius_m, f.skin_modulus_pa, f.skin_poisson
        )
    )
    k = series_stiffness_n_m(config, NOMINAL_FORCE_N)
    sd_axis = ARM_REPEATABILITY_M / 3
    sd_3d = ARM_REPEATABILITY_M / CHI3_MEAN_PLUS_3SD
    sd_1d = ARM_REPEATABILITY_M / CHI1_MEAN_PLUS_3SD
    return {
        "force_n": NOMINAL_FORCE_N,
        "indentation_m": delta,
        "skin_stiffness_n_m": skin_stiffness_n_m(config, NOMINAL_FORCE_N),
        "servo_stiffness_n_m": config.motion.servo_stiffness_n_m,
        "pdms_stiffness_n_m": f.pdms_normal_stiffness_n_m,
        "series_stiffness_n_m": k,
        "depth_sd_m": sd_axis,
        "depth_sd_3d_m": sd_3d,
        "depth_sd_1d_m": sd_1d,
        "value": k * sd_axis / NOMINAL_FORCE_N,
        "gaussian_3d": k * sd_3d / NOMINAL_FORCE_N,
        "gaussian_1d": k * sd_1d / NOMINAL_FORCE_N,
    }


def cmd_force(_args: argparse.Namespace) -> int:
    got = force_scatter(synth.SynthConfig())
    print(
        f"at {got['force_n']:g} N: skin's Hertz indentation {got['indentation_m'] * 1e3:.3f} mm "
        f"(tangent stiffness {got['skin_stiffness_n_m']:.0f} N/m), PDMS support "
        f"{got['pdms_stiffness_n_m']:.0f} N/m, arm's servo {got['servo_stiffness_n_m']:.0f} N/m: "
        f"{got['series_stiffness_n_m']:.0f} N/m in series"
    )
    print(f"arm's pose repeatability (ISO 9283, mean + 3 sd): {ARM_REPEATABILITY_M * 1e3:g} mm")
    for label, sd, rel in (
        ("repeatability / 3", got["depth_sd_m"], got["value"]),
        ("Gaussian in three axes", got["depth_sd_3d_m"], got["gaussian_3d"]),
        ("Gaussian along the press direction", got["depth_sd_1d_m"], got["gaussian_1d"]),
    ):
        print(f"  {label}: depth sd {sd * 1e3:.4f} mm -> load scatter {100 * rel:.2f} %")
    print(f"Variability.force_rel = {got['value']:.3f} (series stiffness x depth sd / force)")
    return 0


def mount_figures(config: synth.SynthConfig) -> dict:
    """The PDMS support's stiffnesses from its geometry and modulus, the simulated
    compression stand-in, and the pad's modes on it (compression with the skin's Hertz
    contact at the nominal force beside the support)."""
    from synth.closed_loop import skin_stiffness_n_m
    from synth.presets import NOMINAL_FORCE_N

    f = config.finger
    return {
        "modulus_pa": f.pdms_modulus_pa,
        "diameter_m": f.pdms_diameter_m,
        "thickness_m": f.pdms_thickness_m,
        "shape_factor": f.pdms_shape_factor,
        "shear_n_m": f.pdms_shear_stiffness_n_m,
        "compression_derived_n_m": f.pdms_normal_stiffness_derived_n_m,
        "compression_simulated_n_m": f.pdms_normal_stiffness_n_m,
        "pitch_nm_rad": f.pdms_pitch_stiffness_nm_rad,
        "modes_hz": f.mount_modes_hz(skin_stiffness_n_m(config, NOMINAL_FORCE_N)),
    }


def cmd_mount(args: argparse.Namespace) -> int:
    got = mount_figures(_configured(args.set))
    print(
        f"PDMS disc {got['diameter_m'] * 1e3:g} mm across, {got['thickness_m'] * 1e3:g} mm "
        f"thick, E {got['modulus_pa'] / 1e6:g} MPa (shape factor {got['shape_factor']:.2f})"
    )
    print(
        f"shear {got['shear_n_m'] / 1e3:.1f} kN/m, compression "
        f"{got['compression_derived_n_m'] / 1e3:.0f} kN/m (simulated: "
        f"{got['compression_simulated_n_m'] / 1e3:.0f} kN/m), rocking "
        f"{got['pitch_nm_rad']:.3f} N m/rad"
    )
    modes = got["modes_hz"]
    print(
        f"modes on the pad: shear {modes['shear']:.0f} Hz, compression (simulated, skin "
        f"beside it) {modes['normal']:.0f} Hz, rocking {modes['pitch']:.0f} Hz"
    )
    return 0


#: Round post-amplifier gains (1-2-5 series) the gain command chooses from.
ROUND_GAINS: tuple[float, ...] = (0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0)


def _configured(items: list[str] | None) -> synth.SynthConfig:
    """The default configuration with the ``--set`` items applied (none: the defaults)."""
    config = synth.SynthConfig()
    for (section, field), value in _parse_set(items).items():
        try:
            config = _with(config, section, field, value)
        except ValueError as exc:
            raise SystemExit(f"--set {section}.{field}={value:g}: {exc}") from None
    return config


def sized_gain(config: synth.SynthConfig) -> tuple[float, float]:
    """``(worst PVDF transient per unit post-gain (V), largest round gain that keeps it
    below 70 % of the DAQ's range)`` for ``config``; SystemExit when no gain fits."""
    from synth.sensors import SaturationError

    # The worst transient per unit post-gain, read through a DAQ of a wide range.
    probe = dataclasses.replace(
        config,
        pvdf=dataclasses.replace(config.pvdf, post_gain=1.0),
        acquisition=dataclasses.replace(config.acquisition, range_v=1e3, adc_bits=24),
    )
    specs = [
        synth.TrialSpec(s, m, force_n=1.4, speed_mm_s=14.0, seed=k)
        for s in SHAPE_NAMES
        for m in synth.MATERIAL_NAMES
        for k in range(2)
    ]
    try:
        trials = synth.simulate_batch(specs, config=probe)
    except SaturationError as exc:
        raise SystemExit(
            f"the PVDF transients exceed +-{probe.acquisition.range_v:g} V per unit "
            f"post-gain, so no gain from {ROUND_GAINS[0]:g} fits the DAQ ({exc})"
        ) from None
    per_gain = max(float(np.abs(t.signals[:2]).max()) for t in trials)
    budget = 0.7 * config.acquisition.range_v
    fits = [g for g in ROUND_GAINS if g * per_gain <= budget]
    if not fits:
        raise SystemExit(
            f"no post-gain from {ROUND_GAINS[0]:g} up keeps the worst PVDF transient "
            f"({per_gain:.1f} V per unit gain) below {budget:g} V"
        )
    return per_gain, max(fits)


def cmd_gain(args: argparse.Namespace) -> int:
    config = _configured(args.set)
    per_gain, best = sized_gain(config)
    print(f"worst PVDF transient at 1.4 N, 14 mm/s: {per_gain:.2f} V per unit post-gain")
    print(
        f"post_gain = {best:g} (peak {best * per_gain:.1f} V of +-{config.acquisition.range_v} V)"
    )
    return 0


#: Young's modulus of the films' polyester carrier (PET film: 4-5 GPa).
CARRIER_MODULUS_PA = 4.5e9
#: Carrier thicknesses ``carrier`` reports by default: the standard polyester film
#: stocks, from the thinnest to the laminated elements' (Measurement Specialties, Piezo
#: Film Sensors Technical Manual: 125 um polyester under 28 um film). The defaults
#: assume 75 um, the stock nearest the middle of that range (docs/simulator.md).
CARRIER_THICKNESSES_M = (23e-6, 36e-6, 50e-6, 75e-6, 125e-6)


def cmd_carrier(args: argparse.Namespace) -> int:
    base = synth.SynthConfig()
    for thickness in args.thickness_m or CARRIER_THICKNESSES_M:
        if not 0 < thickness <= 1e-3:
            raise SystemExit(f"--thickness-m {thickness:g}: must be in (0, 0.001] m")
        offset, shear = film_on_carrier(base.pvdf, base.finger, thickness, CARRIER_MODULUS_PA)
        pvdf = dataclasses.replace(
            base.pvdf, neutral_axis_offset_m=offset, shear_strain_per_n=shear
        )
        _, gain = sized_gain(dataclasses.replace(base, pvdf=pvdf))
        print(
            f"carrier {thickness * 1e6:g} um: neutral_axis_offset_m {offset:.3g}, "
            f"shear_strain_per_n {shear:.3g}, post_gain {gain:g}; measure it with "
            f"`python3 scripts/calibrate.py whatif --set pvdf.neutral_axis_offset_m={offset:.3g} "
            f"--set pvdf.shear_strain_per_n={shear:.3g} --set pvdf.post_gain={gain:g}`",
            flush=True,
        )
    return 0


#: Surface update periods ``update`` compares: the first is the reference.
UPDATE_PERIODS_S = (0.001, 0.002, 0.004)
#: Speeds ``update`` compares them at: the presets' 6, 10 and 14 mm/s, a slow slide that
#: sticks and slips, and the fastest a grid may ask for.
UPDATE_SPEEDS_MM_S = (2.0, 6.0, 10.0, 14.0, 24.0)
#: The band an update-rate artefact shows in: above the texture's strongest tones.
UPDATE_BAND_HZ = 150.0


def update_convergence(
    config: synth.SynthConfig,
    periods: tuple[float, ...] = UPDATE_PERIODS_S,
    *,
    speeds: tuple[float, ...] = UPDATE_SPEEDS_MM_S,
    shapes: tuple[str, ...] = SHAPE_NAMES,
    materials: tuple[str, ...] = synth.MATERIAL_NAMES,
) -> dict:
    """The same trials (every shape x material, seed 0, at each of ``speeds``) simulated
    with each surface update period in ``periods``, compared with the first. One row per
    later period and speed: the films' power above :data:`UPDATE_BAND_HZ` as a ratio to
    the reference's (median and largest over the trials), and the RMS difference of the
    films' and of the gauges' mean-removed signals from the reference's, relative to the
    reference's RMS (median and 95th percentile). ``"seeds"``: per speed, the same
    differences between seeds 0 and 1 at ``config``'s own period, for scale."""
    films = [i for i, c in enumerate(synth.CHANNELS) if c.startswith("pvdf")]
    gauges = [i for i, c in enumerate(synth.CHANNELS) if c.startswith("sg")]
    specs = [(v, s, m) for v in speeds for s in shapes for m in materials]
    at = {v: np.array([i for i, sp in enumerate(specs) if sp[0] == v]) for v in speeds}

    def run(period: float, seed: int) -> np.ndarray:
        cfg = _with(config, "motion", "surface_update_s", period)
        batch = [synth.TrialSpec(s, m, speed_mm_s=v, seed=seed) for v, s, m in specs]
        sig = np.stack([t.signals for t in synth.simulate_batch(batch, config=cfg)])
        return sig - sig.mean(axis=-1, keepdims=True)

    def band_power(sig: np.ndarray) -> np.ndarray:
        spec = np.abs(np.fft.rfft(sig[:, films], axis=-1)) ** 2
        freq = np.fft.rfftfreq(sig.shape[-1], 1.0 / synth.SAMPLE_RATE_HZ)
        return spec[..., freq >= UPDATE_BAND_HZ].sum(axis=(1, 2))

    def differences(a: np.ndarray, b: np.ndarray) -> dict:
        out = {}
        for name, group in (("pvdf", films), ("sg", gauges)):
            num = np.sqrt(((a[:, group] - b[:, group]) ** 2).mean(axis=-1))
            d = (num / np.sqrt((b[:, group] ** 2).mean(axis=-1))).ravel()
            out[f"{name}_diff_median"] = float(np.median(d))
            out[f"{name}_diff_p95"] = float(np.percentile(d, 95))
        return out

    # Seed 0 at every period, each simulated once (the default period is usually one of
    # them, and the seeds' comparison reuses its run).
    runs = {period: run(period, 0) for period in dict.fromkeys(periods)}
    ref = runs[periods[0]]
    ref_power = band_power(ref)
    rows = []
    for period in periods[1:]:
        sig = runs[period]
        ratio = band_power(sig) / ref_power
        for v, idx in at.items():
            rows.append(
                {
                    "surface_update_s": period,
                    "speed_mm_s": v,
                    "band_power_ratio_median": float(np.median(ratio[idx])),
                    "band_power_ratio_max": float(ratio[idx].max()),
                    **differences(sig[idx], ref[idx]),
                }
            )
    own = config.motion.surface_update_s
    same = runs[own] if own in runs else run(own, 0)
    other = run(own, 1)
    seeds = {v: differences(other[idx], same[idx]) for v, idx in at.items()}
    return {"reference_s": periods[0], "rows": rows, "seeds": seeds, "trials": len(specs)}


def cmd_update(_args: argparse.Namespace) -> int:
    config = synth.SynthConfig()
    res = update_convergence(config)
    ref_ms = res["reference_s"] * 1e3
    own_ms = config.motion.surface_update_s * 1e3
    print(f"surface update vs {ref_ms:g} ms, {res['trials']} trials (every shape x material):")
    print(
        f"| update | speed | films' power > {UPDATE_BAND_HZ:g} Hz / {ref_ms:g} ms run "
        "(median, max) | films' RMS difference (median, 95th pct) | gauges' (median, 95th pct) "
        f"| seed 0 vs 1 at {own_ms:g} ms: films, gauges (medians) |"
    )
    print("|---|---|---|---|---|---|")
    for r in res["rows"]:
        sd = res["seeds"][r["speed_mm_s"]]
        print(
            f"| {r['surface_update_s'] * 1e3:g} ms | {r['speed_mm_s']:g} mm/s "
            f"| {r['band_power_ratio_median']:.3f}, {r['band_power_ratio_max']:.2f} "
            f"| {r['pvdf_diff_median']:.2%}, {r['pvdf_diff_p95']:.1%} "
            f"| {r['sg_diff_median']:.2%}, {r['sg_diff_p95']:.1%} "
            f"| {sd['pvdf_diff_median']:.1%}, {sd['sg_diff_median']:.1%} |"
        )
    return 0


def _evaluate(config: synth.SynthConfig, trials_per_class: int, where: Path, seed: int = 0) -> dict:
    from benchmark.diagnose import diagnose
    from synth.presets import preset

    grid = preset("paper").replace(
        trials_per_class=trials_per_class, synth=config.to_dict(), seed=seed
    )
    synth.generate(grid, where, overwrite=True, progress=False)
    data = synth.load_dataset(where)
    diag = diagnose(data).to_dict()
    acc = diag["accuracy"]
    per_shape = diag["per_shape"]["sg"]
    return {
        "sg_shape": acc["shape"]["sg"],
        "sg_worst_shape": min(v for v in per_shape.values() if v is not None),
        "class_all": acc["class"]["all"],
        "material_all": acc["material"]["all"],
        "material_sg": acc["material"]["sg"],
        "material_pvdf": acc["material"]["pvdf"],
        **_selection_shares(data),
    }


#: The feature counts the paper's selections chose (medians): about 6 for cross-shape and
#: 12 for cross-material. Its PVDF shares (21 % and 50 %) are of those many features.
PAPER_D = {"cross_shape": 6, "cross_material": 12}


def _training_fits(data: synth.Dataset, features: np.ndarray):
    """``(protocol, split, fitted AFOP-ML)`` for every cross-shape fold and cross-material
    split of ``data``, each fitted (seed 0) on its training split alone."""
    from benchmark.splits import cross_material_splits, cross_shape_splits
    from models.afop import AFOPML

    for protocol, splits in (
        ("cross_shape", cross_shape_splits(data)),
        ("cross_material", cross_material_splits(data)),
    ):
        for split in splits:
            fitted = AFOPML(seed=0).fit(
                data.signals[split.train], data.label[split.train], features=features[split.train]
            )
            yield protocol, split, fitted


def _selection_shares(data: synth.Dataset) -> dict:
    """Mean PVDF share of AFOP-ML's top-D features over the cross-shape folds and over the
    cross-material splits, each fitted on its training split only; the median D each
    protocol's splits chose (the paper reports both: D about 6 and 12); and the mean PVDF
    share of the first :data:`PAPER_D` features of each split's NCA ranking, the share
    the paper's selection sizes would give (``pvdf_share_paper_d_*``)."""
    from benchmark.interpret import sensor_shares
    from models.features import FEATURE_NAMES, extract

    features = extract(data.signals)
    out = {}
    fits: dict[str, list] = {"cross_shape": [], "cross_material": []}
    for protocol, _split, fitted in _training_fits(data, features):
        fits[protocol].append(fitted)
    for protocol, fitted_splits in fits.items():
        shares, sizes, at_paper_d = [], [], []
        for fitted in fitted_splits:
            shares.append(sensor_shares(fitted.selected_, FEATURE_NAMES)[0])
            sizes.append(len(fitted.selected_))
            top = fitted.ncfs_.ranking_[: PAPER_D[protocol]]
            at_paper_d.append(sensor_shares(top, FEATURE_NAMES)[0])
        out[f"pvdf_share_{protocol}"] = float(np.mean(shares))
        out[f"d_{protocol}"] = float(np.median(sizes))
        out[f"pvdf_share_paper_d_{protocol}"] = float(np.mean(at_paper_d))
    return out


def variance_shares(
    features: np.ndarray, shape: np.ndarray, material: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``(shape share, material share)`` of each feature's variance over the trials given,
    ``(n, f)`` features: the share between the shapes' means, and the share between the
    materials' means inside each shape (the shape-and-material classes' means around their
    shape's mean). The rest lies within the classes. A feature with no variance has 0 for
    both."""
    x = np.asarray(features, dtype=float)
    shape, material = np.asarray(shape), np.asarray(material)
    centred = x - x.mean(axis=0)
    total = np.square(centred).sum(axis=0)

    def between(groups: np.ndarray) -> np.ndarray:
        _, index = np.unique(groups, axis=0, return_inverse=True)
        index = index.ravel()
        counts = np.bincount(index)
        sums = np.zeros((counts.size, x.shape[1]))
        np.add.at(sums, index, centred)
        return (np.square(sums) / counts[:, None]).sum(axis=0)

    by_shape = between(shape)
    by_class = between(np.stack([shape, material], axis=1))
    with np.errstate(invalid="ignore", divide="ignore"):
        shape_share = np.where(total > 0, by_shape / total, 0.0)
        material_share = np.where(total > 0, (by_class - by_shape) / total, 0.0)
    return shape_share, np.maximum(material_share, 0.0)


#: Cuts of the NCA ranking at which ``picks`` gives the PVDF share of the features
#: before it, so that two protocols' shares can be compared at the same feature count.
PICKS_CUTS = (6, 12, 24, 48)


def selection_picks(data: synth.Dataset, top: int) -> list[dict]:
    """Per cross-shape fold and cross-material split of ``data`` (AFOP-ML fitted on the
    training split alone, as :func:`_selection_shares` fits it): the first ``top`` features
    of the NCA ranking, each with its sensor, whether the D-scan selected it, and its
    :func:`variance_shares` on that training split; and, of the selected features of each
    sensor, how many carry more of their variance between materials than between shapes
    (``material_led``); and the PVDF share of the first k ranked features for each k of
    :data:`PICKS_CUTS` (``pvdf_share_first``)."""
    from benchmark.interpret import sensor_shares
    from models.features import FEATURE_NAMES, extract, sensor_of

    features = extract(data.signals)
    shape, material = np.asarray(data.shape), np.asarray(data.material)
    sensors = [sensor_of(name).lower() for name in FEATURE_NAMES]
    out = []
    for protocol, split, fitted in _training_fits(data, features):
        train = split.train
        by_shape, by_material = variance_shares(features[train], shape[train], material[train])
        selected = {int(i) for i in fitted.selected_}
        ranked = [int(i) for i in fitted.ncfs_.ranking_]
        rows = [
            {
                "rank": r + 1,
                "feature": FEATURE_NAMES[i],
                "sensor": sensors[i],
                "selected": i in selected,
                "shape_share": float(by_shape[i]),
                "material_share": float(by_material[i]),
            }
            for r, i in enumerate(ranked[:top])
        ]
        counts = {}
        for sensor in ("pvdf", "sg"):
            mine = [i for i in selected if sensors[i] == sensor]
            led = sum(by_material[i] > by_shape[i] for i in mine)
            counts[sensor] = {"selected": len(mine), "material_led": int(led)}
        out.append(
            {
                "protocol": protocol,
                "fold": str(split.fold),
                "d": len(selected),
                "top": rows,
                **counts,
                "pvdf_share_first": {
                    k: sensor_shares(ranked[:k], FEATURE_NAMES)[0]
                    for k in PICKS_CUTS
                    if k <= len(ranked)
                },
            }
        )
    return out


def cmd_picks(args: argparse.Namespace) -> int:
    try:
        data = synth.load_dataset(args.data)
    except (OSError, ValueError) as exc:
        raise SystemExit(f"DATA ({args.data}): {exc}") from None
    if len(np.unique(np.asarray(data.material))) < 2 or len(np.unique(np.asarray(data.shape))) < 3:
        raise SystemExit(
            f"DATA ({args.data}): the generalisation splits need at least 3 shapes and 2 materials"
        )
    for fit in selection_picks(data, args.top):
        print(
            f"{fit['protocol']} {fit['fold']}: D {fit['d']}; selected PVDF features "
            f"{fit['pvdf']['selected']} ({fit['pvdf']['material_led']} material-led), SG "
            f"{fit['sg']['selected']} ({fit['sg']['material_led']} material-led)"
        )
        print(
            "  PVDF share of the first k ranked: "
            + ", ".join(f"k={k} {v:.2f}" for k, v in fit["pvdf_share_first"].items())
        )
        print("  rank  feature                                 sel  shape  material")
        for row in fit["top"]:
            print(
                f"  {row['rank']:4d}  {row['feature']:38s}  {'*' if row['selected'] else ' '}"
                f"    {row['shape_share']:.2f}   {row['material_share']:.2f}"
            )
    return 0


#: The metrics whose spread over dataset seeds the sweep reports beside their mean.
SPREAD_KEYS = (
    "pvdf_share_cross_shape",
    "pvdf_share_cross_material",
    "pvdf_share_gap",
    "pvdf_share_paper_d_gap",
)


def _measured(
    config: synth.SynthConfig,
    trials_per_class: int,
    seeds: int,
    where: Path,
    keep: Path | None = None,
) -> dict:
    """:func:`_evaluate` of ``config`` on dataset seeds 0..``seeds``-1, summarised by
    :func:`_over_seeds`; with ``keep``, the dataset of seed 0 is moved there."""
    per_seed = []
    for seed in range(seeds):
        per_seed.append(_evaluate(config, trials_per_class, where, seed))
        if keep is not None and seed == 0:
            shutil.move(str(where), str(keep))
    return _over_seeds(per_seed)


def _over_seeds(per_seed: list[dict]) -> dict:
    """One candidate's metrics over its dataset seeds: every metric's mean, the share gaps
    (cross-shape minus cross-material PVDF share, of the selected features and of the
    first :data:`PAPER_D` ranked ones), and for the :data:`SPREAD_KEYS` their standard
    deviation over the seeds (``*_sd``, 0 for one seed)."""
    rows = [
        {
            **r,
            "pvdf_share_gap": r["pvdf_share_cross_shape"] - r["pvdf_share_cross_material"],
            "pvdf_share_paper_d_gap": r["pvdf_share_paper_d_cross_shape"]
            - r["pvdf_share_paper_d_cross_material"],
        }
        for r in per_seed
    ]
    out = {k: float(np.mean([r[k] for r in rows])) for k in rows[0]}
    for k in SPREAD_KEYS:
        out[f"{k}_sd"] = float(np.std([r[k] for r in rows], ddof=1)) if len(rows) > 1 else 0.0
    return out


def _fmt(key: str, value: float) -> str:
    """A metric as the table shows it: feature counts to 1 decimal (a mean over seeds of
    medians; whole numbers without it), accuracies and shares to 3 decimals."""
    if key.startswith("d_"):
        return f"{value:.1f}".removesuffix(".0")
    return f"{value:.3f}"


def _parse_base(items: list[str] | None) -> dict[tuple[str, str], float]:
    """``--base SECTION.FIELD=VALUE`` items as ``{(section, field): value}``, each naming a
    swept parameter once and a value inside the range its candidates span (its cited
    range)."""
    ranges = {f"{s}.{f}": (s, f, min(c), max(c)) for s, f, c, _ in SWEEP}
    out: dict[tuple[str, str], float] = {}
    for item in items or ():
        name, sep, text = item.partition("=")
        if not sep or name not in ranges:
            raise SystemExit(
                f"--base must be SECTION.FIELD=VALUE with a swept parameter "
                f"({', '.join(sorted(ranges))}); got {item!r}"
            )
        try:
            value = parse_number(text)
        except ValueError:
            raise SystemExit(f"--base {name} needs a number; got {text!r}") from None
        section, field, lo, hi = ranges[name]
        if (section, field) in out:
            raise SystemExit(f"--base sets {name} twice")
        if not lo <= value <= hi:
            raise SystemExit(
                f"--base {name} must lie in its cited range {lo:g}..{hi:g}; got {value:g}"
            )
        out[section, field] = value
    return out


def cmd_sweep(args: argparse.Namespace) -> int:
    base = _configured(args.set)
    known = {f"{section}.{field}" for section, field, _, _ in SWEEP}
    for name in args.only or ():
        if name not in known:
            raise SystemExit(f"--only must name a swept parameter ({', '.join(sorted(known))})")
    held = _parse_base(args.base)
    for (section, field), value in held.items():
        base = _with(base, section, field, value)
    out = Path(args.out) if args.out else None
    if out is not None:
        try:
            check_out_dir(out)
        except OSError as exc:
            raise SystemExit(str(exc)) from None
    reuse = _previous_measurements(out, args) if args.resume else {}
    rows = []
    done: dict[str, dict] = {}  # the default configuration recurs in every parameter's sweep
    with tempfile.TemporaryDirectory() as tmp:
        where = Path(tmp) / "grid"
        try:
            for section, field, candidates, why in SWEEP:
                if args.only and f"{section}.{field}" not in args.only:
                    continue
                if (section, field) in held:
                    continue  # held at its --base value
                default = _default(base, section, field)
                for value in candidates:
                    t0 = time.perf_counter()
                    config = _with(base, section, field, value)
                    key = _config_key(config)
                    if key not in done:
                        done[key] = reuse.get(key) or _measured(
                            config, args.trials_per_class, args.seeds, where
                        )
                    metrics = done[key]
                    row = {
                        "parameter": f"{section}.{field}",
                        "value": value,
                        "default": bool(np.isclose(value, default)),
                        "why": why,
                        **metrics,
                        "trials_per_class": args.trials_per_class,
                        "seeds": args.seeds,
                        "config_sha256": key,
                    }
                    rows.append(row)
                    print(
                        f"{row['parameter']} = {value:g}{' (default)' if row['default'] else ''}: "
                        + ", ".join(f"{k} {_fmt(k, metrics[k])}" for k in metrics)
                        + f"  [{time.perf_counter() - t0:.0f} s"
                        + (", kept from the earlier sweep]" if key in reuse else "]"),
                        flush=True,
                    )
                    if out is not None:  # after every candidate: an interruption keeps them
                        _write_tables(out, rows, list(metrics), args.seeds)
        except KeyboardInterrupt:
            kept = f"; {len(rows)} rows are in {out / 'calibration.json'}" if out else ""
            again = " (add --resume to continue)" if out else ""
            raise SystemExit(f"sweep interrupted{kept}{again}") from None
    if out is not None:
        print(f"wrote {out / 'calibration.md'} and calibration.json")
    return 0


def _config_key(config: synth.SynthConfig) -> str:
    """A measurement's identity: the SHA-256 of the canonical JSON of the configuration,
    the simulator's format version (what it simulates from a configuration) and the
    tuned hyper-parameters AFOP-ML's selection uses, so that ``--resume`` keeps no row
    measured by another simulator or another tuning."""
    from models.tuned import tuned_values
    from synth.store import FORMAT_VERSION

    identity = {"config": config.to_dict(), "format": FORMAT_VERSION, "tuned": tuned_values()}
    return hashlib.sha256(json.dumps(identity, sort_keys=True).encode()).hexdigest()


def _previous_measurements(out: Path | None, args: argparse.Namespace) -> dict[str, dict]:
    """``--resume``: the metrics of the rows in ``out/calibration.json`` that were measured
    with this sweep's trials per class and seeds, by configuration."""
    if out is None:
        raise SystemExit("--resume needs --out DIR (the sweep whose rows it keeps)")
    path = out / "calibration.json"
    if not path.is_file():
        return {}
    try:
        rows = json.loads(path.read_text())
        kept = {
            r["config_sha256"]: {k: r[k] for k in r["metrics"]}
            for r in rows
            if (r["trials_per_class"], r["seeds"]) == (args.trials_per_class, args.seeds)
        }
    except (ValueError, KeyError, TypeError) as exc:
        raise SystemExit(
            f"--resume: {path} is not a sweep table this script wrote ({type(exc).__name__}: "
            f"{exc}); choose another --out or remove it"
        ) from None
    return kept


def _write_tables(out: Path, rows: list[dict], metrics: list[str], seeds: int) -> None:
    """``out/calibration.json`` (every row, with the names of its metrics) and
    ``calibration.md`` (the table), each replaced whole."""
    out.mkdir(parents=True, exist_ok=True)
    table = [{**r, "metrics": metrics} for r in rows]
    keys = [k for k in metrics if not k.endswith("_sd")]
    lines = ["| parameter | value | " + " | ".join(keys) + " |", "|---" * (len(keys) + 2) + "|"]
    for r in rows:
        mark = " (default)" if r["default"] else ""
        vals = " | ".join(
            _fmt(k, r[k]) + (f" ± {r[k + '_sd']:.3f}" if seeds > 1 and k in SPREAD_KEYS else "")
            for k in keys
        )
        lines.append(f"| {r['parameter']} | {r['value']:g}{mark} | {vals} |")
    for name, text in (
        ("calibration.json", json.dumps(table, indent=1) + "\n"),
        ("calibration.md", "\n".join(lines) + "\n"),
    ):
        tmp = out / f".{name}.partial"
        tmp.write_text(text)
        os.replace(tmp, out / name)


#: Configuration sections whose numeric fields ``whatif --set`` may change.
SECTIONS = ("finger", "motion", "variability", "strain_gauge", "pvdf", "acquisition")


def _parse_set(items: list[str] | None) -> dict[tuple[str, str], float]:
    """``--set SECTION.FIELD=VALUE`` items as ``{(section, field): value}``: a numeric
    field of a configuration section (or ``materials.texture_scale`` or
    ``materials.marks_scale``), each set once; none gives an empty table."""
    defaults = synth.SynthConfig()
    out: dict[tuple[str, str], float] = {}
    for item in items or ():
        name, sep, text = item.partition("=")
        section, _, field = name.partition(".")
        known = (section, field) in MATERIAL_FACTORS or (
            section in SECTIONS
            and field in {f.name for f in dataclasses.fields(getattr(defaults, section))}
            and type(getattr(getattr(defaults, section), field)) in (int, float)
        )
        if not sep or not known:
            raise SystemExit(
                "--set must be SECTION.FIELD=VALUE with a numeric field of "
                f"{', '.join(SECTIONS)} (or materials.texture_scale or .marks_scale); "
                f"got {item!r}"
            )
        try:
            value = parse_number(text)
        except ValueError:
            value = math.nan
        if not math.isfinite(value):
            raise SystemExit(f"--set {name} needs a finite number; got {text!r}")
        if (section, field) in out:
            raise SystemExit(f"--set sets {name} twice")
        if (section, field) not in MATERIAL_FACTORS and type(
            getattr(getattr(defaults, section), field)
        ) is int:
            if not value.is_integer():
                raise SystemExit(f"--set {name} needs a whole number; got {text!r}")
            value = int(value)
        out[section, field] = value
    return out


def _closed_set_row(
    config: synth.SynthConfig, episodes: int, where: Path, dataset_seed: int = 0
) -> dict:
    """AFOP-ML's closed-set 1-shot accuracy per N-way (%, over ``episodes`` episodes) on
    the paper preset generated with ``config`` from ``dataset_seed``, and of the same fit,
    as a full run reports them: its D, the PVDF share of its selected features and the
    t-SNE indicators of the test half in them (1-NN shape accuracy, mix-sil, DGI). The
    episodes are drawn with seed 0, as the full run draws them."""
    from benchmark import protocols
    from benchmark.engine import Features
    from benchmark.interpret import analyse, sensor_shares
    from benchmark.results import select
    from models.features import FEATURE_NAMES, extract
    from synth.presets import preset

    recipe = preset("paper").replace(synth=config.to_dict(), seed=dataset_seed)
    synth.generate(recipe, where, overwrite=True)
    data = synth.load_dataset(where)
    pool = extract(data.signals)  # the fit and the t-SNE read the same pool
    records = protocols.run(
        "closed-set", data, methods=["AFOP-ML"], episodes=episodes, seed=0, features=pool
    )
    row = {
        f"closed_set_1shot_{r['way']}way": 100 * r["accuracy"]
        for r in select(records, "accuracy")
        if r["shot"] == 1
    }
    selection = select(records, "selection")[0]
    _, artefacts = analyse(
        data, records, features=Features([(data, pool)]), episodes=episodes, seed=0
    )
    return {
        **row,
        "closed_set_d": selection["D"],
        "closed_set_pvdf_share": sensor_shares(selection["selected"], FEATURE_NAMES)[0],
        **{f"tsne_{k}": v for k, v in artefacts.indicators.items()},
    }


def _fmt_closed_set(key: str, value: float) -> str:
    """A closed-set row's figure: accuracies in % to 2 decimals, D whole (to 1 decimal
    for a mean or spread over datasets), the rest to 3."""
    if key.startswith("closed_set_1shot_"):
        return f"{value:.2f}"
    if key == "closed_set_d":
        return f"{value:d}" if isinstance(value, (int, np.integer)) else f"{value:.1f}"
    return f"{value:.3f}"


def _closed_set_rows(config: synth.SynthConfig, episodes: int, seeds: int, tmp: Path) -> None:
    """Print :func:`_closed_set_row` for dataset seeds 0..``seeds``-1 as each is measured
    and, over two or more, each figure's mean and standard deviation over the seeds (one
    paper-preset dataset is one draw of the trials' scatter: the mean says what the
    configuration gives, the spread how far one dataset strays from it)."""
    rows = []
    for seed in range(seeds):
        row = _closed_set_row(config, episodes, tmp / f"paper-{seed}", dataset_seed=seed)
        rows.append(row)
        figures = ", ".join(f"{k} {_fmt_closed_set(k, v)}" for k, v in row.items())
        print(f"dataset seed {seed}: {figures}" if seeds > 1 else figures, flush=True)
        shutil.rmtree(tmp / f"paper-{seed}", ignore_errors=True)
    if seeds > 1:
        spread = []
        for key in rows[0]:
            values = np.array([r[key] for r in rows], dtype=np.float64)
            mean, sd = float(values.mean()), float(values.std(ddof=1))
            spread.append(f"{key} {_fmt_closed_set(key, mean)} +- {_fmt_closed_set(key, sd)}")
        print(f"mean +- sd over {seeds} dataset seeds: " + ", ".join(spread), flush=True)


def cmd_whatif(args: argparse.Namespace) -> int:
    from synth.sensors import SaturationError, amplifier_noise_v
    from synth.simulator import SaturatedTrialError

    config = _configured(args.set)
    keep = None
    if args.keep is not None:
        keep = Path(args.keep)
        try:
            check_out_dir(keep, "--keep")
        except OSError as exc:
            raise SystemExit(str(exc)) from None
        if keep.exists():
            raise SystemExit(f"--keep {keep} already exists; choose a new directory")
    noise = amplifier_noise_v(config)
    print(
        "what-if configuration: "
        + (", ".join(args.set) if args.set else "the defaults")
        + f" (PVDF amplifier noise {1e3 * noise[0]:.3g} mV RMS at the DAQ)",
        flush=True,
    )
    with tempfile.TemporaryDirectory() as tmp:
        try:
            where = Path(tmp) / "grid"
            metrics = _measured(config, args.trials_per_class, args.seeds, where, keep)
            print(", ".join(f"{k} {_fmt(k, v)}" for k, v in metrics.items()), flush=True)
            if keep is not None:
                print(f"dataset of seed 0 kept in {keep}", flush=True)
            if args.closed_set:
                _closed_set_rows(config, args.closed_set, args.closed_set_seeds, Path(tmp))
        except (SaturationError, SaturatedTrialError) as exc:
            # A setting that raises a channel's signal can drive it beyond the ADC's range;
            # the DAQ cannot record that configuration as set.
            raise SystemExit(f"--set {' '.join(args.set)}: {exc}") from None
    return 0


def _add_set_option(parser: argparse.ArgumentParser, what: str) -> None:
    """The repeatable ``--set SECTION.FIELD=VALUE`` option (read by :func:`_configured`)."""
    parser.add_argument(
        "--set", action="append", metavar="SECTION.FIELD=VALUE", help=f"{what} (repeatable)"
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("skin", help="fit the skin contact to Hertz").set_defaults(func=cmd_skin)
    sub.add_parser(
        "friction", help="the stroke-to-stroke friction scatter from silicone measurements"
    ).set_defaults(func=cmd_friction)
    sub.add_parser(
        "force", help="the stroke-to-stroke force scatter from the arm's repeatability"
    ).set_defaults(func=cmd_force)
    p = sub.add_parser("mount", help="the PDMS support's stiffnesses and the pad's modes")
    _add_set_option(p, "the finger to derive")
    p.set_defaults(func=cmd_mount)
    p = sub.add_parser("gain", help="the PVDF post-amplifier gain")
    _add_set_option(p, "size the gain for this configuration, as whatif sets it")
    p.set_defaults(func=cmd_gain)
    p = sub.add_parser("carrier", help="the films' neutral axis and shear coupling per carrier")
    p.add_argument(
        "--thickness-m",
        action="append",
        type=float_arg,
        metavar="T",
        help="a carrier thickness in metres (repeatable; default the stocks from 23e-6 to 125e-6)",
    )
    p.set_defaults(func=cmd_carrier)
    sub.add_parser(
        "update", help="the surface update period against a 1 ms update (not a calibration)"
    ).set_defaults(func=cmd_update)
    p = sub.add_parser("sweep", help="the global parameters over their cited ranges")
    p.add_argument("--trials-per-class", type=int_arg, default=20)
    p.add_argument(
        "--seeds", type=int_arg, default=1, help="dataset seeds per candidate (0..N-1; default 1)"
    )
    p.add_argument(
        "--only",
        action="append",
        metavar="SECTION.FIELD",
        help="sweep only this parameter (repeatable)",
    )
    p.add_argument(
        "--base",
        action="append",
        metavar="SECTION.FIELD=VALUE",
        help="hold a swept parameter at this value and sweep the others (repeatable)",
    )
    _add_set_option(
        p, "start from the defaults with this numeric field changed, as whatif's --set does"
    )
    p.add_argument(
        "--out", help="write calibration.md and calibration.json here (after every candidate)"
    )
    p.add_argument(
        "--resume",
        action="store_true",
        help="keep the rows of --out's table measured with the same trials and seeds",
    )
    p.set_defaults(func=cmd_sweep)
    p = sub.add_parser(
        "picks", help="what the features AFOP-ML's training-split selections rank first tell apart"
    )
    p.add_argument("data", metavar="DATA", help="a dataset (e.g. data/paper)")
    p.add_argument("--top", type=int_arg, default=12, help="ranked features to list per split")
    p.set_defaults(func=cmd_picks)
    p = sub.add_parser("whatif", help="one configuration, any values (not a calibration)")
    _add_set_option(p, "set a numeric configuration field")
    p.add_argument("--trials-per-class", type=int_arg, default=20)
    p.add_argument("--seeds", type=int_arg, default=1, help="dataset seeds (0..N-1; default 1)")
    p.add_argument(
        "--closed-set",
        type=int_arg,
        default=0,
        metavar="EPISODES",
        help="also AFOP-ML's closed-set 1-shot row over this many episodes (and its t-SNE)",
    )
    p.add_argument(
        "--closed-set-seeds",
        type=int_arg,
        default=1,
        metavar="N",
        help="measure the closed-set row on paper-preset datasets of seeds 0..N-1 (default 1)",
    )
    p.add_argument(
        "--keep",
        metavar="DIR",
        help="keep the dataset of seed 0 in this new directory (for picks, diagnose)",
    )
    p.set_defaults(func=cmd_whatif)
    args = parser.parse_args(argv)
    if getattr(args, "trials_per_class", 2) < 2:
        parser.error("--trials-per-class must be at least 2 (leave-one-out needs a neighbour)")
    if getattr(args, "seeds", 1) < 1:
        parser.error("--seeds must be at least 1")
    if getattr(args, "closed_set", 0) < 0:
        parser.error("--closed-set must be 0 (off) or a number of episodes")
    if getattr(args, "top", 1) < 1:
        parser.error("--top must be at least 1")
    if getattr(args, "closed_set_seeds", 1) < 1:
        parser.error("--closed-set-seeds must be at least 1")
    if getattr(args, "closed_set_seeds", 1) > 1 and not args.closed_set:
        parser.error("--closed-set-seeds needs --closed-set EPISODES (the row it repeats)")
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
