"""Reproduce the simulator's calibration from nothing.

Only global, physically meaningful parameters are calibrated, each within the range its
source gives; nothing is tuned per shape, material or class.

    python3 scripts/calibrate.py skin
        Fit MuJoCo's soft-contact parameters of the skin so that its indentation follows
        Hertz's law for the configured skin modulus; prints Finger.skin_solref/solimp.
    python3 scripts/calibrate.py friction
        The stroke-to-stroke scatter of the friction coefficient
        (Variability.friction_rel) from repeated-sliding measurements of two silicones on
        PLA (synth/calibration/data/silicone_pla_friction.csv): for each silicone, the run whose
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
    python3 scripts/calibrate.py speed [--set SECTION.FIELD=VALUE ...]
        Not a calibration: what the path speed's scatter (Variability.speed_rel, an
        assumption) would be if every point of a timed path repeated as a pose does: the
        arm's repeatability over 3 at the first and last touch of each outline, over the
        distance between them; prints it per outline and the largest.
    python3 scripts/calibrate.py gain [--set SECTION.FIELD=VALUE ...]
        The PVDF post-amplifier gain: the largest round gain (1-2-5 series) that keeps
        the worst edge transient of the perturbation grid (every shape x material at
        1.4 N, 14 mm/s) below 70 % of the DAQ's range; with ``--set``, for the
        configuration whatif would measure.
    python3 scripts/calibrate.py carrier [--thickness-m T ...]
        The films' polyester carrier, which the finger's description does not give: for
        each carrier thickness (default: the standard polyester stocks from 23 um to the
        laminated elements' 125 um; the defaults assume 75 um) the neutral-axis offset
        and shear coupling it gives the films (:func:`synth.sensors.film_on_carrier`),
        the post-gain ``gain`` sizes for them, and the ``whatif --set`` options that
        measure that film.
    python3 scripts/calibrate.py fingerprint [--force-n 1] [--draws 200] [--set ...]
        Not a calibration: how much of each material's periodic marks the fingerprint
        passes on under the load (:func:`synth.calibration.finger.fingerprint_gains`):
        the ridges in the contact adding the mark's phases, the central ridge's average
        over its width with a sharp-edged and with a rounded pressure profile, what the
        whole fingerprint passes as the model takes it, and how the finger's one draw of
        its ridges' irregularity ranks among other draws.
    tactile-synth calibrate --sweep / --whatif
        The sweep of every global parameter over its cited range and the what-if of one
        configuration are ``tactile-synth calibrate``'s (``docs/calibrate.md``), on the
        same parameter registry and measurements as the fit.

    python3 scripts/calibrate.py update
        Not a calibration: the surface update period (Motion.surface_update_s, a numerical
        choice) of 2 and 4 ms against a 1 ms update, on the same trials (every shape x
        material, seed 0, at 2, 6, 10, 14 and 22 mm/s): the films' power above 150 Hz
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

"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

import synth
from benchmark import calibration as measure
from synth.calibration import finger, gain, scatter, settings, update
from synth.calibration.settings import CalibrationError
from tactile_synth.validation import float_arg, int_arg


def cmd_skin(_args: argparse.Namespace) -> int:
    t0 = time.perf_counter()
    got = finger.skin_contact(synth.SynthConfig())
    print(f"fitted in {time.perf_counter() - t0:.0f} s")
    print(f"skin_solref = {got['solref']}")
    print(f"skin_solimp = {got['solimp']}")
    print("force (N)   Hertz (mm)   simulated (mm)")
    for fn, h, g in zip(got["forces_n"], got["hertz_m"], got["simulated_m"], strict=True):
        print(f"{fn:8.2f}   {h * 1e3:10.3f}   {g * 1e3:14.3f}")
    return 0


def cmd_friction(_args: argparse.Namespace) -> int:
    from synth.presets import NOMINAL_FORCE_N

    got = scatter.friction_scatter(synth.SynthConfig())
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


def cmd_force(_args: argparse.Namespace) -> int:
    got = scatter.force_scatter(synth.SynthConfig())
    print(
        f"at {got['force_n']:g} N: skin's Hertz indentation {got['indentation_m'] * 1e3:.3f} mm "
        f"(tangent stiffness {got['skin_stiffness_n_m']:.0f} N/m), PDMS support "
        f"{got['pdms_stiffness_n_m']:.0f} N/m, arm's servo {got['servo_stiffness_n_m']:.0f} N/m: "
        f"{got['series_stiffness_n_m']:.0f} N/m in series"
    )
    repeatability_mm = scatter.ARM_REPEATABILITY_M * 1e3
    print(f"arm's pose repeatability (ISO 9283, mean + 3 sd): {repeatability_mm:g} mm")
    for label, sd, rel in (
        ("repeatability / 3", got["depth_sd_m"], got["value"]),
        ("Gaussian in three axes", got["depth_sd_3d_m"], got["gaussian_3d"]),
        ("Gaussian along the press direction", got["depth_sd_1d_m"], got["gaussian_1d"]),
    ):
        print(f"  {label}: depth sd {sd * 1e3:.4f} mm -> load scatter {100 * rel:.2f} %")
    print(f"Variability.force_rel = {got['value']:.3f} (series stiffness x depth sd / force)")
    return 0


def cmd_speed(args: argparse.Namespace) -> int:
    config = settings.configured(args.set)
    got = scatter.speed_scatter(config)
    sd_mm = got["position_sd_m"] * 1e3
    print(
        f"a path point repeating as a pose: sd {sd_mm:.4f} mm (repeatability / 3); "
        f"speed scatter sqrt(2) x sd / distance between the first and last touch:"
    )
    for shape, rel in got["per_shape"].items():
        print(f"  {shape}: {got['phase_m'][shape] * 1e3:.1f} mm -> {100 * rel:.3f} %")
    print(
        f"largest {100 * got['value']:.3f} %; Variability.speed_rel = "
        f"{config.variability.speed_rel:g} is an assumption (force mode's path tracking is "
        "not published)"
    )
    return 0


def cmd_fingerprint(args: argparse.Namespace) -> int:
    config = settings.configured(args.set)
    got = finger.fingerprint_gains(config, args.force_n, args.draws)
    f = config.finger
    print(
        f"at {args.force_n:g} N: {got['ridges']} ridges in a contact "
        f"{2e3 * got['contact_radius_m']:.2f} mm across, {f.ridge_width_m * 1e3:g} mm wide, "
        f"{f.ridge_spacing_m * 1e3:g} mm apart +-{100 * f.ridge_jitter:g} %"
    )
    print(
        f"{'material':<10} {'mark (um)':>9} {'comb':>6} {'box':>7} {'rounded':>8} "
        f"{'felt':>6}   comb over {args.draws} other draws"
    )
    for m in got["marks"]:
        print(
            f"{m['material']:<10} {m['wavelength_m'] * 1e6:>9.0f} {m['comb']:>6.3f} "
            f"{m['box']:>+7.3f} {m['rounded']:>+8.3f} {m['felt']:>6.3f}   median "
            f"{m['comb_median']:.3f}, 90th percentile {m['comb_p90']:.3f}; this draw above "
            f"{m['percentile']:.0f} %"
        )
    print(
        "comb: the ridges' chord-weighted sum of the mark's phases; box / rounded: the "
        "central ridge's even / elliptical average over its width; felt: what the "
        "fingerprint passes, every ridge through its own width and profile (the model's)"
    )
    return 0


def cmd_mount(args: argparse.Namespace) -> int:
    got = finger.mount_figures(settings.configured(args.set))
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


def cmd_gain(args: argparse.Namespace) -> int:
    config = settings.configured(args.set)
    per_gain, best = gain.sized_gain(config)
    print(f"worst PVDF transient at 1.4 N, 14 mm/s: {per_gain:.2f} V per unit post-gain")
    print(
        f"post_gain = {best:g} (peak {best * per_gain:.1f} V of +-{config.acquisition.range_v} V)"
    )
    return 0


def cmd_carrier(args: argparse.Namespace) -> int:
    base = synth.SynthConfig()
    for thickness in args.thickness_m or gain.CARRIER_THICKNESSES_M:
        offset, shear, post_gain = gain.carrier_film(base, thickness)
        print(
            f"carrier {thickness * 1e6:g} um: neutral_axis_offset_m {offset:.3g}, "
            f"shear_strain_per_n {shear:.3g}, post_gain {post_gain:g}; measure it with "
            f"`tactile-synth calibrate --whatif --set pvdf.neutral_axis_offset_m={offset:.3g} "
            f"--set pvdf.shear_strain_per_n={shear:.3g} --set pvdf.post_gain={post_gain:g}`",
            flush=True,
        )
    return 0


def cmd_update(_args: argparse.Namespace) -> int:
    config = synth.SynthConfig()
    res = update.update_convergence(config)
    ref_ms = res["reference_s"] * 1e3
    own_ms = config.motion.surface_update_s * 1e3
    print(f"surface update vs {ref_ms:g} ms, {res['trials']} trials (every shape x material):")
    print(
        f"| update | speed | films' power > {update.UPDATE_BAND_HZ:g} Hz / {ref_ms:g} ms run "
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


def cmd_picks(args: argparse.Namespace) -> int:
    try:
        data = synth.load_dataset(args.data)
    except (OSError, ValueError) as exc:
        raise SystemExit(f"DATA ({args.data}): {exc}") from None
    if len(np.unique(np.asarray(data.material))) < 2 or len(np.unique(np.asarray(data.shape))) < 3:
        raise SystemExit(
            f"DATA ({args.data}): the generalisation splits need at least 3 shapes and 2 materials"
        )
    for fit in measure.selection_picks(data, args.top):
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


def _add_set_option(parser: argparse.ArgumentParser, what: str) -> None:
    """The repeatable ``--set SECTION.FIELD=VALUE`` option (read by
    :func:`synth.calibration.settings.configured`)."""
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
    p = sub.add_parser(
        "speed", help="the speed scatter a path repeating as the arm's poses would have"
    )
    _add_set_option(p, "the finger and path to measure")
    p.set_defaults(func=cmd_speed)
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
    p = sub.add_parser(
        "fingerprint", help="the periodic marks the fingerprint passes on (not a calibration)"
    )
    p.add_argument("--force-n", type=float_arg, default=1.0, help="the normal load (N)")
    p.add_argument("--draws", type=int_arg, default=200, help="other draws of the ridges")
    _add_set_option(p, "the finger to measure")
    p.set_defaults(func=cmd_fingerprint)
    sub.add_parser(
        "update", help="the surface update period against a 1 ms update (not a calibration)"
    ).set_defaults(func=cmd_update)
    p = sub.add_parser(
        "picks", help="what the features AFOP-ML's training-split selections rank first tell apart"
    )
    p.add_argument("data", metavar="DATA", help="a dataset (e.g. data/paper)")
    p.add_argument("--top", type=int_arg, default=12, help="ranked features to list per split")
    p.set_defaults(func=cmd_picks)
    args = parser.parse_args(argv)
    if getattr(args, "trials_per_class", 2) < 2:
        parser.error("--trials-per-class must be at least 2 (leave-one-out needs a neighbour)")
    if getattr(args, "seeds", 1) < 1:
        parser.error("--seeds must be at least 1")
    if getattr(args, "closed_set", 0) < 0:
        parser.error("--closed-set must be 0 (off) or a number of episodes")
    if getattr(args, "top", 1) < 1:
        parser.error("--top must be at least 1")
    if getattr(args, "draws", 1) < 1:
        parser.error("--draws must be at least 1")
    if getattr(args, "force_n", 1.0) <= 0:
        parser.error("--force-n must be a load above 0 N")
    if getattr(args, "closed_set_seeds", 1) < 1:
        parser.error("--closed-set-seeds must be at least 1")
    if getattr(args, "closed_set_seeds", 1) > 1 and not args.closed_set:
        parser.error("--closed-set-seeds needs --closed-set EPISODES (the row it repeats)")
    try:
        return args.func(args)
    except CalibrationError as exc:
        raise SystemExit(str(exc)) from None
    except synth.SimulationError as exc:
        raise SystemExit(f"calibrate.py {args.command}: {exc}") from None


if __name__ == "__main__":
    sys.exit(main())
