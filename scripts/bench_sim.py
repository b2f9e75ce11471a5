"""Simulator speed: raw MuJoCo rollout vs end-to-end ``simulate_batch`` on the same trials.

    python3 scripts/bench_sim.py [--trials-per-class 2] [--threads 1]

Reports physics steps/s of the bare rollout, end-to-end trials/s, CPU seconds per 2 s
trial, and the end-to-end overhead over the raw rollout (target <= 25%, <= 0.1 s CPU).
"""

from __future__ import annotations

import argparse
import time

import mujoco

import synth
from shapes import SHAPE_NAMES
from synth import simulator
from synth.trial import TrialSpec


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials-per-class", type=int, default=2)
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

    # Raw physics: the same rollouts, controls prepared beforehand, no sensor processing.
    by_shape: dict[str, list[TrialSpec]] = {}
    for s in specs:
        by_shape.setdefault(s.shape, []).append(s)
    plans = {shape: [simulator.plan(s, config) for s in group] for shape, group in by_shape.items()}
    wall0, cpu0 = time.perf_counter(), time.process_time()
    for group in plans.values():
        datas = [mujoco.MjData(group[0].model) for _ in range(args.threads)]
        for start in range(0, len(group), simulator.CHUNK):
            simulator._roll(group[start : start + simulator.CHUNK], datas)
    raw_wall, raw_cpu = time.perf_counter() - wall0, time.process_time() - cpu0

    wall0, cpu0 = time.perf_counter(), time.process_time()
    synth.simulate_batch(specs, config=config, threads=args.threads)
    e2e_wall, e2e_cpu = time.perf_counter() - wall0, time.process_time() - cpu0

    n = len(specs)
    steps = n * simulator.n_steps(config)
    print(f"{n} trials x {simulator.n_steps(config)} steps, {args.threads} rollout thread(s)")
    print(
        f"raw rollout:    {raw_wall:6.2f} s wall  {steps / raw_wall:9.0f} steps/s  "
        f"{raw_cpu / n * 1e3:5.1f} ms CPU per trial"
    )
    print(
        f"simulate_batch: {e2e_wall:6.2f} s wall  {n / e2e_wall:6.1f} trials/s  "
        f"{e2e_cpu / n * 1e3:5.1f} ms CPU per trial"
    )
    print(f"overhead over raw rollout: {(e2e_wall / raw_wall - 1) * 100:+.1f}% (wall)")


if __name__ == "__main__":
    main()
