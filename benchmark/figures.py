"""The report's PNG figures (matplotlib, Agg backend; no display needed).

Each function takes results.json records (or arrays) and a path, writes one PNG and
returns the path. Figures follow the paper: Fig. 5 (generalisation curves with the
closed-set curve dashed), Fig. 6 (median D and sensor shares), Fig. 7 (t-SNE), plus the
D-scan curve, the perturbation heat map and example signals per class.
:func:`draw_figures` writes them all for ``benchmark all`` / ``run`` and
:func:`figure_notes` gives each its caption for the report.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np

from models.registry import paper_first
from shapes import SHAPE_NAMES
from synth import CHANNELS, MATERIAL_NAMES, SAMPLE_RATE_HZ, Dataset
from synth.presets import NOMINAL_FORCE_N, NOMINAL_SPEED_MM_S

from .interpret import Artefacts
from .labels import ENROLLED, POOLED, WITHIN_CONDITION, condition_reading
from .results import select

#: Panel order and titles of Fig. 5; the perturbation protocol's readings each have their
#: own panel, side by side, none promoted.
GENERALISATION_PANELS: tuple[tuple[str, str | None, str], ...] = (
    ("cross-shape", None, "(a) Cross-shape"),
    ("cross-material", None, "(b) Cross-material"),
    ("perturbation", WITHIN_CONDITION, "(c) Force-speed: within one condition"),
    ("perturbation", POOLED, "(d) Force-speed: all conditions pooled"),
    ("perturbation", ENROLLED, "(e) Force-speed: enrolled at nominal"),
)
#: Bar order of Fig. 6 (the paper's: Shape, Closed-set, Force&Speed, Material).
SELECTION_ORDER: tuple[tuple[str, str], ...] = (
    ("cross-shape", "Shape"),
    ("closed-set", "Closed-set"),
    ("perturbation", "Force&Speed"),
    ("cross-material", "Material"),
)
METHOD_COLOURS: dict[str, str] = {
    "AFOP-ML": "tab:blue",
    "AFO-MLP-ML": "tab:orange",
    "Direct-Prot-ML": "tab:green",
    "MAML": "tab:red",
    "CWT-ResNet-ML": "tab:purple",
    "CNN": "tab:brown",
    "BiLSTM": "tab:pink",
    "AFO-MLP-ML+meta": "tab:olive",
}
#: One marker per shape in SHAPE_NAMES order, resembling the outline where one exists.
SHAPE_MARKERS: tuple[str, ...] = ("o", "8", "P", "h", "X", "<", "p", "*", "D", "s", ">", "^")
MATERIAL_COLOURS: dict[str, str] = {
    "resin": "tab:blue",
    "wood": "tab:olive",
    "aluminum": "tab:gray",
}
#: Colours of other materials than the paper's, in the order a dataset lists them.
OTHER_COLOURS: tuple[str, ...] = (
    "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown", "tab:pink", "tab:cyan"
)  # fmt: skip
DPI = 120


def names_in_order(values: np.ndarray, preferred: Sequence[str]) -> list[str]:
    """The distinct ``values``: those of ``preferred`` in its order, then the others in the
    order they first appear (a dataset's own specimens or materials after the paper's)."""
    present = list(dict.fromkeys(np.asarray(values).tolist()))
    return [v for v in preferred if v in present] + [v for v in present if v not in preferred]


def material_colour(material: str, others: Sequence[str] = ()) -> str:
    """The colour of ``material``: the paper's three have their own; any other takes the
    next of :data:`OTHER_COLOURS` by its place among ``others``."""
    if material in MATERIAL_COLOURS:
        return MATERIAL_COLOURS[material]
    rest = [m for m in others if m not in MATERIAL_COLOURS]
    i = rest.index(material) if material in rest else 0
    return OTHER_COLOURS[i % len(OTHER_COLOURS)]


#: Panels per row of the perturbation heat map (more methods wrap onto further rows).
HEATMAP_COLUMNS = 4


def save_figure(fig: plt.Figure, path: str | Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI, bbox_inches="tight")
    plt.close(fig)
    return path


def _curve(records: Sequence[dict], **match: object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rs = select(records, "accuracy", **match)
    rs.sort(key=lambda r: r["way"])
    way = np.array([r["way"] for r in rs])
    acc = np.array([r["accuracy"] for r in rs]) * 100
    ci = np.array([r["ci95"] for r in rs]) * 100
    return way, acc, ci


def dscan_curve(dscan: Mapping[str, Sequence[float]], chosen_d: int, path: str | Path) -> Path:
    """AFOP-ML's D-scan: validation accuracy vs D with its 95 % CI band; chosen D marked."""
    d = np.asarray(dscan["D"])
    mean = np.asarray(dscan["mean"]) * 100
    ci = np.asarray(dscan["ci95"]) * 100
    fig, ax = plt.subplots(figsize=(6, 3.6))
    ax.plot(d, mean, color="tab:blue", lw=1.5, label="validation accuracy")
    ax.fill_between(d, mean - ci, mean + ci, color="tab:blue", alpha=0.25, label="95% CI")
    ax.axvline(chosen_d, color="k", ls="--", lw=1, label=f"chosen D = {chosen_d}")
    ax.set_xlabel("number of top-ranked features D")
    ax.set_ylabel("accuracy (%)")
    ax.set_title("AFOP-ML D-scan (closed-set training data)")
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right", fontsize=8)
    return save_figure(fig, path)


