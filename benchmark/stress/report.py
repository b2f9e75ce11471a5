"""The stress suite's report: ``stress.md`` (ranking, per-family scores, accuracy per
family and severity), a heat map of the methods' mean drops per family, and one line
plot per family (accuracy against severity, every method), for each reading."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..results import select
from .families import StressFamily

READING_TITLES = {
    "enrolled-at-nominal": "enrolled at nominal, recognised under the perturbation",
    "all-perturbed": "enrolled and recognised under the perturbation",
}


def _pct(x: float | None, digits: int = 1) -> str:
    return "-" if x is None else f"{100 * x:.{digits}f}"


def _ratio(x: float | None) -> str:
    return "-" if x is None else f"{x:.2f}"


def _methods(records: Sequence[Mapping[str, Any]]) -> list[str]:
    return list(dict.fromkeys(r["method"] for r in select(records, "stress")))


def ranking_table(records: Sequence[Mapping[str, Any]], reading: str) -> list[str]:
    """Methods ranked by mCE (then mean drop): clean accuracy, mean and worst drop, mCE
    and relative mCE."""
    rows = select(records, "stress_score", reading=reading)
    rows = sorted(rows, key=lambda r: (r["mce"] is None, r["mce"] or 0.0, r["mean_drop"]))
    if not rows:
        return []
    ref = rows[0]["reference"]
    out = [
        "| rank | method | clean (%) | mean drop (pp) | worst drop (pp), family | "
        f"mCE vs {ref} | relative mCE |",
        "|---|---|---|---|---|---|---|",
    ]
    for i, r in enumerate(rows, 1):
        out.append(
            f"| {i} | {r['method']} | {_pct(r['clean'])} | {_pct(r['mean_drop'])} | "
            f"{_pct(r['worst_drop'])}, {r['worst_family']} | {_ratio(r['mce'])} | "
            f"{_ratio(r['relative_mce'])} |"
        )
    return out


def family_table(
    records: Sequence[Mapping[str, Any]], reading: str, families: Sequence[str]
) -> list[str]:
    """Each method's mean drop (pp) and CE per family."""
    methods = _methods(records)
    head = "| method | " + " | ".join(families) + " |"
    out = [head, "|---|" + "---|" * len(families)]
    for m in methods:
        cells = []
        for f in families:
            r = select(records, "stress_family", reading=reading, method=m, family=f)
            cells.append("-" if not r else f"{_pct(r[0]['mean_drop'])} ({_ratio(r[0]['ce'])})")
        out.append(f"| {m} | " + " | ".join(cells) + " |")
    return out


def accuracy_table(
    records: Sequence[Mapping[str, Any]], reading: str, family: StressFamily
) -> list[str]:
    """Accuracy ± 95 % CI per method and severity of one family (severity 0: clean)."""
    rows = select(records, "stress", reading=reading, family=family.name)
    severities = sorted({r["severity"] for r in rows})
    head = ["| method | clean |"] + [
        f" {s}: {family.value(s):g} {family.unit} |" for s in severities
    ]
    out = ["".join(head), "|---|---|" + "---|" * len(severities)]
    for m in _methods(records):
        clean = select(records, "stress", reading=reading, family=None, method=m)
        cells = [f"{_pct(clean[0]['accuracy'])} ± {_pct(clean[0]['ci95'])}" if clean else "-"]
        for s in severities:
            r = select(records, "stress", reading=reading, family=family.name, method=m, severity=s)
            cells.append(f"{_pct(r[0]['accuracy'])} ± {_pct(r[0]['ci95'])}" if r else "-")
        out.append(f"| {m} | " + " | ".join(cells) + " |")
    return out


