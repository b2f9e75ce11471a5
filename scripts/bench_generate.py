"""Benchmark dataset generation: a preset end to end vs the raw ``mujoco.rollout`` rate.

    python scripts/bench_generate.py                      # paper preset, default workers
    python scripts/bench_generate.py --preset quick --modes inline pool
    python scripts/bench_generate.py --keep data      # also keep data/paper-inline
    python scripts/bench_generate.py --modes inline pool --repeat 3
    python scripts/bench_generate.py --friction-models shared derived --repeat 2
    python scripts/bench_generate.py --friction-models shared derived+viscoelastic --repeat 2

For each execution mode it generates the preset into a temporary store and reports wall
time, CPU time (this process + its worker processes), trials/s and the peak RSS of the
main process and of the largest worker. It times the simulator's raw rollout of the same
scenes (``synth.simulator.raw_rollout``: physics only, no sensor chain, no storage) on the
same cores (MuJoCo's C++ rollout without its profiling timers, as the simulator runs
it) before the first round and after every round, and compares each generation
with the mean of the raw runs on either side of its round (``--repeat N`` rounds: the
medians are reported). The machine may be shared: its speed drifts over minutes.
``--friction-models shared derived`` generates the preset under each friction model
(``generate --friction-model``, ``docs/friction.md``) in every mode and round, in turn;
``MODEL+viscoelastic`` generates it under that friction model with the viscoelastic skin
(``generate --skin-response viscoelastic``).
"""

from __future__ import annotations

import argparse
import ctypes
import json
import os
import resource
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from synth import generate, load_dataset
from synth.presets import plan, preset
from tactile_synth.validation import int_arg

#: The contact models ``--friction-models`` compares: a friction model, alone or with the
#: viscoelastic skin's answer to the texture.
CONTACT_MODELS = ("shared", "derived", "shared+viscoelastic", "derived+viscoelastic")

MODES = {
    # name: (workers, threads per task)
    "inline": (1, None),  # this process: two chunk tasks on threads, rollouts on all cores
    "pool": (os.cpu_count() or 2, 1),  # one process per core, one rollout thread each
}


def _cpu_s() -> float:
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def _reset_peak_rss() -> bool:
    """Hand the memory the raw rollout freed back to the OS (glibc's ``malloc_trim``: the
    package keeps freed memory for reuse) and reset this process's peak resident size
    (Linux), so that the generation's peak is its own; False where unsupported."""
    try:
        # By its soname: ctypes.util.find_library runs a subprocess, which would start with
        # this process's resident size as its peak and count as the largest worker.
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):  # not glibc
        pass
    try:
        with open("/proc/self/clear_refs", "w", encoding="ascii") as fh:
            fh.write("5")
    except OSError:
        return False
    return True


def bench_generate(
    name: str,
    mode: str,
    keep: Path | None = None,
    friction_model: str = "shared",
    keep_suffix: str = "",
) -> dict:
    from synth.dataset_cli import with_friction_model, with_skin_response

    workers, threads = MODES[mode]
    friction, _, response = friction_model.partition("+")
    config = with_friction_model(preset(name), friction)
    if response:
        config = with_skin_response(config, response)
    with tempfile.TemporaryDirectory(prefix="bench-gen-") as tmp:
        out = Path(tmp) / f"{name}.zarr"
        if keep is not None:
            out = keep / f"{name}-{mode}{keep_suffix}"
            if out.exists():
                raise SystemExit(f"--keep: {out} exists; remove it or choose another directory")
        cpu0, t0 = _cpu_s(), time.perf_counter()
        generate(config, out, workers=workers, threads=threads, progress=sys.stderr.isatty())
        wall, cpu = time.perf_counter() - t0, _cpu_s() - cpu0
        # High-water marks before anything loads the dataset: the generation itself.
        rss_main = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        rss_worker = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
        data = load_dataset(out)
        size_mb = sum(p.stat().st_size for p in out.rglob("*") if p.is_file()) / 1e6
        raw_mb = data.signals.nbytes / 1e6
        assert np.isfinite(data.signals).all()
    return {
        "mode": mode,
        "friction_model": friction_model,
        "trials": len(data),
        "wall_s": wall,
        "cpu_s": cpu,
        "trials_per_s": len(data) / wall,
        "store_mb": size_mb,
        "raw_mb": raw_mb,
        "peak_rss_mb_main": rss_main,
        "peak_rss_mb_largest_worker": rss_worker,
    }


def bench_raw(name: str, n_trials: int | None) -> dict:
    """Physics-only rollout rate of the same scenes on all cores: wall and CPU seconds
    inside the rollout calls (the trials' planning and set-up around them not counted)."""
    from synth.simulator import raw_rollout_times

    specs = plan(preset(name)).specs(0, n_trials or 10**9)
    wall, cpu = raw_rollout_times(specs, threads=os.cpu_count())
    return {"trials": len(specs), "wall_s": wall, "cpu_s": cpu, "trials_per_s": len(specs) / wall}


