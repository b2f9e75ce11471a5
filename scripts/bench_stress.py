"""Time ``tactile-synth stress`` (wall and CPU time of this process and its children).

    python3 scripts/bench_stress.py --out /tmp/ts-stress-quick --quick
    python3 scripts/bench_stress.py --out /tmp/ts-stress

Prints the times as JSON and exits 1 when the wall time exceeds ``--target-s`` (by
default the project's targets for a 2-core machine: 300 s with ``--quick``, 2700 s for
the full suite: every family at 5 severities, paper-size test sets, the paper's seven
methods). Removes nothing: point --out at a fresh directory to time generation too
(re-runs reuse the test sets and checkpoints).
"""

from __future__ import annotations

import argparse
import json
import resource
import sys
import time
from pathlib import Path

from tactile_synth.validation import float_arg, int_arg


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, type=Path)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--data", type=Path, help="a nominal dataset store (default: generated)")
    parser.add_argument("--seed", type=int_arg, default=0)
    parser.add_argument(
        "--target-s",
        type=float_arg,
        help="wall-time target in seconds (default 300 with --quick, else 2700)",
    )
    args = parser.parse_args()

    from benchmark.stress.command import run_stress

    wall0, cpu0 = time.perf_counter(), time.process_time()
    run_stress(args.out, data=args.data, quick=args.quick, seed=args.seed, progress=True)
    wall = time.perf_counter() - wall0
    cpu = time.process_time() - cpu0
    child = resource.getrusage(resource.RUSAGE_CHILDREN)
    command = f"tactile-synth stress --out {args.out}" + (" --quick" if args.quick else "")
    if args.data is not None:
        command += f" --data {args.data}"
    summary = {
        "command": command,
        "wall_s": round(wall, 1),
        "cpu_s_self": round(cpu, 1),
        "cpu_s_children": round(child.ru_utime + child.ru_stime, 1),
        "target_s": args.target_s or (300 if args.quick else 2700),
    }
    print(json.dumps(summary, indent=2))
    return 0 if wall < summary["target_s"] else 1


if __name__ == "__main__":
    sys.exit(main())
