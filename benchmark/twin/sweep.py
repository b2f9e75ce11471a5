"""``tactile-synth calibrate --sweep`` and ``--whatif``: not a fit, the tables a person
reads beside one.

- ``--sweep``: each global parameter of the registry
  (:data:`synth.calibration.settings.SWEEP`, the ranges :mod:`synth.calibration.parameters`
  gives ``calibrate``) over its cited candidates, one at a time from the defaults (or
  from ``--base`` values, or a ``--set`` configuration): the paper grid generated,
  the leave-one-out diagnosis and AFOP-ML's feature selection on the generalisation
  protocols' training splits, one row per candidate in ``--out``'s ``calibration.md`` and
  ``.json`` (rewritten after every candidate; ``--resume`` keeps the rows measured with
  the same trials per class, seeds and configuration);
- ``--whatif``: one configuration with any ``--set`` value, inside or outside a cited
  range, measured the same way (with ``--closed-set N``, AFOP-ML's closed-set 1-shot row
  too), to ask what the real finger would have to be for a target to be met.

Both measure each configuration at the films' post-gain the gain rule sizes for it
(:func:`synth.calibration.gain.at_sized_gain`) unless ``--set pvdf.post_gain=G`` holds
one. ``docs/calibrate.md`` describes the options.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

import synth
from benchmark import calibration as measure
from synth.calibration import gain, settings, sweep
from synth.calibration.settings import CalibrationError
from tactile_synth.atomic import check_out_dir


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
