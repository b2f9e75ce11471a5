"""What checking a dataset costs: ``synth.load_dataset`` (every chunk's checksum, the
per-trial arrays against the regenerated plan) against a plain zarr read of the same
signals (decompression only), best of several runs each.

    python3 scripts/bench_store.py --data PATH [--repeat 5]
"""

from __future__ import annotations

import argparse
import time

from script_args import description, fail, load_data

from tactile_synth.validation import int_arg


def best(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main(argv: list[str] | None = None) -> None:
    import zarr

    from synth import load_dataset
    from synth.presets import plan
    from synth.store import Store

    parser = argparse.ArgumentParser(description=description(__doc__))
    parser.add_argument("--data", required=True, help="a tactile-synth dataset (Zarr store)")
    parser.add_argument("--repeat", type=int_arg, default=5, help="runs of each (best is kept)")
    args = parser.parse_args(argv)
    if args.repeat < 1:
        fail(parser, f"--repeat must be >= 1; got {args.repeat}")

    def raw() -> None:
        zarr.open_group(args.data, mode="r")["signals"][:]

    data = load_data(parser, args.data)  # also warms the page cache
    config = Store.open(args.data).config
    t_raw = best(raw, args.repeat)
    t_load = best(lambda: load_dataset(args.data), args.repeat)
    t_plan = best(lambda: plan(config), args.repeat)
    mb = data.signals.nbytes / 1e6
    print(
        f"{args.data}: {len(data)} trials ({mb:.0f} MB of signals); best of {args.repeat}:\n"
        f"  zarr read of signals (decompression only) {t_raw * 1e3:8.1f} ms\n"
        f"  load_dataset (read + every check)         {t_load * 1e3:8.1f} ms "
        f"({t_load / t_raw:.2f}x)\n"
        f"  of which: regenerating the plan           {t_plan * 1e3:8.1f} ms"
    )


if __name__ == "__main__":
    main()
