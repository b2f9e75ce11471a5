"""Does ``tactile-synth calibrate`` recover parameters it was not told?

    python3 scripts/bench_calibrate.py [--budget 300] [--truths 20] [--trials-per-class 10]
                                       [--workers 2] [--seed 0] [--twin-truths 5]
                                       [--no-twin-check]
                                       [--out DIR]

Recordings are simulated at hidden values of the calibration's default parameters
(``benchmark.twin.calibrate.DEFAULT_PARAMETERS``), each hidden vector drawn uniformly
(in the search's unit cube) over the middle 70 % of every cited range, for the paper's 36
classes at the nominal condition with ``--trials-per-class`` trials each (a 36 x 10 store).
One calibration's simulations and posterior serve every hidden vector (the posterior is
amortised over recordings of the same classes and conditions), so the script measures
exactly what one ``calibrate`` run does, ``--truths`` times:

- per parameter: how often the hidden value lies inside the reported 90 % interval
  (simulation-based calibration: at least 85 % of the truths for a calibrated posterior),
  the median error of the posterior median in percent of the range (on the search's
  scale: log for a range of ten times or more), how often it is within 10 %, and how
  often the posterior is flat (the recordings do not pin it down);
- the wall time of the one calibration (simulations, training, reading the posterior);
- unless ``--no-twin-check``: AFOP-ML's closed-set 5-way 1-shot accuracy (500 episodes)
  on the recordings of the first ``--twin-truths`` hidden vectors (5 by default), on a
  twin generated from the finger file the calibration writes for each, and on an
  *oracle* twin generated at the hidden values themselves with the twin's seed (what a
  perfect calibration gives): per store whether each twin lies within the recordings'
  95 % CI, and how many do. The oracle's count says how often the check can pass at
  all: two datasets of one configuration and different seeds differ by about as much
  as the CI's half-width.

``--out DIR`` keeps the simulations (``DIR/simulations.npz``) so a rerun with the same
options reuses them.
"""

from __future__ import annotations

import argparse
import concurrent.futures as cf
import multiprocessing
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from script_args import description


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=description(__doc__))
    parser.add_argument("--budget", type=int, default=300)
    parser.add_argument("--truths", type=int, default=20)
    parser.add_argument("--trials-per-class", type=int, default=10)
    parser.add_argument("--sim-trials-per-class", type=int, default=2)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--twin-truths", type=int, default=5)
    parser.add_argument("--no-twin-check", action="store_true")
    parser.add_argument("--out", help="keep the simulations here (reused on a rerun)")
    args = parser.parse_args(argv)
    for name in ("budget", "truths", "trials_per_class", "workers", "twin_truths"):
        if getattr(args, name) < 1:
            parser.error(f"--{name.replace('_', '-')} must be at least 1")
    if args.twin_truths > args.truths:
        parser.error(f"--twin-truths ({args.twin_truths}) must not exceed --truths ({args.truths})")

    import synth
    from benchmark.twin import calibrate as cal
    from benchmark.twin.world import World
    from synth.presets import preset

    parameters = cal.default_parameters()
    grid = preset("paper")
    base = synth.SynthConfig().to_dict()
    base["specimens"] = {}
    world = World(
        tuple(grid.classes), tuple((c, 1.0, 10.0) for c in range(len(grid.classes))), base
    )
    n_x = len(cal.summary_size(world))
    out = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="bench-calibrate-"))
    out.mkdir(parents=True, exist_ok=True)
    sims_path = out / "simulations.npz"
    start = time.perf_counter()
    if sims_path.exists():
        sims = cal.Simulations.load(sims_path)
        if len(sims.done) != args.budget:
            parser.error(
                f"{sims_path} holds {len(sims.done)} simulations, not --budget {args.budget}"
            )
    else:
        unit = cal.draws(args.budget, len(parameters), args.seed)
        sims = cal.Simulations(
            unit,
            np.full((args.budget, n_x), np.nan),
            np.zeros(args.budget, bool),
            np.zeros(args.budget, bool),
        )
    cal.run_simulations(
        world,
        parameters,
        sims,
        trials_per_class=args.sim_trials_per_class,
        seed=args.seed,
        workers=args.workers,
        save=sims_path,
    )
    sim_s = time.perf_counter() - start

    # The hidden vectors and their recordings' summaries (seeds apart from the calibration's).
    rng = np.random.default_rng(args.seed + 12345)
    truths = 0.15 + 0.7 * rng.random((args.truths, len(parameters)))
    values = cal.physical(parameters, truths)
    start_rec = time.perf_counter()
    x_obs = _recordings(world, parameters, values, args)
    rec_s = time.perf_counter() - start_rec

    start = time.perf_counter()
    posterior = cal.train_posterior(sims.unit, sims.x, seed=args.seed)
    train_s = time.perf_counter() - start
    inside = np.zeros((args.truths, len(parameters)), bool)
    error = np.zeros((args.truths, len(parameters)))
    flat = np.zeros((args.truths, len(parameters)), bool)
    medians = []
    for j in range(args.truths):
        s = posterior.sample(x_obs[j], cal.POSTERIOR_SAMPLES, args.seed)
        q05, q50, q95 = np.quantile(s, [0.05, 0.5, 0.95], axis=0)
        inside[j] = (q05 <= truths[j]) & (truths[j] <= q95)
        error[j] = np.abs(q50 - truths[j])
        flat[j] = q95 - q05 > cal.FLAT_SHARE
        medians.append([p.from_unit(u) for p, u in zip(parameters, q50, strict=True)])
    read_s = time.perf_counter() - start

    print(
        f"{args.truths} hidden parameter vectors, recordings of {len(world.classes)} classes x "
        f"{args.trials_per_class} trials; one calibration of {args.budget} simulations x "
        f"{args.sim_trials_per_class} trials per class ({int(sims.failed.sum())} failed in the "
        f"physics), {posterior.n_train} used"
    )
    print()
    print(
        "| parameter | true value in 90 % interval | median error (% of range) | within 10 % "
        "| flat posterior |"
    )
    print("|---|---|---|---|---|")
    for k, p in enumerate(parameters):
        print(
            f"| `{p.name}`{' (log)' if p.log else ''} | {inside[:, k].mean():.0%} | "
            f"{100 * np.median(error[:, k]):.1f} | {(error[:, k] <= 0.1).mean():.0%} | "
            f"{flat[:, k].mean():.0%} |"
        )
    print()
    print(
        f"one calibration: {sim_s + train_s + read_s / args.truths:.0f} s wall "
        f"(simulations {sim_s:.0f} s in {args.workers} workers, training {train_s:.0f} s); "
        f"recordings simulated in {rec_s:.0f} s"
    )
    if not args.no_twin_check:
        _twin_check(parameters, values, medians, args, out)
    return 0