def _ordered_methods(records: Sequence[dict]) -> list[str]:
    paper, beyond = paper_first([r["method"] for r in select(records, "accuracy")])
    return [*paper, *beyond]


def generalisation_curves(records: Sequence[dict], path: str | Path) -> Path:
    """Fig. 5: 1-shot accuracy vs N-way per protocol, one line + 95 % CI band per method,
    the closed-set AFOP-ML curve (``protocol="closed-set", condition="reference"``) dashed.
    Uses the across-fold records (``fold=None``). The perturbation protocol has one panel
    per reading (within one condition, pooled, enrolled at nominal); the paper's methods
    are drawn with solid lines, the methods beyond the paper dotted."""
    methods = _ordered_methods(records)
    _, beyond = paper_first(methods)
    fig, grid = plt.subplots(2, 3, figsize=(15, 8.4), sharey=True)
    axes = grid.ravel()
    ref = _curve(records, protocol="closed-set", condition="reference", shot=1)
    for ax, (protocol, condition, title) in zip(axes, GENERALISATION_PANELS, strict=False):
        for m in methods:
            way, acc, ci = _curve(
                records, protocol=protocol, condition=condition, method=m, fold=None, shot=1
            )
            if way.size == 0:
                continue
            c = METHOD_COLOURS.get(m)
            style = ":" if m in beyond else "-"
            ax.plot(way, acc, marker="o", ms=3, lw=1.4, ls=style, color=c, label=m)
            ax.fill_between(way, acc - ci, acc + ci, color=c, alpha=0.2)
        if ref[0].size:
            ax.plot(ref[0], ref[1], "k--", lw=1.3, label="closed-set AFOP-ML")
        ax.set_title(title)
        ax.set_xlabel("N-way (1-shot)")
        ax.set_xticks(range(2, 13))
        ax.grid(alpha=0.3)
    for ax in (axes[0], axes[3]):
        ax.set_ylabel("accuracy (%)")
    handles, labels = [], []
    for ax in axes[: len(GENERALISATION_PANELS)]:
        for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
            if lab not in labels:
                handles.append(h)
                labels.append(lab)
    legend_ax = axes[-1]
    legend_ax.axis("off")
    legend_ax.legend(
        handles, labels, loc="center", fontsize=9, title="solid: paper; dotted: beyond"
    )
    fig.tight_layout()
    return save_figure(fig, path)


