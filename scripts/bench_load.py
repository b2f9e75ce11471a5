"""Slowdown under a competing CPU load: the same work alone and beside a load on every CPU.

    PYTHONPATH=$PWD python3 scripts/bench_load.py                   # both works, 1 round
    PYTHONPATH=$PWD python3 scripts/bench_load.py --work afop --rounds 3
    PYTHONPATH=$PWD python3 scripts/bench_load.py --spin            # the libraries' own
                                                                    # defaults: idle threads spin
    PYTHONPATH=$PWD python3 scripts/bench_load.py --load run        # beside `tactile-synth run`

Each work runs in a fresh Python process (thread pools sized as a user gets them, see
``tactile_synth.threads``), alternately alone ("idle") and beside a competing load, for
``--rounds`` rounds; the script prints the median wall and CPU time of each and the ratio
loaded / idle. Target: at most 2.5 (two jobs sharing the cores fairly take 2x).

Works (``--work``):
  afop  the closed-set AFOP-ML table (every Table I column, ``--episodes`` each) on
        ``--data`` (default: the quick preset, generated once into a scratch directory
        before any measurement), 386-feature pool included;
  test  tests/test_run.py::test_benchmark_all_writes_everything_and_is_deterministic.

Loads (``--load``):
  spin  one busy-loop process per CPU this process may use (every core busy);
  run   ``tactile-synth run --quick`` in a scratch directory, restarted whenever it ends.
The load runs in a session of its own, like a job started from another terminal or by
another CI job; where the kernel groups scheduling by session (autogroup), the two jobs
then split the CPUs between them. ``--same-group`` starts it in this script's session
instead, so that every thread competes one to one (as without autogroup): the stricter
test for a job with more threads than the load.

The idle figure is only as idle as the machine: on a machine shared with other jobs both
figures include their load (the script prints the load average before each measurement),
so measure on an otherwise idle machine for the figure to quote.
"""

from __future__ import annotations

import argparse
import atexit
import json
import os
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from tactile_synth.validation import int_arg

ROOT = Path(__file__).resolve().parents[1]
SLOW_TEST = "tests/test_run.py::test_benchmark_all_writes_everything_and_is_deterministic"
TARGET_RATIO = 2.5
#: GNU OpenMP's and OpenBLAS's own idle-wait defaults (spin ~300,000 iterations / 2^28
#: cycles before sleeping), for ``--spin``.
SPIN_ENV = {"GOMP_SPINCOUNT": "300000", "OPENBLAS_THREAD_TIMEOUT": "28"}


def _afop_table(data_path: str, episodes: int) -> None:
    from benchmark import protocols
    from models.features import extract
    from synth import load_dataset

    data = load_dataset(data_path)
    protocols.run(
        "closed-set",
        data,
        methods=("AFOP-ML",),
        episodes=episodes,
        seed=0,
        features=extract(data.signals),
    )


def _load_run(scratch: str) -> None:
    """Run ``tactile-synth run --quick`` over and over (until killed)."""
    while True:
        out = Path(scratch) / "run"
        shutil.rmtree(out, ignore_errors=True)
        subprocess.run(
            [sys.executable, "-m", "benchmark.cli", "run", "--quick", "--out", str(out)],
            cwd=ROOT,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            check=False,
        )


def _child_env(args: argparse.Namespace) -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    if args.spin:
        env.update(SPIN_ENV)
    if args.threads is not None:
        env["TACTILE_SYNTH_THREADS"] = str(args.threads)
    return env