def _recordings(world, parameters, values, args) -> np.ndarray:
    from benchmark.twin.calibrate import _simulate_task

    ctx = multiprocessing.get_context("spawn")
    out = [None] * len(values)
    with cf.ProcessPoolExecutor(max_workers=args.workers, mp_context=ctx) as pool:
        futures = [
            pool.submit(
                _simulate_task,
                world,
                parameters,
                list(v),
                args.trials_per_class,
                args.seed + 1_000_003,
                j,
                1,
            )
            for j, v in enumerate(values)
        ]
        for fut in cf.as_completed(futures):
            j, x = fut.result()
            out[j] = x
    return np.stack(out)


def _closed_set_cell(store: Path, out: Path, args) -> tuple[float, float]:
    """AFOP-ML's closed-set 5-way 1-shot accuracy and 95 % CI half-width on ``store``."""
    from benchmark.single import benchmark_protocol

    records = benchmark_protocol(
        "closed-set",
        data_path=store,
        out=out,
        methods=["AFOP-ML"],
        episodes=500,
        seed=args.seed,
        progress=False,
        overwrite=True,
    )
    cell = next(
        r for r in records if getattr(r, "way", None) == 5 and getattr(r, "shot", None) == 1
    )
    return cell.accuracy, cell.ci95


def _twin_check(parameters, values, medians, args, out: Path) -> None:
    """AFOP-ML 5-way 1-shot on the recordings at each of the first ``--twin-truths``
    hidden vectors, on the twin at its fitted values and on the oracle twin at the hidden
    values (the twin's seed, so that only the parameters differ between the two)."""
    import synth
    from synth.calibration.finger_file import apply_finger, write_finger
    from synth.calibration.settings import with_value
    from synth.presets import preset

    grid = preset("paper").replace(trials_per_class=args.trials_per_class)
    rows = []
    for j in range(args.twin_truths):
        truth, fitted = values[j], medians[j]
        finger = write_finger(
            out / f"finger_{j}.toml",
            {p.name: v for p, v in zip(parameters, fitted, strict=True)},
        )
        rec_cfg = synth.SynthConfig()
        for p, v in zip(parameters, truth, strict=True):
            rec_cfg = with_value(rec_cfg, p.section, p.field, float(v))
        # Truth 0 keeps the seeds of a single check; later truths take their own.
        rec_seed, twin_seed = args.seed + 1 + 10 * j, args.seed + 2 + 10 * j
        row = {}
        for name, cfg, seed in (
            ("recordings", rec_cfg, rec_seed),
            ("twin", apply_finger(synth.SynthConfig(), finger), twin_seed),
            ("oracle", rec_cfg, twin_seed),
        ):
            store = out / f"truth{j}_{name}_store"
            synth.generate(
                grid.replace(synth=cfg.to_dict(), seed=seed),
                store,
                overwrite=True,
                progress=False,
                workers=args.workers,
            )
            row[name] = _closed_set_cell(store, out / f"truth{j}_{name}_closed", args)
        rows.append(row)
        print(f"twin check {j + 1}/{args.twin_truths} done", file=sys.stderr, flush=True)

    print()
    print(
        "AFOP-ML closed-set 5-way 1-shot (500 episodes) on the recordings, on the twin from "
        "their finger file and on the oracle twin at the hidden values (the twin's seed)"
    )
    print()
    print("| hidden vector | recordings | twin | oracle | twin within CI | oracle within CI |")
    print("|---|---|---|---|---|---|")
    within = {"twin": 0, "oracle": 0}
    distance = {"twin": [], "oracle": []}
    for j, row in enumerate(rows):
        acc_r, ci_r = row["recordings"]
        marks = {}
        for name in within:
            distance[name].append(abs(row[name][0] - acc_r))
            ok = distance[name][-1] <= ci_r
            within[name] += ok
            marks[name] = "yes" if ok else "no"
        print(
            f"| {j} | {100 * acc_r:.2f} +- {100 * ci_r:.2f} % | {100 * row['twin'][0]:.2f} % | "
            f"{100 * row['oracle'][0]:.2f} % | {marks['twin']} | {marks['oracle']} |"
        )
    print()
    print(
        f"the twin lies within the recordings' 95 % CI in {within['twin']} of {len(rows)} "
        f"stores, the oracle twin in {within['oracle']} of {len(rows)}; mean distance "
        f"{100 * np.mean(distance['twin']):.2f} pp (twin) and "
        f"{100 * np.mean(distance['oracle']):.2f} pp "
        "(oracle)"
    )


if __name__ == "__main__":
    sys.exit(main())
