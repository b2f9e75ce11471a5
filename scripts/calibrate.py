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
    python3 scripts/calibrate.py sweep [--trials-per-class 20] [--seeds 1]
                                       [--only SECTION.FIELD] [--base SECTION.FIELD=VALUE]
                                       [--set SECTION.FIELD=VALUE] [--out DIR [--resume]]
        Each global parameter of SWEEP over its cited range, and each material's surface
        figures (``materials.MATERIAL.FIELD``) over their measured ranges or a free
        choice's plausible one, and each gauge's height (``finger.gauge_heights_m.I``)
        (one at a time, the others at their defaults, or at the
        values ``--base`` sets, each within its parameter's cited range, to see how two
        parameters act together; ``--set`` changes any numeric field of the
        configuration the sweep starts from, as whatif's does): generates the paper
        grid, runs the leave-one-out diagnosis and AFOP-ML's feature selection on the
        generalisation protocols' training splits, and prints (and writes DIR/calibration.md
        and .json) what each value changes: strain-gauge shape accuracy
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
        Each candidate is measured at the films' post-gain ``gain`` sizes for it (a lab
        sizes its amplifier for the finger it builds; the table gives it), unless ``--set
        pvdf.post_gain=G`` holds one for all.
        DIR's tables are rewritten after every candidate, so an interrupted sweep keeps
        the rows it measured; ``--resume`` reuses the rows of DIR's table measured with
        the same trials per class, seeds and configuration, and measures the rest; with
        ``--only`` it keeps the table's rows of the other parameters too, when that sweep
        started from the same configuration (so one parameter can be added to a table). A
        candidate that cannot be simulated (MuJoCo diverges, a channel saturates) gets a
        row saying why, naming the trial, and the sweep goes on.

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

    python3 scripts/calibrate.py whatif [--set SECTION.FIELD=VALUE ...]
                                        [--trials-per-class 20] [--seeds 1]
                                        [--closed-set EPISODES [--closed-set-seeds 1]]
                                        [--keep DIR]
        Not a calibration: one configuration with any numeric field set to any value its
        dataclass accepts, inside or outside a cited range (``materials.texture_scale``
        as in the sweep; ``materials.marks_scale`` scales the periodic marks alone;
        ``materials.MATERIAL.kinetic_friction`` gives one material a friction level of
        its own, its static coefficient in the same ratio; ``materials.MATERIAL.FIELD``
        with FIELD ``roughness_rms_m``, ``correlation_length_m`` or ``mark_amplitude_m``
        one material's surface; ``materials.stribeck_velocity_m_s`` every material's
        Stribeck velocity; ``finger.gauge_heights_m.0`` or ``.1`` one gauge's height), to
        measure what the real finger would have to be for a target to be met; without
        ``--set``, the defaults. Prints the sweep's metrics over the seeds and, with
        ``--closed-set N``, AFOP-ML's closed-set 1-shot row over N episodes on a
        paper-preset dataset (seed 0) of that configuration, with the fit's D, PVDF share
        and t-SNE indicators; ``--closed-set-seeds M`` measures that row on the datasets
        of seeds 0..M-1 and adds each figure's mean and standard deviation over them.
        ``--keep DIR`` keeps the measured dataset of seed 0 in DIR, a new directory (for
        ``picks`` or ``tactile-synth diagnose``). The films' post-gain is the one ``gain``
        sizes for the configuration unless ``--set pvdf.post_gain=G`` sets it. The
        defaults never come from it.

The sweep simulates 36 classes x ``--trials-per-class`` trials per candidate and seed
(720 at the default of 20); at 30 trials per class and three seeds a candidate costs
3,240 simulated trials (``docs/speed.md`` gives the simulator's CPU per trial), 72 more
at the grid's corner to size its gain, and AFOP-ML's selection on each dataset. The
default configuration is evaluated once.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import synth
from benchmark import calibration as measure
from synth.calibration import finger, gain, scatter, settings, sweep, update
from synth.calibration.settings import CalibrationError
from tactile_synth.atomic import check_out_dir
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
            f"`python3 scripts/calibrate.py whatif --set pvdf.neutral_axis_offset_m={offset:.3g} "
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


def _measured_or_failed(
    config: synth.SynthConfig, trials_per_class: int, seeds: int, where: Path
) -> dict:
    """A sweep candidate's metrics, or ``{"failed": why}`` when one of its trials cannot be
    simulated (MuJoCo diverges at this value with the configuration's time step, or a
    channel saturates): the sweep reports it and goes on to the next candidate."""
    try:
        return measure.measured(config, trials_per_class, seeds, where)
    except synth.SimulationError as exc:
        return {"failed": str(exc)}


def _at_own_gain(
    config: synth.SynthConfig, sized: dict, hold_gain: bool
) -> tuple[synth.SynthConfig | str, str]:
    """The candidate at the post-gain ``gain``'s rule sizes for it (as it is, with
    ``hold_gain``), or why none could be sized (its trials at the grid's corner diverge,
    or no round gain fits the DAQ); and the key its measurement is kept under (the
    candidate's as measured, or as given when it cannot be). ``sized`` keeps each
    configuration's answer: the base recurs in every parameter's sweep."""
    if hold_gain:
        return config, measure.config_key(config)
    key = measure.config_key(config)
    if key not in sized:
        try:
            sized[key] = gain.at_sized_gain(config)
        except (CalibrationError, synth.SimulationError) as exc:
            sized[key] = f"no post-gain could be sized for it: {exc}"
    own = sized[key]
    return own, key if isinstance(own, str) else measure.config_key(own)


def cmd_sweep(args: argparse.Namespace) -> int:
    base = settings.configured(args.set)
    hold_gain = settings.holds_gain(args.set)
    settings.check_swept(args.only)
    held = settings.parse_base(args.base)
    for (section, field), value in held.items():
        base = settings.with_value(base, section, field, value)
    out = Path(args.out) if args.out else None
    if out is not None:
        try:
            check_out_dir(out)
        except OSError as exc:
            raise SystemExit(str(exc)) from None
    earlier = sweep.earlier_rows(out, args.trials_per_class, args.seeds) if args.resume else []
    reuse = sweep.previous_measurements(earlier)
    rows = []
    kept: list[dict] = []  # the earlier table's rows of parameters this run does not sweep
    names: list[str] = []  # the metrics' names, from the first candidate measured
    done: dict[str, dict] = {}  # the default configuration recurs in every parameter's sweep
    sized: dict[str, synth.SynthConfig | str] = {}
    with tempfile.TemporaryDirectory() as tmp:
        where = Path(tmp) / "grid"
        if earlier:
            _, base_key = _at_own_gain(base, sized, hold_gain)
            kept = sweep.kept_rows(earlier, base_key, sweep.swept_parameters(args.only, held))
        try:
            for section, field, value, why, is_default, config in sweep.candidates(
                base, args.only, held
            ):
                t0 = time.perf_counter()
                own, key = _at_own_gain(config, sized, hold_gain)
                if isinstance(own, str):  # no gain could be sized: the row says why
                    post_gain = None
                    done[key] = {"failed": own}
                else:
                    config, post_gain = own, own.pvdf.post_gain
                if key not in done:
                    done[key] = reuse.get(key) or _measured_or_failed(
                        config, args.trials_per_class, args.seeds, where
                    )
                failed = done[key].get("failed")
                metrics = {} if failed else done[key]
                names = names or list(metrics)
                row = sweep.sweep_row(
                    f"{section}.{field}",
                    value,
                    why,
                    is_default,
                    metrics,
                    args.trials_per_class,
                    args.seeds,
                    key,
                    failed,
                    post_gain=post_gain,
                )
                rows.append(row)
                print(
                    f"{row['parameter']} = {value:g}{' (default)' if row['default'] else ''}"
                    + (f" (post-gain {post_gain:g}): " if post_gain else ": ")
                    + (
                        f"not measured: {failed}"
                        if failed
                        else ", ".join(f"{k} {sweep.format_metric(k, metrics[k])}" for k in metrics)
                    )
                    + f"  [{time.perf_counter() - t0:.0f} s"
                    + (", kept from the earlier sweep]" if key in reuse else "]"),
                    flush=True,
                )
                if out is not None:  # after every candidate: an interruption keeps them
                    sweep.write_tables(
                        out,
                        sweep.in_sweep_order(kept + rows),
                        names or next((r["metrics"] for r in kept if r["metrics"]), []),
                        args.seeds,
                    )
        except KeyboardInterrupt:
            n_rows = len(kept) + len(rows)
            where_kept = f"; {n_rows} rows are in {out / 'calibration.json'}" if out else ""
            again = " (add --resume to continue)" if out else ""
            raise SystemExit(f"sweep interrupted{where_kept}{again}") from None
    if out is not None:
        print(f"wrote {out / 'calibration.md'} and calibration.json")
    return 0


def _fmt_closed_set(key: str, value: float) -> str:
    """A closed-set row's figure: accuracies in % to 2 decimals, D whole (to 1 decimal
    for a mean or spread over datasets), the rest to 3."""
    if key.startswith("closed_set_1shot_"):
        return f"{value:.2f}"
    if key == "closed_set_d":
        return f"{value:d}" if isinstance(value, (int, np.integer)) else f"{value:.1f}"
    return f"{value:.3f}"


def _closed_set_rows(config: synth.SynthConfig, episodes: int, seeds: int, tmp: Path) -> None:
    """Print :func:`benchmark.calibration.closed_set_row` for dataset seeds
    0..``seeds``-1 as each is measured and, over two or more, each figure's mean and
    standard deviation over the seeds (:func:`benchmark.calibration.closed_set_spread`)."""
    rows = []
    for seed in range(seeds):
        row = measure.closed_set_row(config, episodes, tmp / f"paper-{seed}", dataset_seed=seed)
        rows.append(row)
        figures = ", ".join(f"{k} {_fmt_closed_set(k, v)}" for k, v in row.items())
        print(f"dataset seed {seed}: {figures}" if seeds > 1 else figures, flush=True)
        shutil.rmtree(tmp / f"paper-{seed}", ignore_errors=True)
    if seeds > 1:
        spread = [
            f"{key} {_fmt_closed_set(key, mean)} +- {_fmt_closed_set(key, sd)}"
            for key, (mean, sd) in measure.closed_set_spread(rows).items()
        ]
        print(f"mean +- sd over {seeds} dataset seeds: " + ", ".join(spread), flush=True)


def cmd_whatif(args: argparse.Namespace) -> int:
    from synth.sensors import SaturationError, amplifier_noise_v
    from synth.simulator import SaturatedTrialError

    keep = None
    if args.keep is not None:
        keep = Path(args.keep)
        try:
            check_out_dir(keep, "--keep")
        except OSError as exc:
            raise SystemExit(str(exc)) from None
        if keep.exists():
            raise SystemExit(f"--keep {keep} already exists; choose a new directory")
    config = gain.configured_at_own_gain(args.set)  # after the checks: sizing simulates
    noise = amplifier_noise_v(config)
    print(
        "what-if configuration: "
        + (", ".join(args.set) if args.set else "the defaults")
        + f" (PVDF post-gain {config.pvdf.post_gain:g}"
        + (", as set" if settings.holds_gain(args.set) else ", sized by the gain rule")
        + f"; amplifier noise {1e3 * noise[0]:.3g} mV RMS at the DAQ)",
        flush=True,
    )
    with tempfile.TemporaryDirectory() as tmp:
        try:
            where = Path(tmp) / "grid"
            metrics = measure.measured(config, args.trials_per_class, args.seeds, where, keep)
            print(
                ", ".join(f"{k} {sweep.format_metric(k, v)}" for k, v in metrics.items()),
                flush=True,
            )
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
