"""report.md and figures from results.json-shaped records (no model fitting here; the
end-to-end path is in tests/test_run*.py)."""

from __future__ import annotations

import numpy as np
import pytest

from benchmark import figures, paper_reference
from benchmark.report import (
    TIMING_END,
    TIMING_START,
    interpretability_section,
    render,
    strip_timing,
    write_report,
)
from benchmark.splits import condition_name
from tests.synthetic_data import make_dataset

ACCURACY_FIELDS = (
    "record protocol fold condition method way shot query episodes accuracy ci95 "
    "pretrain_s adapt_ms_per_episode latency_ms_per_episode "
    "latency_with_features_ms_per_episode latency_episodes feature_dim"
).split()


def _acc(protocol, fold, condition, method, way, shot, acc, episodes=50, t=1.0):
    return {
        "record": "accuracy",
        "protocol": protocol,
        "fold": fold,
        "condition": condition,
        "method": method,
        "way": way,
        "shot": shot,
        "query": 5,
        "episodes": episodes,
        "accuracy": acc,
        "ci95": 0.02,
        "pretrain_s": t,
        "adapt_ms_per_episode": 3.0 * t,
        "latency_ms_per_episode": 40.0 * t if (way, shot) == (5, 5) else None,
        "latency_with_features_ms_per_episode": 55.0 * t if (way, shot) == (5, 5) else None,
        "latency_episodes": 10 if (way, shot) == (5, 5) else 0,
        "feature_dim": 8 if method == "AFOP-ML" else None,
    }


def fake_records(t: float = 1.0) -> list[dict]:
    """A complete, plausible record set (accuracy falls with N; AFOP-ML best)."""
    rs = []
    methods = {"AFOP-ML": 0.0, "AFO-MLP-ML": 0.04}
    for m, pen in methods.items():
        for k, n in paper_reference.TABLE_ONE_COLUMNS:
            rs.append(_acc("closed-set", None, None, m, n, k, 0.98 - 0.004 * n - pen, t=t))
        for protocol, base in (("cross-shape", 0.95), ("cross-material", 0.9)):
            folds = (0, 1, 2) if protocol == "cross-shape" else ("resin", "wood", "aluminum")
            for f in (*folds, None):
                for n in range(2, 13):
                    eps = 150 if f is None else 50
                    rs.append(_acc(protocol, f, None, m, n, 1, base - 0.01 * n - pen, eps, t))
        grid = [(f, s) for f in (0.6, 1.0, 1.4) for s in (6, 10, 14) if (f, s) != (1.0, 10)]
        conds = [condition_name(f, s) for f, s in grid] + ["pooled", "within-condition"]
        conds += ["enrolled"] + [f"enrolled:{condition_name(f, s)}" for f, s in grid]
        for i, c in enumerate(conds):
            for n in range(2, 13):
                rs.append(
                    _acc("perturbation", None, c, m, n, 1, 0.9 - 0.01 * n - pen - 0.02 * i, t=t)
                )
    for n in range(2, 13):
        rs.append(_acc("closed-set", None, "reference", "AFOP-ML", n, 1, 0.99 - 0.004 * n, t=t))
    for protocol, folds, d, pv in (
        ("cross-shape", (0, 1, 2), 6, 0.2),
        ("cross-material", ("resin", "wood", "aluminum"), 12, 0.5),
        ("closed-set", (None,), 8, 0.3),
        ("perturbation", (None,), 9, 0.4),
    ):
        for f in folds:
            rs.append(
                {
                    "record": "selection",
                    "protocol": protocol,
                    "fold": f,
                    "D": d,
                    "pvdf_share": pv,
                    "sg_share": 1 - pv,
                }
            )
    rs.append(
        {
            "record": "tsne",
            "protocol": "closed-set",
            "D": 8,
            "nn1_shape_accuracy": 0.97,
            "mix_sil": 0.8,
            "dgi": 2.1,
            "dgi_k": 10,
            "dgi_random": 2.07,
            "embedding_nn1_shape_accuracy": 0.95,
            "embedding_mix_sil": 0.7,
            "embedding_dgi": 1.9,
        }
    )
    return rs


META = {
    "seed": 7,
    "methods": ["AFOP-ML", "AFO-MLP-ML"],
    "episodes": "50 everywhere",
    "figures": {"generalisation": "generalisation.png"},
    "figure_notes": {},
}


