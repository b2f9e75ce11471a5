"""The report's accuracy sections: the closed-set table, the generalisation protocols'
curves and drops, the perturbation readings and grid, and the protocols beyond the
paper's four, all read from results.json records."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from models.registry import paper_first

from . import paper_reference as paper
from .labels import ENROLLED, READINGS, condition_reading
from .results import select
from .tables import (
    BEYOND_THE_PAPER,
    episodes_note,
    markdown_table,
    method_rows,
    pct,
    table_one_lines,
)

GENERALISATION = ("cross-shape", "cross-material", "perturbation")


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
            r["fold"]
            for r in accuracy_records(records, protocol="cross-material")
            if r["fold"] is not None
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


def accuracy_records(records: Sequence[dict], **match: Any) -> list[dict]:
    """The accuracy records of ``records`` that match every ``field=value`` of ``match``."""
    return select(records, "accuracy", **match)


def _one(records: Sequence[dict], **match: Any) -> dict | None:
    rs = accuracy_records(records, **match)
    return rs[0] if rs else None


def protocol_methods(records: Sequence[dict], protocol: str) -> list[str]:
    """The methods of ``protocol``'s records: the paper's in Table I's order, then the
    others."""
    paper_methods, beyond = paper_first(
        [r["method"] for r in accuracy_records(records, protocol=protocol)]
    )
    return [*paper_methods, *beyond]


def closed_set_section(records: Sequence[dict]) -> list[str]:
    """Table-I-like closed-set accuracy table (accuracy only; times are in the timing
    section) and AFOP-ML side by side with the paper's Table I."""
    rs = accuracy_records(records, protocol="closed-set", condition=None)
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

    paper_methods, beyond = paper_first(protocol_methods(rs, "closed-set"))
    rows = [row for m in paper_methods for row in rows_of(m)]
    if beyond:
        rows.append([f"**{BEYOND_THE_PAPER}**", *[""] * (len(header) - 1)])
        rows += [row for m in beyond for row in rows_of(m)]
    lines += markdown_table(header, rows)
    return [*lines, ""]


def _curve_table(records: Sequence[dict], protocol: str, condition: str | None) -> list[str]:
    rs = [
        r
        for r in accuracy_records(records, protocol=protocol, condition=condition)
        if r["fold"] is None
    ]
    ways = sorted({r["way"] for r in rs})
    header = ["method", *[f"{w}-way" for w in ways], "episodes/way"]

    def row(m: str) -> list[str]:
        cells = [pct(_one(rs, method=m, way=w)) for w in ways]
        return [m, *cells, episodes_note([r for r in rs if r["method"] == m])]

    rows = method_rows(protocol_methods(rs, protocol), row, len(header))
    ref = [r for r in accuracy_records(records, protocol="closed-set", condition="reference")]
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
        if not accuracy_records(records, protocol=protocol):
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
                for r in accuracy_records(records, protocol=protocol, method="AFOP-ML")
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
        (c, text)
        for c, text in READINGS
        if accuracy_records(records, protocol="perturbation", condition=c)
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
        for r in accuracy_records(records, protocol="perturbation", way=5)
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
        for m in protocol_methods(mine, "perturbation"):
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
    others = dict.fromkeys(
        r["protocol"] for r in accuracy_records(records) if r["protocol"] not in known
    )
    lines: list[str] = []
    for protocol in others:
        rs = accuracy_records(records, protocol=protocol)
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
