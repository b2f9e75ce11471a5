"""The diagnosis as text: the CLI's summary table and ``diagnose.md``."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

from . import steady
from .result import (
    CURVES_NAME,
    GROUP_NAMES,
    GROUPS,
    JSON_NAME,
    TARGETS,
    WELCH_SEGMENT_SAMPLES,
    Diagnosis,
)

#: Channel groups: key, human-readable name, sensor kept (None: all features).


def fmt(value: float | None, digits: int = 3) -> str:
    return "n/a" if value is None else f"{value:.{digits}f}"


def _group_label(diag: Diagnosis, group: str) -> str:
    name = dict((g, n) for g, n, _ in GROUPS)[group]
    return f"{name} ({diag.n_features[group]})"


def _targets(diag: Diagnosis) -> tuple[str, ...]:
    """The targets shown in tables: condition only when the dataset has several."""
    return tuple(t for t in TARGETS if t != "condition" or len(diag.conditions) > 1)


def _count(k: int, noun: str, plural: str | None = None) -> str:
    return f"{k} {noun if k == 1 else plural or noun + 's'}"


def describe(diag: Diagnosis) -> str:
    """One line: trials, grid, trials per class, completeness."""
    lo, hi = diag.trials_per_class
    per_class = f"{lo}" if lo == hi else f"{lo}-{hi}"
    conds = _count(len(diag.conditions), "condition")
    if len(diag.conditions) == 1:
        conds += f" ({diag.conditions[0]})"
    text = (
        f"{diag.n_trials} trials, {_count(len(diag.shapes), 'shape')} x "
        f"{_count(len(diag.materials), 'material')} x {conds}, {per_class} trials per class"
    )
    return text + ("" if diag.complete else " (incomplete store: its finished trials only)")


def _worst(values: dict[str, float | None], k: int = 3) -> str:
    ranked = sorted((v, name) for name, v in values.items() if v is not None)
    return ", ".join(f"{name} {v:.2f}" for v, name in ranked[:k]) or "n/a"


def _by_group(values: dict[str, float | None]) -> str:
    return " / ".join(fmt(values[g], 2) for g in GROUP_NAMES)


def summary_table(diag: Diagnosis) -> str:
    """The compact text the CLI prints: the accuracy table, the worst shapes, the
    materials, the per-condition class accuracy, the most confused pairs and the notes."""
    targets = _targets(diag)
    width = max(len(_group_label(diag, g)) for g in GROUP_NAMES) + 2
    lines = [
        f"{diag.source}: {describe(diag)}",
        f"{'leave-one-out 1-NN accuracy':<{width}}" + "".join(f"{t:>10}" for t in targets),
    ]
    for g in GROUP_NAMES:
        cells = [fmt(None if diag.accuracy[t] is None else diag.accuracy[t][g]) for t in targets]
        lines.append(f"{_group_label(diag, g):<{width}}" + "".join(f"{c:>10}" for c in cells))
    chance = [fmt(diag.chance[t]) for t in targets]
    lines.append(f"{'chance':<{width}}" + "".join(f"{c:>10}" for c in chance))
    if diag.per_shape is not None:
        lines.append(f"worst shapes, all features: {_worst(diag.per_shape['all'])}")
        lines.append(f"worst shapes, SG only:      {_worst(diag.per_shape['sg'])}")
    if diag.per_material is not None:
        per = {g: diag.per_material[g] for g in GROUP_NAMES}
        lines.append(
            "materials (all / SG / PVDF): "
            + ", ".join(
                f"{m} {_by_group({g: per[g][m] for g in GROUP_NAMES})}" for m in diag.materials
            )
        )
    if diag.per_condition is not None:
        lines.append("class accuracy within each condition (all / SG / PVDF):")
        lines += [f"  {c}: {_by_group(v)}" for c, v in diag.per_condition.items()]
    pairs = diag.confused_pairs["all"][:3]
    if pairs:
        lines.append(
            "most confused, all features: "
            + ", ".join(f"{p.a} ~ {p.b} {p.share:.2f}" for p in pairs)
        )
    lines += steady.summary_lines(diag.steady, diag.accuracy.get("material"))
    lines += [f"note: {t}: {text}" for t, text in diag.notes.items() if t in targets]
    return "\n".join(lines)


def _md_table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return out


def markdown(diag: Diagnosis, figures: dict[str, str] | None = None) -> str:
    """``diagnose.md``: every table of the diagnosis, with the figures linked by name."""
    figures = figures or {}
    targets = _targets(diag)
    md = [
        "# Dataset diagnosis",
        "",
        f"`{diag.source}`: {describe(diag)}.",
        "",
        "Leave-one-out 1-nearest-neighbour accuracy on the z-scored 386-feature pool: each",
        "trial gets the label of its nearest other trial (Euclidean distance over the channel",
        "group's features) and the accuracy is the share labelled right. High = the labels",
        "differ in that channel group in a way a plain distance sees. Chance is the accuracy",
        "of a random other trial's label.",
        "",
        "## Accuracy per channel group",
        "",
    ]
    rows = [
        [dict((g, n) for g, n, _ in GROUPS)[g], str(diag.n_features[g])]
        + [fmt(None if diag.accuracy[t] is None else diag.accuracy[t][g]) for t in targets]
        for g in GROUP_NAMES
    ]
    rows.append(["chance", ""] + [fmt(diag.chance[t]) for t in targets])
    md += _md_table(["channel group", "features", *targets], rows)
    if diag.notes:
        md.append("")
        md += [f"- {t}: {text}" for t, text in diag.notes.items()]

    def per_value(title: str, target: str, table: dict | None, what: str) -> None:
        md.extend(["", f"## {title}", ""])
        if table is None:
            md.append(f"Not applicable: {diag.notes.get(target, 'a single value')}.")
            return
        md.append(f"{what} (n/a: a single trial).")
        md.append("")
        keys = list(table["all"])
        md.extend(
            _md_table(
                [target, "all", "SG", "PVDF"],
                [[k] + [fmt(table[g][k]) for g in GROUP_NAMES] for k in keys],
            )
        )

    per_value(
        "Per shape",
        "shape",
        diag.per_shape,
        "Shape accuracy of each shape's trials: the share whose nearest neighbour has their shape",
    )
    per_value(
        "Per material",
        "material",
        diag.per_material,
        "Material accuracy of each material's trials: the share whose nearest neighbour has "
        "their material",
    )
    md += ["", "## Per class (all features)", ""]
    md.append("Class accuracy of each class's trials (rows: shapes; columns: materials).")
    md.append("")
    md += _md_table(
        ["shape", *diag.materials],
        [
            [s] + [fmt(diag.per_class["all"].get(f"{s}/{m}")) for m in diag.materials]
            for s in diag.shapes
        ],
    )
    if diag.per_condition is not None:
        md += ["", "## Per condition", ""]
        md.append("Class accuracy with neighbours taken from the same condition only.")
        md.append("")
        md += _md_table(
            ["condition", "all", "SG", "PVDF"],
            [[c] + [fmt(v[g]) for g in GROUP_NAMES] for c, v in diag.per_condition.items()],
        )
    md += ["", "## Most confused class pairs", ""]
    md.append(
        "a→b: trials of a whose nearest neighbour is of class b; share: (a→b + b→a) / "
        "trials of both."
    )
    for g in GROUP_NAMES:
        md += ["", f"{_group_label(diag, g)}:", ""]
        pairs = diag.confused_pairs[g]
        if not pairs:
            md.append("no trial's nearest neighbour is of another class.")
            continue
        md += _md_table(
            ["a", "b", "differ by", "a→b", "b→a", "share"],
            [
                [p.a, p.b, p.differ_by, str(p.a_to_b), str(p.b_to_a), f"{p.share:.3f}"]
                for p in pairs
            ],
        )
    md += ["", "## PVDF spectra per material", ""]
    md.append(
        f"Mean Welch power spectral density ({WELCH_SEGMENT_SAMPLES}-sample segments) of the "
        "PVDF channels; rms over 0 Hz < f, PSD-weighted mean (centroid) and peak frequency."
    )
    md.append("")
    rows = []
    for cond, mats in diag.spectra.summary().items():
        for mat, chans in mats.items():
            for ch, v in chans.items():
                rms = "n/a" if v["rms_v"] is None else f"{1e3 * v['rms_v']:.2f}"
                rows.append([cond, mat, ch, rms, fmt(v["centroid_hz"], 1), fmt(v["peak_hz"], 1)])
    md += _md_table(
        ["condition", "material", "channel", "rms (mV)", "centroid (Hz)", "peak (Hz)"], rows
    )
    if "pvdf_spectra" in figures:
        md += ["", f"![PVDF spectra per material]({figures['pvdf_spectra']})"]
    md += ["", "## Strain-gauge mean traces per shape", ""]
    if len(diag.conditions) == 1:
        md.append("Mean ± one standard deviation over each shape's trials (all materials).")
    else:
        md.append(
            "Mean over each shape's trials (all materials), one colour per condition; "
            "sg1 solid, sg2 dashed."
        )
    if "sg_traces" in figures:
        md += ["", f"![SG mean traces per shape]({figures['sg_traces']})"]
    extra = [
        (k, t)
        for k, t in (
            ("accuracy", "Per-shape and per-material accuracy"),
            ("confusion", "Nearest-neighbour class confusion"),
        )
        if k in figures
    ]
    if extra:
        md += ["", "## Figures", ""]
        for k, t in extra:
            md += [f"![{t}]({figures[k]})", ""]
        md.pop()
    md += steady.markdown_lines(diag.steady, diag.accuracy.get("material"))
    md += [
        "",
        f"Numbers: `{JSON_NAME}`; curves: `{CURVES_NAME}` (numpy, no pickle). What each "
        "number means: docs/diagnose.md in the tactile-synth repository.",
    ]
    return "\n".join(md) + "\n"


def friction_lines(path: str | Path) -> list[str]:
    """The skin's friction law on each material of the simulated dataset at ``path``, as
    its stored configuration holds it: the kinetic coefficient at 10 mm/s and 1 N, its
    change from 6 to 14 mm/s and the law's velocity exponent (``docs/friction.md``); then
    how the skin answers the texture (``Finger.skin_texture_response``, with the complex
    modulus over the relaxed one at the films' band edges when viscoelastic). Empty for
    imported recordings, which carry no simulated friction."""
    import synth
    from synth.contact import friction_coefficient
    from synth.store import KIND_IMPORTED, config_of, read_meta, store_kind
    from synth.tribology import EXPONENT_SPEEDS_M_S, REFERENCE_SPEED_M_S

    meta = read_meta(Path(path))
    if store_kind(meta) == KIND_IMPORTED:
        return []
    config = config_of(Path(path), meta)
    try:
        sim = (
            synth.SynthConfig.from_dict(dict(config.synth)) if config.synth else synth.SynthConfig()
        )
    except (TypeError, ValueError):
        return []  # signals written without the simulator (a built test store): no laws
    materials = [m for m in config.materials if m in sim.materials]
    if not materials:
        return []
    width = max(10, *(len(m) for m in materials)) + 2
    lines = [
        "skin friction per material (the dataset's laws; docs/friction.md):",
        f"  {'material':<{width}}{'mu 10 mm/s, 1 N':>16}{'14 / 6 mm/s':>13}{'v exponent':>12}",
    ]
    for name in materials:
        law = sim.materials[name].friction
        speeds = (REFERENCE_SPEED_M_S, *EXPONENT_SPEEDS_M_S)
        mu = [float(friction_coefficient(law, v, 1.0)) for v in speeds]
        lines.append(
            f"  {name:<{width}}{mu[0]:>16.3f}{mu[2] / mu[1]:>12.3f}x{law.velocity_exponent:>12.4f}"
        )
    response = sim.finger.skin_texture_response
    if response == "viscoelastic":
        from synth.viscoelastic import SILICONE_PRONY, Viscoelastic

        skin = Viscoelastic(1.0, SILICONE_PRONY)
        ends = [abs(complex(skin.complex_modulus_pa(2 * math.pi * f))) for f in (20.0, 400.0)]
        lines.append(
            f"  skin's answer to the texture: viscoelastic (|E*| / E_inf {ends[0]:.2f} at "
            f"20 Hz, {ends[1]:.2f} at 400 Hz)"
        )
    else:
        lines.append("  skin's answer to the texture: elastic (its relaxed modulus)")
    return lines
