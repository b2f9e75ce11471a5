"""report.md: the benchmark's results as a researcher reads them.

Built only from results.json records plus a small ``meta`` dict (seed, datasets, episode
budgets, figure files), so the same records give the same report. Wall-clock timings are
machine- and load-dependent: they appear only in the section between the
``<!-- timing -->`` and ``<!-- /timing -->`` markers, which is the only part of the
report allowed to differ between two runs with the same seed (see
:func:`strip_timing`).
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from models.registry import beyond_the_paper_note, paper_first
from synth import Dataset

from . import paper_reference as paper
from .checkpoints import fingerprint
from .labels import ENROLLED, READINGS, condition_reading
from .results import select
from .tables import (
    BEYOND_THE_PAPER,
    episodes_note,
    markdown_table,
    method_rows,
    ms,
    pct,
    table_one_lines,
)

TIMING_START = "<!-- timing -->"
TIMING_END = "<!-- /timing -->"
GENERALISATION = ("cross-shape", "cross-material", "perturbation")
_TIMING_RE = re.compile(re.escape(TIMING_START) + r".*?" + re.escape(TIMING_END), re.S)


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


def _plural(n: int, word: str) -> str:
    return f"{n} {word}" + ("" if n == 1 else "s")


def generalisation_titles(records: Sequence[dict], meta: Mapping[str, Any]) -> dict[str, str]:
    """The generalisation protocols' section titles, from the folds the dataset gave."""
    folds = [list(f) for f in meta.get("cross_shape_folds") or ()]
    sizes = sorted({len(f) for f in folds})
    if folds:
        size = str(sizes[0]) if len(sizes) == 1 else f"{sizes[0]}-{sizes[-1]}"
        shape = f"{_plural(len(folds), 'fixed fold')} of {size} unseen shape"
        shape += "" if sizes == [1] else "s"
    else:
        shape = "fixed folds of unseen shapes"
    trained = list(
        dict.fromkeys(
            r["fold"] for r in _acc(records, protocol="cross-material") if r["fold"] is not None
        )
    )
    material = (
        f"train on 1 material, test on the other {len(trained) - 1}"
        if len(trained) > 1
        else "train on 1 material, test on the others"
    )
    return {
        "cross-shape": f"### Cross-shape ({shape})",
        "cross-material": f"### Cross-material ({material})",
        "perturbation": "### Force/speed perturbation (fitted at the nominal condition)",
    }


def strip_timing(text: str) -> str:
    """The report without its timing section (the part that is not reproducible)."""
    return _TIMING_RE.sub(TIMING_START + TIMING_END, text)


def _acc(records: Sequence[dict], **match: Any) -> list[dict]:
    return select(records, "accuracy", **match)


def _one(records: Sequence[dict], **match: Any) -> dict | None:
    rs = _acc(records, **match)
    return rs[0] if rs else None


def _methods(records: Sequence[dict], protocol: str) -> list[str]:
    """The methods of ``protocol``'s records: the paper's in Table I's order, then the
    others."""
    paper_methods, beyond = paper_first([r["method"] for r in _acc(records, protocol=protocol)])
    return [*paper_methods, *beyond]