def perturbation_heatmap(
    records: Sequence[dict],
    path: str | Path,
    *,
    methods: Sequence[str] = ("AFOP-ML",),
    way: int = 5,
    nominal_method: str = "AFOP-ML",
    reading: str | None = None,
) -> Path:
    """5-way-1-shot accuracy over the force x speed grid, one panel per method (every
    method of ``methods`` that has perturbation records, :data:`HEATMAP_COLUMNS` per row),
    of one reading: ``None`` within one condition (``condition="force=..."``), or a named
    reading's per-condition records (``"enrolled"``: ``condition="enrolled:force=..."``).

    The perturbation dataset leaves out the nominal condition; where the grid has a hole
    at 1 N / 10 mm/s, the AFOP-ML panel shows the closed-set reference (nominal test half,
    ``condition="reference"``) there, labelled "nominal", for comparison.
    """
    nominal = next(
        iter(select(records, "accuracy", protocol="closed-set", condition="reference", way=way)),
        None,
    )
    panels = []
    for m in methods:
        cells = {}
        for r in select(records, "accuracy", protocol="perturbation", method=m, way=way, shot=1):
            of, fs = condition_reading(r["condition"])
            if fs is not None and of == reading:
                cells[fs] = r
        if cells:
            panels.append((m, cells))
    if not panels:
        raise ValueError("no per-condition perturbation records to draw")
    n_cols = min(len(panels), HEATMAP_COLUMNS)
    n_rows = -(-len(panels) // n_cols)
    fig, axes = plt.subplots(
        n_rows,
        n_cols,
        figsize=(5.2 * n_cols, 4.0 * n_rows),
        squeeze=False,
        layout="constrained",
    )
    for ax in axes.ravel()[len(panels) :]:
        ax.set_visible(False)
    for ax, (m, cells) in zip(axes.ravel(), panels, strict=False):
        forces = sorted({f for f, _ in cells})
        speeds = sorted({s for _, s in cells})
        hole = (NOMINAL_FORCE_N, NOMINAL_SPEED_MM_S)
        if m == nominal_method and nominal is not None and hole not in cells:
            if hole[0] in forces and hole[1] in speeds:
                cells = {**cells, hole: {**nominal, "nominal": True}}
        grid = np.full((len(forces), len(speeds)), np.nan)
        for (f, s), r in cells.items():
            grid[forces.index(f), speeds.index(s)] = r["accuracy"] * 100
        im = ax.imshow(
            grid, origin="lower", cmap="viridis", vmin=100 / way, vmax=100, aspect="auto"
        )
        for i in range(len(forces)):
            for j in range(len(speeds)):
                if not np.isfinite(grid[i, j]):
                    ax.text(j, i, "not in grid", ha="center", va="center", fontsize=7)
                    continue
                r = cells[(forces[i], speeds[j])]
                tag = "nominal\n(closed-set)\n" if r.get("nominal") else ""
                ax.text(
                    j,
                    i,
                    f"{tag}{grid[i, j]:.1f}\n±{r['ci95'] * 100:.1f}",
                    ha="center",
                    va="center",
                    fontsize=7,
                    color="w" if grid[i, j] < 70 else "k",
                )
        ax.set_xticks(range(len(speeds)), [f"{s:g}" for s in speeds])
        ax.set_yticks(range(len(forces)), [f"{f:g}" for f in forces])
        ax.set_xlabel("sliding speed (mm/s)")
        ax.set_ylabel("normal force (N)")
        where = "within condition" if reading is None else f"{reading} at nominal"
        ax.set_title(f"{m}: {way}-way-1-shot accuracy (%), {where}", fontsize=9)
        fig.colorbar(im, ax=ax, fraction=0.046)
    return save_figure(fig, path)


def selection_bars(records: Sequence[dict], path: str | Path) -> Path:
    """Fig. 6: median chosen D per protocol (bars, left axis) and the PVDF / SG shares of
    the selected features (lines, right axis), medians over folds/splits."""
    labels, med_d, pvdf, sg, n = [], [], [], [], []
    for protocol, label in SELECTION_ORDER:
        rs = select(records, "selection", protocol=protocol)
        if not rs:
            continue
        labels.append(label)
        med_d.append(float(np.median([r["D"] for r in rs])))
        pvdf.append(float(np.median([r["pvdf_share"] for r in rs])) * 100)
        sg.append(float(np.median([r["sg_share"] for r in rs])) * 100)
        n.append(len(rs))
    if not labels:
        raise ValueError("no selection records to draw")
    fig, ax = plt.subplots(figsize=(6, 3.8))
    x = np.arange(len(labels))
    bars = ax.bar(x, med_d, color="tab:blue", alpha=0.7, label="median D")
    for b, d, k in zip(bars, med_d, n, strict=True):
        ax.text(
            b.get_x() + b.get_width() / 2,
            d,
            f"{d:g}\n(n={k})",
            ha="center",
            va="bottom",
            fontsize=8,
        )
    ax.set_xticks(x, labels)
    ax.set_ylabel("median selected D")
    ax.set_ylim(0, max(med_d) * 1.35 + 1)
    ax2 = ax.twinx()
    ax2.plot(x, pvdf, "o-", color="tab:red", label="PVDF share")
    ax2.plot(x, sg, "s--", color="tab:green", label="SG share")
    ax2.set_ylim(0, 105)
    ax2.set_ylabel("share of selected features (%)")
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, loc="upper left", fontsize=8)
    ax.set_title("AFOP-ML: adaptive D and sensor contributions")
    return save_figure(fig, path)


