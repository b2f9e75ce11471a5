"""The report's interpretability section (the paper's Fig. 6 and Fig. 7): AFOP-ML's
chosen D and sensor shares, the head of each fit's NCA ranking, and the t-SNE
indicators beside the paper's values."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from . import paper_reference as paper
from .results import select
from .tables import markdown_table

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
