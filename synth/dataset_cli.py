"""``tactile-synth generate / inspect / plot / export``: thin wrappers over the dataset library."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any


def register(subparsers: argparse._SubParsersAction) -> None:
    from tactile_synth.threads import HELP as THREADS_HELP

    from .export import EXPORT_FORMATS
    from .presets import PRESETS

    p = subparsers.add_parser(
        "generate",
        help="simulate a dataset (preset or custom grid) into a Zarr store",
        description=(
            "Simulate a dataset into a Zarr store. The grid starts from --preset, --config "
            "or --from-config (default: the paper preset, or the stored grid with --resume) "
            "and the grid options override it; the full configuration is saved in the store."
        ),
    )
    base = p.add_mutually_exclusive_group()
    base.add_argument("--preset", choices=tuple(PRESETS), help="named grid")
    base.add_argument("--config", metavar="TOML", help="grid from a TOML file")
    base.add_argument(
        "--from-config", metavar="DATASET", help="the exact grid of an existing dataset"
    )
    p.add_argument("--out", required=True, help="dataset path (a Zarr store directory)")
    p.add_argument("--shapes", nargs="+", metavar="NAME")
    p.add_argument("--materials", nargs="+", metavar="NAME")
    p.add_argument("--trials-per-class", type=int, metavar="N")
    p.add_argument("--force", nargs="+", type=float, metavar="N", help="normal forces (N)")
    p.add_argument("--speed", nargs="+", type=float, metavar="MM_S", help="speeds (mm/s)")
    p.add_argument("--exclude-nominal", action="store_true", help="drop the 1 N, 10 mm/s condition")
    p.add_argument("--seed", type=int)
    p.add_argument("--chunk-trials", type=int, metavar="N", help="trials per chunk / task")
    p.add_argument(
        "--workers",
        type=int,
        help="local processes (default 1: this process; N > 1: a pool of N processes "
        "sharing the CPUs)",
    )
    p.add_argument("--threads", type=int, metavar="N", help=THREADS_HELP)
    p.add_argument("--scheduler", metavar="ADDRESS", help="Dask scheduler, e.g. tcp://host:8786")
    mode = p.add_mutually_exclusive_group()
    mode.add_argument("--resume", action="store_true", help="complete an interrupted store")
    mode.add_argument("--overwrite", action="store_true", help="replace an existing store")
    p.set_defaults(handler=_generate)

    p = subparsers.add_parser("inspect", help="summarise a dataset store")
    p.add_argument("path")
    p.set_defaults(handler=_inspect)

    p = subparsers.add_parser("plot", help="plot one example trial per class")
    p.add_argument("path")
    p.add_argument("--out", required=True, metavar="PNG")
    p.set_defaults(handler=_plot)

    p = subparsers.add_parser("export", help="export a dataset to npz or csv")
    p.add_argument("path")
    p.add_argument("--format", required=True, choices=EXPORT_FORMATS)
    p.add_argument("--out", help="output file (default: PATH with the format's suffix)")
    p.add_argument("--overwrite", action="store_true")
    p.set_defaults(handler=_export)


_GRID_OPTIONS = {
    "shapes": "shapes",
    "materials": "materials",
    "trials_per_class": "trials_per_class",
    "force": "forces_n",
    "speed": "speeds_mm_s",
    "seed": "seed",
    "chunk_trials": "chunk_trials",
}


def config_from_args(args: argparse.Namespace) -> Any:
    """The GenerationConfig the options ask for (``None``: resume with the stored grid)."""
    from . import store
    from .presets import load_toml, preset

    overrides: dict[str, Any] = {
        field: getattr(args, opt)
        for opt, field in _GRID_OPTIONS.items()
        if getattr(args, opt) is not None
    }
    if args.exclude_nominal:
        overrides["include_nominal"] = False
    for key in ("shapes", "materials", "forces_n", "speeds_mm_s"):
        if key in overrides:
            overrides[key] = tuple(overrides[key])
    if args.preset:
        config = preset(args.preset)
    elif args.config:
        config = load_toml(args.config)
    elif args.from_config:
        config = store.stored_config(args.from_config)
    elif args.resume and store.is_store(Path(args.out)):
        config = store.stored_config(args.out)
        if not overrides:
            return None
    else:
        config = preset("paper")
    return config.replace(**overrides) if overrides else config


def _generate(args: argparse.Namespace) -> int:
    from . import store
    from .generation import generate

    config = config_from_args(args)
    executor, client, workers = None, None, args.workers
    if args.scheduler:
        from dask.distributed import Client

        client = Client(args.scheduler)
        executor = client.get_executor()
        workers = workers or max(len(client.scheduler_info()["workers"]), 1)
    start = time.perf_counter()
    try:
        generate(
            config,
            args.out,
            workers=workers,
            threads=args.threads,
            executor=executor,
            resume=args.resume,
            overwrite=args.overwrite,
        )
    except KeyboardInterrupt:
        try:
            done = store.done_mask(store.open_store(args.out)[0])
            saved = f"{int(done.sum())}/{done.size} chunks are saved"
        except (ValueError, FileNotFoundError):
            saved = "nothing was saved"
        print(
            f"tactile-synth generate: interrupted; {saved}; finish with "
            f"`tactile-synth generate --resume --out {args.out}`",
            file=sys.stderr,
        )
        return 130
    finally:
        if client is not None:
            client.close()
    elapsed = time.perf_counter() - start
    _, meta = store.open_store(args.out)
    cfg = meta["config"]
    n, n_classes = int(meta["n_trials"]), len(cfg["shapes"]) * len(cfg["materials"])
    print(
        f"wrote {args.out}: {n} trials ({n_classes} classes x {len(meta['conditions'])} "
        f"conditions x {cfg['trials_per_class']} trials) in {elapsed:.1f} s"
    )
    return 0


def _inspect(args: argparse.Namespace) -> int:
    from .summary import summarize

    print(summarize(args.path))
    return 0


def _plot(args: argparse.Namespace) -> int:
    from .plot import plot_examples

    print(f"wrote {plot_examples(args.path, args.out)}")
    return 0


def _export(args: argparse.Namespace) -> int:
    from .export import export

    print(f"wrote {export(args.path, args.format, args.out, overwrite=args.overwrite)}")
    return 0