def tsne_scatter(
    emb: np.ndarray,
    shape: np.ndarray,
    material: np.ndarray,
    indicators: Mapping[str, float],
    path: str | Path,
    *,
    d: int,
) -> Path:
    """Fig. 7: t-SNE ``(n, 2)`` scatter, marker = shape, colour = material."""
    fig, ax = plt.subplots(figsize=(7.5, 6))
    shapes = names_in_order(shape, SHAPE_NAMES)
    materials = names_in_order(material, MATERIAL_NAMES)
    for s_i, s in enumerate(shapes):
        for m in materials:
            sel = (shape == s) & (material == m)
            if np.any(sel):
                ax.scatter(
                    emb[sel, 0],
                    emb[sel, 1],
                    marker=SHAPE_MARKERS[s_i % len(SHAPE_MARKERS)],
                    s=22,
                    color=material_colour(m, materials),
                    alpha=0.75,
                    linewidths=0.3,
                    edgecolors="k",
                )
    shape_handles = [
        plt.Line2D(
            [],
            [],
            marker=SHAPE_MARKERS[i % len(SHAPE_MARKERS)],
            ls="",
            color="k",
            label=f"S{SHAPE_NAMES.index(s) + 1} {s}" if s in SHAPE_NAMES else s,
        )
        for i, s in enumerate(shapes)
    ]
    mat_handles = [
        plt.Line2D([], [], marker="o", ls="", color=material_colour(m, materials), label=m)
        for m in materials
    ]
    ax.legend(
        handles=shape_handles + mat_handles,
        fontsize=7,
        loc="center left",
        bbox_to_anchor=(1.01, 0.5),
    )
    lines = [f"t-SNE of closed-set top-{d} features"]
    for prefix, where in (("", f"top-{d} space"), ("embedding_", "2-D embedding")):
        if f"{prefix}nn1_shape_accuracy" in indicators:
            lines.append(
                f"{where}: 1-NN={indicators[prefix + 'nn1_shape_accuracy']:.3f}  "
                f"mix-sil={indicators[prefix + 'mix_sil']:.3f}  "
                f"DGI={indicators[prefix + 'dgi']:.3f}"
            )
    ax.set_title("\n".join(lines), fontsize=10)
    ax.set_xticks([])
    ax.set_yticks([])
    return save_figure(fig, path)


def example_signals(data: Dataset, path: str | Path) -> Path:
    """The first trial of each class in a shapes x materials grid, drawn as
    :func:`synth.plot.plot_example_grid` draws a store's examples."""
    from synth.plot import example_rows, plot_example_grid
    from synth.presets import condition_name

    n = len(data)
    rows = example_rows(data.label, np.zeros(n, dtype=np.int64), np.ones(n, dtype=bool))
    names = {cls: f"{data.shape[i]}/{data.material[i]}" for cls, i in rows.items()}
    return plot_example_grid(
        {names[cls]: data.signals[i] for cls, i in rows.items()},
        path,
        shapes=list(data.specimens),
        materials=list(data.materials),
        channels=CHANNELS,
        sample_rate_hz=SAMPLE_RATE_HZ,
        notes={
            names[cls]: condition_name(float(data.force_n[i]), float(data.speed_mm_s[i]))
            for cls, i in rows.items()
        },
        title="Example signals: the first trial of each class",
    )


#: The perturbation heat maps: figure key and reading (None: within one condition).
HEATMAPS: tuple[tuple[str, str | None], ...] = (
    ("perturbation_heatmap", None),
    ("perturbation_heatmap_enrolled", ENROLLED),
)
#: Figure key -> file name (fixed, so reports and READMEs can link them).
FIGURE_FILES: dict[str, str] = {
    "dscan": "dscan.png",
    "generalisation": "generalisation.png",
    "perturbation_heatmap": "perturbation_heatmap.png",
    "perturbation_heatmap_enrolled": "perturbation_heatmap_enrolled.png",
    "selection": "selection.png",
    "tsne": "tsne.png",
    "signals": "example_signals.png",
}


def draw_figures(
    records: Sequence[Mapping[str, Any]], data: Dataset, art: Artefacts, out: Path
) -> dict[str, str]:
    """Write every PNG into ``out``; returns figure key -> file name (relative)."""
    made: dict[str, str] = {}
    if art.dscan is not None:
        dscan_curve(art.dscan, art.chosen_d, out / FIGURE_FILES["dscan"])
        made["dscan"] = FIGURE_FILES["dscan"]
    generalisation_curves(records, out / FIGURE_FILES["generalisation"])
    made["generalisation"] = FIGURE_FILES["generalisation"]
    pert = select(records, "accuracy", protocol="perturbation")
    pert_methods = _ordered_methods(pert)
    for key, reading in (
        ("perturbation_heatmap", None),
        ("perturbation_heatmap_enrolled", ENROLLED),
    ):
        if any(
            condition_reading(r["condition"])[0] == reading
            and condition_reading(r["condition"])[1] is not None
            for r in pert
        ):
            perturbation_heatmap(
                records, out / FIGURE_FILES[key], methods=pert_methods, reading=reading
            )
            made[key] = FIGURE_FILES[key]
    selection_bars(records, out / FIGURE_FILES["selection"])
    made["selection"] = FIGURE_FILES["selection"]
    tsne_scatter(
        art.emb, art.shape, art.material, art.indicators, out / FIGURE_FILES["tsne"], d=art.chosen_d
    )
    made["tsne"] = FIGURE_FILES["tsne"]
    example_signals(data, out / FIGURE_FILES["signals"])
    made["signals"] = FIGURE_FILES["signals"]
    return made


