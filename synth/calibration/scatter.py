"""The stroke-to-stroke scatter of the friction coefficient
(``Variability.friction_rel``), from repeated-sliding measurements of two silicones on
PLA, and of the normal force (``Variability.force_rel``), from the arm's pose
repeatability against the stiffness the press compresses."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from ..config import SynthConfig
from .settings import CalibrationError

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


def skin_contact_pressure_pa(config: SynthConfig, force_n: float) -> float:
    """Mean Hertz pressure of the skin's contact under ``force_n``: the force over the
    contact area ``pi a^2`` (:func:`synth.texture.contact_radius_m`)."""
    from ..texture import contact_radius_m

    return force_n / (math.pi * float(contact_radius_m(config.finger, force_n)) ** 2)


def friction_scatter(config: SynthConfig, path: Path = FRICTION_DATA) -> dict:
    """The friction scatter the measurements give for ``config``'s skin at the nominal
    force: per silicone, the coefficient of variation (``ddof=1``) of the run nearest the
    skin's contact pressure; ``value`` is their mean."""
    from ..presets import NOMINAL_FORCE_N

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


#: Pose repeatability of the UR5 (its data sheet: +-0.1 mm), stated as ISO 9283 states it:
#: the mean distance of the reached poses from their mean plus 3 standard deviations.
ARM_REPEATABILITY_M = 0.1e-3
#: Mean plus 3 standard deviations of the distance from the centre of a Gaussian scatter
#: of standard deviation 1 in each of three axes (a chi distribution of 3 degrees: mean
#: 2 sqrt(2 / pi), variance 3 - 8 / pi) ...
CHI3_MEAN_PLUS_3SD = 2 * math.sqrt(2 / math.pi) + 3 * math.sqrt(3 - 8 / math.pi)
#: ... and along one axis only (a folded normal: mean sqrt(2 / pi), variance 1 - 2 / pi).
CHI1_MEAN_PLUS_3SD = math.sqrt(2 / math.pi) + 3 * math.sqrt(1 - 2 / math.pi)


def force_scatter(config: SynthConfig) -> dict:
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
    from .. import contact
    from ..closed_loop import series_stiffness_n_m, skin_stiffness_n_m
    from ..presets import NOMINAL_FORCE_N

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


def speed_scatter(config: SynthConfig) -> dict:
    """How much a timed path that repeats as the arm's poses do would scatter the path
    speed from stroke to stroke, per built-in outline of ``config``'s paper grid: the
    time between a stroke's first and last touch of the outline is the distance between
    them, ``L`` (at the nominal force, on the configured path), over the speed, and
    each end lies where that stroke's path puts it at that time, a pose's repeatability
    ``s`` (the arm's over 3, as :func:`force_scatter` reads it) from the mean; the two
    ends' errors, independent at worst, change the mean speed between them by
    ``sqrt(2) s / L`` (relative). A bound under the assumption that every point of the
    path repeats as a pose does: how closely UR force mode tracks its path along the
    slide is not published, and ``Variability.speed_rel`` stays an assumption."""
    from .. import planning
    from ..presets import NOMINAL_FORCE_N, PRESETS

    reach = planning.touch_distance_m(config, NOMINAL_FORCE_N)
    sd = ARM_REPEATABILITY_M / 3
    phase = {}
    for shape in PRESETS["paper"].shapes:
        try:
            d_in, d_out = planning.contact_phase_m(
                config.specimen(shape), config.motion.path_y_m, 0.0, reach
            )
        except ValueError as exc:  # the path misses an outline
            raise CalibrationError(f"motion.path_y_m: {exc}") from None
        phase[shape] = d_out - d_in
    per_shape = {shape: math.sqrt(2) * sd / length for shape, length in phase.items()}
    return {
        "position_sd_m": sd,
        "phase_m": phase,
        "per_shape": per_shape,
        "value": max(per_shape.values()),
    }
