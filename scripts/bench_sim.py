"""Simulator speed: raw MuJoCo rollout vs end-to-end ``simulate_batch`` on the same trials.

    python3 scripts/bench_sim.py [--trials-per-class 10] [--threads 1]

Reports physics steps/s of the bare rollout, end-to-end trials/s, CPU seconds per 2 s
trial, and the end-to-end overhead over the raw rollout (targets: <= 25 %, <= 60 ms CPU
per trial). The default of 10 trials per class gives rollout batches of 30 trials per
shape, about the size of a generation chunk (36 trials of the paper preset); smaller
batches pay the closed loop's fixed cost per update period over fewer trials.
"""

from __future__ import annotations

import argparse
import time

import synth
from shapes import SHAPE_NAMES
from synth import simulator
from synth.trial import TrialSpec


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials-per-class", type=int, default=10)
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args()
    config = synth.SynthConfig()
    specs = [
        TrialSpec(s, m, seed=i)
        for s in SHAPE_NAMES
        for m in synth.MATERIAL_NAMES
        for i in range(args.trials_per_class)
    ]
    synth.simulate_batch([TrialSpec(s, "wood") for s in SHAPE_NAMES], threads=1)  # warm caches

    # Raw physics: the same scenes and step counts, one open-loop rollout call per chunk
    # (no controller, texture, sensor chain or checks).
    cpu0 = time.process_time()
    raw_wall = simulator.raw_rollout(specs, config=config, threads=args.threads)
    raw_cpu = time.process_time() - cpu0

    wall0, cpu0 = time.perf_counter(), time.process_time()
    trials = synth.simulate_batch(specs, config=config, threads=args.threads)
    e2e_wall, e2e_cpu = time.perf_counter() - wall0, time.process_time() - cpu0

    n = len(specs)
    steps = sum(simulator.plan(s, config).steps for s in specs)
    print(f"{n} trials, {steps / n:.0f} steps each on average, {args.threads} rollout thread(s)")
    print(
        f"raw rollout:    {raw_wall:6.2f} s wall  {steps / raw_wall:9.0f} steps/s  "
        f"{raw_cpu / n * 1e3:5.1f} ms CPU per trial"
    )
    print(
        f"simulate_batch: {e2e_wall:6.2f} s wall  {n / e2e_wall:6.1f} trials/s  "
        f"{e2e_cpu / n * 1e3:5.1f} ms CPU per trial"
    )
    print(f"overhead over raw rollout: {(e2e_wall / raw_wall - 1) * 100:+.1f}% (wall)")
    assert len(trials) == n


if __name__ == "__main__":
    main()