def _label(run: dict, args: argparse.Namespace) -> str:
    """A run's mode, and its friction model when several are compared."""
    if len(args.friction_models) == 1:
        return run["mode"]
    return f"{run['mode']}, {run['friction_model']} friction"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="paper")
    parser.add_argument("--modes", nargs="+", default=["inline"], choices=tuple(MODES))
    parser.add_argument(
        "--raw-trials", type=int_arg, default=None, help="trials for the raw rate (default: all)"
    )
    parser.add_argument(
        "--repeat",
        type=int_arg,
        default=1,
        metavar="N",
        help="rounds of (generation in every mode, raw rollout); ratios are medians (default 1)",
    )
    parser.add_argument(
        "--friction-models",
        nargs="+",
        default=["shared"],
        choices=CONTACT_MODELS,
        help="generate under each friction model (MODEL+viscoelastic: with the viscoelastic "
        "skin) in turn (default: shared)",
    )
    parser.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    parser.add_argument(
        "--keep",
        metavar="DIR",
        type=Path,
        help="keep each generated store as DIR/<preset>-<mode> (-<friction model> with "
        "several; default: a deleted temp dir)",
    )
    args = parser.parse_args(argv)
    if args.repeat < 1:
        parser.error(f"--repeat must be at least 1; got {args.repeat}")
    if args.keep is not None and args.repeat > 1:
        parser.error("--keep keeps one store per mode: use it with --repeat 1")

    results: dict = {"preset": args.preset, "cores": os.cpu_count(), "runs": []}
    # The raw rollout runs before the first round and after every round; each generation
    # is compared with the mean of the raw runs on either side of its round, since a
    # shared machine's speed drifts over minutes.
    raws = [bench_raw(args.preset, args.raw_trials)]
    resettable = _reset_peak_rss()
    if not resettable:
        print(
            "(this system cannot reset the peak RSS: the main process's figure includes "
            "the raw rollout run before the generation)",
            flush=True,
        )
    pooled = False  # a pool ran: the children's peak RSS (not resettable) is its own
    for round_ in range(args.repeat):
        gens = []
        for mode, model in [(m, f) for m in args.modes for f in args.friction_models]:
            _reset_peak_rss()
            suffix = f"-{model}" if len(args.friction_models) > 1 else ""
            r = bench_generate(args.preset, mode, args.keep, model, suffix)
            r["round"] = round_ + 1
            if pooled:
                r["peak_rss_mb_largest_worker"] = None
            pooled = pooled or MODES[mode][0] > 1
            gens.append(r)
        raws.append(bench_raw(args.preset, args.raw_trials))
        raw_rate = (raws[-2]["trials_per_s"] + raws[-1]["trials_per_s"]) / 2
        for r in gens:
            r["raw_trials_per_s"] = raw_rate
            r["time_ratio"] = raw_rate / r["trials_per_s"]
            results["runs"].append(r)
            worker = r["peak_rss_mb_largest_worker"]
            print(
                f"round {r['round']}: generate {args.preset} [{_label(r, args)}]: "
                f"{r['trials']} trials in {r['wall_s']:.1f} s wall, {r['cpu_s']:.1f} s CPU -> "
                f"{r['trials_per_s']:.1f} trials/s; store {r['store_mb']:.1f} MB "
                f"({r['raw_mb']:.1f} MB raw); peak RSS during generation main "
                f"{r['peak_rss_mb_main']:.0f} MB"
                + (f", largest worker {worker:.0f} MB" if worker is not None else "")
                + f"; raw rollout {raws[-2]['wall_s']:.1f} s before, {raws[-1]['wall_s']:.1f} s "
                f"after: {r['time_ratio']:.2f}x",
                flush=True,
            )
    results["raw_runs"] = raws
    trials = raws[0]["trials"]
    summary = {}
    for label in dict.fromkeys(_label(r, args) for r in results["runs"]):
        mine = [r for r in results["runs"] if _label(r, args) == label]
        summary[label] = {
            "wall_s": statistics.median([r["wall_s"] for r in mine]),
            "cpu_ms_per_trial": statistics.median([r["cpu_s"] / r["trials"] * 1e3 for r in mine]),
            "time_ratio": statistics.median([r["time_ratio"] for r in mine]),
        }
    results["modes"] = summary
    results["raw"] = {
        "trials": trials,
        "wall_s": statistics.median([r["wall_s"] for r in raws]),
        "cpu_s": statistics.median([r["cpu_s"] for r in raws]),
        "wall_s_runs": [r["wall_s"] for r in raws],
    }
    # Time of the fastest mode's generation over the raw physics' time (target <= 1.25).
    best = min(summary, key=lambda m: summary[m]["time_ratio"])
    results["time_ratio"] = summary[best]["time_ratio"]
    rounds = f"median of {args.repeat} rounds" if args.repeat > 1 else "one round"
    for mode, m in summary.items():
        print(
            f"{mode} ({rounds}): {m['wall_s']:.1f} s wall, {m['cpu_ms_per_trial']:.1f} ms CPU "
            f"per trial, {m['time_ratio']:.2f}x the raw rollout's time"
        )
    print(
        f"raw rollout (MuJoCo's C++ rollout), same scenes: {trials} trials in "
        f"{', '.join(f'{w:.1f}' for w in results['raw']['wall_s_runs'])} s wall, "
        f"{results['raw']['cpu_s'] / trials * 1e3:.1f} ms CPU per trial in the rollout calls "
        f"(median); generation ({best}) takes {results['time_ratio']:.2f}x the raw physics' time"
    )
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
