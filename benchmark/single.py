"""``tactile-synth benchmark PROTOCOL``: one protocol (or all) on existing datasets."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from models.registry import DEFAULT_METHODS, MethodOptions, check_method_options
from tactile_synth.validation import check_int

from . import figures
from .budget import Budget
from .cells import Features
from .engine import protocol_tasks
from .guards import check_episodes, check_perturbation_pair
from .methods import check_methods
from .outputs import OutputDir
from .protocols import get
from .protocols.closed_set import Reference
from .results import Record, select, write_results
from .tables import table_one


def benchmark_protocol(
    protocol: str,
    *,
    data_path: str | Path,
    out: str | Path,
    perturbed_path: str | Path | None = None,
    methods: Sequence[str] | None = None,
    episodes: int = 500,
    seed: int = 0,
    progress: bool = True,
    overwrite: bool = False,
    workers: int | None = None,
    options: MethodOptions | None = None,
) -> list[Record]:
    """Run ``protocol`` (a built-in or plug-in protocol name, ``module:Class``, or
    ``"all"``) and write results, report and figures. A protocol read against the
    closed-set reference curve also gets that curve.

    ``workers``: processes the fits run in (default: one per usable CPU, see
    :func:`benchmark.run.default_workers`). ``methods`` default to the paper's seven and
    the variants (:data:`models.registry.DEFAULT_METHODS`); ``options``: constructor
    options per method (``--method-option``).

    ``out`` is refused if it holds files this tool did not write, unless ``overwrite``;
    its whole output set is replaced at once when the run succeeds (see
    :mod:`benchmark.outputs`).
    """
    from synth import load_dataset

    from .report import class_grid, dataset_summary, write_report
    from .run import (
        benchmark_all,
        default_workers,
        kernels_line,
        options_notes,
        run_protocols,
        threads_line,
    )
    from .splits import NotApplicable, specimen_folds

    chosen = None if protocol == "all" else get(protocol, arg="PROTOCOL")
    methods = check_methods(list(methods) if methods else list(DEFAULT_METHODS))
    options = check_method_options(options or {}, methods)
    check_episodes(episodes)
    check_int("seed", seed, minimum=0)
    workers = default_workers() if workers is None else check_int("workers", workers, minimum=1)
    if chosen is None and "AFOP-ML" not in methods:
        raise ValueError(
            "--methods must include AFOP-ML for 'benchmark all' (its report and Fig. 6/7 are "
            "about it)"
        )
    needs_perturbed = chosen is None or chosen.needs_perturbed
    if needs_perturbed and perturbed_path is None:
        raise ValueError(f"--perturbed is required for the {protocol} protocol")
    for arg, path in (("--data", data_path), ("--perturbed", perturbed_path)):
        if path is not None and not Path(path).is_dir():
            raise FileNotFoundError(f"{arg} {path} is not a dataset directory")
    data = load_dataset(data_path)
    perturbed = load_dataset(perturbed_path) if perturbed_path is not None else None
    if perturbed is not None and needs_perturbed:
        check_perturbation_pair(data, perturbed)
    inputs = {"--data": data_path, "--perturbed": perturbed_path}
    with OutputDir(out, overwrite=overwrite, command=f"benchmark {protocol}", inputs=inputs) as out:
        if chosen is not None:
            try:  # a protocol that cannot apply is refused before anything is fitted
                protocol_tasks(chosen, data, perturbed, episodes=episodes, seed=seed)
            except NotApplicable as exc:
                raise NotApplicable(f"--data: {exc}") from None
        if chosen is None:
            return benchmark_all(
                data,
                perturbed,
                out,
                methods=methods,
                budget=Budget(default=episodes),
                seed=seed,
                progress=progress,
                data_path=data_path,
                perturbed_path=perturbed_path,
                workers=workers,
                options=options,
            )
        records, processes, _ = run_protocols(
            [chosen, Reference()] if chosen.uses_reference else [chosen],
            data,
            perturbed,
            out,
            methods=methods,
            budget=Budget(default=episodes),
            seed=seed,
            progress=progress,
            features=Features(),
            workers=workers,
            options=options,
        )
        write_results(out / "results.json", records)
        made: dict[str, str] = {}
        if select(records, "accuracy", protocol="closed-set", condition=None):
            (out / "table1.md").write_text(table_one(records))
            made["table1"] = "table1.md"
        curves = {panel[0] for panel in figures.GENERALISATION_PANELS}
        if any(r["protocol"] in curves for r in select(records, "accuracy")):
            figures.generalisation_curves(records, out / "generalisation.png")
            made["generalisation"] = "generalisation.png"
        bars = {protocol for protocol, _ in figures.SELECTION_ORDER}
        if any(r["protocol"] in bars for r in select(records, "selection")):
            figures.selection_bars(records, out / "selection.png")
            made["selection"] = "selection.png"
        meta = {
            "seed": seed,
            "data": dataset_summary(data, data_path),
            "perturbed": None if perturbed is None else dataset_summary(perturbed, perturbed_path),
            "classes": class_grid(data, perturbed),
            "cross_shape_folds": (
                [list(f) for f in specimen_folds(data.specimens)]
                if chosen.name == "cross-shape"
                else []
            ),
            "methods": list(methods),
            "episodes": f"{episodes} per cell",
            "threads": threads_line(processes),
            "kernels": kernels_line(processes),
            "figures": made,
            "notes": [f"protocol {chosen.name} only", *options_notes(options, methods)],
        }
        write_report(records, out, meta)
        return records