def _work_command(work: str, args: argparse.Namespace) -> list[str]:
    if work == "afop":
        me = str(Path(__file__).resolve())
        return [sys.executable, me, "--child", "afop", "--data", args.data,
                "--episodes", str(args.episodes)]  # fmt: skip
    return [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", SLOW_TEST]


def _measure(cmd: list[str], env: dict[str, str]) -> tuple[float, float]:
    """Wall and CPU (user + system) seconds of ``cmd`` and the processes it waited for."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed (exit {proc.returncode})")
    return wall, usage.ru_utime + usage.ru_stime


class Load:
    """The competing load: started on entry, stopped (its own processes only) on exit."""

    def __init__(self, kind: str, procs: int, env: dict[str, str], same_group: bool) -> None:
        self.kind, self.procs, self.env, self.own_session = kind, procs, env, not same_group
        self.children: list[subprocess.Popen] = []
        self.scratch: str | None = None

    def __enter__(self) -> Load:
        if self.kind == "spin":
            cmd = [sys.executable, "-c", "while True: pass"]
            self.children = [
                subprocess.Popen(cmd, start_new_session=self.own_session) for _ in range(self.procs)
            ]
        else:
            self.scratch = tempfile.mkdtemp(prefix="bench-load-")
            me = str(Path(__file__).resolve())
            cmd = [sys.executable, me, "--child", "load-run", "--data", self.scratch]
            # Its own process group, so that stopping it stops the runs it started too.
            if self.own_session:
                self.children = [subprocess.Popen(cmd, env=self.env, start_new_session=True)]
            else:
                self.children = [subprocess.Popen(cmd, env=self.env, process_group=0)]
        time.sleep(1.0)  # let the load reach its steady state
        return self

    def __exit__(self, *exc: object) -> None:
        for child in self.children:
            if self.kind == "run":
                os.killpg(child.pid, signal.SIGKILL)
            else:
                child.kill()
            child.wait()
        if self.scratch is not None:
            shutil.rmtree(self.scratch, ignore_errors=True)


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.splitlines()[0],
        epilog=__doc__.split("\n\n", 2)[2],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--work", nargs="+", choices=("afop", "test"), default=["afop", "test"])
    parser.add_argument(
        "--data", help="dataset of the afop work (default: the quick preset, generated first)"
    )
    parser.add_argument("--episodes", type=int_arg, default=100, help="afop: episodes per column")
    parser.add_argument("--rounds", type=int_arg, default=1, help="idle/loaded pairs per work")
    parser.add_argument("--load", choices=("spin", "run"), default="spin")
    parser.add_argument("--load-procs", type=int_arg, help="spin: processes (default: CPUs)")
    parser.add_argument(
        "--same-group", action="store_true", help="load in this session's scheduling group"
    )
    parser.add_argument("--threads", type=int_arg, help="the works' --threads (default: automatic)")
    parser.add_argument("--spin", action="store_true", help="the libraries' spinning defaults")
    parser.add_argument("--json", metavar="FILE", help="also write the figures as JSON")
    parser.add_argument("--child", choices=("afop", "load-run"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child == "afop":
        _afop_table(args.data, args.episodes)
        return 0
    if args.child == "load-run":
        _load_run(args.data)
        return 0
    for name in ("episodes", "rounds", "load_procs", "threads"):
        value = getattr(args, name)
        if value is not None and value < 1:
            parser.error(f"--{name.replace('_', '-')} must be >= 1; got {value}")
    if "afop" in args.work and args.data is not None and not Path(args.data).is_dir():
        parser.error(f"--data {args.data} is not a dataset directory")
    if "afop" in args.work and args.data is None:
        import synth
        from synth.presets import preset

        scratch = tempfile.mkdtemp(prefix="bench-load-data-")
        atexit.register(shutil.rmtree, scratch, ignore_errors=True)
        args.data = str(Path(scratch) / "quick")
        print(f"generating the quick preset into {args.data} (not timed)", flush=True)
        synth.generate(preset("quick"), args.data, progress=False)

    from tactile_synth.threads import available_cpus

    cpus = available_cpus()
    procs = args.load_procs or cpus
    env = _child_env(args)
    load_env = {k: v for k, v in _child_env(args).items() if k != "TACTILE_SYNTH_THREADS"}
    load_desc = f"{procs} busy-loop processes" if args.load == "spin" else "tactile-synth run"
    load_desc += " in this session" if args.same_group else " in a session of their own"
    print(
        f"{cpus} usable CPUs; load: {load_desc}; "
        f"{'library spin defaults' if args.spin else 'project thread settings'}"
        + (f", --threads {args.threads}" if args.threads else ""),
        flush=True,
    )
    results = []
    for work in args.work:
        cmd = _work_command(work, args)
        times: dict[str, list[tuple[float, float]]] = {"idle": [], "loaded": []}
        for r in range(args.rounds):
            for state in ("idle", "loaded"):
                load_avg = os.getloadavg()[0]
                if state == "idle":
                    wall, cpu = _measure(cmd, env)
                else:
                    with Load(args.load, procs, load_env, args.same_group):
                        wall, cpu = _measure(cmd, env)
                times[state].append((wall, cpu))
                print(
                    f"  {work} round {r + 1} {state:6s}: wall {wall:7.1f} s, CPU {cpu:7.1f} s "
                    f"(load average before: {load_avg:.1f})",
                    flush=True,
                )
        idle_wall = statistics.median(w for w, _ in times["idle"])
        loaded_wall = statistics.median(w for w, _ in times["loaded"])
        row = {
            "work": work,
            "idle_wall_s": round(idle_wall, 2),
            "loaded_wall_s": round(loaded_wall, 2),
            "idle_cpu_s": round(statistics.median(c for _, c in times["idle"]), 2),
            "loaded_cpu_s": round(statistics.median(c for _, c in times["loaded"]), 2),
            "ratio": round(loaded_wall / idle_wall, 2),
        }
        results.append(row)
        print(
            f"{work}: idle {idle_wall:.1f} s, loaded {loaded_wall:.1f} s -> ratio "
            f"{row['ratio']:.2f} (target <= {TARGET_RATIO}); CPU {row['idle_cpu_s']:.1f} s "
            f"idle, {row['loaded_cpu_s']:.1f} s loaded",
            flush=True,
        )
    if args.json:
        summary = {
            "cpus": cpus,
            "load": args.load,
            "load_procs": procs if args.load == "spin" else None,
            "load_same_group": args.same_group,
            "spin_defaults": args.spin,
            "threads": args.threads,
            "rounds": args.rounds,
            "episodes": args.episodes,
            "results": results,
        }
        Path(args.json).write_text(json.dumps(summary, indent=2) + "\n")
    return 0 if all(r["ratio"] <= TARGET_RATIO for r in results) else 1


if __name__ == "__main__":
    sys.exit(main())
