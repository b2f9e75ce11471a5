"""report.md: the benchmark's results as a researcher reads them.

Built only from results.json records plus a small ``meta`` dict (seed, datasets, episode
budgets, figure files), so the same records give the same report. Wall-clock timings are
machine- and load-dependent: they appear only in the section between the
``<!-- timing -->`` and ``<!-- /timing -->`` markers, which is the only part of the
report allowed to differ between two runs with the same seed (see
:func:`strip_timing`).

This module assembles the sections (:func:`render`) and writes the file; the sections
live in sibling modules by what they report: the dataset's classes
(:mod:`benchmark.report_datasets`), the accuracies (:mod:`benchmark.report_accuracy`),
the interpretability (:mod:`benchmark.report_interpret`) and the timings
(:mod:`benchmark.report_timing`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from models.registry import beyond_the_paper_note, paper_first

from .report_accuracy import (
    GENERALISATION,
    accuracy_records,
    closed_set_section,
    generalisation_section,
    generalisation_titles,
    other_protocols_section,
    perturbation_grid_section,
    perturbation_readings,
)
from .report_datasets import class_grid, classes_section, dataset_summary
from .report_interpret import RANKING_HEAD, interpretability_section, ranking_heads
from .report_timing import TIMING_END, TIMING_START, strip_timing, timing_section
from .tables import BEYOND_THE_PAPER

#: The report's names, with its sections' (:mod:`benchmark.report_datasets`,
#: :mod:`benchmark.report_accuracy`, :mod:`benchmark.report_interpret`,
#: :mod:`benchmark.report_timing`) that callers reach through this module.
__all__ = [
    "GENERALISATION",
    "RANKING_HEAD",
    "TIMING_END",
    "TIMING_START",
    "beyond_section",
    "class_grid",
    "classes_section",
    "closed_set_section",
    "dataset_summary",
    "figures_section",
    "generalisation_section",
    "generalisation_titles",
    "interpretability_section",
    "other_protocols_section",
    "perturbation_grid_section",
    "perturbation_readings",
    "ranking_heads",
    "render",
    "strip_timing",
    "timing_section",
    "write_report",
]


def figures_section(records: Sequence[dict], meta: Mapping[str, Any]) -> list[str]:
    figs: Mapping[str, str] = meta.get("figures", {})
    seed = meta.get("seed")
    lines = ["## Figures", ""]
    desc = meta.get("figure_notes", {})
    for key, fname in figs.items():
        lines.append(f"- **{fname}** — {desc.get(key, '')} Seed {seed}.")
    for key in figs:
        lines += ["", f"![{key}]({figs[key]})"]
    return [*lines, ""]


def beyond_section(records: Sequence[dict], meta: Mapping[str, Any]) -> list[str]:
    """The methods beyond the paper, one line each on what differs from the paper; every
    table lists them after the paper's methods, under a "Beyond the paper" row."""
    names = list(meta.get("methods") or ()) or [r["method"] for r in accuracy_records(records)]
    _, beyond = paper_first(names)
    if not beyond:
        return []
    lines = [f"## {BEYOND_THE_PAPER}", ""]
    lines.append(
        "The paper's methods are implemented as the paper ran them and come first in every "
        f'table, in Table I\'s order; these follow under a "{BEYOND_THE_PAPER}" row:'
    )
    lines.append("")
    lines += [f"- **{m}**: {beyond_the_paper_note(m)}." for m in beyond]
    return [*lines, ""]


def render(records: Sequence[dict], meta: Mapping[str, Any]) -> str:
    """The report's Markdown text."""
    lines = ["# tactile-synth benchmark report", ""]
    lines.append(
        "AFOP-ML and baselines on synthetic tactile data (MuJoCo finger), following the "
        "evaluation of the AFOP-ML paper (Section V). Accuracies are fractions of correctly "
        "labelled queries, mean ± 95 % CI (1.96 · std / √episodes over per-episode "
        "accuracies)."
    )
    lines.append("")
    lines += [f"- seed: {meta.get('seed')}"]
    for key, label in (("data", "nominal dataset"), ("perturbed", "perturbation dataset")):
        if meta.get(key):
            lines.append(f"- {label}: {meta[key]}")
    if meta.get("methods"):
        paper_methods, beyond = paper_first(meta["methods"])
        lines.append(f"- methods: {', '.join([*paper_methods, *beyond])}")
    if meta.get("episodes"):
        lines.append(f"- episode budgets: {meta['episodes']}")
    if meta.get("threads"):
        lines.append(f"- thread settings: {meta['threads']}")
    if meta.get("kernels"):
        lines.append(f"- CPU kernels: {meta['kernels']}")
    for note in meta.get("notes", ()):
        lines.append(f"- {note}")
    lines.append("")
    lines += beyond_section(records, meta)
    lines += classes_section(meta)
    lines += closed_set_section(records)
    lines += generalisation_section(records, meta)
    lines += perturbation_grid_section(records)
    lines += other_protocols_section(records)
    lines += interpretability_section(records)
    lines += figures_section(records, meta)
    lines += timing_section(records)
    return "\n".join(lines).rstrip() + "\n"


def write_report(records: Sequence[dict], out_dir: str | Path, meta: Mapping[str, Any]) -> Path:
    """Write ``out_dir/report.md``; returns its path."""
    path = Path(out_dir) / "report.md"
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".md.tmp")
    tmp.write_text(render(records, meta))
    tmp.replace(path)
    return path
