"""Time ``tactile-synth run`` (wall and CPU time of this process and its children).

    python3 scripts/bench_run.py --out /tmp/ts-run --quick
    python3 scripts/bench_run.py --out /tmp/ts-full

Prints the times as JSON and exits 1 when the wall time exceeds ``--target-s`` (by
default the project's targets for a 2-core machine: 300 s with ``--quick``, 1500 s for
the full run of every method, the paper's seven and the variants). Removes nothing: point
--out at a fresh directory to time generation too (re-runs reuse the datasets).
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
    parser.add_argument("--seed", type=int_arg, default=0)
    parser.add_argument(
        "--target-s",
        type=float_arg,
        help="wall-time target in seconds (default 300 with --quick, else 1500)",
    )
    args = parser.parse_args()

    from benchmark.run import run

    wall0, cpu0 = time.perf_counter(), time.process_time()
    run(args.out, quick=args.quick, seed=args.seed, progress=True)
    wall = time.perf_counter() - wall0
    cpu = time.process_time() - cpu0
    child = resource.getrusage(resource.RUSAGE_CHILDREN)
    summary = {
        "command": f"tactile-synth run --out {args.out}" + (" --quick" if args.quick else ""),
        "wall_s": round(wall, 1),
        "cpu_s_self": round(cpu, 1),
        "cpu_s_children": round(child.ru_utime + child.ru_stime, 1),
        "target_s": args.target_s or (300 if args.quick else 1500),
    }
    print(json.dumps(summary, indent=2))
    return 0 if wall < summary["target_s"] else 1


if __name__ == "__main__":
    sys.exit(main())