# -- sections ------------------------------------------------------------------------------
def closed_set_section(records: Sequence[dict]) -> list[str]:
    """Table-I-like closed-set accuracy table (accuracy only; times are in the timing
    section) and AFOP-ML side by side with the paper's Table I."""
    rs = _acc(records, protocol="closed-set", condition=None)
    if not rs:
        return ["## Closed-set (Table I)", "", "Not run.", ""]
    lines = ["## Closed-set accuracy (Table I)", ""]
    lines.append(
        "Accuracy in % (mean ± 95 % CI over episodes); each cell from its own episodes "
        "(count in the last column). Columns: K-shot / N-way."
    )
    lines.append("")
    lines += table_one_lines(rs, timing=False)
    lines += ["", "### AFOP-ML here vs the paper's Table I", ""]
    lines.append(
        f"Paper values typed in from {paper.CITATION} (real sensor data); ours on the "
        "synthetic dataset. Difference = ours − paper, in percentage points (pp)."
    )
    lines.append("")
    side = []
    for k, n in paper.TABLE_ONE_COLUMNS:
        ours = _one(rs, method="AFOP-ML", shot=k, way=n)
        ref = paper.TABLE_ONE_ACCURACY_PCT["AFOP-ML"][(k, n)]
        diff = "-" if ours is None else f"{100 * ours['accuracy'] - ref:+.2f}"
        side.append([f"{k}-shot {n}-way", pct(ours), f"{ref:.2f}", diff])
    lines += markdown_table(
        ["task", "AFOP-ML here (%)", "AFOP-ML paper (%)", "difference (pp)"], side
    )
    lines += ["", "### Every method's 1-shot row beside the paper's Table I", ""]
    lines.append(
        "Accuracy in %: here (mean ± 95 % CI), the paper's Table I, and here − paper in "
        "percentage points. Methods beyond the paper have no row in Table I."
    )
    lines.append("")
    one_shot = [(k, n) for k, n in paper.TABLE_ONE_COLUMNS if k == 1]
    header = ["method", "", *[f"{n}-way" for _, n in one_shot]]

    def rows_of(m: str) -> list[list[str]]:
        ours = [_one(rs, method=m, shot=k, way=n) for k, n in one_shot]
        out = [[m, "here", *[pct(r) for r in ours]]]
        ref = paper.TABLE_ONE_ACCURACY_PCT.get(m)
        if ref is not None:
            out.append(["", "paper", *[f"{ref[c]:.2f}" for c in one_shot]])
            out.append(
                [
                    "",
                    "here − paper (pp)",
                    *[
                        "-" if r is None else f"{100 * r['accuracy'] - ref[c]:+.2f}"
                        for r, c in zip(ours, one_shot, strict=True)
                    ],
                ]
            )
        return out

    paper_methods, beyond = paper_first(_methods(rs, "closed-set"))
    rows = [row for m in paper_methods for row in rows_of(m)]
    if beyond:
        rows.append([f"**{BEYOND_THE_PAPER}**", *[""] * (len(header) - 1)])
        rows += [row for m in beyond for row in rows_of(m)]
    lines += markdown_table(header, rows)
    return [*lines, ""]


def _curve_table(records: Sequence[dict], protocol: str, condition: str | None) -> list[str]:
    rs = [r for r in _acc(records, protocol=protocol, condition=condition) if r["fold"] is None]
    ways = sorted({r["way"] for r in rs})
    header = ["method", *[f"{w}-way" for w in ways], "episodes/way"]

    def row(m: str) -> list[str]:
        cells = [pct(_one(rs, method=m, way=w)) for w in ways]
        return [m, *cells, episodes_note([r for r in rs if r["method"] == m])]

    rows = method_rows(_methods(rs, protocol), row, len(header))
    ref = [r for r in _acc(records, protocol="closed-set", condition="reference")]
    if ref:
        rows.append(
            [
                "closed-set AFOP-ML (reference)",
                *[pct(_one(ref, way=w)) for w in ways],
                episodes_note(ref),
            ]
        )
    return markdown_table(header, rows)


def _drop_lines(records: Sequence[dict], protocol: str, condition: str | None) -> list[str]:
    """AFOP-ML's 5-way drop below the closed-set curve and its 12-way lead over
    AFO-MLP-ML, each beside the paper's figure."""
    out = []
    ours5 = _one(
        records, protocol=protocol, condition=condition, fold=None, method="AFOP-ML", way=5
    )
    ref5 = _one(records, protocol="closed-set", condition="reference", way=5)
    if ours5 and ref5:
        drop = 100 * (ref5["accuracy"] - ours5["accuracy"])
        ref = f" (paper: {paper.GENERALISATION_DROP_5WAY_PP[protocol]:.1f} pp)"
        out.append(f"- AFOP-ML 5-way-1-shot drop below the closed-set curve: {drop:.1f} pp{ref}.")
    a12 = _one(records, protocol=protocol, condition=condition, fold=None, method="AFOP-ML", way=12)
    b12 = _one(
        records, protocol=protocol, condition=condition, fold=None, method="AFO-MLP-ML", way=12
    )
    if a12 and b12:
        gap = 100 * (a12["accuracy"] - b12["accuracy"])
        ref = f" (paper: +{paper.GAP_TO_AFO_MLP_12WAY_PP[protocol]:.1f} pp)"
        out.append(f"- AFOP-ML minus AFO-MLP-ML at 12-way-1-shot: {gap:+.1f} pp{ref}.")
    return out


