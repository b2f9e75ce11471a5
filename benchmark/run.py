"""The whole study in one call: ``benchmark all`` (all four protocols + interpretability +
report) and ``run`` (generate the datasets from nothing, then ``benchmark all``).

This module only orchestrates. Every protocol goes through the same loop
(:func:`run_protocols`): its tasks come from the protocol (:mod:`benchmark.protocols`),
the engine (:mod:`benchmark.engine`) fits and evaluates, and its records are saved as a
checkpoint (:mod:`benchmark.checkpoints`) as soon as it completes, and each fit as soon as
it finishes, so interruptions lose nothing already finished. Budgets live in
:mod:`benchmark.budget`, the run plan and the dataset generation in
:mod:`benchmark.plan`, the interpretability analysis in
:mod:`benchmark.interpret`, figures and their captions in :mod:`benchmark.figures`, the
output directories in :mod:`benchmark.outputs`.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

from models.registry import DEFAULT_METHODS, MethodOptions, check_method_options
from synth import Dataset
from synth.store import versions as store_versions
from tactile_synth import atomic
from tactile_synth.threads import describe as describe_threads
from tactile_synth.threads import settings
from tactile_synth.validation import check_int

from . import checkpoints
from .budget import Budget
from .engine import (
    Features,
    Protocol,
    Task,
    TaskResults,
    check_methods,
    protocol_records,
    protocol_tasks,
    run_task_sets,
)
from .figures import draw_figures, figure_notes
from .plan import log, perturbation_for, prepare_datasets, run_plan
from .protocols import PROTOCOL_NAMES, get
from .report import class_grid, dataset_summary, write_report
from .results import Record, write_results
from .splits import NotApplicable, specimen_folds
from .workers import ProcessPool

__all__ = ["benchmark_all", "dataset_summary", "run", "run_plan", "run_protocols"]

NOTES = (
    "The perturbation protocol tests the closed-set fit of each method (fitted once on the "
    "closed-set training half of the nominal dataset, the same seeded 50:50 per-class "
    "split).",
)
#: The report's note on CWT-ResNet-ML's network when it is not started from given weights.
CWT_SCRATCH_NOTE = (
    "CWT-ResNet-ML's ResNet was trained from scratch on each task's training classes (its "
    "epoch count chosen on held-out training classes, then trained on all of them): the "
    "paper's pretrained ResNet weights cannot be downloaded at run time "
    "(--method-option CWT-ResNet-ML:weights=PATH starts from a ResNet-18 state dict you have)."
)


def options_notes(options: MethodOptions | None, methods: Sequence[str] | None = None) -> list[str]:
    """The report's note on each method built with options other than its defaults, and
    on CWT-ResNet-ML's network when it is among ``methods`` without given weights."""
    options = options or {}
    notes = [
        f"{method} built with {', '.join(f'{k}={v!r}' for k, v in params.items())} "
        "(--method-option)."
        for method, params in options.items()
        if params
    ]
    if "CWT-ResNet-ML" in (methods or ()) and not options.get("CWT-ResNet-ML", {}).get("weights"):
        notes.append(CWT_SCRATCH_NOTE)
    return notes


def run_protocols(
    protocols: Sequence[Protocol],
    data: Dataset,
    perturbed: Dataset | None,
    out: Path,
    *,
    methods: Sequence[str],
    budget: Budget,
    seed: int,
    progress: bool,
    features: Features,
    workers: int = 1,
    options: MethodOptions | None = None,
) -> ProtocolRuns:
    """Every protocol's records, each from its checkpoint in ``out`` when the inputs are
    unchanged, else run by the engine and checkpointed as soon as it completes. The
    protocols still to run share one queue of fits (:func:`benchmark.engine.run_task_sets`)
    in up to ``workers`` processes; ``options``: constructor options per method."""
    base = {
        "data": checkpoints.fingerprint(data),
        "perturbed": None if perturbed is None else checkpoints.fingerprint(perturbed),
        "methods": list(methods),
        "settings": checkpoints.method_settings(methods, options),
        "version": store_versions()["package_version"],
        "seed": seed,
    }
    # Options join the key only when there are any (keys of runs without them unchanged).
    if options:
        base["options"] = {m: dict(o) for m, o in options.items()}
        base["option_files"] = checkpoints.option_files(options)
    # Plug-ins' source hashes join the key only when there are any, so that the keys of
    # runs of built-in methods and protocols stay those of earlier versions.
    sources = checkpoints.method_sources(methods)
    if sources:
        base["sources"] = sources
    found: dict[int, list[Record]] = {}
    skipped: dict[str, str] = {}
    processes = 0
    pending: list[tuple[int, Protocol, str, list[Task]]] = []
    for i, protocol in enumerate(protocols):
        per_method = budget.for_protocol(protocol.name)
        inputs = {
            **base,
            "protocol": protocol.name,
            "episodes": budget.default,
            "per_method": dict(sorted(per_method.items())),
        }
        protocol_source = checkpoints.source_hash(type(protocol))
        if protocol_source is not None:
            inputs["protocol_source"] = protocol_source
        key = checkpoints.key(inputs)
        cached = checkpoints.load(out, protocol.name, key)
        if cached is not None:
            log(progress, f"{protocol.name}: reusing checkpoint")
            found[i] = cached
            continue
        episodes = budget.for_task(protocol.name)
        try:
            tasks = protocol_tasks(protocol, data, perturbed, episodes=episodes, seed=seed)
        except NotApplicable as exc:
            log(progress, f"{protocol.name}: skipped: {exc}")
            skipped[protocol.name] = str(exc)
            found[i] = []
            continue
        pending.append((i, protocol, key, tasks))
    if pending:
        start = time.perf_counter()
        where = f" in {workers} worker processes" if workers > 1 else ""
        names = ", ".join(protocol.name for _, protocol, _, _ in pending)
        log(progress, f"{names}: fitting and evaluating {', '.join(methods)}{where}")

        def done(j: int, results: TaskResults) -> None:
            i, protocol, key, tasks = pending[j]
            found[i] = protocol_records(tasks, results)
            checkpoints.save(out, protocol.name, key, found[i])
            log(progress, f"{protocol.name}: done ({time.perf_counter() - start:.0f} s)")

        fits = checkpoints.FitCheckpoints(out, [key for _, _, key, _ in pending])
        kept = len(list(fits.directory.glob("*.json"))) if fits.directory.is_dir() else 0
        if kept:
            # (out may be the output set's temporary sibling: the path is not the user's.)
            log(progress, f"{kept} fits finished by an interrupted run: reused where unchanged")
        processes = run_task_sets(
            [tasks for _, _, _, tasks in pending],
            methods,
            features=features,
            progress=progress,
            executor=ProcessPool(workers),
            on_done=done,
            fit_cache=fits,
            options=options,
        ).processes
        fits.clear()
    return ProtocolRuns([r for i in range(len(protocols)) for r in found[i]], processes, skipped)


