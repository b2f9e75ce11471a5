"""Benchmark dataset generation: a preset end to end vs the raw ``mujoco.rollout`` rate.

    python scripts/bench_generate.py                      # paper preset, default workers
    python scripts/bench_generate.py --preset quick --modes inline pool
    python scripts/bench_generate.py --keep data      # also keep data/paper-inline

For each execution mode it generates the preset into a temporary store and reports wall
time, CPU time (this process + its worker processes), trials/s and the peak RSS of the
main process and of the largest worker. It times the simulator's raw rollout of the same
scenes (``synth.simulator.raw_rollout``: physics only, no sensor chain, no storage) on the
same cores before and after the generations and prints the ratio to the mean of the two.
The machine may be shared: CPU time is the steadier figure.
"""

from __future__ import annotations

import argparse
import ctypes
import json
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from synth import generate, load_dataset
from synth.presets import plan, preset

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


def bench_generate(name: str, mode: str, keep: Path | None = None) -> dict:
    workers, threads = MODES[mode]
    with tempfile.TemporaryDirectory(prefix="bench-gen-") as tmp:
        out = Path(tmp) / f"{name}.zarr"
        if keep is not None:
            out = keep / f"{name}-{mode}"
            if out.exists():
                raise SystemExit(f"--keep: {out} exists; remove it or choose another directory")
        cpu0, t0 = _cpu_s(), time.perf_counter()
        generate(name, out, workers=workers, threads=threads, progress=sys.stderr.isatty())
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
    """Physics-only rollout rate of the same scenes on all cores (plans made beforehand)."""
    from synth.simulator import raw_rollout

    specs = plan(preset(name)).specs(0, n_trials or 10**9)
    cpu0 = _cpu_s()
    wall = raw_rollout(specs, threads=os.cpu_count())
    cpu = _cpu_s() - cpu0
    return {"trials": len(specs), "wall_s": wall, "cpu_s": cpu, "trials_per_s": len(specs) / wall}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="paper")
    parser.add_argument("--modes", nargs="+", default=["inline"], choices=tuple(MODES))
    parser.add_argument(
        "--raw-trials", type=int, default=None, help="trials for the raw rate (default: all)"
    )
    parser.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    parser.add_argument(
        "--keep",
        metavar="DIR",
        type=Path,
        help="keep each generated store as DIR/<preset>-<mode> (default: a deleted temp dir)",
    )
    args = parser.parse_args(argv)

    results: dict = {"preset": args.preset, "cores": os.cpu_count(), "runs": []}
    # The raw rollout runs before and after the generations, and the ratio uses the mean of
    # the two: a shared machine's speed drifts over minutes.
    raws = [bench_raw(args.preset, args.raw_trials)]
    if not _reset_peak_rss():
        print(
            "(this system cannot reset the peak RSS: the main process's figure includes "
            "the raw rollout run before the generation)",
            flush=True,
        )
    for mode in args.modes:
        r = bench_generate(args.preset, mode, args.keep)
        results["runs"].append(r)
        print(
            f"generate {args.preset} [{mode}]: {r['trials']} trials in {r['wall_s']:.1f} s wall, "
            f"{r['cpu_s']:.1f} s CPU -> {r['trials_per_s']:.1f} trials/s; store "
            f"{r['store_mb']:.1f} MB ({r['raw_mb']:.1f} MB raw); peak RSS during generation "
            f"main {r['peak_rss_mb_main']:.0f} MB, largest worker "
            f"{r['peak_rss_mb_largest_worker']:.0f} MB",
            flush=True,
        )
    raws.append(bench_raw(args.preset, args.raw_trials))
    raw = {
        "trials": raws[0]["trials"],
        "wall_s": (raws[0]["wall_s"] + raws[1]["wall_s"]) / 2,
        "cpu_s": (raws[0]["cpu_s"] + raws[1]["cpu_s"]) / 2,
        "wall_s_before_after": [r["wall_s"] for r in raws],
    }
    raw["trials_per_s"] = raw["trials"] / raw["wall_s"]
    results["raw"] = raw
    best = max(r["trials_per_s"] for r in results["runs"])
    # Time of the fastest generation over the raw physics' time (target <= 1.25).
    results["time_ratio"] = raw["trials_per_s"] / best
    print(
        f"raw mujoco.rollout, same scenes: {raw['trials']} trials in {raw['wall_s']:.1f} s "
        f"wall (mean of {raws[0]['wall_s']:.1f} s before and {raws[1]['wall_s']:.1f} s after "
        f"the generation), {raw['cpu_s']:.1f} s CPU -> {raw['trials_per_s']:.1f} trials/s; "
        f"generation takes {results['time_ratio']:.2f}x the raw physics' time"
    )
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