def generalisation_section(records: Sequence[dict], meta: Mapping[str, Any]) -> list[str]:
    lines = ["## Generalisation to unseen domains, 1-shot (Fig. 5)", ""]
    lines.append(
        "Accuracy in % (mean ± 95 % CI). Cross-shape and cross-material: over all folds' "
        "episodes together (per-fold tables below for AFOP-ML). Perturbation: the paper's "
        '"testing on multiple perturbed force-speed combinations" allows more than one '
        "reading of where an episode's support and queries come from, so each reading "
        "has its own table, side by side, none promoted. The last row of every table is "
        "the closed-set AFOP-ML 1-shot curve on the closed-set test half (Fig. 5's dashed "
        "line)."
    )
    lines.append("")
    titles = generalisation_titles(records, meta)
    for protocol in GENERALISATION:
        if not _acc(records, protocol=protocol):
            lines += [titles[protocol], "", "Not run.", ""]
            continue
        lines += [titles[protocol], ""]
        if protocol == "perturbation":
            lines += perturbation_readings(records)
            continue
        if protocol == "cross-shape" and "cross_shape_folds" in meta:
            folds = "; ".join(
                f"fold {i}: {', '.join(f)}" for i, f in enumerate(meta["cross_shape_folds"])
            )
            lines += [f"Test shapes per fold: {folds}.", ""]
        lines += _curve_table(records, protocol, None)
        lines.append("")
        lines += _drop_lines(records, protocol, None)
        if protocol != "perturbation":
            folds = [
                r
                for r in _acc(records, protocol=protocol, method="AFOP-ML")
                if r["fold"] is not None
            ]
            if folds:
                lines += ["", "AFOP-ML per fold:", ""]
                fold_ids = list(dict.fromkeys(r["fold"] for r in folds))
                ways = sorted({r["way"] for r in folds})
                rows = [
                    [str(f), *[pct(_one(folds, fold=f, way=w)) for w in ways]] for f in fold_ids
                ]
                lines += markdown_table(["fold", *[f"{w}-way" for w in ways]], rows)
        lines.append("")
    return lines


#: The readings of the perturbation protocol with per-condition records: (reading of
#: :func:`benchmark.labels.condition_reading`, title).
HEATMAP_READINGS: tuple[tuple[str | None, str], ...] = (
    (None, "within one condition (support and queries from it)"),
    (ENROLLED, "enrolled at nominal (support from the nominal test half, queries from it)"),
)


def _pp(a: Mapping[str, Any], b: Mapping[str, Any]) -> float:
    """``a``'s accuracy minus ``b``'s, in percentage points."""
    return 100 * (a["accuracy"] - b["accuracy"])


def perturbation_readings(records: Sequence[dict]) -> list[str]:
    """The perturbation protocol's readings side by side: a summary of AFOP-ML's 5-way
    drop below the closed-set curve and its 12-way lead over AFO-MLP-ML per reading,
    beside the paper's single figure, then one curve table per reading."""
    lines = [
        "Every method is fitted once at the nominal condition (the closed-set fit). The readings:",
        "",
    ]
    present = [
        (c, text) for c, text in READINGS if _acc(records, protocol="perturbation", condition=c)
    ]
    for condition, text in present:
        lines.append(f"- **{condition}**: {text}.")
    lines.append("")
    rows = []
    ref5 = _one(records, protocol="closed-set", condition="reference", way=5)
    for condition, _ in present:
        a5 = _one(records, protocol="perturbation", condition=condition, method="AFOP-ML", way=5)
        a12 = _one(records, protocol="perturbation", condition=condition, method="AFOP-ML", way=12)
        b12 = _one(
            records, protocol="perturbation", condition=condition, method="AFO-MLP-ML", way=12
        )
        drop = "-" if a5 is None or ref5 is None else f"{_pp(ref5, a5):.1f}"
        gap = "-" if a12 is None or b12 is None else f"{_pp(a12, b12):+.1f}"
        rows.append([condition, drop, gap])
    rows.append(
        [
            "paper (one figure; its wording allows each reading)",
            f"{paper.GENERALISATION_DROP_5WAY_PP['perturbation']:.1f}",
            f"+{paper.GAP_TO_AFO_MLP_12WAY_PP['perturbation']:.1f}",
        ]
    )
    lines += markdown_table(
        [
            "reading",
            "AFOP-ML 5-way-1-shot drop below the closed-set curve (pp)",
            "AFOP-ML − AFO-MLP-ML at 12-way-1-shot (pp)",
        ],
        rows,
    )
    lines.append("")
    for condition, text in present:
        lines += [f"#### {condition}: {text}", ""]
        lines += _curve_table(records, "perturbation", condition)
        lines.append("")
    return lines


