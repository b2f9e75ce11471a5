"""What ``tactile-synth run`` does before the benchmark: its plan (presets, methods,
episode budgets) and the datasets it generates into ``DIR/data`` (resumable) or takes
as given."""

from __future__ import annotations

import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from models.registry import DEFAULT_METHODS

from .budget import Budget
from .guards import generate_for_run
from .methods import check_methods


def log(progress: bool, msg: str) -> None:
    """One progress line on stderr (when ``progress``)."""
    if progress:
        print(f"[tactile-synth] {msg}", file=sys.stderr, flush=True)


def full_budget(methods: Sequence[str]) -> Budget:
    """Episode budgets of the full run, the same for every one of ``methods``: the paper's
    500 episodes per closed-set column and 100 per generalisation point (fold or condition
    x way)."""
    return Budget(default=500, generalisation_per_method=dict.fromkeys(methods, 100))


QUICK_METHODS: tuple[str, ...] = ("AFOP-ML", "AFO-MLP-ML", "Direct-Prot-ML")
QUICK_BUDGET = Budget(default=100)


@dataclass(frozen=True)
class RunPlan:
    """What ``tactile-synth run`` generates and how many episodes it evaluates."""

    nominal: Any  # synth.presets.GenerationConfig
    perturbation: Any
    methods: tuple[str, ...]
    budget: Budget


def run_plan(quick: bool, *, seed: int = 0, methods: Sequence[str] | None = None) -> RunPlan:
    """The full (``paper`` + ``perturbation`` presets) or ``--quick`` plan; ``methods``
    replaces the plan's methods (default: the paper's seven and the variants beyond the
    paper, :data:`models.registry.DEFAULT_METHODS`; :data:`QUICK_METHODS` when quick).

    Budgets (:func:`full_budget`): the same for every method, the paper's 500 episodes per
    closed-set column and 100 per generalisation point (11 ways x 3 folds or 9
    conditions each); every record carries its own ``episodes``.
    """
    from synth.presets import preset

    chosen = None if methods is None else check_methods(methods)
    if quick:
        nominal = preset("quick").replace(seed=seed)
        pert = preset("perturbation").replace(
            preset="perturbation-quick",
            trials_per_class=2,
            forces_n=(0.6, 1.4),
            speeds_mm_s=(6.0, 14.0),
            seed=seed,
        )
        return RunPlan(nominal, pert, chosen or QUICK_METHODS, QUICK_BUDGET)
    chosen = chosen or DEFAULT_METHODS
    return RunPlan(
        preset("paper").replace(seed=seed),
        preset("perturbation").replace(seed=seed),
        chosen,
        full_budget(chosen),
    )


def perturbation_for(nominal: str | Path, base: Any) -> Any:
    """The perturbation grid ``base`` (the plan's, a ``GenerationConfig``) for the classes
    of the nominal dataset at ``nominal``: its specimens, materials and simulator settings
    (its stored configuration), at ``base``'s conditions, trials and seed. A store of
    imported recordings has no configuration: its classes are simulated with the
    simulator's defaults when the paper's shapes and materials are all they hold; other
    specimens or materials have no definition to simulate (``ValueError``: give
    ``--perturbed``)."""
    from shapes import SHAPE_NAMES
    from synth import MATERIAL_NAMES, store

    path = Path(nominal)
    meta = store.read_meta(path)
    if store.store_kind(meta) != store.KIND_IMPORTED:
        config = store.stored_config(path)
        return base.replace(shapes=config.shapes, materials=config.materials, synth=config.synth)
    shapes_, materials = list(meta.get("shapes") or ()), list(meta.get("materials") or ())
    unknown = [s for s in shapes_ if s not in SHAPE_NAMES]
    unknown += [m for m in materials if m not in MATERIAL_NAMES]
    if unknown:
        raise ValueError(
            f"--data {nominal} holds imported recordings of {', '.join(unknown)}, which the "
            f"simulator has no definition of, so their perturbation dataset cannot be "
            f"simulated; give it with --perturbed"
        )
    return base.replace(shapes=tuple(shapes_), materials=tuple(materials))


def prepare_datasets(
    plan: RunPlan,
    out: Path,
    given: Mapping[str, str | Path | None],
    *,
    progress: bool,
    workers: int | None,
    simulator: Any,
) -> dict[str, Path]:
    """``{"nominal": path, "perturbation": path}``: each ``given`` store as it is, else
    the plan's dataset generated into ``out/data/<name>`` (completed if interrupted)."""
    paths = {}
    for name, config in (("nominal", plan.nominal), ("perturbation", plan.perturbation)):
        if given.get(name) is not None:
            log(progress, f"{name} dataset: {given[name]} (given, not generated)")
            paths[name] = Path(given[name])
            continue
        path = Path(out) / "data" / name
        log(progress, f"generating the {name} dataset into {path} (resumable)")
        t0 = time.perf_counter()
        generate_for_run(config, path, progress=progress, workers=workers, simulator=simulator)
        log(progress, f"{name} dataset ready ({time.perf_counter() - t0:.0f} s)")
        paths[name] = path
    return paths