def test_report_has_every_section_and_side_by_side_table(tmp_path):
    path = write_report(fake_records(), tmp_path, META)
    text = path.read_text()
    for heading in (
        "## Closed-set accuracy (Table I)",
        "### AFOP-ML here vs the paper's Table I",
        "### Cross-shape",
        "### Cross-material",
        "### Force/speed perturbation",
        "## Perturbation heat map",
        "## Interpretability",
        "## Figures",
        "**mix-sil**",
        "**DGI**",
        "**1-NN shape accuracy**",
    ):
        assert heading in text, heading
    # 1-shot 5-way: ours 0.98 - 0.02 = 96.00 %, paper 96.08 % -> -0.08 pp.
    assert "| 1-shot 5-way | 96.00 ± 2.00 | 96.08 | -0.08 |" in text
    # Cross-shape drop at 5-way: reference 97.0 - 90.0 = 7.0 pp; gap at 12-way +4.0 pp.
    assert "drop below the closed-set curve: 7.0 pp (paper: 2.4 pp)" in text
    assert "AFOP-ML minus AFO-MLP-ML at 12-way-1-shot: +4.0 pp (paper: +7.2 pp)" in text
    assert "Seed 7" in text and "seed: 7" in text
    assert paper_reference.CITATION in text
    # Perturbation: the three readings side by side, each with its drop below the closed-set
    # curve at 5-way (within-condition, index 9: 97.0 - 67.0; pooled, index 8: 97.0 - 69.0;
    # enrolled, index 10: 97.0 - 65.0) and its 12-way gap, beside the paper's one figure.
    perturbation = text[text.index("### Force/speed perturbation") :]
    for row in (
        "| within-condition | 30.0 | +4.0 |",
        "| pooled | 28.0 | +4.0 |",
        "| enrolled | 32.0 | +4.0 |",
        "| paper (one figure; its wording allows each reading) | 7.7 | +10.1 |",
    ):
        assert row in perturbation, row
    tables = [perturbation.index(f"#### {c}:") for c in ("within-condition", "pooled", "enrolled")]
    assert tables == sorted(tables)
    # The indicators of the top-D space beside those of the 2-D embedding, labelled.
    assert "| indicator | top-8 space here | 2-D t-SNE embedding here | paper (D=8) |" in text
    assert "| 1-NN shape accuracy | 0.970 | 0.950 | 0.982 |" in text
    assert "| DGI (cross- / same-material same-shape neighbours, k = 10) | 2.100 | 1.900 |" in text
    assert "would give a DGI of 2.070" in text
    heat = text[text.index("## Perturbation heat maps") :]
    assert "### within one condition" in heat and "### enrolled at nominal" in heat


def test_report_numbers_ignore_timing_only(tmp_path):
    a = render(fake_records(t=1.0), META)
    b = render(fake_records(t=2.5), META)
    assert a != b  # timings are reported ...
    assert strip_timing(a) == strip_timing(b)  # ... but only inside the timing section
    assert a.count(TIMING_START) == 1 and a.count(TIMING_END) == 1
    c = render(
        [
            dict(r, accuracy=r.get("accuracy", 0) * 0.5) if r["record"] == "accuracy" else r
            for r in fake_records()
        ],
        META,
    )
    assert strip_timing(c) != strip_timing(a)


@pytest.mark.slow
def test_figures_are_written(tmp_path):
    rs = fake_records()
    out = [
        figures.generalisation_curves(rs, tmp_path / "gen.png"),
        figures.perturbation_heatmap(rs, tmp_path / "heat.png", methods=["AFOP-ML", "AFO-MLP-ML"]),
        figures.perturbation_heatmap(
            rs, tmp_path / "heat_enrolled.png", methods=["AFOP-ML"], reading="enrolled"
        ),
        figures.selection_bars(rs, tmp_path / "sel.png"),
        figures.dscan_curve(
            {
                "D": np.arange(1, 41),
                "mean": 0.5 + 0.4 * np.tanh(np.arange(40) / 6),
                "ci95": np.full(40, 0.02),
            },
            8,
            tmp_path / "dscan.png",
        ),
    ]
    rng = np.random.default_rng(0)
    data = make_dataset(trials_per_class=1, n_samples=500)
    out.append(
        figures.tsne_scatter(
            rng.normal(size=(len(data), 2)),
            data.shape,
            data.material,
            {"nn1_shape_accuracy": 0.9, "mix_sil": 0.8, "dgi": 2.0},
            tmp_path / "tsne.png",
            d=8,
        )
    )
    out.append(figures.example_signals(data, tmp_path / "signals.png"))
    for p in out:
        assert p.is_file() and p.stat().st_size > 10_000
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_heatmap_needs_condition_records(tmp_path):
    with pytest.raises(ValueError, match="no per-condition"):
        figures.perturbation_heatmap([], tmp_path / "x.png")