def perturbation_grid_section(records: Sequence[dict]) -> list[str]:
    rs = [
        r
        for r in _acc(records, protocol="perturbation", way=5)
        if condition_reading(r["condition"])[1] is not None
    ]
    if not rs:
        return []
    lines = ["## Perturbation heat maps: 5-way-1-shot accuracy per force/speed condition", ""]
    lines.append(
        "Accuracy in % (mean ± 95 % CI); rows: normal force, columns: sliding speed. One map "
        "per reading that has per-condition results, side by side (the pooled reading has "
        "none: its episodes mix the conditions)."
    )
    lines.append("")
    for reading, title in HEATMAP_READINGS:
        mine = [r for r in rs if condition_reading(r["condition"])[0] == reading]
        if not mine:
            continue
        lines += [f"### {title}", ""]
        for m in _methods(mine, "perturbation"):
            mr = [r for r in mine if r["method"] == m]
            cells = {condition_reading(r["condition"])[1]: r for r in mr}
            forces = sorted({f for f, _ in cells})
            speeds = sorted({s for _, s in cells})
            lines += [f"**{m}** ({episodes_note(mr)} episodes per cell):", ""]
            rows = [[f"{f:g} N", *[pct(cells.get((f, s))) for s in speeds]] for f in forces]
            lines += markdown_table(["force \\ speed", *[f"{s:g} mm/s" for s in speeds]], rows)
            lines.append("")
    return lines


def other_protocols_section(records: Sequence[dict]) -> list[str]:
    """Accuracy tables of protocols other than the paper's four (plug-ins): per method,
    one column per (shot, way), over all folds where the protocol has folds."""
    known = ("closed-set", *GENERALISATION)
    others = dict.fromkeys(r["protocol"] for r in _acc(records) if r["protocol"] not in known)
    lines: list[str] = []
    for protocol in others:
        rs = _acc(records, protocol=protocol)
        rs = [r for r in rs if r["fold"] is None] or rs
        for condition in dict.fromkeys(r["condition"] for r in rs):
            mine = [r for r in rs if r["condition"] == condition]
            cells = sorted({(r["shot"], r["way"]) for r in mine})
            title = protocol if condition is None else f"{protocol}, {condition}"
            lines += [f"## Protocol {title}", ""]
            lines.append("Accuracy in % (mean ± 95 % CI); columns: K-shot / N-way.")
            lines.append("")
            rows = []
            for m in dict.fromkeys(r["method"] for r in mine):
                row = [pct(_one(mine, method=m, shot=k, way=n)) for k, n in cells]
                rows.append([m, *row, episodes_note([r for r in mine if r["method"] == m])])
            header = ["method", *[f"{k}-shot {n}-way" for k, n in cells], "episodes"]
            lines += [*markdown_table(header, rows), ""]
    return lines


#: Features of each fit's NCA ranking that the report names.
RANKING_HEAD = 4

_TASKS = (
    ("cross-shape", "Shape"),
    ("closed-set", "Closed-set"),
    ("perturbation", "Force&Speed (the closed-set fit)"),
    ("cross-material", "Material"),
)


def ranking_heads(selection: Sequence[dict]) -> list[str]:
    """The first :data:`RANKING_HEAD` features of every fit's NCA ranking, by name: what
    the shares above are made of. Empty when no record holds its selected features."""
    from models.features import FEATURE_NAMES

    rows = []
    for protocol, label in _TASKS:
        if protocol == "perturbation":  # the closed-set fit, listed once
            continue
        for r in selection:
            if r["protocol"] != protocol or not r.get("selected"):
                continue
            fold = "-" if r.get("fold") is None else str(r["fold"])
            head = [int(i) for i in r["selected"][:RANKING_HEAD]]
            bad = [i for i in head if not 0 <= i < len(FEATURE_NAMES)]
            if bad:
                raise ValueError(
                    f"selection record ({protocol}, fold {fold}): selected holds feature "
                    f"index {bad[0]}, outside the {len(FEATURE_NAMES)}-feature pool"
                )
            names = [FEATURE_NAMES[i] for i in head]
            rows.append([label, fold, ", ".join(f"`{n}`" for n in names)])
    if not rows:
        return []
    return [
        f"The first {RANKING_HEAD} features of each fit's NCA ranking, best first (names are "
        "`<channel>.<domain>.<statistic>`; `pvdf*` and `sg*` channels give the shares above):",
        "",
        *markdown_table(["task", "fold", "first features"], rows),
        "",
    ]


