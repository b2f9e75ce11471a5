"""The report's dataset lines: a dataset's one-line summary and the table of its classes
(specimens x materials, nominal and perturbation trials)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from synth import Dataset

from .checkpoints import fingerprint
from .tables import markdown_table


def dataset_summary(data: Dataset, path: str | Path | None) -> str:
    """One line on a dataset for the report: where, size, conditions, fingerprint."""
    conds = sorted(
        {(float(f), float(s)) for f, s in zip(data.force_n, data.speed_mm_s, strict=True)}
    )
    n_cls = np.unique(data.label).size
    per_cls = np.unique(np.unique(data.label, return_counts=True)[1])
    cond = ", ".join(f"{f:g} N/{s:g} mm/s" for f, s in conds)
    where = f"`{path}`, " if path is not None else ""
    return (
        f"{where}{len(data)} trials, {n_cls} classes, {'/'.join(map(str, per_cls))} trials "
        f"per class, conditions: {cond}; fingerprint {fingerprint(data)}"
    )


def class_grid(data: Dataset, perturbed: Dataset | None = None) -> dict[str, Any]:
    """The dataset's classes for the report's class table: its specimens and materials
    (in its class order) and the trials of each class, ``"<specimen>/<material>"`` ->
    ``[nominal trials, perturbation trials]`` (the second 0 without ``perturbed``)."""
    counts: dict[str, list[int]] = {}
    for which, d in enumerate((data, perturbed)):
        if d is None:
            continue
        names, n = np.unique(np.asarray(d.classes)[d.label], return_counts=True)
        for name, k in zip(names.tolist(), n.tolist(), strict=True):
            counts.setdefault(name, [0, 0])[which] = int(k)
    return {
        "specimens": list(data.specimens),
        "materials": list(data.materials),
        "trials": counts,
        "perturbed": perturbed is not None,
    }


def classes_section(meta: Mapping[str, Any]) -> list[str]:
    """A table of the nominal dataset's classes (rows: specimens, columns: materials;
    each cell the class's trials in the nominal dataset, and in the perturbation
    dataset after a slash)."""
    grid = meta.get("classes")
    if not grid:
        return []
    specimens, materials, trials = grid["specimens"], grid["materials"], grid["trials"]
    lines = ["## Classes", ""]
    both = " (nominal / perturbation dataset)" if grid.get("perturbed") else ""
    lines.append(
        f"The nominal dataset's {len(trials)} classes `<specimen>/<material>`: "
        f"{len(specimens)} specimens x {len(materials)} materials; each cell is the "
        f"class's trials{both}, - where the class has none."
    )
    lines.append("")

    def cell(name: str) -> str:
        n = trials.get(name)
        if n is None:
            return "-"
        return f"{n[0]} / {n[1]}" if grid.get("perturbed") else str(n[0])

    rows = [[s, *[cell(f"{s}/{m}") for m in materials]] for s in specimens]
    lines += markdown_table(["specimen", *materials], rows)
    lines.append("")
    return lines