def test_timing_section_keeps_latency_and_batched_throughput_apart():
    text = render(fake_records(), META)
    timing = text[text.index(TIMING_START) : text.index(TIMING_END)]
    single = timing[timing.index("### Single-episode") : timing.index("### Batched")]
    batched = timing[timing.index("### Batched") :]
    # Latency (40 / 55 ms) sits next to the paper's per-episode time; the batched
    # throughput (3 ms) appears only in its own table.
    assert "| AFOP-ML | 1.00 | 40.00 | 55.00 | 10 | ~2 s | 391.04 |" in single
    assert "3.00" not in single
    assert "| closed-set | AFOP-ML | 1.00 | 3.00 | 5-way-5-shot, 50 episodes |" in batched
    from benchmark.tables import table_one

    table = table_one(fake_records())
    assert "latency/episode 5w5s (ms)" in table and "| 1.00 | 40.00 | 55.00 | 50 |" in table


def test_heatmap_and_report_show_every_method(tmp_path, monkeypatch):
    base = [r for r in fake_records() if r.get("method") == "AFOP-ML"]
    names = ["AFOP-ML", *[f"method-{i}" for i in range(5)]]
    rs = [dict(r, method=m) for m in names for r in base]
    drawn: list[str] = []

    def save(fig, path):
        drawn.extend(ax.get_title() for ax in fig.axes if ax.get_visible() and ax.get_title())
        return figures.plt.close(fig)

    monkeypatch.setattr(figures, "save_figure", save)
    figures.perturbation_heatmap(rs, tmp_path / "heat.png", methods=names)
    assert [t.split(":")[0] for t in drawn] == names
    text = render(rs, META)
    for m in names:
        assert f"**{m}** (50 episodes per cell)" in text


def test_run_draws_the_heatmap_of_every_method_that_ran(tmp_path, monkeypatch):
    from benchmark.interpret import Artefacts

    names = ["AFOP-ML", *[f"method-{i}" for i in range(5)]]
    rs = [dict(r, method=m) for m in names for r in fake_records() if r.get("method") == "AFOP-ML"]
    asked: list[list[str]] = []
    for name in ("generalisation_curves", "selection_bars", "tsne_scatter", "example_signals"):
        monkeypatch.setattr(figures, name, lambda *a, **k: None)
    monkeypatch.setattr(
        figures,
        "perturbation_heatmap",
        lambda records, path, methods, reading=None: asked.append((reading, methods)),
    )
    art = Artefacts(None, 8, np.zeros((2, 2)), np.zeros(2), np.zeros(2), {}, 10)
    made = figures.draw_figures(rs, make_dataset(trials_per_class=1, n_samples=50), art, tmp_path)
    # One map per reading with per-condition records (within one condition, enrolled).
    assert {"perturbation_heatmap", "perturbation_heatmap_enrolled"} <= set(made)
    assert asked == [(None, names), ("enrolled", names)]


def test_interpretability_names_the_head_of_each_ranking():
    from models.features import FEATURE_NAMES

    rs = fake_records()
    sel = [r for r in rs if r.get("record") == "selection"]
    sel[0]["selected"] = [5, 300, 7, 42, 1, 2]  # cross-shape fold 0, best ranked first
    text = "\n".join(interpretability_section(rs))
    first = ", ".join(f"`{FEATURE_NAMES[i]}`" for i in (5, 300, 7, 42))
    assert f"| Shape | 0 | {first} |" in text
    # Only fits whose records hold their selected features get a row.
    assert text.count("| Shape |") == 2  # the shares row and fold 0's head
    for r in sel:
        r.pop("selected", None)
    assert "NCA ranking" not in "\n".join(interpretability_section(rs))
    sel[0]["selected"] = [5, 386]
    with pytest.raises(ValueError, match=r"cross-shape, fold 0.*index 386"):
        interpretability_section(rs)