def interpretability_section(records: Sequence[dict]) -> list[str]:
    lines = ["## Interpretability (Fig. 6, Fig. 7)", ""]
    sel = select(records, "selection")
    if sel:
        lines.append(
            "AFOP-ML's chosen D and the share of PVDF / SG features among its top-D, "
            "median over folds/splits (per-fold values in brackets). Paper values from "
            "Section V-D. Force&Speed: the perturbation protocol trains at the nominal "
            "condition only, with the closed-set split and fit, so its D is the closed-set "
            "D by construction (choosing D on perturbed trials would use test conditions)."
        )
        lines.append("")
        rows = []
        for protocol, label in _TASKS:
            rs = [r for r in sel if r["protocol"] == protocol]
            if not rs:
                continue
            ds = [r["D"] for r in rs]
            pv = [r["pvdf_share"] for r in rs]
            sg = [r["sg_share"] for r in rs]
            ref_pv = paper.PVDF_SHARE.get(protocol)
            rows.append(
                [
                    label,
                    f"{np.median(ds):g} ({', '.join(str(d) for d in ds)})",
                    str(paper.MEDIAN_D.get(protocol, "-")),
                    f"{100 * np.median(pv):.1f}",
                    f"{100 * np.median(sg):.1f}",
                    "-" if ref_pv is None else f"{100 * ref_pv:.1f}",
                ]
            )
        lines += markdown_table(
            [
                "task",
                "median D here (per fold)",
                "D paper",
                "PVDF % here",
                "SG % here",
                "PVDF % paper",
            ],
            rows,
        )
        lines.append("")
        lines += ranking_heads(sel)
    tsne = select(records, "tsne")
    if tsne:
        t = tsne[0]
        d = t.get("D", "?")
        k = t.get("dgi_k") or "?"
        lines.append(
            f"The paper's Fig. 7 indicators of the closed-set test-half trials in AFOP-ML's "
            f"top-{d} feature space (each feature standardised, Euclidean distance: where "
            "the paper's caption places them, since its t-SNE is \"used only for qualitative "
            'visualization"), and the same indicators of the 2-D t-SNE embedding of those '
            "trials (the figure), beside the paper's values:"
        )
        lines.append("")
        ref = paper.TSNE_INDICATORS

        def num(value: object) -> str:
            return "-" if value is None else f"{value:.3f}"

        lines += markdown_table(
            [
                "indicator",
                f"top-{d} space here",
                "2-D t-SNE embedding here",
                f"paper (D={paper.TSNE_D})",
            ],
            [
                [
                    "1-NN shape accuracy",
                    num(t["nn1_shape_accuracy"]),
                    num(t.get("embedding_nn1_shape_accuracy")),
                    f"{ref['nn1_shape_accuracy']:.3f}",
                ],
                [
                    "mix-sil (0-1 material mixing)",
                    num(t["mix_sil"]),
                    num(t.get("embedding_mix_sil")),
                    f"{ref['mix_sil']:.3f}",
                ],
                [
                    f"DGI (cross- / same-material same-shape neighbours, k = {k})",
                    num(t["dgi"]),
                    num(t.get("embedding_dgi")),
                    f"{ref['dgi']:.3f}",
                ],
            ],
        )
        lines.append("")
        if t.get("dgi_random") is not None:
            lines.append(
                f"Materials randomly mixed within each shape would give a DGI of "
                f"{t['dgi_random']:.3f} on these labels (the ratio of the same-shape pairs "
                "of points with different and with the same material)."
            )
            lines.append("")
    lines += [
        "Indicator definitions (t-SNE: scikit-learn, PCA init, perplexity min(30, (n-1)/3), "
        "features standardised per column first; Euclidean distance in either space):",
        "",
        "- **1-NN shape accuracy**: leave-one-out 1-nearest-neighbour accuracy of the "
        "shape label (each trial's nearest other trial has its shape). Chance ≈ 1 / the "
        "number of shapes (1/12 on the paper's).",
        "- **mix-sil**: within each shape's trials, the silhouette coefficient of the "
        "material labels; s = trial-weighted mean over shapes; mix-sil = 1 − clip(s, 0, 1). "
        "1 = materials do not form sub-clusters inside a shape cluster; 0 = each material "
        "is a perfectly separated sub-cluster.",
        '- **DGI**, the paper\'s "ratio of cross-material to same-material neighbors": in '
        "the k-nearest-neighbour graph of the trials, among the edges joining two trials "
        "of the same shape, the number joining different materials divided by the number "
        "joining the same material. Random mixing of the materials within each shape "
        "gives about 2n/(n−1) with n trials per class (the value above); material "
        'sub-clusters drive it towards 0. The paper calls it "Distance to Geometric '
        'Impostor" but defines it by neighbour counts; docs/results.md discusses the '
        "reading.",
        "",
    ]
    return lines


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