def heatmap(
    records: Sequence[Mapping[str, Any]], families: Sequence[str], path: str | Path
) -> Path:
    """Mean drop (pp) per method x family, one panel per reading."""
    import matplotlib.pyplot as plt

    from ..figures import save_figure

    methods = _methods(records)
    readings = [r for r in READING_TITLES if select(records, "stress_family", reading=r)]
    fig, axes = plt.subplots(
        1,
        len(readings),
        figsize=(1.0 + (1.4 + 0.55 * len(families)) * len(readings), 1.4 + 0.4 * len(methods)),
        squeeze=False,
        constrained_layout=True,
    )
    for ax, reading in zip(axes[0], readings, strict=True):
        grid = np.full((len(methods), len(families)), np.nan)
        for i, m in enumerate(methods):
            for j, f in enumerate(families):
                r = select(records, "stress_family", reading=reading, method=m, family=f)
                if r:
                    grid[i, j] = 100 * r[0]["mean_drop"]
        im = ax.imshow(grid, cmap="Reds", vmin=0, vmax=max(5.0, float(np.nanmax(grid))))
        for (i, j), v in np.ndenumerate(grid):
            if np.isfinite(v):
                ax.text(j, i, f"{v:.0f}", ha="center", va="center", fontsize=7)
        ax.set_xticks(range(len(families)), families, rotation=60, ha="right", fontsize=8)
        ax.set_yticks(range(len(methods)), methods, fontsize=8)
        ax.set_title(READING_TITLES[reading], fontsize=8)
        fig.colorbar(im, ax=ax, shrink=0.8, label="mean drop (pp)")
    return save_figure(fig, path)


def family_plot(
    records: Sequence[Mapping[str, Any]], family: StressFamily, path: str | Path
) -> Path:
    """Accuracy against severity for every method (clean at severity 0), one panel per
    reading, with the 95 % CI as error bars."""
    import matplotlib.pyplot as plt

    from ..figures import METHOD_COLOURS, save_figure

    readings = [r for r in READING_TITLES if select(records, "stress", reading=r)]
    fig, axes = plt.subplots(
        1, len(readings), figsize=(5 * len(readings), 3.4), squeeze=False, constrained_layout=True
    )
    for ax, reading in zip(axes[0], readings, strict=True):
        for m in _methods(records):
            clean = select(records, "stress", reading=reading, family=None, method=m)
            pts = select(records, "stress", reading=reading, family=family.name, method=m)
            pts = clean + sorted(pts, key=lambda r: r["severity"])
            if not pts:
                continue
            ax.errorbar(
                [r["severity"] for r in pts],
                [100 * r["accuracy"] for r in pts],
                yerr=[100 * r["ci95"] for r in pts],
                marker="o",
                ms=3,
                capsize=2,
                color=METHOD_COLOURS.get(m),
                label=m,
            )
        ax.set_xlabel(f"severity, and its value ({family.unit})")
        ticks = sorted({0, *(r["severity"] for r in select(records, "stress", family=family.name))})
        ax.set_xticks(ticks, [f"{s}\n{family.value(s):g}" for s in ticks], fontsize=7)
        ax.set_ylabel("accuracy (%)")
        ax.set_title(f"{family.name}: {READING_TITLES[reading]}", fontsize=8)
        ax.grid(alpha=0.3)
    axes[0][-1].legend(fontsize=7, loc="lower left")
    return save_figure(fig, path)


def write_stress_report(
    records: Sequence[Mapping[str, Any]],
    families: Sequence[StressFamily],
    out: Path,
    meta: Mapping[str, Any],
) -> list[Path]:
    """``stress.md`` and its figures in ``out``; returns the files written."""
    names = [f.name for f in families]
    figures = [heatmap(records, names, out / "stress_heatmap.png")]
    for fam in families:
        figures.append(family_plot(records, fam, out / f"stress_{fam.name}.png"))
    md = [
        "# Stress suite",
        "",
        f"- nominal dataset: {meta['data']}",
        f"- test sets: {meta['test_sets']}",
        f"- methods fitted once on the nominal closed-set training half; {meta['cell']}, "
        f"{meta['episodes']} episodes per method and condition, seed {meta['seed']}",
        f"- scores against the reference method {meta['reference']} (docs/stress.md)",
        "- sensor families are faults applied to the recorded signals after the DAQ "
        "(signal-level); physical families are simulated through MuJoCo",
        "",
    ]
    for reading, title in READING_TITLES.items():
        if not select(records, "stress_score", reading=reading):
            continue
        md += [f"## {title.capitalize()} ({reading})", "", "### Ranking", ""]
        md += ranking_table(records, reading)
        md += ["", "### Mean drop per family, pp (CE in brackets)", ""]
        md += family_table(records, reading, names)
        for fam in families:
            md += ["", f"### {fam.name}: {fam.summary}", ""]
            md += accuracy_table(records, reading, fam)
        md += [""]
    md += ["## Figures", "", "![mean drop per method and family](stress_heatmap.png)", ""]
    md += [f"![{f.name}](stress_{f.name}.png)" for f in families]
    path = out / "stress.md"
    path.write_text("\n".join(md) + "\n")
    return [path, *figures]