class ProtocolRuns(NamedTuple):
    """What :func:`run_protocols` returns: the records, the processes the fits ran in
    (0: every protocol came from its checkpoint), and the protocols that could not apply
    to the datasets, each with the reason (:class:`benchmark.splits.NotApplicable`)."""

    records: list[Record]
    processes: int
    skipped: dict[str, str]


#: The report's thread line when every protocol came from its checkpoint.
NO_FITS_LINE = (
    "no fits ran in this invocation: every protocol's records came from its checkpoint "
    "(the settings of the run that computed them are not recorded)"
)


def threads_line(processes: int) -> str:
    """The report's thread line: the settings the fits ran with (``processes`` 0: no fit
    ran, so there are no settings of this invocation to report)."""
    if processes == 0:
        return NO_FITS_LINE
    if processes > 1:
        return f"{describe_threads(processes)}; fits in {processes} worker processes"
    return describe_threads()


def kernels_line(processes: int) -> str | None:
    """The report's CPU-kernel line: the instruction set torch dispatches its float kernels
    to on this machine, and the BLAS builds numpy and scipy load, with the kernels they
    picked. These depend on the CPU, and so can the torch methods' last digits, so two
    reports whose lines differ need not agree bit for bit. None when no fit ran in this
    invocation (the records came from checkpoints, maybe computed elsewhere)."""
    if processes == 0:
        return None
    import scipy.linalg  # noqa: F401  (loads scipy's BLAS, so the line names it every time)
    import threadpoolctl
    import torch

    blas = sorted(
        {
            f"{i['internal_api']} {i['version']} ({i.get('architecture') or 'unknown'})"
            for i in threadpoolctl.threadpool_info()
            if i["user_api"] == "blas"
        }
    )
    cpu = torch.backends.cpu.get_cpu_capability()
    return f"torch {torch.__version__} {cpu}; BLAS {', '.join(blas) or 'none loaded'}"


def default_workers() -> int:
    """Processes a benchmark's fits run in by default: one per CPU this process may use."""
    return settings().cpus


