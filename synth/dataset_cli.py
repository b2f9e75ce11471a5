"""``tactile-synth generate / import / inspect / plot / export``: thin wrappers over the dataset
library."""

from __future__ import annotations

import argparse
import re
import shlex
import sys
import time
from pathlib import Path
from typing import Any

from .finger_config import SKIN_TEXTURE_RESPONSES


def register(subparsers: argparse._SubParsersAction) -> None:
    from tactile_synth.threads import HELP as THREADS_HELP
    from tactile_synth.validation import float_arg, int_arg

    from .export import EXPORT_FORMATS
    from .presets import PRESETS

    p = subparsers.add_parser(
        "generate",
        help="simulate a dataset (preset, experiment file or custom grid) into a Zarr store",
        description=(
            "Simulate a dataset into a Zarr store. The grid starts from --preset, "
            "--experiment, --config or --from-config (default: the paper preset, or the "
            "stored grid with --resume) and the grid options override it; the full "
            "configuration (specimens' outlines and materials included) is saved in the store."
        ),
    )
    base = p.add_mutually_exclusive_group()
    base.add_argument("--preset", choices=tuple(PRESETS), help="named grid")
    base.add_argument(
        "--experiment",
        metavar="FILE",
        help="an experiment file (TOML): its specimens, materials, conditions, trials per "
        "class and simulator settings (docs/experiments.md)",
    )
    base.add_argument("--config", metavar="TOML", help="grid from a TOML file")
    base.add_argument(
        "--from-config", metavar="DATASET", help="the exact grid of an existing dataset"
    )
    p.add_argument("--out", required=True, help="dataset path (a Zarr store directory)")
    p.add_argument(
        "--finger",
        metavar="TOML",
        help="a finger file (the one `tactile-synth calibrate` writes): its global "
        "parameters set on the grid's simulator configuration",
    )
    p.add_argument(
        "--friction-model",
        choices=("shared", "derived"),
        help="the skin's friction on each material: 'shared' keeps the configured laws "
        "(the paper's materials share one measured silicone law), 'derived' derives each "
        "material's from its surface roughness and the skin's viscoelasticity "
        "(docs/friction.md); default: the configured laws",
    )
    p.add_argument(
        "--skin-response",
        choices=SKIN_TEXTURE_RESPONSES,
        help="how the skin answers the texture it slides over: 'elastic' with its relaxed "
        "modulus, 'viscoelastic' with the silicone's complex modulus at the frequency the "
        "texture is passed at (finger.skin_texture_response, docs/friction.md); default: "
        "the configured finger's",
    )
    p.add_argument("--shapes", nargs="+", metavar="NAME")
    p.add_argument("--materials", nargs="+", metavar="NAME")
    p.add_argument("--trials-per-class", type=int_arg, metavar="N")
    p.add_argument("--force", nargs="+", type=float_arg, metavar="N", help="normal forces (N)")
    p.add_argument("--speed", nargs="+", type=float_arg, metavar="MM_S", help="speeds (mm/s)")
    p.add_argument("--exclude-nominal", action="store_true", help="drop the 1 N, 10 mm/s condition")
    p.add_argument("--seed", type=int_arg)
    p.add_argument("--chunk-trials", type=int_arg, metavar="N", help="trials per chunk / task")
    p.add_argument(
        "--workers",
        type=int_arg,
        help="local processes (default 1: this process; N > 1: a pool of N processes "
        "sharing the CPUs)",
    )
    p.add_argument("--threads", type=int_arg, metavar="N", help=THREADS_HELP)
    p.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help=SCHEDULER_HELP,
    )
    mode = p.add_mutually_exclusive_group()
    mode.add_argument(
        "--resume",
        action="store_true",
        help="complete an interrupted store (or an interrupted --overwrite of it)",
    )
    mode.add_argument(
        "--overwrite",
        action="store_true",
        help="replace an existing store (built beside it, swapped in when complete)",
    )
    p.add_argument(
        "--repair",
        action="store_true",
        help="with --resume: re-simulate the chunks that fail their checks (bit-identical)",
    )
    p.set_defaults(handler=_generate)

    p = subparsers.add_parser(
        "import",
        help="turn your own recordings (CSV/NPZ, one per trial) into a dataset store",
        description=(
            "Import real recordings into a dataset store like the simulator's. RECORDINGS "
            "is a folder with one CSV or NPZ file per trial (channels pvdf1, pvdf2, sg1, sg2 "
            "in volts) and a labels table (file, shape, material, force_n, speed_mm_s; see "
            "docs/recordings.md). Recordings are resampled to 1 kHz (with a warning) and cut "
            "to 2 s windows centred on the contact phase of the strain gauges."
        ),
    )
    p.add_argument("recordings", metavar="RECORDINGS", help="folder of recordings")
    p.add_argument(
        "--labels", metavar="CSV", help="table of labels (default: RECORDINGS/labels.csv)"
    )
    p.add_argument("--out", required=True, help="dataset path (a Zarr store directory)")
    p.add_argument(
        "--sample-rate",
        type=float_arg,
        metavar="HZ",
        help="sample rate of recordings that state none (labels column sample_rate_hz, "
        "NPZ array sample_rate_hz or a time_s column)",
    )
    p.add_argument(
        "--window-start",
        type=float_arg,
        metavar="S",
        help="start of every 2 s window in seconds from the recording's first sample "
        "(default: centred on the contact phase found in sg1/sg2)",
    )
    p.add_argument(
        "--chunk-trials",
        type=int_arg,
        default=36,
        metavar="N",
        help="trials per chunk (default 36)",
    )
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="replace an existing dataset (built beside it, swapped in when complete)",
    )
    p.set_defaults(handler=_import)

    p = subparsers.add_parser(
        "inspect", help="summarise a dataset store and check every chunk (exit 1 if damaged)"
    )
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
    from .experiment import load_experiment
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
    resume = args.resume or args.repair
    if args.preset:
        config = preset(args.preset)
    elif args.experiment:
        config = load_experiment(args.experiment)
    elif args.config:
        config = load_toml(args.config)
    elif args.from_config:
        config = store.stored_config(args.from_config)
    elif resume:
        if not overrides and not (
            getattr(args, "finger", None)
            or getattr(args, "friction_model", None)
            or getattr(args, "skin_response", None)
        ):
            return None  # the stored grid (of the dataset, or of its unfinished replacement)
        from .generation import check_resume_target

        out = Path(args.out)
        check_resume_target(out, repair=args.repair)
        pending = store.pending_path(out)
        config = store.stored_config(pending if store.is_store(pending) else out)
    else:
        config = preset("paper")
    if getattr(args, "finger", None):
        config = with_finger(config, args.finger)
    if getattr(args, "skin_response", None):
        config = with_skin_response(config, args.skin_response)
    if getattr(args, "friction_model", None):
        config = with_friction_model(config, args.friction_model)
    if not overrides:
        return config
    try:
        return config.replace(**overrides)
    except ValueError as exc:
        raise ValueError(_as_typed(str(exc), overrides)) from None


