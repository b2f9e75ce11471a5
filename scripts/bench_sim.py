"""Simulator speed: raw MuJoCo rollout vs end-to-end ``simulate_batch`` on the same trials.

    python3 scripts/bench_sim.py [--trials-per-class 10] [--threads 1] [--repeat 3]

Reports physics steps/s of the bare rollout, end-to-end trials/s, CPU seconds per 2 s
trial, and the end-to-end overhead over the raw rollout (targets: <= 25 %, <= 60 ms CPU
per trial), per round and as the median over the rounds. The raw rollout's wall and
CPU time are those of its rollout calls alone, without the trials' planning. Raw and
end-to-end runs alternate so that a drift of the machine's speed does not pass for
overhead. Then, once, the CPU per trial of ``simulate_batch``'s stages run one after
the other on the same batches: planning (each trial's felt surface, model and path),
the closed loop (MuJoCo's steps and the surface's and force loop's updates between
periods) and the sensor chain, so an overhead can be traced to its stage, with the
closed loop's wall time split into the time inside MuJoCo's rollout calls (the closed
loop's physics, to set against the raw rollout's) and the rest: the updates between
them and the loop's set-up. The default of 10 trials per class gives rollout batches of
30 trials per shape, about the size of a generation chunk (36 trials of the paper
preset); smaller batches pay the closed loop's fixed cost per update period over fewer
trials.
"""

from __future__ import annotations

import argparse
import statistics
import time

import synth
from shapes import SHAPE_NAMES
from synth import simulator
from synth.trial import TrialSpec
from tactile_synth.validation import int_arg


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials-per-class", type=int_arg, default=10)
    parser.add_argument("--threads", type=int_arg, default=1)
    parser.add_argument(
        "--repeat", type=int_arg, default=3, help="end-to-end runs, each between two raw ones"
    )
    args = parser.parse_args()
    for name in ("trials_per_class", "threads", "repeat"):
        if getattr(args, name) < 1:
            parser.error(f"--{name.replace('_', '-')} must be at least 1")
    config = synth.SynthConfig()
    specs = [
        TrialSpec(s, m, seed=i)
        for s in SHAPE_NAMES
        for m in synth.MATERIAL_NAMES
        for i in range(args.trials_per_class)
    ]
    synth.simulate_batch([TrialSpec(s, "wood") for s in SHAPE_NAMES], threads=1)  # warm caches

    # Raw physics: the same scenes and step counts, one open-loop rollout call per chunk
    # (no controller, texture, sensor chain or checks). Raw and end-to-end runs alternate,
    # and each end-to-end run is compared with the mean of the raw runs just before and
    # just after it: a shared machine's speed drifts over minutes, and a ratio of two
    # runs far apart in time measures the drift as much as the overhead.
    # Both figures of a raw run are those of its rollout calls: its planning and set-up
    # are not physics, while the end-to-end run's CPU includes its own planning.
    def raw() -> tuple[float, float]:
        return simulator.raw_rollout_times(specs, config=config, threads=args.threads)

    def end_to_end() -> tuple[float, float]:
        wall0, cpu0 = time.perf_counter(), time.process_time()
        trials = synth.simulate_batch(specs, config=config, threads=args.threads)
        assert len(trials) == len(specs)
        return time.perf_counter() - wall0, time.process_time() - cpu0

    raws, e2es = [raw()], []
    for _ in range(args.repeat):
        e2es.append(end_to_end())
        raws.append(raw())

    n = len(specs)
    steps = sum(simulator.plan(s, config).steps for s in specs)
    print(f"{n} trials, {steps / n:.0f} steps each on average, {args.threads} rollout thread(s)")
    ratios, cpu_ratios = [], []
    for i, (e2e_wall, e2e_cpu) in enumerate(e2es):
        raw_wall = (raws[i][0] + raws[i + 1][0]) / 2
        raw_cpu = (raws[i][1] + raws[i + 1][1]) / 2
        ratios.append(e2e_wall / raw_wall)
        cpu_ratios.append(e2e_cpu / raw_cpu)
        print(
            f"round {i + 1}: raw rollout {raw_wall:6.2f} s wall {steps / raw_wall:9.0f} steps/s "
            f"{raw_cpu / n * 1e3:5.1f} ms CPU per trial | simulate_batch {e2e_wall:6.2f} s wall "
            f"{n / e2e_wall:5.1f} trials/s {e2e_cpu / n * 1e3:5.1f} ms CPU per trial | "
            f"{(ratios[-1] - 1) * 100:+.1f}% wall"
        )
    e2e_cpu = statistics.median(c for _, c in e2es)
    raw_cpu = statistics.median(c for _, c in raws)
    print(
        f"median over {args.repeat} round(s): simulate_batch {e2e_cpu / n * 1e3:.1f} ms CPU per "
        f"trial (raw rollout {raw_cpu / n * 1e3:.1f} ms); overhead over raw rollout "
        f"{(statistics.median(ratios) - 1) * 100:+.1f}% wall, "
        f"{(statistics.median(cpu_ratios) - 1) * 100:+.1f}% CPU"
    )

    stages, loop_wall, in_rollout = _stages(specs, config, args.threads)
    print(
        "stages, one after the other (CPU ms per trial): "
        + ", ".join(f"{name} {cpu / n * 1e3:.1f}" for name, cpu in stages.items())
        + f"; the closed loop's wall time {loop_wall / n * 1e3:.1f} ms per trial, "
        f"{in_rollout / n * 1e3:.1f} ms of it inside MuJoCo's rollout calls and "
        f"{(loop_wall - in_rollout) / n * 1e3:.1f} ms outside them (the updates between "
        "them and the loop's set-up)"
    )


def _stages(
    specs: list[TrialSpec], config: synth.SynthConfig, threads: int
) -> tuple[dict[str, float], float, float]:
    """CPU seconds of planning, closed loop and sensor chain over ``specs``, in the batches
    ``simulate_batch`` makes (:func:`synth.simulator.rollout_chunks`); and the closed
    loops' wall seconds and the part of them inside MuJoCo's rollout calls (the rest is
    the controller's and the surface's work between update periods and each loop's
    set-up, from the reset of its data to its outputs' check)."""
    import mujoco

    from synth import scene

    cpu = {"plan": 0.0, "closed loop": 0.0, "sensor chain": 0.0}
    loop_wall = in_rollout = 0.0
    datas: dict[str, list[mujoco.MjData]] = {}
    for chunk in simulator.rollout_chunks(specs):
        shape = specs[chunk[0]].shape
        if shape not in datas:
            base = scene.scene(shape, config).model
            datas[shape] = [mujoco.MjData(base) for _ in range(threads)]
        t0 = time.process_time()
        plans = [simulator.plan(specs[i], config) for i in chunk]
        t1, w1 = time.process_time(), time.perf_counter()
        sens, heights, loop = simulator._roll_loop(plans, datas[shape][: len(plans)], config)
        t2 = time.process_time()
        loop_wall += time.perf_counter() - w1
        in_rollout += loop.rollout_s_
        simulator._process(plans, sens, heights, config)
        t3 = time.process_time()
        cpu["plan"] += t1 - t0
        cpu["closed loop"] += t2 - t1
        cpu["sensor chain"] += t3 - t2
    return cpu, loop_wall, in_rollout


if __name__ == "__main__":
    main()