def benchmark_all(
    data: Dataset,
    perturbed: Dataset,
    out: str | Path,
    *,
    methods: Sequence[str] = DEFAULT_METHODS,
    budget: Budget | None = None,
    seed: int = 0,
    progress: bool = True,
    data_path: str | Path | None = None,
    perturbed_path: str | Path | None = None,
    workers: int | None = None,
    options: MethodOptions | None = None,
) -> list[Record]:
    """All four protocols + interpretability on ``data`` (nominal) and ``perturbed``;
    writes ``out/results.json``, ``out/report.md`` and the PNG figures. Returns records.

    workers: processes the protocols' fits run in (default :func:`default_workers`);
    options: constructor options per method (``--method-option``)."""
    from .interpret import analyse
    from .protocols.closed_set import Reference

    workers = default_workers() if workers is None else check_int("workers", workers, minimum=1)
    methods = check_methods(methods)
    if "AFOP-ML" not in methods:
        raise ValueError("methods must include AFOP-ML (the report and Fig. 6/7 are about it)")
    options = check_method_options(options or {}, methods)
    check_int("seed", seed, minimum=0)
    budget = budget or Budget()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    log(progress, "extracting the 386-feature pools")
    features = Features()
    for d in (data, perturbed):
        features.of(d)
    # The reference curve joins the queue: it is evaluated on the closed-set AFOP-ML fit.
    protocols = [*(get(name) for name in PROTOCOL_NAMES), Reference()]
    records, processes, skipped = run_protocols(
        protocols,
        data,
        perturbed,
        out,
        methods=methods,
        budget=budget,
        seed=seed,
        progress=progress,
        features=features,
        workers=workers,
        options=options,
    )
    log(progress, "t-SNE of the closed-set AFOP-ML fit's top-D features")
    extra, artefacts = analyse(data, records, features=features, episodes=budget.default, seed=seed)
    records += extra
    write_results(out / "results.json", records)
    log(progress, "drawing figures")
    meta = {
        "seed": seed,
        "data": dataset_summary(data, data_path),
        "perturbed": dataset_summary(perturbed, perturbed_path),
        "classes": class_grid(data, perturbed),
        "methods": list(methods),
        "episodes": budget.describe(methods, PROTOCOL_NAMES),
        "threads": threads_line(processes),
        "kernels": kernels_line(processes),
        "cross_shape_folds": []
        if "cross-shape" in skipped
        else [list(f) for f in specimen_folds(data.specimens)],
        "figures": draw_figures(records, data, artefacts, out),
        "figure_notes": figure_notes(records, artefacts, seed),
        "notes": [
            *NOTES,
            *options_notes(options, methods),
            *(f"{name} was not run: {why}." for name, why in skipped.items()),
        ],
    }
    write_report(records, out, meta)
    log(progress, f"benchmark done in {time.perf_counter() - t_start:.0f} s")
    return records


def run(
    out: str | Path,
    *,
    quick: bool = False,
    seed: int = 0,
    progress: bool = True,
    workers: int | None = None,
    methods: Sequence[str] | None = None,
    simulator: object = None,
    overwrite: bool = False,
    data: str | Path | None = None,
    perturbed: str | Path | None = None,
    options: MethodOptions | None = None,
) -> list[Record]:
    """Generate the nominal and perturbation datasets into ``out/data`` (reusing or
    completing any already there) and run :func:`benchmark_all` into ``out`` with the
    plan's methods, or ``methods`` (names, plug-in names or ``module:Class``; must include
    AFOP-ML), each built with its ``options`` (``--method-option``).

    ``data`` / ``perturbed``: existing dataset stores (generated or imported with
    ``tactile-synth import``) used instead of generating the nominal / perturbation
    dataset; the one not given is generated as usual. With ``data`` alone the
    perturbation grid is simulated for ``data``'s own classes (its specimens, materials
    and simulator settings: :func:`benchmark.plan.perturbation_for`).

    ``workers``: processes for generation and for the benchmark's fits (default: the
    generator's own default, and :func:`default_workers` for the fits).

    ``out`` is refused if it holds files this tool did not write, unless ``overwrite``;
    its output set is replaced at once at the end, its datasets and checkpoints kept
    (see :mod:`benchmark.outputs`). ``simulator`` replaces the MuJoCo simulator (tests
    only; see :func:`synth.generate`).
    """
    from synth import load_dataset

    from .guards import check_perturbation_pair
    from .outputs import OutputDir

    check_int("seed", seed, minimum=0)
    if workers is not None:
        check_int("workers", workers, minimum=1)
    out = Path(out)
    atomic.check_out_dir(out)
    plan = run_plan(quick, seed=seed, methods=methods)
    if "AFOP-ML" not in plan.methods:
        raise ValueError("methods must include AFOP-ML (the report and Fig. 6/7 are about it)")
    options = check_method_options(options or {}, plan.methods)
    given = {"nominal": data, "perturbation": perturbed}
    for path, arg in zip(given.values(), ("data", "perturbed"), strict=True):
        if path is not None and not Path(path).is_dir():
            raise FileNotFoundError(f"--{arg} {path} is not a dataset directory")
    if data is not None and perturbed is None:
        # The perturbation grid is simulated for the nominal dataset's own classes.
        plan = dataclasses.replace(plan, perturbation=perturbation_for(data, plan.perturbation))
    t_start = time.perf_counter()
    # The given datasets are inputs: OutputDir refuses any that replacing out's contents
    # would delete (only out/data is kept across runs).
    inputs = {"--data": data, "--perturbed": perturbed}
    with OutputDir(out, overwrite=overwrite, command="run", inputs=inputs) as target:
        paths = prepare_datasets(
            plan, out, given, progress=progress, workers=workers, simulator=simulator
        )
        nominal = load_dataset(paths["nominal"])
        pert = load_dataset(paths["perturbation"])
        check_perturbation_pair(nominal, pert)
        records = benchmark_all(
            nominal,
            pert,
            target,
            methods=plan.methods,
            budget=plan.budget,
            seed=seed,
            progress=progress,
            data_path=paths["nominal"],
            perturbed_path=paths["perturbation"],
            workers=workers,
            options=options,
        )
    log(progress, f"done in {time.perf_counter() - t_start:.0f} s (datasets and benchmark)")
    return records