def _with_simulator(config: Any, change: Any) -> Any:
    """The grid ``config`` with ``change`` (a ``SynthConfig`` to ``SynthConfig``
    function) applied to its simulator configuration (the defaults where the grid holds
    none)."""
    from .config import SynthConfig

    synth = SynthConfig.from_dict(dict(config.synth)) if config.synth else SynthConfig()
    return config.replace(synth=change(synth).to_dict())


def with_finger(config: Any, path: str, arg: str = "--finger") -> Any:
    """The grid ``config`` with the finger file ``path``'s parameters set on its simulator
    configuration (the defaults where the grid holds none)."""
    from .calibration.finger_file import apply_finger

    return _with_simulator(config, lambda synth: apply_finger(synth, path, arg=arg))


def with_skin_response(config: Any, response: str) -> Any:
    """The grid ``config`` with its finger's ``skin_texture_response`` set to
    ``response`` (the defaults where the grid holds no simulator configuration)."""
    import dataclasses

    def change(synth):
        finger = dataclasses.replace(synth.finger, skin_texture_response=response)
        return dataclasses.replace(synth, finger=finger)

    return _with_simulator(config, change)


def with_friction_model(config: Any, model: str) -> Any:
    """The grid ``config`` with its materials' friction laws under ``model``
    (:func:`synth.tribology.with_friction_model`), from its simulator configuration's
    finger (the defaults where the grid holds none)."""
    import dataclasses

    from .tribology import with_friction_model as under

    def change(synth):
        return dataclasses.replace(synth, materials=under(synth.materials, synth.finger, model))

    return _with_simulator(config, change)


def _as_typed(message: str, overrides: dict[str, Any]) -> str:
    """``message`` with the configuration field it starts with (``forces_n must ...``)
    named as the option the user typed (``--force must ...``)."""
    for opt, field in _GRID_OPTIONS.items():
        if field in overrides and message.startswith((f"{field} ", f"{field}=")):
            return re.sub(rf"\b{field}\b", "--" + opt.replace("_", "-"), message)
    return message


def _saved(out: Path) -> str | None:
    """What an interrupted or failed generation left at ``out`` (None: nothing usable)."""
    from . import store

    pending = store.pending_path(out)
    for path, replacement in ((pending, True), (out, False)):
        try:
            done = store.Store.open(path).status()[0]
        except (OSError, ValueError):
            continue
        saved = f"{int(done.sum())}/{done.size} chunks"
        if replacement:
            return f"{out} still holds its previous dataset; its replacement has {saved} saved"
        return f"{saved} of {out} are saved"
    return None