def _episodes_of(records: Sequence[Mapping[str, Any]], **match: Any) -> str:
    eps: dict[str, set[int]] = {}
    for r in select(records, "accuracy", **match):
        eps.setdefault(r["method"], set()).add(r["episodes"])
    return ", ".join(f"{m} {'/'.join(map(str, sorted(e)))}" for m, e in eps.items())


def figure_notes(records: Sequence[Mapping[str, Any]], art: Artefacts, seed: int) -> dict[str, str]:
    """One-paragraph summary of each figure: what it shows, numbers, episode counts."""

    def _one(records: Sequence[Mapping[str, Any]], **match: Any) -> Mapping[str, Any] | None:
        return next(iter(select(records, "accuracy", **match)), None)

    notes: dict[str, str] = {}
    if art.dscan is not None:
        d = np.asarray(art.dscan["D"])
        notes["dscan"] = (
            f"AFOP-ML validation accuracy vs number of top-ranked features D "
            f"({int(d.min())}..{int(d.max())}) on held-out episodes of the closed-set "
            f"training half, 95 % CI band; chosen D = {art.chosen_d}."
        )
    parts = []
    for protocol, cond, _ in GENERALISATION_PANELS:
        a2 = _one(records, protocol=protocol, condition=cond, fold=None, method="AFOP-ML", way=2)
        a12 = _one(records, protocol=protocol, condition=cond, fold=None, method="AFOP-ML", way=12)
        if a2 and a12:
            label = protocol if cond is None else f"{protocol} ({cond})"
            parts.append(
                f"{label}: AFOP-ML {100 * a2['accuracy']:.1f} % (2-way) → "
                f"{100 * a12['accuracy']:.1f} % (12-way), episodes per way "
                f"[{_episodes_of(records, protocol=protocol, condition=cond, fold=None, way=5)}]"
            )
    notes["generalisation"] = (
        "1-shot accuracy vs N (2..12) with 95 % CI bands per method (the paper's methods "
        "solid, the methods beyond the paper dotted); the force/speed perturbation in three "
        "panels, one per reading of where support and queries come from (within one "
        "condition, all conditions pooled, enrolled at nominal), none promoted; the dashed "
        f"black line is closed-set AFOP-ML ({art.reference_episodes} episodes per way). "
        + "; ".join(parts)
        + "."
    )
    notes["perturbation_heatmap"] = (
        "5-way-1-shot accuracy per force x speed condition after fitting at the nominal "
        "1 N / 10 mm/s, support and queries within each condition; episodes per cell: "
        f"[{_episodes_of(records, protocol='perturbation', way=5)}]."
    )
    notes["perturbation_heatmap_enrolled"] = (
        "The same grid with the support enrolled at nominal: support examples from the "
        "nominal dataset's closed-set test half, queries from each perturbed condition."
    )
    sel = select(records, "selection")
    notes["selection"] = (
        "Median AFOP-ML D per task (bars) and PVDF / SG shares of the selected features "
        f"(lines); {len(sel)} fits (3 folds each for cross-shape and cross-material, 1 each "
        "for closed-set and perturbation)."
    )
    ind = art.indicators
    notes["tsne"] = (
        f"t-SNE of the {art.emb.shape[0]} closed-set test-half trials in AFOP-ML's "
        f"top-{art.chosen_d} feature space; markers = shape, colours = material. In the "
        f"top-{art.chosen_d} space: 1-NN = {ind['nn1_shape_accuracy']:.3f}, mix-sil = "
        f"{ind['mix_sil']:.3f}, DGI = {ind['dgi']:.3f}; on the 2-D embedding drawn: "
        f"1-NN = {ind.get('embedding_nn1_shape_accuracy', float('nan')):.3f}, mix-sil = "
        f"{ind.get('embedding_mix_sil', float('nan')):.3f}, DGI = "
        f"{ind.get('embedding_dgi', float('nan')):.3f} (t-SNE seed {seed})."
    )
    notes["signals"] = (
        "The first trial of each class, 4 channels each, every channel standardised over "
        "the plotted trials."
    )
    return notes