def timing_section(records: Sequence[dict]) -> list[str]:
    """Single-episode latency next to the paper's Table I times, then batched throughput
    in a separate table (the two are different measures)."""
    lines = [
        TIMING_START,
        "## Timing (wall clock; machine- and load-dependent, not part of the reproducible numbers)",
        "",
        "### Single-episode latency, closed-set 5-way-5-shot (the paper's Table I measure)",
        "",
        "Latency = mean wall time of adapting ONE episode at a time (support and queries "
        "of that episode only) and labelling its queries, in ms, without / with extracting "
        "the 386-feature pool of the episode's trials from raw signals (methods that read "
        "raw signals preprocess inside both). Pretrain = one fit on the training half (s). "
        "Paper: i9-12900HX + RTX 3080 Ti.",
        "",
    ]
    rows = []
    for m in _methods(records, "closed-set"):
        rs = [r for r in _acc(records, protocol="closed-set", method=m) if r["condition"] is None]
        if not rs:
            continue
        five = next((r for r in rs if r["way"] == 5 and r["shot"] == 5), None)
        paper_time = paper.TABLE_ONE_TIME.get(m)
        rows.append(
            [
                m,
                f"{rs[0]['pretrain_s']:.2f}",
                ms(None if five is None else five.get("latency_ms_per_episode")),
                ms(None if five is None else five.get("latency_with_features_ms_per_episode")),
                "-" if five is None else str(five.get("latency_episodes") or "-"),
                "-" if paper_time is None else paper_time[0],
                "-" if paper_time is None else f"{paper_time[1]:g}",
            ]
        )
    if rows:
        lines += markdown_table(
            [
                "method",
                "pretrain (s)",
                "latency (ms), features precomputed",
                "latency (ms), incl. feature extraction",
                "episodes timed",
                "paper pretrain",
                "paper Adapt/episode (ms)",
            ],
            rows,
        )
    else:
        lines.append("Closed-set not run.")
    lines += [
        "",
        "### Batched throughput (not comparable with the paper's per-episode time)",
        "",
        "All of a record's episodes adapted in ONE call as stacked tensor problems, "
        "features precomputed; the call's wall time divided by the number of episodes "
        "(ms). Pretrain in s, mean over folds.",
        "",
    ]
    rows = []
    for protocol in ("closed-set", *GENERALISATION):
        for m in _methods(records, protocol):
            rs = [r for r in _acc(records, protocol=protocol, method=m) if r["fold"] is None]
            rs = rs or _acc(records, protocol=protocol, method=m)
            if protocol == "closed-set":
                rs = [r for r in rs if r["condition"] is None] or rs
            pick = next((r for r in rs if r["way"] == 5 and r["shot"] == 5), None)
            pick = pick or next((r for r in rs if r["way"] == 5), rs[0])
            rows.append(
                [
                    protocol,
                    m,
                    f"{np.mean([r['pretrain_s'] for r in rs]):.2f}",
                    f"{pick['adapt_ms_per_episode']:.2f}",
                    f"{pick['way']}-way-{pick['shot']}-shot, {pick['episodes']} episodes",
                ]
            )
    lines += markdown_table(
        ["protocol", "method", "pretrain (s)", "batched ms/episode", "task, batch size"], rows
    )
    lines += ["", TIMING_END, ""]
    return lines


def beyond_section(records: Sequence[dict], meta: Mapping[str, Any]) -> list[str]:
    """The methods beyond the paper, one line each on what differs from the paper; every
    table lists them after the paper's methods, under a "Beyond the paper" row."""
    names = list(meta.get("methods") or ()) or [r["method"] for r in _acc(records)]
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
