"""Time the work that allocates most (a per-episode CNN training loop, a chunk of the
simulator) with tactile-synth's allocator thresholds and with glibc's defaults
(``TACTILE_SYNTH_MALLOC=system``) and with the trim threshold a Dask nanny exports
(``MALLOC_TRIM_THRESHOLD_=65536``, which also fixes glibc's mmap threshold at 128 kB), each
in a fresh process on one thread.

    python3 scripts/bench_malloc.py [--repeats 3]

Prints wall, user and system seconds and page faults per setting as JSON (the median of
``--repeats`` runs).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

from tactile_synth import allocator
from tactile_synth.validation import int_arg

#: name -> (set-up, timed work): imports are not timed.
WORK = {
    "cnn": (
        """
import torch, torch.nn.functional as F
from models.nets import init_cnn, cnn_forward
from models.cnn import LAYERS
""",
        """
torch.manual_seed(0)
for e, r in ((64, 25), (17, 180), (64, 5), (64, 36)):
    x = torch.randn(r, e, 4, 1000)
    gen = torch.Generator().manual_seed(0)
    params = [p.requires_grad_(True) for p in init_cnn(LAYERS, 5, gen, copies=e)]
    target = torch.randint(0, 5, (r * e,))
    opt = torch.optim.Adam(params, lr=1e-3)
    for _ in range(20):
        loss = F.cross_entropy(cnn_forward(x, params, LAYERS).reshape(-1, 5), target)
        opt.zero_grad(); loss.backward(); opt.step()
""",
    ),
    "simulate": (
        """
from synth import TrialSpec, simulate_batch
simulate_batch([TrialSpec("moon", "wood", seed=99)], threads=1)
""",
        """
simulate_batch([TrialSpec("moon", "wood", seed=s) for s in range(32)], threads=1)
""",
    ),
}

PROBE = """
import json, resource, time, tactile_synth
exec(compile({setup!r}, "setup", "exec"))
r0, t0 = resource.getrusage(resource.RUSAGE_SELF), time.perf_counter()
exec(compile({work!r}, "work", "exec"))
r1 = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({{"wall_s": time.perf_counter() - t0, "user_s": r1.ru_utime - r0.ru_utime,
       "sys_s": r1.ru_stime - r0.ru_stime, "minor_faults": r1.ru_minflt - r0.ru_minflt,
       "tuned": tactile_synth.allocator.TUNED}}))
"""


#: label -> the allocator variables of the measured process.
SETTINGS = {
    "tuned": {},
    "glibc defaults": {"TACTILE_SYNTH_MALLOC": "system"},
    "Dask's trim threshold": {"MALLOC_TRIM_THRESHOLD_": "65536"},
}


def measure(work: str, setting: str) -> dict:
    env = allocator.without_user_settings(os.environ)
    env["TACTILE_SYNTH_THREADS"] = "1"
    env.update(SETTINGS[setting])
    out = subprocess.run(
        [sys.executable, "-c", PROBE.format(setup=WORK[work][0], work=WORK[work][1])],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int_arg, default=3)
    parser.add_argument("--work", nargs="+", choices=sorted(WORK), default=sorted(WORK))
    args = parser.parse_args(argv)
    if args.repeats < 1:
        parser.error(f"--repeats must be >= 1; got {args.repeats}")
    summary = {}
    for work in args.work:
        for label in SETTINGS:
            runs = sorted(
                (measure(work, label) for _ in range(args.repeats)), key=lambda r: r["wall_s"]
            )
            mid = runs[len(runs) // 2]
            summary[f"{work}, {label}"] = {
                k: round(v, 2) if isinstance(v, float) else v for k, v in mid.items()
            }
    print(json.dumps(summary, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