def _generate(args: argparse.Namespace) -> int:
    from tactile_synth.interrupts import terminate_as_interrupt

    from . import store
    from .generation import generate
    from .simulator import SimulationError
    from .summary import counted

    out = Path(args.out)
    config = config_from_args(args)
    executor, client, workers = None, None, args.workers
    if args.scheduler:
        client, executor, cluster_workers = connect_scheduler(args.scheduler)
        workers = workers or cluster_workers
    start = time.perf_counter()
    try:
        with terminate_as_interrupt():  # `kill` stops at a chunk boundary, as Ctrl-C does
            generate(
                config,
                out,
                workers=workers,
                threads=args.threads,
                executor=executor,
                resume=args.resume,
                overwrite=args.overwrite,
                repair=args.repair,
            )
    except KeyboardInterrupt:
        saved = _saved(out)
        if saved is None:
            # Nothing (or only an unfinished skeleton) was created: the same command again.
            argv = getattr(args, "argv", None)
            again = "tactile-synth " + (shlex.join(argv) if argv else f"generate --out {out}")
            advice = f"nothing was saved; start again with `{again}`"
        else:
            advice = f"{saved}; finish with `tactile-synth generate --resume --out {out}`"
        print(f"tactile-synth generate: interrupted; {advice}", file=sys.stderr)
        return 130
    except SimulationError as exc:
        saved = _saved(out) or "nothing was saved"
        reason = " ".join(str(exc).split())
        print(
            f"tactile-synth generate: error: the physics failed: {reason}; {saved}, so "
            f"`tactile-synth generate --resume --out {out}` continues once the cause is fixed "
            f"(the same trial fails the same way every time: to go on now, choose other "
            f"--force/--speed values and pass --overwrite)",
            file=sys.stderr,
        )
        return 1
    finally:
        if client is not None:
            client.close()
    elapsed = time.perf_counter() - start
    st = store.Store.open(out)
    cfg, meta = st.config, st.meta
    n, n_classes = st.n_trials, len(cfg.classes)
    grid = (
        f"{counted(n_classes, 'class', 'classes')} x "
        f"{counted(len(meta['conditions']), 'condition')} x "
        f"{counted(cfg.trials_per_class, 'trial')}"
    )
    print(f"wrote {args.out}: {counted(n, 'trial')} ({grid}) in {elapsed:.1f} s")
    return 0


def _import(args: argparse.Namespace) -> int:
    import warnings

    from .importer import RecordingWarning, import_recordings
    from .summary import counted

    start = time.perf_counter()
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", RecordingWarning)
            summary = import_recordings(
                args.recordings,
                args.out,
                labels=args.labels,
                sample_rate_hz=args.sample_rate,
                window_start_s=args.window_start,
                chunk_trials=args.chunk_trials,
                overwrite=args.overwrite,
            )
    except KeyboardInterrupt:
        print(
            f"tactile-synth import: interrupted; nothing was written ({args.out} is as it "
            f"was); run the same command again",
            file=sys.stderr,
        )
        return 130
    for w in caught:
        if issubclass(w.category, RecordingWarning):
            print(f"tactile-synth import: warning: {w.message}", file=sys.stderr)
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    elapsed = time.perf_counter() - start
    formats = ", ".join(f"{n} {fmt.upper()}" for fmt, n in sorted(summary.formats.items()))
    how = {
        "contact": "centred on the contact phase",
        "given": "from the given start",
        "whole": "whole recordings",
    }
    windows = ", ".join(f"{n} {how.get(k, k)}" for k, n in sorted(summary.windows.items()))
    print(
        f"wrote {args.out}: {counted(summary.n_trials, 'trial')} "
        f"({counted(summary.n_classes, 'class', 'classes')} x "
        f"{counted(len(summary.conditions), 'condition')}) from {formats} recordings; "
        f"windows: {windows}; in {elapsed:.1f} s"
    )
    return 0


def _inspect(args: argparse.Namespace) -> int:
    from .summary import inspect_store

    text, problems = inspect_store(args.path)
    print(text)
    return 1 if problems else 0


def _plot(args: argparse.Namespace) -> int:
    from .plot import plot_examples

    print(f"wrote {plot_examples(args.path, args.out)}")
    return 0


def _export(args: argparse.Namespace) -> int:
    from .export import export

    print(f"wrote {export(args.path, args.format, args.out, overwrite=args.overwrite)}")
    return 0


#: ``--scheduler``'s help, shared by every command that simulates on a Dask cluster.
SCHEDULER_HELP = (
    "Dask scheduler, e.g. tcp://host:8786; each task sizes its worker's thread pools to "
    "--threads (default 1); start workers with OMP_WAIT_POLICY=PASSIVE "
    "OPENBLAS_THREAD_TIMEOUT=4 in their environment so idle threads sleep"
)


def connect_scheduler(address: str) -> tuple[Any, Any, int]:
    """``(client, executor, workers)`` of the Dask scheduler at ``address``: the client
    (close it when done), its executor for :func:`synth.generate`, and the cluster's
    worker count (at least 1); ValueError naming ``--scheduler`` when it cannot connect."""
    from dask.distributed import Client

    try:
        client = Client(address)
    except (OSError, ValueError, TimeoutError) as exc:
        raise ValueError(f"--scheduler {address}: cannot connect ({exc})") from None
    return client, client.get_executor(), max(len(client.scheduler_info()["workers"]), 1)
